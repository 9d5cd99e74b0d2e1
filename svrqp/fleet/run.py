"""Running a fleet's records: one diagnosis per record, serially or on Dask, streamed.

:func:`run_record` is what runs on a worker: it reads one record, diagnoses it through
:func:`svrqp.fleet.record.diagnose_table` (the code path of ``svrqp gap``), writes
``records/NAME.json`` exactly as ``svrqp gap --json`` would, then the stamp
``records/NAME.fleet.json`` (the input's SHA-256, the settings, the runtime, and ``pool``: every
candidate's transfer-test p-value for the pooled evidence, :mod:`svrqp.gap.transfer.pooling`,
which the gap JSON does not carry). A record whose JSON and stamp are both there with the same
checksum and settings is not diagnosed again (``resume``). Any error of one record is caught
and becomes its row's reason; the others go on.
Every file is written to a temporary name and renamed (:mod:`svrqp.output`): a stopped run
leaves whole files or none.

:func:`results` runs the records and yields each one's outcome as it completes. The parent never
reads a record: it sends the record's path and options, and at most ``2 × workers`` records are
in flight, so its memory does not grow with the fleet.
"""

from __future__ import annotations

import hashlib
import json
import time
from collections.abc import Iterable, Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from svrqp.fleet.manifest import Record
from svrqp.fleet.record import GapOptions, diagnose_table
from svrqp.fleet.table import failed_row, row_of, tests_of

RECORDS = "records"
STAMP_SUFFIX = ".fleet.json"
#: Dask settings of the local cluster's workers, which differ from Dask's defaults because a
#: record is many small numpy allocations and a second of pure computation: Dask's nannies start
#: workers with ``MALLOC_TRIM_THRESHOLD_=65536``, which in glibc also fixes the mmap threshold at
#: 128 KiB, so every larger array is a fresh mmap (ten times the page faults of a plain process,
#: and 10-30 % more time per record); and Dask's statistical profiler samples the running thread
#: every 10 ms. With both, a record took about 1.5 times its serial time on a worker; the
#: nannies' thread caps (one BLAS/OpenMP thread per worker) are kept. The worker's event loop also
#: wakes every 20 ms to time itself, every 100 ms to read its memory and every 500 ms to read the
#: machine's CPU and disk counters; each wake takes the GIL from the record's thread. Woken every
#: 1 s to 5 s instead, a record took 1.01-1.16 s on a worker where it took 1.22-1.24 s with those
#: defaults and 1.06-1.15 s in a plain forked process (30 records, two workers, 2 cores).
LOCAL_CLUSTER_CONFIG = {"distributed.nanny.pre-spawn-environ.MALLOC_TRIM_THRESHOLD_": None,
                        "distributed.worker.profile.enabled": False,
                        "distributed.admin.tick.interval": "1s",
                        "distributed.worker.memory.monitor-interval": "1s",
                        "distributed.admin.system-monitor.interval": "5s",
                        "distributed.admin.system-monitor.disk": False}


@dataclass(frozen=True)
class Outcome:
    """What one record gave: its fleet-table row and its per-candidate transfer tests."""

    row: dict[str, Any]
    tests: list[dict[str, Any]]


def sha256_of(path: Path) -> str:
    """The SHA-256 of a file's bytes, read in 1 MiB blocks."""
    digest = hashlib.sha256()
    with path.open("rb") as handle:
        for block in iter(lambda: handle.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


def _stamp(options: GapOptions, sha256: str) -> dict[str, Any]:
    return {"sha256": sha256, "settings": options.key()}


def _resumed(json_path: Path, stamp_path: Path, stamp: dict[str, Any]) -> dict | None:
    """The earlier stamp when the record's outputs match ``stamp`` (else None)."""
    if not (json_path.is_file() and stamp_path.is_file()):
        return None
    try:
        earlier = json.loads(stamp_path.read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None
    same = all(earlier.get(key) == value for key, value in stamp.items())
    return earlier if same and isinstance(earlier.get("pool"), dict) else None


def run_record(record: Record, options: GapOptions, out: Path, resume: bool = True) -> Outcome:
    """Diagnose one record into ``out/records`` (or take its earlier output); never raises."""
    from svrqp import output
    from svrqp.tables import read_table

    start = time.perf_counter()
    folder = out / RECORDS
    json_path, stamp_path = folder / f"{record.name}.json", folder / f"{record.name}{STAMP_SUFFIX}"
    try:
        sha256 = sha256_of(record.path)
        stamp = _stamp(options, sha256)
        earlier = _resumed(json_path, stamp_path, stamp) if resume else None
        if earlier is not None:
            document = json.loads(json_path.read_text(encoding="utf-8"))
            return Outcome(row_of(record.name, record.path, document, status="resumed",
                                  runtime_s=earlier["runtime_s"], sha256=sha256),
                           tests_of(record.name, document, earlier["pool"]))
        report = diagnose_table(read_table(record.path), options, pool=True)
        stamp_path.unlink(missing_ok=True)  # no stamp ever vouches for a stale JSON
        report.write_json(json_path, force=True)  # the fleet's own folder: a rerun replaces it
        runtime_s = time.perf_counter() - start
        pool = report.pool_p or {}
        output.write_text(stamp_path, json.dumps(stamp | {"runtime_s": runtime_s, "pool": pool},
                                                 indent=2), force=True)
        document = report.to_dict()
        return Outcome(row_of(record.name, record.path, document, status="ok",
                              runtime_s=runtime_s, sha256=sha256),
                       tests_of(record.name, document, pool))
    except Exception as err:  # noqa: BLE001  (a record's failure is its row's reason)
        reason = f"{type(err).__name__}: {err}"
        return Outcome(failed_row(record.name, record.path, reason,
                                  time.perf_counter() - start), [])


@dataclass(frozen=True)
class Execution:
    """Where the records run: ``workers`` processes of a local Dask cluster (``workers=1``:
    serially in this process), or an existing cluster at ``scheduler``."""

    workers: int = 1
    scheduler: str | None = None

    @property
    def serial(self) -> bool:
        """True when the records run in this process, one after another."""
        return self.scheduler is None and self.workers <= 1


Job = tuple[Record, GapOptions]


def results(jobs: Iterable[Job], out: Path, execution: Execution,
            resume: bool = True) -> Iterator[Outcome]:
    """Each record's :class:`Outcome`, in the order they complete."""
    if execution.serial:
        for record, options in jobs:
            yield run_record(record, options, out, resume)
        return
    yield from _on_dask(jobs, out, execution, resume)


def _on_dask(jobs: Iterable[Job], out: Path, execution: Execution,
             resume: bool) -> Iterator[Outcome]:
    """Run on Dask with at most two records per worker in flight (the rest wait here)."""
    from svrqp.extras import require

    require("dask", "a fleet on Dask")
    from distributed import Client, LocalCluster, as_completed

    cluster = None
    if execution.scheduler is None:
        import dask

        with dask.config.set(LOCAL_CLUSTER_CONFIG):
            cluster = LocalCluster(n_workers=execution.workers, threads_per_worker=1,
                                   processes=True, dashboard_address=None)
    client = Client(cluster if cluster is not None else execution.scheduler)
    try:
        window = 2 * max(len(client.scheduler_info()["workers"]), 1)
        pending = iter(jobs)

        def submit(job: Job):
            return client.submit(run_record, *job, out, resume, pure=False,
                                 key=f"svrqp-fleet-{job[0].name}-{time.monotonic_ns()}")

        first = [submit(job) for _, job in zip(range(window), pending, strict=False)]
        flight = as_completed(first)
        for future in flight:
            outcome = future.result()
            future.release()
            following = next(pending, None)
            if following is not None:
                flight.add(submit(following))
            yield outcome
    finally:
        client.close()
        if cluster is not None:
            cluster.close()

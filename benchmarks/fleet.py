"""A fleet in one run (issue #36): ``svrqp fleet`` over simulated machines against their truth.

Four parts, each on fleets of :mod:`svrqp.machine.fleet` (written to a temporary folder):

1. **Main fleet** (``--n`` records: 30 % nut heating withheld, 20 % headstock heating, 10 % a
   faulty sensor, 40 % nothing; strength ``--snr``). It runs as ``svrqp fleet --workers 1``
   (serial, in a child process) and ``svrqp fleet --workers 2`` (a local Dask cluster): the wall
   time of each, and the child's peak memory (its maximum resident set) serially on a quarter of
   the records and on all of them. Then one ``svrqp gap`` call per record (the command itself,
   called in this process, ``svrqp.cli.main``), whose JSON must equal the fleet's byte for byte
   but for ``runtime_s``. Per-record top-1 (the verdict names the truth column) and false
   attribution (a verdict naming another column, or any column on a record with nothing
   withheld or a faulty sensor), per kind.
2. **Weak effect** (``--weak-n`` records, 30 % carrying the nut heating at ``--weak-snr``, too
   weak for a record alone): how often a single record names it, and what the pooled evidence
   names.
3. **Null fleets** (``--null-fleets`` fleets of ``--null-n`` records, nothing withheld, 10 % a
   faulty sensor): how many the pooled evidence names anything in.
4. The time model: ``T(n, w) = t0(w) + n * t_record / (w * e)``, from the measured runs.

Run: ``python benchmarks/fleet.py [--n 200] [--null-fleets 20] ...``; it writes
``benchmarks/results/fleet.md`` and ``fleet.json``.
"""

from __future__ import annotations

import argparse
import json
import os
import re
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import pandas as pd

from svrqp.fleet import Execution, pool, read_records, run_fleet
from svrqp.machine.fleet import FleetDesign, write_fleet

RESULTS = Path(__file__).resolve().parent / "results"
RUNTIME = re.compile(r'"runtime_s": [0-9.eE+-]+')
MEASURE = ("import resource, sys, time; from svrqp.cli import main; start = time.perf_counter()\n"
           "try:\n    main(sys.argv[1:])\nexcept SystemExit as stop:\n    code = stop.code\n"
           "print('MEASURED', time.perf_counter() - start, "
           "resource.getrusage(resource.RUSAGE_SELF).ru_maxrss, file=sys.stderr)")


def fleet_cli(manifest: Path, out: Path, workers: int) -> tuple[float, float]:
    """Run ``svrqp fleet`` in a child process: (wall seconds inside it, its peak RSS in MiB)."""
    env = os.environ | {"OPENBLAS_NUM_THREADS": "1"}
    argv = [sys.executable, "-c", MEASURE, "fleet", str(manifest), "--out", str(out),
            "--workers", str(workers)]
    done = subprocess.run(argv, capture_output=True, text=True, env=env, check=False)
    line = next(x for x in done.stderr.splitlines() if x.startswith("MEASURED"))
    _, wall, rss_kib = line.split()
    return float(wall), float(rss_kib) / 1024.0


def subset_manifest(manifest: Path, n: int) -> Path:
    """The first ``n`` rows of a manifest, beside it."""
    path = manifest.with_name(f"manifest_{n}.csv")
    pd.read_csv(manifest).head(n).to_csv(path, index=False)
    return path


def identical_to_gap(folder: Path, out: Path) -> tuple[int, int]:
    """(records whose fleet JSON equals a single ``svrqp gap`` call's, records compared)."""
    from svrqp.cli import main

    manifest = pd.read_csv(folder / "manifest.csv")
    same = 0
    for row in manifest.itertuples():
        single = out / "single" / f"{row.name}.json"
        argv = ["gap", str(folder / row.path), "--json", str(single), "--target", row.target,
                "--train", row.train, "--prediction", row.prediction, "--candidates",
                row.candidates, "--order", row.order, "--group", row.group]
        try:
            main(argv)
        except SystemExit:
            pass
        fleet_text = (out / "serial" / "records" / f"{row.name}.json").read_text()
        runtime = RUNTIME.search(fleet_text).group(0)
        same += RUNTIME.sub(runtime, single.read_text()) == fleet_text
    return same, len(manifest)


def attribution(table: pd.DataFrame, truth: pd.DataFrame) -> pd.DataFrame:
    """Per kind: records, top-1 (the truth named) and false attribution (another, or any on a
    record with nothing withheld)."""
    merged = table.merge(truth, on="name")
    merged["named"] = merged["verdict_column"].fillna("").astype(str)
    merged["truth"] = merged["truth"].fillna("").astype(str)
    merged["top1"] = (merged["truth"] != "") & (merged["named"] == merged["truth"])
    merged["false"] = (merged["named"] != "") & (merged["named"] != merged["truth"])
    return merged.groupby("kind").agg(records=("name", "size"), top1=("top1", "sum"),
                                      false=("false", "sum"))


def draw(folder: Path, design: FleetDesign) -> Path:
    start = time.perf_counter()
    manifest = write_fleet(folder, design)
    print(f"drew {design.n} machines into {folder} in {time.perf_counter() - start:.0f} s",
          flush=True)
    return manifest


def main_fleet(args, root: Path) -> dict:
    design = FleetDesign(n=args.n, seed=args.seed, snr={"nut": args.snr, "headstock": args.snr})
    manifest = draw(root / "main", design)
    quarter = subset_manifest(manifest, max(args.n // 4, 1))
    out = root / "main_out"
    small_wall, small_rss = fleet_cli(quarter, root / "quarter_out", 1)
    serial_wall, serial_rss = fleet_cli(manifest, out / "serial", 1)
    dask_wall, dask_rss = fleet_cli(manifest, out / "dask", 2)
    print(f"serial {serial_wall:.0f} s, 2 workers {dask_wall:.0f} s", flush=True)
    same, compared = identical_to_gap(root / "main", out)
    table = pd.read_csv(out / "serial" / "fleet.csv")
    truth = pd.read_csv(root / "main" / "truth.csv")
    dask_table = pd.read_csv(out / "dask" / "fleet.csv")
    records = {name: (out / "serial" / "records" / f"{name}.json").read_text()
               for name in table["name"]}
    dask_same = sum(_strip(records[n]) == _strip((out / "dask" / "records" / f"{n}.json")
                                                 .read_text()) for n in dask_table["name"])
    return {"n": args.n, "snr": args.snr, "serial_s": serial_wall, "dask2_s": dask_wall,
            "speedup": serial_wall / dask_wall, "rss_quarter_mib": small_rss,
            "rss_all_mib": serial_rss, "rss_dask_parent_mib": dask_rss,
            "quarter_s": small_wall, "n_quarter": max(args.n // 4, 1),
            "identical": same, "compared": compared, "dask_identical": int(dask_same),
            "record_s_mean": float(table["runtime_s"].mean()),
            "record_s_sum": float(table["runtime_s"].sum()),
            "dask_record_s_mean": float(dask_table["runtime_s"].mean()),
            "dask_record_s_sum": float(dask_table["runtime_s"].sum()),
            "record_s_max": float(table["runtime_s"].max()),
            "failed": int((table["status"] == "failed").sum()),
            "attribution": attribution(table, truth).reset_index().to_dict("records"),
            "pooled": pd.read_csv(out / "serial" / "pooled.csv").to_dict("records")}


def _strip(text: str) -> dict:
    document = json.loads(text)
    document.pop("runtime_s")
    return document


def run_in_process(manifest: Path, out: Path, workers: int):
    execution = Execution(workers=workers)
    return run_fleet(read_records(manifest), {}, out, execution=execution)


def weak_fleet(args, root: Path) -> dict:
    design = FleetDesign(n=args.weak_n, seed=args.seed + 1, snr={"nut": args.weak_snr},
                         shares={"nut": 0.3, "faulty": 0.1, "none": 0.6})
    manifest = draw(root / "weak", design)
    result = run_in_process(manifest, root / "weak_out", args.workers)
    truth = pd.read_csv(root / "weak" / "truth.csv")
    carriers = set(truth.loc[truth["kind"] == "nut", "name"])
    table = result.table.set_index("name")
    named_alone = int((table.loc[sorted(carriers), "verdict_column"] == "nut_C").sum())
    pooled_carriers = set(result.pooled.carriers.get("nut_C", []))
    return {"n": args.weak_n, "snr": args.weak_snr, "seed": args.seed + 1,
            "carriers": len(carriers),
            "named_alone": named_alone, "pooled_named": result.pooled.named,
            "pooled_summary": result.pooled.summary(),
            "fisher_named": pool(result.tests, "fisher").named,
            "pooled_carriers_true": len(pooled_carriers & carriers),
            "pooled_carriers_false": len(pooled_carriers - carriers),
            "pooled": result.pooled.table.to_dict("records")}


def null_fleets(args, root: Path) -> dict:
    named, fisher_named, records_naming = [], [], []
    for k in range(args.null_fleets):
        design = FleetDesign(n=args.null_n, seed=1000 + k, shares={"faulty": 0.1, "none": 0.9})
        manifest = draw(root / f"null{k}", design)
        result = run_in_process(manifest, root / f"null{k}_out", args.workers)
        named.append(result.pooled.named)
        fisher_named.append(pool(result.tests, "fisher").named)
        single = int((result.table["verdict_column"].fillna("") != "").sum())
        records_naming.append(single)
        print(f"null fleet {k}: pooled names {result.pooled.named}, {single} records name one",
              flush=True)
    return {"fleets": args.null_fleets, "n": args.null_n,
            "fleets_naming": sum(bool(x) for x in named), "named": named,
            "fisher_naming": sum(bool(x) for x in fisher_named),
            "records_naming": sum(records_naming)}


def _more_weak(runs: list[dict]) -> str:
    """One paragraph per further weak-effect run (``--parts weak --json-name …``, merged by
    ``--render --merge-weak FILE``)."""
    lines = [] if not runs else [
        "Further weak-effect fleets, each its own run (`python benchmarks/fleet.py --parts weak "
        "--weak-snr S --seed K --json-name fleet_weakNNN.json`; the fleet's seed is K + 1):"]
    for w in runs:
        lines.append(f"A further weak-effect fleet ({w['n']} records, {w['carriers']} carriers, "
                     f"strength {w['snr']}, seed {w.get('seed', '?')}): a single record names "
                     f"it on **{w['named_alone']} of {w['carriers']}** carriers. "
                     f"{w['pooled_summary']} Fisher's rule would name "
                     f"{w['fisher_named'] or 'nothing'}.")
    return "\n\n".join(lines) + ("\n" if lines else "")


def markdown(results: dict, args) -> str:
    m, w, z = results["main"], results["weak"], results["null"]
    rows = "\n".join(f"| {r['kind']} | {r['records']} | {r['top1']} | {r['false']} |"
                     for r in m["attribution"])
    pooled = "\n".join(f"| {r['column']} | {r['records']} | {r['tested']} | {r['carriers']} | "
                       f"{r['p_wilkinson']:.3g} | {r['p_fisher']:.3g} | {r['q_value']:.3g} | "
                       f"{r['named']} |" for r in w["pooled"])
    t_record = m["record_s_mean"]
    big = 10_000 * t_record / 64
    return f"""# Fleet benchmark (issue #36)

`python benchmarks/fleet.py {' '.join(results.get('argv', []))}` on {results['machine']}
(shared with other work while it ran: wall times carry that load). Sizes: main fleet
{m['n']} records, weak-effect fleet {w['n']}, {z['fleets']} null fleets of {z['n']} records.

## Main fleet ({m['n']} records, strength {m['snr']})

- Per-record answers identical to single `svrqp gap` calls (JSON text equal, `runtime_s` aside):
  **{m['identical']} of {m['compared']}**; the 2-worker Dask run's documents equal the serial
  run's: {m['dask_identical']} of {m['n']}. Failed records: {m['failed']}.
- Wall time (`svrqp fleet` in a child process, start-up included): serial {m['serial_s']:.1f} s,
  2 Dask workers {m['dask2_s']:.1f} s: **speed-up {m['speedup']:.2f}×**. Mean record
  {t_record:.2f} s (longest {m['record_s_max']:.2f} s).
- Reading the speed-up: a record took {t_record:.2f} s on average serially and
  {m['dask_record_s_mean']:.2f} s on a Dask worker, so the workers' records ran
  {m['dask_record_s_mean'] / t_record:.2f}× slower than the serial ones: they did not get two
  cores' time. The workers were busy with records {m['dask_record_s_sum'] / (2 * m['dask2_s']):.0%}
  of the wall time (Σ record time / (2 × wall)), the serial process
  {m['record_s_sum'] / m['serial_s']:.0%}: the rest is the start (imports, the cluster) and the
  writing of the fleet's files.
- Peak memory of the serial `svrqp fleet` process: {m['rss_quarter_mib']:.0f} MiB on
  {m['n_quarter']} records, {m['rss_all_mib']:.0f} MiB on {m['n']}; the parent of the 2-worker
  run: {m['rss_dask_parent_mib']:.0f} MiB.

| kind | records | top-1 | false attribution |
|---|---|---|---|
{rows}

## Weak effect ({w['n']} records, nut heating on {w['carriers']} of them at strength {w['snr']})

A single record names it on **{w['named_alone']} of {w['carriers']}** carriers.
{w['pooled_summary']} Carriers it lists: {w['pooled_carriers_true']} true,
{w['pooled_carriers_false']} not carrying the effect. Fisher's rule would name:
{w['fisher_named'] or 'nothing'}.

| candidate | records | tested | p <= 0.05 | p (Wilkinson) | p (Fisher) | q (BH) | named |
|---|---|---|---|---|---|---|---|
{pooled}

{_more_weak(results.get('weak_more', []))}
## Null fleets

The pooled evidence names a candidate in **{z['fleets_naming']} of {z['fleets']}** fleets where
nothing is withheld ({z['n']} records each, 10 % with a faulty `coolant_C`); with Fisher's rule
instead, in {z['fisher_naming']} of {z['fleets']}. Single records name a cause on
{z.get('records_naming', '?')} of the {z['fleets'] * z['n']} null records.

**The limit.** The pooled evidence counts the records' own transfer tests, and a record runs
no test of a column whose transfer gain stays below the effect floor (5 %,
`svrqp.gap.contract`): such a record enters with p = 1. Where the effect is so weak that nearly
no record clears the floor (strength 0.15 above: the nut's column tested on few records), there
is nothing to count and the fleet names nothing, rightly at its level but without power.

## Time model

`T(n, w) ≈ t0(w) + n · t_record / (w · e)`: `t0` the start (Python and svrqp's imports; for
Dask also the local cluster's processes), `t_record` = {t_record:.2f} s per record here (read,
checksum, diagnosis, write), `e` the parallel efficiency. Serially, `n · t_record` =
{m['n'] * t_record:.0f} s of the {m['serial_s']:.0f} s measured; at 2 workers the efficiency
over all was {m['speedup'] / 2:.2f}. 10,000 such records on a 64-core cluster at `e = 0.9`
would take about {big / 0.9 / 60:.0f} min, plus the cluster's start; the parent holds only the
fleet table's rows (one small dict per record) and at most two records per worker in flight.
"""


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--n", type=int, default=200)
    parser.add_argument("--snr", type=float, default=2.0)
    parser.add_argument("--weak-n", type=int, default=200)
    parser.add_argument("--weak-snr", type=float, default=0.2)
    parser.add_argument("--null-fleets", type=int, default=20)
    parser.add_argument("--null-n", type=int, default=30)
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--parts", default="main,weak,null")
    parser.add_argument("--json-name", default="fleet.json",
                        help="file of benchmarks/results/ the numbers go to")
    parser.add_argument("--merge-weak", nargs="*", default=[],
                        help="with --render: files of further weak-effect runs to add")
    parser.add_argument("--render", action="store_true",
                        help="only write fleet.md again from the recorded fleet.json")
    args = parser.parse_args()
    if args.render:
        results = json.loads((RESULTS / "fleet.json").read_text())
        for name in args.merge_weak:
            results.setdefault("weak_more", []).append(
                json.loads((RESULTS / name).read_text())["weak"])
        (RESULTS / "fleet.md").write_text(markdown(results, args), encoding="utf-8")
        return
    results: dict = {"machine": f"{os.cpu_count()} cores", "argv": sys.argv[1:]}
    with tempfile.TemporaryDirectory(prefix="svrqp-fleet-") as folder:
        root = Path(folder)
        for part, function in (("main", main_fleet), ("weak", weak_fleet),
                               ("null", null_fleets)):
            if part in args.parts.split(","):
                results[part] = function(args, root)
                print(json.dumps(results[part], default=str)[:400], flush=True)
    RESULTS.mkdir(exist_ok=True)
    (RESULTS / args.json_name).write_text(json.dumps(results, indent=2, default=str) + "\n")
    if {"main", "weak", "null"} <= set(results):
        (RESULTS / "fleet.md").write_text(markdown(results, args), encoding="utf-8")


if __name__ == "__main__":
    main()

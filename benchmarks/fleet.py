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
2. **Weak effect** (``--weak-n`` records, 30 % carrying the nut heating at each strength of
   ``--weak-snr``, the same machines at each): how often a single record tests and names it, and
   what the pooled evidence (every record's transfer test, below the effect floor too) names.
3. **Null fleets** (``--null-fleets`` fleets of ``--null-n`` records, nothing withheld, 10 % a
   faulty sensor; fleet seeds from ``--null-seed``): how many the pooled evidence names anything
   in, and the distribution of their records' pooled p-values.
4. The time model: ``T(n, w) = t0(w) + n * t_record / (w * e)``, from the measured runs.

Run: ``python benchmarks/fleet.py [--parts main,weak,null] [--n 200] [--null-fleets 20] ...``;
the parts run replace theirs in ``benchmarks/results/fleet.json`` (the others are kept), and
``fleet.md`` is written from it (a part it lacks is named as missing).
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

import numpy as np
import pandas as pd

from svrqp.fleet import Execution, pool, read_records, run_fleet
from svrqp.fleet.pooled import FLEET_ALPHA
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


def weak_fleet(args, root: Path, snr: float) -> dict:
    """One weak-effect fleet: the nut heating on 30 % of the machines at strength ``snr``."""
    start = time.perf_counter()
    design = FleetDesign(n=args.weak_n, seed=args.seed + 1, snr={"nut": snr},
                         shares={"nut": 0.3, "faulty": 0.1, "none": 0.6})
    manifest = draw(root / f"weak{snr}", design)
    result = run_in_process(manifest, root / f"weak{snr}_out", args.workers)
    truth = pd.read_csv(root / f"weak{snr}" / "truth.csv")
    carriers = set(truth.loc[truth["kind"] == "nut", "name"])
    table = result.table.set_index("name")
    named_alone = int((table.loc[sorted(carriers), "verdict_column"] == "nut_C").sum())
    nut = result.tests[result.tests["column"] == "nut_C"].set_index("name")
    pooled_carriers = set(result.pooled.carriers.get("nut_C", []))
    other = pool(result.tests, "wilkinson")
    return {"n": args.weak_n, "snr": snr, "seed": args.seed + 1, "carriers": len(carriers),
            "named_alone": named_alone,
            "tested_alone": int(nut.loc[sorted(carriers), "tested"].sum()),
            "carrier_p_median": float(nut.loc[sorted(carriers), "p_pool"].median()),
            "pooled_named": result.pooled.named, "pooled_summary": result.pooled.summary(),
            "wilkinson_named": other.named,
            "pooled_carriers_true": len(pooled_carriers & carriers),
            "pooled_carriers_false": len(pooled_carriers - carriers),
            "pooled": result.pooled.table.to_dict("records"),
            "seconds": time.perf_counter() - start}


def weak_fleets(args, root: Path) -> list[dict]:
    runs = []
    for snr in (float(x) for x in args.weak_snr.split(",")):
        runs.append(weak_fleet(args, root, snr))
        print(f"weak {snr}: alone {runs[-1]['named_alone']}, pooled {runs[-1]['pooled_named']}",
              flush=True)
    return runs


def null_fleets(args, root: Path) -> dict:
    """``--null-fleets`` fleets with nothing withheld: what the pool names, and how the pooled
    p-values of their records are distributed (valid: at most a share u at or below u)."""
    start = time.perf_counter()
    named, other_named, records_naming, p_values, smallest_q = [], [], [], [], []
    seeds = [args.null_seed + k for k in range(args.null_fleets)]
    for k, seed in enumerate(seeds):
        design = FleetDesign(n=args.null_n, seed=seed, shares={"faulty": 0.1, "none": 0.9})
        manifest = draw(root / f"null{k}", design)
        result = run_in_process(manifest, root / f"null{k}_out", args.workers)
        named.append(result.pooled.named)
        other_named.append(pool(result.tests, "wilkinson").named)
        single = int((result.table["verdict_column"].fillna("") != "").sum())
        records_naming.append(single)
        p_values += result.tests["p_pool"].tolist()
        smallest_q.append(float(result.pooled.table["q_value"].min()))
        print(f"null fleet {k}: pooled names {result.pooled.named}, {single} records name one, "
              f"smallest q {result.pooled.table['q_value'].min():.3g}", flush=True)
    p = pd.Series(p_values)
    return {"fleets": args.null_fleets, "n": args.null_n, "seeds": seeds,
            "fleets_naming": sum(bool(x) for x in named), "named": named,
            "smallest_q": smallest_q,
            "wilkinson_naming": sum(bool(x) for x in other_named),
            "records_naming": sum(records_naming), "p_tests": len(p),
            "p_share": {str(u): float((p <= u).mean()) for u in (0.01, 0.05, 0.1, 0.5)},
            "mean_fisher_term": float((-2 * np.log(p)).mean()),
            "seconds": time.perf_counter() - start}


def _weak_rows(runs: list[dict]) -> str:
    return "\n".join(
        f"| {w['snr']} | {w['carriers']} | {w['tested_alone']} | **{w['named_alone']}** | "
        f"{w['carrier_p_median']:.3g} | {', '.join(w['pooled_named']) or 'nothing'} | "
        f"{w['pooled_carriers_true']} / {w['pooled_carriers_false']} | "
        f"{', '.join(w['wilkinson_named']) or 'nothing'} |" for w in runs)


def _pooled_rows(w: dict) -> str:
    return "\n".join(f"| {r['column']} | {r['records']} | {r['tested']} | {r['carriers']} | "
                     f"{r['p_fisher']:.3g} | {r['p_wilkinson']:.3g} | {r['q_value']:.3g} | "
                     f"{r['named']} |" for r in w["pooled"])


def _commands(results: dict) -> str:
    """The command that ran each part (each part may be its own run)."""
    argv = results.get("argv_of", {})
    return "; ".join(f"{part}: `python benchmarks/fleet.py {' '.join(argv[part])}`"
                     for part in ("main", "weak", "null") if part in argv) or "Recorded runs"


def _main_section(m: dict) -> str:
    rows = "\n".join(f"| {r['kind']} | {r['records']} | {r['top1']} | {r['false']} |"
                     for r in m["attribution"])
    t_record = m["record_s_mean"]
    return f"""## Main fleet ({m['n']} records, strength {m['snr']})

- Per-record answers identical to single `svrqp gap` calls (JSON text equal, `runtime_s` aside):
  **{m['identical']} of {m['compared']}**; the 2-worker Dask run's documents equal the serial
  run's: {m['dask_identical']} of {m['n']}. Failed records: {m['failed']}.
- Wall time (`svrqp fleet` in a child process, start-up included): serial {m['serial_s']:.1f} s,
  2 Dask workers {m['dask2_s']:.1f} s: **speed-up {m['speedup']:.3f}×**. Mean record
  {t_record:.2f} s (longest {m['record_s_max']:.2f} s).
- Reading the speed-up: a record took {t_record:.2f} s on average serially and
  {m['dask_record_s_mean']:.2f} s on a Dask worker ({_pace(m['dask_record_s_mean'] / t_record)}).
  The workers were busy with records {m['dask_record_s_sum'] / (2 * m['dask2_s']):.0%}
  of the wall time (Σ record time / (2 × wall)), the serial process
  {m['record_s_sum'] / m['serial_s']:.0%}: the rest is the start (imports, the cluster) and the
  writing of the fleet's files.
- Peak memory of the serial `svrqp fleet` process: {m['rss_quarter_mib']:.0f} MiB on
  {m['n_quarter']} records, {m['rss_all_mib']:.0f} MiB on {m['n']}; the parent of the 2-worker
  run: {m['rss_dask_parent_mib']:.0f} MiB.

| kind | records | top-1 | false attribution |
|---|---|---|---|
{rows}

"""


def _pace(ratio: float) -> str:
    """How a worker's records compare with the serial process's (time ratio)."""
    if ratio > 1.0:
        return f"{ratio:.2f}× the serial time: the workers did not get two cores' time"
    return f"{ratio:.2f}× the serial time: the workers lost nothing to each other"


def _weak_section(runs: list[dict]) -> str:
    # the pooled table: the weakest strength the pool names the effect at (else the weakest)
    w = min((r for r in runs if "nut_C" in r["pooled_named"]) or runs, key=lambda r: r["snr"])
    return f"""## Weak effect ({w['n']} records, nut heating on {w['carriers']} of them)

The same {w['n']} machines (fleet seed {w['seed']}) with the withheld nut heating at each
strength: how many carriers their own diagnosis tests for it (its transfer gain above the
effect floor) and names, the median of the carriers' pooled p-values (`p_pool`), what the
pooled evidence names (Fisher over every record's transfer test, below the floor too; BH over
the candidates), the records it lists as carriers (true / not carrying it), and what
Wilkinson's count of the same p-values would name.

| strength | carriers | tested alone | named alone | carriers' median p | pooled (Fisher) \
names | listed true / false | Wilkinson names |
|---|---|---|---|---|---|---|---|
{_weak_rows(runs)}

At strength {w['snr']}: {w['pooled_summary']}

| candidate | records | tested alone | p <= 0.05 | p (Fisher) | p (Wilkinson) | q (BH) | named |
|---|---|---|---|---|---|---|---|
{_pooled_rows(w)}

"""


def _smallest_q(z: dict) -> str:
    q = np.sort(z["smallest_q"])
    return (f" Each fleet's smallest q-value: {q[0]:.3g} at the least, {np.median(q):.2g} "
            f"the median.")


def _null_section(z: dict, runs: list[dict], workers) -> str:
    return f"""## Null fleets

The pooled evidence (q < {FLEET_ALPHA}) names a candidate in **{z['fleets_naming']} of
{z['fleets']}** fleets where nothing is withheld ({z['n']} records each, 10 % with a faulty
`coolant_C`; fleet seeds {z['seeds'][0]}–{z['seeds'][-1]}); Wilkinson's count instead, in {z['wilkinson_naming']} of
{z['fleets']}.{_smallest_q(z)} Single records name a cause on
{z['records_naming']} of the {z['fleets'] * z['n']} null records. The pooled p-values of those
records' {z['p_tests']} tests (a valid p-value is at or below u at most a share u of the time; its
Fisher term −2 ln p averages at most 2): at or below 0.01, 0.05, 0.1, 0.5 in
{', '.join(f"{v:.3f}" for v in z['p_share'].values())} of them; mean −2 ln p
{z['mean_fisher_term']:.2f}.

**Below the floor.** A record tests by transfer only the columns whose transfer gain clears the
effect floor (5 %, `svrqp.gap.contract`); in the fleet each record also tests every other
candidate, after its diagnosis and on its own surrogate stream (`svrqp.gap.transfer.pooling`;
its JSON unchanged), and the pool combines those p-values. Times: weak-effect fleets
{', '.join(f"{r['seconds']:.0f} s" for r in runs) or 'not recorded'} (drawing included), null
fleets {z['seconds']:.0f} s in all, with {workers} workers.

"""


def _time_section(m: dict) -> str:
    t_record = m["record_s_mean"]
    big = 10_000 * t_record / 64
    return f"""## Time model

`T(n, w) ≈ t0(w) + n · t_record / (w · e)`: `t0` the start (Python and svrqp's imports; for
Dask also the local cluster's processes), `t_record` = {t_record:.2f} s per record here (read,
checksum, diagnosis, write), `e` the parallel efficiency. Serially, `n · t_record` =
{m['n'] * t_record:.0f} s of the {m['serial_s']:.0f} s measured; at 2 workers the efficiency
over all was {m['speedup'] / 2:.2f}. 10,000 such records on a 64-core cluster at `e = 0.9`
would take about {big / 0.9 / 60:.0f} min, plus the cluster's start; the parent holds only the
fleet table's rows (one small dict per record) and at most two records per worker in flight.
"""


def _missing(part: str) -> str:
    return (f"## {part.capitalize()}\n\nNot in this record (or recorded in an older format): "
            f"`python benchmarks/fleet.py --parts {part}` adds it.\n\n")


def markdown(results: dict, args) -> str:
    """fleet.md from the recorded parts (a part not recorded, or recorded by an older version of
    this script, is named as missing)."""
    m, runs, z = results.get("main"), results.get("weak"), results.get("null")
    runs = runs if isinstance(runs, list) and runs else None
    z = z if isinstance(z, dict) and "p_share" in z else None
    sizes = [f"main fleet {m['n']} records" if m else None,
             f"weak-effect fleets {runs[0]['n']} records" if runs else None,
             f"{z['fleets']} null fleets of {z['n']} records" if z else None]
    text = (f"# Fleet benchmark (issue #36)\n\n{_commands(results)} on {results['machine']}. "
            f"Sizes: {', '.join(x for x in sizes if x)}.\n\n")
    text += _main_section(m) if m else _missing("main")
    text += _weak_section(runs) if runs else _missing("weak")
    text += (_null_section(z, runs or [], results.get("workers", "?")) if z
             else _missing("null"))
    return text + (_time_section(m) if m else "")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--n", type=int, default=200)
    parser.add_argument("--snr", type=float, default=2.0)
    parser.add_argument("--weak-n", type=int, default=200)
    parser.add_argument("--weak-snr", default="0.2,0.1,0.05",
                        help="comma-separated strengths of the weak-effect fleets")
    parser.add_argument("--null-fleets", type=int, default=20)
    parser.add_argument("--null-n", type=int, default=30)
    parser.add_argument("--null-seed", type=int, default=1000,
                        help="seed of the first null fleet (fleet k: this + k)")
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--parts", default="main,weak,null")
    parser.add_argument("--json-name", default="fleet.json",
                        help="file of benchmarks/results/ the numbers go to: the parts run "
                             "replace theirs, the others are kept")
    parser.add_argument("--render", action="store_true",
                        help="only write fleet.md again from the recorded --json-name")
    args = parser.parse_args()
    path = RESULTS / args.json_name
    results: dict = json.loads(path.read_text()) if path.is_file() else {}
    if args.render:
        (RESULTS / "fleet.md").write_text(markdown(results, args), encoding="utf-8")
        return
    results.update(machine=f"{os.cpu_count()} cores", workers=args.workers)
    with tempfile.TemporaryDirectory(prefix="svrqp-fleet-") as folder:
        root = Path(folder)
        for part, function in (("main", main_fleet), ("weak", weak_fleets),
                               ("null", null_fleets)):
            if part in args.parts.split(","):
                results[part] = function(args, root)
                results.setdefault("argv_of", {})[part] = sys.argv[1:]
                print(json.dumps(results[part], default=str)[:400], flush=True)
    RESULTS.mkdir(exist_ok=True)
    path.write_text(json.dumps(results, indent=2, default=str) + "\n")
    (RESULTS / "fleet.md").write_text(markdown(results, args), encoding="utf-8")


if __name__ == "__main__":
    main()

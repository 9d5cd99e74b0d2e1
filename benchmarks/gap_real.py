"""An independent check of ``svrqp gap`` on real data: FL_THERMAL, leave-one-cycle-out refits.

The checker imports nothing of ``svrqp.gap``: it reads FL_THERMAL (:mod:`gap_fl_data`), fits
every model with plain :func:`numpy.linalg.lstsq`, computes the candidate transforms from their
definitions, and runs the engine only through its command line (``svrqp gap … --json``).

Models
    For each of the five displacement channels, the :data:`PAIRS_PER_CHANNEL` two-sensor
    linear models (intercept + two temperatures) with the lowest leave-one-cycle-out RMSE on
    the train cycles (1250, 2500, 3750 rpm; every cycle is a run and the stop after it). The
    real rows are the 5000 rpm cycle and the mixed-speed run.

The checker's answer (DESIGN §4, "What shrink means")
    For every candidate (the other 14 temperatures and the spindle speed) × {level, rate,
    rise, lag, local}: the model refitted leave-one-cycle-out over all five cycles with the effect added,
    scored on the real rows. ``level`` adds :math:`x`; ``rate`` :math:`\\mathrm{d}x/\\mathrm{d}t`
    (:func:`numpy.gradient` within each cycle); ``rise`` :math:`x - x(t_0)` (the change since the
    cycle's first row); ``lag`` adds :math:`x` and its first-order
    low-pass :math:`x_\\tau` (restarted in equilibrium at each cycle start), :math:`\\tau` taken
    from a geometric grid of :data:`N_TAU` values from max(2 sampling steps, median cycle
    span/100) to half the median cycle span, chosen inside each fit by the smallest squared
    error on the fit's own rows; ``local`` adds :math:`\\mathbb{1}_W` and :math:`x\\mathbb{1}_W`,
    the indicator of a window :math:`W` of ``time_min`` and the candidate inside it, with
    :math:`W` taken from the same tile dictionary as the engine's (:func:`windows`, written
    here from its definition: tiles of 5, 10 and 20 % of the axis's range, the 10 and 20 % tiles
    also shifted by half a tile, each bounded by
    the smallest and largest order value of its rows, kept once, and dropped when it holds
    fewer than 5 rows in every held-out unit, rows in fewer than two of them — the units are
    the real cycles and the train cycles together, which every fit keeps — or when it does not
    lie inside the time span of at least two cycles), the window chosen inside each fit by the
    smallest squared error on the fit's own rows. FL_THERMAL's clock runs on through the
    cycles, so no tile lies inside two cycles' spans and the family is empty here (the table
    says how many windows were tried): a stretch of the clock holds no later cycle, and a tile
    across the seam of two cycles would carry the end of one into the start of the next. ``shrink = 1 − rmse_after / rmse_before`` with
    ``rmse_before`` the model fitted on the train cycles; ``beyond_refit = 1 − rmse_after /
    rmse_refit``. A column's score is its best transform; a candidate *transfers* when its
    shrink beyond the refit is at least :data:`TRANSFERS`.

Scores of the engine
    * top-3 hit: the verdict's column is among the checker's three best columns (a verdict
      withheld while some candidate transfers is a miss; withheld while none does, a hit);
    * shrink error: ``|verdict.shrink − checker's shrink for that column and transform|``;
    * false verdict: a verdict where no candidate transfers or there is no gap.
    Withheld-sensor experiment: for each channel's best pair the better sensor alone is
    withheld and offered as a candidate; with a gap the engine passes when it names the withheld
    sensor or a candidate whose independent refit transfers at least as well (best shrink ≥ the
    withheld sensor's best shrink − :data:`AS_WELL`), without one when it names nothing.

Run: ``python benchmarks/gap_real.py`` — writes ``benchmarks/results/gap_real.{csv,md}``.
"""

from __future__ import annotations

import argparse
import itertools
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import pandas as pd

from svrqp.bench.report import markdown_table

sys.path.insert(0, str(Path(__file__).resolve().parent))
from gap_fl_data import ASSESS_CYCLES, CHANNELS, DEFAULT_DATA, REPO, TEMPERATURES, TRAIN_CYCLES, load_fl  # noqa: E402
from transfer_oracle import logo_rmse, lstsq_predict, tau_grid, transform_variants  # noqa: E402

RESULTS = REPO / "benchmarks" / "results"
EVERY = 4
"""Every fourth sample (one a minute), as the case study."""
PAIRS_PER_CHANNEL = 4
N_TAU = 8
TILE_WIDTHS, TILE_MIN_ROWS, TILE_SHIFTED_MIN = (0.05, 0.1, 0.2), 5, 0.1
"""The ``local`` family's tile dictionary (module docstring): widths, fewest rows, and the least width also
laid half a tile on."""
TRANSFERS = 0.05
AS_WELL = 0.005
TOP = 3
SHRINK_TARGET, HIT_TARGET = 0.05, 0.9


# -- the checker's own computations ------------------------------------------------------------------

def windows(table: pd.DataFrame) -> list[np.ndarray]:
    """The indicator of every window of the ``local`` family's tile dictionary (module docstring)."""
    t = table["time_min"].to_numpy(float)
    unit = table["cycle"].where(table["cycle"].isin(ASSESS_CYCLES), "train").to_numpy()  # units held out
    spans = table.groupby("cycle")["time_min"].agg(["min", "max"]).to_numpy()
    out, seen = [], set()
    tilings = [(width, shift) for width in TILE_WIDTHS
               for shift in ((0.0, width / 2) if width >= TILE_SHIFTED_MIN else (0.0,))]
    for width, shift in tilings:
        n = int(round(1 / width)) - (shift > 0)  # a shifted tiling ends half a tile before the axis does
        edges = t.min() + np.ptp(t) * (shift + width * np.arange(n + 1))
        for i in range(n):
            inside = (t >= edges[i]) & ((t < edges[i + 1]) | (i == n - 1 and shift == 0))
            counts = pd.Series(unit[inside]).value_counts()
            if len(counts) < 2 or counts.max() < TILE_MIN_ROWS:
                continue
            bounds = (t[inside].min(), t[inside].max())
            shared = np.sum((spans[:, 0] <= bounds[0]) & (spans[:, 1] >= bounds[1]))
            if shared >= 2 and bounds not in seen:
                seen.add(bounds)
                out.append(((t >= bounds[0]) & (t <= bounds[1])).astype(float))
    return out


def transforms(table: pd.DataFrame, column: str, taus: np.ndarray,
               tiles: list[np.ndarray]) -> dict[str, list[np.ndarray]]:
    """Each transform's variants as input columns (``lag``: one per time constant, from
    :func:`transfer_oracle.transform_variants`; ``local``: one per window)."""
    x = table[column].to_numpy(float)
    bank = transform_variants(x, table["time_min"].to_numpy(float), table["cycle"].to_numpy(), taus)
    if tiles:
        bank["local"] = [np.column_stack([w, x * w]) for w in tiles]
    return bank


def checker(table: pd.DataFrame, target: str, features: list[str], candidates: list[str],
            banks: dict[str, dict[str, list[np.ndarray]]]) -> tuple[dict[str, float], pd.DataFrame]:
    """The checker's numbers for one model: train CV, before, refit, and every candidate × transform."""
    y = table[target].to_numpy(float)
    train = table["cycle"].isin(TRAIN_CYCLES).to_numpy()
    base = np.column_stack([np.ones(y.size), table[features].to_numpy(float)])
    prediction = lstsq_predict(base[train], y[train], base[~train])
    before = float(np.sqrt(np.mean((y[~train] - prediction) ** 2)))
    cycle, assessed = table["cycle"].to_numpy(), table["cycle"].isin(ASSESS_CYCLES).to_numpy()
    refit = logo_rmse(y, base, [np.zeros((y.size, 0))], cycle, assessed)
    rows = []
    for column in candidates:
        for transform, variants in banks[column].items():
            after = logo_rmse(y, base, variants, cycle, assessed)
            rows.append({"column": column, "transform": transform, "rmse_after": after,
                         "shrink": 1 - after / before, "beyond_refit": 1 - after / refit})
    train_cv = cv_rmse(table[train], target, features)
    return {"rmse_train_cv": train_cv, "rmse_before": before, "rmse_refit": refit}, pd.DataFrame(rows)


def cv_rmse(train: pd.DataFrame, target: str, features: list[str]) -> float:
    """Leave-one-cycle-out RMSE of the linear model on the train cycles."""
    D = np.column_stack([np.ones(len(train)), train[features].to_numpy(float)])
    return logo_rmse(train[target].to_numpy(float), D, [np.zeros((len(train), 0))], train["cycle"].to_numpy(),
                     np.ones(len(train), dtype=bool))


def best_pairs(train: pd.DataFrame, target: str) -> list[tuple[str, str]]:
    scores = {pair: cv_rmse(train, target, list(pair)) for pair in itertools.combinations(TEMPERATURES, 2)}
    return sorted(scores, key=scores.get)[:PAIRS_PER_CHANNEL]


# -- the engine, through its command line -----------------------------------------------------------

def engine(csv: Path, target: str, features: list[str], candidates: list[str], out: Path) -> dict:
    """``svrqp gap`` on the table written to ``csv``; its JSON."""
    command = [sys.executable, "-c", "import sys; from svrqp.cli import main; sys.exit(main())", "gap", str(csv),
               "--target", target, "--train", "cycle in " + repr(list(TRAIN_CYCLES)), "--features", ",".join(features),
               "--candidates", ",".join(candidates), "--order", "time_min", "--group", "cycle", "--local",
               "--json", str(out), "--force"]
    subprocess.run(command, check=True, capture_output=True, text=True, env=os.environ | {"PYTHONPATH": str(REPO)})
    return json.loads(out.read_text(encoding="utf-8"))


def score(kind: str, target: str, features: list[str], withheld: str | None, numbers: dict, table: pd.DataFrame,
          report: dict, seconds: float) -> dict:
    """One row of the results table."""
    by_column = table.sort_values("shrink", ascending=False).drop_duplicates("column").reset_index(drop=True)
    transfers = bool((by_column["beyond_refit"] >= TRANSFERS).any())
    gap = numbers["rmse_before"] > numbers["rmse_train_cv"]  # one-sided: real rows worse than the train cycles
    verdict = report["verdict"]
    named = verdict["column"]
    top = list(by_column["column"][:TOP])
    checker_shrink = error = None
    if named is not None:
        match = table[(table["column"] == named) & (table["transform"] == verdict["transform"])]
        checker_shrink = float(match["shrink"].iloc[0])
        error = abs(verdict["shrink"] - checker_shrink)
    row = {"experiment": kind, "target": target, "model": "+".join(features),
           "checker top 3": ", ".join(f"{c} {t} {s:.0%}" for c, t, s in
                                      by_column[["column", "transform", "shrink"]].head(TOP).itertuples(index=False)),
           "train CV RMSE": numbers["rmse_train_cv"], "real RMSE": numbers["rmse_before"], "gap": gap,
           "refit shrink": 1 - numbers["rmse_refit"] / numbers["rmse_before"], "any transfers": transfers,
           "verdict": "none" if named is None else f"{verdict['transform']} of {named}" + window_text(verdict),
           "engine shrink": verdict.get("shrink"), "checker shrink": checker_shrink, "shrink error": error,
           "top-3 hit": (bool(named in top) if named is not None else not transfers) if gap else named is None,
           "false verdict": named is not None and not (transfers and gap), "seconds": seconds}
    if withheld is not None:
        best = by_column.set_index("column")["shrink"]
        row["withheld"] = withheld
        if not gap:
            row["withheld rule"] = named is None
        else:
            row["withheld rule"] = bool(named == withheld or best[named] >= best[withheld] - AS_WELL
                                        if named is not None else not transfers)
    return row


def window_text(verdict: dict) -> str:
    """`` in [low, high] min`` of a local verdict's window, or nothing."""
    region = verdict.get("region")
    return "" if region is None else f" in [{region['low']:.0f}, {region['high']:.0f}] min"


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("data", nargs="?", type=Path, default=DEFAULT_DATA, help="FL_THERMAL data.csv")
    parser.add_argument("--out", type=Path, default=RESULTS)
    parser.add_argument("--channels", default=",".join(CHANNELS), help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    table = load_fl(args.data, EVERY)
    train = table[table["cycle"].isin(TRAIN_CYCLES)]
    taus = tau_grid(table["time_min"].to_numpy(float), table["cycle"].to_numpy(), N_TAU)
    tiles = windows(table)
    banks = {c: transforms(table, c, taus, tiles) for c in TEMPERATURES + ["speed_rpm"]}
    rows = []
    with tempfile.TemporaryDirectory() as folder:
        csv = Path(folder) / "fl.csv"
        table.to_csv(csv, index=False)
        for target in args.channels.split(","):
            pairs = best_pairs(train, target)
            experiments = [("pairs", list(pair), None) for pair in pairs]
            alone = {s: cv_rmse(train, target, [s]) for s in pairs[0]}
            better = min(alone, key=alone.get)
            experiments.append(("withheld", [s for s in pairs[0] if s != better], better))
            for kind, features, withheld in experiments:
                candidates = [c for c in TEMPERATURES if c not in features] + ["speed_rpm"]
                numbers, cands = checker(table, target, features, candidates, banks)
                started = time.perf_counter()
                report = engine(csv, target, features, candidates, Path(folder) / "gap.json")
                rows.append(score(kind, target, features, withheld, numbers, cands, report,
                                  time.perf_counter() - started))
                print(rows[-1], flush=True)
    write(pd.DataFrame(rows), args.out, len(tiles))
    return 0


def write(results: pd.DataFrame, out: Path, n_windows: int) -> None:
    """The CSV and the Markdown page with the scores against their targets."""
    out.mkdir(parents=True, exist_ok=True)
    results.to_csv(out / "gap_real.csv", index=False)
    pairs = results[results["experiment"] == "pairs"]
    withheld = results[results["experiment"] == "withheld"]
    errors = pairs["shrink error"].dropna()
    hit = float(pairs["top-3 hit"].mean())
    worst = float(errors.max()) if len(errors) else float("nan")
    lines = [
        "# svrqp gap on FL_THERMAL — an independent leave-one-cycle-out check", "",
        "Generated by `benchmarks/gap_real.py` (method in its docstring): the checker refits every candidate × "
        "{level, rate, rise, lag, local} leave-one-cycle-out with plain least squares; the engine runs through `svrqp gap`.", "",
        f"- models: {len(pairs)} ({PAIRS_PER_CHANNEL} two-sensor models per channel, chosen on the train cycles)",
        f"- windows of the `local` family: {n_windows} (a window must lie inside the time span of two cycles; "
        "FL_THERMAL's clock runs on through the cycles)",
        f"- top-3 hit rate: {hit:.2f} (target ≥ {HIT_TARGET}) — {'met' if hit >= HIT_TARGET else '**not met**'}",
        f"- largest shrink error of a named verdict: {worst:.3f} over {len(errors)} verdicts (target ≤ {SHRINK_TARGET}) — "
        + ("met" if len(errors) and worst <= SHRINK_TARGET else "**not met**" if len(errors) else "no verdict named"),
        f"- models without a gap (real rows no worse than the train cycles' leave-one-cycle-out RMSE): "
        f"{int((~pairs['gap'].astype(bool)).sum())}",
        f"- false verdicts (a verdict where no candidate transfers or there is no gap): {int(pairs['false verdict'].sum())}",
        f"- withheld-sensor experiment: {int(withheld['withheld rule'].sum())} of {len(withheld)} pass the rule "
        "(with a gap: names the withheld sensor or a candidate whose independent refit transfers at least as well; "
        "without one: names nothing)", "",
        markdown_table(results.drop(columns=["seconds"])), "",
        f"Engine time per model: median {results['seconds'].median():.1f} s (through the command line, one thread).",
    ]
    (out / "gap_real.md").write_text("\n".join(lines) + "\n", encoding="utf-8")
    print("\n".join(lines[:10]))


if __name__ == "__main__":
    sys.exit(main())

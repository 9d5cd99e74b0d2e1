"""Validation suite of ``svrqp gap`` on withheld-effect data from :mod:`svrqp.machine`.

Every scenario simulates several runs (groups) of a machine, leaves one physical effect out of
the model on purpose — or nothing (*null*), or an effect that no candidate column measures
(*unmeasured*) — runs :func:`svrqp.gap.diagnose`, and scores the answer against the truth the
simulator knows.

Scenario families
-----------------
``thermal/prediction``
    :func:`svrqp.machine.simulate_thermal`; the prediction is the sum of every effect column
    except the withheld one (a simulation with that effect off, noise-free); the target adds
    probe noise. Truth: the sensor of the effect or its driver (``TRUTH_PREDICTION``).
``thermal/features``
    The model (MLR, some LS-SVR) uses the node sensors ``T1_C`` (spindle), ``T4_C``
    (headstock), ``bed_C`` (column), ``nut_C`` (nut), ``coolant_C`` and ``ambient_C``; one node
    sensor is withheld and is the truth. Since the displacement is linear in node
    temperatures, the model can represent everything but the withheld node; sensors are ideal
    (``sensor_lag = 0``) so that their lag is not a second unmodelled effect.
``gantry/prediction``
    :func:`svrqp.machine.contour.simulate_gantry` (S4), order ``time_s``; withheld
    ``servo_lag`` (truth ``feed_mm_min``), ``sync_error`` (``accel_mm_s2``),
    ``motor_heating`` (``motor_C``); *unmeasured*: ``ripple`` and ``guideway_straightness``,
    which no candidate column carries (the right answer is no verdict).

Candidates are the truth plus correlated decoys; a decoy never contains the withheld node
(a sensor blending the same node would be a second correct answer) nor its driver. Runs use
random speed/duty programmes and seasons (the train runs in summer), varied record length,
signal-to-noise ratio and white or AR(1) noise (φ = 0.8). The SNR is the std of the
*identifiable* part of the withheld effect — what the discrepancy model's base regressors
(intercept + prediction, or + the model's features) cannot explain on the real rows — over the
noise std; a between-run offset that a recalibration absorbs is no signal to attribute.

Metrics
-------
top-1 — the verdict names a truth column; top-3 — a truth column is among the first three
causes; false attribution — a verdict on a null/unmeasured scenario; decoy rate — a wrong
column named on a withheld scenario; IoU — rows of the first ``where`` region on the order
axis against the rows where the noise-free residual's square exceeds its mean; shrink error —
``|verdict.shrink − oracle|``, the oracle being the same out-of-sample discrepancy model
(:func:`svrqp.gap.quantify.estimate_shrink`) given the true effect column instead.

Run: ``python benchmarks/gap_suite.py`` (writes ``benchmarks/results/gap_suite.{csv,md}``);
``--quick`` runs a small subset, ``--jobs`` sets parallel workers (default 2).
"""

from __future__ import annotations

import argparse
import platform
import sys
import time
from dataclasses import asdict, dataclass, replace
from pathlib import Path

import numpy as np
import pandas as pd
from joblib import Parallel, delayed

import svrqp
from svrqp.gap import diagnose
from svrqp.gap.baseline import fit_baseline
from svrqp.gap.blocks import blocked_folds
from svrqp.gap.diagnose import base_design
from svrqp.gap.prepare import prepare
from svrqp.gap.quantify import estimate_shrink
from svrqp.machine import ThermalConfig, simulate_thermal
from svrqp.machine.contour import GantryConfig, simulate_gantry
from svrqp.machine.cycles import CycleSegment
from svrqp.machine.thermal import Ambient

RESULTS = Path(__file__).resolve().parent / "results"
AR_PHI = 0.8
SUMMER_DAYS = (170.0, 230.0)

# Thermal prediction mode: withheld effect -> columns that are right answers.
TRUTH_PREDICTION = {
    "spindle_heating": ("T1_C", "speed_rpm"),
    "headstock_heating": ("T4_C", "speed_rpm"),
    "nut_heating": ("nut_C", "axis_duty_pct"),
    "coolant_chiller": ("coolant_C",),
    "ambient_drift": ("ambient_C", "T9_C"),
}
# Decoys per withheld effect (no blend of the effect's own node, not its driver).
DECOYS_PREDICTION = {
    "spindle_heating": ("T5_C", "T8_C", "nut_C", "coolant_C", "ambient_C", "bed_C", "axis_duty_pct"),
    "headstock_heating": ("T1_C", "nut_C", "coolant_C", "ambient_C", "bed_C", "axis_duty_pct", "T9_C"),
    "nut_heating": ("T1_C", "T4_C", "T8_C", "coolant_C", "ambient_C", "bed_C", "speed_rpm"),
    "coolant_chiller": ("T1_C", "T4_C", "nut_C", "ambient_C", "bed_C", "speed_rpm", "axis_duty_pct"),
    "ambient_drift": ("T1_C", "T4_C", "nut_C", "coolant_C", "speed_rpm", "axis_duty_pct"),
}
# Thermal features mode: node sensors of the model; withheld node -> its sensor and decoys.
NODE_SENSORS = ("T1_C", "T4_C", "bed_C", "nut_C", "coolant_C", "ambient_C")
DECOYS_FEATURES = {
    "T1_C": ("T5_C", "T9_C", "speed_rpm", "axis_duty_pct", "T8_C"),
    "T4_C": ("T9_C", "speed_rpm", "axis_duty_pct", "coolant_C", "nut_C"),
    "bed_C": ("T5_C", "T9_C", "speed_rpm", "axis_duty_pct", "T1_C"),
    "nut_C": ("T5_C", "T6_C", "T8_C", "T9_C", "speed_rpm"),
}
NULL_FEATURES_CANDIDATES = ("T5_C", "T9_C", "speed_rpm", "axis_duty_pct", "T8_C")
NULL_PREDICTION_CANDIDATES = ("T1_C", "T4_C", "nut_C", "coolant_C", "ambient_C", "speed_rpm")
# Effect column whose contribution is the truth (features mode: the withheld node's share).
NODE_OF_SENSOR = {"T1_C": "spindle", "T4_C": "headstock", "bed_C": "column", "nut_C": "nut"}
NODE_LENGTH_MM = {"spindle": 200.0, "headstock": 250.0, "column": -350.0, "nut": 120.0}

GANTRY_TRUTH = {"servo_lag": ("feed_mm_min",), "sync_error": ("accel_mm_s2",), "motor_heating": ("motor_C",)}
GANTRY_UNMEASURED = ("ripple", "guideway_straightness")
GANTRY_CANDIDATES = ("feed_mm_min", "accel_mm_s2", "motor_C")
# The rate of the feed *is* the acceleration: feed is no decoy for sync_error.
GANTRY_CANDIDATES_FOR = {"sync_error": ("accel_mm_s2", "motor_C")}


@dataclass(frozen=True)
class Scenario:
    """One withheld-effect (or null) scenario; ``truth`` is empty when no verdict is right."""

    name: str
    family: str  # thermal/prediction, thermal/features, gantry/prediction
    kind: str  # withheld, null, unmeasured
    effect: str | None
    truth: tuple[str, ...]
    candidates: tuple[str, ...]
    snr: float  # std of the identifiable part of the withheld effect on the real rows / noise std
    runs: int
    run_min: float
    ar: bool
    seed: int
    model: str = "mlr"
    null_noise_um: float = 0.3  # noise std of null scenarios (no effect to scale it by)


# ----------------------------------------------------------------------------- data


def _noise(n: int, sigma: float, ar: bool, rng: np.random.Generator, groups: np.ndarray) -> np.ndarray:
    """White or AR(1) noise of standard deviation ``sigma``, restarting per group."""
    white = rng.standard_normal(n)
    if not ar:
        return sigma * white
    out = np.empty(n)
    for g in np.unique(groups):
        rows = np.flatnonzero(groups == g)
        e = np.empty(rows.size)
        e[0] = white[rows[0]]
        for k in range(1, rows.size):
            e[k] = AR_PHI * e[k - 1] + np.sqrt(1 - AR_PHI**2) * white[rows[k]]
        out[rows] = e
    return sigma * out


def _programme(rng: np.random.Generator, minutes: float) -> tuple[CycleSegment, ...]:
    """Random speed/duty steps (independent, so spindle and nut heating decorrelate)."""
    segments, used = [], 0.0
    while used < minutes:
        length = float(min(rng.uniform(20, 90), minutes - used + 1))
        speed = float(rng.choice([0, 1500, 3000, 4500, 6000, 8000]))
        duty = float(rng.choice([0, 20, 40, 60, 80])) if speed > 0 or rng.random() < 0.3 else 0.0
        segments.append(CycleSegment(length, speed, duty))
        used += length
    return tuple(segments)


def thermal_table(s: Scenario) -> pd.DataFrame:
    """Simulated runs of a thermal scenario with ``prediction_um`` and ``true_effect_um``."""
    rng = np.random.default_rng(s.seed)
    n_train = 2 if s.runs >= 5 else 1  # as train_query
    tables = []
    for run in range(s.runs):
        day = rng.uniform(*SUMMER_DAYS) if run < n_train else rng.uniform(0, 365)
        config = ThermalConfig(
            cycle=_programme(rng, s.run_min),
            ambient=Ambient(day_of_year=day, daily_amplitude_C=rng.uniform(0.5, 3.5), start_hour=rng.uniform(6, 14)),
            zero_at_start=False,
            measurement_noise=0.0,
            sensor_lag=0.0 if s.family == "thermal/features" else 1.0,
        )
        config = replace(config, heat=replace(config.heat, chiller_period_min=rng.uniform(30, 60),
                                              chiller_on_fraction=rng.uniform(0.2, 0.4)))
        table = simulate_thermal(config, seed=int(rng.integers(1 << 31)))
        tables.append(table[table["time_min"] <= s.run_min].assign(run=run))
    df = pd.concat(tables, ignore_index=True)
    effects = [c for c in df if c.startswith("effect_")]
    clean = df[effects].sum(axis=1).to_numpy()
    if s.family == "thermal/prediction":
        true_effect = df[f"effect_{s.effect}_um"].to_numpy() if s.effect else np.zeros(len(df))
        df["prediction_um"] = clean - true_effect
    elif s.effect is not None:
        node = NODE_OF_SENSOR[s.effect]
        true_effect = 1e3 * 11.5e-6 * NODE_LENGTH_MM[node] * (df[f"true_{node}_C"].to_numpy() - 20.0)
    else:
        true_effect = np.zeros(len(df))
    return _add_noise(df, clean, true_effect, s, rng, df["run"] >= n_train)


def gantry_table(s: Scenario) -> pd.DataFrame:
    """Simulated gantry runs (varied feed, acceleration, warm-up) with the prediction column."""
    rng = np.random.default_rng(s.seed)
    tables = []
    for run in range(s.runs):
        config = GantryConfig(
            feed_mm_min=float(rng.choice([200, 400, 800, 1200])),
            acceleration_mm_s2=float(rng.choice([10, 20, 50])),
            motor_warm_min=float(rng.uniform(0, 60)),
            measurement_noise=0.0,
            motor_noise_C=0.005,
        )
        tables.append(simulate_gantry(config, seed=int(rng.integers(1 << 31))).assign(run=run))
    df = pd.concat(tables, ignore_index=True)
    effects = [c for c in df if c.startswith("effect_")]
    clean = df[effects].sum(axis=1).to_numpy()
    true_effect = df[f"effect_{s.effect}_um"].to_numpy() if s.effect else np.zeros(len(df))
    df["prediction_um"] = clean - true_effect
    return _add_noise(df.rename(columns={"deviation_um": "error_um"}), clean, true_effect, s, rng, df["run"] >= 1)


def _add_noise(df, clean, true_effect, s: Scenario, rng, real) -> pd.DataFrame:
    """Target = noise-free error + noise of std (identifiable effect std) / SNR.

    The identifiable part of the effect is what the base regressors of the discrepancy model
    (intercept + prediction, or intercept + the model's features) cannot explain on the real
    rows: a between-run offset that a recalibration absorbs is no signal to attribute.
    """
    real = real.to_numpy()
    if s.effect is None:
        sigma = s.null_noise_um
    else:
        base = df["prediction_um"].to_numpy()[:, None] if s.family.endswith("prediction") else \
            df[[c for c in NODE_SENSORS if c != s.effect]].to_numpy()
        design = np.column_stack([np.ones(real.sum()), base[real]])
        part = true_effect[real] - design @ np.linalg.lstsq(design, true_effect[real], rcond=None)[0]
        sigma = np.std(part) / s.snr
    noise = _noise(len(df), sigma, s.ar, rng, df["run"].to_numpy())
    return df.assign(error_um=clean + noise, noise_true_um=noise, true_effect_um=true_effect)


# ------------------------------------------------------------------------ scenarios


def scenarios(quick: bool = False) -> list[Scenario]:
    """The fixed scenario grid (deterministic seeds)."""
    rng = np.random.default_rng(20240601)
    out: list[Scenario] = []

    def design(i: int) -> dict:
        # Cycle through SNR x record length x noise colour so every effect sees each level.
        return {"snr": (1.0, 2.0, 4.0, 8.0, 1.5)[i % 5], "runs": (3, 5, 4)[i % 3],
                "run_min": (240.0, 420.0)[i % 2], "ar": i % 4 == 3}

    def decoys(pool: tuple[str, ...], k: int) -> tuple[str, ...]:
        return tuple(rng.choice(pool, size=min(k, len(pool)), replace=False))

    for effect, truth in TRUTH_PREDICTION.items():
        for i in range(10):
            cands = (truth[0], *decoys(DECOYS_PREDICTION[effect], 4 + i % 3))
            out.append(Scenario(f"tp-{effect}-{i}", "thermal/prediction", "withheld", effect, truth,
                                tuple(rng.permutation(cands)), seed=1000 + len(out), **design(i)))
    for sensor in DECOYS_FEATURES:
        for i in range(10):
            cands = (sensor, *decoys(DECOYS_FEATURES[sensor], 3 + i % 3))
            out.append(Scenario(f"tf-{sensor}-{i}", "thermal/features", "withheld", sensor, (sensor,),
                                tuple(rng.permutation(cands)), seed=1000 + len(out),
                                model="lssvr" if i % 5 == 4 else "mlr", **design(i)))
    for effect, truth in GANTRY_TRUTH.items():
        for i in range(6):
            d = design(i) | {"runs": (4, 6, 8)[i % 3], "run_min": 0.0}
            out.append(Scenario(f"gp-{effect}-{i}", "gantry/prediction", "withheld", effect, truth,
                                GANTRY_CANDIDATES_FOR.get(effect, GANTRY_CANDIDATES), seed=1000 + len(out), **d))
    for i in range(12):
        d = design(i) | {"null_noise_um": (0.1, 0.3, 1.0)[i % 3]}
        out.append(Scenario(f"tp-null-{i}", "thermal/prediction", "null", None, (),
                            decoys(NULL_PREDICTION_CANDIDATES, 5), seed=1000 + len(out), **d))
        out.append(Scenario(f"tf-null-{i}", "thermal/features", "null", None, (),
                            decoys(NULL_FEATURES_CANDIDATES, 4), seed=1000 + len(out),
                            model="lssvr" if i % 5 == 4 else "mlr", **d))
    for i in range(6):
        d = design(i) | {"null_noise_um": (0.05, 0.15, 0.3)[i % 3], "runs": (4, 6, 8)[i % 3], "run_min": 0.0}
        out.append(Scenario(f"gp-null-{i}", "gantry/prediction", "null", None, (), GANTRY_CANDIDATES,
                            seed=1000 + len(out), **d))
    for effect in GANTRY_UNMEASURED:
        for i in range(4):
            d = design(i) | {"runs": (4, 6, 8)[i % 3], "run_min": 0.0}
            out.append(Scenario(f"gu-{effect}-{i}", "gantry/prediction", "unmeasured", effect, (),
                                GANTRY_CANDIDATES, seed=1000 + len(out), **d))
    if quick:
        out = out[::10]
    return out


# ----------------------------------------------------------------------- evaluation


def table_for(s: Scenario) -> pd.DataFrame:
    """The simulated data of a scenario."""
    return gantry_table(s) if s.family.startswith("gantry") else thermal_table(s)


def diagnose_scenario(s: Scenario, df: pd.DataFrame):
    """Run the diagnosis the way a user would on this scenario."""
    gantry = s.family.startswith("gantry")
    common = dict(target="error_um", train=train_query(s),
                  candidates=list(s.candidates), order="time_s" if gantry else "time_min", group="run")
    if s.family.endswith("prediction"):
        return diagnose(df, prediction="prediction_um", **common)
    features = [c for c in NODE_SENSORS if c != s.effect]
    return diagnose(df, features=features, model=s.model, **common)


def evaluate(s: Scenario) -> dict:
    """Simulate, diagnose and score one scenario."""
    df = table_for(s)
    started = time.perf_counter()
    report = diagnose_scenario(s, df)
    runtime = time.perf_counter() - started
    verdict = report.verdict.column
    causes = [c.column for c in report.causes]
    row = asdict(s) | {"truth": "|".join(s.truth), "candidates": "|".join(s.candidates),
                       "n_rows": report.n_rows, "verdict": verdict, "transform": report.verdict.transform,
                       "top1": verdict in s.truth if s.truth else None,
                       "top3": bool(set(causes[:3]) & set(s.truth)) if s.truth else None,
                       "named": verdict is not None, "ambiguous": bool(report.verdict.ambiguous_with),
                       "runtime_s": runtime, "shrink": report.verdict.shrink}
    real = ~df.eval(train_query(s)).to_numpy()
    residual_clean = (df["error_um"] - df["noise_true_um"] - _baseline_prediction(report, df)).to_numpy()[real]
    row["iou"] = _iou(report, df, real, residual_clean) if s.kind == "withheld" else None
    row["oracle_shrink"] = _oracle_shrink(s, df) if s.kind == "withheld" else None
    return row


def train_query(s: Scenario) -> str:
    """Train rows: the first run (the first two with five runs or more)."""
    return "run < 2" if s.family.startswith("thermal") and s.runs >= 5 else "run < 1"


def _baseline_prediction(report, df: pd.DataFrame) -> np.ndarray:
    """The baseline's prediction in the table's row order (the report holds it sorted)."""
    series = report.series
    order = np.lexsort((df[series.order_name].to_numpy(), df["run"].to_numpy()))
    out = np.empty(len(df))
    out[order] = series.y_hat
    return out


def _iou(report, df, real, residual_clean) -> float:
    """Row IoU of the first order-axis region with the rows of above-mean clean squared error."""
    region = next(r for r in report.where if r.column == report.order)
    order = df[report.order].to_numpy()[real]
    truth = residual_clean**2 > np.mean(residual_clean**2)
    found = (order >= region.low) & (order <= region.high)
    union = np.sum(truth | found)
    return float(np.sum(truth & found) / union) if union else float("nan")


def _oracle_shrink(s: Scenario, df: pd.DataFrame) -> float:
    """Shrink of the same out-of-sample discrepancy model given the true effect column."""
    data = prepare(df, target="error_um", train=train_query(s), candidates=["true_effect_um"], group="run",
                   order="time_s" if s.family.startswith("gantry") else "time_min",
                   **({"prediction": "prediction_um"} if s.family.endswith("prediction")
                      else {"features": [c for c in NODE_SENSORS if c != s.effect]}))
    baseline = fit_baseline(data, s.model)
    real = data.is_real
    r, groups = baseline.residual[real], data.groups[real]
    effect = data.C[real]
    effect = (effect - effect.mean()) / effect.std()
    return estimate_shrink(r, base_design(data, baseline), effect, None, blocked_folds(groups), groups,
                           np.random.default_rng(0)).shrink


# -------------------------------------------------------------------------- summary


def summarise(rows: pd.DataFrame) -> str:
    """Markdown tables: overall metrics against targets, then per family and per effect."""
    withheld = rows[rows.kind == "withheld"]
    nulls = rows[rows.kind != "withheld"]
    correct = withheld[withheld.top1 == True]  # noqa: E712  (pandas object column)
    metric = {
        "top-1 accuracy (withheld)": (withheld.top1.mean(), "≥ 0.90"),
        "top-3 accuracy (withheld)": (withheld.top3.mean(), ""),
        "false attribution (null + unmeasured)": (nulls.named.mean(), "≤ 0.05"),
        "false attribution (null only)": (rows[rows.kind == "null"].named.mean(), "≤ 0.05"),
        "decoy named (withheld, wrong column)": ((withheld.named & (withheld.top1 == False)).mean(), ""),  # noqa: E712
        "no verdict (withheld)": ((~withheld.named).mean(), ""),
        "localisation IoU (withheld, mean)": (withheld.iou.mean(), ""),
        "mean |shrink − oracle| (correct verdicts)": ((correct.shrink - correct.oracle_shrink).abs().mean(), "≤ 0.15"),
        "runtime per scenario, median s": (rows.runtime_s.median(), ""),
        "runtime per scenario, max s": (rows.runtime_s.max(), ""),
    }
    lines = [f"# svrqp gap — validation suite ({len(withheld)} withheld, {int((rows.kind == 'null').sum())} null, "
             f"{int((rows.kind == 'unmeasured').sum())} unmeasured scenarios)", "",
             f"svrqp {svrqp.__version__}, Python {platform.python_version()}, {platform.machine()}, "
             f"generated by `benchmarks/gap_suite.py`.", "", "| metric | value | target |", "|---|---|---|"]
    lines += [f"| {name} | {value:.3f} | {target} |" for name, (value, target) in metric.items()]
    lines += ["", "## By family and withheld effect", "",
              "| family | kind | effect | n | top-1 | top-3 | named | decoy | IoU | mean abs shrink err |", "|---|---|---|---|---|---|---|---|---|---|"]
    for (family, kind, effect), part in rows.groupby(["family", "kind", rows.effect.fillna("–")], sort=True):
        ok = part[part.top1 == True]  # noqa: E712
        err = (ok.shrink - ok.oracle_shrink).abs().mean() if len(ok) else float("nan")
        decoy = (part.named & (part.top1 == False)).mean() if kind == "withheld" else float("nan")  # noqa: E712
        lines.append(f"| {family} | {kind} | {effect} | {len(part)} | {_fmt(part.top1)} | {_fmt(part.top3)} | "
                     f"{part.named.mean():.2f} | {decoy:.2f} | {_fmt(part.iou)} | {err:.3f} |")
    lines += ["", "## By signal-to-noise ratio (withheld)", "", "| SNR | n | top-1 | named | decoy |", "|---|---|---|---|---|"]
    for snr, part in withheld.groupby("snr"):
        lines.append(f"| {snr:g} | {len(part)} | {part.top1.mean():.2f} | {part.named.mean():.2f} | "
                     f"{(part.named & (part.top1 == False)).mean():.2f} |")  # noqa: E712
    return "\n".join(lines) + "\n"


def _fmt(column: pd.Series) -> str:
    values = pd.to_numeric(column, errors="coerce")
    return "–" if values.isna().all() else f"{values.mean():.2f}"


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--quick", action="store_true", help="Run every tenth scenario only.")
    parser.add_argument("--jobs", type=int, default=2, help="Parallel worker processes.")
    parser.add_argument("--out", type=Path, default=RESULTS, help="Folder for gap_suite.csv and gap_suite.md.")
    args = parser.parse_args(argv)
    grid = scenarios(args.quick)
    started = time.perf_counter()
    rows = Parallel(n_jobs=args.jobs, verbose=5)(delayed(evaluate)(s) for s in grid)
    table = pd.DataFrame(rows)
    args.out.mkdir(parents=True, exist_ok=True)
    table.to_csv(args.out / "gap_suite.csv", index=False)
    text = summarise(table) + f"\nTotal wall time {time.perf_counter() - started:.0f} s with {args.jobs} workers.\n"
    (args.out / "gap_suite.md").write_text(text, encoding="utf-8")
    print(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())

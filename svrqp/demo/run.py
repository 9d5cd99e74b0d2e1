"""``run_demo``: every step of ``svrqp demo`` in order, writing into a fresh output directory.

Files written (relative to the output directory):

* ``results.json`` — every number below; ``report.html`` — the page that links everything;
* ``s0_predictions.csv`` (per-sample measured and predicted error), ``s0_cv_grid.csv``,
  ``s0_x1.png``, ``s0_x2.png``, ``s0_x3.png``, ``s4_straightness.png``, ``s2_delta_x.png``;
* ``export/s0_svr.json`` (``svrqp.model/1``), ``export/s0_svr.csv``, ``export/svrqp_model.c/.h``;
* ``gap/gap.json`` (``svrqp.gap/2``), ``gap/gap.html``.
"""

from __future__ import annotations

import json
import shutil
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from svrqp import datasets, output
from svrqp.demo import figures, online_seeds, steps
from svrqp.demo.report import SIMULATED_NOTE, report_html
from svrqp.demo.reproduction import reproduction_table
from svrqp.estimators.linear import LinearLS
from svrqp.export import build_document, verify, write
from svrqp.extras import require
from svrqp.kernels import gamma_from_sigma_s4

Progress = Callable[[str, float], None]

#: Share of the run time each step takes (for the progress bar), in order.
STEP_WEIGHTS = {"S0: MLR and ε-SVR with 5-fold CV": 0.25, "S0 variants": 0.15,
                "S1: GA-tuned ε-SVR": 0.3, "S4: LS-SVR straightness": 0.03,
                "S2: nine-line and δx models": 0.04, "S3: recursive least squares": 0.01,
                "export and verify": 0.05, "gap diagnosis": 0.14, "figures and report": 0.03}


#: The extras the demo needs, and why (checked before anything is written).
REQUIRED_EXTRA = (("guard", "ga"), "svrqp demo (S0's conformal intervals, S1's genetic algorithm)")


def prepare_directory(out: Path, force: bool) -> None:
    """Create ``out``; refuse a non-empty one unless
    ``force`` (then the demo's files are replaced)."""
    if out.exists() and not out.is_dir():
        raise FileExistsError(f"{out} exists and is not a directory")
    if out.exists() and any(out.iterdir()) and not force:
        raise FileExistsError(f"{out} exists and is not empty; use --force to overwrite the demo's "
                              f"files in it")
    (out / "export").mkdir(parents=True, exist_ok=True)
    (out / "gap").mkdir(exist_ok=True)


def plain_formula(mlr: LinearLS, target: str) -> str:
    """``target = a·x1 − b·x2 + c`` in plain text (the report renders no LaTeX)."""
    terms = [(float(value), f"·{name}")
             for value, name in zip(mlr.coef_, mlr.feature_names_in_, strict=True)]
    terms.append((float(mlr.intercept_), ""))
    text = f"{terms[0][0]:.4g}{terms[0][1]}"
    for value, name in terms[1:]:
        text += f" {'−' if value < 0 else '+'} {abs(value):.4g}{name}"
    return f"{target} = {text.replace('-', '−')}"


def _unit(column: str) -> str:
    return " °C" if column.endswith("_C") else ""


def extrapolation_notes(ranges: list[dict[str, Any]]) -> list[str]:
    """One sentence per batch whose inputs leave the training range, naming how far."""
    notes = []
    for batch in sorted({row["batch"] for row in ranges}):
        outside = [row for row in ranges if row["batch"] == batch and row["share_outside"] > 0]
        if not outside:
            continue
        parts = [f"{row['input']} spans {row['low']:.3g} … {row['high']:.3g}{_unit(row['input'])} "
                 f"against {row['train_low']:.3g} … {row['train_high']:.3g}{_unit(row['input'])} "
                 f"in training ({100 * row['share_outside']:.0f} % of the rows "
                 "outside)" for row in outside]
        notes.append(f"On {batch} the models extrapolate: " + "; ".join(parts) + ". What they "
                     "predict there is not what they learned from data but how their functional "
                     "form continues: the MLR plane goes on linearly, and the RBF ε-SVR's sum of "
                     "Gaussians tends to its bias b far from its support vectors.")
    return notes


def _s0_rows(result: steps.S0Result) -> tuple[list[dict[str, Any]], str, str]:
    table = result.table.to_dict(orient="records")
    x3 = {row["model"]: row["rms_um"] for row in table if row["batch"] == "x3"}
    better, worse = sorted(x3, key=x3.get)
    return table, better, worse


def _contiguous_section(result: steps.S0Result) -> dict[str, Any]:
    """The labelled variant of S0's CV with contiguous folds (blocks of time) instead of random."""
    return {"folds": "contiguous (KFold without shuffling: five blocks of time)",
            "best_params": result.search.best_params, "edges": result.search.edges(),
            "n_support": int(len(result.svr.support_)), "table": result.table.to_dict("records")}


def _s0_section(result: steps.S0Result, absolute: steps.S0Result, contiguous: steps.S0Result,
                quick: bool) -> dict[str, Any]:
    table, better, worse = _s0_rows(result)
    x3 = {row["model"]: row["rms_um"] for row in table if row["batch"] == "x3"}
    paper = steps.S0_PAPER_RMS_UM
    sentence = (f"On the autumn batch x3, with S0's temperature rises, the {better} leaves the "
                f"smaller RMS residual ({x3[better]:.3g} μm) and the {worse} the larger "
                f"({x3[worse]:.3g} μm); S0 published ε-SVR {paper[('ε-SVR', 'x3')]} vs MLR "
                f"{paper[('MLR', 'x3')]} μm (RMS). The data here is simulated, so the comparison "
                "says what this simulated machine does, not what S0's did.")
    absolute_table, absolute_better, _ = _s0_rows(absolute)
    grid = steps.S0_GRID_QUICK if quick else steps.S0_GRID
    return {
        "dataset": steps.S0_DATASET, "metric": "RMS of the residuals (μm), S0's 'standard "
                                               "deviation'",
        "features": result.features, "target": steps.S0_TARGET, "train_batch": steps.S0_TRAIN_BATCH,
        "epsilon_um": steps.S0_EPSILON_UM,
        "cv": {"folds": steps.S0_FOLDS, "fold_split": f"random, seed {steps.S0_FOLD_SEED} (as S0)",
               "grid": {key: list(values) for key, values in grid.items()},
               "best_params": result.search.best_params, "best_mse_um2": result.search.best_mse,
               "edges": result.search.edges(), "edge_text": result.search.edge_text(),
               "n_fits": result.search.n_fits},
        "contiguous_folds_variant": _contiguous_section(contiguous),
        "n_support": int(len(result.svr.support_)),
        "mlr_formula": plain_formula(result.mlr, steps.S0_TARGET),
        "mlr_latex": result.mlr.to_latex(),
        "table": table, "x3_better_model": better, "sentence": sentence,
        "input_ranges": result.ranges, "extrapolation": extrapolation_notes(result.ranges),
        "absolute_variant": {
            "dataset": steps.S0_ABSOLUTE_DATASET, "features": absolute.features,
            "best_params": absolute.search.best_params,
            "n_support": int(len(absolute.svr.support_)),
            "mlr_formula": plain_formula(absolute.mlr, steps.S0_TARGET), "table": absolute_table,
            "x3_better_model": absolute_better, "input_ranges": absolute.ranges,
            "extrapolation": extrapolation_notes(absolute.ranges),
        },
        "predictions": "s0_predictions.csv", "cv_table": "s0_cv_grid.csv",
        "figures": {batch: f"s0_{batch}.png"
                    for batch in sorted(result.predictions["batch"].unique())},
    }


def _s4_section(result: steps.S4Result) -> dict[str, Any]:
    runs = [{"run": run.run, "fitted_on": run.run == result.train_run, "before_um": run.before_um,
             "after_um": run.after_um, "improvement_percent": run.improvement_percent,
             "after_without_ripple_noise_um": run.after_without_ripple_noise_um}
            for run in result.runs]
    return {
        "sigma_mm": steps.S4_SIGMA_MM, "gamma": gamma_from_sigma_s4(steps.S4_SIGMA_MM),
        "C": steps.S4_C, "n_support": result.n_support, "feed_forward_mm": steps.S4_FEED_FORWARD_MM,
        "dead_band_um": steps.S4_DEAD_BAND_UM,
        "metric": "straightness: peak-to-valley of the deviation from the least-squares line (μm), "
                  "S4 eqs. 2–3",
        "out_of_sample": True, "train_run": result.train_run,
        "test_runs": [run.run for run in result.test_runs],
        "before_um": result.before_um, "after_um": result.after_um,
        "improvement_percent": result.improvement_percent, "runs": runs,
        "model_slope": result.model_slope,
        "after_without_ripple_noise_um": float(np.mean(
            [run.after_without_ripple_noise_um for run in result.test_runs])),
        "paper": steps.S4_PAPER, "figure": "s4_straightness.png",
    }


def _s2_section(result: steps.S2Result) -> dict[str, Any]:
    better = [c for c in result.max_error_improved
              if result.max_error_improved[c] < result.max_error_original[c]]
    worse = [c for c in result.max_error_improved if c not in better]
    noise_free = max(max(errors.values()) for errors in result.max_error_noise_free.values())
    identification = (f"The improved method identifies {len(better)} of {len(better) + len(worse)} "
                      f"components more closely than the original ({', '.join(better) or 'none'})"
                      + (f"; not {', '.join(worse)}" if worse else "")
                      + f". On noise-free readings both are exact (largest error {noise_free:.1g}, "
                        "the rounding of the truth table): the difference is only what each does "
                        "with reading noise — nine readings averaged by least squares against six "
                        "solved exactly — and so depends on the noise draw and on how far apart "
                        "the measuring lines are.")
    return {
        "metric": "MSE of the δx(x) model's residuals at the 11 positions (μm²), S2's 'MSE' "
                  "(in-sample fit)",
        "max_error_improved": result.max_error_improved,
        "max_error_original": result.max_error_original,
        "max_error_noise_free": result.max_error_noise_free, "identification_note": identification,
        "svr_params": result.svr_params, "n_support": result.n_support, "mse_um2": result.mse,
        "edge_text": result.edge_text, "dataset": "zhou_axis_x", "variant_note": (
            "The default data have no ball-screw periodic error: S2's MSEs leave no room for one. "
            "The variant zhou_axis_x_periodic adds a 1 μm, 16 mm-lead periodic error, aliased "
            "at the 55 mm spacing (see its data card)."),
        "paper": steps.S2_PAPER, "figure": "s2_delta_x.png",
    }


def _s1_section(result: online_seeds.S1Result, quick: bool) -> dict[str, Any]:
    genetic = result.genetic
    return {
        "dataset": online_seeds.S1_DATASET, "features": online_seeds.S1_FEATURES,
        "metric": "sum of |residuals| on the 20 test samples (μm), S1's", "quick": quick,
        "genetic": {"population": genetic.population, "generations": genetic.generations,
                    "crossover_probability": genetic.crossover_probability,
                    "mutation_probability": genetic.mutation_probability, "seed": genetic.seed},
        "ranges": {"C": list(online_seeds.S1_C_RANGE),
                   "epsilon": list(online_seeds.S1_EPSILON_RANGE)},
        "best_params": result.search.best_params, "best_mse_um2": result.search.best_mse,
        "n_fits": result.search.n_fits, "edges": result.search.edges(),
        "edge_text": result.edge_text, "n_support": result.n_support, "n_train": result.n_train,
        "sum_abs_um": {"ga": result.sum_abs_ga_um, "untuned": result.sum_abs_untuned_um},
        "paper": online_seeds.S1_PAPER,
    }


def _s3_section(ours: dict[str, float]) -> dict[str, Any]:
    return {"dataset": online_seeds.S3_DATASET, "features": online_seeds.S3_FEATURES,
            "start_workpieces": online_seeds.S3_START, "ours": ours,
            "paper": online_seeds.S3_PAPER}


def _export_section(result: steps.S0Result, out: Path, force: bool) -> dict[str, Any]:
    document = build_document(result.svr, result.X_train, result.y_train)
    written = [*write(document, out / "export" / "s0_svr.json", force=force),
               *write(document, out / "export" / "s0_svr.csv", force=force),
               *write(document, out / "export" / "svrqp_model.c", force=force)]
    report = verify(out / "export" / "s0_svr.json")
    return {
        "files": [path.relative_to(out).as_posix() for path in written],
        "verify": {"ok": report.ok, "max_deviation": report.max_deviation,
                   "tolerance": report.tolerance,
                   "checks": [{"name": c.name, "ok": c.ok, "detail": c.detail}
                              for c in report.checks]},
        "cross_check": document["cross_check"],
    }


def run_demo(out: str | Path = "demo-output", *, quick: bool = False, force: bool = False,
             n_jobs: int | None = None, progress: Progress | None = None) -> dict[str, Any]:
    """Run every step of the demo and write its files into ``out``.

    Parameters
    ----------
    out
        Output directory, created fresh (a non-empty one needs ``force``).
    quick
        Smaller S0 CV grid and a smaller S1 GA (population 10 for 5 generations; S1's, run
        otherwise, is 100 for 50), for tests and a first look; the S1 rows say so.
    force
        Overwrite the demo's own files in an existing, non-empty ``out``.
    n_jobs
        Parallel workers of the S0 cross-validation; default 2, or 1 with ``quick`` (starting
        worker processes costs more than the 20 fits of the quick grid).
    progress
        Called as ``progress(step, fraction_done)``.

    Returns
    -------
    dict
        The content of ``results.json``.
    """
    started = time.perf_counter()
    if n_jobs is None:
        n_jobs = 1 if quick else 2
    out = Path(out)
    require(*REQUIRED_EXTRA)  # before any file is written
    created = not out.exists()
    prepare_directory(out, force)
    try:
        return _run_steps(out, quick=quick, force=force, n_jobs=n_jobs, progress=progress,
                          started=started)
    except BaseException:
        if created:  # nothing left behind: the folder this run made goes with it
            shutil.rmtree(out, ignore_errors=True)
        raise


def _run_steps(out: Path, *, quick: bool, force: bool, n_jobs: int, progress: Progress | None,
               started: float) -> dict[str, Any]:
    """Every step of :func:`run_demo` into the prepared
    ``out``; returns ``results.json``'s content."""
    report = progress or (lambda step, done: None)
    done = 0.0
    names = iter(STEP_WEIGHTS)

    def step() -> str:
        nonlocal done
        name = next(names)
        report(name, done)
        done += STEP_WEIGHTS[name]
        return name

    name = step()
    s0_start = done - STEP_WEIGHTS[name]
    s0 = steps.s0_thermal(datasets.load(steps.S0_DATASET), quick=quick, n_jobs=n_jobs,
                          progress=lambda k, n: report(name, s0_start + STEP_WEIGHTS[name] * k / n))
    step()
    absolute_data = datasets.load(steps.S0_ABSOLUTE_DATASET)
    s0_absolute = steps.s0_thermal(absolute_data, quick=quick, n_jobs=n_jobs,
                                   features=steps.S0_ABSOLUTE_FEATURES)
    s0_contiguous = steps.s0_thermal(datasets.load(steps.S0_DATASET), quick=quick, n_jobs=n_jobs,
                                     contiguous=True)
    step()
    s1 = online_seeds.s1_ga(datasets.load(online_seeds.S1_DATASET), quick=quick)
    step()
    s4 = steps.s4_straightness(datasets.load("lin_gantry"))
    step()
    s2 = steps.s2_nine_line(datasets.load("zhou_axis_x"), datasets.load("zhou_axis_x_true"))
    step()
    s3 = online_seeds.s3_recursive(datasets.load(online_seeds.S3_DATASET))
    step()
    export = _export_section(s0, out, force)
    name = step()
    gap_start = done - STEP_WEIGHTS[name]
    gap = steps.gap_autumn(absolute_data, progress=lambda stage, f: report(
        f"{name}: {stage}", gap_start + STEP_WEIGHTS[name] * f))
    gap.write_json(out / "gap" / "gap.json", force=force)
    gap.to_html(out / "gap" / "gap.html", force=force)
    step()
    # prepare_directory accepted out (fresh, or --force): the demo's own files in it are replaced
    # through svrqp.output, so a link planted there is replaced, never written through.
    for name, table in (("s0_predictions.csv", s0.predictions),
                        ("s0_cv_grid.csv", s0.search.table)):
        with output.replacing(out / name, force=True) as temporary:
            table.to_csv(temporary, index=False)
    results: dict[str, Any] = {
        "note": SIMULATED_NOTE, "quick": quick,
        "s0": _s0_section(s0, s0_absolute, s0_contiguous, quick),
        "s1": _s1_section(s1, quick), "s4": _s4_section(s4), "s2": _s2_section(s2),
        "s3": _s3_section(s3),
        "export": export, "gap": {"verdict": gap.to_dict()["verdict"],
                "summary": gap.summary.replace("\u00b5m", "μm"), "json": "gap/gap.json",
                "html": "gap/gap.html"},
    }
    results["reproduction"] = reproduction_table(results)
    for batch, path in results["s0"]["figures"].items():
        figures.s0_batch_figure(s0.predictions, batch, out / path)
    figures.s4_figure(s4, out / results["s4"]["figure"])
    figures.s2_figure(s2, out / results["s2"]["figure"])
    results["runtime_s"] = time.perf_counter() - started
    output.write_text(out / "results.json",
                      json.dumps(results, indent=2, ensure_ascii=False, allow_nan=False) + "\n",
                      force=True)
    output.write_text(out / "report.html", report_html(results), force=True)
    report("done", 1.0)
    return results

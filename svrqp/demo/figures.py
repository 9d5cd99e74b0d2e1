"""Figures of ``svrqp demo``: measured vs predicted vs residual over time (S0 Figs. 3–8), S4's
straightness before and after compensation, S2's δx(x) identification and models."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

# A Figure of its own, never pyplot's global state: the backend of a notebook or GUI stays as it is.
from matplotlib.figure import Figure

from svrqp import output
from svrqp.demo.steps import S2_TRAVEL_MM, S2Result, S4Result
from svrqp.guard.figures import draw_guard

BATCH_TITLES = {"x1": "x1 (summer, training batch)", "x2": "x2 (summer)", "x3": "x3 (autumn)"}


def _save(figure: Figure, path: Path) -> Path:
    figure.tight_layout()
    # inside the demo's own folder (prepare_directory)
    with output.replacing(path, force=True) as temporary:
        figure.savefig(temporary, dpi=90)
    return path


def s0_batch_figure(predictions: pd.DataFrame, batch: str, path: Path) -> Path:
    """Measured and predicted axial error (top) and
    the residuals (bottom) of one batch over time."""
    rows = predictions[predictions["batch"] == batch]
    figure = Figure(figsize=(7.5, 5.5))
    top, bottom = figure.subplots(2, 1, sharex=True)
    top.plot(rows["time_min"], rows["error_um"], color="black", lw=1.2,
             label="measured (simulated)")
    top.plot(rows["time_min"], rows["mlr_um"], color="tab:orange", lw=1, label="MLR")
    top.plot(rows["time_min"], rows["svr_um"], color="tab:blue", lw=1, ls="--", label="ε-SVR")
    draw_guard(top, rows["time_min"], rows["svr_lower_um"], rows["svr_upper_um"],
               rows["svr_outside"], coverage=0.9)
    top.set_ylabel("axial error since start (μm)")
    top.set_title(f"S0 — batch {BATCH_TITLES.get(batch, batch)}")
    top.legend(loc="best", fontsize=8)
    bottom.plot(rows["time_min"], rows["error_um"] - rows["mlr_um"], color="tab:orange", lw=1,
                label="MLR")
    bottom.plot(rows["time_min"], rows["error_um"] - rows["svr_um"], color="tab:blue", lw=1,
                ls="--", label="ε-SVR")
    bottom.axhline(0.0, color="grey", lw=0.6)
    bottom.set_xlabel("time (min)")
    bottom.set_ylabel("residual (μm)")
    bottom.legend(loc="best", fontsize=8)
    return _save(figure, path)


def s4_figure(result: S4Result, path: Path) -> Path:
    """The first unseen run's deviation, the model
    fitted on another run, and what remains, along x."""
    run = result.test_runs[0]
    figure = Figure(figsize=(7.5, 4))
    axis = figure.subplots()
    axis.plot(run.x_mm, run.deviation_um, color="black", lw=0.8,
              label=f"run {run.run}: deviation e = g(x) − y from its LS line (simulated)")
    axis.plot(result.x_mm, result.model_um, color="tab:blue", lw=1.2, label=f"LS-SVR model fitted "
                                                                            f"on run "
                                                                            f"{result.train_run}")
    axis.plot(run.x_mm, run.compensated.residual_um, color="tab:green", lw=0.8,
              label=f"run {run.run} after compensation (feed-forward, dead band)")
    axis.set_xlabel("x (mm)")
    axis.set_ylabel("straightness deviation (μm)")
    axis.set_title("S4 — gantry straightness, scored on a run the model never saw")
    axis.legend(loc="best", fontsize=8)
    return _save(figure, path)


def s2_figure(result: S2Result, path: Path) -> Path:
    """δx(x): truth, improved and original nine-line identification, SVR and 5th-order LSM."""
    x_mm = result.identified["x_mm"].to_numpy()
    fine_mm = np.linspace(x_mm.min(), x_mm.max(), 300)
    figure = Figure(figsize=(7.5, 4))
    axis = figure.subplots()
    axis.plot(result.truth["x_mm"], result.truth["delta_x_um"], "k-", lw=0.8, label="true δx "
                                                                                    "(simulator)")
    axis.plot(x_mm, result.identified["delta_x_um"], "o", color="tab:blue", label="improved "
                                                                                  "nine-line")
    axis.plot(x_mm, result.original["delta_x_um"], "x", color="tab:red", label="original nine-line")
    axis.plot(fine_mm, result.svr.predict(pd.DataFrame({"u": fine_mm / S2_TRAVEL_MM})),
              color="tab:blue", lw=1, label="ε-SVR")
    axis.plot(fine_mm, result.lsm.predict(pd.DataFrame({"x_mm": fine_mm})), color="tab:orange",
              lw=1, ls="--", label="5th-order LSM")
    axis.set_xlabel("x (mm)")
    axis.set_ylabel("positioning error δx (μm)")
    axis.set_title("S2 — X-axis positioning error")
    axis.legend(loc="best", fontsize=8)
    return _save(figure, path)

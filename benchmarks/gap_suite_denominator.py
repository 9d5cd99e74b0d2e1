"""Which scenarios of the gap suite can be named, decided by the simulator before the engine runs.

DESIGN §4 (how the suite judges): the targets count every withheld scenario except those whose truth
*cannot* be named, and that is decided here, from what the simulator knows, never from the engine's
gate or from an oracle that shares its design:

* **gap** — the noise-free residual: the model's family fitted on the train rows of the target
  *without* its noise leaves a larger RMS residual on the real rows than on train rows it did not see
  (:func:`noise_free_gap`; no significance test: the noise is the engine's problem, not the truth's);
* **run level** — a truth whose driver holds one level per run by the simulator's definition
  (:data:`gap_suite_cases.RUN_LEVEL_EFFECTS`) needs six runs and its driver at two levels or more;
* **nameable** — the truth, under the best form of :mod:`generating_oracle` (lags up to τ = ∞, two-τ lags,
  the between-run block, the simulator's own physics for a noise-free driver), beats the same-input
  refit by at least :data:`generating_oracle.NAMEABLE_GAIN` of that refit's real-row RMSE, and beats its
  own surrogates (rotated within runs, run means exchanged) with that form at a p-value below
  :data:`generating_oracle.NAMEABLE_P` (:func:`truth_p`); a localised truth the same in its true stretch
  with the effect's true profile (:func:`local_gain`, :func:`local_p`).

A scenario failing one of these leaves the denominator with its reason (:func:`exclusion`), never counted
right. For a scenario with nothing withheld, the same oracle says whether any offered column transfers
at all (:func:`best_candidate`): on an *unmeasured* record such a column is a proxy of the unmeasured
effect, scored apart; on a null record it would be a defect of the scenario.
"""

from __future__ import annotations

import numpy as np
import pandas as pd
from generating_oracle import NAMEABLE_DRAWS, NAMEABLE_GAIN, NAMEABLE_P, best_rmse, form_p, gain_over_refit, refit_rmse
from local_oracle import stretch_p, stretch_rmse

from gap_suite_cases import RUN_LEVEL_EFFECTS, Scenario

PHYSICS_DRIVERS = ("speed_rpm", "axis_duty_pct", "feed_mm_min", "accel_mm_s2", "load_kg")
"""Inputs the simulator records without noise and drives an effect with: for these the oracle may use the
effect exactly as the simulator computes it from them (``true_effect_um``)."""

Family = tuple[np.ndarray, np.ndarray, object, float]
"""The model's family for the suite's refits: target, own inputs, fitting rule, the given model's RMSE."""


def noise_free_gap(table: pd.DataFrame, own: np.ndarray, predict, real: np.ndarray, prediction: bool) -> bool:
    """Whether the family, fitted on the noise-free target of the train rows, leaves more RMS residual on the
    real rows than on train rows it did not see (the one-sided gap of DESIGN §4, from the simulator's clean
    error); with a given prediction, whether the clean target − prediction is larger on the real rows.

    The train rows are scored on the footing of the real ones, out of sample (:func:`train_folds`): a model
    is compared on runs it never saw, never with its own fit on its own rows.
    """
    clean = (table["error_um"] - table["noise_true_um"]).to_numpy(float)
    if prediction:  # nothing is fitted to a given prediction (DESIGN §4): the gap is target − prediction
        residual = clean - table["prediction_um"].to_numpy(float)
        return float(np.sqrt(np.mean(residual[real] ** 2))) > float(np.sqrt(np.mean(residual[~real] ** 2)))
    real_residual = clean[real] - predict(own[~real], clean[~real], own[real])
    train = np.flatnonzero(~real)
    train_residual = np.empty(train.size)
    for held in train_folds(table["run"].to_numpy()[train]):
        fit = np.setdiff1d(np.arange(train.size), held)
        train_residual[held] = clean[train[held]] - predict(own[train[fit]], clean[train[fit]], own[train[held]])
    return float(np.sqrt(np.mean(real_residual**2))) > float(np.sqrt(np.mean(train_residual**2)))


TRAIN_BLOCKS = 5
"""Contiguous blocks of a single train run scored out of sample (a count of the suite's own)."""


def train_folds(runs: np.ndarray) -> list[np.ndarray]:
    """Held-out sets of the train rows: each train run when there are two or more, else
    :data:`TRAIN_BLOCKS` contiguous blocks of the one run (never interleaved rows, which would
    interpolate an autocorrelated record)."""
    labels = pd.unique(runs)
    if labels.size >= 2:
        return [np.flatnonzero(runs == r) for r in labels]
    block = np.arange(runs.size) * TRAIN_BLOCKS // runs.size
    return [np.flatnonzero(block == b) for b in range(TRAIN_BLOCKS)]


def truth_gain(table: pd.DataFrame, family: Family, truth: tuple[str, ...], order: str,
               real: np.ndarray) -> tuple[float, str, str]:
    """The best gain over the same-input refit of any truth column under any generating form, the column and
    the form (rows sorted by run and ``order``)."""
    y, own, predict, _ = family
    runs, t = table["run"].to_numpy(), table[order].to_numpy(float)
    refit = refit_rmse(y, own, runs, real, predict)
    best = (-np.inf, "", "")
    for column in truth:
        physics = table["true_effect_um"].to_numpy(float) if column in PHYSICS_DRIVERS else None
        rmse, form = best_rmse(y, own, table[column].to_numpy(float), t, runs, real, predict, physics)
        best = max(best, (gain_over_refit(rmse, refit), column, form))
    return best


def truth_p(table: pd.DataFrame, family: Family, column: str, form: str, order: str, real: np.ndarray,
            seed: int) -> float:
    """The surrogate p-value of the truth column under the form :func:`truth_gain` chose for it
    (:func:`generating_oracle.form_p`; rows sorted by run and ``order``)."""
    y, own, predict, _ = family
    physics = table["true_effect_um"].to_numpy(float) if form == "physics" else None
    return form_p(y, own, table[column].to_numpy(float), table[order].to_numpy(float), table["run"].to_numpy(),
                  real, form, np.random.default_rng(seed), predict, physics)


def best_candidate(table: pd.DataFrame, family: Family, candidates: tuple[str, ...], order: str,
                   real: np.ndarray) -> tuple[float, str]:
    """The best gain over the same-input refit of any offered column under the generating forms (no physics:
    nothing was withheld), and that column."""
    y, own, predict, _ = family
    runs, t = table["run"].to_numpy(), table[order].to_numpy(float)
    refit = refit_rmse(y, own, runs, real, predict)
    gains = {c: gain_over_refit(best_rmse(y, own, table[c].to_numpy(float), t, runs, real, predict)[0], refit)
             for c in candidates}
    column = max(gains, key=gains.get)
    return gains[column], column


def local_gain(table: pd.DataFrame, family: Family, truth: tuple[str, ...], profile: np.ndarray,
               real: np.ndarray) -> float:
    """The best gain over the same-input refit of a localised truth in its true stretch, entered as
    ``[w, x w]`` with the effect's true profile ``w`` (the simulator's own form of the effect)."""
    y, own, predict, _ = family
    runs = table["run"].to_numpy()
    refit = refit_rmse(y, own, runs, real, predict)
    return max(gain_over_refit(stretch_rmse(y, own, table[c].to_numpy(float), profile, runs, real, predict), refit)
               for c in truth)


def local_p(table: pd.DataFrame, family: Family, truth: tuple[str, ...], profile: np.ndarray,
            real: np.ndarray, seed: int) -> float:
    """The smallest surrogate p-value of a localised truth column entered in its true stretch as ``[w, x w]``
    (:func:`local_oracle.stretch_p`), unadjusted for the other offered columns."""
    y, own, predict, _ = family
    runs, rng = table["run"].to_numpy(), np.random.default_rng(seed)
    return min(stretch_p(y, own, table[c].to_numpy(float), profile, runs, real, rng, predict, draws=NAMEABLE_DRAWS)
               for c in truth)


def run_levels(table: pd.DataFrame, truth: tuple[str, ...]) -> int:
    """Distinct run means of the truth columns (the most any of them has), over every run."""
    return max(table.groupby("run")[c].mean().round(9).nunique() for c in truth)


def exclusion(s: Scenario, gap: bool, gain: float, levels: int | None, p: float | None = None) -> str | None:
    """Why a withheld scenario leaves the denominator, or None when it stays (module docstring)."""
    if s.model != "mlr" and s.family == "thermal/features":
        return "kernel-family model (reported apart)"
    if not gap:
        return "no gap in the noise-free residual"
    if s.effect in RUN_LEVEL_EFFECTS and (s.runs < 6 or (levels is not None and levels < 2)):
        return "run-level truth with fewer than six runs or one level"
    if gain < NAMEABLE_GAIN:
        return f"truth cannot transfer (generating-form oracle gain {gain:.3f} < {NAMEABLE_GAIN})"
    if p is not None and p >= NAMEABLE_P:
        return f"truth does not transfer beyond chance (generating-form oracle p {p:.3f} ≥ {NAMEABLE_P})"
    return None

r"""Result rows: success, the comparison with the reference run, and the per-method aggregates.

**Success** means the method says it solved the problem *and* every relative certificate
(primal residual, dual residual, duality gap; :mod:`svrqp.bench.outcomes`) is at most the
profile's ``residual_tol``.

Times are aggregated per method by the shifted geometric mean
:math:`\exp(\overline{\log(t + s)}) - s` with failed runs counted at the time limit
(qpbenchmark's convention).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np
import pandas as pd
from numpy.typing import NDArray

from svrqp.bench.cases import BenchCase, Profile
from svrqp.bench.outcomes import Method, RunOutcome
from svrqp.bench.runners import REFERENCES

#: Every column of a result row, in order.
ROW_COLUMNS = (
    "dataset", "n", "d", "kernel", "C", "epsilon", "gamma", "problem", "formulation", "backend",
    "method", "profile", "tol", "residual_tol", "status", "success", "build_time_s", "solve_time_s",
    "total_time_s", "iterations", "primal_residual", "dual_residual", "duality_gap", "objective",
    "reference_objective",
    "objective_gap_rel", "prediction_diff_rel", "support_agreement", "n_support",
    "n_support_reference",
    "pd_regularisation", "pd_objective_shift", "approximation_error", "error",
)


def is_success(outcome: RunOutcome, profile: Profile) -> bool:
    """Solved, and every certificate that applies is finite and at most ``profile.residual_tol``."""
    return (
        outcome.status == "optimal"
        and bool(outcome.residuals)
        and all(math.isfinite(value) and value <= profile.residual_tol
                for value in outcome.residuals.values())
    )


def _jaccard(a: NDArray[np.bool_], b: NDArray[np.bool_]) -> float:
    union = int(np.sum(a | b))
    return 1.0 if union == 0 else float(np.sum(a & b)) / union


def evaluate(outcome: RunOutcome, method: Method, case: BenchCase, reference: RunOutcome | None,
             profile: Profile) -> dict[str, Any]:
    """One result row (keys :data:`ROW_COLUMNS`).

    Comparisons with the reference: ``objective_gap_rel`` is
    :math:`(J - J_\\text{ref}) / |J_\\text{ref}|` (negative: lower than the reference),
    ``prediction_diff_rel`` is
    :math:`\\max_i |f(x_i) - f_\\text{ref}(x_i)| / \\operatorname{std}(y)` on the training inputs,
    ``support_agreement`` the Jaccard index of the two support sets
    (:func:`svrqp.formulations.epsilon_svr.support_mask`, threshold
    relative to C). They are NaN when either run has no model.
    """
    has_reference = (
        reference is not None and reference.decision is not None and outcome.decision is not None
    )
    compare = (lambda fn: fn()) if has_reference else (lambda fn: math.nan)
    residual = outcome.residuals.get
    return {
        "dataset": case.dataset, "n": case.n, "d": case.d, "kernel": case.kernel, "C": case.C,
        "epsilon": case.epsilon, "gamma": case.gamma, "problem": method.problem,
        "formulation": method.formulation, "backend": method.backend, "method": method.label,
        "profile": profile.name, "tol": profile.tol, "residual_tol": profile.residual_tol,
        "status": outcome.status, "success": is_success(outcome, profile),
        "build_time_s": outcome.build_time_s, "solve_time_s": outcome.solve_time_s,
        "total_time_s": outcome.total_time_s, "iterations": outcome.iterations,
        "primal_residual": residual("primal_rel", math.nan),
        "dual_residual": residual("dual_rel", math.nan),
        "duality_gap": residual("gap_rel", math.nan), "objective": outcome.objective,
        "reference_objective": reference.objective if reference is not None else math.nan,
        "objective_gap_rel": compare(
            lambda: (outcome.objective - reference.objective) / (abs(reference.objective) or 1.0)),
        "prediction_diff_rel": compare(
            lambda: float(np.max(np.abs(outcome.decision - reference.decision)) / np.std(case.y))),
        "support_agreement": compare(lambda: _jaccard(outcome.support, reference.support)),
        "n_support": int(outcome.support.sum()) if outcome.support is not None else -1,
        "n_support_reference": (int(reference.support.sum())
                                if reference is not None and reference.support is not None else -1),
        "pd_regularisation": outcome.notes.get("pd_regularisation", 0.0),
        "pd_objective_shift": outcome.notes.get("pd_objective_shift", 0.0),
        "approximation_error": outcome.notes.get("approximation_error", 0.0),
        "error": outcome.error,
    }


def shifted_geometric_mean(times_s: Sequence[float], shift_s: float = 1.0) -> float:
    """:math:`\\exp(\\overline{\\log(t + s)}) - s`:
    small times count, one slow run does not dominate."""
    times = np.asarray(times_s, dtype=float)
    if times.size == 0:
        return math.nan
    return float(np.exp(np.mean(np.log(times + shift_s))) - shift_s)


def aggregate(rows: pd.DataFrame, time_limit_s: float, shift_s: float = 1.0) -> pd.DataFrame:
    """Per method: runs, successes, and the shifted
    geometric mean of total time (failures at the limit).

    ``sgm_ratio`` divides each method's mean by the smallest one (1.0 is the fastest).
    """
    times = rows["total_time_s"].where(rows["success"], time_limit_s)
    table = (
        rows.assign(charged_time_s=times)
        .groupby(["problem", "method"], sort=False)
        .agg(runs=("success", "size"), successes=("success", "sum"),
             sgm_time_s=("charged_time_s", lambda t: shifted_geometric_mean(t, shift_s)))
        .reset_index()
    )
    table["success_rate"] = table["successes"] / table["runs"]
    table["sgm_ratio"] = table["sgm_time_s"] / table.groupby("problem")["sgm_time_s"].transform(
        "min"
    )
    return table.sort_values(["problem", "sgm_time_s"]).reset_index(drop=True)


def ratios_to_reference(rows: pd.DataFrame, objective_gap_max: float = 1e-8,
                        prediction_diff_max: float = 1e-4) -> pd.DataFrame:
    """Per dataset and n: the reference's time, the
    fastest *exact* compared method, and their ratio.

    Exact means: success, objective at most ``objective_gap_max`` (relative) above the reference's,
    and predictions within ``prediction_diff_max``·std(y) of the reference's (the issue's targets).
    """
    reference = rows[rows["method"].isin([method.label for method in REFERENCES.values()])]
    exact = rows[rows["success"] & (rows["objective_gap_rel"] <= objective_gap_max)
                 & (rows["prediction_diff_rel"] <= prediction_diff_max)]
    table = []
    for (problem, dataset, n), runs in exact.groupby(["problem", "dataset", "n"], sort=True):
        ref = reference[
            (reference["problem"] == problem)
            & (reference["dataset"] == dataset)
            & (reference["n"] == n)
        ]
        best = runs.loc[runs["total_time_s"].idxmin()]
        ref_time = float(ref["total_time_s"].iloc[0]) if len(ref) else math.nan
        table.append({"problem": problem, "dataset": dataset, "n": n,
                      "reference": ref["method"].iloc[0] if len(ref) else "",
                      "reference_time_s": ref_time, "fastest_exact": best["method"],
                      "fastest_exact_time_s": best["total_time_s"],
                      "ratio": best["total_time_s"] / ref_time})
    return pd.DataFrame(table,
                        columns=["problem", "dataset", "n", "reference", "reference_time_s",
                                 "fastest_exact",
                                        "fastest_exact_time_s", "ratio"])

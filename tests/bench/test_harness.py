"""The solver comparison: rows, success flags, certificates, time limits, outputs, CLI."""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
import pytest
from typer.testing import CliRunner

from svrqp.bench import runners
from svrqp.bench.cases import PROFILES, BenchCase, make_case
from svrqp.bench.evaluate import (
    ROW_COLUMNS,
    aggregate,
    evaluate,
    is_success,
    ratios_to_reference,
    shifted_geometric_mean,
)
from svrqp.bench.outcomes import Method, QPPoint, beta_certificates, qp_outcome
from svrqp.bench.report import write_outputs
from svrqp.bench.run import BenchConfig, run_benchmark
from svrqp.bench.runners import LOW_RANK_TOL, methods, run_isolated
from svrqp.cli import app
from svrqp.exceptions import ProblemError, SolverError
from svrqp.formulations import epsilon_svr
from svrqp.solvers import solve_qp

DEFAULT = PROFILES["default"]


@pytest.fixture(scope="module")
def tiny_config() -> BenchConfig:
    """Two small sizes of the S0-like thermal set, two fast backends, both dual forms and LS-SVR."""
    return BenchConfig(datasets=("thermal",), sizes=(40, 60), d=3, C=10.0, epsilon=0.1,
                       formulations=("stacked", "split"), backends=("clarabel", "osqp"), ls_svr=True,
                       time_limit_s=30.0)


@pytest.fixture(scope="module")
def tiny_rows(tiny_config) -> pd.DataFrame:
    return run_benchmark(tiny_config)


@pytest.fixture(scope="module")
def thermal_case() -> BenchCase:
    """30 samples of the thermal set: small enough for the dense stacked QP and its certificates."""
    return make_case("thermal", 30, 3, C=10.0, epsilon=0.1)


def test_tiny_benchmark_has_every_column_and_row(tiny_config, tiny_rows):
    assert list(tiny_rows.columns) == list(ROW_COLUMNS)
    assert len(tiny_rows) == tiny_config.n_runs() == 2 * (2 + 4 + 2)
    assert set(tiny_rows["method"]) == {"libsvm/smo", "numpy/kkt", "clarabel/stacked", "osqp/stacked",
                                        "clarabel/split", "osqp/split", "lu/kkt", "cholesky/cholesky_schur"}
    assert (tiny_rows["error"] == "").all()


def test_tiny_benchmark_success_flags_follow_status_and_certificates(tiny_rows):
    certificates = tiny_rows[["primal_residual", "dual_residual", "duality_gap"]]
    expected = (tiny_rows["status"] == "optimal") & (certificates.fillna(0.0) <= DEFAULT.residual_tol).all(axis=1)
    assert (tiny_rows["success"] == expected).all()
    assert tiny_rows["success"].all()  # these backends solve these small problems


def test_tiny_benchmark_agrees_with_the_references(tiny_rows):
    compared = tiny_rows[~tiny_rows["method"].isin(["libsvm/smo", "numpy/kkt"])]
    assert (compared["objective_gap_rel"].abs() < 1e-6).all()
    assert (compared["prediction_diff_rel"] < 1e-3).all()
    assert (compared["support_agreement"] > 0.9).all()
    svr = compared[compared["problem"] == "epsilon_svr"]
    assert (svr["n_support_reference"] > 0).all()
    assert (tiny_rows.loc[tiny_rows["problem"] == "ls_svr", "prediction_diff_rel"].dropna() < 1e-9).all()


def test_a_perturbed_solution_is_marked_failed(thermal_case):
    K = thermal_case.gram()
    problem = epsilon_svr.dual_split(K, thermal_case.y, thermal_case.C, thermal_case.epsilon)
    solution = solve_qp(problem, "clarabel")
    method = Method("epsilon_svr", "split", "clarabel")

    def row(x):
        point = QPPoint("split", problem, x, solution.y, solution.z, solution.z_box)
        outcome = qp_outcome(thermal_case, point, solution.status, K)
        return evaluate(outcome, method, thermal_case, None, DEFAULT)

    assert row(solution.x)["success"]
    perturbed = solution.x + 1e-3 * np.random.default_rng(6).standard_normal(solution.x.size)
    wrong = row(perturbed)
    assert wrong["status"] == "optimal"  # the solver's word is not enough
    assert not wrong["success"]
    assert max(wrong["primal_residual"], wrong["dual_residual"], wrong["duality_gap"]) > DEFAULT.residual_tol


def test_beta_certificates_equal_the_stacked_qp_certificates(thermal_case):
    """The closed form matches QuadraticProgram.kkt_residuals at the reconstructed multipliers."""
    case = thermal_case
    K = case.gram()
    stacked = epsilon_svr.dual_stacked(K, case.y, case.C, case.epsilon)
    beta = epsilon_svr.beta_from_solution("split", case.n, solve_qp(
        epsilon_svr.dual_split(K, case.y, case.C, case.epsilon), "osqp").x)
    rng = np.random.default_rng(7)
    for trial_beta in (beta, np.clip(beta + 0.05 * rng.standard_normal(case.n), -case.C, case.C)):
        b = epsilon_svr.intercept_from_kkt(K, case.y, trial_beta, case.C, case.epsilon)
        f = K @ trial_beta + b
        x = np.concatenate([np.maximum(-trial_beta, 0.0), np.maximum(trial_beta, 0.0)])
        z_box = np.concatenate([f - case.y - case.epsilon, case.y - f - case.epsilon])
        expected = stacked.kkt_residuals(x, np.array([b]), None, z_box)
        got = beta_certificates(K @ trial_beta, b, case.y, trial_beta, case.C, case.epsilon)
        for key in ("primal_rel", "gap_rel"):
            # The gap is a sum of O(100) terms that cancel: both sides carry ~1e-14 of rounding.
            assert got[key] == pytest.approx(expected[key], rel=1e-9, abs=1e-12)
        assert expected["dual_rel"] < 1e-14
    assert got["gap_rel"] > 1e-3  # the perturbed model is far from optimal, and the gap says so


def test_solver_errors_become_failed_rows(thermal_case, monkeypatch):
    def failing_solve(*args, **kwargs):
        raise SolverError("backend 'clarabel' did not solve it (status: max_iter)", "clarabel", "max_iter")

    monkeypatch.setattr(runners, "solve_qp", failing_solve)  # inherited by the forked child
    outcome = run_isolated(thermal_case, Method("epsilon_svr", "split", "clarabel"), DEFAULT, 30.0)
    assert outcome.status == "max_iter"
    assert "did not solve" in outcome.error
    row = evaluate(outcome, Method("epsilon_svr", "split", "clarabel"), thermal_case, None, DEFAULT)
    assert not row["success"]
    assert math.isnan(row["objective"])


def test_other_exceptions_become_error_rows(thermal_case, monkeypatch):
    monkeypatch.setattr(runners, "solve_qp", lambda *a, **k: 1 / 0)
    outcome = run_isolated(thermal_case, Method("epsilon_svr", "split", "osqp"), DEFAULT, 30.0)
    assert outcome.status == "error"
    assert "ZeroDivisionError" in outcome.error
    assert not is_success(outcome, DEFAULT)


def test_time_limit_kills_the_run_and_skips_larger_n():
    config = BenchConfig(datasets=("thermal",), sizes=(30, 50), d=3, formulations=("split",),
                         backends=("osqp",), time_limit_s=1e-3)
    rows = run_benchmark(config)
    first, second = rows[rows["n"] == 30], rows[rows["n"] == 50]
    assert (first["status"] == "time_limit").all()
    assert (second["status"] == "skipped").all()
    assert not rows["success"].any()
    summary = aggregate(rows, config.time_limit_s)
    assert np.allclose(summary["sgm_time_s"], config.time_limit_s)  # failures charged the limit


def test_shifted_geometric_mean_closed_form():
    assert shifted_geometric_mean([2.0, 2.0]) == pytest.approx(2.0)
    assert shifted_geometric_mean([0.0, 3.0], shift_s=1.0) == pytest.approx(math.sqrt(1.0 * 4.0) - 1.0)


def test_aggregate_charges_failures_at_the_limit():
    rows = pd.DataFrame({"problem": ["p"] * 4, "method": ["a", "a", "b", "b"],
                         "success": [True, False, True, True], "total_time_s": [1.0, 0.5, 1.0, 3.0]})
    summary = aggregate(rows, time_limit_s=10.0, shift_s=1.0).set_index("method")
    assert summary.loc["a", "sgm_time_s"] == pytest.approx(math.sqrt(2.0 * 11.0) - 1.0)
    assert summary.loc["b", "sgm_time_s"] == pytest.approx(math.sqrt(2.0 * 4.0) - 1.0)
    assert summary.loc["b", "sgm_ratio"] == pytest.approx(1.0)
    assert summary.loc["a", "successes"] == 1


def test_outputs_are_written_once_and_describe_the_machine(tiny_config, tiny_rows, tmp_path):
    paths = write_outputs(tiny_rows, tiny_config, tmp_path)
    report = paths["markdown"].read_text()
    for heading in ("## Machine", "architecture", "OPENBLAS_CORETYPE", "## Package versions", "## Limitations",
                    "## Fastest exact method",
                    "scikit-learn", "clarabel"):
        assert heading in report
    assert pd.read_csv(paths["csv"]).shape == tiny_rows.shape
    assert paths["plot"].stat().st_size > 0
    with pytest.raises(FileExistsError, match="--force"):
        write_outputs(tiny_rows, tiny_config, tmp_path)


def test_cli_bench_runs_a_tiny_configuration(tmp_path):
    arguments = ["bench", "--n", "30", "--d", "3", "--datasets", "thermal", "--backends", "osqp",
                 "--formulations", "split", "--output-dir", str(tmp_path)]
    result = CliRunner().invoke(app, arguments)
    assert result.exit_code == 0, result.output
    rows = pd.read_csv(tmp_path / "results.csv")
    assert set(rows["method"]) == {"libsvm/smo", "osqp/split"}
    assert rows["success"].all()
    again = CliRunner().invoke(app, arguments)
    assert again.exit_code != 0 and isinstance(again.exception, FileExistsError)


def test_ratios_pick_the_fastest_exact_method():
    base = {"problem": "epsilon_svr", "dataset": "d", "n": 10, "success": True, "prediction_diff_rel": 0.0}
    rows = pd.DataFrame([
        {**base, "method": "libsvm/smo", "total_time_s": 2.0, "objective_gap_rel": math.nan},
        {**base, "method": "fast/inexact", "total_time_s": 0.1, "objective_gap_rel": 1e-6},
        {**base, "method": "fast/unsolved", "total_time_s": 0.2, "objective_gap_rel": 0.0, "success": False},
        {**base, "method": "exact/a", "total_time_s": 1.0, "objective_gap_rel": -1e-12},
        {**base, "method": "exact/b", "total_time_s": 1.5, "objective_gap_rel": 0.0},
    ])
    table = ratios_to_reference(rows)
    assert table.loc[0, "fastest_exact"] == "exact/a"
    assert table.loc[0, "ratio"] == pytest.approx(0.5)


def test_svrqp_exact_and_low_rank_methods_run_in_the_harness():
    config = BenchConfig(datasets=("thermal",), sizes=(60,), d=3, formulations=("dense", "auto", "low_rank"),
                         backends=("dual_ipm", "clarabel"), time_limit_s=30.0)
    rows = run_benchmark(config).set_index("method")
    assert set(rows.index) == {"libsvm/smo", "dual_ipm/dense", "dual_ipm/auto", "dual_ipm/low_rank",
                               "clarabel/low_rank"}
    for exact in ("dual_ipm/dense", "dual_ipm/auto"):
        assert rows.loc[exact, "success"] and rows.loc[exact, "duality_gap"] < 1e-10
        assert rows.loc[exact, "objective_gap_rel"] <= 1e-8
        assert rows.loc[exact, "approximation_error"] == 0.0
    for approximate in ("dual_ipm/low_rank", "clarabel/low_rank"):
        # The rank is capped at n/4 = 15 here, short of LOW_RANK_TOL: the error is reported, not hidden.
        assert rows.loc[approximate, "approximation_error"] > LOW_RANK_TOL
        assert rows.loc[approximate, "success"]  # certified on the factored problem it solved


def test_methods_reject_names_that_pair_with_nothing():
    with pytest.raises(ProblemError, match="pair with none"):
        methods(("split", "dense"), ("clarabel", "no_such_backend"), "rbf")

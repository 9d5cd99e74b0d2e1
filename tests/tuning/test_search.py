"""Hyper-parameter search: grid CV (shared Gram matrices), GA (pygad), joblib/Dask backends.

Independent references: scikit-learn's ``GridSearchCV`` over our estimators, and a data set
built so that one grid point is clearly best.
"""

from __future__ import annotations

import dataclasses
import warnings

import numpy as np
import pandas as pd
import pytest
from support.problems import diabetes, thermal_two_sensors
from sklearn.model_selection import GridSearchCV, KFold
from sklearn.svm import SVR

from svrqp import LSSVR, EpsilonSVR
from svrqp.exceptions import ProblemError
from svrqp.tuning import (
    Execution,
    Genetic,
    SearchEdgeWarning,
    SearchResult,
    ga_search,
    grid_search,
    plot_convergence,
    plot_grid_scores,
)

#: Shuffled 5-fold CV: the sine set's folds must interpolate, not extrapolate.
SHUFFLED_5_FOLD = KFold(5, shuffle=True, random_state=0)
#: Those folds, every fit in this process.
SERIAL = Execution(cv=SHUFFLED_5_FOLD, backend="sequential")


@pytest.fixture
def sine_wave() -> tuple[np.ndarray, np.ndarray]:
    """One period of sin(2πx) at 40 points on [0, 1] with 0.05 noise.

    Built so that one grid point is clearly best among C ∈ {0.01, 100}, ε ∈ {0.01, 1},
    γ ∈ {0.01, 10, 10⁴}: C = 0.01 caps |β| too low to follow the wave, ε = 1 is a tube as wide
    as the amplitude (the flat model fits), γ = 0.01 is nearly linear over [0, 1] and γ = 10⁴ has
    a width (0.007) below the point spacing (0.026), so only (C=100, ε=0.01, γ=10) fits it
    (CV MSE ≈ 0.002 against ≥ 0.27 for every other point).
    """
    rng = np.random.default_rng(7)
    x = np.linspace(0.0, 1.0, 40)
    return x[:, None], np.sin(2.0 * np.pi * x) + 0.05 * rng.standard_normal(40)


SINE_GRID = {"C": [0.01, 100.0], "epsilon": [0.01, 1.0], "gamma": [0.01, 10.0, 1e4]}


def _with_reference(ours: SearchResult, search: GridSearchCV, keys: list[str]) -> pd.DataFrame:
    reference = pd.DataFrame(search.cv_results_["params"]).astype(float)
    reference["reference_mse"] = -search.cv_results_["mean_test_score"]
    return ours.table.merge(reference, on=keys, validate="one_to_one")


def test_grid_search_picks_the_clearly_best_point(sine_wave):
    X, y = sine_wave
    result = grid_search(X, y, **SINE_GRID, execution=SERIAL)
    assert result.best_params == {"C": 100.0, "epsilon": 0.01, "gamma": 10.0}
    assert result.best_mse < 0.01 < result.table["mse"].iloc[1]
    assert len(result.table) == 12 and result.n_fits == 60
    assert (result.table["failed_folds"] == 0).all()


def test_lssvr_grid_search_picks_the_clearly_best_point(sine_wave):
    X, y = sine_wave
    result = grid_search(X, y, C=SINE_GRID["C"], gamma=SINE_GRID["gamma"], model="lssvr", execution=SERIAL)
    assert result.best_params == {"C": 100.0, "gamma": 10.0}
    assert list(result.table.columns[:2]) == ["C", "gamma"]


def test_grid_search_cv_works_on_epsilon_svr_and_equals_shared_gram_search():
    case = thermal_two_sensors()
    grid = {"C": [1.0, 100.0], "epsilon": [0.05, 0.2], "gamma": [0.1, 2.0]}
    reference = GridSearchCV(EpsilonSVR(), grid, cv=5, scoring="neg_mean_squared_error").fit(case.X, case.y)
    ours = grid_search(case.X, case.y, **grid, execution=Execution(cv=5, backend="sequential"))
    merged = _with_reference(ours, reference, ["C", "epsilon", "gamma"])
    np.testing.assert_allclose(merged["mse"], merged["reference_mse"], rtol=1e-9)
    assert ours.best_params == reference.best_params_


def test_grid_search_cv_works_on_lssvr_and_equals_shared_gram_search():
    case = thermal_two_sensors()
    grid = {"C": [0.5, 50.0], "gamma": [0.1, 2.0]}
    reference = GridSearchCV(LSSVR(), grid, cv=5, scoring="neg_mean_squared_error").fit(case.X, case.y)
    ours = grid_search(case.X, case.y, **grid, model="lssvr", execution=Execution(cv=5, backend="sequential"))
    merged = _with_reference(ours, reference, ["C", "gamma"])
    np.testing.assert_allclose(merged["mse"], merged["reference_mse"], rtol=1e-9)


def test_warm_start_along_c_does_not_change_the_scores():
    case = thermal_two_sensors()
    grid = {"C": [1.0, 10.0, 100.0], "epsilon": [0.2], "gamma": [0.5]}
    osqp = Execution(solver="osqp", backend="sequential")
    cold = grid_search(case.X, case.y, **grid, warm_start=False, execution=osqp)
    warm = grid_search(case.X, case.y, **grid, warm_start=True, execution=osqp)
    np.testing.assert_allclose(warm.table["mse"], cold.table["mse"], rtol=1e-6)


def test_dual_ipm_grid_search_matches_libsvm_grid_search_cv():
    """The fast exact path scores every candidate as GridSearchCV(SVR(tol=1e-8)) does, within DESIGN §3.

    Predictions within δ = 1e-5·std(y) of the reference bound the difference of the mean squared
    errors by 2δ·√MSE + δ² (Cauchy–Schwarz, then Jensen over the folds).
    """
    case = thermal_two_sensors()
    grid = {"C": [10.0, 100.0], "epsilon": [0.05, 0.2], "gamma": [0.1, 2.0]}
    reference = GridSearchCV(SVR(tol=1e-8), grid, cv=5, scoring="neg_mean_squared_error").fit(case.X, case.y)
    ours = grid_search(case.X, case.y, **grid, execution=Execution(cv=5, solver="dual_ipm", backend="sequential"))
    merged = _with_reference(ours, reference, ["C", "epsilon", "gamma"])
    delta = 1e-5 * case.y.std()
    bound = 2 * delta * np.sqrt(merged["reference_mse"]) + delta**2
    assert (np.abs(merged["mse"] - merged["reference_mse"]) <= bound).all()
    assert ours.best_params == reference.best_params_ and (ours.table["failed_folds"] == 0).all()


def test_dual_ipm_warm_start_along_c_gives_the_cold_scores():
    """On diabetes the active set of C = 0.1 guessed for C = 1 ends with every coefficient at ±C
    and Σβ ≠ 0, which the crossover alone accepts; the warm start must reject it (cold = warm)."""
    case = diabetes()
    grid = {"C": [0.1, 1.0, 10.0], "epsilon": [0.05, 0.2], "gamma": [0.1]}
    dual_ipm = Execution(solver="dual_ipm", backend="sequential")
    warm = grid_search(case.X, case.y, **grid, warm_start=True, execution=dual_ipm)
    cold = grid_search(case.X, case.y, **grid, warm_start=False, execution=dual_ipm)
    np.testing.assert_allclose(warm.table["mse"], cold.table["mse"], rtol=1e-9)


def test_best_estimator_refits_with_the_best_parameters(sine_wave):
    X, y = sine_wave
    result = grid_search(X, y, **SINE_GRID, execution=SERIAL)
    model = result.best_estimator().fit(X, y)
    assert isinstance(model, EpsilonSVR)
    assert (model.C, model.epsilon, model.gamma) == (100.0, 0.01, 10.0)
    assert np.mean((model.predict(X) - y) ** 2) < 0.01


def test_ga_with_a_fixed_seed_reproduces_its_search(sine_wave):
    X, y = sine_wave
    first = ga_search(X, y, genetic=Genetic(population=8, generations=3, seed=11), execution=SERIAL)
    again = ga_search(X, y, genetic=Genetic(population=8, generations=3, seed=11), execution=SERIAL)
    other = ga_search(X, y, genetic=Genetic(population=8, generations=3, seed=12), execution=SERIAL)
    assert first.best_params == again.best_params
    pd.testing.assert_frame_equal(first.table, again.table)
    np.testing.assert_array_equal(first.convergence_mse, again.convergence_mse)
    assert not first.table[["C", "epsilon", "gamma"]].equals(other.table[["C", "epsilon", "gamma"]])


def test_ga_convergence_curve_and_search_space(sine_wave):
    X, y = sine_wave
    ranges = {"C_range": (1.0, 1e3), "epsilon_range": (1e-3, 0.1), "gamma": (0.1, 100.0)}
    result = ga_search(X, y, **ranges, genetic=Genetic(population=8, generations=4, seed=11), execution=SERIAL)
    curve = result.convergence_mse
    assert curve.shape == (5,)  # the initial population, then one entry per generation
    assert np.all(np.diff(curve) <= 0)  # one elite is kept: the best never gets worse
    assert curve[-1] == pytest.approx(result.best_mse)
    for name, (low, high) in zip(("C", "epsilon", "gamma"), ranges.values()):
        assert result.table[name].between(low, high).all()
    # S1's un-tuned baseline (C=1, ε=0.5) must lose to the GA's choice.
    baseline = grid_search(X, y, C=[1.0], epsilon=[0.5], gamma=[10.0], execution=SERIAL)
    assert result.best_mse < baseline.best_mse


def test_lssvr_ga_searches_c_and_gamma_only(sine_wave):
    X, y = sine_wave
    result = ga_search(X, y, model="lssvr", gamma=(0.1, 100.0), genetic=Genetic(population=6, generations=2, seed=1),
                       execution=SERIAL)
    assert set(result.best_params) == {"C", "gamma"}
    assert result.table["gamma"].nunique() > 1
    assert isinstance(result.best_estimator(), LSSVR)


def test_ga_tunes_c_and_epsilon_only_by_default_as_s1(sine_wave):
    X, y = sine_wave
    result = ga_search(X, y, genetic=Genetic(population=6, generations=2, seed=3), execution=SERIAL)
    assert result.table["C"].nunique() > 1 and result.table["epsilon"].nunique() > 1
    # γ stays at scikit-learn's "scale", computed here independently by scikit-learn itself.
    from sklearn.svm import SVR

    reference_gamma = SVR(gamma="scale").fit(X, y)._gamma
    assert result.table["gamma"].nunique() == 1
    assert result.table["gamma"].iloc[0] == pytest.approx(reference_gamma, rel=1e-12)
    assert result.best_params["gamma"] == pytest.approx(reference_gamma, rel=1e-12)
    fixed = ga_search(X, y, gamma=10.0, genetic=Genetic(population=6, generations=2, seed=3), execution=SERIAL)
    assert set(fixed.table["gamma"]) == {10.0}
    for bad in (-1.0, "auto", None):
        with pytest.raises(ProblemError, match="gamma must be a positive number, 'scale' or a"):
            ga_search(X, y, gamma=bad, genetic=Genetic(population=4, generations=1))


def test_dask_local_cluster_gives_the_serial_results(sine_wave):
    distributed = pytest.importorskip("distributed")
    X, y = sine_wave
    serial_grid = grid_search(X, y, **SINE_GRID, execution=SERIAL)
    ga_settings = Genetic(population=6, generations=2, seed=5)
    serial_ga = ga_search(X, y, genetic=ga_settings, execution=Execution(cv=3, backend="sequential"))
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=False,
                                  dashboard_address=None) as cluster:
        reported = []
        on_dask = grid_search(X, y, **SINE_GRID, execution=Execution(
            cv=SHUFFLED_5_FOLD, backend="dask", scheduler=cluster.scheduler_address,
            progress=lambda done, total: reported.append((done, total))))
        with distributed.Client(cluster) as client:
            on_client = Execution(cv=3, backend="dask", scheduler=client)
            ga_on_dask = ga_search(X, y, genetic=ga_settings, execution=on_client)
    pd.testing.assert_frame_equal(on_dask.table, serial_grid.table)
    pd.testing.assert_frame_equal(ga_on_dask.table, serial_ga.table)
    assert reported[-1] == (30, 30)  # 6 (γ, ε) chains × 5 folds


def test_plots_label_their_axes_with_units(sine_wave, tmp_path):
    X, y = sine_wave
    grid = grid_search(X, y, **SINE_GRID, execution=SERIAL)
    ga = ga_search(X, y, genetic=Genetic(population=4, generations=2, seed=0),
                   execution=Execution(cv=3, backend="sequential"))
    for figure in (plot_grid_scores(grid, "μm"), plot_convergence(ga, "μm")):
        axes = figure.axes[0]
        assert "μm²" in axes.get_ylabel() and axes.get_xlabel()
        figure.savefig(tmp_path / "plot.png")
        assert (tmp_path / "plot.png").stat().st_size > 0
    with pytest.raises(ProblemError, match="GA"):
        plot_convergence(grid)
    with pytest.raises(ProblemError, match="grid"):
        plot_grid_scores(ga)


@pytest.mark.parametrize(
    ("arguments", "message"),
    [
        ({"C": [1.0, 0.0], "gamma": [1.0]}, "every C must be finite and positive"),
        ({"C": [-5.0], "gamma": [1.0]}, "every C must be finite and positive"),
        ({"C": [], "gamma": [1.0]}, "the C grid is empty"),
        ({"C": [1.0], "gamma": []}, "the gamma grid is empty"),
        ({"C": [1.0], "gamma": [0.0]}, "every gamma must be finite and positive"),
        ({"C": [1.0], "gamma": [1.0], "epsilon": [-0.1]}, "every epsilon must be finite and non-negative"),
        ({"C": [1.0], "gamma": [1.0], "cv": 1}, "folds must be between 2"),
        ({"C": [1.0], "gamma": [1.0], "model": "ridge"}, "model must be one of"),
        ({"C": [1.0], "gamma": [1.0], "backend": "spark"}, "backend must be one of"),
        ({"C": [1.0], "gamma": [1.0], "backend": "dask"}, "needs a scheduler"),
    ],
)
def test_grid_search_rejects_bad_ranges(sine_wave, arguments, message):
    X, y = sine_wave
    searched, run = _split(arguments, Execution)
    with pytest.raises(ProblemError, match=message):
        grid_search(X, y, **searched, execution=Execution(**run))


@pytest.mark.parametrize(
    ("arguments", "message"),
    [
        ({"C_range": (0.0, 10.0)}, "C range must satisfy 0 < low < high"),
        ({"C_range": (10.0, 1.0)}, "C range must satisfy 0 < low < high"),
        ({"gamma": (1.0,)}, r"gamma range must be \(low, high\)"),
        ({"gamma": (1.0, 10.0, 100.0)}, r"gamma range must be \(low, high\)"),
        ({"epsilon_range": (0.0, 1.0)}, "epsilon range must satisfy"),
        ({"population": 1}, "population >= 2"),
        ({"generations": 0}, "generations >= 1"),
        ({"mutation_probability": 1.5}, "mutation_probability must be in"),
        ({"crossover_probability": -0.1}, "crossover_probability must be in"),
    ],
)
def test_ga_search_rejects_bad_ranges(sine_wave, arguments, message):
    X, y = sine_wave
    searched, genetic = _split(arguments, Genetic)
    with pytest.raises(ProblemError, match=message):
        ga_search(X, y, **searched, genetic=Genetic(**genetic))


def _split(arguments: dict, settings: type) -> tuple[dict, dict]:
    """``arguments`` split into the searched keywords and the fields of the dataclass ``settings``."""
    names = {field.name for field in dataclasses.fields(settings)}
    return ({key: value for key, value in arguments.items() if key not in names},
            {key: value for key, value in arguments.items() if key in names})


def test_failed_fits_are_recorded_not_hidden(sine_wave, monkeypatch):
    """A candidate whose solver fails scores inf with its failed folds counted; the rest stand."""
    import svrqp.solvers.qp_backends as solve_module
    from svrqp.exceptions import SolverError

    real_solve_qp = solve_module.solve_qp

    def failing_at_large_c(problem, backend, **kwargs):
        if problem.ub.max() >= 100.0:
            raise SolverError("simulated failure", backend, "max_iter")
        return real_solve_qp(problem, backend, **kwargs)

    monkeypatch.setattr(solve_module, "solve_qp", failing_at_large_c)
    X, y = sine_wave
    clarabel = Execution(cv=SHUFFLED_5_FOLD, solver="clarabel", backend="sequential")
    result = grid_search(X, y, **SINE_GRID, execution=clarabel)
    failed = result.table[result.table["C"] == 100.0]
    assert np.isinf(failed["mse"]).all() and (failed["failed_folds"] == 5).all()
    assert result.best_params["C"] == 0.01
    with pytest.raises(SolverError, match="every candidate"):
        grid_search(X, y, C=[100.0], gamma=[10.0], execution=clarabel)


@pytest.fixture
def sine_wave_csv(sine_wave, tmp_path):
    """The sine-wave set as a CSV table with units in the column names."""
    X, y = sine_wave
    path = tmp_path / "sine.csv"
    pd.DataFrame({"x_mm": X[:, 0], "error_um": y}).to_csv(path, index=False)
    return path


def _svrqp(*argv: str) -> int:
    """Run the ``svrqp`` entry point; its exit code (0 when it returns normally)."""
    from svrqp.cli import main

    try:
        main(list(argv))
    except SystemExit as stop:
        return stop.code
    return 0


def test_cli_tune_grid_writes_best_parameters_and_plot(sine_wave_csv, tmp_path):
    import json

    out_json, out_png = tmp_path / "tune.json", tmp_path / "scores.png"
    argv = [str(sine_wave_csv), "--target", "error_um", "--features", "x_mm", "--C", "0.01,100",
            "--epsilon", "0.01,1", "--gamma", "0.01,10,10000", "--shuffle", "--backend", "sequential",
            "--json", str(out_json), "--plot", str(out_png), "--target-unit", "μm"]
    assert _svrqp("tune", *argv) == 0
    report = json.loads(out_json.read_text())
    assert report["best_params"] == {"C": 100.0, "epsilon": 0.01, "gamma": 10.0}
    assert len(report["candidates"]) == 12 and out_png.stat().st_size > 0
    assert _svrqp("tune", *argv) == 2  # the files exist: no silent overwrite
    assert _svrqp("tune", *argv, "--force") == 0


def test_cli_tune_with_the_dual_ipm_solver_finds_the_clearly_best_point(sine_wave_csv, tmp_path):
    import json

    out_json = tmp_path / "tune.json"
    assert _svrqp("tune", str(sine_wave_csv), "--target", "error_um", "--features", "x_mm", "--C", "0.01,100",
                  "--epsilon", "0.01,1", "--gamma", "0.01,10,10000", "--shuffle", "--backend", "sequential",
                  "--solver", "dual_ipm", "--json", str(out_json)) == 0
    report = json.loads(out_json.read_text())
    assert report["best_params"] == {"C": 100.0, "epsilon": 0.01, "gamma": 10.0}
    assert all(candidate["failed_folds"] == 0 for candidate in report["candidates"])


def test_cli_tune_ga_and_bad_input(sine_wave_csv, capsys):
    assert _svrqp("tune", str(sine_wave_csv), "--target", "error_um", "--features", "x_mm", "--method", "ga",
                  "--population", "4", "--generations", "1", "--folds", "3", "--backend", "sequential") == 0
    assert "ga search" in capsys.readouterr().out
    assert _svrqp("tune", str(sine_wave_csv), "--target", "error_um", "--features", "x_mm", "--C", "0,1") == 2
    assert "every C must be finite and positive" in capsys.readouterr().err


def test_cli_tune_ga_fixes_gamma_unless_given_a_range(sine_wave_csv, tmp_path):
    import json

    common = [str(sine_wave_csv), "--target", "error_um", "--features", "x_mm", "--method", "ga", "--population", "4",
              "--generations", "1", "--folds", "3", "--backend", "sequential"]
    gammas = {}
    for name, extra in (("default", []), ("fixed", ["--gamma", "10"]), ("range", ["--gamma", "1,100"])):
        out_json = tmp_path / f"{name}.json"
        assert _svrqp("tune", *common, *extra, "--json", str(out_json)) == 0
        gammas[name] = {candidate["gamma"] for candidate in json.loads(out_json.read_text())["candidates"]}
    x = np.loadtxt(sine_wave_csv, delimiter=",", skiprows=1, usecols=0)  # the x_mm column
    (default,) = gammas["default"]
    assert default == pytest.approx(1.0 / x.var(), rel=1e-12)  # scikit-learn's "scale"
    assert gammas["fixed"] == {10.0}
    assert len(gammas["range"]) > 1 and all(1.0 <= g <= 100.0 for g in gammas["range"])


def test_a_search_ending_on_its_edge_warns_and_names_the_parameter():
    """A grid whose best C is its largest value says so; the GA's range bounds count the same way."""
    rng = np.random.default_rng(3)
    X = rng.uniform(-1, 1, size=(60, 1))
    y = np.sin(3 * X[:, 0]) + 0.01 * rng.normal(size=60)
    with pytest.warns(SearchEdgeWarning, match=r"C = 0.01 on the upper edge of the searched range \[0.001, 0.01\]"):
        result = grid_search(X, y, C=[0.001, 0.01], gamma=[1.0], epsilon=[0.01])
    assert result.edges() == {"C": "upper"}
    assert result.bounds == {"C": (0.001, 0.01)}  # γ and ε held at one value: no range, no edge


def test_a_search_inside_its_range_stays_silent():
    rng = np.random.default_rng(3)
    X = rng.uniform(-1, 1, size=(60, 1))
    y = np.sin(3 * X[:, 0]) + 0.01 * rng.normal(size=60)
    with warnings.catch_warnings():
        warnings.simplefilter("error", SearchEdgeWarning)
        result = grid_search(X, y, C=[1.0, 10.0, 1e5], gamma=[1.0], epsilon=[0.001, 0.01, 0.5])
    assert result.best_params["C"] == 10.0 and result.edges() == {}
    assert result.edge_text() == ""

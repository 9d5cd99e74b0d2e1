"""EpsilonSVR and LSSVR as scikit-learn estimators: the estimator checks, bad input, properties."""

import warnings

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays
from sklearn.model_selection import GridSearchCV
from sklearn.utils.estimator_checks import parametrize_with_checks
from support.epsilon_svr_reference import (
    assert_kkt,
    assert_matches_reference,
    full_beta,
    linear,
    reference,
)
from support.problems import SVR_CASES, thermal_two_sensors

from svrqp import LSSVR, EpsilonSVR, ProblemError, SolverError, SvrqpError
from svrqp.formulations.epsilon_svr_certificate import dual_qp_point, multipliers
from svrqp.kernels import gram
from svrqp.solvers.dual_ipm.certified import solve_dual_ipm
from svrqp.solvers.dual_qp import DualSettings

X_OK = np.linspace(0.0, 1.0, 20)[:, None]
Y_OK = np.sin(6.0 * X_OK[:, 0])


@parametrize_with_checks([EpsilonSVR(), EpsilonSVR(solver="dual_ipm"), LSSVR()])
def test_scikit_learn_estimator_checks(estimator, check):
    check(estimator)


def test_fitted_attributes_and_latex():
    model = EpsilonSVR(C=10.0, epsilon=0.05).fit(X_OK, Y_OK)
    assert model.dual_coef_.shape == (1, model.support_.size)
    assert model.support_vectors_.shape == (model.support_.size, 1)
    assert model.intercept_.shape == (1,)
    assert model.solution_.backend == model.solver_ == "smo_crossover"  # solver="auto" chose it
    assert r"\alpha^*" in model.problem_.to_latex()


def test_works_inside_grid_search():
    search = GridSearchCV(EpsilonSVR(epsilon=0.05), {"C": [0.1, 10.0]}, cv=3).fit(X_OK, Y_OK)
    assert search.best_params_["C"] == 10.0


@pytest.mark.parametrize("Model", [EpsilonSVR, LSSVR])
@pytest.mark.parametrize("X, y, word", [
    (np.array([[np.nan], [1.0], [2.0]]), np.ones(3), "NaN"),
    (np.array([[np.inf], [1.0], [2.0]]), np.ones(3), "infinity"),
    (X_OK, np.r_[Y_OK[:-1], np.nan], "NaN"),
    (X_OK, Y_OK[:-1], "inconsistent numbers of samples"),
    (np.array([[1.0]]), np.ones(1), "1 sample"),
    (np.empty((0, 1)), np.empty(0), "0 sample"),
    (np.array([["a"], ["b"]], dtype=object), np.ones(2), "X holds text"),
])
def test_bad_data_is_a_value_error(Model, X, y, word):
    with pytest.raises(ValueError, match=word):
        Model().fit(X, y)


@pytest.mark.parametrize("params, word", [
    ({"C": 0.0}, "'C' parameter"), ({"C": -1.0}, "'C' parameter"), ({"epsilon": -0.1}, "'epsilon'"),
    ({"gamma": 0.0}, "'gamma'"), ({"gamma": -2.0}, "'gamma'"), ({"kernel": "sigmoid"}, "'kernel'"),
    ({"solver": "nope"}, "'solver'"), ({"formulation": "primal"}, "kernel='linear'"),
])
def test_bad_parameters_name_the_parameter(params, word):
    with pytest.raises(ValueError, match=word):
        EpsilonSVR(**params).fit(X_OK, Y_OK)


@pytest.mark.parametrize("Model", [EpsilonSVR, LSSVR])
def test_non_psd_precomputed_kernel_is_rejected(Model):
    K = np.array([[1.0, 2.0, 0.0], [2.0, 1.0, 0.0], [0.0, 0.0, 1.0]])
    with pytest.raises(ValueError, match="positive semidefinite"):
        Model(kernel="precomputed").fit(K, np.array([1.0, 2.0, 3.0]))


@pytest.mark.parametrize("solver", ["clarabel", "dual_ipm"])
def test_precomputed_kernel_equals_the_built_in_one(solver):
    built_in = EpsilonSVR(C=10.0, gamma=2.0, solver=solver).fit(X_OK, Y_OK)
    K = gram(X_OK, gamma=2.0)
    pre = EpsilonSVR(C=10.0, kernel="precomputed", solver=solver).fit(K, Y_OK)
    np.testing.assert_allclose(pre.predict(K), built_in.predict(X_OK), atol=1e-9)


finite = st.floats(-1e3, 1e3, allow_nan=False, allow_infinity=False)
wild = st.floats(allow_nan=True, allow_infinity=True, width=64)


@settings(max_examples=200, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    X=arrays(np.float64, st.tuples(st.integers(0, 12), st.integers(1, 3)), elements=st.one_of(finite, wild)),
    y_seed=st.integers(0, 2**32 - 1),
    C=st.floats(-1.0, 1e4),
    epsilon=st.floats(-0.5, 2.0),
    solver=st.sampled_from(["clarabel", "dual_ipm"]),
)
def test_property_epsilon_svr_raises_only_library_errors_and_never_returns_nan(X, y_seed, C, epsilon, solver):
    y = np.random.default_rng(y_seed).normal(size=X.shape[0])
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        try:
            predictions = EpsilonSVR(C=C, epsilon=epsilon, gamma=1.0, solver=solver).fit(X, y).predict(X)
        except (ValueError, SvrqpError):
            return
    assert np.all(np.isfinite(predictions))


@settings(max_examples=100, deadline=None)
@given(
    X=arrays(np.float64, st.tuples(st.integers(0, 12), st.integers(1, 3)), elements=st.one_of(finite, wild)),
    C=st.floats(-1.0, 1e6),
)
def test_property_ls_svr_raises_only_library_errors_and_never_returns_nan(X, C):
    y = np.arange(X.shape[0], dtype=float)
    try:
        predictions = LSSVR(C=C, gamma=1.0).fit(X, y).predict(X)
    except (ValueError, SvrqpError):
        return
    assert np.all(np.isfinite(predictions))


@pytest.mark.parametrize("Model", [EpsilonSVR, LSSVR])
def test_model_export_round_trips_through_verify(Model, tmp_path):
    from svrqp.export import predict as predict_from_file
    from svrqp.export import export_model, read_document, verify

    model = Model(C=10.0).fit(X_OK, Y_OK)
    [path] = export_model(model, tmp_path / "model.json", X=X_OK, y=Y_OK, feature_names=["x_mm"], target_name="error_um")
    assert verify(path).ok
    np.testing.assert_allclose(predict_from_file(read_document(path), X_OK), model.predict(X_OK), rtol=0, atol=1e-12)


@pytest.mark.parametrize("case_factory", SVR_CASES, ids=lambda f: f.__name__)
@pytest.mark.parametrize("kernel", ["rbf", "linear"])
@pytest.mark.parametrize("formulation", ["split", "stacked"])
def test_dual_ipm_matches_libsvm_and_is_certified_on_the_qp(case_factory, kernel, formulation):
    """The fast exact path meets DESIGN §3 against SVR(tol=1e-8), and the QP it names certifies it."""
    case = case_factory() if kernel == "rbf" else linear(case_factory())
    model = EpsilonSVR(C=case.C, epsilon=case.epsilon, gamma=case.gamma, kernel=kernel, solver="dual_ipm",
                       formulation=formulation).fit(case.X, case.y)
    assert model.solution_.backend == "dual_ipm" and model.solution_.status == "optimal"
    assert model.problem_.name.startswith(f"epsilon-SVR dual, {formulation}")
    assert model.solution_.is_optimal(1e-10)  # the crossover's optimum: certificates at rounding level
    K = gram(case.X, kernel=kernel, gamma=case.gamma)
    assert_kkt(K, case.y, full_beta(model, len(case.y)), model.intercept_[0], case.C, case.epsilon, 1e-6)
    assert_matches_reference(model, reference(case, kernel=kernel), case, K)


def test_dual_ipm_certificates_catch_a_wrong_solution():
    """The QP residuals at a perturbed β are large, and an unmeetable check_tol raises naming the solver."""
    case = thermal_two_sensors()
    K = gram(case.X, gamma=case.gamma)
    fit = solve_dual_ipm(K, case.y, case.C, case.epsilon)
    beta = 0.9 * fit.beta
    x, y_eq, z_box = dual_qp_point("split", multipliers(beta, fit.intercept, K @ beta, case.y, case.epsilon), case.C)
    residuals = fit.problem.kkt_residuals(x, y_eq, None, z_box)
    assert max(residuals["dual_rel"], residuals["gap_rel"]) > 1e-3
    with pytest.raises(SolverError, match="'dual_ipm'.*certificate"):
        solve_dual_ipm(K, case.y, case.C, case.epsilon, DualSettings(check_tol=1e-300))


def test_dual_ipm_rejects_the_primal_formulation():
    with pytest.raises(ProblemError, match="dual_ipm.*formulation"):
        EpsilonSVR(kernel="linear", solver="dual_ipm", formulation="primal").fit(X_OK, Y_OK)


def test_dual_ipm_takes_an_integer_c_above_the_int8_range():
    """C = 1000 given as an int: the crossover stores its states as int8 and must see a float C."""
    ints = EpsilonSVR(C=1000, epsilon=0.05, solver="dual_ipm").fit(X_OK, Y_OK)
    floats = EpsilonSVR(C=1000.0, epsilon=0.05, solver="dual_ipm").fit(X_OK, Y_OK)
    np.testing.assert_array_equal(ints.predict(X_OK), floats.predict(X_OK))


def test_dual_ipm_model_exports_and_verifies(tmp_path):
    from svrqp.export import export_model, verify

    model = EpsilonSVR(C=10.0, solver="dual_ipm").fit(X_OK, Y_OK)
    [path] = export_model(model, tmp_path / "model.json", X=X_OK, y=Y_OK, feature_names=["x_mm"], target_name="error_um")
    report = verify(path)
    assert report.ok, [check for check in report.checks if not check.ok]


def test_lssvr_leaves_a_precomputed_kernel_untouched():
    """The Cholesky factorisation works in place on svrqp's own Gram matrix, never on the caller's."""
    case = thermal_two_sensors()
    K = gram(case.X, gamma=case.gamma)
    before = K.copy()
    LSSVR(C=10.0, kernel="precomputed").fit(K, case.y)
    np.testing.assert_array_equal(K, before)


def test_dual_ipm_estimator_on_smooth_data_takes_the_low_rank_path_and_matches_libsvm():
    """1500 samples of the S0-like warm-up set (10 temperatures, few support vectors): the fit goes
    through a low-rank interior point and the exact crossover, and agrees with SVR(tol=1e-8)."""
    from sklearn.svm import SVR

    from svrqp.bench import cases as bench

    X, y = bench.thermal(1500, 10, seed=0)
    ours = EpsilonSVR(C=10.0, epsilon=0.1, solver="dual_ipm").fit(X, y)
    reference = SVR(C=10.0, epsilon=0.1, tol=1e-8).fit(X, y)
    assert ours.solution_.settings["crossover_exact"]
    assert ours.solution_.settings["low_rank_path"]
    assert np.max(np.abs(ours.predict(X) - reference.predict(X))) <= 1e-5 * y.std()
    assert ours.solution_.residuals["gap_rel"] <= 1e-10

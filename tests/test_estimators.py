"""EpsilonSVR and LSSVR as scikit-learn estimators: the estimator checks, bad input, properties."""

import warnings

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays
from sklearn.model_selection import GridSearchCV
from sklearn.utils.estimator_checks import parametrize_with_checks

from svrqp import LSSVR, EpsilonSVR, SvrqpError

X_OK = np.linspace(0.0, 1.0, 20)[:, None]
Y_OK = np.sin(6.0 * X_OK[:, 0])


@parametrize_with_checks([EpsilonSVR(), LSSVR()])
def test_scikit_learn_estimator_checks(estimator, check):
    check(estimator)


def test_fitted_attributes_and_latex():
    model = EpsilonSVR(C=10.0, epsilon=0.05).fit(X_OK, Y_OK)
    assert model.dual_coef_.shape == (1, model.support_.size)
    assert model.support_vectors_.shape == (model.support_.size, 1)
    assert model.intercept_.shape == (1,)
    assert model.solution_.backend == "clarabel"
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
    (np.array([["a"], ["b"]], dtype=object), np.ones(2), "could not convert"),
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


def test_precomputed_kernel_equals_the_built_in_one():
    from svrqp.kernels import gram

    built_in = EpsilonSVR(C=10.0, gamma=2.0).fit(X_OK, Y_OK)
    K = gram(X_OK, gamma=2.0)
    pre = EpsilonSVR(C=10.0, kernel="precomputed").fit(K, Y_OK)
    np.testing.assert_allclose(pre.predict(K), built_in.predict(X_OK), atol=1e-9)


finite = st.floats(-1e3, 1e3, allow_nan=False, allow_infinity=False)
wild = st.floats(allow_nan=True, allow_infinity=True, width=64)


@settings(max_examples=120, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    X=arrays(np.float64, st.tuples(st.integers(0, 12), st.integers(1, 3)), elements=st.one_of(finite, wild)),
    y_seed=st.integers(0, 2**32 - 1),
    C=st.floats(-1.0, 1e4),
    epsilon=st.floats(-0.5, 2.0),
)
def test_property_epsilon_svr_raises_only_library_errors_and_never_returns_nan(X, y_seed, C, epsilon):
    y = np.random.default_rng(y_seed).normal(size=X.shape[0])
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        try:
            predictions = EpsilonSVR(C=C, epsilon=epsilon, gamma=1.0).fit(X, y).predict(X)
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
    from svrqp.export import read_document, verify
    from svrqp.export import predict as predict_from_file

    model = Model(C=10.0).fit(X_OK, Y_OK)
    [path] = model.export(tmp_path / "model.json", X=X_OK, y=Y_OK, feature_names=["x_mm"], target_name="error_um")
    assert verify(path).ok
    np.testing.assert_allclose(predict_from_file(read_document(path), X_OK), model.predict(X_OK), rtol=0, atol=1e-12)

"""The baseline of the gap diagnosis (svrqp.gap.model.baseline) against independent references."""

import numpy as np
import pytest
from support.gap_problems import CANDIDATES, air_lag_problem
from sklearn.linear_model import LinearRegression
from sklearn.svm import SVR

from svrqp.exceptions import ProblemError
from svrqp.gap.data.prepare import prepare
from svrqp.gap.model.baseline import LSSVR_C, SVR_C, SVR_EPSILON, fit_baseline
from svrqp.gap.question import GapQuestion

FEATURES = ["spindle_C", "nut_C"]


@pytest.fixture(scope="module")
def data():
    """The air-lag problem, a two-feature model fitted on run r0 (240 rows)."""
    question = GapQuestion(target="error_um", train="run == 'r0'", features=FEATURES,
                           candidates=[c for c in CANDIDATES if c not in FEATURES], order="time_min", group="run")
    return prepare(air_lag_problem(), question)


def standardised(data):
    """Train-row standardisation of the features and the target, as the documented pipeline does."""
    train = data.is_train
    mean, std = data.X[train].mean(axis=0), data.X[train].std(axis=0)
    y_mean, y_std = data.y[train].mean(), data.y[train].std()
    return (data.X - mean) / std, (data.y - y_mean) / y_std, y_mean, y_std


def test_mlr_baseline_is_ordinary_least_squares(data):
    baseline = fit_baseline(data, "mlr")
    reference = LinearRegression().fit(data.X[data.is_train], data.y[data.is_train]).predict(data.X)
    np.testing.assert_allclose(baseline.y_hat, reference, atol=1e-9 * np.abs(data.y).max())
    np.testing.assert_allclose(baseline.residual, data.y - baseline.y_hat)


def test_svr_baseline_matches_libsvm(data):
    Z, t, y_mean, y_std = standardised(data)
    train = data.is_train
    reference = SVR(C=SVR_C, epsilon=SVR_EPSILON, gamma=1.0 / Z.shape[1], tol=1e-8).fit(Z[train], t[train])
    expected = y_mean + y_std * reference.predict(Z)
    np.testing.assert_allclose(fit_baseline(data, "svr").y_hat, expected, atol=1e-5 * data.y[train].std())


def test_lssvr_baseline_solves_the_kkt_system(data):
    """S4 eqs. (4)–(7): [[0, 1ᵀ], [1, K + I/C]]·[b; α] = [0; y], solved here by numpy."""
    Z, t, y_mean, y_std = standardised(data)
    train = data.is_train
    Zt = Z[train]
    gamma = 1.0 / Z.shape[1]
    K = np.exp(-gamma * ((Zt[:, None, :] - Zt[None, :, :]) ** 2).sum(axis=2))
    n = train.sum()
    M = np.block([[np.zeros((1, 1)), np.ones((1, n))], [np.ones((n, 1)), K + np.eye(n) / LSSVR_C]])
    b, *alpha = np.linalg.solve(M, np.concatenate([[0.0], t[train]]))
    K_all = np.exp(-gamma * ((Z[:, None, :] - Zt[None, :, :]) ** 2).sum(axis=2))
    expected = y_mean + y_std * (K_all @ np.array(alpha) + b)
    np.testing.assert_allclose(fit_baseline(data, "lssvr").y_hat, expected, atol=1e-8 * data.y[train].std())


def test_unknown_model_kind_is_named(data):
    with pytest.raises(ProblemError, match="model: unknown kind 'gp'"):
        fit_baseline(data, "gp")

"""``svrqp.Guarded``: coverage on a seeded problem, group-aware folds, the domain guard, bad input."""

from __future__ import annotations

import math
import warnings

import numpy as np
import pandas as pd
import pytest
from scipy.spatial.distance import mahalanobis as scipy_mahalanobis
from sklearn.cluster import KMeans
from sklearn.linear_model import LinearRegression
from sklearn.pipeline import make_pipeline
from sklearn.preprocessing import StandardScaler
from sklearn.utils.estimator_checks import parametrize_with_checks

from svrqp import EpsilonSVR, ExtrapolationWarning, Guarded
from svrqp.exceptions import ProblemError, SvrqpError
from svrqp.guard import GroupFallbackWarning
from svrqp.estimators import LinearLS


def sine_problem(n: int, seed: int) -> tuple[pd.DataFrame, np.ndarray]:
    """y = sin(3 x0) + 0.5 x1 + N(0, 0.1²), x uniform on [-1, 1]²: i.i.d. rows."""
    rng = np.random.default_rng(seed)
    X = pd.DataFrame(rng.uniform(-1, 1, (n, 2)), columns=["T7_C", "T9_C"])
    return X, np.sin(3 * X["T7_C"].to_numpy()) + 0.5 * X["T9_C"].to_numpy() + rng.normal(0, 0.1, n)


@pytest.fixture(scope="module")
def fitted() -> Guarded:
    X, y = sine_problem(300, 1)
    return Guarded(make_pipeline(StandardScaler(), EpsilonSVR(C=10.0, epsilon=0.05, gamma=0.5)), coverage=0.9).fit(X, y)


def covered(model: Guarded, X, y) -> float:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ExtrapolationWarning)
        interval = model.predict_interval(X)
    return float(np.mean((y >= interval[:, 0]) & (y <= interval[:, 1])))


def test_coverage_on_a_seeded_iid_problem(fitted):
    X, y = sine_problem(4000, 2)
    assert abs(covered(fitted, X, y) - 0.9) <= 0.03


def test_quantile_is_the_conformal_order_statistic(fitted):
    """crepes' quantile equals the ⌈(n+1)(1-α)⌉-th smallest score, computed here with numpy."""
    scores = fitted.calibration_.scores
    rank = math.ceil((len(scores) + 1) * 0.9)
    assert fitted.calibration_.quantile == np.sort(scores)[rank - 1]


def test_normalized_intervals_follow_the_noise():
    """Noise growing with x0: the normalised interval is wider where the noise is, and covers."""
    rng = np.random.default_rng(3)
    X = rng.uniform(0, 1, (400, 1))
    noise = 0.02 + 0.5 * X[:, 0]
    y = 2 * X[:, 0] + rng.normal(0, 1, 400) * noise
    model = Guarded(LinearRegression(), coverage=0.8, method="normalized").fit(X, y)
    interval = model.predict_interval(np.array([[0.05], [0.95]]))
    width = interval[:, 1] - interval[:, 0]
    assert width[1] > 5 * width[0]
    X_test = rng.uniform(0, 1, (4000, 1))
    y_test = 2 * X_test[:, 0] + rng.normal(0, 1, 4000) * (0.02 + 0.5 * X_test[:, 0])
    assert abs(covered(model, X_test, y_test) - 0.8) <= 0.04


def test_group_folds_hold_out_whole_groups():
    X, y = sine_problem(120, 4)
    groups = np.repeat(["a", "b", "c", "d", "e", "f"], 20)
    model = Guarded(LinearLS(), n_splits=10).fit(X, y, groups=groups)
    assert model.calibration_.folds == "leave-one-group-out" and model.calibration_.n_splits == 6
    assert model.calibration_.groups == ("a", "b", "c", "d", "e", "f")
    model = Guarded(LinearLS(), n_splits=3).fit(X, y, groups=groups)
    assert model.calibration_.folds == "3-fold by group"


def test_too_few_groups_say_so_and_fall_back():
    X, y = sine_problem(120, 4)
    with pytest.warns(GroupFallbackWarning, match="2 group"):
        model = Guarded(LinearLS(), min_groups=3).fit(X, y, groups=np.repeat([1, 2], 60))
    assert model.calibration_.folds == "10 contiguous row folds" and model.calibration_.groups is None


def test_predict_warns_outside_and_is_silent_inside(fitted):
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        fitted.predict(pd.DataFrame({"T7_C": [0.0, 0.5], "T9_C": [0.0, -0.5]}))
    with pytest.warns(ExtrapolationWarning, match="1 of 2 row"):
        fitted.predict(pd.DataFrame({"T7_C": [0.0, 1.5], "T9_C": [0.0, 0.0]}))
    with pytest.warns(ExtrapolationWarning):
        fitted.predict_interval(pd.DataFrame({"T7_C": [0.0], "T9_C": [-3.0]}))


def test_check_domain_says_which_inputs_and_by_how_much(fitted):
    table = fitted.check_domain(pd.DataFrame({"T7_C": [0.0, 1.5, -2.0], "T9_C": [0.0, 0.0, 3.0]}))
    low, high = fitted.domain_.low, fitted.domain_.high
    assert table["outside"].tolist() == [False, True, True]
    assert table["inputs_outside"].tolist() == ["", "T7_C", "T7_C, T9_C"]
    assert table.loc[1, "excess_T7_C"] == pytest.approx(1.5 - high[0], abs=1e-15)
    assert table.loc[2, "excess_T7_C"] == pytest.approx(-2.0 - low[0], abs=1e-15)
    assert table.loc[2, "excess_T9_C"] == pytest.approx(3.0 - high[1], abs=1e-15)


def test_distance_flags_a_combination_never_seen():
    """Two correlated sensors that disagree, each inside its own range, are outside."""
    rng = np.random.default_rng(5)
    t = rng.uniform(20, 30, 200)
    X = np.column_stack([t, t + rng.normal(0, 0.1, 200)])
    model = Guarded(LinearRegression()).fit(X, 2 * t + rng.normal(0, 0.1, 200))
    table = model.check_domain(np.array([[21.0, 29.0], [25.0, 25.05]]))
    assert table["outside"].tolist() == [True, False] and table["inputs_outside"].tolist() == ["", ""]


def test_distance_matches_scipy(fitted):
    X, _ = sine_problem(300, 1)
    Z = (X.to_numpy() - X.to_numpy().mean(axis=0)) / X.to_numpy().std(axis=0)
    inverse = np.linalg.inv(np.cov(Z, rowvar=False, bias=True))
    points = np.array([[0.3, -0.2], [1.4, 0.9]])
    reference = [scipy_mahalanobis((p - X.to_numpy().mean(axis=0)) / X.to_numpy().std(axis=0), np.zeros(2), inverse)
                 for p in points]
    np.testing.assert_allclose(fitted.domain_.distance(points), reference, rtol=1e-12)
    assert fitted.domain_.threshold >= max(fitted.domain_.distance(X.to_numpy()))
    assert not fitted.domain_.outside(X.to_numpy()).any()


def test_works_with_scikit_learn_and_svrqp_regressors_and_arrays():
    X, y = sine_problem(100, 6)
    for estimator in (LinearRegression(), EpsilonSVR(C=1.0, epsilon=0.1), LinearLS()):
        model = Guarded(estimator, coverage=0.8).fit(X.to_numpy(), y)
        assert model.predict_interval(X.to_numpy()[:5]).shape == (5, 2)
        assert model.domain_.names == ("x0", "x1") and not hasattr(model, "feature_names_in_")


@pytest.mark.parametrize("coverage", [0.0, 1.0, 1.5, -0.1, "0.9", True, float("nan")])
def test_coverage_outside_0_1_is_refused(coverage):
    X, y = sine_problem(50, 7)
    with pytest.raises(ProblemError, match="coverage"):
        Guarded(LinearLS(), coverage=coverage).fit(X, y)


def test_bad_input_is_refused_with_clear_errors():
    X, y = sine_problem(50, 7)
    with pytest.raises(ProblemError, match="regressor"):
        Guarded(KMeans(n_clusters=2)).fit(X, y)
    holed = X.copy()
    holed.iloc[[3, 9], 0] = np.nan
    with pytest.raises(ProblemError, match=r"2 row\(s\) hold NaN.*\[3, 9\]"):
        Guarded(LinearLS()).fit(holed, y)
    with pytest.raises(ProblemError, match="y contains NaN"):
        Guarded(LinearLS()).fit(X, np.where(np.arange(50) == 4, np.nan, y))
    with pytest.raises(ProblemError, match="at least 99 calibration rows"):
        Guarded(LinearLS(), coverage=0.99).fit(X, y)
    with pytest.raises(ProblemError, match="method"):
        Guarded(LinearLS(), method="quantile").fit(X, y)
    with pytest.raises(ProblemError, match="groups"):
        Guarded(LinearLS()).fit(X, y, groups=np.where(np.arange(50) < 25, 1.0, np.nan))
    model = Guarded(LinearLS()).fit(X, y)
    with pytest.raises(ProblemError, match="NaN"):
        model.predict(holed)
    with pytest.raises(SvrqpError, match="feature names should match"):
        model.predict(X.rename(columns={"T9_C": "T8_C"}))


@parametrize_with_checks([Guarded(LinearRegression()), Guarded(LinearLS(), method="normalized")])
def test_scikit_learn_estimator_manners(estimator, check):
    check(estimator)

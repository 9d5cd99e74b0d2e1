"""scikit-learn regressors LinearLS, PolynomialLS and RecursiveLS.

Cross-checks: ``LinearRegression`` and ``numpy.polynomial.Polynomial.fit``; scikit-learn's
estimator checks; the real FL_THERMAL measurements.
"""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
from sklearn.exceptions import NotFittedError
from sklearn.linear_model import LinearRegression
from sklearn.utils.estimator_checks import parametrize_with_checks
from support.paths import FL_THERMAL

from svrqp.estimators import LinearLS, PolynomialLS, RecursiveLS, merge_models
from svrqp.exceptions import ProblemError, SingularSystemError

#: scikit-learn checks that feed PolynomialLS several input columns. PolynomialLS is S2 eq.
#: (22), a polynomial in ONE variable, and rejects them with ProblemError by design; these
#: checks cannot apply. Every other check runs on it.
_MULTI_FEATURE_CHECKS = (
    "check_fit_score_takes_y", "check_estimators_overwrite_params",
    "check_dont_overwrite_parameters", "check_estimators_fit_returns_self",
    "check_readonly_memmap_input", "check_n_features_in_after_fitting",
    "check_positive_only_tag_during_fit", "check_estimators_dtypes", "check_dtype_object",
    "check_pipeline_consistency", "check_estimators_nan_inf", "check_estimators_pickle",
    "check_f_contiguous_array_estimator", "check_regressors_train",
    "check_regressor_data_not_an_array", "check_regressors_no_decision_function",
    "check_supervised_y_2d", "check_regressors_int", "check_methods_sample_order_invariance",
    "check_methods_subset_invariance", "check_fit2d_1sample", "check_dict_unchanged",
    "check_fit_idempotent", "check_fit_check_is_fitted", "check_n_features_in",
    "check_fit2d_predict1d",
)


def _expected_failed_checks(estimator) -> dict[str, str]:
    if isinstance(estimator, PolynomialLS):
        return {name: "passes several features; PolynomialLS models one variable (S2 eq. 22)"
                for name in _MULTI_FEATURE_CHECKS}
    return {}


@parametrize_with_checks([LinearLS(), LinearLS(fit_intercept=False), PolynomialLS(),
                          RecursiveLS(), RecursiveLS(forgetting=0.9)],
                         expected_failed_checks=_expected_failed_checks)
def test_scikit_learn_conventions(estimator, check):
    check(estimator)


@pytest.fixture
def s0_summer_batch() -> tuple[pd.DataFrame, pd.Series]:
    """S0's batch x1 as a table: spindle-box T7 warming 30 → 38 °C and ambient T9 near 30 °C
    over 250 min; the axial error follows S0 eq. (5) exactly (no noise), so the fit must
    print the paper's formula."""
    time_min = np.linspace(0.0, 250.0, 60)
    X = pd.DataFrame({
        "T7_C": 30.0 + 8.0 * (1.0 - np.exp(-time_min / 60.0)),
        "T9_C": 30.0 + 0.8 * np.sin(time_min / 40.0) + 0.1 * np.cos(time_min / 7.0),
    })
    y = pd.Series(3.7674 * X.T7_C - 0.4237 * X.T9_C - 2.7669, name="S_um")
    return X, y


@pytest.fixture(scope="module")
def fl_thermal() -> pd.DataFrame:
    """The real FL_THERMAL run (11,115 rows, 15 s apart): displacement ch1 and 16 temperatures."""
    return pd.read_csv(FL_THERMAL)


def test_linear_ls_equals_linear_regression(s0_summer_batch):
    X, y = s0_summer_batch
    noisy = y + 0.3 * np.sin(np.arange(len(y)) * 1.7)
    ours = LinearLS().fit(X, noisy)
    reference = LinearRegression().fit(X, noisy)
    np.testing.assert_allclose(ours.coef_, reference.coef_, rtol=1e-10)
    np.testing.assert_allclose(ours.intercept_, reference.intercept_, rtol=1e-10)
    np.testing.assert_allclose(ours.predict(X), reference.predict(X), rtol=1e-12)


def test_linear_ls_on_real_thermal_data_equals_linear_regression(fl_thermal):
    temperatures = [c for c in fl_thermal.columns if c.startswith("t")]
    X, y = fl_thermal[temperatures], fl_thermal["ch1(um)"]
    ours = LinearLS().fit(X, y)
    reference = LinearRegression().fit(X, y)
    np.testing.assert_allclose(ours.coef_, reference.coef_, rtol=1e-9)
    np.testing.assert_allclose(ours.intercept_, reference.intercept_, rtol=1e-9)


def test_formula_and_coefficient_table(s0_summer_batch):
    X, y = s0_summer_batch
    model = LinearLS().fit(X, y)
    assert model.to_latex(target_symbol="S") == r"S = 3.7674\,T_7 - 0.4237\,T_9 - 2.7669"
    assert model.to_latex(digits=2) == r"S = 3.77\,T_7 - 0.42\,T_9 - 2.77"
    table = model.coefficient_table()
    assert list(table.columns) == ["name", "value", "unit"]
    assert table.name.tolist() == ["T7_C", "T9_C", "intercept"]
    assert table.unit.tolist() == ["μm/°C", "μm/°C", "μm"]
    np.testing.assert_allclose(table.value, [3.7674, -0.4237, -2.7669], rtol=1e-10)


def test_formula_without_names_or_intercept(s0_summer_batch):
    X, y = s0_summer_batch
    model = LinearLS(fit_intercept=False).fit(X.to_numpy(), y.to_numpy())
    formula = model.to_latex()
    assert formula.startswith(r"y = ") and r"\,x_0" in formula and r"\,x_1" in formula
    assert model.coefficient_table().unit.tolist() == ["", "", ""]


def test_linear_ls_errors(s0_summer_batch):
    X, y = s0_summer_batch
    with pytest.raises(SingularSystemError, match=r"'T7_C'.*'T7_copy'"):
        LinearLS().fit(X.assign(T7_copy=X.T7_C), y)
    with pytest.raises(SingularSystemError, match=r"constant column.*'T3_C'"):
        LinearLS().fit(X.assign(T3_C=21.0), y)
    with pytest.raises(ProblemError, match="X contains 1 non-finite"):
        LinearLS().fit(X.assign(T9_C=X.T9_C.where(X.index != 4)), y)
    least_norm = LinearLS(rank_deficient="lstsq").fit(X.assign(T7_copy=X.T7_C), y)
    np.testing.assert_allclose(least_norm.predict(X.assign(T7_copy=X.T7_C)), y, rtol=1e-9)


def test_polynomial_ls_equals_numpy_polynomial_fit():
    """S2's δx at 11 positions over 0–550 mm, 5th-order least squares."""
    x_mm = np.linspace(0.0, 550.0, 11)
    delta_x_um = 0.012 * x_mm + 1.5 * np.sin(2 * np.pi * x_mm / 275.0)
    model = PolynomialLS(degree=5).fit(x_mm[:, None], delta_x_um)
    reference = np.polynomial.Polynomial.fit(x_mm, delta_x_um, 5)
    fine_mm = np.linspace(0.0, 550.0, 111)
    np.testing.assert_allclose(model.predict(fine_mm[:, None]), reference(fine_mm), atol=1e-12)
    np.testing.assert_allclose(model.to_polynomial().coef, reference.coef, atol=1e-12)
    assert model.condition_number_ < 100.0


def test_polynomial_ls_rejects_several_features(s0_summer_batch):
    X, y = s0_summer_batch
    with pytest.raises(ProblemError, match="one variable; X has 2 features"):
        PolynomialLS().fit(X, y)


def _batch_reference(X, y) -> np.ndarray:
    reference = LinearRegression().fit(X, y)
    return np.r_[reference.intercept_, reference.coef_]


def test_recursive_ls_sample_by_sample_equals_batch(s0_summer_batch):
    X, y = s0_summer_batch
    y = y + 0.3 * np.sin(np.arange(len(y)) * 1.7)
    model = RecursiveLS()
    for i in range(len(y)):
        model.partial_fit(X.iloc[[i]], y.iloc[[i]])
    np.testing.assert_allclose(np.r_[model.intercept_, model.coef_], _batch_reference(X, y),
                               rtol=1e-9)
    assert model.n_samples_seen_ == len(y)
    residual = y - LinearRegression().fit(X, y).predict(X)
    np.testing.assert_allclose(model.sigma2_, residual @ residual / (len(y) - 3), rtol=1e-9)


def test_recursive_ls_is_not_fitted_until_the_coefficients_are_determined(s0_summer_batch):
    X, y = s0_summer_batch
    model = RecursiveLS().partial_fit(X.iloc[:2], y.iloc[:2])  # 2 samples, 3 coefficients
    with pytest.raises(NotFittedError):
        model.predict(X)
    model.partial_fit(X.iloc[2:], y.iloc[2:])
    np.testing.assert_allclose(model.predict(X), y, rtol=1e-10)


def test_recursive_ls_on_real_data_in_batches_equals_batch_ls(fl_thermal):
    """11,115 real samples in chunks of 500; the first minutes barely change temperature."""
    X, y = fl_thermal[["t1(°C)", "t7(°C)", "t13(°C)"]], fl_thermal["ch1(um)"]
    model = RecursiveLS()
    for start in range(0, len(y), 500):
        model.partial_fit(X.iloc[start:start + 500], y.iloc[start:start + 500])
    np.testing.assert_allclose(np.r_[model.intercept_, model.coef_], _batch_reference(X, y),
                               rtol=1e-9)


def test_merged_models_equal_refit_on_union(fl_thermal):
    X, y = fl_thermal[["t1(°C)", "t7(°C)"]], fl_thermal["ch1(um)"]
    first = RecursiveLS().fit(X.iloc[:4000], y.iloc[:4000])
    second = RecursiveLS().fit(X.iloc[4000:], y.iloc[4000:])
    merged = merge_models(first, second)
    np.testing.assert_allclose(np.r_[merged.intercept_, merged.coef_], _batch_reference(X, y),
                               rtol=1e-9)
    assert merged.n_samples_seen_ == len(y)
    residual = y - LinearRegression().fit(X, y).predict(X)
    np.testing.assert_allclose(merged.sigma2_, residual @ residual / (len(y) - 3), rtol=1e-9)
    with pytest.raises(ProblemError, match="different features"):
        merge_models(first, RecursiveLS().fit(X[["t7(°C)", "t1(°C)"]], y))


def test_recursive_ls_errors(s0_summer_batch):
    X, y = s0_summer_batch
    with pytest.raises(SingularSystemError, match=r"rank deficient.*'T3_C'"):
        RecursiveLS().fit(X.assign(T3_C=21.0), y)
    with pytest.raises(ProblemError, match="fewer samples than parameters: 2 sample"):
        RecursiveLS().fit(X.iloc[:2], y.iloc[:2])
    with pytest.raises(ProblemError, match="y contains 1 non-finite"):
        RecursiveLS().fit(X, y.where(y.index != 9))
    with pytest.raises(ValueError, match="forgetting"):
        RecursiveLS(forgetting=1.2).fit(X, y)

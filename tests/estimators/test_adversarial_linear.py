"""Second hostile campaign (issue #39) on the least-squares estimators: named reproducers, each
checked against an independent reference (scipy's lstsq, scikit-learn's LinearRegression)."""

from __future__ import annotations

import warnings

import numpy as np
import pytest
import scipy.linalg
from sklearn.linear_model import LinearRegression

from svrqp.estimators import LinearLS, RecursiveLS
from svrqp.export import build_document, predict, verify, write


def weighted_reference(X: np.ndarray, y: np.ndarray, forgetting: float) -> np.ndarray:
    """(intercept, coef) of the exponentially weighted least-squares problem, by scipy's SVD lstsq."""
    n = len(y)
    root = np.sqrt(forgetting ** np.arange(n - 1, -1, -1, dtype=float))
    A = np.column_stack([np.ones(n), X])
    return scipy.linalg.lstsq(A * root[:, None], y * root)[0]


def drifting_problem() -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(1)
    n = 40
    X = rng.uniform(0, 1, (n, 1))
    y = (0.1 + np.linspace(0, 0.1, n)) * X[:, 0] + 0.02 * rng.standard_normal(n)
    return X, y


@pytest.mark.parametrize("forgetting", [0.9, 1e-2, 1e-8, 1e-30])
def test_tiny_forgetting_gives_the_weighted_least_squares_answer(forgetting):
    """#5: forgetting=1e-8 gave a slope of 0.036 for the problem's 0.121 (no warning); 1e-30
    raised SingularSystemError. The square-root recursion answers the weighted problem."""
    X, y = drifting_problem()
    model = RecursiveLS(forgetting=forgetting).fit(X, y)
    reference = weighted_reference(X, y, forgetting)
    np.testing.assert_allclose(np.r_[model.intercept_, model.coef_], reference, rtol=1e-8, atol=1e-12)


def test_forgetting_too_small_for_the_coefficients_is_a_clear_error():
    """With λ = 1e-300 only the newest sample keeps a weight in float64: two coefficients are not
    determined, which the error says (naming the forgetting factor) instead of a wrong answer."""
    X, y = drifting_problem()
    with pytest.raises(np.linalg.LinAlgError, match="forgetting factor 1e-300"):
        RecursiveLS(forgetting=1e-300).fit(X[:2], y[:2])


def offset_problem() -> tuple[np.ndarray, np.ndarray]:
    """Epoch seconds spread over 10 ms (a fast transient): the raw form's intercept is about -8.5e11."""
    rng = np.random.default_rng(6)
    t = rng.uniform(0, 0.01, 50)
    X = np.column_stack([1.7e9 + t, rng.uniform(20, 30, 50)])
    y = 500.0 * (X[:, 0] - 1.7e9) + 0.5 * X[:, 1] + 0.05 * rng.standard_normal(50)
    return X, y


def centred_reference(X: np.ndarray, y: np.ndarray) -> np.ndarray:
    """scikit-learn on inputs shifted by an exactly representable offset (no cancellation)."""
    shifted = X - np.array([1.7e9, 0.0])
    return LinearRegression().fit(shifted, y).predict(shifted)


@pytest.mark.parametrize("model", [LinearLS(), RecursiveLS()])
def test_offset_inputs_predict_in_centred_units(model):
    """#6: X ≈ 1.7e9 (epoch seconds): predict added X @ coef_ ≈ 1e15 to intercept_ ≈ −1e15 and
    was 0.14–0.31 std(y) off. Predictions are now evaluated about the stored centre."""
    X, y = offset_problem()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        fitted = model.fit(X, y)
    np.testing.assert_allclose(fitted.predict(X), centred_reference(X, y), rtol=0, atol=1e-6 * y.std())


@pytest.mark.parametrize("model", [LinearLS(), RecursiveLS()])
def test_exported_offset_model_predicts_and_verifies(model, tmp_path):
    """#6, exported: the file records the centre in its scaling, so the file alone predicts right."""
    X, y = offset_problem()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        fitted = model.fit(X, y)
        document = build_document(fitted, X, y)
    path = tmp_path / "model.json"
    write(document, path)
    assert verify(path).ok, verify(path).failures()
    np.testing.assert_allclose(predict(document, X), centred_reference(X, y), rtol=0,
                               atol=1e-6 * y.std())


def test_lstsq_on_nearly_collinear_columns_gives_the_minimum_norm_answer():
    """#11: columns [x, 2x + 1e-12·noise] with rank_deficient="lstsq" raised SingularSystemError
    ("Cholesky failed") where the option promises the least-squares answer of scipy's lstsq."""
    rng = np.random.default_rng(2)
    x = rng.uniform(-1, 1, 30)
    X = np.column_stack([x, 2 * x + 1e-12 * rng.standard_normal(30)])
    y = 3 * x + 0.1 * rng.standard_normal(30)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        model = LinearLS(rank_deficient="lstsq").fit(X, y)
    centred = X - X.mean(axis=0)
    reference = centred @ scipy.linalg.lstsq(centred, y - y.mean())[0] + y.mean()
    # The columns' condition number is ~1e12: the coefficients (~1e10) are determined only to ~1e-4
    # relative by data rounded at 1e-16, and predictions summing such terms to ~1e10·eps ≈ 4e-6.
    # What must hold: finite coefficients, the residual of scipy's lstsq, and predictions within
    # DESIGN §3's 1e-5·std(y) of its answer.
    assert np.all(np.isfinite(model.coef_))
    np.testing.assert_allclose(model.predict(X), reference, rtol=0, atol=1e-5 * y.std())
    assert np.linalg.norm(y - model.predict(X)) <= np.linalg.norm(y - reference) * (1 + 1e-9)

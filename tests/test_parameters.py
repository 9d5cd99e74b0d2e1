"""Parameter checks: the same verdicts as scikit-learn's own validation, errors that name the parameter."""

from __future__ import annotations

import itertools
from numbers import Integral, Real

import numpy as np
import pytest
from sklearn.linear_model import LinearRegression

from svrqp import EpsilonSVR, LinearLS, RecursiveLS
from svrqp.exceptions import ProblemError
from svrqp.parameters import Boolean, HasMethods, Nothing, Number, OneOf, check_parameters

# The reference: scikit-learn's validation, which the estimators used before (a private module,
# imported here only to compare verdicts).
sklearn_validation = pytest.importorskip("sklearn.utils._param_validation")

VALUES = [0, 1, 2, -1, 0.0, 0.5, 1.0, 1.5, -0.1, 1e300, np.inf, -np.inf, np.nan, True, False,
          np.float64(0.5), np.int64(3), np.float32(2.0), np.bool_(True), "1", None, [1]]
INTERVALS = [(0.0, None, "neither"), (0.0, None, "left"), (0.0, 1.0, "right"), (0.0, 1.0, "neither"),
             (None, None, "neither"), (None, 1.0, "right"), (0.0, 1.0, "both")]


@pytest.mark.parametrize("low, high, closed", INTERVALS)
@pytest.mark.parametrize("integer", [False, True])
def test_number_agrees_with_sklearn_interval(low, high, closed, integer):
    low, high = (None if bound is None else (int(bound) if integer else bound) for bound in (low, high))
    ours = Number(low, high, closed, integer=integer)
    reference = sklearn_validation.Interval(Integral if integer else Real, low, high, closed=closed)
    for value in VALUES:
        assert ours.accepts(value) == reference.is_satisfied_by(value), value
    assert str(ours) == str(reference)


def test_choices_booleans_none_and_methods_agree_with_sklearn():
    pairs = [
        (OneOf(frozenset({"rbf", "poly"})), sklearn_validation.StrOptions({"rbf", "poly"})),
        (Boolean(), sklearn_validation.make_constraint("boolean")),
        (Nothing(), sklearn_validation.make_constraint(None)),
        (HasMethods(("fit", "predict")), sklearn_validation.HasMethods(["fit", "predict"])),
    ]
    for (ours, reference), value in itertools.product(pairs, [*VALUES, "rbf", "linear", LinearRegression()]):
        assert ours.accepts(value) == reference.is_satisfied_by(value), (ours, value)


@pytest.mark.parametrize("model, message", [
    (EpsilonSVR(C=-1.0), r"The 'C' parameter of EpsilonSVR must be a float in the range \(0.0, inf\). Got -1.0"),
    (EpsilonSVR(gamma="wide"), r"'gamma' parameter of EpsilonSVR must be a str among \['auto', 'scale'\] or a float"),
    (EpsilonSVR(check_tol="tight"), r"'check_tol' .* or None\. Got 'tight'"),
    (LinearLS(fit_intercept=1), r"'fit_intercept' parameter of LinearLS must be an instance of 'bool'"),
    (RecursiveLS(forgetting=0.0), r"'forgetting' .* \(0.0, 1.0\]\. Got 0.0"),
])
def test_a_bad_parameter_is_a_problem_error_naming_it(model, message):
    X, y = np.arange(20.0).reshape(10, 2), np.arange(10.0)
    with pytest.raises(ProblemError, match=message):
        model.fit(X, y)


def test_check_parameters_reports_the_first_failing_parameter():
    class Settings:
        a, b = 1.0, -1.0

    check_parameters(Settings(), {"a": [Number(0.0)]})
    with pytest.raises(ProblemError, match="'b' parameter of Settings"):
        check_parameters(Settings(), {"a": [Number(0.0)], "b": [Number(0.0)]})


def test_estimator_parameters_are_keyword_only():
    with pytest.raises(TypeError):
        EpsilonSVR(10.0)
    assert EpsilonSVR(C=10.0).C == 10.0

"""Second hostile campaign (issue #39) on :class:`svrqp.Guarded`: named reproducers."""

from __future__ import annotations

import numpy as np
import pytest

from svrqp import Guarded
from svrqp.estimators import LinearLS
from svrqp.exceptions import ProblemError


def data() -> tuple[np.ndarray, np.ndarray]:
    X = np.random.default_rng(0).normal(size=(30, 2))
    return X, X[:, 0] + 0.1 * X[:, 1]


def test_groups_of_mixed_types_are_a_problem_error():
    """#8: ``[0, "a", 1]`` as an object array raised numpy's TypeError inside ``np.unique``."""
    X, y = data()
    with pytest.raises(ProblemError, match="groups: labels mix types"):
        Guarded(LinearLS()).fit(X, y, groups=np.array([0, "a", 1] * 10, dtype=object))


def test_groups_of_one_type_in_an_object_array_still_fit():
    X, y = data()
    model = Guarded(LinearLS(), n_splits=3).fit(X, y, groups=np.array(["a", "b", "c"] * 10, dtype=object))
    assert model.predict_interval(X).shape == (30, 2)


def test_no_estimator_is_a_problem_error():
    """#9: ``Guarded(None)`` raised AttributeError about ``__sklearn_tags__``."""
    X, y = data()
    with pytest.raises(ProblemError, match="estimator must be a scikit-learn regressor.*None"):
        Guarded(None).fit(X, y)

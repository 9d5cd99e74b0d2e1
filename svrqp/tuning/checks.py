"""Input checks shared by the searches: data, model, grid values, log-space ranges, a fixed γ."""

from __future__ import annotations

from collections.abc import Sequence
from numbers import Real

import numpy as np
from numpy.typing import ArrayLike, NDArray
from sklearn.utils.validation import check_X_y

from svrqp import registry
from svrqp.exceptions import ProblemError


def validated(X: ArrayLike, y: ArrayLike) -> tuple[NDArray, NDArray]:
    """``X`` and ``y`` as float arrays of matching length (a :class:`ProblemError` otherwise)."""
    try:
        return check_X_y(X, y, dtype=np.float64, y_numeric=True)
    except ValueError as err:
        raise ProblemError(f"X, y: {err}") from err


def check_model(model: str) -> None:
    """Raise unless ``model`` is a searchable model of
    the registry (:func:`svrqp.registry.tunable`)."""
    if model not in registry.tunable():
        raise ProblemError(f"model must be one of {registry.tunable()}, got {model!r}")


def grid_values(values: ArrayLike, name: str, *, allow_zero: bool = False) -> NDArray[np.float64]:
    """The distinct grid values of ``name``, sorted; each
    finite and positive (non-negative with ``allow_zero``)."""
    values = np.unique(np.asarray(values, dtype=float).ravel())
    if values.size == 0:
        raise ProblemError(f"the {name} grid is empty: give at least one value")
    lowest_allowed = "non-negative" if allow_zero else "positive"
    if not np.all(np.isfinite(values)) or (values.min() < 0 if allow_zero else values.min() <= 0):
        raise ProblemError(f"every {name} must be finite and {lowest_allowed}, got "
                           f"{values.tolist()}")
    return values


def log_range(bounds: Sequence[float], name: str) -> tuple[float, float]:
    """``(log10 low, log10 high)`` of a search range ``(low, high)`` with ``0 < low < high``."""
    if len(bounds) != 2:
        raise ProblemError(f"{name} range must be (low, high), got {tuple(bounds)}")
    low, high = float(bounds[0]), float(bounds[1])
    if not (np.isfinite(low) and np.isfinite(high) and 0 < low < high):
        raise ProblemError(f"{name} range must satisfy 0 < low < high (searched in log space), got "
                           f"({low}, {high})")
    return np.log10(low), np.log10(high)


def fixed_gamma(gamma: float | str, X: NDArray) -> float:
    """The RBF γ held fixed by the GA: a positive number, or scikit-learn's ``"scale"``."""
    if isinstance(gamma, str):
        if gamma != "scale":
            raise ProblemError(f"gamma must be a positive number, 'scale' or a (low, high) range, "
                               f"got {gamma!r}")
        variance = float(X.var())
        if not variance > 0:
            raise ProblemError("gamma='scale' needs features that vary (Var(X) is 0); give gamma "
                               "explicitly")
        return 1.0 / (X.shape[1] * variance)
    if not isinstance(gamma, Real) or not (np.isfinite(gamma) and gamma > 0):
        raise ProblemError(f"gamma must be a positive number, 'scale' or a (low, high) range, got "
                           f"{gamma!r}")
    return float(gamma)

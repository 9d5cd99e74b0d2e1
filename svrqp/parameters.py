"""Checks of estimator parameters, with errors that name the parameter.

An estimator lists what each parameter accepts in a class attribute ``_parameter_checks``
(parameter name → the constraints it may satisfy, any one of them) and calls
:func:`check_parameters` at the start of ``fit``. A value that satisfies none raises
:class:`~svrqp.exceptions.ProblemError`: ``The 'C' parameter of EpsilonSVR must be a float in the
range (0.0, inf). Got -1.0 instead.``

The constraints accept what scikit-learn's own parameter validation accepts (its ``Interval``,
``StrOptions``, ``"boolean"``, ``None`` and ``HasMethods``), written on public Python only: that
validation lives in a private scikit-learn module that may change in any release.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from numbers import Integral, Real
from typing import Any, Protocol

import numpy as np

from svrqp.exceptions import ProblemError


class Constraint(Protocol):
    """What one parameter value may be."""

    def accepts(self, value: Any) -> bool:
        """Whether ``value`` satisfies the constraint."""

    def __str__(self) -> str:
        """The constraint in words (``"a float in the range (0.0, inf)"``)."""


@dataclass(frozen=True)
class Number:
    """A real number (or an integer) in an interval; ``None`` bounds are infinite.

    ``closed`` names the bounds that belong to the interval: ``"left"``, ``"right"``, ``"both"`` or
    ``"neither"``. NaN is never accepted, nor an infinity outside a closed infinite bound.
    """

    low: float | None = None
    high: float | None = None
    closed: str = "neither"
    integer: bool = False

    def accepts(self, value: Any) -> bool:
        kind = type(value)  # float and int first: the ABCs' isinstance costs more than the check
        if kind is float:
            if self.integer or math.isnan(value):
                return False
        elif kind is not int:
            if not isinstance(value, Integral if self.integer else Real):
                return False
            if not isinstance(value, Integral) and math.isnan(value):
                return False
        low = -math.inf if self.low is None else self.low
        high = math.inf if self.high is None else self.high
        above_low = value >= low if self.closed in ("left", "both") else value > low
        below_high = value <= high if self.closed in ("right", "both") else value < high
        return bool(above_low and below_high)

    def __str__(self) -> str:
        def bound(value: float | None, infinite: str) -> str:
            if value is None:
                return infinite
            return str(int(value)) if self.integer else str(float(value))

        left = "[" if self.closed in ("left", "both") else "("
        right = "]" if self.closed in ("right", "both") else ")"
        kind = "an int" if self.integer else "a float"
        return (
            f"{kind} in the range {left}{bound(self.low, '-inf')}, {bound(self.high, 'inf')}{right}"
        )


@dataclass(frozen=True)
class OneOf:
    """One of a set of strings."""

    options: frozenset[str]

    def accepts(self, value: Any) -> bool:
        return isinstance(value, str) and value in self.options

    def __str__(self) -> str:
        return f"a str among {sorted(self.options)}"


class Boolean:
    """``True`` or ``False`` (a Python or numpy boolean)."""

    def accepts(self, value: Any) -> bool:
        return isinstance(value, (bool, np.bool_))

    def __str__(self) -> str:
        return "an instance of 'bool'"


class Nothing:
    """``None``."""

    def accepts(self, value: Any) -> bool:
        return value is None

    def __str__(self) -> str:
        return "None"


@dataclass(frozen=True)
class HasMethods:
    """An object with these callable methods."""

    methods: tuple[str, ...]

    def accepts(self, value: Any) -> bool:
        return all(callable(getattr(value, method, None)) for method in self.methods)

    def __str__(self) -> str:
        return f"an object implementing {', '.join(repr(method) for method in self.methods)}"


def check_parameters(estimator: Any, checks: Mapping[str, Sequence[Constraint]]) -> None:
    """Raise :class:`ProblemError` for the first
    parameter of ``estimator`` that fails its ``checks``.

    Parameters
    ----------
    estimator
        An object whose attributes of the names in ``checks`` are its parameters.
    checks
        Parameter name → the constraints it may satisfy (any one of them).
    """
    for name, constraints in checks.items():
        value = getattr(estimator, name)
        for constraint in constraints:  # a loop, not any(generator): a fit checks a dozen
            if constraint.accepts(value):
                break
        else:
            wanted = [str(constraint) for constraint in constraints]
            text = wanted[0] if len(wanted) == 1 else f"{', '.join(wanted[:-1])} or {wanted[-1]}"
            raise ProblemError(f"The {name!r} parameter of {type(estimator).__name__} must be "
                               f"{text}. Got {value!r} instead.")

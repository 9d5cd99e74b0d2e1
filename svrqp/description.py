"""What a fitted model says about itself: the protocol the export reads, and its sections' builders.

An exportable estimator is :class:`Describable`: its class attribute ``export_kind`` is the
``kind`` of its ``svrqp.model/1`` documents and its ``export_sections()`` returns
:class:`Sections` — the ``model`` section (its coefficients, with the formula every evaluator
computes) and the ``solver`` section (how they were computed, and their certificates) — built
with the helpers of this module (:func:`kernel_sections`, :func:`linear_model`,
:func:`polynomial_model`, :func:`least_squares_solver`).

This module sits below the estimators and imports none of them, nor anything of
:mod:`svrqp.export`: the estimators implement the protocol, :mod:`svrqp.export.describe` reads
it, and neither imports the other.
"""

from __future__ import annotations

import math
from importlib.metadata import version
from typing import Any, ClassVar, NamedTuple, Protocol, runtime_checkable

import numpy as np

from svrqp.exceptions import ProblemError
from svrqp.kernels import rbf_conventions

KERNEL_FORMULA = (
    "f(x) = sum_i dual_coef[i] * k(u, support_vectors[i]) + intercept, u = (x - scaling.mean) / "
    "scaling.scale"
)
LINEAR_FORMULA = "f(x) = sum_j coef[j] * u[j] + intercept, u = (x - scaling.mean) / scaling.scale"
POLYNOMIAL_FORMULA = (
    "f(x) = sum_m coef[m] * P_m(t), P_m Legendre, t = (2 u - domain[0] - domain[1]) / (domain[1] - "
    "domain[0]), u = (x - scaling.mean) / scaling.scale"
)


def floats(values: Any) -> list[float]:
    """An array as a flat list of Python floats (JSON writes them exactly, as ``repr``)."""
    return [float(value) for value in np.asarray(values, dtype=float).ravel()]


class Sections(NamedTuple):
    """The sections of a document that an estimator writes about itself."""

    model: dict[str, Any]
    """Coefficients and formula (the document's ``model``)."""
    solver: dict[str, Any]
    """How the coefficients were computed and their certificates (the document's ``solver``)."""
    centre: Any = None
    """A linear model's input centre :math:`\bar x`, or None: the model is then written as
    :math:`f = b + (x - \bar x)^\top a` (``intercept`` is :math:`b`, the value at the centre) and
    the centre goes into the document's ``scaling`` (:func:`svrqp.export.describe.with_centre`), so
    that inputs offset far from zero keep their digits in every evaluator of the file."""


@runtime_checkable
class Describable(Protocol):
    """What an exportable estimator provides: the protocol :mod:`svrqp.export` reads.

    ``export_kind`` (a class attribute) is the ``kind`` of its documents, one of
    :func:`svrqp.registry.export_kinds`; ``export_sections()`` returns the ``model`` and
    ``solver`` sections of the fitted estimator, built with the helpers of this module.
    """

    export_kind: ClassVar[str]

    def export_sections(self) -> Sections:
        """The ``model`` and ``solver`` sections of the fitted estimator."""
        ...


def kernel_section(name: str, gamma: float, degree: int, coef0: float) -> dict[str, Any]:
    """The kernel with its parameters; the RBF width in every convention of :mod:`svrqp.kernels`."""
    empty = {"gamma": None, "g": None, "sigma_s0": None, "sigma_s4": None, "degree": None,
             "coef0": None}
    if name == "rbf":
        return {**empty, "name": name,
                **{key: float(value) for key, value in rbf_conventions(gamma).items()}}
    if name == "poly":
        return {**empty, "name": name, "gamma": float(gamma), "degree": int(degree),
                "coef0": float(coef0)}
    if name == "linear":
        return {**empty, "name": name}
    raise ProblemError(f"model: kernel {name!r} cannot be exported (a precomputed kernel has no "
                       f"formula)")


def kernel_model(estimator: Any, *, epsilon: float | None, fit_intercept: bool) -> dict[str, Any]:
    """The ``model`` section of a fitted kernel model (:math:`\\beta` of its support vectors, b)."""
    return {
        "formula": KERNEL_FORMULA,
        "kernel": kernel_section(estimator.kernel, estimator.gamma_, estimator.degree,
                                 estimator.coef0),
        "C": float(estimator.C),
        "epsilon": None if epsilon is None else float(epsilon),
        "fit_intercept": bool(fit_intercept),
        "support_vectors": [floats(row) for row in estimator.support_vectors_],
        "dual_coef": floats(estimator.dual_coef_[0]),
        "intercept": float(estimator.intercept_[0]),
    }


def polynomial_model(degree: int, domain: Any, legendre_coef: Any) -> dict[str, Any]:
    """The ``model`` section of a polynomial on the Legendre basis over ``domain``."""
    return {
        "formula": POLYNOMIAL_FORMULA,
        "basis": "legendre",
        "degree": int(degree),
        "domain": floats(domain),
        "coef": floats(legendre_coef),
    }


def linear_model(coef: Any, intercept: float, fit_intercept: bool, **extra: Any) -> dict[str, Any]:
    """The ``model`` section of ``y = intercept + u @ coef``;
    ``extra`` entries follow (recursive LS)."""
    return {
        "formula": LINEAR_FORMULA,
        "coef": floats(coef),
        "intercept": float(intercept),
        "fit_intercept": bool(fit_intercept),
        **extra,
    }


def _json_number(value: Any) -> float | int | None:
    """A finite number as a JSON number; an undefined (non-finite) certificate as null."""
    if isinstance(value, (bool, np.bool_)):
        return bool(value)
    if isinstance(value, (int, np.integer)):
        return int(value)
    value = float(value)
    return value if math.isfinite(value) else None


def _json_value(value: Any) -> Any:
    if value is None or isinstance(value, str):
        return value
    if isinstance(value, (bool, int, float, np.generic)):
        return _json_number(value)
    if isinstance(value, dict):
        return {str(key): _json_value(item) for key, item in value.items()}
    if isinstance(value, (list, tuple)):
        return [_json_value(item) for item in value]
    return repr(value)  # an enum or object setting: recorded by its text, never re-evaluated


def least_squares_solver(backend: str, settings: dict[str, Any],
                         residuals: dict[str, Any]) -> dict[str, Any]:
    """The ``solver`` section of a model solved as a linear system (no iterative solver, no
    certificates of a QP): ``backend`` says how, ``residuals`` its
    figures (a condition number, a rank, a variance)."""
    return {
        "backend": backend, "version": f"scipy {version('scipy')}, numpy {np.__version__}",
        "requested_tol": None,
        "settings": _json_value(settings), "status": "optimal", "primal_residual": None,
        "dual_residual": None, "duality_gap": None,
        "residuals": {key: _json_number(value) for key, value in residuals.items()},
        "iterations": None,
    }


def solution_solver(solution: Any, requested_tol: float | None) -> dict[str, Any]:
    """The ``solver`` section of a kernel model: its certificate-checked ``solution_``."""
    return {
        "backend": solution.backend,
        "version": solution.backend_version,
        "requested_tol": None if requested_tol is None else _json_number(requested_tol),
        "settings": _json_value(dict(solution.settings)),
        "status": solution.status,
        "primal_residual": _json_number(solution.residuals["primal"]),
        "dual_residual": _json_number(solution.residuals["dual"]) if "dual" in solution.residuals
        else None,
        "duality_gap": _json_number(solution.residuals["gap"]) if "gap" in solution.residuals
        else None,
        "residuals": {key: _json_number(value) for key, value in solution.residuals.items()},
        "iterations": solution.iterations,
    }


def kernel_sections(estimator: Any, *, epsilon: float | None, fit_intercept: bool,
                    requested_tol: float | None) -> Sections:
    """Both sections of a fitted kernel model (:func:`kernel_model`, :func:`solution_solver`)."""
    return Sections(kernel_model(estimator, epsilon=epsilon, fit_intercept=fit_intercept),
                    solution_solver(estimator.solution_, requested_tol))

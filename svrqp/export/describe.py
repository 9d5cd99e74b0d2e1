"""Read a fitted model into the plain-data sections of an ``svrqp.model/1`` document.

A model is either a fitted svrqp estimator or a scikit-learn ``Pipeline`` of a ``StandardScaler``
followed by one. :func:`split_pipeline` separates the scaling (recorded so the file alone maps raw
inputs to the model's coordinates ``u = (x - mean) / scale``) from the estimator.

Each exportable estimator describes itself (:class:`svrqp.export.mixin.ExportMixin`): its class
attribute ``_export_kind`` is the document's ``kind`` and its ``_export_sections()`` returns the
``model`` section (its coefficients) and the ``solver`` section (how they were computed), built
with the helpers of this module (:func:`kernel_sections`, :func:`linear_model`,
:func:`polynomial_model`, :func:`least_squares_solver`). This package never imports an estimator.
"""

from __future__ import annotations

import math
from importlib.metadata import version
from typing import Any, NamedTuple

import numpy as np
from sklearn.pipeline import Pipeline
from sklearn.preprocessing import StandardScaler
from sklearn.utils.validation import check_is_fitted

from svrqp import registry
from svrqp.exceptions import ProblemError
from svrqp.kernels import rbf_conventions

KERNEL_FORMULA = (
    "f(x) = sum_i dual_coef[i] * k(u, support_vectors[i]) + intercept, u = (x - scaling.mean) / scaling.scale"
)
LINEAR_FORMULA = "f(x) = sum_j coef[j] * u[j] + intercept, u = (x - scaling.mean) / scaling.scale"
POLYNOMIAL_FORMULA = (
    "f(x) = sum_m coef[m] * P_m(t), P_m Legendre, t = (2 u - domain[0] - domain[1]) / (domain[1] - domain[0]), "
    "u = (x - scaling.mean) / scaling.scale"
)


def split_pipeline(model: Any) -> tuple[dict[str, Any] | None, Any]:
    """Return ``(scaling section or None, final estimator)`` of ``model``.

    Raises
    ------
    ProblemError
        For a pipeline step other than one leading ``StandardScaler``.
    """
    if not isinstance(model, Pipeline):
        return None, model
    steps = [step for _, step in model.steps if step not in (None, "passthrough")]
    *transforms, estimator = steps
    if len(transforms) > 1 or (transforms and not isinstance(transforms[0], StandardScaler)):
        names = [type(step).__name__ for step in transforms]
        raise ProblemError(f"model: only a pipeline StandardScaler → estimator can be exported, got steps {names}")
    if not transforms:
        return None, estimator
    scaler = transforms[0]
    check_is_fitted(scaler)
    d = scaler.n_features_in_
    mean = scaler.mean_ if scaler.mean_ is not None else np.zeros(d)
    scale = scaler.scale_ if scaler.scale_ is not None else np.ones(d)
    return {"method": "standard", "mean": floats(mean), "scale": floats(scale)}, estimator


def with_centre(scaling: dict[str, Any] | None, centre: Any) -> dict[str, Any] | None:
    """The ``scaling`` section that also subtracts a model's own input centre (in the model's
    coordinates): :math:`u = (x - m)/s - c = (x - (m + s c))/s`."""
    if centre is None:
        return scaling
    centre = np.asarray(centre, dtype=float)
    if scaling is None:
        return {"method": "standard", "mean": floats(centre), "scale": floats(np.ones_like(centre))}
    scale = np.asarray(scaling["scale"], dtype=float)
    return {**scaling, "mean": floats(np.asarray(scaling["mean"], dtype=float) + scale * centre)}


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
    """A linear model's input centre :math:`\\bar x`, or None: the model is then written as
    :math:`f = b + (x - \\bar x)^\\top a` (``intercept`` is :math:`b`, the value at the centre) and the
    centre goes into the document's ``scaling`` (:func:`with_centre`), so that inputs offset far from
    zero keep their digits in every evaluator of the file."""


def kind_of(estimator: Any) -> str:
    """The ``kind`` of an exportable estimator (its ``_export_kind``)."""
    kind = getattr(estimator, "_export_kind", None)
    if kind is None:
        exportable = ", ".join(model.class_name for model in registry.MODELS)
        raise ProblemError(f"model: cannot export a {type(estimator).__name__}; exportable: "
                           f"{exportable} (alone or after a StandardScaler)")
    return kind


def sections(estimator: Any) -> Sections:
    """The ``model`` and ``solver`` sections of a fitted exportable estimator."""
    check_is_fitted(estimator)
    return estimator._export_sections()


def kernel_section(name: str, gamma: float, degree: int, coef0: float) -> dict[str, Any]:
    """The kernel with its parameters; the RBF width in every convention of :mod:`svrqp.kernels`."""
    empty = {"gamma": None, "g": None, "sigma_s0": None, "sigma_s4": None, "degree": None, "coef0": None}
    if name == "rbf":
        return {**empty, "name": name, **{key: float(value) for key, value in rbf_conventions(gamma).items()}}
    if name == "poly":
        return {**empty, "name": name, "gamma": float(gamma), "degree": int(degree), "coef0": float(coef0)}
    if name == "linear":
        return {**empty, "name": name}
    raise ProblemError(f"model: kernel {name!r} cannot be exported (a precomputed kernel has no formula)")


def kernel_model(estimator: Any, *, epsilon: float | None, fit_intercept: bool) -> dict[str, Any]:
    """The ``model`` section of a fitted kernel model (:math:`\\beta` of its support vectors, b)."""
    return {
        "formula": KERNEL_FORMULA,
        "kernel": kernel_section(estimator.kernel, estimator.gamma_, estimator.degree, estimator.coef0),
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
    """The ``model`` section of ``y = intercept + u @ coef``; ``extra`` entries follow (recursive LS)."""
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


def least_squares_solver(backend: str, settings: dict[str, Any], residuals: dict[str, Any]) -> dict[str, Any]:
    """The ``solver`` section of a model solved as a linear system (no iterative solver, no certificates
    of a QP): ``backend`` says how, ``residuals`` its figures (a condition number, a rank, a variance)."""
    return {
        "backend": backend, "version": f"scipy {version('scipy')}, numpy {np.__version__}", "requested_tol": None,
        "settings": _json_value(settings), "status": "optimal", "primal_residual": None, "dual_residual": None,
        "duality_gap": None, "residuals": {key: _json_number(value) for key, value in residuals.items()},
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
        "dual_residual": _json_number(solution.residuals["dual"]) if "dual" in solution.residuals else None,
        "duality_gap": _json_number(solution.residuals["gap"]) if "gap" in solution.residuals else None,
        "residuals": {key: _json_number(value) for key, value in solution.residuals.items()},
        "iterations": solution.iterations,
    }


def kernel_sections(estimator: Any, *, epsilon: float | None, fit_intercept: bool,
                    requested_tol: float | None) -> Sections:
    """Both sections of a fitted kernel model (:func:`kernel_model`, :func:`solution_solver`)."""
    return Sections(kernel_model(estimator, epsilon=epsilon, fit_intercept=fit_intercept),
                    solution_solver(estimator.solution_, requested_tol))

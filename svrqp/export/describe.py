"""Read a fitted model into the plain-data sections of an ``svrqp.model/1`` document.

A model is either a fitted svrqp estimator or a scikit-learn ``Pipeline`` of a ``StandardScaler``
followed by one. :func:`split_pipeline` separates the scaling (recorded so the file alone maps raw
inputs to the model's coordinates ``u = (x - mean) / scale``) from the estimator;
:func:`model_section` writes the estimator's coefficients; :func:`solver_section` its
certificate-checked solution.
"""

from __future__ import annotations

import math
from importlib.metadata import version
from typing import Any

import numpy as np
from sklearn.pipeline import Pipeline
from sklearn.preprocessing import StandardScaler
from sklearn.utils.validation import check_is_fitted

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


def floats(values: Any) -> list[float]:
    """An array as a flat list of Python floats (JSON writes them exactly, as ``repr``)."""
    return [float(value) for value in np.asarray(values, dtype=float).ravel()]


def kind_of(estimator: Any) -> str:
    """The ``kind`` of an exportable estimator."""
    # Imported here, not at the top: the estimators inherit ExportMixin from this package.
    from svrqp.estimators.kernel import LSSVR, EpsilonSVR
    from svrqp.estimators.linear import LinearLS, PolynomialLS, RecursiveLS

    kinds = {EpsilonSVR: "epsilon_svr", LSSVR: "ls_svr", LinearLS: "linear_ls", PolynomialLS: "polynomial_ls",
             RecursiveLS: "recursive_ls"}
    for cls, kind in kinds.items():
        if isinstance(estimator, cls):
            return kind
    raise ProblemError(f"model: cannot export a {type(estimator).__name__}; exportable: "
                       f"{', '.join(cls.__name__ for cls in kinds)} (alone or after a StandardScaler)")


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


def model_section(kind: str, estimator: Any) -> dict[str, Any]:
    """Coefficients of a fitted estimator of ``kind``."""
    check_is_fitted(estimator)
    if kind in ("epsilon_svr", "ls_svr"):
        return {
            "formula": KERNEL_FORMULA,
            "kernel": kernel_section(estimator.kernel, estimator.gamma_, estimator.degree, estimator.coef0),
            "C": float(estimator.C),
            "epsilon": float(estimator.epsilon) if kind == "epsilon_svr" else None,
            "fit_intercept": bool(getattr(estimator, "fit_intercept", True)),
            "support_vectors": [floats(row) for row in estimator.support_vectors_],
            "dual_coef": floats(estimator.dual_coef_[0]),
            "intercept": float(estimator.intercept_[0]),
        }
    if kind == "polynomial_ls":
        return {
            "formula": POLYNOMIAL_FORMULA,
            "basis": "legendre",
            "degree": int(estimator.degree),
            "domain": floats(estimator.domain_),
            "coef": floats(estimator.legendre_coef_),
        }
    section = {
        "formula": LINEAR_FORMULA,
        "coef": floats(estimator.coef_),
        "intercept": float(estimator.intercept_),
        "fit_intercept": bool(getattr(estimator, "fit_intercept", True)),
    }
    if kind == "recursive_ls":
        section["forgetting"] = float(estimator.forgetting)
        section["n_samples_seen"] = int(estimator.n_samples_seen_)
    return section


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


def _least_squares_solver(estimator: Any) -> dict[str, Any]:
    """The normal equations / the S3 recursion have no iterative solver: record how they were solved."""
    from svrqp.estimators.linear import RecursiveLS

    scipy_version = f"scipy {version('scipy')}, numpy {np.__version__}"
    if isinstance(estimator, RecursiveLS):
        backend = "recursive least squares (S3 eqs. 13-17), started from the batch normal equations"
        settings = {"forgetting": estimator.forgetting}
        residuals = {"sigma2": estimator.sigma2_}
    else:
        backend = "normal equations, equilibrated, Cholesky (svrqp.formulations.least_squares)"
        settings = estimator.get_params()
        residuals = {"condition_number": estimator.condition_number_}
        if hasattr(estimator, "rank_"):
            residuals["rank"] = estimator.rank_
    return {
        "backend": backend, "version": scipy_version, "requested_tol": None, "settings": _json_value(settings),
        "status": "optimal", "primal_residual": None, "dual_residual": None, "duality_gap": None,
        "residuals": {key: _json_number(value) for key, value in residuals.items()}, "iterations": None,
    }


def solver_section(estimator: Any) -> dict[str, Any]:
    """Backend, version, requested tolerance, settings, status and certificates of the fit.

    Kernel models report their certificate-checked ``solution_``; least-squares models how
    their linear system was solved (certificates that do not apply are null).
    """
    if not hasattr(estimator, "solution_"):
        return _least_squares_solver(estimator)
    solution = estimator.solution_
    return {
        "backend": solution.backend,
        "version": solution.backend_version,
        "requested_tol": _json_number(estimator.tol) if hasattr(estimator, "tol") else None,
        "settings": _json_value(dict(solution.settings)),
        "status": solution.status,
        "primal_residual": _json_number(solution.residuals["primal"]),
        "dual_residual": _json_number(solution.residuals["dual"]) if "dual" in solution.residuals else None,
        "duality_gap": _json_number(solution.residuals["gap"]) if "gap" in solution.residuals else None,
        "residuals": {key: _json_number(value) for key, value in solution.residuals.items()},
        "iterations": solution.iterations,
    }

"""The export-time cross-check: refit an independent reference on the same data and parameters.

References (none shares code with svrqp's solvers):

* ``epsilon_svr`` → scikit-learn's ``SVR`` (libsvm's SMO) with ``tol=1e-8``;
* ``ls_svr`` without bias → scikit-learn's ``KernelRidge(alpha=1/C)``; with bias → the bordered KKT
  system of S4 eq. (5), :math:`[[0, 1^\\top], [1, \\Omega + I/C]]\\,[b; \\alpha] = [0; y]`, built
  from ``sklearn.metrics.pairwise_kernels`` and solved by ``numpy.linalg.solve`` (LU);
* ``linear_ls`` → scikit-learn's ``LinearRegression``;
* ``recursive_ls`` → ``LinearRegression`` with sample weights :math:`\\lambda^{n-1-i}`: after all
  samples, the recursion with forgetting factor
  :math:`\\lambda` minimises exactly that weighted sum;
* ``polynomial_ls`` → ``numpy.polynomial.Polynomial.fit`` (power basis, numpy's own scaling).

The recorded deviation is :math:`\\max_i |f(x_i) - f_\\text{ref}(x_i)|` over the training inputs,
in target units, next to ``std(y)`` so a reader can judge it against the numerical contract
(1e-5·std(y) for the ε-SVR; "The cross-check" in ``docs/export.md``).
"""

from __future__ import annotations

from collections.abc import Callable
from importlib.metadata import version
from typing import Any

import numpy as np
from numpy.polynomial import Polynomial
from numpy.typing import NDArray
from sklearn.kernel_ridge import KernelRidge
from sklearn.linear_model import LinearRegression
from sklearn.metrics.pairwise import pairwise_kernels
from sklearn.svm import SVR

from svrqp.exceptions import ProblemError

Reference = tuple[str, str, dict[str, Any], Callable[[NDArray[np.float64]], NDArray[np.float64]]]


def _kernel_parameters(kernel: dict[str, Any]) -> dict[str, Any]:
    return {key: kernel[key] for key in ("gamma", "degree", "coef0") if kernel[key] is not None}


def _epsilon_svr(model: dict[str, Any], U: NDArray, y: NDArray) -> Reference:
    parameters = {"kernel": model["kernel"]["name"], "C": model["C"], "epsilon": model["epsilon"],
                  "tol": 1e-8, **_kernel_parameters(model["kernel"])}
    reference = SVR(**parameters).fit(U, y)
    return "sklearn.svm.SVR", version("scikit-learn"), parameters, reference.predict


def _ls_svr(model: dict[str, Any], U: NDArray, y: NDArray) -> Reference:
    kernel = {"metric": model["kernel"]["name"], **_kernel_parameters(model["kernel"])}
    if not model["fit_intercept"]:
        parameters = {"alpha": 1.0 / model["C"], "kernel": kernel["metric"],
                      **_kernel_parameters(model["kernel"])}
        reference = KernelRidge(**parameters).fit(U, y)
        return (
            "sklearn.kernel_ridge.KernelRidge", version("scikit-learn"), parameters,
            reference.predict,
        )
    n = len(y)
    Omega = pairwise_kernels(U, **kernel)
    M = np.zeros((n + 1, n + 1))
    M[0, 1:] = M[1:, 0] = 1.0
    M[1:, 1:] = Omega + np.eye(n) / model["C"]
    solution = np.linalg.solve(M, np.concatenate([[0.0], y]))
    b, alpha = solution[0], solution[1:]
    parameters = {"C": model["C"], **kernel}
    return ("numpy.linalg.solve of the LS-SVR KKT system (S4 eq. 5), Gram by sklearn "
            "pairwise_kernels",
            f"numpy {np.__version__}, scikit-learn {version('scikit-learn')}", parameters,
            lambda V: pairwise_kernels(V, U, **kernel) @ alpha + b)


def _linear_ls(model: dict[str, Any], U: NDArray, y: NDArray) -> Reference:
    parameters = {"fit_intercept": model["fit_intercept"]}
    reference = LinearRegression(**parameters).fit(U, y)
    return (
        "sklearn.linear_model.LinearRegression", version("scikit-learn"),
        parameters, reference.predict,
    )


def _recursive_ls(model: dict[str, Any], U: NDArray, y: NDArray) -> Reference:
    forgetting = model["forgetting"]
    weights = forgetting ** np.arange(len(y) - 1, -1, -1, dtype=float)
    reference = LinearRegression().fit(U, y, sample_weight=weights)
    return ("sklearn.linear_model.LinearRegression, sample_weight = forgetting^(n-1-i)",
            version("scikit-learn"), {"forgetting": forgetting}, reference.predict)


def _polynomial_ls(model: dict[str, Any], U: NDArray, y: NDArray) -> Reference:
    reference = Polynomial.fit(U[:, 0], y, model["degree"])
    return ("numpy.polynomial.Polynomial.fit", f"numpy {np.__version__}", {"deg": model["degree"]},
            lambda V: reference(V[:, 0]))


REFERENCES: dict[str, Callable[[dict[str, Any], NDArray, NDArray], Reference]] = {
    "epsilon_svr": _epsilon_svr,
    "ls_svr": _ls_svr,
    "linear_ls": _linear_ls,
    "recursive_ls": _recursive_ls,
    "polynomial_ls": _polynomial_ls,
}


def cross_check(kind: str, model: dict[str, Any], U: NDArray[np.float64], y: NDArray[np.float64],
                prediction: NDArray[np.float64]) -> dict[str, Any]:
    """Fit the reference of ``kind`` on ``(U, y)`` and compare it with ``prediction`` at ``U``.

    Parameters
    ----------
    kind
        The document kind.
    model
        The document's ``model`` section (the parameters are read from it).
    U
        Training inputs in the model's coordinates (scaling applied).
    y
        Training targets.
    prediction
        The exported model's predictions at the training inputs.
    """
    if kind not in REFERENCES:
        raise ProblemError(f"no cross-check reference for kind {kind!r}")
    name, reference_version, parameters, reference_predict = REFERENCES[kind](model, U, y)
    deviation = np.abs(np.asarray(prediction, dtype=float) - reference_predict(U))
    return {
        "reference": name,
        "reference_version": reference_version,
        "parameters": parameters,
        "n_points": int(len(y)),
        "max_abs_deviation": float(deviation.max()),
        "target_std": float(np.std(y)),
    }

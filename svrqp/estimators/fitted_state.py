"""Small fitted kernel models: ``problem_`` and the full ``solution_`` rebuilt on demand.

A fitted :class:`svrqp.EpsilonSVR` needs only its support vectors, coefficients and bias to
predict; the QP it solved (a 3n×3n ``P`` in the split form) and the solver's n-vectors are what
made pickles hundreds of times larger than scikit-learn's ``SVR``. What is pickled:

* the model (``support_``, ``support_vectors_``, ``dual_coef_``, ``intercept_``, ...);
* the solver record: ``solution_`` without its vectors (status, certificate figures, backend,
  settings, times);
* the data needed to rebuild the rest: the training rows that are not support vectors, ``y``,
  and the fit's ``C``, ``epsilon``, kernel and formulation.

Within the process that fitted it, the model keeps ``problem_`` and ``solution_`` as they were
built (when the path built them at all). After unpickling — or when the fit's path never formed
the QP, as ``solver="auto"`` does not — ``problem_`` is rebuilt from the training data, and
``solution_`` gets its point and multipliers back from :math:`(\\beta, b)`
(:func:`svrqp.formulations.epsilon_svr_residuals.model_on_qp`), its objective and certificates
recomputed on that QP (so they certify the returned coefficients). A linear-kernel primal fit keeps its solution vectors
(``O(n)`` numbers; the multipliers of that QP are not a function of the model alone).

:class:`svrqp.LSSVR` (:class:`CompactSystemMixin`) keeps its solution (:math:`(b, \\alpha)`, ``O(n)``)
and drops its KKT system (an :math:`(n+1)\\times(n+1)` matrix, S4 eq. (5)); every training row is a
support vector, so ``problem_`` is rebuilt from ``support_vectors_``, ``y`` and the fit's ``C`` and
kernel (a precomputed Gram matrix is kept, as scikit-learn's ``KernelRidge`` keeps it).
"""

from __future__ import annotations

import dataclasses
from typing import Any

import numpy as np
from numpy.typing import NDArray

from svrqp.formulations import epsilon_svr, ls_svr
from svrqp.formulations.epsilon_svr_residuals import kernel_scale, model_on_qp
from svrqp.kernels import gram
from svrqp.problems import LinearSystem, QuadraticProgram
from svrqp.solution import Solution

#: Attributes held only in memory (dropped from pickles, rebuilt on demand).
_CACHES = ("_problem", "_solution")


class CompactFitMixin:
    """``problem_`` and ``solution_`` as properties; pickles keep the model and the solver record only."""

    @property
    def problem_(self) -> QuadraticProgram:
        """The QP that was solved (rebuilt from the training data when not held)."""
        if self.__dict__.get("_problem") is None:
            record = self._fit_record()
            self._problem = epsilon_svr.build(record["formulation"], record["y"], record["C"], record["epsilon"],
                                              K=self._fit_gram() if record["formulation"] != "primal" else None,
                                              X=self._training_rows())
        return self._problem

    @problem_.setter
    def problem_(self, value: QuadraticProgram | None) -> None:
        self._problem = value

    @property
    def solution_(self) -> Solution:
        """The certificate-checked :class:`svrqp.solution.Solution` (vectors rebuilt when not held)."""
        if self.__dict__.get("_solution") is None:
            self._solution = self._rebuilt_solution()
        return self._solution

    @solution_.setter
    def solution_(self, value: Solution) -> None:
        self._solution = value
        self._solution_record = value

    def _rebuilt_solution(self) -> Solution:
        record = self._fit_record()
        if record["formulation"] == "primal":
            return self._solution_record  # pickled with its vectors
        X, y = self._training_rows(), record["y"]
        beta = np.zeros(y.size)
        beta[self.support_] = self.dual_coef_[0]
        Kbeta = self._kernel(X, X[self.support_]) @ self.dual_coef_[0]
        # X is the Gram matrix when the kernel is precomputed
        on_qp = model_on_qp(record["formulation"], y, record["C"], record["epsilon"], beta, float(self.intercept_[0]),
                            Kbeta, kernel_scale(X, record["kernel"]))
        return Solution.of_qp(on_qp.qp, on_qp.point, self._solution_record.record, extra_residuals=on_qp.certificate)

    def _keep_fit_data(self, X: NDArray[np.float64], y: NDArray[np.float64], formulation: str) -> None:
        """Store what rebuilding ``problem_`` and ``solution_`` needs (call at the end of ``fit``)."""
        precomputed = self.kernel == "precomputed"  # no support-vector rows: the Gram matrix is the data
        others = np.ones(X.shape[0], dtype=bool)
        if not precomputed:
            others[self.support_] = False
        self._fit_data = {"X_rows": X[others], "others": np.flatnonzero(others), "y": y, "formulation": formulation,
                          "C": float(self.C), "epsilon": float(self.epsilon),
                          "kernel": {"kernel": self.kernel, "gamma": self.gamma_, "degree": self.degree,
                                     "coef0": self.coef0}}

    def _fit_record(self) -> dict[str, Any]:
        if "_fit_data" not in self.__dict__:
            raise AttributeError("the model is not fitted: problem_ and solution_ exist after fit")
        return self._fit_data

    def _training_rows(self) -> NDArray[np.float64]:
        record = self._fit_record()
        if record["kernel"]["kernel"] == "precomputed":
            return record["X_rows"]
        X = np.empty((record["y"].size, record["X_rows"].shape[1]))
        X[record["others"]] = record["X_rows"]
        X[self.support_] = self.support_vectors_
        return X

    def _kernel(self, A: NDArray[np.float64], B: NDArray[np.float64]) -> NDArray[np.float64]:
        parameters = self._fit_record()["kernel"]
        if parameters["kernel"] == "precomputed":  # A is the Gram matrix; B its support-vector rows
            return A[:, self.support_]
        return gram(A, B, **parameters)

    def _fit_gram(self) -> NDArray[np.float64]:
        X = self._training_rows()
        return X if self._fit_record()["kernel"]["kernel"] == "precomputed" else self._kernel(X, X)

    def __getstate__(self) -> dict[str, Any]:
        state = super().__getstate__()
        for name in _CACHES:
            state.pop(name, None)
        record = state.get("_solution_record")
        if record is not None and self.__dict__.get("_fit_data", {}).get("formulation") != "primal":
            state["_solution_record"] = dataclasses.replace(record, x=None, y=None, z=None, z_box=None)
        return state


class CompactSystemMixin:
    """LS-SVR's ``problem_`` as a property: formed by ``fit`` only when solved by LU, never pickled."""

    @property
    def problem_(self) -> LinearSystem:
        """The KKT system of S4 eq. (5) (rebuilt from the training data when not held)."""
        if self.__dict__.get("_problem") is None:
            if "_fit_data" not in self.__dict__:
                raise AttributeError("the model is not fitted: problem_ exists after fit")
            record = self._fit_data
            K = record["K"] if record["K"] is not None else gram(self.support_vectors_, **record["kernel"])
            self._problem = ls_svr.kkt_system(K, record["y"], record["C"], record["fit_intercept"])
        return self._problem

    @problem_.setter
    def problem_(self, value: LinearSystem | None) -> None:
        self._problem = value

    def _keep_fit_data(self, K: NDArray[np.float64] | None, y: NDArray[np.float64]) -> None:
        """Store what rebuilding ``problem_`` needs; ``K`` only for a precomputed kernel (call in ``fit``)."""
        self._fit_data = {"K": K, "y": y, "C": float(self.C), "fit_intercept": bool(self.fit_intercept),
                          "kernel": {"kernel": self.kernel, "gamma": self.gamma_, "degree": self.degree,
                                     "coef0": self.coef0}}

    def __getstate__(self) -> dict[str, Any]:
        state = super().__getstate__()
        state.pop("_problem", None)
        return state

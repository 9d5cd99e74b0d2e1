"""Small fitted kernel models: ``problem_`` and the full ``solution_`` rebuilt on demand.

A fitted :class:`svrqp.EpsilonSVR` needs only its support vectors, coefficients and bias to
predict; the QP it solved (a 3n×3n ``P`` in the split form), the solver's n-vectors and the
training rows that are not support vectors are what made pickles hundreds of times larger than
scikit-learn's ``SVR`` (tens of times with few support vectors). What is pickled:

* the model (``support_``, ``support_vectors_``, ``dual_coef_``, ``intercept_``, ...);
* the solver record: ``solution_`` without its vectors (status, certificate figures, backend,
  settings, times);
* the fit's ``C``, ``epsilon``, kernel and formulation, and a SHA-256 digest of its ``X`` and ``y``.

Within the process that fitted it, the model keeps ``problem_`` and ``solution_`` as they were
built (when the path built them at all) and the training rows: when the fit's path never formed
the QP, as ``solver="auto"`` does not, ``problem_`` is rebuilt from them on first access, and
``solution_`` gets its point and multipliers back from :math:`(\\beta, b)`
(:func:`svrqp.formulations.epsilon_svr_residuals.stated_dual`), its objective and certificates
recomputed on that QP (so they certify the returned coefficients). After unpickling, ``solution_``
is the solver record without vectors, and :meth:`CompactFitMixin.with_training_data` gives the
model its training rows back (checked against the digest) so that both are rebuilt as above. A
linear-kernel primal fit keeps its solution vectors (``O(n)`` numbers; the multipliers of that QP
are not a function of the model alone).

:class:`svrqp.LSSVR` (:class:`CompactSystemMixin`) keeps its solution (:math:`(b, \\alpha)`,
``O(n)``) and drops its KKT system (an :math:`(n+1)\\times(n+1)` matrix, S4 eq. (5)); every training
row is a support vector, so ``problem_`` is rebuilt from ``support_vectors_``, ``y`` and the fit's
``C`` and kernel (a precomputed Gram matrix is kept, as scikit-learn's ``KernelRidge`` keeps it).
"""

from __future__ import annotations

import dataclasses
import hashlib
from typing import Any

import numpy as np
from numpy.typing import NDArray

from svrqp.formulations import epsilon_svr, ls_svr
from svrqp.formulations.epsilon_svr_residuals import kernel_scale, stated_dual
from svrqp.kernels import gram
from svrqp.problems import LinearSystem, QuadraticProgram
from svrqp.solution import Solution

#: Attributes held only in memory (dropped from pickles, rebuilt on demand).
_CACHES = ("_problem", "_solution")
#: Entries of the fit record held only in memory: the
#: training rows (given back by ``with_training_data``).
_TRAINING_ROWS = ("X_rows", "others", "y")


class CompactFitMixin:
    """``problem_`` and ``solution_`` as properties;
    pickles keep the model and the solver record only."""

    @property
    def problem_(self) -> QuadraticProgram:
        """The QP that was solved (rebuilt from the training data when not held)."""
        if self.__dict__.get("_problem") is None:
            record = self._fit_record()
            self._problem = epsilon_svr.build(record["formulation"], record["y"], record["C"],
                                              record["epsilon"], K=self._fit_gram()
                                              if record["formulation"] != "primal" else None,
                                              X=self._training_rows())
        return self._problem

    @problem_.setter
    def problem_(self, value: QuadraticProgram | None) -> None:
        self._problem = value

    @property
    def solution_(self) -> Solution:
        """The certificate-checked :class:`svrqp.solution.Solution`
        (vectors rebuilt when not held)."""
        if self.__dict__.get("_solution") is None:
            self._solution = self._rebuilt_solution()
        return self._solution

    @solution_.setter
    def solution_(self, value: Solution) -> None:
        self._solution = value
        self._solution_record = value

    def _rebuilt_solution(self) -> Solution:
        record = self._fit_record(rows=False)
        if record["formulation"] == "primal":
            return self._solution_record  # pickled with its vectors
        if "y" not in record:
            # unpickled without training data: the record without vectors
            return self._solution_record
        X, y = self._training_rows(), record["y"]
        beta = np.zeros(y.size)
        beta[self.support_] = self.dual_coef_[0]
        Kbeta = self._kernel(X, X[self.support_]) @ self.dual_coef_[0]
        # X is the Gram matrix when the kernel is precomputed
        stated = stated_dual(record["formulation"], y, record["C"], record["epsilon"], beta,
                             float(self.intercept_[0]), Kbeta, kernel_scale(X, record["kernel"]))
        return Solution.of_stated(stated, self._solution_record.record)

    def _keep_fit_data(self, X: NDArray[np.float64], y: NDArray[np.float64],
                       formulation: str) -> None:
        """Store what rebuilding ``problem_`` and
        ``solution_`` needs (call at the end of ``fit``)."""
        self._fit_data = {"formulation": formulation, "C": float(self.C),
                          "epsilon": float(self.epsilon),
                          "kernel": {"kernel": self.kernel, "gamma": self.gamma_,
                                     "degree": self.degree, "coef0": self.coef0},
                          "n": int(y.size)}
        self._store_training_rows(X, y)

    def with_training_data(self, X: NDArray[np.float64], y: NDArray[np.float64]):
        """Give an unpickled model its training rows back, so
        that ``problem_`` and ``solution_`` can be rebuilt.

        Parameters
        ----------
        X, y
            Exactly the inputs (the Gram matrix for a precomputed kernel) and targets the model
            was fitted on, as float64 after the model's own validation.

        Returns
        -------
        self

        Raises
        ------
        ValueError
            When ``X`` and ``y`` are not the fit's data (their SHA-256 digest differs from the one
            recorded by ``fit``).
        """
        record = self._fit_record(rows=False)
        X, y = np.ascontiguousarray(X, dtype=float), np.ascontiguousarray(y, dtype=float).ravel()
        if _digest(X, y) != self._data_digest():
            raise ValueError(
                f"these are not the data {type(self).__name__} was fitted on (n = {record['n']}): "
                "problem_ and solution_ can only be rebuilt from the fit's own X and y"
            )
        self._store_training_rows(X, y)
        return self

    def _data_digest(self) -> str:
        """The digest of the fit's data, computed from the rows held the first time it is asked for
        (by a pickle, which leaves the rows out, or by
        :meth:`with_training_data`), not during ``fit``."""
        record = self._fit_record(rows=False)
        if "digest" not in record:
            record["digest"] = _digest(self._training_rows(), self._fit_record()["y"])
        return record["digest"]

    def _store_training_rows(self, X: NDArray[np.float64], y: NDArray[np.float64]) -> None:
        others = np.ones(X.shape[0], dtype=bool)
        if self.kernel != "precomputed":  # no support-vector rows: the Gram matrix is the data
            others[self.support_] = False
        self._fit_data.update({"X_rows": X[others], "others": others.nonzero()[0], "y": y})

    def _fit_record(self, rows: bool = True) -> dict[str, Any]:
        """The fit's record; with ``rows``, one that holds the
        training rows (after unpickling: once given back)."""
        if "_fit_data" not in self.__dict__:
            raise AttributeError("the model is not fitted: problem_ and solution_ exist after fit")
        if rows and "y" not in self._fit_data:
            raise AttributeError(f"an unpickled {type(self).__name__} does not carry its training "
                                 "rows (its pickle keeps what predicting needs, as scikit-learn's "
                                 "SVR): call model.with_training_data(X, y) with the fit's data "
                                 "to rebuild problem_")
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
        parameters = self._fit_record(rows=False)["kernel"]
        if parameters["kernel"] == "precomputed":  # A is the Gram matrix; B its support-vector rows
            return A[:, self.support_]
        return gram(A, B, **parameters)

    def _fit_gram(self) -> NDArray[np.float64]:
        X = self._training_rows()
        return (
            X
            if self._fit_record(rows=False)["kernel"]["kernel"] == "precomputed"
            else self._kernel(X, X)
        )

    def __getstate__(self) -> dict[str, Any]:
        # a copy: object.__getstate__ returns the live __dict__
        state = dict(super().__getstate__())
        for name in _CACHES:
            state.pop(name, None)
        record = state.get("_solution_record")
        if record is not None and self.__dict__.get("_fit_data", {}).get("formulation") != "primal":
            state["_solution_record"] = dataclasses.replace(record, x=None, y=None, z=None,
                                                            z_box=None)
        if "_fit_data" in state:
            self._data_digest()  # recorded before the rows are left out
            state["_fit_data"] = {key: value for key, value in state["_fit_data"].items()
                                  if key not in _TRAINING_ROWS}
        return state


def _digest(X: NDArray[np.float64], y: NDArray[np.float64]) -> str:
    """SHA-256 of the fit's data (shapes included), to recognise it when it is given back."""
    hash_ = hashlib.sha256()
    for array in (np.ascontiguousarray(X, dtype=float), np.ascontiguousarray(y, dtype=float)):
        hash_.update(str(array.shape).encode())
        hash_.update(array.tobytes())
    return hash_.hexdigest()


class CompactSystemMixin:
    """LS-SVR's ``problem_`` as a property: formed by
    ``fit`` only when solved by LU, never pickled."""

    @property
    def problem_(self) -> LinearSystem:
        """The KKT system of S4 eq. (5) (rebuilt from the training data when not held)."""
        if self.__dict__.get("_problem") is None:
            if "_fit_data" not in self.__dict__:
                raise AttributeError("the model is not fitted: problem_ exists after fit")
            record = self._fit_data
            K = record["K"] if record["K"] is not None else gram(self.support_vectors_,
                                                                 **record["kernel"])
            self._problem = ls_svr.kkt_system(K, record["y"], record["C"], record["fit_intercept"])
        return self._problem

    @problem_.setter
    def problem_(self, value: LinearSystem | None) -> None:
        self._problem = value

    def _keep_fit_data(self, K: NDArray[np.float64] | None, y: NDArray[np.float64]) -> None:
        """Store what rebuilding ``problem_`` needs; ``K``
        only for a precomputed kernel (call in ``fit``)."""
        self._fit_data = {"K": K, "y": y, "C": float(self.C),
                          "fit_intercept": bool(self.fit_intercept),
                          "kernel": {"kernel": self.kernel, "gamma": self.gamma_,
                                     "degree": self.degree, "coef0": self.coef0}}

    def __getstate__(self) -> dict[str, Any]:
        # a copy: object.__getstate__ returns the live __dict__
        state = dict(super().__getstate__())
        state.pop("_problem", None)
        return state

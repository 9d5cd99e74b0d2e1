"""The exact ε-SVR dual: the interior point, then the
crossover; on a low-rank factor when the kernel allows."""

from __future__ import annotations

import time
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from svrqp.kernels import gram, gram_diagonal, kernel_arguments
from svrqp.linalg.kernel_columns import KernelColumns
from svrqp.linalg.pivoted_cholesky import pivoted_cholesky
from svrqp.solvers.dual_ipm.crossover import (
    CROSSOVER_THRESHOLD,
    CrossoverResult,
    CrossoverSettings,
    DenseColumns,
    crossover,
)
from svrqp.solvers.dual_ipm.interior_point import IPMResult, check_inputs, interior_point
from svrqp.solvers.dual_ipm.kernel_operators import (
    DenseKernel,
    FactoredKernel,
    KernelOperator,
)


@dataclass
class ExactFit:
    """The exact ε-SVR dual solution found by :func:`solve_exact`, with where the time went."""

    beta: NDArray[np.float64]
    intercept: float
    ipm: IPMResult
    crossover: CrossoverResult
    times_s: dict[str, float]
    # whether the interior point ran on a low-rank factor (no Gram matrix formed)
    low_rank: bool = False


def solve_exact(K: NDArray[np.float64], y: NDArray[np.float64], C: float, epsilon: float, *,
                tol: float = 1e-8, max_iter: int = 100) -> ExactFit:
    """Interior point on the reduced dense system,
    then the active-set crossover to the exact optimum.

    When the crossover does not settle (``crossover.exact`` false) the interior-point solution is
    returned; its certificates say how accurate it is.
    """
    return _interior_point_then_crossover(DenseKernel(K), DenseColumns(K), y, C, epsilon, tol,
                                          max_iter, float(np.max(np.diagonal(K), initial=0.0)))


#: The interior point behind a crossover stops at this relative accuracy (or the requested one, if
#: looser): the crossover needs the active set, not the optimum, and states read with the
#: threshold :math:`\\sqrt{\\text{tol}}` are already right there; it saves about a third of the
#: iterations. When the crossover does not settle, the interior point is run again to ``tol``.
IDENTIFICATION_TOL = 1e-4


def _interior_point_then_crossover(kernel: KernelOperator, columns, y, C, epsilon, tol,
                                   max_iter, kernel_scale: float) -> ExactFit:
    times_s = {"ipm_s": 0.0, "crossover_s": 0.0}
    for ipm_tol in dict.fromkeys([max(tol, IDENTIFICATION_TOL), tol]):  # the loose run first
        start = time.perf_counter()
        ipm = interior_point(kernel, y, C, epsilon, tol=ipm_tol, max_iter=max_iter)
        middle = time.perf_counter()
        result = crossover(
            columns, y, C, epsilon, ipm.beta,
            settings=CrossoverSettings(threshold=max(CROSSOVER_THRESHOLD, np.sqrt(ipm_tol))),
            kernel_scale=kernel_scale,
        )
        times_s["ipm_s"] += middle - start
        times_s["crossover_s"] += time.perf_counter() - middle
        if result.exact:
            break
    beta, b = (result.beta, result.intercept) if result.exact else (ipm.beta, ipm.intercept)
    return ExactFit(beta, b, ipm, result, times_s)


@dataclass(frozen=True)
class ExactSettings:
    """Accuracy and low-rank settings of :func:`solve_exact_from_data`."""

    tol: float = 1e-8  #: relative accuracy of the interior point
    max_iter: int = 100  #: interior-point iteration limit
    factor_tol: float = 3e-5  #: relative trace error the pivoted Cholesky factor must reach
    max_rank: int | None = None  #: rank limit of the factor (None: n // 8)


def solve_exact_from_data(X: NDArray[np.float64], y: NDArray[np.float64], C: float, epsilon: float,
                          kernel_parameters: Mapping[str, Any], *,
                          settings: ExactSettings = ExactSettings(),
                          K: NDArray[np.float64] | None = None) -> ExactFit:
    """The fastest exact path: a low-rank interior point
    when the kernel allows it, the dense one otherwise.

    ``kernel_parameters`` are ``kernel``, ``gamma``, ``degree`` and ``coef0`` as in
    :func:`svrqp.kernels.gram`. A pivoted Cholesky factor of rank at most ``settings.max_rank``
    (default ``n // 8``) is tried first; if its relative trace error reaches
    ``settings.factor_tol``, the interior point runs on
    :math:`LL^\top` in :math:`O(nr^2)` per iteration and the crossover, which uses exact kernel
    columns of the support vectors only, turns its solution into the exact optimum: the factor
    only guides the search (a coarser one means more crossover steps, not another answer). When
    the factor does not reach ``factor_tol`` or the crossover does not settle, the full Gram
    matrix is formed (or ``K`` used, when the caller already holds it) and :func:`solve_exact`
    runs. ``times_s`` adds the factorisation (``factor_s``) and Gram (``gram_s``) times.
    """
    X = np.asarray(X, dtype=float)
    y = np.asarray(y, dtype=float)
    n = X.shape[0]
    check_inputs(y, C, epsilon, n)
    tol, max_iter = settings.tol, settings.max_iter
    parameters = kernel_arguments(kernel_parameters)
    start = time.perf_counter()
    columns = KernelColumns(X, **parameters)
    factor = pivoted_cholesky(columns, max_rank=settings.max_rank or max(1, n // 8),
                              tol=settings.factor_tol, give_up=True)
    factor_s = time.perf_counter() - start
    if factor.relative_trace_error <= settings.factor_tol:
        scale = float(np.max(gram_diagonal(X, **parameters), initial=0.0))
        fit = _interior_point_then_crossover(FactoredKernel(factor.L), columns, y, C, epsilon, tol,
                                             max_iter, scale)
        if fit.crossover.exact:
            fit.times_s.update(factor_s=factor_s, gram_s=0.0)
            fit.low_rank = True
            return fit
    start = time.perf_counter()
    K = gram(X, **parameters) if K is None else K
    gram_s = time.perf_counter() - start
    fit = solve_exact(K, y, C, epsilon, tol=tol, max_iter=max_iter)
    fit.times_s.update(factor_s=factor_s, gram_s=gram_s)
    return fit

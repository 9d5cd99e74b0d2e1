r"""The ε-SVR dual by a loose decomposition run, then the exact active-set crossover.

**Method.** A working-set (decomposition) method — libsvm's SMO with second-order working-set
selection (Fan, Chen & Lin 2005, *Working set selection using second order information for
training support vector machines*, JMLR 6:1889–1918), run through scikit-learn's ``SVR`` — stops
at a loose tolerance (``WARM_START_TOL`` on its maximal KKT violation). Its coefficients say
which :math:`\beta_i` sit at :math:`\pm C`, at zero or in between; from that start the active-set
crossover of :func:`svrqp.solvers.dual_ipm.crossover` solves the free-set system

.. math::

    K_{FF}\beta_F + b\mathbf 1 = y_F - \varepsilon s_F - K_{F,\bar F}\beta_{\bar F},
    \qquad \mathbf 1^\top \beta_F = -\mathbf 1^\top \beta_{\bar F}

exactly and frees or fixes coefficients until every KKT condition of the dual (S0 eq. 6) holds to
rounding. SMO pays per support vector and per iteration, so a loose run is cheap; its tail to
1e-8 is what costs on smooth data, and the crossover replaces that tail by one or a few solves of
size :math:`|F|`. Up to ``DENSE_MAX_POINTS`` points (below the sizes where screening starts) the
n×n Gram matrix is formed once and both the loose run and the crossover read it; above, only kernel
columns of support vectors are formed (:class:`svrqp.linalg.kernel_columns.KernelColumns`), and the
loose run first holds the points a pilot fit settles at zero or at ±C
(:mod:`svrqp.solvers.screening`).

The result is exact only when the crossover says so (``exact``); the caller certifies it on the
stated QP (:mod:`svrqp.formulations.epsilon_svr_residuals`) and otherwise moves to another path.
"""

from __future__ import annotations

import time
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from svrqp.formulations.epsilon_svr_residuals import kernel_scale
from svrqp.kernels import kernel_arguments
from svrqp.linalg.kernel_columns import KernelColumns
from svrqp.solvers.dual_ipm.crossover import DenseColumns, crossover, products_of
from svrqp.solvers.screening import SCREEN_MIN_POINTS, decomposition_fit, screened_fit

#: libsvm's stopping tolerance for the warm start: its own default, loose next to the 1e-8 an exact
#: answer needs; the crossover finishes the job. (1e-2 saves SMO iterations at large C but costs
#: crossover steps at small C, where SMO is cheap anyway: measured on the benchmark panel.)
WARM_START_TOL = 1e-3


@dataclass
class WarmStartFit:
    """Outcome of :func:`solve_warm_started`: coefficients,
    bias, :math:`K\\beta` and the crossover record."""

    beta: NDArray[np.float64]
    intercept: float
    Kbeta: NDArray[np.float64]
    exact: bool
    crossover_steps: int
    smo_iterations: int
    screened: int = 0  #: points the warm start held at zero or ±C (:mod:`svrqp.solvers.screening`)
    times_s: dict[str, float] = field(default_factory=dict)


#: Below the size where screening starts, the whole Gram matrix is formed at once by one product
#: of the column factors, and both the loose run (libsvm on it as a precomputed kernel: each value
#: looked up, not computed again) and the crossover read it. A column cache's and a product's
#: bookkeeping cost more than the matrix at n = 50 (0.82–0.95× the fit's time), and from n = 100
#: to 1500 libsvm's own kernel evaluations are most of a loose run on smooth data, where its
#: tolerance hardly matters (issue 38, `benchmarks/results/epsilon_svr_small_smooth.md` against
#: `..._before_dense.md`, the same machine minutes apart: thermal generator 0.85× and 0.82×
#: libsvm's time at n = 200 and 1000, 1.01× and 1.11× before; noisy sinc 0.61× and 0.41×, 0.77×
#: and 0.39× before; n = 50 unchanged, 1.06–1.17×). At 1999 points the matrix is 32 MB.
DENSE_MAX_POINTS = SCREEN_MIN_POINTS - 1


def solve_warm_started(X: NDArray[np.float64], y: NDArray[np.float64], C: float, epsilon: float,
                       kernel_parameters: Mapping[str, Any], *,
                       smo_tol: float = WARM_START_TOL) -> WarmStartFit:
    """Loose SMO (Fan, Chen & Lin 2005) then the exact crossover (module docstring).

    On a kernel of inputs the loose run first tries the held start of
    :func:`svrqp.solvers.screening.screened_fit`; when the crossover does not settle from it,
    the loose run over all points and the crossover start again.

    Parameters
    ----------
    X
        Training inputs, or the training Gram matrix when ``kernel_parameters["kernel"]`` is
        ``"precomputed"``.
    y, C, epsilon
        Targets and SVR parameters.
    kernel_parameters
        ``kernel``, ``gamma``, ``degree``, ``coef0`` in scikit-learn's convention (the same as
        :func:`svrqp.kernels.gram`).
    smo_tol
        libsvm's tolerance for the warm start.
    """
    C, epsilon = float(C), float(epsilon)
    start = time.perf_counter()
    screened = None
    smo_X, smo_kernel = X, kernel_parameters
    if kernel_parameters["kernel"] == "precomputed":
        columns = DenseColumns(X)
    elif y.size <= DENSE_MAX_POINTS:  # below screening's sizes: one Gram matrix for both stages
        # checked finite as it is formed (KernelColumns.uncached)
        K = KernelColumns(X, **kernel_arguments(kernel_parameters)).uncached(np.arange(y.size))
        columns = DenseColumns(K)
        smo_X, smo_kernel = K, {**kernel_parameters, "kernel": "precomputed"}
    else:
        columns = KernelColumns(X, **kernel_arguments(kernel_parameters))
        screened = screened_fit(X, y, C, epsilon, kernel_parameters, smo_tol, columns.products)
    warm = screened or decomposition_fit(smo_X, y, C, epsilon, smo_kernel, smo_tol)
    middle = time.perf_counter()
    scale = kernel_scale(X, kernel_parameters)
    result = crossover(columns, y, C, epsilon, warm.beta, kernel_scale=scale,
                       # the bounds' product is formed already: the bounded term starts there
                       bounded_start=None if screened is None else screened.bounded_term)
    iterations = warm.iterations
    if screened is not None and not result.exact:  # the held start misled it: start from all points
        warm = decomposition_fit(X, y, C, epsilon, kernel_parameters, smo_tol)
        iterations += warm.iterations
        result = crossover(columns, y, C, epsilon, warm.beta, kernel_scale=scale)
    Kbeta = result.Kbeta
    if Kbeta is None:  # not exact: the caller rejects it, but its certificates are still reported
        support = np.flatnonzero(result.beta)
        Kbeta = products_of(columns)(support, result.beta[support])
    end = time.perf_counter()
    return WarmStartFit(result.beta, result.intercept, Kbeta, result.exact, result.steps,
                        iterations,
                        warm.screened, {"smo_s": middle - start, "crossover_s": end - middle})

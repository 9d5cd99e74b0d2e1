r"""A warm start for the ε-SVR dual that leaves out the points a pilot fit puts inside the tube.

**Why.** A point strictly inside the ε-tube at the optimum, :math:`|y_i - f(x_i)| < \varepsilon`, has
:math:`\beta_i = 0` (the KKT conditions of the dual, S0 eq. 6): it neither enters :math:`f` nor costs
the decomposition method anything once it is known. On smooth data with noisy readings most points
end there, and a decomposition run over all of them spends its time proving it.

**Method: chunking from a pilot fit** (Osuna, Freund & Girosi 1997, *An improved training
algorithm for support vector machines*, Proc. IEEE NNSP VII, 276–285: solve the QP on a working
set, check the KKT conditions of the points left out, add the violators, solve again).

1. *Pilot.* A loose decomposition run on a random subsample of :math:`m` points with
   :math:`C\,n/m` (the subsample's loss sum estimates the full one) gives residuals
   :math:`r_i = y_i - f_{\text{pilot}}(x_i)` of every point.
2. *Screen.* Points with :math:`|r_i| < (1 - \mu)\,\varepsilon` (``INSIDE_MARGIN`` :math:`=\mu`)
   are left out and held at :math:`\beta_i = 0`. Screening is used only when it leaves out at
   least ``MIN_SCREENED`` of the points; otherwise the caller runs on all of them.
3. *Chunk.* The loose decomposition run on the points kept gives :math:`\beta` and :math:`b`;
   a point left out whose residual under that fit leaves the tube, :math:`|r_i| > \varepsilon`,
   violates its KKT condition and is put back. This repeats (at most ``MAX_ROUNDS`` runs) while
   more than ``CROSSOVER_VIOLATORS`` points violate; the few left are freed by the crossover.

Nothing here is assumed exact: the result is only a start for the active-set crossover
(:func:`svrqp.solvers.dual_ipm.crossover.crossover`), which checks every KKT condition on all
points, and the caller certifies the answer on the stated QP.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from svrqp.kernels import gram

#: Share of the points in the pilot's subsample (at least ``PILOT_MIN_POINTS``).
PILOT_FRACTION = 0.1
PILOT_MIN_POINTS = 200
#: Screening is tried from this many points on: below, a decomposition run over all points is
#: cheap and the pilot would cost more than it saves.
SCREEN_MIN_POINTS = 1000
#: A point is left out when the pilot's residual is within (1 − INSIDE_MARGIN)·ε of the tube's centre.
INSIDE_MARGIN = 0.5
#: Screening pays only when it leaves out at least this share of the points (a decomposition run
#: costs about the square of the points it keeps; 0.5 left the thermal panel set at n = 4000, C = 1,
#: with 43 % inside, on the slower run over all points).
MIN_SCREENED = 0.3
#: Decomposition runs on the kept points, at most.
MAX_ROUNDS = 3
#: Points left out that violate their KKT condition after a run: up to this many are left to the
#: crossover — as many as it lets enter the free set in one step
#: (:data:`svrqp.solvers.dual_ipm.crossover.ENTERING_PER_STEP`) —, more trigger another run.
CROSSOVER_VIOLATORS = 64

#: libsvm's kernel cache in MB (scikit-learn's default is 200).
CACHE_SIZE_MB = 1000.0


@dataclass
class DecompositionFit:
    """Coefficients and bias of a loose decomposition run, on all points or on those kept."""

    beta: NDArray[np.float64]
    intercept: float
    iterations: int
    rounds: int = 1
    screened: int = 0  #: points held at zero, left out of the last run


def decomposition_fit(X: NDArray[np.float64], y: NDArray[np.float64], C: float, epsilon: float,
                      kernel_parameters: Mapping[str, Any], tol: float,
                      rows: NDArray[np.intp] | None = None) -> DecompositionFit:
    """libsvm's SMO (second-order working-set selection) on ``rows`` (all when ``None``), β of every point.

    A precomputed kernel restricts the Gram matrix ``X`` to ``rows`` on both sides.
    """
    from sklearn.svm import SVR  # libsvm: the decomposition method

    parameters = {key: kernel_parameters[key] for key in ("kernel", "gamma", "degree", "coef0")}
    n = y.size
    rows = np.arange(n) if rows is None else rows
    X_rows = X[np.ix_(rows, rows)] if parameters["kernel"] == "precomputed" and rows.size < n else X[rows]
    smo = SVR(C=C, epsilon=epsilon, **parameters, tol=tol, cache_size=CACHE_SIZE_MB).fit(X_rows, y[rows])
    beta = np.zeros(n)
    beta[rows[smo.support_]] = smo.dual_coef_[0]
    return DecompositionFit(beta, float(smo.intercept_[0]), int(np.sum(smo.n_iter_)))


def screened_fit(X: NDArray[np.float64], y: NDArray[np.float64], C: float, epsilon: float,
                 kernel_parameters: Mapping[str, Any], tol: float,
                 products: Callable[[NDArray[np.intp], NDArray[np.float64]], NDArray[np.float64]],
                 *, seed: int = 0) -> DecompositionFit | None:
    """Chunking from a pilot fit (module docstring); ``None`` when screening would not pay.

    Parameters
    ----------
    X, y, C, epsilon, kernel_parameters, tol
        As :func:`decomposition_fit` (a kernel on inputs, not a precomputed one).
    products
        ``products(idx, v)`` returns :math:`K_{:, idx} v` over all points.
    seed
        Seed of the pilot's subsample (a fixed one: the start, not the answer, depends on it).
    """
    n = y.size
    if n < SCREEN_MIN_POINTS:
        return None
    m = max(PILOT_MIN_POINTS, int(PILOT_FRACTION * n))
    sample = np.sort(np.random.default_rng(seed).choice(n, m, replace=False))
    pilot = decomposition_fit(X[sample], y[sample], C * n / m, epsilon, kernel_parameters, tol)
    inside_limit = (1.0 - INSIDE_MARGIN) * epsilon
    support = np.flatnonzero(pilot.beta)
    parameters = {key: kernel_parameters[key] for key in ("kernel", "gamma", "degree", "coef0")}
    fitted = gram(X[sample], X[sample[support]], **parameters) @ pilot.beta[support] + pilot.intercept
    if np.mean(np.abs(y[sample] - fitted) < inside_limit) < MIN_SCREENED:  # decided on the subsample: cheap
        return None
    inside = np.abs(_residuals(y, pilot.beta, pilot.intercept, products, sample)) < inside_limit
    if inside.mean() < MIN_SCREENED:
        return None
    iterations = pilot.iterations
    for rounds in range(1, MAX_ROUNDS + 1):
        kept = np.flatnonzero(~inside)
        fit = decomposition_fit(X, y, C, epsilon, kernel_parameters, tol, rows=kept)
        iterations += fit.iterations
        violators = inside & (np.abs(_residuals(y, fit.beta, fit.intercept, products)) > epsilon)
        if violators.sum() <= CROSSOVER_VIOLATORS:
            break
        inside &= ~violators
    return DecompositionFit(fit.beta, fit.intercept, iterations, rounds, int(inside.sum()))


def _residuals(y, beta, intercept, products, points=None):
    """:math:`y - K\\beta - b` over all points; ``beta`` is over ``points`` (all when ``None``)."""
    support = np.flatnonzero(beta)
    idx = support if points is None else points[support]
    return y - products(idx, beta[support]) - intercept

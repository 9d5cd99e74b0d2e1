r"""A warm start for the ε-SVR dual that holds the points a pilot fit settles at zero or at ±C.

**Why.** At the optimum a point strictly inside the ε-tube, :math:`|y_i - f(x_i)| < \varepsilon`,
has :math:`\beta_i = 0`, and a point strictly outside it has :math:`\beta_i = C\,\mathrm{sign}(y_i -
f(x_i))` (the KKT conditions of the dual, S0 eq. 6). A decomposition run over all points spends
its time proving that of each of them: on smooth data with noisy readings most points end inside
the tube; at small C on hard data most end outside it, at ±C.

**Method: chunking from a pilot fit** (Osuna, Freund & Girosi 1997, *An improved training
algorithm for support vector machines*, Proc. IEEE NNSP VII, 276–285: solve the QP on a working
set with the other variables held, check the KKT conditions of the held ones, release the
violators, solve again).

1. *Pilot.* A loose decomposition run on a random subsample of :math:`m` points with
   :math:`C\,n/m` (the subsample's loss sum estimates the full one) gives residuals
   :math:`r_i = y_i - f_{\text{pilot}}(x_i)` of every point. A pilot that needs many iterations
   per point (many free support vectors: large C) stops early and nothing is held.
2. *Hold.* Points with :math:`|r_i| < (1 - \mu)\,\varepsilon` are held at :math:`\beta_i = 0`,
   points with :math:`|r_i| > (1 + \nu)\,\varepsilon` at :math:`\beta_i = C\,\mathrm{sign}(r_i)`
   (:math:`\mu` = ``INSIDE_MARGIN``, :math:`\nu` = ``OUTSIDE_MARGIN``: wider outside, where a
   wrong hold moves the fit of every neighbour). The bounded holds are balanced,
   :math:`\sum_{\text{held}}\beta_i = 0`, by releasing the least certain of the larger side, so
   that the run on the rest keeps the equality :math:`\mathbf 1^\top\beta = 0` on its own. Holding
   is used only when it covers at least ``MIN_SCREENED`` of the points (judged first on the
   subsample, where it is cheap, after a first pilot on ``CHECK_FRACTION`` of the points has
   shown at least half that share); otherwise the caller runs on all of them.
3. *Chunk.* The loose decomposition run on the released points, with targets
   :math:`y_U - K_{U,H}\beta_H`, gives :math:`\beta_U` and :math:`b`; a held point whose residual
   contradicts its hold (zero outside the tube, :math:`\pm C` inside it) is released. This repeats
   (at most ``MAX_ROUNDS`` runs) while more than ``CROSSOVER_VIOLATORS`` holds are contradicted;
   the few left are freed by the crossover.

Nothing here is assumed exact: the result is only a start for the active-set crossover
(:func:`svrqp.solvers.dual_ipm.crossover.crossover`), which checks every KKT condition on all
points, and the caller certifies the answer on the stated QP.
"""

from __future__ import annotations

import warnings
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any, NamedTuple

import numpy as np
from numpy.typing import NDArray

from svrqp.kernels import gram, kernel_arguments

#: Share of the points in the pilot's subsample (at least ``PILOT_MIN_POINTS``), and libsvm's
#: tolerance for it: its residuals are only as good as its subsample, so a loose run does. Measured
#: on the benchmark panel: 10 % left hundreds of holds at ±C contradicted on the noisy sinc set
#: (slower than no hold); 30 % at tolerance 0.1 took every C = 1 cell there below libsvm's time.
PILOT_FRACTION, PILOT_TOL = 0.3, 0.1
#: A first, cheaper pilot on this share decides whether the real one is worth running: holding is
#: dropped when it would hold less than half of ``MIN_SCREENED`` of its own subsample (on the panel
#: at 10 %: 0.08–0.12 on friedman1, where nothing can be held, at least 0.40 where holding paid).
CHECK_FRACTION = 0.1
PILOT_MIN_POINTS = 200
#: The pilot stops after this many SMO iterations per point of its subsample, and nothing is held:
#: many iterations per point mean many free support vectors (large C), where holds do not pay
#: (measured on the benchmark panel: up to 3.5 per point where they paid or cost little, 54–58 on
#: the noisy sinc set at C = 100, where the held run took 1.6× the run over all points).
PILOT_ITERATIONS_PER_POINT = 10
#: Holding is tried from this many points on: below, a decomposition run over all points is cheap
#: and the pilot costs more than it saves (measured on the benchmark panel at n = 1000, C = 1: the
#: held start took 1.16× and 1.50× libsvm's time where
#: the run over all points took 1.12× and 1.08×).
SCREEN_MIN_POINTS = 2000
#: A point is held at zero when the pilot's residual is within (1 − INSIDE_MARGIN)·ε of the tube's
#: centre, at ±C when it is beyond (1 + OUTSIDE_MARGIN)·ε.
INSIDE_MARGIN, OUTSIDE_MARGIN = 0.5, 2.0
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
#: Most libsvm SMO iterations of a warm start per training point (at least SMO_MIN_ITERATIONS):
#: SMO is a warm start only (the exact crossover follows), and with a nearly hard margin (the
#: linear kernel on inputs of 1e5 and more, or C = 1e6) it would otherwise run for minutes.
SMO_ITERATIONS_PER_POINT, SMO_MIN_ITERATIONS = 1_000, 100_000


@dataclass
class DecompositionFit:
    """Coefficients and bias of a loose decomposition run, on all points or on the released ones."""

    beta: NDArray[np.float64]
    intercept: float
    iterations: int
    rounds: int = 1
    #: points held at zero or ±C in the last run (None: no hold)
    held: NDArray[np.bool_] | None = None
    #: ``(v, K v)``: the coefficients at ±C of ``beta`` (held, or put there by the last run) and
    #: :math:`Kv`, a product from scratch that the residuals of the last run were formed with
    #: (None: no hold); the crossover's bounded term starts from it
    bounded_term: tuple[NDArray[np.float64], NDArray[np.float64]] | None = None

    @property
    def screened(self) -> int:
        """How many points the last run left out."""
        return 0 if self.held is None else int(self.held.sum())


def decomposition_fit(X: NDArray[np.float64], y: NDArray[np.float64], C: float, epsilon: float,
                      kernel_parameters: Mapping[str, Any], tol: float,
                      rows: NDArray[np.intp] | None = None,
                      max_iter: int | None = None) -> DecompositionFit:
    """libsvm's SMO (second-order working-set selection)
    on ``rows`` (all when ``None``), β of every point.

    A precomputed kernel restricts the Gram matrix ``X`` to ``rows`` on both sides; ``max_iter``
    (default: :data:`SMO_ITERATIONS_PER_POINT` per point, at least :data:`SMO_MIN_ITERATIONS`; -1:
    none) stops the run early, silently: the caller compares ``iterations`` with it.
    """
    if max_iter is None:
        n_rows = y.size if rows is None else len(rows)
        max_iter = max(SMO_MIN_ITERATIONS, SMO_ITERATIONS_PER_POINT * n_rows)
    parameters = kernel_arguments(kernel_parameters)
    if rows is None:  # all points: X and y as given, no copies
        X_rows, y_rows = X, y
    else:
        X_rows = X[np.ix_(rows, rows)] if parameters["kernel"] == "precomputed" else X[rows]
        y_rows = y[rows]
    support, coefficients, intercept, iterations = libsvm_smo(X_rows, y_rows, C, epsilon,
                                                              parameters, tol, max_iter)
    beta = np.zeros(y.size)
    beta[support if rows is None else rows[support]] = coefficients
    return DecompositionFit(beta, intercept, iterations)


def libsvm_smo(X: NDArray[np.float64], y: NDArray[np.float64], C: float, epsilon: float,
               parameters: Mapping[str, Any], tol: float,
               max_iter: int) -> tuple[NDArray[np.intp], NDArray[np.float64], float, int]:
    """libsvm's ε-SVR SMO on (X, y): support indices, their coefficients, the bias, iterations.

    ``parameters`` are :func:`svrqp.kernels.kernel_arguments`. libsvm is called through
    scikit-learn's own binding (``sklearn.svm._libsvm.fit``, what ``SVR.fit`` runs after its
    checks): the data were checked by the estimator, and ``SVR.fit``'s validation costs 20 times
    libsvm's own work on a 50-point fit (measured: 1.1 ms against 0.05 ms). Where that binding is
    missing or has another signature, the public ``SVR`` runs instead.

    Raises
    ------
    ValueError
        When libsvm's coefficients or bias are not finite (as ``SVR.fit`` raises).
    """
    if parameters["kernel"] == "precomputed":
        parameters = {**parameters, "gamma": 0.0}  # unused, but libsvm's binding wants a number
    try:
        from sklearn.svm import _libsvm

        _libsvm.set_verbosity_wrap(0)  # as SVR(verbose=False) sets it before every fit
        fitted = _libsvm.fit(np.ascontiguousarray(X, dtype=float),
                             np.ascontiguousarray(y, dtype=float), svm_type=LIBSVM_EPSILON_SVR,
                             C=float(C), epsilon=float(epsilon), tol=float(tol),
                             cache_size=CACHE_SIZE_MB, max_iter=int(max_iter), random_seed=0,
                             **parameters)
    except (ImportError, TypeError, AttributeError):
        return _public_smo(X, y, C, epsilon, parameters, tol, max_iter)
    support, _, _, dual_coef, intercept, _, _, _, iterations = fitted
    # array methods, not np.all / np.sum: their dispatch costs more than a small fit's arrays
    if not (np.isfinite(dual_coef).all() and np.isfinite(intercept).all()):
        raise ValueError("The dual coefficients or intercepts are not finite. The input data may "
                         "contain large values and need to be preprocessed.")
    return support, dual_coef[0], float(intercept[0]), int(iterations.sum())


#: libsvm's code for the ε-SVR (``svm_type``; scikit-learn's ``LIBSVM_IMPL`` order).
LIBSVM_EPSILON_SVR = 3


def _public_smo(X, y, C, epsilon, parameters, tol, max_iter):
    """:func:`libsvm_smo` through scikit-learn's public ``SVR``."""
    from sklearn.exceptions import ConvergenceWarning
    from sklearn.svm import SVR  # libsvm: the decomposition method

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ConvergenceWarning)
        smo = SVR(C=C, epsilon=epsilon, **parameters, tol=tol, cache_size=CACHE_SIZE_MB,
                  max_iter=max_iter).fit(X, y)
    return smo.support_, smo.dual_coef_[0], float(smo.intercept_[0]), int(np.sum(smo.n_iter_))


def screened_fit(X: NDArray[np.float64], y: NDArray[np.float64], C: float, epsilon: float,
                 kernel_parameters: Mapping[str, Any], tol: float,
                 products: Callable[[NDArray[np.intp], NDArray[np.float64]], NDArray[np.float64]],
                 *, seed: int = 0) -> DecompositionFit | None:
    """Chunking from a pilot fit (module docstring); ``None`` when holding would not pay.

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
    rng = np.random.default_rng(seed)
    check = _pilot(X, y, C, epsilon, kernel_parameters, _subsample(rng, n, CHECK_FRACTION))
    if check is None or check.share < MIN_SCREENED / 2:
        return None
    found = _pilot(X, y, C, epsilon, kernel_parameters, _subsample(rng, n, PILOT_FRACTION))
    if found is None or found.share < MIN_SCREENED:
        return None
    pilot, sample = found.fit, found.sample
    iterations = check.fit.iterations + pilot.iterations
    residual = _residuals(y, pilot.beta, pilot.intercept, products, sample)
    held, value = _holds(residual, C, epsilon)
    _balance(held, value, residual)
    if held.mean() < MIN_SCREENED or held.sum() > n - 2:
        return None
    for rounds in range(1, MAX_ROUNDS + 1):  # noqa: B007 (read after the loop)
        held_term = _times(products, value)
        fit = decomposition_fit(X, y - held_term, C, epsilon, kernel_parameters, tol,
                                rows=np.flatnonzero(~held))
        iterations += fit.iterations
        # the run's residuals, the product of its coefficients at ±C kept apart for the crossover
        at_bound = np.where(np.abs(fit.beta) >= C, fit.beta, 0.0)
        bounded_term = (value + at_bound, held_term + _times(products, at_bound))
        residual = y - bounded_term[1] - _times(products, fit.beta - at_bound) - fit.intercept
        contradicted = held & np.where(value == 0.0, np.abs(residual) > epsilon,
                                       value * residual < C * epsilon)
        if contradicted.sum() <= CROSSOVER_VIOLATORS:
            break
        held &= ~contradicted
        value[contradicted] = 0.0
        _balance(held, value, residual)
    return DecompositionFit(fit.beta + value, fit.intercept, iterations, rounds, held,
                            bounded_term)


class _Pilot(NamedTuple):
    fit: DecompositionFit  #: over the subsample
    share: float  #: of the subsample that would be held
    sample: NDArray[np.intp]


def _subsample(rng: np.random.Generator, n: int, fraction: float) -> NDArray[np.intp]:
    return np.sort(rng.choice(n, max(PILOT_MIN_POINTS, int(fraction * n)), replace=False))


def _pilot(X, y, C, epsilon, kernel_parameters, sample) -> _Pilot | None:
    """A pilot run on ``sample`` (step 1 of the module
    docstring); None when it exceeds its iteration budget."""
    n, m = y.size, sample.size
    budget = max(1, PILOT_ITERATIONS_PER_POINT * m)
    fit = decomposition_fit(X[sample], y[sample], C * n / m, epsilon, kernel_parameters, PILOT_TOL,
                            max_iter=budget)
    if fit.iterations >= budget:
        return None
    support = np.flatnonzero(fit.beta)
    fitted = gram(X[sample], X[sample[support]],
                  **kernel_arguments(kernel_parameters)) @ fit.beta[support]
    fitted += fit.intercept
    return _Pilot(fit, float(_holds(y[sample] - fitted, C, epsilon)[0].mean()), sample)


def _holds(residual: NDArray[np.float64], C: float,
           epsilon: float) -> tuple[NDArray[np.bool_], NDArray[np.float64]]:
    """Which points to hold (step 2 of the module docstring) and the β each is held at."""
    size = np.abs(residual)
    outside = size > (1.0 + OUTSIDE_MARGIN) * epsilon
    return (size < (1.0 - INSIDE_MARGIN) * epsilon) | outside, np.where(
        outside, C * np.sign(residual), 0.0
    )


def _balance(held: NDArray[np.bool_], value: NDArray[np.float64],
             residual: NDArray[np.float64]) -> None:
    """Release the least certain bounded holds of the
    larger side until the held β sum to zero (in place)."""
    excess = int(np.sum(value > 0) - np.sum(value < 0))
    if excess == 0:
        return
    side = np.flatnonzero(value > 0 if excess > 0 else value < 0)
    released = side[np.argsort(np.abs(residual[side]))[:abs(excess)]]
    held[released] = False
    value[released] = 0.0


def _times(products, v: NDArray[np.float64]) -> NDArray[np.float64]:
    """:math:`Kv` over all points from the columns of the nonzero entries of ``v`` only."""
    idx = np.flatnonzero(v)
    return products(idx, v[idx]) if idx.size else np.zeros(v.size)


def _residuals(y, beta, intercept, products, points):
    """:math:`y - K\\beta - b` over all points of a fit on ``points`` (``beta`` is over them)."""
    support = np.flatnonzero(beta)
    return y - products(points[support], beta[support]) - intercept

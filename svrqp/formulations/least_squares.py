r"""Least squares by the normal equations: multiple linear regression, polynomial fits,
and the least-squares reference line used to evaluate straightness.

Normal equations (S3 eq. (6), S2 eq. (5))
-----------------------------------------
For a design matrix :math:`X \in \mathbb{R}^{n \times p}` and targets :math:`y`, the
least-squares coefficients solve

.. math::

    \Bigl(\sum_{i=1}^{n} x_i x_i^\top\Bigr)\, a = \sum_{i=1}^{n} x_i y_i
    \quad\Longleftrightarrow\quad X^\top X\, a = X^\top y .

:func:`solve_normal_equations` equilibrates the columns first (:math:`D =
\operatorname{diag}(1/\lVert X_{:j}\rVert)`, so it solves :math:`(XD)^\top (XD)\, z = (XD)^\top y`,
:math:`a = D z`: the same equations, better scaled) and factors :math:`(XD)^\top (XD)` by
Cholesky. The rank is decided on the singular values of :math:`XD`; a rank-deficient design
raises :class:`~svrqp.exceptions.SingularSystemError` naming the columns involved, unless the
caller asks for the minimum-norm answer with ``rank_deficient="lstsq"``. A condition number
:math:`\kappa\bigl((XD)^\top XD\bigr)` above :data:`CONDITION_WARNING` issues an
:class:`IllConditionedWarning`.

Multiple linear regression (S0 eq. (5), S3 eq. (1))
---------------------------------------------------
.. math::

    y = a_0 + \sum_{j=1}^{p} a_j x_j .

With an intercept, :func:`fit_linear` eliminates :math:`a_0` from the normal equations
(its row says :math:`a_0 = \bar y - \bar x^\top a`) and solves the centred system

.. math::

    (X - \mathbf 1 \bar x^\top)^\top (X - \mathbf 1 \bar x^\top)\, a
        = (X - \mathbf 1 \bar x^\top)^\top (y - \bar y),

which is exactly the full system with the intercept column, without the round-off that the
large mean of, e.g., temperatures near 30 °C would cause.

Polynomial least squares (S2 eq. (22))
--------------------------------------
A degree-:math:`d` polynomial in one variable on :math:`[x_{\min}, x_{\max}]`. The monomials
:math:`x^0 \dots x^5` at 11 points over 0–550 mm give a normal matrix with a condition
number near :math:`4\cdot10^{27}` (still :math:`5\cdot10^{6}` with equilibrated columns);
:func:`fit_polynomial` instead maps :math:`x` to
:math:`u = (2x - x_{\min} - x_{\max})/(x_{\max} - x_{\min}) \in [-1, 1]` and uses the Legendre
basis :math:`P_0(u) \dots P_d(u)`, which is nearly orthogonal on spread-out points:

.. math::

    \hat y(x) = \sum_{m=0}^{d} c_m P_m(u(x)), \qquad V^\top V c = V^\top y,\quad V_{im} = P_m(u_i).

Least-squares reference line and straightness (S4 eqs. (2)–(3))
---------------------------------------------------------------
.. math::

    g(x) = kx + t,\qquad
    k = \frac{\sum_i (x_i - \bar x)(y_i - \bar y)}{\sum_i (x_i - \bar x)^2},\qquad
    t = \bar y - k \bar x,

    e_i = g(x_i) - y_i,\qquad \text{straightness} = \max_i e_i - \min_i e_i .

(The paper's denominator misses the square; this is the least-squares slope.)
"""

from __future__ import annotations

import warnings
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Literal

import numpy as np
import scipy.linalg
from numpy.polynomial import legendre

from svrqp.exceptions import ProblemError, SingularSystemError

RankDeficient = Literal["raise", "lstsq"]

#: Condition number of the equilibrated normal matrix above which a warning is issued:
#: the solution then keeps fewer than about six significant digits.
CONDITION_WARNING = 1e10


class IllConditionedWarning(UserWarning):
    """The normal-equation matrix is ill conditioned; the coefficients are unreliable."""


@dataclass(frozen=True)
class NormalEquationsSolution:
    """Solution of :math:`X^\\top X a = X^\\top y`.

    Attributes
    ----------
    coef : ndarray of shape (p,)
        The coefficients :math:`a`.
    rank : int
        Numerical rank of the (equilibrated) design matrix.
    condition_number : float
        Condition number of the equilibrated normal matrix :math:`(XD)^\\top XD` (``inf`` when
        rank deficient).
    """

    coef: np.ndarray
    rank: int
    condition_number: float


@dataclass(frozen=True)
class LinearFit:
    """A multiple linear regression :math:`y = a_0 + \\sum_j a_j x_j` (S0 eq. (5)).

    ``x_centre`` and ``centre_value`` (:math:`\\bar x` and :math:`\\bar y`; ``None`` and 0
    without an intercept) give the same line as :math:`f(x) = \\bar y + (x - \\bar x)^\\top a`, the
    form :meth:`predict` evaluates: with inputs offset far from zero (epoch seconds, 1.7e9) the raw
    form :math:`a_0 + x^\\top a` adds two numbers near :math:`10^{15}` and loses the answer.
    """

    coef: np.ndarray
    intercept: float
    rank: int
    condition_number: float
    x_centre: np.ndarray | None = None
    centre_value: float = 0.0

    def predict(self, X: np.ndarray) -> np.ndarray:
        """Evaluate :math:`\\bar y + (X - \\bar x) a` (:math:`a_0 + X a` without a centre)."""
        X = np.asarray(X, dtype=float)
        if self.x_centre is None:
            return X @ self.coef + self.intercept
        return (X - self.x_centre) @ self.coef + self.centre_value


@dataclass(frozen=True)
class PolynomialFit:
    """A Legendre-basis polynomial on the domain ``(x_min, x_max)`` (S2 eq. (22))."""

    legendre_coef: np.ndarray
    domain: tuple[float, float]
    condition_number: float

    def predict(self, x: np.ndarray) -> np.ndarray:
        """Evaluate :math:`\\sum_m c_m P_m(u(x))`."""
        return legendre.legval(_to_unit_interval(np.asarray(x, dtype=float), self.domain),
                               self.legendre_coef)

    def to_polynomial(self) -> np.polynomial.Polynomial:
        """The same polynomial in the power basis of :math:`u`, as a numpy ``Polynomial`` with
        this domain (so ``fit.to_polynomial()(x)`` equals ``fit.predict(x)``)."""
        power = legendre.leg2poly(self.legendre_coef)
        return np.polynomial.Polynomial(power, domain=list(self.domain), window=[-1.0, 1.0])


@dataclass(frozen=True)
class Straightness:
    """Least-squares reference line :math:`g(x) = kx + t` and the deviations from it (S4)."""

    slope: float
    intercept: float
    deviation: np.ndarray
    straightness: float


def check_finite_matrix(values: np.ndarray, name: str, ndim: int) -> np.ndarray:
    """Return ``values`` as a float array of dimension ``ndim``; raise if it holds NaN/inf."""
    array = np.asarray(values, dtype=float)
    if array.ndim != ndim:
        raise ProblemError(f"{name} must be {ndim}-dimensional, got shape {array.shape}")
    bad = ~np.isfinite(array)
    if bad.any():
        where = np.argwhere(bad)[0]
        raise ProblemError(
            f"{name} contains {int(bad.sum())} non-finite value(s) (NaN or inf), "
            f"first at index {tuple(int(i) for i in where)}"
        )
    return array


def _column_names(names: Sequence[str] | None, p: int) -> list[str]:
    return list(names) if names is not None else [f"x{j}" for j in range(p)]


def _equilibration(X: np.ndarray) -> np.ndarray:
    """Column scale factors :math:`1/\\lVert X_{:j}\\rVert` (1 for an all-zero column)."""
    norms = np.linalg.norm(X, axis=0)
    return 1.0 / np.where(norms > 0, norms, 1.0)


def _rank(singular_values: np.ndarray, n: int, p: int) -> int:
    tolerance = max(n, p) * np.finfo(float).eps * singular_values[0]
    return int(np.sum(singular_values > tolerance))


def _dependent_columns(scaled: np.ndarray, names: list[str]) -> list[str]:
    """Names of the columns that take part in the smallest singular direction."""
    _, _, vt = np.linalg.svd(scaled, full_matrices=False)
    null_direction = np.abs(vt[-1])
    return [names[j] for j in np.flatnonzero(null_direction > 0.1 * null_direction.max())]


def solve_normal_equations(
    X: np.ndarray,
    y: np.ndarray,
    *,
    rank_deficient: RankDeficient = "raise",
    column_names: Sequence[str] | None = None,
) -> NormalEquationsSolution:
    """Solve :math:`X^\\top X a = X^\\top y` (S3 eq. (6)) by an equilibrated Cholesky factorisation.

    Parameters
    ----------
    X : array of shape (n, p)
        Design matrix (one regressor per column, intercept column included if wanted).
    y : array of shape (n,)
        Targets.
    rank_deficient : {"raise", "lstsq"}
        What to do when ``X`` does not have full column rank: raise
        :class:`SingularSystemError` (default), or return the minimum-norm least-squares answer.
    column_names : sequence of str, optional
        Names used in error messages.

    Returns
    -------
    NormalEquationsSolution

    Raises
    ------
    ProblemError
        Non-finite values, mismatched shapes, fewer samples than parameters.
    SingularSystemError
        ``X`` is rank deficient and ``rank_deficient="raise"``.
    """
    X = check_finite_matrix(X, "X", 2)
    y = check_finite_matrix(y, "y", 1)
    n, p = X.shape
    if y.shape[0] != n:
        raise ProblemError(f"X has {n} rows but y has {y.shape[0]} values")
    if rank_deficient not in ("raise", "lstsq"):
        raise ProblemError(f"rank_deficient must be 'raise' or 'lstsq', got {rank_deficient!r}")
    names = _column_names(column_names, p)
    if n < p and rank_deficient == "raise":
        raise ProblemError(
            f"fewer samples than parameters: {n} sample(s) for {p} parameters, the "
            "least-squares problem is underdetermined"
        )
    scale = _equilibration(X)
    scaled = X * scale
    singular_values = np.linalg.svd(scaled, compute_uv=False)
    rank = _rank(singular_values, n, p)
    if rank < p:
        if rank_deficient == "raise":
            raise SingularSystemError(
                f"the design matrix is rank deficient (rank {rank} < {p} parameters); "
                f"linearly dependent column(s): {_dependent_columns(scaled, names)}"
            )
        return _minimum_norm(X, y, rank)
    condition_number = float((singular_values[0] / singular_values[-1]) ** 2)
    if rank_deficient == "lstsq" and condition_number * np.finfo(float).eps > 1e-2:
        # Full rank by the singular values, but too close to collinear for the normal equations,
        # whose condition number is the square of the
        # design's: Cholesky would fail or keep no digit.
        return _minimum_norm(X, y, rank, condition_number)
    if condition_number > CONDITION_WARNING:
        warnings.warn(
            f"the normal-equation matrix is ill conditioned (condition number "
            f"{condition_number:.2e} > {CONDITION_WARNING:.0e}); coefficients are unreliable",
            IllConditionedWarning,
            stacklevel=2,
        )
    try:
        factor = scipy.linalg.cho_factor(scaled.T @ scaled)
    except np.linalg.LinAlgError as err:
        raise SingularSystemError(
            f"Cholesky factorisation of the normal matrix failed: {err}"
        ) from err
    z = scipy.linalg.cho_solve(factor, scaled.T @ y)
    return NormalEquationsSolution(coef=z * scale, rank=rank, condition_number=condition_number)


def _minimum_norm(X: np.ndarray, y: np.ndarray, rank: int,
                  condition_number: float = np.inf) -> NormalEquationsSolution:
    """The minimum-norm least-squares answer by an SVD of ``X`` itself (``scipy.linalg.lstsq``),
    never through the normal equations; minimum norm of ``a`` itself, so on the unscaled columns."""
    a = scipy.linalg.lstsq(X, y)[0]
    return NormalEquationsSolution(coef=a, rank=rank, condition_number=condition_number)


def fit_linear(
    X: np.ndarray,
    y: np.ndarray,
    *,
    fit_intercept: bool = True,
    rank_deficient: RankDeficient = "raise",
    column_names: Sequence[str] | None = None,
) -> LinearFit:
    """Multiple linear regression :math:`y = a_0 + X a` by the (centred) normal equations.

    Parameters
    ----------
    X : array of shape (n, p)
    y : array of shape (n,)
    fit_intercept : bool
        Fit :math:`a_0` (eliminated by centring, see the module docstring).
    rank_deficient : {"raise", "lstsq"}
        See :func:`solve_normal_equations`.
    column_names : sequence of str, optional
        Names used in error messages (e.g. ``["T7", "T9"]``).

    Raises
    ------
    ProblemError
        Non-finite values, shape mismatch, fewer samples than parameters.
    SingularSystemError
        A constant column (collinear with the intercept) or linearly dependent columns.
    """
    X = check_finite_matrix(X, "X", 2)
    y = check_finite_matrix(y, "y", 1)
    n, p = X.shape
    names = _column_names(column_names, p)
    if not fit_intercept:
        solution = solve_normal_equations(X, y, rank_deficient=rank_deficient, column_names=names)
        return LinearFit(solution.coef, 0.0, solution.rank, solution.condition_number)
    if n < p + 1 and rank_deficient == "raise":
        raise ProblemError(
            f"fewer samples than parameters: {n} sample(s) for {p + 1} parameters (intercept "
            "included), the least-squares problem is underdetermined"
        )
    x_mean = X.mean(axis=0)
    y_mean = float(y.mean())
    centred = X - x_mean
    constant = [names[j] for j in range(p) if np.ptp(X[:, j]) == 0.0]
    if constant and rank_deficient == "raise":
        raise SingularSystemError(
            f"constant column(s) {constant}: a constant regressor is collinear with the "
            "intercept, so its coefficient is not identifiable"
        )
    # x_mean is rounded to the grid of the offset (2.4e-7 at 1.7e9): the centred columns then keep
    # a mean of that size, which their normal equations (no intercept column) would pass to the
    # answer times the slope. Subtract it too, and evaluate about x_mean with the matching value.
    drift = centred.mean(axis=0)
    centred = centred - drift
    solution = solve_normal_equations(
        centred, y - y_mean, rank_deficient=rank_deficient, column_names=names
    )
    intercept = y_mean - float(x_mean @ solution.coef) - float(drift @ solution.coef)
    return LinearFit(solution.coef, intercept, solution.rank, solution.condition_number, x_mean,
                     y_mean - float(drift @ solution.coef))


def _to_unit_interval(x: np.ndarray, domain: tuple[float, float]) -> np.ndarray:
    low, high = domain
    return (2.0 * x - low - high) / (high - low)


def fit_polynomial(
    x: np.ndarray, y: np.ndarray, degree: int, *, domain: tuple[float, float] | None = None
) -> PolynomialFit:
    """Least-squares polynomial of ``degree`` in one variable on the Legendre basis (S2 eq. (22)).

    Parameters
    ----------
    x, y : arrays of shape (n,)
    degree : int
        Polynomial degree :math:`d \\ge 0` (the paper uses 5).
    domain : (float, float), optional
        Interval mapped to :math:`[-1, 1]`; default ``(min(x), max(x))``.

    Raises
    ------
    ProblemError
        Non-finite values, negative degree, fewer distinct points than coefficients.
    """
    x = check_finite_matrix(x, "x", 1)
    y = check_finite_matrix(y, "y", 1)
    if x.shape != y.shape:
        raise ProblemError(f"x and y differ in length: {x.shape[0]} vs {y.shape[0]}")
    if not isinstance(degree, (int, np.integer)) or degree < 0:
        raise ProblemError(f"degree must be a non-negative integer, got {degree!r}")
    distinct = np.unique(x).size
    if distinct < degree + 1:
        raise ProblemError(
            f"a degree-{degree} polynomial needs at least {degree + 1} distinct x values, "
            f"got {distinct} in {x.size} sample(s)"
        )
    if domain is None:
        domain = (float(x.min()), float(x.max()))
    if not domain[1] > domain[0]:
        raise ProblemError(f"domain must be an interval (low < high), got {domain}")
    V = legendre.legvander(_to_unit_interval(x, domain), degree)
    names = [f"P{m}" for m in range(degree + 1)]
    solution = solve_normal_equations(V, y, column_names=names)
    return PolynomialFit(solution.coef, (float(domain[0]), float(domain[1])),
                         solution.condition_number)


def reference_line(x: np.ndarray, y: np.ndarray) -> tuple[float, float]:
    """Slope :math:`k` and intercept :math:`t` of the least-squares line (S4 eq. (2))."""
    x = check_finite_matrix(x, "x", 1)
    y = check_finite_matrix(y, "y", 1)
    if x.shape != y.shape:
        raise ProblemError(f"x and y differ in length: {x.shape[0]} vs {y.shape[0]}")
    if x.size < 2:
        raise ProblemError(f"a reference line needs at least 2 points, got {x.size}")
    dx = x - x.mean()
    sxx = float(dx @ dx)
    if sxx == 0.0:
        raise SingularSystemError("all x values are equal: the reference-line slope is undefined")
    k = float(dx @ (y - y.mean())) / sxx
    t = float(y.mean()) - k * float(x.mean())
    return k, t


def straightness(x: np.ndarray, y: np.ndarray) -> Straightness:
    """Deviations :math:`e_i = g(x_i) - y_i` from the reference line and their range (S4 eq. (3)).

    Parameters
    ----------
    x : array of shape (n,)
        Positions along the axis (e.g. mm).
    y : array of shape (n,)
        Measured perpendicular coordinate (e.g. μm).
    """
    k, t = reference_line(x, y)
    deviation = k * np.asarray(x, dtype=float) + t - np.asarray(y, dtype=float)
    return Straightness(k, t, deviation, float(deviation.max() - deviation.min()))

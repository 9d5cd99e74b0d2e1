r"""The ε-SVR optimality conditions at a model :math:`(\beta, b)`: stated once, checked by everyone.

**Conditions** (the KKT conditions of the dual, S0 eq. 6, in the stacked variables
:math:`[\alpha; \alpha^*]` of :mod:`svrqp.formulations.epsilon_svr`). With
:math:`\beta = \alpha^* - \alpha` and the residual :math:`r = y - K\beta - b\mathbf 1`, the
multipliers of the stacked QP are reconstructed from the model alone (:func:`multipliers`):

.. math::

    \alpha = \max(-\beta, 0), \qquad \alpha^* = \max(\beta, 0), \qquad \lambda = b, \qquad
    z_\alpha = -\varepsilon\mathbf 1 - r, \qquad z_{\alpha^*} = r - \varepsilon\mathbf 1,

where :math:`\lambda` multiplies :math:`\mathbf 1^\top(\alpha^* - \alpha) = 0` and
:math:`z_{box} = [z_\alpha; z_{\alpha^*}]` the box (qpsolvers' sign: negative on an active lower
bound, positive on an active upper one). Stationarity holds with them by construction; what
remains is :math:`\mathbf 1^\top\beta = 0`, :math:`|\beta_i| \le C` and, per point, a sign
condition on :math:`z_{box}` that depends on the state of :math:`\beta_i` (:func:`states`):

.. math::

    \beta_i = 0 &\Rightarrow |r_i| \le \varepsilon, \qquad
    0 < \pm\beta_i < C \Rightarrow r_i = \pm\varepsilon, \\
    \beta_i = C &\Rightarrow r_i \ge \varepsilon, \qquad\quad
    \beta_i = -C \Rightarrow r_i \le -\varepsilon .

:func:`kkt_violation` is how far each point is from its condition, in the units of y. The
returned model's own certificate (:func:`model_certificate`) weighs these violations by what
moving a coefficient would change in the predictions; :func:`dual_qp_point` writes the
multipliers in the variables of each dual QP, projected onto the bounds each variable sits at
(:func:`box_multipliers`: a sign condition that fails then shows as a stationarity residual), so
the stated QP's residuals certify a model however it was found.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from svrqp.exceptions import ProblemError, SolverError

#: The state of a coefficient (:func:`states`): at :math:`-C`,
#: free negative, zero, free positive, at :math:`+C`.
AT_LOWER, FREE_NEGATIVE, ZERO, FREE_POSITIVE, AT_UPPER = -2, -1, 0, 1, 2

#: The keys of :func:`model_certificate`.
MODEL_CERTIFICATES: tuple[str, ...] = ("box_rel", "balance_rel", "kkt_rel")

#: Rounding allowance of :func:`model_certificate`, in units of the float64 machine epsilon.
ROUNDING_ULPS = 64.0
#: How many roundings below C a variable of :func:`box_multipliers` still sits at C.
BOUND_ULPS = 4.0
#: The float64 machine epsilon, the unit of :data:`ROUNDING_ULPS` and :data:`BOUND_ULPS`.
EPS = float(np.finfo(float).eps)


def states(beta: NDArray[np.float64], C: float, bound_tol: float,
           zero_tol: float | None = None) -> NDArray[np.int8]:
    r"""The state of each coefficient: -2 at :math:`-C`, -1
    free negative, 0 zero, 1 free positive, 2 at :math:`+C`.

    :math:`|\beta_i| \le` ``zero_tol`` (default ``bound_tol``·C) is zero;
    :math:`|\beta_i| \ge C(1 - \text{bound\_tol})` is at its bound (``bound_tol = 0``: exactly
    0 and exactly :math:`\pm C`).
    """
    result = np.sign(beta).astype(np.int8)
    result[np.abs(beta) <= (bound_tol * C if zero_tol is None else zero_tol)] = ZERO
    result[beta >= C * (1 - bound_tol)] = AT_UPPER
    result[beta <= -C * (1 - bound_tol)] = AT_LOWER
    return result


class Multipliers(NamedTuple):
    """The stacked dual's point and multipliers at a model (module docstring)."""

    alpha: NDArray[np.float64]  #: max(-beta, 0)
    alpha_star: NDArray[np.float64]  #: max(beta, 0)
    lam: float  #: the equality multiplier, b
    z_box: NDArray[np.float64]  #: [z_alpha; z_alpha*] = [-epsilon - r; r - epsilon]
    residual: NDArray[np.float64]  #: r = y - K beta - b


def multipliers(beta: NDArray[np.float64], b: float, Kbeta: NDArray[np.float64],
                y: NDArray[np.float64], epsilon: float) -> Multipliers:
    r"""The reconstructed point and multipliers of the
    stacked dual at :math:`(\beta, b)` (module docstring).

    ``Kbeta`` is :math:`K\beta` on the training inputs (computed by the caller, from whatever
    kernel access it has).
    """
    r = y - Kbeta - b
    return Multipliers(np.maximum(-beta, 0.0), np.maximum(beta, 0.0), b,
                       np.concatenate([-epsilon - r, r - epsilon]), r)


def kkt_violation(residual: NDArray[np.float64], state: NDArray[np.int8],
                  epsilon: float) -> NDArray[np.float64]:
    r"""How far each point is from its condition (module docstring), in the units of y.

    :math:`|r_i| - \varepsilon` for a zero, :math:`|r_i - \varepsilon s_i|` for a free coefficient
    of sign :math:`s_i`, :math:`\varepsilon - r_i` at :math:`+C` and :math:`r_i + \varepsilon` at
    :math:`-C`; a point meets its condition when its value is at most 0 (a slack for rounding is
    the caller's). ``residual`` is :math:`r`
    (``Multipliers.residual``), ``state`` from :func:`states`.
    """
    free = np.abs(residual - epsilon * np.clip(state, FREE_NEGATIVE, FREE_POSITIVE))
    return np.select([state == ZERO, state == AT_UPPER, state == AT_LOWER],
                     [np.abs(residual) - epsilon, epsilon - residual, residual + epsilon], free)


def dual_qp_point(formulation: str, point: Multipliers, C: float
                  ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    r"""The primal point and multipliers ``(x, y_eq, z_box)``
    of a dual QP at the model of ``point``, for the box :math:`[0, C]` of each
    :math:`\alpha_i, \alpha^*_i`.

    In the variables of the QPs of :mod:`svrqp.formulations.epsilon_svr` (qpsolvers' signs):

    * split, :math:`x = [\beta; \alpha; \alpha^*]`: equality multipliers :math:`[r;\ b]`, box
      multipliers :math:`[0;\ z_\alpha;\ z_{\alpha^*}]`;
    * stacked, :math:`x = [\alpha; \alpha^*]`: equality multiplier :math:`b`, box multipliers
      :math:`[z_\alpha;\ z_{\alpha^*}]`.

    The box multipliers are those of ``point`` (:math:`-\varepsilon - r` and
    :math:`r - \varepsilon`) projected onto what the bound each variable sits at allows
    (:func:`box_multipliers`); what the projection removes is left in the QP's stationarity
    residual. At a model that satisfies the ε-SVR KKT conditions nothing is removed, so the QP's
    residuals certify the model independently of how it was found.
    """
    alpha, alpha_star, b, z_box, r = point
    z_box = box_multipliers(np.concatenate([alpha, alpha_star]), z_box, C)
    if formulation == "split":
        beta = alpha_star - alpha
        return (
            np.concatenate([beta, alpha, alpha_star]), np.concatenate([r, [b]]),
            np.concatenate([np.zeros(beta.size), z_box]),
        )
    if formulation == "stacked":
        return np.concatenate([alpha, alpha_star]), np.array([b]), z_box
    raise ProblemError(f"formulation must be one of ('split', 'stacked'), got {formulation!r}")


def box_multipliers(x: NDArray[np.float64], z: NDArray[np.float64],
                    C: float) -> NDArray[np.float64]:
    r"""The multipliers ``z`` of the box :math:`0 \le x \le C` projected onto the normal cone
    of the box at ``x``: at most 0 where :math:`x_i = 0`, at least 0 where :math:`x_i = C`, and 0
    strictly inside the box.

    A multiplier of a bound the variable does not sit at enters the duality gap multiplied by the
    bound: :math:`C\,z_i`. Left there, the rounding of :math:`r - \varepsilon` at a free
    coefficient (about :math:`10^{-16}` of y) counts C times over, and a wide box
    (:math:`C \gg \max|\beta|`: targets of 1e-12 with C = 10, or a linear kernel on large inputs)
    fails the gap certificate at the exact optimum (issue #39, findings 14 and 15). Projected, the
    same amount is measured once, as a stationarity residual in the units of y. A variable within
    :data:`BOUND_ULPS` roundings of C sits at C (:math:`u \cdot (C/u)` of a rescaled solve).
    """
    at_lower, at_upper = x <= 0.0, x >= C * (1.0 - BOUND_ULPS * EPS)
    return np.where(at_lower, np.minimum(z, 0.0), np.where(at_upper, np.maximum(z, 0.0), 0.0))


def model_certificate(y: NDArray[np.float64], beta: NDArray[np.float64],
                      K_beta: NDArray[np.float64], b: float,
                      C: float, epsilon: float, kernel_scale: float, *,
                      residual: NDArray[np.float64] | None = None) -> dict[str, float]:
    r"""How far a returned model :math:`(\beta, b)` is from the ε-SVR optimality conditions, in the
    units of the problem (not of C).

    With :math:`r = y - K\beta - b`, :math:`k = \max_i K_{ii}` (``kernel_scale``) and
    :math:`s_y = \operatorname{std}(y)` (:math:`\max|y|` or 1 for a constant ``y``):

    .. math::

        \text{box} = \max_i (|\beta_i| - C)^+ / C, \qquad
        \text{balance} = k\,\lvert \mathbf 1^\top\beta \rvert / s_y, \qquad
        \text{kkt} = \max_i v_i / s_y,

    where :math:`v_i` is the violation, in units of y, of the conditions of S0 eq. 6 at point i
    (module docstring): :math:`|r_i| \le \varepsilon` where :math:`\beta_i = 0`;
    :math:`r_i \ge \varepsilon` where :math:`\beta_i > 0` and :math:`r_i \le \varepsilon` where
    :math:`\beta_i < C` (mirrored for :math:`\beta_i < 0`). A condition of a non-zero
    coefficient counts at most what moving that coefficient to 0 or to its bound would change in
    the predictions (:math:`|\beta_i| k` or :math:`(C - |\beta_i|) k`), so a coefficient that is
    merely tiny or merely near its bound is not a violation, while a dropped support vector
    (:math:`\beta_i = 0` outside the tube) is. A model with every value at most δ is optimal for
    targets within about δ·s_y of y. ``residual`` is :math:`r` when the caller has it already
    (``Multipliers.residual``).
    """
    beta = np.asarray(beta, dtype=float)
    r = y - K_beta - b if residual is None else residual
    y_max = float(np.abs(y).max()) if y.size else 0.0
    s_y = target_scale(y)
    k = kernel_scale if kernel_scale > 0 else 1.0
    magnitude = np.abs(beta)
    # > 0: outside the tube on the coefficient's side, where it would grow; < 0: inside, where
    # it would shrink. A non-zero coefficient violates by |distance|, capped by what moving it to
    # its bound (growing) or to zero (shrinking) would change in the predictions.
    distance = np.sign(beta) * r - epsilon
    cap = np.where(distance < 0.0, magnitude, np.maximum(C - magnitude, 0.0)) * k
    violation = np.where(beta == 0.0, np.maximum(np.abs(r) - epsilon, 0.0),
                         np.minimum(np.abs(distance), cap))
    l1 = float(magnitude.sum())
    rounding = ROUNDING_ULPS * EPS * (y_max + abs(b) + k * l1)
    largest = (float(magnitude.max()), float(violation.max())) if beta.size else (0.0, 0.0)
    return {
        "box_rel": max(largest[0] - C, 0.0) / C,
        "balance_rel": max(k * abs(float(beta.sum())) - rounding, 0.0) / s_y,
        "kkt_rel": max(largest[1] - rounding, 0.0) / s_y,
    }


def target_scale(y: NDArray[np.float64]) -> float:
    r""":math:`s_y`, the scale the model certificate's values are relative to: std(y), or
    :math:`\max|y|` for a constant ``y``, or 1 when y is all zero."""
    spread = std(y)
    return spread if spread > 0 else ((float(np.abs(y).max()) if y.size else 0.0) or 1.0)


def std(y: NDArray[np.float64]) -> float:
    """``np.std(y)`` of a 1-D float array, the same operations (pairwise sums) without its
    dispatch, which costs more than the sums on a small fit."""
    if not y.size:
        return float("nan")
    # Python floats for the scalars: each numpy scalar operation costs a microsecond
    centred = y - float(np.add.reduce(y)) / y.size
    return math.sqrt(float(np.add.reduce(centred * centred)) / y.size)


def failed_model_certificates(certificate: dict[str, float], check_tol: float) -> list[str]:
    """The keys of :func:`model_certificate` in ``certificate`` whose value exceeds ``check_tol``
    (NaN included), in the order of :data:`MODEL_CERTIFICATES`;
    empty when the model meets them all."""
    return [key for key in MODEL_CERTIFICATES if not certificate[key] <= check_tol]


def require_model_certificate(certificate: dict[str, float], check_tol: float,
                              backend: str) -> None:
    """Raise :class:`~svrqp.exceptions.SolverError` naming ``backend`` when a value of
    :func:`model_certificate` in ``certificate`` (other keys are ignored) exceeds ``check_tol``
    (NaN included)."""
    failed = failed_model_certificates(certificate, check_tol)
    if failed:
        worst = failed[0]
        raise SolverError(f"backend {backend!r} returned a model that misses the ε-SVR optimality "
                          f"conditions: its {worst[:-4]} certificate is {certificate[worst]:.2e} "
                          f"(relative) > {check_tol:.1e}", backend, "inaccurate")

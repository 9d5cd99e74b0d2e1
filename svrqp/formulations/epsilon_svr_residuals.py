r"""The stated ε-SVR dual QP at a model :math:`(\beta, b)` from :math:`K\beta` alone, none formed.

The QPs of :mod:`svrqp.formulations.epsilon_svr` touch the kernel only through :math:`Px`:

* split, :math:`x = [\beta; \alpha; \alpha^*]`: :math:`Px = [K\beta;\ 0;\ 0]`;
* stacked, :math:`x = [\alpha; \alpha^*]`: :math:`Px = [-K\beta;\ K\beta]`;

and their equality matrices, vectors and box are as simple. So the stated QP's residuals — the
quantities of :meth:`svrqp.problems.QuadraticProgram.kkt_residuals`, the code every backend's
answer goes through: primal residual, dual residual, duality gap and complementarity, absolute and
relative — and its objective are evaluated block by block (:func:`stated_dual`) in :math:`O(n)`,
with no matrix and no 3n-vector of the QP formed: :math:`K\beta` comes from the kernel columns
of the support vectors only (:math:`O(n\,n_{SV})` kernel entries instead of the :math:`O(n^2)`
of building P), and a small fit pays no per-fit construction (the tests hold the two equal on the
QP built by :func:`svrqp.formulations.epsilon_svr.build`). The point and multipliers are those of
:func:`svrqp.formulations.epsilon_svr_certificate.dual_qp_point`; the returned model's own
certificate (:func:`svrqp.formulations.epsilon_svr_certificate.model_certificate`) is added to the
residuals.
"""

from __future__ import annotations

import functools
from typing import Any, NamedTuple

import numpy as np
from numpy.typing import NDArray

from svrqp.exceptions import ProblemError
from svrqp.formulations import epsilon_svr
from svrqp.formulations.epsilon_svr_certificate import (
    Multipliers,
    dual_qp_point,
    model_certificate,
    multipliers,
)
from svrqp.kernels import gram_diagonal


@functools.cache
def _name(formulation: str) -> str:
    """The name :func:`svrqp.formulations.epsilon_svr.build` gives the QP of ``formulation``."""
    return epsilon_svr.build(formulation, np.zeros(1), 1.0, 0.0, K=np.zeros((1, 1))).name


def kernel_scale(X: NDArray[np.float64], kernel_parameters: dict[str, Any]) -> float:
    """:math:`\\max_i K_{ii}` without forming K (``X`` is the Gram matrix for ``"precomputed"``)."""
    kernel = kernel_parameters["kernel"]
    if kernel == "rbf":  # k(x, x) = 1: nothing to evaluate
        return 1.0 if len(X) else 0.0
    if kernel == "precomputed":
        return float(np.max(np.diagonal(X), initial=0.0))
    return float(np.max(gram_diagonal(np.asarray(X, dtype=float), **kernel_parameters),
                        initial=0.0))


def _largest(v: NDArray[np.float64]) -> float:
    """The infinity norm of ``v`` (0 for an empty one)."""
    return float(np.abs(v).max()) if v.size else 0.0


def _box_and_sign_terms(x, z, C):
    """For the variables ``x`` with box :math:`0 \\le x \\le C` and box multipliers ``z``
    (qpsolvers' signs): the largest box violation, the gap's term :math:`C\\,\\mathbf 1^\\top
    \\max(z, 0)` (the lower bound's, :math:`0^\\top\\min(z, 0)`, is zero) and complementarity."""
    positive = np.maximum(z, 0.0)
    violation = max(-float(x.min()), float(x.max()) - C, 0.0) if x.size else 0.0
    complementarity = max(_largest(np.minimum(z, 0.0) * x), _largest(positive * (x - C)))
    return violation, C * float(positive.sum()), complementarity


#: The n-vectors of the split dual whose infinity norms :func:`_split_residuals` takes at once
#: (one row each of a stacked array; a 2n-vector of the pair of α-blocks takes two rows).
_SPLIT_ROWS = ("equality", "beta", "Kbeta", "y", "r_b", "r", "stationarity_beta",
               "stationarity_alpha", "stationarity_alpha_star", "z_alpha", "z_alpha_star",
               "lower_alpha", "lower_alpha_star", "upper_alpha", "upper_alpha_star")


def _split_residuals(y, C, epsilon, point: Multipliers, Kbeta):
    """Residuals and objective of the split dual, :math:`x = [\\beta; \\alpha; \\alpha^*]`:
    :math:`Px = [K\\beta; 0; 0]`, :math:`q = [-y; \\varepsilon; \\varepsilon]`,
    :math:`A x = [\\beta + \\alpha - \\alpha^*; \\mathbf 1^\\top\\beta]`,
    :math:`A^\\top [r; b] = [r + b; r; -r]`, box multipliers :math:`[0; z_\\alpha; z_{\\alpha^*}]`,
    :math:`-C \\le \\beta \\le C` and :math:`0 \\le \\alpha, \\alpha^* \\le C`. The infinity
    norms of :data:`_SPLIT_ROWS` are taken in one pass over their stacked rows (a small fit pays
    per numpy call, not per entry)."""
    alpha, alpha_star, b, z_pair, r = point
    beta = alpha_star - alpha
    pair = np.concatenate([alpha, alpha_star])
    positive = np.maximum(z_pair, 0.0)
    r_b = r + b
    rows = np.concatenate([beta + alpha - alpha_star, beta, Kbeta, y, r_b, r, Kbeta - y + r_b,
                           epsilon + np.concatenate([r, -r]) + z_pair, z_pair,
                           np.minimum(z_pair, 0.0) * pair, positive * (pair - C)])
    norm = dict(zip(_SPLIT_ROWS, np.abs(rows.reshape(len(_SPLIT_ROWS), -1)).max(axis=1).tolist(),
                    strict=True))
    balance = abs(float(beta.sum()))
    pair_low, pair_high = float(pair.min()), float(pair.max())
    curvature = float(beta @ Kbeta)
    linear = float(epsilon * pair.sum() - y @ beta)
    return _assembled(
        primal=(norm["equality"], balance, -pair_low, pair_high - C, norm["beta"] - C),
        primal_scale=(norm["beta"], max(-pair_low, pair_high), norm["equality"], balance, C),
        dual=max(norm["stationarity_beta"], norm["stationarity_alpha"],
                 norm["stationarity_alpha_star"]),
        dual_scale=(norm["Kbeta"], norm["y"], epsilon, norm["r_b"], norm["r"], norm["z_alpha"],
                    norm["z_alpha_star"]),
        gap_terms=(curvature, linear, C * float(positive.sum())),
        complementarity=max(norm["lower_alpha"], norm["lower_alpha_star"], norm["upper_alpha"],
                            norm["upper_alpha_star"]),
    ), 0.5 * curvature + linear


def _stacked_residuals(y, C, epsilon, point: Multipliers, Kbeta):
    """Residuals and objective of the stacked dual, :math:`x = [\\alpha; \\alpha^*]`:
    :math:`Px = [-K\\beta; K\\beta]`, :math:`q = [\\varepsilon + y; \\varepsilon - y]`,
    :math:`A x = -\\mathbf 1^\\top\\alpha + \\mathbf 1^\\top\\alpha^*`, :math:`A^\\top b = [-b; b]`,
    box multipliers :math:`[z_\\alpha; z_{\\alpha^*}]` and :math:`0 \\le x \\le C`."""
    alpha, alpha_star, b, z_box, _ = point
    x = np.concatenate([alpha, alpha_star])
    Px = np.concatenate([-Kbeta, Kbeta])
    q = np.concatenate([epsilon + y, epsilon - y])
    balance = abs(float(alpha_star.sum() - alpha.sum()))
    violation, upper_term, complementarity = _box_and_sign_terms(x, z_box, C)
    half = alpha.size
    stationarity = Px + q
    stationarity[:half] -= b
    stationarity[half:] += b
    curvature, linear = float(x @ Px), float(q @ x)
    return _assembled(
        primal=(balance, violation), primal_scale=(_largest(x), balance, C),
        dual=_largest(stationarity + z_box),
        dual_scale=(_largest(Kbeta), _largest(q), abs(b), _largest(z_box)),
        gap_terms=(curvature, linear, upper_term), complementarity=complementarity,
    ), 0.5 * curvature + linear


def _assembled(*, primal, primal_scale, dual, dual_scale, gap_terms,
               complementarity) -> dict[str, float]:
    """The keys of :meth:`QuadraticProgram.kkt_residuals` from their terms: each relative value
    divides by one plus the largest term of its expression (the gap's terms are
    :math:`x^\\top Px`, :math:`q^\\top x` and the box's)."""
    gap_scale = max(abs(term) for term in gap_terms)
    result = {"primal": max(0.0, *primal), "dual": dual, "gap": abs(sum(gap_terms)),
              "complementarity": complementarity}
    result["primal_rel"] = result["primal"] / (1.0 + max(primal_scale))
    result["dual_rel"] = dual / (1.0 + max(dual_scale))
    result["gap_rel"] = result["gap"] / (1.0 + gap_scale)
    result["complementarity_rel"] = complementarity / (1.0 + gap_scale)
    return result


class StatedDual(NamedTuple):
    """A model :math:`(\\beta, b)` judged on a stated dual QP: what :func:`stated_dual` returns."""

    name: str  #: the QP's name, as :func:`svrqp.formulations.epsilon_svr.build` gives it
    #: (x, y_eq, z, z_box)
    point: tuple[NDArray[np.float64], NDArray[np.float64], None, NDArray[np.float64]]
    #: the QP's residuals (keys of :meth:`QuadraticProgram.kkt_residuals`) and the model
    #: certificate (:func:`svrqp.formulations.epsilon_svr_certificate.model_certificate`)
    residuals: dict[str, float]
    objective: float  #: of the stated QP at x


def stated_dual(formulation: str, y: NDArray[np.float64], C: float, epsilon: float,
                beta: NDArray[np.float64], b: float, Kbeta: NDArray[np.float64],
                scale: float) -> StatedDual:
    r"""The residuals and objective of the stated dual of ``formulation`` at :math:`(\beta, b)`,
    term by term in :math:`O(n)`, with no QP formed.

    The same quantities as :meth:`~svrqp.problems.QuadraticProgram.kkt_residuals` and
    :meth:`~svrqp.problems.QuadraticProgram.objective` on the QP (equal to rounding: the tests
    compare them with the QP built by
    :func:`svrqp.formulations.epsilon_svr.build`), written per block of the QP's vectors: the
    primal residual (equalities, the balance :math:`\mathbf 1^\top\beta = 0`, the box), the dual
    residual (stationarity :math:`Px + q + A^\top y + z_{box}` and its scale), the duality gap and
    complementarity, each relative to one plus its largest term. Every vector of the point enters
    as it would through the QP (a point off the model, such as :math:`\beta \ne \alpha^* -
    \alpha`, is seen); only the matrices, whose products are known in closed form, are not formed.
    ``scale`` is :math:`\max_i K_{ii}` for the model certificate, added to the residuals.
    """
    point = multipliers(beta, b, Kbeta, y, epsilon)
    C, epsilon = float(C), float(epsilon)
    residuals_of = {"split": _split_residuals, "stacked": _stacked_residuals}.get(formulation)
    if residuals_of is None:
        raise ProblemError(f"formulation must be 'split' or 'stacked', got {formulation!r}")
    # What the certificate module gives, together: the QP's point and the model certificate.
    x, y_eq, z_box = dual_qp_point(formulation, point, C)
    # The box multipliers as the QP's point carries them (its last 2n entries, those of α and α*):
    # projected onto the bound each variable sits at (box_multipliers), so rounding at a free
    # coefficient is not counted C times over in the gap.
    point = Multipliers(*point[:3], z_box[z_box.size - 2 * beta.size:], point.residual)
    certificate = model_certificate(y, beta, Kbeta, b, C, epsilon, scale, residual=point.residual)
    residuals, objective = residuals_of(y, C, epsilon, point, Kbeta)
    residuals.update(certificate)
    return StatedDual(_name(formulation), (x, y_eq, None, z_box), residuals, objective)

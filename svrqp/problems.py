r"""Explicit optimisation problems: a quadratic program and a linear system.

A :class:`QuadraticProgram` is the problem every QP backend receives:

.. math::

    \min_{x \in \mathbb{R}^n} \ \tfrac12 x^\top P x + q^\top x
    \quad \text{s.t.} \quad G x \le h, \quad A x = b, \quad lb \le x \le ub

with Lagrangian (qpsolvers' sign convention, which every backend adapter maps into)

.. math::

    L(x, y, z, z_{box}) = \tfrac12 x^\top P x + q^\top x + z^\top (G x - h) + y^\top (A x - b)
    + z_{box}^\top x ,

where :math:`z \ge 0` and :math:`z_{box}` is negative on active lower bounds and positive on
active upper bounds. Its certificates:

.. math::

    r_p &= \max(\lVert Ax - b\rVert_\infty,\ \lVert (Gx - h)^+\rVert_\infty,
             \lVert (lb - x)^+\rVert_\infty,\ \lVert (x - ub)^+\rVert_\infty) \\
    r_d &= \lVert P x + q + A^\top y + G^\top z + z_{box}\rVert_\infty \\
    r_g &= \lvert x^\top P x + q^\top x + b^\top y +
    h^\top z + lb^\top z_{box}^- + ub^\top z_{box}^+\rvert

A :class:`LinearSystem` is :math:`M x = \text{rhs}` (the LS-SVR KKT system, normal equations).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
import scipy.linalg
import scipy.sparse as sp
from numpy.typing import NDArray

from svrqp.exceptions import ProblemError

Matrix = NDArray[np.float64] | sp.spmatrix | sp.sparray

#: Relative tolerance on symmetry and on the smallest eigenvalue of P (rounding in Gram matrices).
PSD_TOLERANCE = 1e-8
#: Above this size a sparse, non-diagonal P is not densified for the PSD check.
PSD_CHECK_MAX_DENSE = 6000


def _as_matrix(M: Any, name: str) -> Matrix | None:
    if M is None:
        return None
    if sp.issparse(M):
        M = sp.csc_matrix(M, dtype=float)
        values = M.data
    else:
        M = np.asarray(M)
        if M.dtype == object or not np.issubdtype(M.dtype, np.number):
            raise ProblemError(f"{name} must be numeric, got dtype {M.dtype}")
        M = np.atleast_2d(M.astype(float, copy=False))
        values = M
    if M.ndim != 2:
        raise ProblemError(f"{name} must be a 2-D matrix, got shape {M.shape}")
    if not np.all(np.isfinite(values)):
        raise ProblemError(f"{name} contains NaN or infinite entries")
    return M


def _as_vector(v: Any, name: str, size: int, *,
               allow_inf: bool = False) -> NDArray[np.float64] | None:
    if v is None:
        return None
    v = np.asarray(v)
    if v.dtype == object or not np.issubdtype(v.dtype, np.number):
        raise ProblemError(f"{name} must be numeric, got dtype {v.dtype}")
    v = np.ravel(v.astype(float))
    if v.shape != (size,):
        raise ProblemError(f"{name} must have {size} entries, got {v.shape[0]}")
    if np.any(np.isnan(v)) or (not allow_inf and not np.all(np.isfinite(v))):
        raise ProblemError(f"{name} contains NaN{'' if allow_inf else ' or infinite'} entries")
    return v


def _inf_norm(v: Any) -> float:
    v = np.asarray(v, dtype=float)
    return float(np.abs(v).max()) if v.size else 0.0


def check_psd(P: Matrix, name: str = "P", tolerance: float = PSD_TOLERANCE) -> None:
    """Raise :class:`ProblemError` unless ``P`` is symmetric positive semidefinite.

    Semidefiniteness is tested by a Cholesky factorisation of :math:`P + \\delta I` with
    :math:`\\delta = \\text{tolerance}\\cdot\\max(1, \\max_i |P_{ii}|)`: it succeeds for every PSD
    matrix (and for Gram matrices with rounding of order machine epsilon) and fails as soon as
    an eigenvalue is below :math:`-\\delta`. It costs a third of an eigen-decomposition.
    """
    n = P.shape[0]
    if P.shape != (n, n):
        raise ProblemError(f"{name} must be square, got shape {P.shape}")
    if sp.issparse(P):
        off_diagonal = P - sp.diags(P.diagonal())
        if off_diagonal.count_nonzero() == 0:
            if np.any(P.diagonal() < -tolerance * max(1.0, _inf_norm(P.diagonal()))):
                raise ProblemError(f"{name} has a negative diagonal entry: it is not PSD")
            return
        if n > PSD_CHECK_MAX_DENSE:
            return  # documented: large sparse P built by our formulations from checked blocks
        P = P.toarray()
    scale = max(1.0, _inf_norm(np.diag(P)))
    if _inf_norm(P - P.T) > tolerance * scale:
        raise ProblemError(f"{name} is not symmetric (max |P - P^T| = {_inf_norm(P - P.T):.3g})")
    try:
        scipy.linalg.cholesky(P + tolerance * scale * np.eye(n), lower=True, check_finite=False)
    except np.linalg.LinAlgError:
        smallest = float(scipy.linalg.eigvalsh(P, subset_by_index=[0, 0], check_finite=False)[0])
        raise ProblemError(
            f"{name} is not positive semidefinite (smallest eigenvalue {smallest:.3g})"
        ) from None


@dataclass
class QuadraticProgram:
    r"""The QP :math:`\min \tfrac12 x^\top P x + q^\top x`
    s.t. :math:`Gx \le h,\ Ax = b,\ lb \le x \le ub`.

    Parameters
    ----------
    P, q
        Cost matrix (dense or sparse, symmetric PSD) and vector.
    G, h
        Inequality constraints, or ``None``.
    A, b
        Equality constraints, or ``None``.
    lb, ub
        Box bounds (may hold infinities), or ``None``.
    name
        Short name shown in reports (``"epsilon-SVR dual, split form"``).
    statement
        The formulation in its own symbols as LaTeX, shown by :meth:`to_latex`.
    check_psd
        Verify that ``P`` is PSD on construction; formulations that checked the kernel block
        already pass ``False`` (the block structure keeps it PSD).
    """

    P: Matrix
    q: NDArray[np.float64]
    G: Matrix | None = None
    h: NDArray[np.float64] | None = None
    A: Matrix | None = None
    b: NDArray[np.float64] | None = None
    lb: NDArray[np.float64] | None = None
    ub: NDArray[np.float64] | None = None
    name: str = "quadratic program"
    statement: str | None = None
    check_psd: bool = field(default=True, repr=False)

    def __post_init__(self) -> None:
        self.P = _as_matrix(self.P, "P")
        n = self.P.shape[0]
        if self.P.shape != (n, n):
            raise ProblemError(f"P must be square, got shape {self.P.shape}")
        self.q = _as_vector(self.q, "q", n)
        for M_name, v_name in (("G", "h"), ("A", "b")):
            M, v = getattr(self, M_name), getattr(self, v_name)
            if (M is None) != (v is None):
                raise ProblemError(f"{M_name} and {v_name} must be given together")
            if M is None:
                continue
            M = _as_matrix(M, M_name)
            if M.shape[1] != n:
                raise ProblemError(f"{M_name} must have {n} columns, got {M.shape[1]}")
            setattr(self, M_name, M)
            setattr(self, v_name, _as_vector(v, v_name, M.shape[0]))
        self.lb = _as_vector(self.lb, "lb", n, allow_inf=True)
        self.ub = _as_vector(self.ub, "ub", n, allow_inf=True)
        if self.lb is not None and self.ub is not None and np.any(self.lb > self.ub):
            raise ProblemError("lb must be <= ub elementwise")
        if self.check_psd:
            check_psd(self.P)

    @property
    def n(self) -> int:
        """Number of variables."""
        return self.P.shape[0]

    def objective(self, x: NDArray[np.float64]) -> float:
        r""":math:`\tfrac12 x^\top P x + q^\top x`."""
        x = np.asarray(x, dtype=float)
        return float(0.5 * x @ (self.P @ x) + self.q @ x)

    def kkt_residuals(
        self,
        x: NDArray[np.float64],
        y: NDArray[np.float64] | None = None,
        z: NDArray[np.float64] | None = None,
        z_box: NDArray[np.float64] | None = None,
    ) -> dict[str, float]:
        """Primal residual, dual residual, duality gap and complementarity, absolute and relative.

        Missing multipliers count as zero. The relative values divide by ``1 +`` the largest
        term of each expression (OSQP's scaling), so they are comparable across problem sizes
        and magnitudes of C. Returns keys ``primal``, ``dual``, ``gap``, ``complementarity``
        and the same with a ``_rel`` suffix.
        """
        x = np.asarray(x, dtype=float)
        zeros_n = np.zeros(self.n)
        Px = self.P @ x
        primal, primal_scale = [0.0], [_inf_norm(x)]
        stationarity = Px + self.q
        dual_scale = [_inf_norm(Px), _inf_norm(self.q)]
        gap = float(x @ Px + self.q @ x)
        gap_scale = [abs(float(x @ Px)), abs(float(self.q @ x))]
        complementarity = [0.0]
        if self.A is not None:
            y = np.zeros(self.A.shape[0]) if y is None else np.asarray(y, dtype=float)
            Ax = self.A @ x
            primal.append(_inf_norm(Ax - self.b))
            primal_scale += [_inf_norm(Ax), _inf_norm(self.b)]
            ATy = self.A.T @ y
            stationarity = stationarity + ATy
            dual_scale.append(_inf_norm(ATy))
            gap += float(self.b @ y)
            gap_scale.append(abs(float(self.b @ y)))
        if self.G is not None:
            z = np.zeros(self.G.shape[0]) if z is None else np.asarray(z, dtype=float)
            Gx = self.G @ x
            primal.append(_inf_norm(np.maximum(Gx - self.h, 0.0)))
            primal_scale += [_inf_norm(Gx), _inf_norm(self.h)]
            GTz = self.G.T @ z
            stationarity = stationarity + GTz
            dual_scale.append(_inf_norm(GTz))
            gap += float(self.h @ z)
            gap_scale.append(abs(float(self.h @ z)))
            complementarity.append(_inf_norm(z * (Gx - self.h)))
            primal.append(_inf_norm(np.minimum(z, 0.0)))  # z >= 0 is dual feasibility
        if self.lb is not None or self.ub is not None:
            z_box = zeros_n if z_box is None else np.asarray(z_box, dtype=float)
            stationarity = stationarity + z_box
            dual_scale.append(_inf_norm(z_box))
            for bound, sign_part, violation in (
                (self.lb, np.minimum(z_box, 0.0), lambda bd: bd - x),
                (self.ub, np.maximum(z_box, 0.0), lambda bd: x - bd),
            ):
                if bound is None:
                    continue
                finite = np.isfinite(bound)
                primal.append(_inf_norm(np.maximum(violation(bound)[finite], 0.0)))
                primal_scale.append(_inf_norm(bound[finite]))
                term = float(bound[finite] @ sign_part[finite])
                gap += term
                gap_scale.append(abs(term))
                complementarity.append(_inf_norm(sign_part[finite] * violation(bound)[finite]))
        result = {
            "primal": max(primal),
            "dual": _inf_norm(stationarity),
            "gap": abs(gap),
            "complementarity": max(complementarity),
        }
        result["primal_rel"] = result["primal"] / (1.0 + max(primal_scale))
        result["dual_rel"] = result["dual"] / (1.0 + max(dual_scale))
        result["gap_rel"] = result["gap"] / (1.0 + max(gap_scale))
        result["complementarity_rel"] = result["complementarity"] / (1.0 + max(gap_scale))
        return result

    def to_latex(self) -> str:
        """The problem as a student writes it: the formulation's own statement, then its QP form."""
        constraints = []
        if self.G is not None:
            constraints.append(rf"G x \le h, \; G \in "
                               rf"\mathbb{{R}}^{{{self.G.shape[0]}\times{self.n}}}")
        if self.A is not None:
            constraints.append(rf"A x = b, \; A \in "
                               rf"\mathbb{{R}}^{{{self.A.shape[0]}\times{self.n}}}")
        if self.lb is not None or self.ub is not None:
            constraints.append(r"lb \le x \le ub")
        generic = (
            rf"\min_{{x \in \mathbb{{R}}^{{{self.n}}}}} \; \tfrac12 x^\top P x + q^\top x"
            + (r" \quad \text{s.t.} \quad " + r", \quad ".join(constraints) if constraints else "")
        )
        parts = [f"% {self.name}"]
        if self.statement:
            parts.append(self.statement)
        parts.append(r"\text{as a QP:}\quad " + generic)
        return "\n".join(parts)


@dataclass
class LinearSystem:
    r"""The square linear system :math:`M x = \text{rhs}`.

    Parameters
    ----------
    M
        Square matrix, shape ``(n, n)``.
    rhs
        Right-hand side, shape ``(n,)``.
    name, statement
        As for :class:`QuadraticProgram`.
    """

    M: NDArray[np.float64]
    rhs: NDArray[np.float64]
    name: str = "linear system"
    statement: str | None = None

    def __post_init__(self) -> None:
        self.M = _as_matrix(self.M, "M")
        n = self.M.shape[0]
        if self.M.shape != (n, n):
            raise ProblemError(f"M must be square, got shape {self.M.shape}")
        self.rhs = _as_vector(self.rhs, "rhs", n)

    def residual(self, x: NDArray[np.float64]) -> dict[str, float]:
        r"""Absolute :math:`\lVert Mx - \text{rhs}\rVert_\infty` and its relative value."""
        Mx = self.M @ np.asarray(x, dtype=float)
        absolute = _inf_norm(Mx - self.rhs)
        return {"residual": absolute,
                "residual_rel": absolute / (1.0 + max(_inf_norm(Mx), _inf_norm(self.rhs)))}

    def to_latex(self) -> str:
        """The system as a student writes it."""
        n = self.M.shape[0]
        parts = [f"% {self.name}"]
        if self.statement:
            parts.append(self.statement)
        parts.append(rf"M x = \text{{rhs}}, \quad M \in \mathbb{{R}}^{{{n}\times{n}}}")
        return "\n".join(parts)

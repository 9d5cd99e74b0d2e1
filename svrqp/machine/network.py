r"""Lumped-capacitance thermal network, integrated exactly for piecewise-constant inputs.

Each node :math:`i` (a machine part) has a heat capacity :math:`C_i` (J/K) and exchanges heat
with other nodes through conductances :math:`G_{ij} = 1/R_{ij}` (W/K) and with prescribed
boundary temperatures (ambient air, ...) through :math:`G_{ib}`. With temperatures written as
deviations :math:`\theta = T - T_\mathrm{ref}` the energy balance of node :math:`i` is

.. math::

   C_i \dot\theta_i = Q_i(t) - \sum_j G_{ij}(\theta_i
   - \theta_j) - \sum_b G_{ib}(\theta_i - \theta_b(t)),

or, in matrix form with the weighted Laplacian
:math:`\mathcal{L} = \operatorname{diag}(G\mathbf{1} + G_b\mathbf{1}) - G`,

.. math::

   C\dot\theta = -\mathcal{L}\theta + Q + G_b\theta_b
   \quad\Longleftrightarrow\quad
   \dot\theta = A\theta + B u,\qquad A = -C^{-1}\mathcal{L},\quad B = C^{-1}[\,I \;\; G_b\,],\quad
   u = \begin{bmatrix} Q \\ \theta_b \end{bmatrix}.

The steady state for constant inputs is :math:`\theta_\infty = \mathcal{L}^{-1}(Q + G_b\theta_b)`;
it exists when every node is connected, possibly through other nodes, to a boundary (then
:math:`\mathcal{L}` is symmetric positive definite).

The system is stiff (time constants from minutes to hours), so it is not integrated with
Euler steps: with the input held constant over each step of length :math:`\Delta t`
(zero-order hold) the exact update is

.. math::

   \theta_{k+1} = \Phi\theta_k + \Gamma u_k, \qquad
   \begin{bmatrix}\Phi & \Gamma\\ 0 & I\end{bmatrix}
   = \exp\!\left(\begin{bmatrix}A & B\\ 0 & 0\end{bmatrix}\Delta t\right).

Time is in minutes throughout (``A`` in 1/min).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import scipy.linalg

from svrqp.exceptions import ProblemError, SingularSystemError

SECONDS_PER_MIN = 60.0


@dataclass(frozen=True, eq=False)
class LumpedNetwork:
    """A thermal network of heat capacities joined by conductances.

    Parameters
    ----------
    nodes
        Names of the nodes (machine parts), in state order.
    capacity_J_K
        Heat capacity :math:`C_i` of each node, J/K, shape ``(n,)``.
    conductance_W_K
        Symmetric node-to-node conductances :math:`G_{ij}`, W/K, shape ``(n, n)``, zero diagonal.
    boundaries
        Names of the prescribed-temperature boundaries (e.g. ``("ambient",)``).
    boundary_conductance_W_K
        Node-to-boundary conductances :math:`G_{ib}`, W/K, shape ``(n, m)``.
    """

    nodes: tuple[str, ...]
    capacity_J_K: np.ndarray
    conductance_W_K: np.ndarray
    boundaries: tuple[str, ...]
    boundary_conductance_W_K: np.ndarray

    def __post_init__(self) -> None:
        n, m = len(self.nodes), len(self.boundaries)
        C = np.asarray(self.capacity_J_K, dtype=float)
        G = np.asarray(self.conductance_W_K, dtype=float)
        G_b = np.asarray(self.boundary_conductance_W_K, dtype=float)
        if C.shape != (n,) or G.shape != (n, n) or G_b.shape != (n, m):
            raise ProblemError(
                f"network shapes: capacity {C.shape} must be ({n},), conductance {G.shape} "
                f"must be ({n}, {n}), boundary_conductance {G_b.shape} must be ({n}, {m})"
            )
        if not (np.all(np.isfinite(C)) and np.all(C > 0)):
            raise ProblemError("capacity_J_K: every heat capacity must be finite and > 0")
        for name, matrix in (("conductance_W_K", G), ("boundary_conductance_W_K", G_b)):
            if not (np.all(np.isfinite(matrix)) and np.all(matrix >= 0)):
                raise ProblemError(f"{name}: conductances must be finite and >= 0")
        if not np.allclose(G, G.T) or np.any(np.diag(G) != 0):
            raise ProblemError("conductance_W_K must be symmetric with a zero diagonal")
        object.__setattr__(self, "capacity_J_K", C)
        object.__setattr__(self, "conductance_W_K", G)
        object.__setattr__(self, "boundary_conductance_W_K", G_b)

    @property
    def laplacian_W_K(self) -> np.ndarray:
        r"""The weighted Laplacian :math:`\mathcal{L}` (W/K)."""
        G, G_b = self.conductance_W_K, self.boundary_conductance_W_K
        return np.diag(G.sum(axis=1) + G_b.sum(axis=1)) - G

    def state_matrices(self) -> tuple[np.ndarray, np.ndarray]:
        """Return ``(A, B)`` of :math:`\\dot\\theta = A\\theta + Bu`, time in minutes.

        ``u`` stacks the node heat inputs (W) and the boundary temperature deviations (K).
        """
        C_inv = SECONDS_PER_MIN / self.capacity_J_K
        A = -C_inv[:, None] * self.laplacian_W_K
        B = C_inv[:, None] * np.hstack([np.eye(len(self.nodes)), self.boundary_conductance_W_K])
        return A, B

    def steady_state(self, heat_W: np.ndarray, boundary_K: np.ndarray) -> np.ndarray:
        r"""Steady temperatures :math:`\theta_\infty = \mathcal{L}^{-1}(Q + G_b\theta_b)`.

        ``heat_W`` has shape ``(n, ...)`` and ``boundary_K`` shape ``(m, ...)``; trailing axes
        are independent input cases solved together.
        """
        heat_W, boundary_K = np.asarray(heat_W, float), np.asarray(boundary_K, float)
        rhs = heat_W + np.tensordot(self.boundary_conductance_W_K, boundary_K, axes=1)
        try:
            factor = scipy.linalg.cho_factor(self.laplacian_W_K)
        except np.linalg.LinAlgError as err:
            raise SingularSystemError(
                "thermal network has no steady state: some node has no conductive path to a "
                "boundary (the Laplacian is singular)"
            ) from err
        return scipy.linalg.cho_solve(factor, rhs)

    def time_constants_min(self) -> np.ndarray:
        """Time constants of the network's modes,
        :math:`-1/\\lambda_k(A)`, in minutes, ascending."""
        A, _ = self.state_matrices()
        # A is similar to the symmetric -C^{-1/2} L C^{-1/2}, so its eigenvalues are real.
        s = np.sqrt(SECONDS_PER_MIN / self.capacity_J_K)
        eigenvalues = np.linalg.eigvalsh(-(s[:, None] * self.laplacian_W_K * s[None, :]))
        return np.sort(-1.0 / eigenvalues)

    def discretise(self, dt_min: float) -> tuple[np.ndarray, np.ndarray]:
        """Exact zero-order-hold update matrices ``(Phi, Gamma)`` for a step of ``dt_min``."""
        if not (np.isfinite(dt_min) and dt_min > 0):
            raise ProblemError(f"dt_min must be finite and > 0, got {dt_min}")
        A, B = self.state_matrices()
        n, p = B.shape
        block = np.zeros((n + p, n + p))
        block[:n, :n], block[:n, n:] = A, B
        transition = scipy.linalg.expm(block * dt_min)
        return transition[:n, :n], transition[:n, n:]

    def simulate(
        self,
        inputs: np.ndarray,
        dt_min: float,
        theta0: np.ndarray,
        progress: Callable[[int], None] | None = None,
    ) -> np.ndarray:
        """Propagate the node temperatures through ``len(inputs)`` steps of ``dt_min``.

        Parameters
        ----------
        inputs
            Stacked inputs ``u_k`` held over step ``k``, shape ``(steps, n + m, ...)``; any
            trailing axes are independent input cases (used to superpose effects).
        dt_min
            Step length, minutes.
        theta0
            Initial temperature deviations, shape ``(n, ...)`` matching the trailing axes.
        progress
            Called with the number of steps done, every few hundred steps.

        Returns
        -------
        numpy.ndarray
            Temperatures at the step boundaries, shape ``(steps + 1, n, ...)``.
        """
        Phi, Gamma = self.discretise(dt_min)
        inputs = np.asarray(inputs, dtype=float)
        if inputs.ndim < 2 or inputs.shape[1] != Gamma.shape[1]:
            raise ProblemError(
                f"inputs must have shape (steps, {Gamma.shape[1]}, ...), got {inputs.shape}"
            )
        theta = np.empty((inputs.shape[0] + 1, *np.shape(theta0)))
        theta[0] = theta0
        for k, u_k in enumerate(inputs):
            theta[k + 1] = np.tensordot(Phi, theta[k], axes=1) + np.tensordot(Gamma, u_k, axes=1)
            if progress is not None and (k + 1) % 500 == 0:
                progress(k + 1)
        if progress is not None:
            progress(inputs.shape[0])
        return theta

    def boundary_heat_flow_W(self, theta: np.ndarray, boundary_K: np.ndarray) -> np.ndarray:
        r"""Heat flowing from the nodes into each
        boundary, :math:`\sum_i G_{ib}(\theta_i-\theta_b)`.

        ``theta`` has shape ``(..., n)`` and ``boundary_K``
        shape ``(..., m)``; returns ``(..., m)``.
        """
        G_b = self.boundary_conductance_W_K
        return np.asarray(theta) @ G_b - np.asarray(boundary_K) * G_b.sum(axis=0)

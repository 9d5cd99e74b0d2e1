"""Named test problems for the core cross-checks (DESIGN §3), each with why it is here."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from sklearn.datasets import load_diabetes

from svrqp.problems import QuadraticProgram


@dataclass(frozen=True)
class SVRCase:
    """One dataset with the ε-SVR parameters it is solved with."""

    name: str
    X: np.ndarray
    y: np.ndarray
    C: float
    epsilon: float
    gamma: float
    why: str
    C_linear: float | None = None  # C for the linear-kernel checks, when it differs (say why)


def diabetes() -> SVRCase:
    """scikit-learn's diabetes data (first 120 rows, target in units of 50): a 10-feature real set."""
    X, y = load_diabetes(return_X_y=True)
    return SVRCase("diabetes", X[:120], y[:120] / 50.0, C=10.0, epsilon=0.1, gamma=5.0,
                   why="real data, 10 features, a nearly singular RBF Gram matrix (eigenvalues ~1e-6)")


def thermal_two_sensors() -> SVRCase:
    """A 2-feature thermal-like set: axial error (μm) from a spindle-box and an ambient temperature.

    Imitates S0's (T7, T9) model: error grows with the spindle-box temperature and shrinks with
    ambient, with a mild non-linearity and 0.3 μm noise; inputs standardised as an SVR user would.
    """
    rng = np.random.default_rng(2013)
    t = np.linspace(0.0, 250.0, 80)  # minutes
    T7 = 30.0 + 8.0 * (1.0 - np.exp(-t / 40.0)) + rng.normal(0, 0.05, t.size)
    T9 = 30.0 + 0.8 * np.sin(2 * np.pi * t / 250.0) + rng.normal(0, 0.05, t.size)
    error_um = 3.77 * (T7 - 30.0) - 0.42 * (T9 - 30.0) + 0.08 * (T7 - 30.0) ** 2 + rng.normal(0, 0.3, t.size)
    X = np.column_stack([T7, T9])
    X = (X - X.mean(axis=0)) / X.std(axis=0)
    # With a linear kernel and C = 100, libsvm's single-precision kernel cache limits its own
    # accuracy: its w is 3e-5 off the exact optimum (objective 5e-10 above ours), i.e. 1.2e-5·std(y)
    # in prediction — beyond the contract. C = 10 keeps the reference within it.
    return SVRCase("thermal_two_sensors", X, error_um, C=100.0, epsilon=0.2, gamma=0.5,
                   why="S0-style two-temperature model: smooth, well conditioned, few free SVs",
                   C_linear=10.0)


def position_error_11() -> SVRCase:
    """S2's setting: positioning error δx (μm) at 11 positions over 0–550 mm (x scaled to [0, 1])."""
    x_mm = np.linspace(0.0, 550.0, 11)
    delta_x_um = 0.012 * x_mm + 1.5 * np.sin(2 * np.pi * x_mm / 275.0) + 0.2 * np.cos(x_mm / 40.0)
    return SVRCase("position_error_11", (x_mm / 550.0)[:, None], delta_x_um, C=11.3137, epsilon=0.05,
                   gamma=1.0 / 0.5946**2, why="11 points, 1 feature: tiny, most points are support vectors")


SVR_CASES = (diabetes, thermal_two_sensors, position_error_11)


def box_qp() -> QuadraticProgram:
    """min ½(x1² + x2²) − x1 − x2 s.t. x1 + x2 = 1, 0 ≤ x ≤ 0.8: optimum (0.5, 0.5), y = 0.5."""
    return QuadraticProgram(P=np.eye(2), q=-np.ones(2), A=np.ones((1, 2)), b=np.ones(1),
                            lb=np.zeros(2), ub=np.full(2, 0.8))

"""Benchmark problems: accuracy profiles, the generated datasets, and one dataset at one size."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from svrqp.exceptions import ProblemError
from svrqp.kernels import gram


@dataclass(frozen=True)
class Profile:
    """An accuracy profile: the tolerance asked of every
    method, and the one its certificates must meet."""

    name: str
    tol: float
    residual_tol: float


PROFILES: dict[str, Profile] = {
    "default": Profile("default", tol=1e-8, residual_tol=1e-6),
    "high": Profile("high", tol=1e-10, residual_tol=1e-8),
    "low": Profile("low", tol=1e-5, residual_tol=1e-3),
}


def _standardised(X: NDArray[np.float64], y: NDArray[np.float64]) -> tuple[NDArray, NDArray]:
    return (X - X.mean(axis=0)) / X.std(axis=0), (y - y.mean()) / y.std()


def friedman1(n: int, d: int, seed: int) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Friedman #1 (:func:`sklearn.datasets.make_friedman1`, noise 1.0), X and y standardised.

    Noisy: most points end up as support vectors, the slow case for SMO solvers.
    """
    from sklearn.datasets import make_friedman1

    if d < 5:
        raise ProblemError(f"friedman1 needs d >= 5 features, got d={d}")
    X, y = make_friedman1(n_samples=n, n_features=d, noise=1.0, random_state=seed)
    return _standardised(X, y)


def thermal(n: int, d: int, seed: int) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    r"""An S0-like thermal-error set: ``d`` temperatures (°C) and an axial error (μm), standardised.

    Sample times :math:`t` are uniform on 0–250 min; sensor :math:`k` warms up as
    :math:`T_k = 20 + a_k (1 - e^{-t/\tau_k})` with :math:`\tau_k` log-spaced over 20–120 min, plus
    0.05 °C noise; the error is :math:`\sum_k c_k (T_k - 20) + 0.05 (T_1 - 20)^2` plus 2 μm noise
    (about 0.1 std(y), so ε = 0.1 sits at the noise level as a tuned model would). Smooth, with a
    low numerical rank kernel: few free support vectors, most support vectors at the bound C.
    """
    rng = np.random.default_rng(seed)
    time_min = rng.uniform(0.0, 250.0, n)
    tau_min = np.geomspace(20.0, 120.0, d)
    rise_C = rng.uniform(4.0, 12.0, d)
    T_C = (
        20.0 + rise_C * (1.0 - np.exp(-time_min[:, None] / tau_min)) + rng.normal(0.0, 0.05, (n, d))
    )
    weights_um_per_C = rng.uniform(-1.0, 4.0, d)
    error_um = (
        (T_C - 20.0) @ weights_um_per_C + 0.05 * (T_C[:, 0] - 20.0) ** 2 + rng.normal(0.0, 2.0, n)
    )
    return _standardised(T_C, error_um)


#: Generated datasets: name -> generator(n, d, seed).
GENERATORS: dict[str, Callable[[int, int, int], tuple[NDArray, NDArray]]] = {
    "friedman1": friedman1,
    "thermal": thermal,
}


@dataclass(frozen=True)
class BenchCase:
    """One dataset at one size, with the kernel and SVR parameters every method is given."""

    dataset: str
    X: NDArray[np.float64]
    y: NDArray[np.float64]
    kernel: str
    C: float
    epsilon: float
    gamma: float
    degree: int = 3
    coef0: float = 0.0

    @property
    def n(self) -> int:
        """Number of samples."""
        return self.X.shape[0]

    @property
    def d(self) -> int:
        """Number of features."""
        return self.X.shape[1]

    def gram(self, rows: NDArray[np.float64] | None = None) -> NDArray[np.float64]:
        """Kernel matrix between ``rows`` (default: every sample) and the training samples."""
        return gram(self.X if rows is None else rows, self.X, kernel=self.kernel, gamma=self.gamma,
                    degree=self.degree, coef0=self.coef0)

    def kernel_times(self, B: NDArray[np.float64], chunk: int = 2048) -> NDArray[np.float64]:
        """:math:`K B` in row blocks, so memory stays O(chunk · n) (n = 20000 would need 3.2 GB)."""
        return np.concatenate([self.gram(self.X[start:start + chunk]) @ B
                               for start in range(0, self.n, chunk)])


def resolve_gamma(gamma: float | str, X: NDArray[np.float64]) -> float:
    """``gamma`` as a number; ``"scale"`` is scikit-learn's
    :math:`1 / (d\\,\\operatorname{Var} X)`."""
    if gamma == "scale":
        variance = float(X.var())
        return 1.0 / (X.shape[1] * variance) if variance > 0 else 1.0
    value = float(gamma)
    if not np.isfinite(value) or value <= 0:
        raise ProblemError(f"gamma must be 'scale' or a positive number, got {gamma!r}")
    return value


def make_case(dataset: str, n: int, d: int, *, kernel: str = "rbf", C: float = 10.0,
              epsilon: float = 0.1, gamma: float | str = "scale", seed: int = 0) -> BenchCase:
    """Generate ``dataset`` (a name of :data:`GENERATORS`) with ``n`` samples and ``d`` features."""
    if dataset not in GENERATORS:
        raise ProblemError(f"dataset must be one of {sorted(GENERATORS)}, got {dataset!r}")
    if n < 2:
        raise ProblemError(f"n must be at least 2, got {n}")
    X, y = GENERATORS[dataset](n, d, seed)
    return BenchCase(dataset, X, y, kernel, float(C), float(epsilon), resolve_gamma(gamma, X))


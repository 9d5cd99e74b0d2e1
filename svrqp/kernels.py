r"""Kernel functions and Gram matrices, and the RBF width conventions of the papers.

.. math::

    k_\text{linear}(x_i, x) = x_i \cdot x

    k_\text{poly}(x_i, x) = (\gamma\, x_i \cdot x + c)^d
    \qquad\text{(S0 eq. 4 is the case } \gamma = 1,\ c = 0\text{)}

    k_\text{rbf}(x_i, x) = \exp(-\gamma \lVert x_i - x \rVert^2)

The RBF width is written three ways in the literature:

* ``gamma`` — scikit-learn/libsvm: :math:`\exp(-\gamma\lVert\cdot\rVert^2)`;
* S0 (Miao 2013, eq. 4): :math:`\exp(-\lVert\cdot\rVert^2/\sigma^2)` with :math:`g = 1/\sigma^2`,
  so :math:`\gamma = g = 1/\sigma^2`;
* S4 (Lin 2011, eq. 6): :math:`\exp(-\lVert\cdot\rVert^2/(2\sigma^2))`,
  so :math:`\gamma = 1/(2\sigma^2)`.

All Gram matrices are computed with one matrix product per row block (no Python loops over samples).
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any, Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

from svrqp.exceptions import ProblemError
from svrqp.problems import check_psd

KernelName = Literal["linear", "poly", "rbf"]
KERNELS: tuple[str, ...] = ("linear", "poly", "rbf")


def _positive(value: float, name: str) -> float:
    value = float(value)
    if not np.isfinite(value) or value <= 0.0:
        raise ProblemError(f"{name} must be a finite positive number, got {value!r}")
    return value


def gamma_from_g(g: float) -> float:
    """S0's ``g = 1/σ²`` is scikit-learn's ``gamma`` unchanged."""
    return _positive(g, "g")


def gamma_from_sigma_s0(sigma: float) -> float:
    r"""``gamma`` for S0's :math:`\exp(-\lVert\cdot\rVert^2/\sigma^2)`: :math:`1/\sigma^2`."""
    return 1.0 / _positive(sigma, "sigma") ** 2


def gamma_from_sigma_s4(sigma: float) -> float:
    r"""``gamma`` for S4's :math:`\exp(-\lVert\cdot\rVert^2/(2\sigma^2))`: :math:`1/(2\sigma^2)`."""
    return 1.0 / (2.0 * _positive(sigma, "sigma") ** 2)


def sigma_s0_from_gamma(gamma: float) -> float:
    r"""S0's :math:`\sigma = 1/\sqrt{\gamma}`."""
    return 1.0 / np.sqrt(_positive(gamma, "gamma"))


def sigma_s4_from_gamma(gamma: float) -> float:
    r"""S4's :math:`\sigma = 1/\sqrt{2\gamma}`."""
    return 1.0 / np.sqrt(2.0 * _positive(gamma, "gamma"))


def rbf_conventions(gamma: float) -> dict[str, float]:
    """Every RBF width convention for one ``gamma``:
    ``gamma``, ``g``, ``sigma_s0``, ``sigma_s4``."""
    gamma = _positive(gamma, "gamma")
    return {
        "gamma": gamma,
        "g": gamma,
        "sigma_s0": sigma_s0_from_gamma(gamma),
        "sigma_s4": sigma_s4_from_gamma(gamma),
    }


#: Entries of one row block of a Gram matrix (1 MiB): the in-place passes after each block's
#: matrix product then run in cache instead of streaming the whole n×m matrix through memory.
BLOCK_ENTRIES = 2**17


def kernel_arguments(kernel_parameters: Mapping[str, Any]) -> dict[str, Any]:
    """``kernel``, ``gamma``, ``degree`` and ``coef0`` out of
    a larger settings mapping (as :func:`gram` takes them)."""
    return {key: kernel_parameters[key] for key in ("kernel", "gamma", "degree", "coef0")}


#: Highest polynomial-kernel degree accepted (by the estimators, :func:`gram` and the model files'
#: ``verify``): far above any error model of a machine tool, and low enough that a kernel value is
#: never raised to a power a user could not mean (``degree=2**40`` used to hang or overflow).
MAX_DEGREE = 100
#: Largest polynomial-kernel value accepted, as for the inputs
#: (:data:`svrqp.table_checks.MAX_MAGNITUDE`): a sum
#: of products of such values stays finite in float64.
MAX_KERNEL_VALUE = 1e150


def check_kernel_parameters(kernel: str, gamma: float, degree: int) -> None:
    """Raise :class:`ProblemError` naming the kernel parameter that is out of range (a ``degree``
    above :data:`MAX_DEGREE` included)."""
    if kernel not in KERNELS:
        raise ProblemError(f"kernel must be one of {KERNELS}, got {kernel!r}")
    if kernel != "linear":
        _positive(gamma, "gamma")
    if kernel == "poly" and (int(degree) != degree or not 1 <= degree <= MAX_DEGREE):
        raise ProblemError(f"degree must be an integer in [1, {MAX_DEGREE}], got {degree!r}")


def check_kernel_range(X: NDArray[np.float64], kernel: str, gamma: float, degree: int,
                       coef0: float) -> None:
    r"""Raise :class:`ProblemError` before any work when a polynomial kernel's values on ``X`` can
    exceed :data:`MAX_KERNEL_VALUE`.

    The bound is :math:`|k(x_i, x_j)| \le (\gamma \max_i \lVert x_i\rVert^2 + |c|)^d`, taken in
    logarithms so that it cannot overflow itself (``coef0=1e200`` used to reach the solver and
    fail there as "dual coefficients are not finite").
    """
    if kernel != "poly" or X.size == 0:
        return
    check_kernel_parameters(kernel, gamma, degree)
    base = float(gamma) * float(np.einsum("ij,ij->i", X, X).max()) + abs(float(coef0))
    if not np.isfinite(base) or (
        base > 1.0 and int(degree) * np.log10(base) > np.log10(MAX_KERNEL_VALUE)
    ):
        raise ProblemError(f"the poly kernel reaches values up to ({base:.3g})^{int(degree)} on "
                           f"these inputs (gamma={gamma:.3g}, coef0={float(coef0):.3g}, "
                           f"degree={int(degree)}); at most {MAX_KERNEL_VALUE:.0e} is supported: "
                           "scale the features or lower coef0 / degree")


def centred(
    kernel: str, X: NDArray[np.float64], Y: NDArray[np.float64] | None = None
) -> tuple[NDArray[np.float64], NDArray[np.float64] | None]:
    r"""RBF inputs shifted by one common centre, the
    mean of ``Y`` (of ``X`` when ``Y`` is ``None``).

    The RBF kernel depends on :math:`x - y` only, so the shift changes no kernel value, but the
    expansion :math:`\lVert x\rVert^2 + \lVert y\rVert^2 - 2x\cdot y` is then computed on
    numbers of the size of the spread of the data instead of cancelling between numbers of the
    size of its offset (epoch seconds, 1.7e9, leave nothing of a spread of 1). Other kernels are
    not translation invariant and are returned unchanged.
    """
    reference = X if Y is None or Y.shape[0] == 0 else Y
    if kernel != "rbf" or reference.shape[0] == 0:
        return X, Y
    centre = np.add.reduce(reference, axis=0) / reference.shape[0]  # mean(), without its dispatch
    return X - centre, (None if Y is None else Y - centre)


def left_factor(X: NDArray[np.float64], kernel: str, gamma: float,
                coef0: float) -> NDArray[np.float64]:
    r"""Left factor :math:`A(X)` of the kernel's inner
    matrix :math:`A(X) B(Y)^\top` (see :func:`right_factor`).

    .. math::

        A_\text{linear} = X, \qquad A_\text{poly} = [\gamma X,\ c\mathbf 1], \qquad
        A_\text{rbf} = [2\gamma X,\ -\gamma \lVert x\rVert^2,\ \mathbf 1]
    """
    if kernel == "linear":
        return X
    d = X.shape[1]  # the columns written in place: hstack's pieces cost more than a small kernel
    A = np.empty((X.shape[0], d + (2 if kernel == "rbf" else 1)))
    if kernel == "poly":
        np.multiply(gamma, X, out=A[:, :d])
        A[:, d] = coef0
    else:
        np.multiply(2.0 * gamma, X, out=A[:, :d])
        np.multiply(-gamma, np.einsum("ij,ij->i", X, X), out=A[:, d])
        A[:, d + 1] = 1.0
    return A


def factors(X: NDArray[np.float64], kernel: str, gamma: float,
            coef0: float) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    r""":func:`left_factor` and :func:`right_factor` of one set of points: the RBF's
    :math:`-\gamma\lVert x\rVert^2` is formed once, in the left factor, and copied into the right
    (the same numbers; a small Gram matrix pays per numpy call)."""
    A = left_factor(X, kernel, gamma, coef0)
    return A, right_factor(X, kernel, gamma,
                           scaled_norms=A[:, X.shape[1]] if kernel == "rbf" else None)


def right_factor(Y: NDArray[np.float64], kernel: str, gamma: float, *,
                 scaled_norms: NDArray[np.float64] | None = None) -> NDArray[np.float64]:
    r"""Right factor :math:`B(Y)`: one matrix product :math:`A(X) B(Y)^\top` gives the inner matrix

    .. math::

        B_\text{linear} = Y,\ \ B_\text{poly} = [Y,\ \mathbf 1],\ \
        B_\text{rbf} = [Y,\ \mathbf 1,\ -\gamma\lVert y\rVert^2]
        \quad\Rightarrow\quad
        (AB^\top)_{ij} = x_i\cdot y_j,\ \ \gamma\, x_i\cdot y_j + c,\ \
        -\gamma\bigl(\lVert x_i\rVert^2 - 2x_i\cdot y_j + \lVert
        y_j\rVert^2\bigr) = -\gamma\lVert x_i - y_j\rVert^2 .

    ``scaled_norms`` is the RBF's :math:`-\gamma\lVert y\rVert^2` when the caller has formed it
    (:func:`factors`, from the left factor of the same points).
    """
    if kernel == "linear":
        return Y
    d = Y.shape[1]
    B = np.empty((Y.shape[0], d + (2 if kernel == "rbf" else 1)))
    B[:, :d] = Y
    B[:, d] = 1.0
    if kernel == "rbf" and scaled_norms is not None:
        B[:, d + 1] = scaled_norms
    elif kernel == "rbf":
        np.multiply(-gamma, np.einsum("ij,ij->i", Y, Y), out=B[:, d + 1])
    return B


def finish_in_place(inner: NDArray[np.float64], kernel: str, degree: int, *,
                    in_product: bool = False) -> None:
    """Turn a block of the inner matrix into kernel values, in place (no temporaries).

    ``in_product=True`` for values that only enter a product computed by the caller, who checks
    that product for overflow (:func:`require_finite_kernel`): the per-block check and the RBF
    clamp are skipped, two passes over the block. The clamp only moves entries of coinciding
    points by the few ulps of the expansion's own rounding, which a product carries anyway.
    """
    with np.errstate(over="ignore", invalid="ignore"):
        if kernel == "poly" and int(degree) > 8:
            # never more than one pass (degree <= MAX_DEGREE)
            np.power(inner, int(degree), out=inner)
        elif kernel == "poly":
            # Repeated products: libm's pow per entry is several times slower for small degrees.
            base = inner.copy()  # one cache-sized block
            for _ in range(int(degree) - 1):
                inner *= base
        elif kernel == "rbf":
            if not in_product:  # the expansion can go a few ulps above −γ·0 where points coincide
                np.minimum(inner, 0.0, out=inner)
            np.exp(inner, out=inner)
    if not in_product:
        require_finite_kernel(inner, kernel)


def require_finite_kernel(values: NDArray[np.float64], kernel: str) -> None:
    """Raise :class:`ProblemError` when kernel values
    (or a product they all flow into) overflowed."""
    if not np.isfinite(values).all():
        raise ProblemError(f"the {kernel} kernel overflows on these inputs: scale the features")


def gram_diagonal(X: NDArray[np.float64], *, kernel: str = "rbf", gamma: float = 1.0,
                  degree: int = 3, coef0: float = 0.0) -> NDArray[np.float64]:
    """:math:`K_{ii}` for every row of ``X``, in closed
    form (no kernel entry off the diagonal is formed).

    RBF: :math:`k(x, x) = 1`; linear: :math:`\\lVert x\\rVert^2`; polynomial:
    :math:`(\\gamma\\lVert x\\rVert^2 + c)^d`.
    """
    if kernel == "rbf":
        return np.ones(X.shape[0])
    squared_norms = np.einsum("ij,ij->i", X, X)
    if kernel == "linear":
        return squared_norms
    return (gamma * squared_norms + coef0) ** int(degree)


def gram(
    X: ArrayLike,
    Y: ArrayLike | None = None,
    *,
    kernel: str = "rbf",
    gamma: float = 1.0,
    degree: int = 3,
    coef0: float = 0.0,
) -> NDArray[np.float64]:
    """Gram matrix :math:`K_{ij} = k(x_i, y_j)`, built in place block by block.

    RBF inputs are first shifted to a common centre (:func:`centred`). Each row block is one
    matrix product of the factors of :func:`left_factor` and :func:`right_factor` written into K,
    then :func:`finish_in_place` while it is in cache: the only n×m array is K itself. Without ``Y``
    only the lower triangle is computed and mirrored, so K is exactly
    symmetric (and the RBF diagonal exactly 1, the zero self-distance).

    Parameters
    ----------
    X, Y
        Samples, shape ``(n, d)`` and ``(m, d)``; ``Y`` defaults to ``X``.
    kernel
        ``"linear"``, ``"poly"`` or ``"rbf"``.
    gamma, degree, coef0
        Kernel parameters (``gamma`` in scikit-learn's convention).

    Returns
    -------
    ndarray of shape ``(n, m)``
    """
    X = np.asarray(X, dtype=float)
    symmetric = Y is None
    Y = X if Y is None else np.asarray(Y, dtype=float)
    if X.ndim != 2 or Y.ndim != 2 or X.shape[1] != Y.shape[1]:
        raise ProblemError(
            f"X and Y must be 2-D with the same columns, got {X.shape} and {Y.shape}"
        )
    check_kernel_parameters(kernel, gamma, degree)
    X, centred_Y = centred(kernel, X, None if symmetric else Y)
    Y = X if symmetric else centred_Y
    n, m = X.shape[0], Y.shape[0]
    K = np.empty((n, m))
    rows = max(8, BLOCK_ENTRIES // max(m, 1))
    # overflow is checked per block, in finish_in_place
    with np.errstate(over="ignore", invalid="ignore"):
        A, B = (factors(X, kernel, gamma, coef0) if symmetric
                else (left_factor(X, kernel, gamma, coef0), right_factor(Y, kernel, gamma)))
        try:
            # Bottom-up, so that the rows below a block are done when its upper part is mirrored.
            for start in reversed(range(0, n, rows)):
                stop = min(start + rows, n)
                columns = stop if symmetric else m
                block = K[start:stop, :columns]
                np.matmul(A[start:stop], B[:columns].T, out=block)
                finish_in_place(block, kernel, degree)
                if symmetric:
                    diagonal = K[start:stop, start:stop]
                    upper = np.triu_indices(stop - start, 1)
                    diagonal[upper] = diagonal.T[upper]
                    K[start:stop, stop:] = K[stop:, start:stop].T
        except ProblemError:
            raise ProblemError(f"the {kernel} kernel overflows on these inputs (|X| up to "
                               f"{np.abs(X).max():.3g}, "
                               f"|Y| up to {np.abs(Y).max():.3g}): scale the features") from None
    if symmetric and kernel == "rbf":
        np.fill_diagonal(K, 1.0)  # exp(−γ·0): rounding of the expansion leaves ulps off zero
    return K


def training_gram(X: NDArray[np.float64],
                  kernel_parameters: Mapping[str, Any]) -> NDArray[np.float64]:
    """The training Gram matrix of a kernel model, checked positive semidefinite where the kernel
    does not guarantee it.

    ``kernel_parameters`` are ``kernel``, ``gamma``, ``degree`` and ``coef0`` as in :func:`gram`;
    with ``kernel="precomputed"``, ``X`` is the Gram matrix and is returned (checked) as it is.

    Raises
    ------
    ProblemError
        A precomputed kernel, or a polynomial kernel with a negative ``coef0``, that is not PSD.
    """
    kernel = kernel_parameters["kernel"]
    K = X if kernel == "precomputed" else gram(X, **kernel_parameters)
    if kernel == "precomputed":
        check_psd(K, name="precomputed kernel X")
    elif kernel == "poly" and kernel_parameters["coef0"] < 0:  # not PSD in general
        check_psd(K, name="polynomial kernel with negative coef0")
    return K

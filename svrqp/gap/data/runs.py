"""Resampling that respects runs and autocorrelation.

Rows of a thermal record are strongly autocorrelated, so nothing here splits or shuffles
single rows:

* :func:`blocked_folds` — cross-validation folds made of whole groups (runs) when there are
  enough of them, otherwise of contiguous blocks interleaved along each group (block ``j``
  of group ``g`` goes to fold ``(j + g) mod K``), so every fold sees every phase of a run
  while test rows stay in blocks much longer than the correlation length;
* :func:`shift_offsets` and :func:`rotated_rows` — surrogate row orders for significance
  tests: each group is rotated by its own random offset, which keeps a series'
  autocorrelation and breaks only its alignment with the other series (offsets that would
  rotate a periodic candidate onto itself are avoided);
* :func:`block_bootstrap` — moving-block bootstrap resamples drawn within each group.

All functions take the group code of each row, with rows sorted so that a group is one
contiguous run (:func:`svrqp.gap.data.transforms.group_slices`).
"""

from __future__ import annotations

import numpy as np

from svrqp.gap.data.transforms import group_slices

N_FOLDS = 5
"""Number of cross-validation folds."""

MIN_GROUPS_FOR_GROUP_FOLDS = 4
"""With at least this many groups, folds hold out whole groups."""

BLOCKS_PER_FOLD = 4
"""With few groups, each group is cut into ``N_FOLDS * BLOCKS_PER_FOLD`` interleaved blocks."""

MIN_SHIFT_FRACTION = 0.1
"""A surrogate rotates a group by at least this fraction of its length (and at most 1 − it)."""

MAX_SELF_CORRELATION = 0.5
"""A surrogate never rotates a candidate onto a copy of itself correlating this much or more."""


def holds_out_groups(groups: np.ndarray) -> bool:
    """Whether :func:`blocked_folds` holds out whole
    groups (enough of them) or blocks within groups."""
    return len(group_slices(groups)) >= MIN_GROUPS_FOR_GROUP_FOLDS


def blocked_folds(groups: np.ndarray, n_folds: int = N_FOLDS) -> list[np.ndarray]:
    """Test-row indices of each cross-validation fold, blocked by group.

    Parameters
    ----------
    groups : ndarray of int, shape (n,)
        Group code per row, each group contiguous.
    n_folds : int
        Number of folds wanted (fewer when there are fewer groups or rows).

    Returns
    -------
    list of ndarray of int
        Disjoint, non-empty test index sets covering all rows.
    """
    slices = group_slices(groups)
    n = len(groups)
    fold_of = np.empty(n, dtype=int)
    if holds_out_groups(groups):
        k = min(n_folds, len(slices))
        load = np.zeros(k)
        # Largest groups first, each to the lightest fold: balanced and deterministic.
        for rows in sorted(slices, key=lambda s: s.start - s.stop):
            f = int(np.argmin(load))
            fold_of[rows] = f
            load[f] += rows.stop - rows.start
    else:
        k = n_folds
        for g, rows in enumerate(slices):
            m = rows.stop - rows.start
            n_blocks = min(m, k * BLOCKS_PER_FOLD)
            block = np.minimum((np.arange(m) * n_blocks) // m, n_blocks - 1)
            # Rotated per group: the same phase of different runs (a start-up) is never held
            # out from all of them at once.
            fold_of[rows] = (block + g) % k
    return [np.flatnonzero(fold_of == f) for f in range(k) if np.any(fold_of == f)]


def shift_offsets(
    groups: np.ndarray, n_surrogates: int, rng: np.random.Generator,
    signature: np.ndarray | None = None
) -> np.ndarray:
    """Random offsets that rotate every group independently, for surrogate row orders.

    Offsets are drawn uniformly among those at least :data:`MIN_SHIFT_FRACTION` of the group
    length away from no shift. With a ``signature`` (the candidate column being tested), offsets
    at which the rotated signature would correlate with itself by :data:`MAX_SELF_CORRELATION`
    or more in absolute value are left out as well: a periodic candidate (a chiller cycling
    every 40 min) rotated by whole periods is a copy of itself, not a surrogate, and rotated by
    half periods a negated copy — which a regression uses just as well. The choice depends on the
    candidate alone, never on the residual, so under "no relation" every surrogate statistic still
    has the distribution of the observed one. When fewer than a fifth of the offsets would remain,
    the self-correlation rule is dropped for that group.

    Drawing the offsets is cheap and consumes the random stream; turning them into rows
    (:func:`rotated_rows`) and scoring the surrogates is the work, which can then run anywhere
    without changing the result.

    Parameters
    ----------
    groups : ndarray of int, shape (n,)
        Group code per row, each group contiguous.
    n_surrogates : int
        Number of surrogates.
    rng : numpy.random.Generator
        Source of the offsets.
    signature : ndarray, shape (n,), optional
        Column whose self-alignment is avoided.

    Returns
    -------
    ndarray of int, shape (n_surrogates, k)
        Offset of each of the ``k`` groups (in row order) in each surrogate.
    """
    slices = group_slices(groups)
    offsets = np.empty((n_surrogates, len(slices)), dtype=np.int64)
    for g, rows in enumerate(slices):
        m = rows.stop - rows.start
        low = max(1, int(np.ceil(MIN_SHIFT_FRACTION * m)))
        allowed = np.arange(low, max(low + 1, m - low + 1))
        if signature is not None:
            kept = allowed[
                np.abs(circular_autocorrelation(signature[rows])[allowed % m])
                < MAX_SELF_CORRELATION
            ]
            if kept.size >= allowed.size / 5:
                allowed = kept
        offsets[:, g] = rng.choice(allowed, size=n_surrogates)
    return offsets


def rotated_rows(groups: np.ndarray, offsets: np.ndarray) -> np.ndarray:
    """Row orders that rotate group ``g`` circularly by ``offsets[:, g]`` (:func:`shift_offsets`).

    Returns
    -------
    ndarray of int, shape (n_surrogates, n)
        ``series[index[s]]`` is surrogate ``s`` of ``series``.
    """
    index = np.empty((offsets.shape[0], len(groups)), dtype=np.int64)
    for g, rows in enumerate(group_slices(groups)):
        m = rows.stop - rows.start
        index[:, rows] = rows.start + (np.arange(m)[None, :] + offsets[:, g, None]) % m
    return index


def lift_steps(x: np.ndarray, groups: np.ndarray) -> np.ndarray:
    """Every row's group end-minus-start change of ``x``: what lifts the part of a rotation that
    wraps round (:func:`wrapped_part`) so that the rotated series is continuous at the seam."""
    step = np.empty(x.size)
    for rows in group_slices(groups):
        step[rows] = x[rows.stop - 1] - x[rows.start]
    return step


def wrapped_part(index: np.ndarray, groups: np.ndarray) -> np.ndarray:
    """Whether each row of each rotation in ``index`` (:func:`rotated_rows`) reads from before its
    group's rotation point (and so has wrapped round)."""
    first = np.concatenate([np.full(sl.stop - sl.start, sl.start) for sl in group_slices(groups)])
    return index < index[..., first]


def circular_autocorrelation(x: np.ndarray) -> np.ndarray:
    """Correlation of ``x`` with itself rotated by every lag 0 … m−1 (by FFT)."""
    centred = x - x.mean()
    power = np.abs(np.fft.rfft(centred)) ** 2
    acov = np.fft.irfft(power, n=x.size)
    return acov / acov[0] if acov[0] > 0 else np.zeros(x.size)


def block_length(residual: np.ndarray, groups: np.ndarray) -> int:
    """Block length for a block bootstrap of ``residual``.

    The longer of :math:`\\lceil 1.5\\, n^{1/3}\\rceil` (the usual rate for a moving-block
    bootstrap of a mean) and :math:`2(1+\\rho_1)/(1-\\rho_1)`, twice the number of rows over
    which an AR(1) process with the observed lag-1 autocorrelation :math:`\\rho_1` stays
    correlated; never more than a fifth of the shortest group.
    """
    rho = lag1_autocorrelation(residual, groups)
    n = len(residual)
    length = max(np.ceil(1.5 * n ** (1 / 3)), 2 * (1 + rho) / max(1 - rho, 1e-3))
    shortest = min(s.stop - s.start for s in group_slices(groups))
    return int(max(1, min(length, shortest // 5 or 1)))


def lag1_autocorrelation(residual: np.ndarray, groups: np.ndarray) -> float:
    """Lag-1 autocorrelation pooled over groups, clipped to [0, 0.99]."""
    num = den = 0.0
    for rows in group_slices(groups):
        e = residual[rows] - residual[rows].mean()
        num += float(e[1:] @ e[:-1])
        den += float(e @ e)
    if den <= 0:
        return 0.0
    return float(np.clip(num / den, 0.0, 0.99))


def block_bootstrap(groups: np.ndarray, n_boot: int, length: int,
                    rng: np.random.Generator) -> np.ndarray:
    """Moving-block bootstrap row indices, drawn within each group.

    Parameters
    ----------
    groups : ndarray of int, shape (n,)
        Group code per row, each group contiguous.
    n_boot : int
        Number of resamples.
    length : int
        Block length in rows.
    rng : numpy.random.Generator
        Source of the block starts.

    Returns
    -------
    ndarray of int, shape (n_boot, n)
        Each row is one resample of the row indices (same group sizes as the original).
    """
    n = len(groups)
    index = np.empty((n_boot, n), dtype=np.int64)
    for rows in group_slices(groups):
        m = rows.stop - rows.start
        b = min(length, m)
        n_blocks = -(-m // b)
        starts = rng.integers(0, m - b + 1, size=(n_boot, n_blocks))
        drawn = (starts[:, :, None] + np.arange(b)[None, None, :]).reshape(n_boot, -1)[:, :m]
        index[:, rows] = rows.start + drawn
    return index

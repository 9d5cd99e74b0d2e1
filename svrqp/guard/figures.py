"""Intervals as bands on measured-vs-predicted figures, out-of-domain stretches shaded.

:func:`interval_columns` evaluates a fitted :class:`~svrqp.guard.Guarded` on a table (lower, upper,
outside); :func:`draw_guard` adds the band and the shading to a matplotlib axis whose x axis is
time (or sample index), so a figure of the demo or a benchmark shows where the model is sure and
where it is extrapolating.
"""

from __future__ import annotations

import warnings
from typing import Any

import numpy as np
import pandas as pd
from numpy.typing import ArrayLike

from svrqp.exceptions import ExtrapolationWarning


def interval_columns(model: Any, X: pd.DataFrame, name: str = "svr",
                     unit: str = "um") -> dict[str, np.ndarray]:
    """``{name}_lower_{unit}``, ``{name}_upper_{unit}``
    and ``{name}_outside`` for every row of ``X``."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ExtrapolationWarning)  # shown as shading instead
        interval = model.predict_interval(X)
    return {f"{name}_lower_{unit}": interval[:, 0], f"{name}_upper_{unit}": interval[:, 1],
            f"{name}_outside": model.check_domain(X)["outside"].to_numpy()}


def stretches(flags: ArrayLike) -> list[tuple[int, int]]:
    """``[(start, stop), ...]``: the index ranges of consecutive True values."""
    flags = np.asarray(flags, dtype=bool)
    edges = np.diff(np.concatenate([[0], flags.astype(np.int8), [0]]))
    return list(zip(np.flatnonzero(edges == 1), np.flatnonzero(edges == -1), strict=True))


def draw_guard(axis: Any, x: ArrayLike, lower: ArrayLike, upper: ArrayLike, outside: ArrayLike, *,
               coverage: float, color: str = "tab:blue") -> None:
    """Fill ``[lower, upper]`` over ``x`` and shade the stretches where ``outside`` is true."""
    x = np.asarray(x, dtype=float)
    axis.fill_between(x, lower, upper, color=color, alpha=0.2, lw=0, label=f"{coverage:.0%} "
                                                                           f"interval")
    for i, (start, stop) in enumerate(stretches(outside)):
        axis.axvspan(x[start], x[stop - 1], color="tab:red", alpha=0.12, lw=0,
                     label="outside training domain" if i == 0 else None)

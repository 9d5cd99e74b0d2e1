"""Figures of a gap report (matplotlib; every axis labelled
with its unit, read by :func:`svrqp.units.unit_of`).

matplotlib is imported when a figure is drawn, not with this module: a diagnosis that writes no
report never loads it. Each figure is a ``Figure`` of its own, never pyplot's global state, so the
backend of a notebook or GUI stays as it is.
"""

from __future__ import annotations

import io

import numpy as np

from svrqp.gap.data import group_slices
from svrqp.gap.results.records import Series
from svrqp.units import unit_of


def axis_label(name: str) -> str:
    """Axis label of a column: ``"time_min"`` → ``"time (min)"``; ``"row"`` → row position."""
    if name == "row":
        return "row within group (count)"
    unit = unit_of(name)
    if unit is not None:
        return f"{name.rpartition('_')[0].replace('_', ' ')} ({unit})"
    return f"{name} (units of the column)"


def _lines(ax, s: Series, values: np.ndarray, rows: np.ndarray, **style) -> None:
    """Plot ``values`` against order, one line piece per group, only on ``rows``."""
    first = True
    for piece in group_slices(s.groups):
        keep = rows[piece]
        if keep.any():
            label = style.pop("label", None) if first else None
            ax.plot(s.t[piece][keep], values[piece][keep], label=label, **style)
            first = False


def gap_figure(s: Series, regions: list[tuple[float, float, str | None]]) -> bytes:
    """Measured vs model (top) and residual with shaded regions (bottom), PNG bytes.

    ``regions`` are ``(low, high, run)`` on the order axis; ``run`` is None for a region pooled
    over every run, else the label of the one run it lies in (shaded in another colour and
    labelled with the run, since the runs share the axis).
    """
    from matplotlib.figure import Figure

    fig = Figure(figsize=(9, 6))
    top, bottom = fig.subplots(2, 1, sharex=True)
    real = ~s.is_train
    _lines(top, s, s.y, s.is_train, color="0.6", lw=1, label="measured (train rows)")
    _lines(top, s, s.y, real, color="C0", lw=1, label="measured (real rows)")
    _lines(top, s, s.y_hat, np.ones_like(real), color="C1", lw=1, ls="--", label="model")
    top.set_ylabel(axis_label(s.target))
    top.legend(loc="best", fontsize=8)
    residual = s.y - s.y_hat
    _lines(bottom, s, residual, s.is_train, color="0.6", lw=1, label="residual (train rows)")
    _lines(bottom, s, residual, real, color="C3", lw=1, label="residual (real rows)")
    pooled = [(low, high) for low, high, run in regions if run is None]
    for k, (low, high) in enumerate(pooled):
        bottom.axvspan(low, high, color="C3", alpha=0.12,
                       label="error concentrates" if k == 0 else None)
    within = [(low, high, run) for low, high, run in regions if run is not None]
    for k, (low, high, run) in enumerate(within):
        bottom.axvspan(low, high, color="C4", alpha=0.15,
                       label="error concentrates within one run" if k == 0 else None)
        bottom.annotate(f"run {run}", ((low + high) / 2, 1.0), xycoords=("data", "axes fraction"),
                        ha="center", va="top", fontsize=7, color="C4")
    bottom.axhline(0, color="k", lw=0.5)
    bottom.set_ylabel(f"residual {axis_label(s.target)}")
    bottom.set_xlabel(axis_label(s.order_name))
    bottom.legend(loc="best", fontsize=8)
    return _png(fig)


def before_after_figure(s: Series, effect: str, region: tuple[float, float] | None = None) -> bytes:
    """Real-row residual before and (out of sample) after adding the effect, PNG bytes.

    For a local effect (``region``: its stretch of the order axis), the stretch is shaded and a
    second panel shows the effect's profile along the axis: what the refits with it predict on
    each held-out real row (residual before minus after).
    """
    from matplotlib.figure import Figure

    fig = Figure(figsize=(9, 3.5 if region is None else 6))
    axes = [fig.subplots()] if region is None else fig.subplots(2, 1, sharex=True)
    ax = axes[0]
    real = ~s.is_train
    residual = s.y - s.y_hat
    _lines(ax, s, residual, real, color="C3", lw=1, label="before")
    after = np.full_like(residual, np.nan)
    after[real] = s.after
    _lines(ax, s, after, real, color="C2", lw=1, label=f"after adding {effect} (out of sample)")
    ax.set_ylabel(f"residual {axis_label(s.target)}")
    if region is not None:
        _lines(axes[1], s, residual - after, real, color="C2", lw=1, label=f"{effect}: profile on "
                                                                           f"held-out runs")
        axes[1].set_ylabel(f"effect {axis_label(s.target)}")
    for panel in axes:
        if region is not None:
            panel.axvspan(*region, color="C2", alpha=0.12, label="where the effect acts")
        panel.axhline(0, color="k", lw=0.5)
        panel.legend(loc="best", fontsize=8)
    axes[-1].set_xlabel(axis_label(s.order_name))
    return _png(fig)


def _png(fig) -> bytes:
    buffer = io.BytesIO()
    fig.tight_layout()
    fig.savefig(buffer, format="png", dpi=110)
    return buffer.getvalue()

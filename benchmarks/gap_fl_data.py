"""FL_THERMAL arranged for the gap benchmarks: cycles, train and assessment rows.

Shared by :mod:`fl_thermal_case_study` and the independent checker :mod:`gap_real`; it reads
the data with :func:`svrqp.datasets.load_fl_thermal` and imports nothing of ``svrqp.gap``.
"""

from __future__ import annotations

from pathlib import Path

import pandas as pd

from svrqp import datasets

REPO = Path(__file__).resolve().parents[1]
DEFAULT_DATA = REPO / "svrqp" / "datasets" / "fl_thermal" / "data.csv"  # the copy shipped in the package
TRAIN_CYCLES = ("1250", "2500", "3750")
ASSESS_CYCLES = ("5000", "mixed")
CHANNELS = [f"ch{i}_um" for i in range(1, 6)]
TEMPERATURES = [f"t{i}_C" for i in range(1, 17)]


def cycle_labels(table: pd.DataFrame) -> pd.Series:
    """Cycle of each row: a run and the stop after it share the run's speed; the mixed-speed tail is ``mixed``.

    The mixed-speed run is the sequence of runs that follow one another without a stop
    (500 → 1500 → 2500 → 4500 rpm) and the short stop that ends the record.
    """
    phases = table.groupby("segment")["phase"].first()
    labels, current = {}, "1250"  # the half-minute idle before the first run joins the first cycle
    for segment, phase in phases.items():
        kind, _, speed = phase.partition("_")
        back_to_back = phases.get(segment - 1, "").startswith("run") or phases.get(segment + 1, "").startswith("run")
        if kind == "run":
            current = "mixed" if (back_to_back or current == "mixed") else speed
        labels[segment] = current
    return table["segment"].map(labels)


def load_fl(path: Path, every: int) -> pd.DataFrame:
    """FL_THERMAL with a ``cycle`` column, the train and assessment cycles only, every ``every``-th row."""
    table = datasets.load_fl_thermal(path)
    table["cycle"] = cycle_labels(table)
    table = table.iloc[::every]
    return table[table["cycle"].isin(TRAIN_CYCLES + ASSESS_CYCLES)].reset_index(drop=True)

"""The embedded datasets, their data cards, and the real FL_THERMAL measurements.

The embedded datasets are simulated by :mod:`svrqp.machine` with fixed seeds, each imitating
the set-up of one source paper; every one has a data card (:func:`card`) saying what it
imitates, which effects are on, the columns and their units. Column names carry their units
(``error_um``, ``T7_C``, ``x_mm``).

>>> from svrqp import datasets
>>> datasets.names()
('chen2012', 'lin_gantry', 'miao2013', 'miao2013_rise',
'yang_turning', 'zhou_axis_x', 'zhou_axis_x_periodic',
'zhou_axis_x_periodic_true', 'zhou_axis_x_true')
>>> datasets.load("miao2013").query("batch == 'x1'").shape
(251, 19)

FL_THERMAL (measured on a CNC machine, MIT licence) ships with the package beside its licence
notice and data card (:func:`fl_thermal_card`); :func:`load_fl_thermal` reads it:

>>> datasets.load_fl_thermal().shape
(11115, 25)
"""

from __future__ import annotations

from importlib import resources
from pathlib import Path

import numpy as np
import pandas as pd

from svrqp.exceptions import ProblemError

_DATA = resources.files("svrqp.datasets") / "data"
_FL_THERMAL = resources.files("svrqp.datasets") / "fl_thermal"
FL_THERMAL_SHA256 = "4a29ddd6d25cbfc0237fe90c2714e329afb633ede988065b2baace53eedbaaf8"
"""SHA-256 of the shipped ``data.csv``, as converted
from the source workbook (see the data card)."""
FL_TIME_COLUMN = "時間(s)"  # the file's header carries a trailing space, stripped on reading
FL_CHANNELS = 5
FL_TEMPERATURES = 16


def names() -> tuple[str, ...]:
    """Names of the embedded datasets, sorted."""
    return tuple(sorted(entry.name[: -len(".csv")] for entry in _DATA.iterdir()
                        if entry.name.endswith(".csv")))


def _entry(name: str, suffix: str):
    if name not in names():
        raise ProblemError(f"unknown dataset {name!r}; valid names: {', '.join(names())}")
    return _DATA / f"{name}{suffix}"


def load(name: str) -> pd.DataFrame:
    """Load an embedded dataset as a DataFrame (see :func:`card` for its columns).

    Raises
    ------
    ProblemError
        If ``name`` is not one of :func:`names`; the message lists the valid names.
    """
    with resources.as_file(_entry(name, ".csv")) as path:
        return pd.read_csv(path)


def card(name: str) -> str:
    """The data card (Markdown) of an embedded dataset."""
    return _entry(name, ".md").read_text(encoding="utf-8")


def fl_thermal_card() -> str:
    """The data card (Markdown) of the shipped FL_THERMAL measurements: source, licence, columns."""
    return (_FL_THERMAL / "README.md").read_text(encoding="utf-8")


def fl_thermal_licence() -> str:
    """The MIT licence notice that travels with the FL_THERMAL data."""
    return (_FL_THERMAL / "LICENSE").read_text(encoding="utf-8")


def load_fl_thermal(path: str | Path | None = None) -> pd.DataFrame:
    """Read the real FL_THERMAL spindle measurements into tidy columns.

    The file (``data.csv`` of the FL_THERMAL repository, MIT licence; 15 s sampling) has the
    header ``時間(s) ,spindle(RPM),ch1(um),…,ch5(um),t1(°C),…,t16(°C)``.

    Parameters
    ----------
    path
        Path of a CSV file in that layout; by default the copy shipped with svrqp
        (:data:`FL_THERMAL_SHA256`, :func:`fl_thermal_card`).

    Returns
    -------
    pandas.DataFrame
        ``time_min``, ``speed_rpm``, ``ch1_um`` … ``ch5_um`` (displacements, μm),
        ``t1_C`` … ``t16_C`` (temperatures, °C), ``phase`` — the run/stop segment and its speed
        (``run_1250`` while running at 1250 rpm, ``stop_1250`` while standing after it,
        ``stop_0`` before the first run) — and ``segment``, an integer id of each stretch of
        constant speed, usable as a group column.
    """
    if path is None:
        with resources.as_file(_FL_THERMAL / "data.csv") as shipped:
            return load_fl_thermal(shipped)
    path = Path(path)
    if not path.exists():
        raise FileNotFoundError(f"FL_THERMAL file not found: {path}")
    raw = pd.read_csv(path)
    raw.columns = [str(column).strip() for column in raw.columns]
    channels = [f"ch{i}(um)" for i in range(1, FL_CHANNELS + 1)]
    temperatures = [f"t{i}(°C)" for i in range(1, FL_TEMPERATURES + 1)]
    expected = [FL_TIME_COLUMN, "spindle(RPM)", *channels, *temperatures]
    missing = [column for column in expected if column not in raw.columns]
    if missing:
        raise ProblemError(f"{path}: not an FL_THERMAL file, missing column(s) {missing}")
    values = raw[expected].apply(pd.to_numeric, errors="coerce")
    if values.isna().any().any():
        bad = values.columns[values.isna().any()].tolist()
        raise ProblemError(f"{path}: non-numeric or empty values in column(s) {bad}")

    table = pd.DataFrame({"time_min": values[FL_TIME_COLUMN] / 60.0,
                          "speed_rpm": values["spindle(RPM)"]})
    for i, column in enumerate(channels, start=1):
        table[f"ch{i}_um"] = values[column]
    for i, column in enumerate(temperatures, start=1):
        table[f"t{i}_C"] = values[column]
    table["phase"], table["segment"] = _phases(table["speed_rpm"].to_numpy())
    return table


def _phases(speed_rpm: np.ndarray) -> tuple[list[str], np.ndarray]:
    """Label each sample ``run_<rpm>`` or ``stop_<rpm of the run before>``; number the segments."""
    segment = np.r_[0, np.cumsum(speed_rpm[1:] != speed_rpm[:-1])]
    labels, last_run = [], 0
    for start in np.flatnonzero(np.r_[True, speed_rpm[1:] != speed_rpm[:-1]]):
        speed = int(round(speed_rpm[start]))
        if speed > 0:
            last_run = speed
        labels.append(f"run_{speed}" if speed > 0 else f"stop_{last_run}")
    return [labels[k] for k in segment], segment

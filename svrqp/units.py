"""Units carried in column names, written with one micro sign.

The project names columns with their unit as a suffix (``T7_C``, ``error_um``, ``x_mm``); measured
tables may instead write ``name(unit)`` (``t1(°C)``, ``ch1(um)``). This module is the one table of
those suffixes and how each unit is written, used by the estimators' coefficient tables, the
exported model documents, the simulators' plot labels and the gap report's words and figures
(:func:`unit_of`, :func:`quantity`).

The micro sign is the Greek small letter mu, μ (U+03BC). The compatibility character MICRO SIGN
(U+00B5), which looks the same, is read as μ wherever a unit is read (:func:`normalise_micro`), so
a table typed with either key gives the same unit.
"""

from __future__ import annotations

import re

#: The micro sign of the project: GREEK SMALL LETTER MU (U+03BC).
MICRO = "\N{GREEK SMALL LETTER MU}"

#: Unit suffixes of the naming convention (``T7_C``) and how each unit is written.
UNIT_SUFFIXES: dict[str, str] = {
    "C": "°C", "K": "K", "um": f"{MICRO}m", "mm": "mm", "m": "m", "min": "min", "s": "s", "h": "h",
    "rpm": "rpm", "urad": f"{MICRO}rad", "arcsec": "arcsec", "deg": "°",
}

#: Further ``_suffix`` spellings measured tables bring (``Fehler_μm``, ``t_degC``, ``duty_pct``),
#: read by :func:`unit_of` besides :data:`UNIT_SUFFIXES`.
MEASURED_SUFFIXES: dict[str, str] = {f"{MICRO}m": f"{MICRO}m", "°C": "°C", "degC": "°C", "pct": "%"}

#: Axis names that count positions rather than measure a quantity (the gap diagnosis orders the rows
#: of a group by position, ``row``, when no order column is given), and their unit.
COUNT_AXES: dict[str, str] = {"row": "rows"}

_PARENTHESISED_UNIT = re.compile(r"^\s*(?P<base>.*?)\s*\((?P<unit>[^()]*)\)\s*$")
_INDEXED_SYMBOL = re.compile(r"^(?P<letters>[A-Za-z]+)_?(?P<index>\d+)$")


def normalise_micro(text: str) -> str:
    """``text`` with every MICRO SIGN (U+00B5) written as the project's μ (U+03BC)."""
    return text.replace("\N{MICRO SIGN}", MICRO)


def split_unit(name: str) -> tuple[str, str]:
    """Split a column name into (base name, unit).

    ``"T7_C"`` → ``("T7", "°C")``, ``"ch1(um)"`` → ``("ch1", "μm")``, ``"speed"`` →
    ``("speed", "")``. A parenthesised unit that is not a known suffix is kept as written (its
    micro sign normalised); a ``_suffix`` is a unit only when it is one of :data:`UNIT_SUFFIXES`.
    """
    match = _PARENTHESISED_UNIT.match(name)
    if match:
        unit = match["unit"].strip()
        return match["base"], normalise_micro(UNIT_SUFFIXES.get(unit, unit))
    base, _, suffix = name.rpartition("_")
    if base and suffix in UNIT_SUFFIXES:
        return base, UNIT_SUFFIXES[suffix]
    return name, ""


def unit_from_name(name: str) -> str | None:
    """The unit carried in a column name (``T7_C`` → ``°C``, ``ch1(um)`` → ``μm``), or None."""
    return split_unit(name)[1] or None


def ratio_unit(numerator: str, denominator: str) -> str:
    """The unit of a coefficient of ``numerator`` per ``denominator`` (``μm/°C``; ``1/°C``)."""
    if not denominator:
        return numerator
    return f"{numerator or '1'}/{denominator}"


def latex_symbol(name: str) -> str:
    """LaTeX symbol of a column: ``"T7_C"`` → ``T_7``, ``"t12(°C)"`` → ``t_{12}``,
    ``"ambient"`` → ``\\mathrm{ambient}``."""
    base, _ = split_unit(name)
    match = _INDEXED_SYMBOL.match(base)
    if match:
        index = match["index"]
        return (
            f"{match['letters']}_{index}" if len(index) == 1 else f"{match['letters']}_{{{index}}}"
        )
    if len(base) == 1 and base.isalpha():
        return base
    return r"\mathrm{" + base.replace("_", r"\_") + "}"


def axis_label(name: str) -> str:
    """A column as an axis label: ``"time_min"`` →
    ``"time (min)"``; a name without a unit suffix as is."""
    base, _, suffix = name.rpartition("_")
    return f"{base} ({UNIT_SUFFIXES[suffix]})" if base and suffix in UNIT_SUFFIXES else name


def unit_of(name: str) -> str | None:
    """The unit of a column from its name's ``_suffix``
    (``"error_um"`` → ``"μm"``), None when there is none.

    Reads :data:`UNIT_SUFFIXES` and the measured spellings of :data:`MEASURED_SUFFIXES`, a MICRO
    SIGN (U+00B5) in the suffix as μ; a count axis of :data:`COUNT_AXES` (``"row"``) has its own
    unit. Unlike :func:`unit_from_name`, a parenthesised unit (``ch1(um)``) is not read.
    """
    if name in COUNT_AXES:
        return COUNT_AXES[name]
    stem, _, suffix = name.rpartition("_")
    suffix = normalise_micro(suffix)
    return (UNIT_SUFFIXES.get(suffix) or MEASURED_SUFFIXES.get(suffix)) if stem else None


def quantity(value: float, unit: str | None) -> str:
    """A number to three significant digits with its
    unit (``4.09 μm``), or bare when ``unit`` is None."""
    return f"{value:.3g} {unit}" if unit else f"{value:.3g}"


P_FLOOR = 1e-10
"""Below this a p- or q-value is written "< 1e-10": its digits say nothing a reader can use, and
past double precision's tail (5.3e-195) they are rounding."""


def probability(p: float) -> str:
    """A p- or q-value to two significant digits, or ``< 1e-10`` below :data:`P_FLOOR`."""
    return f"< {P_FLOOR:g}" if p < P_FLOOR else f"{p:.2g}"


def probability_relation(p: float) -> str:
    """``= 0.012`` or ``< 1e-10``: a p- or q-value
    after its symbol (``q = 0.012``, ``q < 1e-10``)."""
    text = probability(p)
    return text if text.startswith("<") else f"= {text}"

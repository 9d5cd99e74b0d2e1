"""Units read from column names: one table, one micro sign (μ, U+03BC)."""

from __future__ import annotations

from pathlib import Path

import pytest

import svrqp
from svrqp.units import (
    MICRO,
    UNIT_SUFFIXES,
    axis_label,
    latex_symbol,
    probability,
    probability_relation,
    quantity,
    ratio_unit,
    split_unit,
    unit_from_name,
    unit_of,
)

MICRO_SIGN = "\N{MICRO SIGN}"  # U+00B5, the look-alike the project does not write
PACKAGE = Path(svrqp.__file__).parent


def test_the_micro_sign_is_the_greek_mu():
    assert MICRO == "\u03bc" and UNIT_SUFFIXES["um"] == "\u03bcm" and UNIT_SUFFIXES["urad"] == "\u03bcrad"


@pytest.mark.parametrize("name, base, unit", [
    ("T7_C", "T7", "°C"), ("error_um", "error", "μm"), ("x_mm", "x", "mm"), ("theta_x_urad", "theta_x", "μrad"),
    ("t12(°C)", "t12", "°C"), ("ch1(um)", "ch1", "μm"), ("ch1(" + MICRO_SIGN + "m)", "ch1", "μm"),
    ("ch2(μm)", "ch2", "μm"), ("speed", "speed", ""), ("ambient_temp", "ambient_temp", ""), ("_C", "_C", ""),
])
def test_split_unit(name, base, unit):
    assert split_unit(name) == (base, unit)
    assert unit_from_name(name) == (unit or None)


def test_latex_symbols_ratios_and_axis_labels():
    assert [latex_symbol(name) for name in ("T7_C", "t12(°C)", "x_mm", "ambient_temp")] == [
        "T_7", "t_{12}", "x", r"\mathrm{ambient\_temp}"]
    assert ratio_unit("μm", "°C") == "μm/°C" and ratio_unit("", "°C") == "1/°C" and ratio_unit("μm", "") == "μm"
    assert axis_label("time_min") == "time (min)" and axis_label("error_um") == "error (μm)"
    assert axis_label("speed") == "speed"


def _files_with_micro_sign() -> set[str]:
    return {path.relative_to(PACKAGE).as_posix() for path in PACKAGE.rglob("*")
            if path.is_file() and path.suffix in {".py", ".md", ".json", ".toml"}
            and MICRO_SIGN in path.read_text(encoding="utf-8")}


def test_no_module_writes_the_micro_sign_look_alike():
    assert _files_with_micro_sign() == set()


@pytest.mark.parametrize("name, unit", [
    ("error_um", "μm"), ("Fehler_\N{MICRO SIGN}m", "μm"), ("Fehler_μm", "μm"), ("spindle_box_C", "°C"), ("t_degC", "°C"),
    ("duty_pct", "%"), ("time_min", "min"), ("deviation", None), ("row", "rows"), ("_um", None), ("ch1(um)", None),
])
def test_unit_of_reads_the_suffix_and_the_measured_spellings(name, unit):
    assert unit_of(name) == unit


def test_quantity_has_three_digits_and_its_unit():
    assert quantity(4.0912, "μm") == "4.09 μm" and quantity(13.44, None) == "13.4"


@pytest.mark.parametrize(("p", "text", "relation"), [
    (0.012, "0.012", "= 0.012"), (1.0, "1", "= 1"), (5.32e-195, "< 1e-10", "< 1e-10"), (1e-10, "1e-10", "= 1e-10"),
])
def test_probabilities_below_1e_10_are_written_as_a_bound(p, text, relation):
    assert probability(p) == text and probability_relation(p) == relation

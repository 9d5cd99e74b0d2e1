"""The one vocabulary of reproduction rows, and the docs' table generated from the recorded rows."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from svrqp.demo.record import DOCS_PAGE, RECORDED, docs_block, with_docs_block
from svrqp.demo.vocabulary import LABELS, Label, label_for, markdown_table, reproduction_row
from svrqp.exceptions import ProblemError

ROOT = Path(__file__).resolve().parents[2]


@pytest.mark.parametrize("paper, ours, tolerance, holds, label", [
    (1.0, 1.2, 0.25, True, Label.REPRODUCED),
    (1.0, 1.3, 0.25, True, Label.SAME_DIRECTION),
    (1.0, 1.0, 0.25, False, Label.DIFFERS),  # the number matches, the comparison does not hold
    (16.0, 17.9, 2.0, None, Label.REPRODUCED),
    (16.0, 18.1, 2.0, None, Label.DIFFERS),  # a magnitude without a comparison
], ids=["within", "outside", "comparison-fails", "magnitude-within", "magnitude-outside"])
def test_one_rule_gives_the_label(paper, ours, tolerance, holds, label):
    assert label_for(paper, ours, tolerance, holds) is label


def test_a_row_not_reproduced_needs_its_measured_reason():
    with pytest.raises(ProblemError, match="without its measured reason"):
        reproduction_row("S9", "a number", "μm", 1.0, 3.0, comparison_holds=False)
    row = reproduction_row("S9", "a number", "μm", 1.0, 3.0, comparison_holds=True, note="why")
    assert row["reproduction"] == "same direction" and row["tolerance"] == pytest.approx(0.25)
    with pytest.raises(ProblemError, match="tolerance"):
        label_for(1.0, 1.0, -1.0, True)


def test_the_words_are_three_and_agrees_is_not_one():
    assert LABELS == ("reproduced", "same direction", "differs")
    assert not any("agree" in label for label in LABELS)


@pytest.fixture(scope="module")
def recorded():
    return json.loads((ROOT / RECORDED).read_text(encoding="utf-8"))


def test_recorded_rows_follow_the_rule(recorded):
    assert {row["seed"] for row in recorded} == {"S0", "S1", "S2", "S3", "S4"}
    for row in recorded:
        expected = label_for(row["paper"], row["ours"], row["tolerance"], row["comparison_holds"])
        assert row["reproduction"] == expected.value, row["quantity"]
        if row["reproduction"] != "reproduced":
            assert row["note"].strip()


def test_docs_table_is_the_recorded_rows(recorded):
    page = (ROOT / DOCS_PAGE).read_text(encoding="utf-8")
    assert docs_block(recorded) in page
    assert with_docs_block(page, recorded) == page
    assert "agrees" not in page


def test_docs_block_needs_its_markers(recorded):
    with pytest.raises(ProblemError, match="block"):
        with_docs_block("# a page without the markers\n", recorded)


def test_markdown_escapes_pipes_in_cells():
    row = reproduction_row("S3", "max |r|", "|r| (μm)", 1.0, 1.0, comparison_holds=True)
    line = markdown_table([row]).splitlines()[-1]
    assert line.count(" | ") == 7 and "max \\|r\\|" in line

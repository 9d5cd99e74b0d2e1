"""Awkward records of issue #33: a candidate with a single value, a run listed backwards, a record of one
run. Each gets a stated fallback and a schema-valid JSON, never a crash or a silent change of answer."""

import json

import jsonschema
import pandas as pd
import pytest
from support.gap_problems import CANDIDATES, air_lag_problem

from svrqp.gap import GapQuestion, diagnose, load_schema


@pytest.fixture(scope="module")
def table():
    return air_lag_problem()


def _diagnose(table, train="run == 'r0'", candidates=CANDIDATES, group="run"):
    result = diagnose(table, GapQuestion(target="error_um", train=train, features=["spindle_C"],
                                         candidates=candidates, order="time_min", group=group))
    document = json.loads(result.to_json())
    jsonschema.validate(document, load_schema())
    return result, document


def test_a_candidate_with_a_single_value_is_said_constant_and_never_named(table):
    result, _ = _diagnose(table.assign(const_C=20.0), candidates=[*CANDIDATES, "const_C"])
    const = next(c for c in result.causes if c.column == "const_C")
    assert "constant on the real rows" in const.note and not const.significant
    assert result.verdict.column == "air_C"


def test_a_run_listed_backwards_is_sorted_along_the_order_and_said_so(table):
    backwards = table[table.run == "r1"].iloc[::-1]
    shuffled = pd.concat([table[table.run != "r1"], backwards], ignore_index=True)
    result, document = _diagnose(shuffled)
    reference, _ = _diagnose(table)
    assert document["order_sorted"] == ["r1"]
    assert result.verdict.column == reference.verdict.column == "air_C"
    assert result.verdict.shrink == pytest.approx(reference.verdict.shrink, rel=1e-9)


def test_a_record_of_one_run_is_cut_into_blocks_and_said_so(table):
    one = table[table.run == "r0"]
    result, document = _diagnose(one, train="time_min < 100")
    assert document["blocks"]["kind"] == "blocks" and document["blocks"]["n"] >= 5
    assert "leave-one-block-out" in result.verdict.reason or result.verdict.column is None

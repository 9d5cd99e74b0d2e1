"""The pooled evidence below the effect floor: six machines carry the same weak nut heating,
too weak for any record to name (and for all but a few to test at all); pooled over their
transfer tests it is named, and on the same six machines with nothing withheld nothing is."""

from __future__ import annotations

import pytest

from svrqp.fleet import pool, read_records, run_fleet
from svrqp.machine.fleet import FleetDesign, write_fleet

#: The same six machines (seed 3) with the nut heating withheld at strength 0.15, or nothing.
WEAK = FleetDesign(n=6, seed=3, snr={"nut": 0.15}, shares={"nut": 1.0})
NULL = FleetDesign(n=6, seed=3, shares={"none": 1.0})


def _fleet(folder, design):
    return run_fleet(read_records(write_fleet(folder / "data", design)), {}, folder / "out")


@pytest.fixture(scope="module")
def weak(tmp_path_factory):
    return _fleet(tmp_path_factory.mktemp("weak"), WEAK)


@pytest.fixture(scope="module")
def null(tmp_path_factory):
    return _fleet(tmp_path_factory.mktemp("null"), NULL)


def test_no_record_names_the_weak_effect_alone(weak):
    assert (weak.table["status"] == "ok").all()
    assert not (weak.table["verdict_column"] == "nut_C").any()
    nut = weak.tests[weak.tests["column"] == "nut_C"]
    assert nut["tested"].sum() <= 2  # most records do not even test it (below the floor)


def test_the_pool_names_it_from_every_records_test(weak):
    assert weak.pooled.named == ["nut_C"]
    assert "nut_C" in weak.pooled.summary()
    # the records' own tests alone (an untested column at p = 1) could not show it
    assert pool(weak.tests.drop(columns="p_pool")).named == []
    assert (weak.tests["p_pool"] <= 1.0).all() and (weak.tests["p_pool"] > 0.0).all()


def test_the_same_machines_with_nothing_withheld_name_nothing(null):
    assert (null.table["verdict_column"].fillna("") == "").all()
    assert null.pooled.named == []
    assert null.pooled.table["q_value"].min() > 0.05

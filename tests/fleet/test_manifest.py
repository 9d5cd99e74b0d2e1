"""Manifests (CSV, TOML, glob) and each record's options over the fleet's."""

from __future__ import annotations

import pytest

from svrqp.exceptions import ProblemError
from svrqp.fleet.manifest import read_records
from svrqp.fleet.record import options_for

FLEET = {"target": "error_um", "train": "run < 2", "prediction": "prediction_um",
         "candidates": "a,b", "order": None}


def test_toml_and_csv_manifests_name_the_same_records(tmp_path):
    for name in ("one.csv", "two.csv"):
        (tmp_path / name).write_text("x\n1\n", encoding="utf-8")
    (tmp_path / "m.toml").write_text('[[record]]\npath = "one.csv"\ntrain = "run < 3"\n'
                                     '[[record]]\nname = "second"\npath = "two.csv"\n',
                                     encoding="utf-8")
    (tmp_path / "m.csv").write_text("path,name,train\none.csv,,run < 3\ntwo.csv,second,\n",
                                    encoding="utf-8")
    toml, csv = read_records(tmp_path / "m.toml"), read_records(tmp_path / "m.csv")
    assert toml == csv
    assert [r.name for r in toml] == ["one", "second"]
    assert toml[0].overrides == {"train": "run < 3"} and toml[1].overrides == {}
    assert [r.name for r in read_records(str(tmp_path / "*.csv"))] == ["m", "one", "two"]


def test_a_record_overrides_the_fleet_and_may_change_mode():
    own = options_for(FLEET, {"train": "run < 3"}, "r")
    assert own.train == "run < 3" and own.prediction == "prediction_um"
    fitted = options_for(FLEET, {"features": "T1_C", "model": "svr"}, "r")
    assert fitted.prediction is None and fitted.features == "T1_C" and fitted.model == "svr"
    with pytest.raises(ProblemError, match="r: a record may set only"):
        options_for(FLEET, {"seed": 3}, "r")
    with pytest.raises(ProblemError, match="r: give exactly one of"):
        options_for(FLEET | {"features": "T1_C"}, {}, "r")

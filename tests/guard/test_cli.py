"""``svrqp fit/export --coverage --group``: the interval and domain from the command line."""

from __future__ import annotations

import json

import numpy as np
import pytest

from support.cli_runs import run
from support.export_cases import thermal_raw


@pytest.fixture
def runs_csv(tmp_path):
    X, y = thermal_raw()
    path = tmp_path / "thermal.csv"
    X.assign(error_um=y, run=np.arange(len(y)) * 5 // len(y)).to_csv(path, index=False)
    return path


FIT = ["--target", "error_um", "--features", "T7_C,T9_C", "--model", "mlr"]


def test_fit_reports_the_interval_and_the_domain(runs_csv, capsys):
    assert run(["fit", str(runs_csv), *FIT, "--train", "run < 4", "--coverage", "0.8", "--group", "run"]) == 0
    out = capsys.readouterr().out
    assert "interval: 0.8 conformal (absolute)" in out and "leave-one-group-out over 4 groups" in out
    assert "inside interval" in out and "outside domain" in out


def test_export_carries_the_interval_into_json_and_c(runs_csv, tmp_path, capsys):
    model = tmp_path / "model.json"
    assert run(["export", str(runs_csv), *FIT, "--coverage", "0.9", "--group", "run", "--interval", "normalized",
                "--out", str(model)]) == 0
    document = json.loads(model.read_text(encoding="utf-8"))
    assert document["interval"]["coverage"] == 0.9 and document["interval"]["method"] == "normalized"
    assert document["interval"]["calibration"]["groups"] == ["0", "1", "2", "3", "4"]
    assert run(["verify", str(model)]) == 0
    assert "OK   guard" in capsys.readouterr().out
    assert run(["export", str(model), "--format", "c", "--out", str(tmp_path / "c")]) == 0
    assert "svrqp_predict_guarded" in (tmp_path / "c" / "svrqp_model.h").read_text()


@pytest.mark.parametrize("options, message", [
    (["--group", "run"], "--group only applies with --coverage"),
    (["--coverage", "1.2"], "coverage must be a number strictly between 0 and 1"),
    (["--coverage", "0.9", "--group", "cycle"], "cycle"),
    (["--coverage", "0.9", "--interval", "wide"], "--interval must be one of"),
])
def test_bad_guard_options_are_one_error_line(runs_csv, capsys, options, message):
    assert run(["fit", str(runs_csv), *FIT, *options]) != 0
    assert message in capsys.readouterr().err

"""Bad input to ``svrqp fleet``: one clear line each, exit code 2, nothing written or lost."""

from __future__ import annotations

import os

import pandas as pd
import pytest
from support.cli_runs import run

from svrqp.exceptions import ProblemError
from svrqp.fleet import read_records, run_fleet
from svrqp.machine.fleet import GAP_OPTIONS, FleetDesign, machine_record

OPTIONS = [arg for key, value in GAP_OPTIONS.items() for arg in (f"--{key}", value)]


@pytest.fixture(scope="module")
def record_csv(tmp_path_factory):
    folder = tmp_path_factory.mktemp("records")
    table, _ = machine_record(FleetDesign(n=1, runs=4, run_min=60.0), 0, "none")
    table.to_csv(folder / "a.csv", index=False)
    return folder / "a.csv"


def _one_error_line(capsys) -> str:
    lines = [line for line in capsys.readouterr().err.splitlines() if line.strip()]
    assert len(lines) == 1, lines
    return lines[0]


def test_a_manifest_naming_a_missing_file(record_csv, tmp_path, capsys):
    manifest = tmp_path / "manifest.csv"
    manifest.write_text(f"path\n{record_csv}\nnot_there.csv\n", encoding="utf-8")
    assert run(["fleet", str(manifest), "--out", str(tmp_path / "out"), *OPTIONS]) == 2
    line = _one_error_line(capsys)
    assert "record file not found" in line and "not_there.csv" in line
    assert not (tmp_path / "out").exists()


def test_two_records_of_one_name(record_csv, tmp_path, capsys):
    manifest = tmp_path / "manifest.csv"
    manifest.write_text(f"name,path\nx,{record_csv}\nx,{record_csv}\n", encoding="utf-8")
    assert run(["fleet", str(manifest), "--out", str(tmp_path / "out"), *OPTIONS]) == 2
    assert "two records named 'x'" in _one_error_line(capsys)
    assert not (tmp_path / "out").exists()


def test_a_record_without_the_target_column_fails_alone(record_csv, tmp_path, capsys):
    pd.read_csv(record_csv).drop(columns=["error_um"]).to_csv(tmp_path / "b.csv", index=False)
    manifest = tmp_path / "manifest.toml"
    manifest.write_text(f'[[record]]\npath = "{record_csv}"\n[[record]]\npath = "b.csv"\n',
                        encoding="utf-8")
    out = tmp_path / "out"
    assert run(["fleet", str(manifest), "--out", str(out), "--workers", "1", *OPTIONS]) == 1
    line = _one_error_line(capsys)
    assert line.startswith("record b failed:") and "error_um" in line
    table = pd.read_csv(out / "fleet.csv").set_index("name")
    assert table.at["a", "status"] == "ok" and table.at["b", "status"] == "failed"
    assert (out / "records" / "a.json").is_file() and not (out / "records" / "b.json").exists()
    leftovers = [p.name for p in out.rglob(".*")]  # no temporary file stays behind
    assert leftovers == []


def test_an_output_folder_that_cannot_be_written(record_csv, tmp_path, capsys):
    blocker = tmp_path / "file"
    blocker.write_text("not a folder", encoding="utf-8")
    pattern = str(record_csv.parent / "*.csv")
    assert run(["fleet", pattern, "--out", str(blocker / "out"), *OPTIONS]) == 2
    assert "cannot be written" in _one_error_line(capsys)
    if os.geteuid() != 0:  # root writes through permissions
        locked = tmp_path / "locked"
        locked.mkdir(mode=0o500)
        assert run(["fleet", pattern, "--out", str(locked), *OPTIONS]) == 2
        assert "cannot be written" in _one_error_line(capsys)


def test_a_record_left_without_a_target_is_refused_before_any_work(record_csv, tmp_path):
    records = read_records(str(record_csv.parent / "*.csv"))
    with pytest.raises(ProblemError, match="no --target"):
        run_fleet(records, {"train": "run < 2", "candidates": "nut_C"}, tmp_path / "out")
    assert not (tmp_path / "out").exists()


@pytest.mark.parametrize("text, message", [
    ("name\nx\n", "needs a 'path' column"),
    ("name,path\nx,\n", "no path"),
    ("path,colour\na.csv,red\n", "unknown column"),
])
def test_a_manifest_that_is_not_one(text, message, tmp_path):
    manifest = tmp_path / "manifest.csv"
    manifest.write_text(text, encoding="utf-8")
    with pytest.raises(ProblemError, match=message):
        read_records(manifest)


def test_a_glob_matching_nothing(tmp_path):
    with pytest.raises(ProblemError, match="names no record"):
        read_records(str(tmp_path / "*.csv"))

"""The ``svrqp gap`` command line (svrqp.cli.gap): the DESIGN §4 contract end to end."""

import json

import pytest
from support.gap_problems import air_lag_problem

from svrqp.cli import main


@pytest.fixture(scope="module")
def data_csv(tmp_path_factory):
    """The air-lag problem written as a CSV file."""
    path = tmp_path_factory.mktemp("gap") / "runs.csv"
    air_lag_problem().to_csv(path, index=False)
    return path


def _run(argv, capsys):
    try:
        main(argv)
        code = 0
    except SystemExit as stop:
        code = stop.code
    return code, capsys.readouterr()


def test_contract_command_line_writes_json_and_report(data_csv, tmp_path, capsys):
    out, html = tmp_path / "gap.json", tmp_path / "gap.html"
    code, printed = _run(["gap", str(data_csv), "--target", "error_um", "--train", "run == 'r0'",
                          "--features", "spindle_C", "--model", "mlr", "--candidates", "air_C,coolant_C,nut_C",
                          "--order", "time_min", "--group", "run", "--json", str(out), "--report", str(html)], capsys)
    assert code == 0, printed.err
    document = json.loads(out.read_text())
    assert document["verdict"]["column"] == "air_C"
    assert html.read_text(encoding="utf-8").startswith("<!doctype html>")
    assert "air_C" in printed.out


def test_prediction_mode(data_csv, tmp_path, capsys):
    out = tmp_path / "pred.json"
    code, printed = _run(["gap", str(data_csv), "--target", "error_um", "--train", "run == 'r0'",
                          "--prediction", "spindle_C", "--candidates", "air_C,nut_C", "--json", str(out),
                          "--jobs", "2"], capsys)
    assert code == 0, printed.err
    document = json.loads(out.read_text())
    assert document["mode"] == "prediction" and document["settings"]["within_evidence"] is False
    assert all(cause["p_within"] is None for cause in document["causes"])


def test_within_evidence_is_a_flag(data_csv, tmp_path, capsys):
    out = tmp_path / "within.json"
    code, printed = _run(["gap", str(data_csv), "--target", "error_um", "--train", "run == 'r0'",
                          "--prediction", "spindle_C", "--candidates", "air_C,nut_C", "--json", str(out),
                          "--within-evidence"], capsys)
    assert code == 0, printed.err
    document = json.loads(out.read_text())
    assert document["settings"]["within_evidence"] is True
    assert any(cause["p_within"] is not None for cause in document["causes"])


@pytest.mark.parametrize("extra, message", [
    (["--candidates", "bogus"], "unknown column"),
    (["--candidates", "air_C", "--prediction", "spindle_C"], "exactly one of --features"),
    (["--candidates", "air_C", "--train", "run == 'none'"], "selects no row"),
    (["--candidates", "air_C", "--jobs", "0"], "--jobs"),
])
def test_bad_input_is_one_line_and_writes_nothing(data_csv, tmp_path, capsys, extra, message):
    out = tmp_path / "bad.json"
    argv = ["gap", str(data_csv), "--target", "error_um", "--train", "run == 'r0'", "--features", "spindle_C",
            "--json", str(out), *extra]
    code, printed = _run(argv, capsys)
    assert code == 2
    assert message in printed.err and printed.err.count("\n") == 1
    assert not out.exists()


def test_existing_output_needs_force(data_csv, tmp_path, capsys):
    out = tmp_path / "taken.json"
    out.write_text("{}")
    argv = ["gap", str(data_csv), "--target", "error_um", "--train", "run == 'r0'", "--features", "spindle_C",
            "--candidates", "air_C", "--json", str(out)]
    code, printed = _run(argv, capsys)
    assert code == 2 and "--force" in printed.err
    assert out.read_text() == "{}"

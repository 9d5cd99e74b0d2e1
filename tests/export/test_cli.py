"""``svrqp export`` and ``svrqp verify`` from the command line (through the console entry point)."""

from __future__ import annotations

import json

import pytest

from support.cli_runs import run
from support.export_cases import thermal_raw


@pytest.fixture
def data_csv(tmp_path):
    X, y = thermal_raw()
    path = tmp_path / "thermal.csv"
    X.assign(error_um=y).to_csv(path, index=False)
    return path


FIT = ["--target", "error_um", "--features", "T7_C,T9_C"]


def test_data_table_to_verified_json_then_csv_and_c(data_csv, tmp_path, capsys):
    model = tmp_path / "model.json"
    assert run(["export", str(data_csv), *FIT, "--model", "svr", "--C", "100", "--epsilon", "0.2",
                "--gamma", "0.5", "--standardize", "--out", str(model)]) == 0
    output = capsys.readouterr().out
    assert f"wrote {model}" in output and "cross-check vs sklearn.svm.SVR" in output
    document = json.loads(model.read_text(encoding="utf-8"))
    assert document["kind"] == "epsilon_svr" and document["scaling"]["method"] == "standard"
    assert [v["name"] for v in document["inputs"]] == ["T7_C", "T9_C"]
    assert run(["verify", str(model)]) == 0
    assert capsys.readouterr().out.splitlines()[-1].startswith("OK ")
    assert run(["export", str(model), "--format", "csv", "--out", str(tmp_path / "table.csv")]) == 0
    assert run(["export", str(model), "--format", "c", "--out", str(tmp_path / "c")]) == 0
    assert (tmp_path / "c" / "svrqp_model.c").is_file() and (tmp_path / "c" / "svrqp_model.h").is_file()


@pytest.mark.parametrize(("model", "kind", "extra"), [
    ("lssvr", "ls_svr", ["--C", "10", "--gamma", "0.5", "--standardize"]),
    ("mlr", "linear_ls", []),
    ("rls", "recursive_ls", ["--forgetting", "0.98"]),
])
def test_every_model_kind_exports_from_data(data_csv, tmp_path, model, kind, extra):
    out = tmp_path / f"{model}.json"
    assert run(["export", str(data_csv), *FIT, "--model", model, *extra, "--out", str(out)]) == 0
    assert json.loads(out.read_text(encoding="utf-8"))["kind"] == kind
    assert run(["verify", str(out)]) == 0


def test_polynomial_exports_from_one_column(data_csv, tmp_path):
    out = tmp_path / "poly.json"
    assert run(["export", str(data_csv), "--target", "error_um", "--features", "T7_C", "--model", "poly",
                "--degree", "3", "--out", str(out)]) == 0
    assert run(["verify", str(out)]) == 0


def test_existing_output_needs_force(data_csv, tmp_path, capsys):
    out = tmp_path / "model.json"
    out.write_text("a user's file", encoding="utf-8")
    assert run(["export", str(data_csv), *FIT, "--model", "mlr", "--out", str(out)]) == 2
    assert "--force" in capsys.readouterr().err
    assert out.read_text(encoding="utf-8") == "a user's file"
    assert run(["export", str(data_csv), *FIT, "--model", "mlr", "--out", str(out), "--force"]) == 0


def test_tampered_file_fails_verify_and_is_not_converted(data_csv, tmp_path, capsys):
    out = tmp_path / "model.json"
    run(["export", str(data_csv), *FIT, "--model", "mlr", "--out", str(out)])
    document = json.loads(out.read_text(encoding="utf-8"))
    document["model"]["coef"][0] *= 1.01
    out.write_text(json.dumps(document), encoding="utf-8")
    capsys.readouterr()
    assert run(["verify", str(out)]) == 1
    printed = capsys.readouterr().out
    assert "FAIL hash" in printed and "FAIL probes" in printed and printed.splitlines()[-1].startswith("FAIL")
    assert run(["export", str(out), "--out", str(tmp_path / "table.csv")]) == 2
    assert "fails verification" in capsys.readouterr().err
    assert not (tmp_path / "table.csv").exists()


def test_schema_invalid_file_names_the_field(data_csv, tmp_path, capsys):
    out = tmp_path / "model.json"
    run(["export", str(data_csv), *FIT, "--model", "mlr", "--out", str(out)])
    document = json.loads(out.read_text(encoding="utf-8"))
    del document["target"]["unit"]
    out.write_text(json.dumps(document), encoding="utf-8")
    capsys.readouterr()
    assert run(["verify", str(out)]) == 1
    assert "target: 'unit' is a required property" in capsys.readouterr().out


@pytest.mark.parametrize(("argv", "message"), [
    (["export", "{model}", "--target", "error_um", "--out", "{tmp}/x.csv"], "only apply when SOURCE is a data table"),
    (["export", "{data}", "--out", "{tmp}/x.json"], "needs --target and --features"),
    (["export", "{data}", *FIT, "--out", "{tmp}/x.txt"], "cannot tell the format"),
    (["export", "{data}", *FIT, "--gamma", "wide", "--out", "{tmp}/x.json"], "--gamma must be"),
    (["export", "{data}", "--target", "error_um", "--features", "T7_C,T8_C", "--out", "{tmp}/x.json"], "T8_C"),
    (["export", "{tmp}/model.txt", "--out", "{tmp}/x.json"], "SOURCE must be a model file"),
    (["verify", "{tmp}/missing.json"], "not found"),
])
def test_bad_invocations_give_one_clear_line(data_csv, tmp_path, capsys, argv, message):
    model = tmp_path / "model.json"
    run(["export", str(data_csv), *FIT, "--model", "mlr", "--out", str(model)])
    capsys.readouterr()
    argv = [arg.format(model=model, data=data_csv, tmp=tmp_path) for arg in argv]
    assert run(argv) == 2
    err = capsys.readouterr().err
    assert message in err and len(err.strip().splitlines()) == 1, err

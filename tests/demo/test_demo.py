"""``svrqp demo --quick`` end to end: every file is written and linked, every number is finite and
agrees with the per-sample outputs it was computed from (read back, not hard-coded)."""

from __future__ import annotations

import io
import json
import math
import re
import sys
from html import escape as html_escape
from html import unescape as html_unescape

import numpy as np
import pandas as pd
import pytest
from rich.console import Console

from svrqp import datasets
from svrqp.cli import main
from svrqp.cli.demo import print_summary
from svrqp.demo.vocabulary import LABELS, cells, label_for, rule_text
from svrqp.demo.report import verdict_label
from svrqp.demo.run import prepare_directory
from svrqp.export import predict, read_document, verify
from svrqp.gap.results.document import load_schema as load_gap_schema


@pytest.fixture(scope="module")
def demo(tmp_path_factory):
    out = tmp_path_factory.mktemp("demo") / "demo-output"
    main(["demo", "--quick", "--out", str(out)])
    return out, json.loads((out / "results.json").read_text(encoding="utf-8"))


def _numbers(value):
    if isinstance(value, bool) or value is None or isinstance(value, str):
        return
    if isinstance(value, (int, float)):
        yield value
    elif isinstance(value, dict):
        for item in value.values():
            yield from _numbers(item)
    elif isinstance(value, list):
        for item in value:
            yield from _numbers(item)


def test_every_number_is_finite(demo):
    _, results = demo
    numbers = list(_numbers(results))
    assert len(numbers) > 50
    assert all(math.isfinite(number) for number in numbers)


def test_report_links_only_files_that_exist(demo):
    out, results = demo
    page = (out / "report.html").read_text(encoding="utf-8")
    targets = set(re.findall(r'(?:href|src)="([^"]+)"', page))
    expected = {"results.json", results["s0"]["predictions"], results["s0"]["cv_table"], results["s4"]["figure"],
                results["s2"]["figure"], *results["s0"]["figures"].values(), *results["export"]["files"],
                results["gap"]["json"], results["gap"]["html"]}
    assert expected <= targets
    for target in targets:
        assert (out / target).is_file(), target
    assert "SIMULATED" in page


def test_s0_table_is_what_the_predictions_say(demo):
    out, results = demo
    assert results["s0"]["dataset"] == "miao2013_rise" and "RMS" in results["s0"]["metric"]
    predictions = pd.read_csv(out / results["s0"]["predictions"])
    rms = {}
    for row in results["s0"]["table"]:
        rows = predictions[predictions["batch"] == row["batch"]]
        column = "mlr_um" if row["model"] == "MLR" else "svr_um"
        residual = rows["error_um"] - rows[column]
        assert row["rms_um"] == pytest.approx(np.sqrt(np.mean(residual**2)), rel=1e-9)
        assert row["std_um"] == pytest.approx(residual.std(ddof=0), rel=1e-9)
        rms[(row["model"], row["batch"])] = row["rms_um"]
    assert {batch for _, batch in rms} == {"x1", "x2", "x3"}
    better_on_x3 = min(("MLR", "ε-SVR"), key=lambda model: rms[(model, "x3")])
    assert results["s0"]["x3_better_model"] == better_on_x3
    assert results["s0"]["sentence"].startswith(f"On the autumn batch x3, with S0's temperature rises, the "
                                                f"{better_on_x3} leaves the smaller RMS residual")


def test_s0_says_where_the_models_extrapolate(demo):
    _, results = demo
    data = datasets.load("miao2013_rise")
    x1 = data[data["batch"] == "x1"]
    for batch in ("x2", "x3"):
        rows = data[data["batch"] == batch]
        shares = {}
        for feature in results["s0"]["features"]:
            low, high = x1[feature].min(), x1[feature].max()
            shares[feature] = ((rows[feature] < low) | (rows[feature] > high)).mean()
            row = next(r for r in results["s0"]["input_ranges"] if r["batch"] == batch and r["input"] == feature)
            assert row["share_outside"] == pytest.approx(shares[feature])
        noted = any(note.startswith(f"On {batch} the models extrapolate") for note in results["s0"]["extrapolation"])
        assert noted == (max(shares.values()) > 0)
    assert not any(note.startswith("On x3") for note in results["s0"]["extrapolation"])  # autumn inside summer
    variant = results["s0"]["absolute_variant"]
    assert variant["dataset"] == "miao2013" and variant["features"] == ["T7_C", "T9_C"]
    assert any("100 % of the rows outside" in note for note in variant["extrapolation"])


def test_report_writes_its_maths_as_plain_text(demo):
    out, results = demo
    page = (out / "report.html").read_text(encoding="utf-8")
    assert "\\" not in page  # no LaTeX (\\mathrm …) left for a renderer that is not there
    assert html_escape(results["s0"]["mlr_formula"]) in page
    assert "µ" not in page  # one micro sign: μ (U+03BC)


def test_exported_model_is_the_demo_svr_and_verifies(demo):
    out, results = demo
    assert results["export"]["verify"]["ok"]
    assert verify(out / "export" / "s0_svr.json").ok
    document = read_document(out / "export" / "s0_svr.json")
    x1 = datasets.load(results["s0"]["dataset"]).query("batch == 'x1'")
    predictions = pd.read_csv(out / results["s0"]["predictions"]).query("batch == 'x1'")
    from_file = predict(document, x1[results["s0"]["features"]].to_numpy())
    assert np.max(np.abs(from_file - predictions["svr_um"].to_numpy())) <= 1e-9  # CSV round trip of predictions
    assert document["model"]["C"] == results["s0"]["cv"]["best_params"]["C"]
    assert len(document["model"]["dual_coef"]) == results["s0"]["n_support"]


def test_s4_and_s2_numbers_are_consistent(demo):
    _, results = demo
    s4 = results["s4"]
    assert s4["improvement_percent"] == pytest.approx(100 * (1 - s4["after_um"] / s4["before_um"]))
    assert s4["n_support"] == 82 and s4["paper"]["improvement_percent"] == 53.0
    assert s4["out_of_sample"] is True and s4["train_run"] not in s4["test_runs"]
    unseen = [run for run in s4["runs"] if not run["fitted_on"]]
    assert [run["run"] for run in unseen] == s4["test_runs"]
    assert s4["before_um"] == pytest.approx(np.mean([run["before_um"] for run in unseen]))
    assert s4["after_um"] == pytest.approx(np.mean([run["after_um"] for run in unseen]))
    s2 = results["s2"]
    assert set(s2["max_error_improved"]) == set(s2["max_error_original"])
    assert all(value >= 0 for value in s2["mse_um2"].values())
    # The note names exactly the components the improved method identifies more closely.
    better = [c for c, e in s2["max_error_improved"].items() if e < s2["max_error_original"][c]]
    assert f"identifies {len(better)} of 6 components more closely than the original ({', '.join(better)})" in \
        s2["identification_note"]
    assert max(max(errors.values()) for errors in s2["max_error_noise_free"].values()) < 1e-5
    assert s2["dataset"] == "zhou_axis_x" and "zhou_axis_x_periodic" in s2["variant_note"]
    assert s2["mse_um2"]["lsm_fit_truth"] < 1e-6  # the simulated δx is a polynomial at the 11 points
    assert s4["model_slope"] < 1  # C = 0.5 shrinks what the model reproduces


def test_reproduction_table_repeats_the_sections_numbers(demo):
    _, results = demo
    rows = results["reproduction"]
    assert {row["seed"] for row in rows} == {"S0", "S1", "S2", "S3", "S4"}
    s0 = {(r["model"], r["batch"]): (r["paper_rms_um"], r["rms_um"]) for r in results["s0"]["table"]}
    for row in rows:
        assert row["metric"] and row["reproduction"] in LABELS
        expected = label_for(row["paper"], row["ours"], row["tolerance"], row["comparison_holds"])
        assert row["reproduction"] == expected.value
        if row["seed"] == "S0":
            model, batch = row["quantity"].split(", batch ")
            assert (row["paper"], row["ours"]) == s0[(model, batch)]
        if row["reproduction"] != "reproduced":
            assert row["note"]  # a difference always comes with its measured reason
    s2_rows = [row for row in rows if row["seed"] == "S2"]
    svr_better = results["s2"]["mse_um2"]["svr_fit"] < results["s2"]["mse_um2"]["lsm_fit"]
    assert all(row["comparison_holds"] is svr_better for row in s2_rows)
    s1 = {row["quantity"]: row["ours"] for row in rows if row["seed"] == "S1"}
    assert s1["GA-SVR"] == results["s1"]["sum_abs_um"]["ga"]
    s4 = {row["quantity"]: row for row in rows if row["seed"] == "S4"}
    assert s4["improvement, unseen runs"]["paper"] == 53.0
    assert s4["improvement, unseen runs"]["tolerance"] == 10.0


def test_results_terminal_and_report_carry_the_same_labels(demo):
    """The rows of results.json, the terminal table and report.html: the same cells, one vocabulary."""
    out, results = demo
    page = (out / "report.html").read_text(encoding="utf-8")
    assert "Reproduction, seed by seed" in page and rule_text() in html_unescape(page)
    console = Console(width=1000, record=True, file=io.StringIO())
    print_summary(console, results, out)
    terminal = console.export_text()
    lines = terminal.splitlines()
    for row in results["reproduction"]:
        expected = cells(row)
        html_row = "".join(f"<td>{html_escape(cell)}</td>" for cell in expected)
        assert html_row in page, row["quantity"]
        assert any(all(cell in line for cell in expected) for line in lines), row["quantity"]
    for text in (page, terminal):
        assert "agrees" not in text and "qualitatively" not in text


def test_s0_folds_are_random_and_seeded_as_s0s_with_contiguous_as_a_variant(demo):
    _, results = demo
    assert results["s0"]["cv"]["fold_split"].startswith("random, seed ")
    variant = results["s0"]["contiguous_folds_variant"]
    assert variant["folds"].startswith("contiguous") and len(variant["table"]) == 6
    claim = next(row for row in results["reproduction"] if row["quantity"] == "ε-SVR, batch x3")
    under = claim["ours"] < 2.0
    assert ("holds here" if under else "does not hold here") in claim["note"]


def test_s1_states_the_ga_size_and_that_quick_shrinks_it(demo):
    _, results = demo
    s1 = results["s1"]
    assert s1["quick"] is True and s1["genetic"]["population"] < 100
    assert (s1["genetic"]["crossover_probability"], s1["genetic"]["mutation_probability"]) == (0.85, 0.02)
    note = next(row for row in results["reproduction"] if row["seed"] == "S1")["note"]
    assert "quick run: S1 ran 100 × 50" in note
    assert (s1["edge_text"][1:] in note) if s1["edges"] else "No parameter ended on a bound" in note


def test_full_run_uses_s1s_ga():
    from svrqp.demo.online_seeds import S1_GENETIC

    assert (S1_GENETIC.population, S1_GENETIC.generations) == (100, 50)
    assert (S1_GENETIC.crossover_probability, S1_GENETIC.mutation_probability) == (0.85, 0.02)


def test_gap_report_is_schema_valid_and_matches(demo):
    import jsonschema

    out, results = demo
    gap = json.loads((out / results["gap"]["json"]).read_text(encoding="utf-8"))
    jsonschema.validate(gap, load_gap_schema())
    assert gap["verdict"] == results["gap"]["verdict"]


def test_existing_output_is_not_overwritten_without_force(demo, capsys):
    out, _ = demo
    before = (out / "results.json").read_bytes()
    with pytest.raises(SystemExit) as exit_:
        main(["demo", "--quick", "--out", str(out)])
    assert exit_.value.code == 2
    assert "--force" in capsys.readouterr().err
    assert (out / "results.json").read_bytes() == before
    prepare_directory(out, force=True)  # allowed with --force


def test_a_file_in_place_of_the_directory_is_refused(tmp_path):
    (tmp_path / "demo-output").write_text("a user's file")
    with pytest.raises(FileExistsError, match="not a directory"):
        prepare_directory(tmp_path / "demo-output", force=True)


@pytest.mark.parametrize("verdict, label", [
    ({"column": "T8_C", "transform": "lag"}, "T8_C (lag)"),
    ({"column": None, "ambiguous_with": ["T2_C", "T4_C"]}, "none named — several candidates cannot be told apart"),
    ({"column": None, "ambiguous_with": []}, "no cause beyond chance"),
], ids=["named", "tied", "none"])
def test_verdict_label_says_why_nothing_is_named(verdict, label):
    assert verdict_label(verdict) == label


def test_report_shows_no_raw_tex_in_a_browser(demo):
    """Opened in a real headless browser, the demo report's visible text holds no TeX."""
    from support.browser import raw_tex, rendered_dom

    out, _ = demo
    assert raw_tex(rendered_dom(out / "report.html")) == []


def test_without_the_guard_extra_the_demo_names_it_and_writes_nothing(tmp_path, monkeypatch, capsys):
    monkeypatch.setitem(sys.modules, "crepes", None)  # what a core install without the extra sees
    out = tmp_path / "demo-output"
    with pytest.raises(SystemExit) as exit_info:
        main(["demo", "--quick", "--out", str(out)])
    assert exit_info.value.code == 2
    error = capsys.readouterr().err.strip()
    assert "\n" not in error and "pip install 'svrqp[guard]'" in error
    assert not out.exists()


def test_without_both_extras_the_demo_names_both_in_one_line(tmp_path, monkeypatch, capsys):
    monkeypatch.setitem(sys.modules, "crepes", None)
    monkeypatch.setitem(sys.modules, "pygad", None)
    out = tmp_path / "demo-output"
    with pytest.raises(SystemExit) as exit_info:
        main(["demo", "--quick", "--out", str(out)])
    assert exit_info.value.code == 2
    error = capsys.readouterr().err.strip()
    assert "\n" not in error and "'guard' and 'ga' extras" in error and "pip install 'svrqp[guard,ga]'" in error
    assert not out.exists()


def test_a_demo_that_fails_midway_leaves_no_folder_behind(tmp_path, monkeypatch):
    from svrqp.demo import run as demo_run

    def broken(*args, **kwargs):
        raise RuntimeError("a step failed")

    monkeypatch.setattr(demo_run.steps, "s4_straightness", broken)
    out = tmp_path / "demo-output"
    with pytest.raises(RuntimeError, match="a step failed"):
        demo_run.run_demo(out, quick=True)
    assert not out.exists()

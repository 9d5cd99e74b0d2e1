"""A fleet of six small records, one broken, run serially and on a local Dask cluster of two
workers: each record's JSON is the one ``svrqp gap`` writes, the broken one is a row with its
reason, a rerun resumes."""

from __future__ import annotations

import importlib.util
import json
import shutil

import pandas as pd
import pytest
from support.cli_runs import run

from svrqp.fleet import Execution, read_records, run_fleet
from svrqp.machine.fleet import GAP_OPTIONS, FleetDesign, write_fleet

DESIGN = FleetDesign(n=5, runs=5, run_min=90.0, seed=7,
                     shares={"nut": 0.4, "headstock": 0.2, "faulty": 0.2, "none": 0.2})
DEFAULTS = {key: GAP_OPTIONS[key] for key in GAP_OPTIONS}


def _gap_argv(path, out):
    argv = ["gap", str(path), "--json", str(out)]
    for key, value in GAP_OPTIONS.items():
        argv += [f"--{key}", value]
    return argv


def _without_runtime(path) -> dict:
    document = json.loads(path.read_text(encoding="utf-8"))
    document.pop("runtime_s")
    return document


@pytest.fixture(scope="module")
def fleet_folder(tmp_path_factory):
    """Five simulated machines and one record without the target column."""
    folder = tmp_path_factory.mktemp("fleet")
    write_fleet(folder / "data", DESIGN)
    broken = pd.read_csv(folder / "data" / "m0.csv").drop(columns=["error_um"])
    broken.to_csv(folder / "data" / "broken.csv", index=False)
    manifest = pd.read_csv(folder / "data" / "manifest.csv")
    row = manifest.iloc[[0]].assign(name="broken", path="broken.csv")
    pd.concat([manifest, row]).to_csv(folder / "data" / "manifest.csv", index=False)
    return folder


@pytest.fixture(scope="module")
def serial(fleet_folder):
    records = read_records(fleet_folder / "data" / "manifest.csv")
    return run_fleet(records, {}, fleet_folder / "serial")


def test_a_broken_record_is_a_row_with_its_reason_and_the_rest_go_on(serial):
    table = serial.table.set_index("name")
    assert len(table) == 6
    assert table.at["broken", "status"] == "failed"
    assert "error_um" in table.at["broken", "reason"]
    assert (table.drop(index="broken")["status"] == "ok").all()
    assert set(serial.tests["name"]) == {f"m{i}" for i in range(5)}


def test_each_record_json_is_the_one_svrqp_gap_writes(fleet_folder, serial, tmp_path):
    for name in ("m0", "m3"):
        single = tmp_path / f"{name}.json"
        assert run(_gap_argv(fleet_folder / "data" / f"{name}.csv", single)) == 0
        fleet_json = fleet_folder / "serial" / "records" / f"{name}.json"
        assert _without_runtime(fleet_json) == _without_runtime(single)
        text = fleet_json.read_text(encoding="utf-8")
        runtime = json.loads(text)["runtime_s"]
        expected = single.read_text(encoding="utf-8").replace(
            json.dumps(json.loads(single.read_text())["runtime_s"]), json.dumps(runtime))
        assert text == expected  # byte for byte, but for the seconds it took


def test_the_fleet_writes_its_table_page_and_pooled_evidence(fleet_folder, serial):
    out = fleet_folder / "serial"
    table = pd.read_csv(out / "fleet.csv")
    assert list(table["name"]) == sorted(serial.table["name"])
    assert {"verdict_column", "shrink", "shrink_low", "extrapolated", "runtime_s"} <= set(table)
    page = (out / "fleet.html").read_text(encoding="utf-8")
    assert "data:image/png;base64," in page and "broken" in page
    pooled = pd.read_csv(out / "pooled.csv")
    assert set(pooled["column"]) == set(GAP_OPTIONS["candidates"].split(","))


def test_a_rerun_resumes_unchanged_records_and_redoes_a_changed_one(fleet_folder, serial,
                                                                    tmp_path):
    for part in ("data", "serial"):  # a copy: the other tests read the first run
        shutil.copytree(fleet_folder / part, tmp_path / part)
    records = read_records(tmp_path / "data" / "manifest.csv")
    with pytest.raises(FileExistsError, match="--resume"):
        run_fleet(records, {}, tmp_path / "serial")
    path = tmp_path / "data" / "m1.csv"
    table = pd.read_csv(path)
    table.loc[0, "error_um"] += 0.5
    table.to_csv(path, index=False)
    stamp = tmp_path / "serial" / "records" / "m2.fleet.json"  # a stamp without pooled p-values
    stamp.write_text(json.dumps({k: v for k, v in json.loads(stamp.read_text()).items()
                                 if k != "pool"}), encoding="utf-8")
    rerun = run_fleet(records, {}, tmp_path / "serial", resume=True)
    again = rerun.table.set_index("name")
    assert again.at["m1", "status"] == "ok" and again.at["m2", "status"] == "ok"
    assert again.at["broken", "status"] == "failed"
    assert (again.drop(index=["m1", "m2", "broken"])["status"] == "resumed").all()
    kept = ~serial.tests["name"].isin(["m1"])  # a resumed record keeps its pooled p-values
    pd.testing.assert_frame_equal(rerun.tests[kept].reset_index(drop=True),
                                  serial.tests[kept].reset_index(drop=True))
    changed = {**DEFAULTS, "seed": 1}  # other settings: nothing is taken as it was
    records_changed = [r for r in records if r.name != "broken"]
    redo = run_fleet(records_changed, changed, tmp_path / "serial", resume=True)
    assert (redo.table["status"] == "ok").all()


@pytest.mark.skipif(importlib.util.find_spec("distributed") is None,
                    reason="dask.distributed is not installed (pip install 'svrqp[dask]')")
def test_two_dask_workers_give_the_serial_answers(fleet_folder, serial):
    records = read_records(fleet_folder / "data" / "manifest.csv")
    result = run_fleet(records, {}, fleet_folder / "dask", execution=Execution(workers=2))
    assert result.table["status"].tolist() == serial.table["status"].tolist()
    for name in (f"m{i}" for i in range(5)):
        on_dask = fleet_folder / "dask" / "records" / f"{name}.json"
        assert _without_runtime(on_dask) == _without_runtime(
            fleet_folder / "serial" / "records" / f"{name}.json")
    pd.testing.assert_frame_equal(result.pooled.table, serial.pooled.table)

"""Hostile model files and names: each reproducer ends in a failed report or the library's own error.

* C injection: an input name or an edited formula that closes the ``/* */`` comment stays inside it;
* loading verifies: a changed coefficient under the old hash is refused by ``read_document``;
* the probe tolerance is bounded (schema, and by the file's own term magnitude);
* ``verify`` reports (never raises) on deep nesting, 400-digit numbers and oversized files;
* ``created_utc`` must be a real date; the writers never follow a (dangling) symbolic link.
"""

from __future__ import annotations

import json
import os
import re

import numpy as np
import pytest

from support.c_driver import run_driver
from support.export_cases import svr_scaled
from svrqp.cli import main
from svrqp.exceptions import ProblemError
from svrqp.export import build_document, canonical, content_sha256, read_document, verify, write
from svrqp.export.c_source import c_source

PAYLOAD = '*/ __attribute__((constructor)) static void pwn(void) { puts("PWNED"); } /*'


@pytest.fixture(scope="module")
def document() -> dict:
    case = svr_scaled()
    return build_document(case.model, case.X, case.y)


def _rehashed(document: dict) -> dict:
    document = json.loads(json.dumps(document))
    document["content_sha256"] = content_sha256(document)
    return document


def _code_outside_comments(source: str) -> str:
    return re.sub(r"/\*.*?\*/", "", source, flags=re.DOTALL)


def _hostile(document: dict) -> dict:
    hostile = json.loads(json.dumps(document))
    hostile["inputs"][0]["name"] = "T7_C" + PAYLOAD
    hostile["inputs"][1]["unit"] = "°C\n#include <stdlib.h>\n??/"
    hostile["target"]["name"] = "error_um */ int injected; /*"
    hostile["model"]["formula"] = PAYLOAD + "\r\n\u2028 \\"
    return _rehashed(hostile)


def test_c_injection_through_names_and_formula_stays_in_comments(document):
    """Reproducer: a feature named ``T7_C*/ … /*`` or an edited formula became compiled code."""
    hostile = _hostile(document)
    assert _code_outside_comments(c_source(hostile)) == _code_outside_comments(c_source(document))
    assert "??" not in c_source(hostile)
    assert "*\\/ __attribute__" in c_source(hostile)  # the text is kept, escaped


def test_c_injection_does_not_run_when_compiled(document, gcc, tmp_path):
    source, _ = write(_hostile(document), tmp_path)
    driver = ('#include <stdio.h>\n#include "svrqp_model.h"\n'
              "int main(void) { double x[SVRQP_N_INPUTS] = {0}; printf(\"%g\\n\", svrqp_predict(x)); return 0; }\n")
    output = run_driver(gcc, driver, source, np.empty((0, 0)), tmp_path)
    assert "PWNED" not in output


def test_c_header_name_is_whitelisted(document):
    with pytest.raises(ProblemError, match="#include"):
        c_source(document, header_name='x.h"\n#include "/etc/passwd')


def test_csv_comments_cannot_start_a_row(document, tmp_path):
    (path,) = write(_hostile(document), tmp_path / "table.csv")
    lines = path.read_text(encoding="utf-8").splitlines()
    header = next(i for i, line in enumerate(lines) if not line.startswith("#"))
    assert lines[header].startswith("i,sv_coef,")
    assert len(lines) == header + 1 + len(document["model"]["dual_coef"])


def test_read_document_refuses_a_changed_coefficient_under_the_old_hash(document, tmp_path):
    """Reproducer: read_document loaded tampered files whose hash no longer matched."""
    tampered = json.loads(json.dumps(document))
    tampered["model"]["dual_coef"][0] *= 2.0
    path = tmp_path / "model.json"
    path.write_text(json.dumps(tampered), encoding="utf-8")
    with pytest.raises(ProblemError, match="hash"):
        read_document(path)


def test_read_document_refuses_rehashed_changed_coefficients(document, tmp_path):
    tampered = json.loads(json.dumps(document))
    tampered["model"]["dual_coef"][0] *= 2.0
    path = tmp_path / "model.json"
    path.write_text(json.dumps(_rehashed(tampered)), encoding="utf-8")
    with pytest.raises(ProblemError, match="probes"):
        read_document(path)


@pytest.mark.parametrize("tolerance", [1e300, 2.0])
def test_probe_tolerance_is_bounded_by_the_schema(document, tmp_path, tolerance):
    """Reproducer: a re-hashed file with tolerance 1e300 passed verify with changed coefficients."""
    tampered = json.loads(json.dumps(document))
    tampered["model"]["dual_coef"][0] *= 2.0
    tampered["probes"]["tolerance"] = tolerance
    path = tmp_path / "model.json"
    path.write_text(json.dumps(_rehashed(tampered)), encoding="utf-8")
    report = verify(path)
    assert not report.ok and "probes.tolerance" in report.checks[0].detail


def test_probe_tolerance_is_bounded_by_the_files_own_terms(document, tmp_path):
    tampered = json.loads(json.dumps(document))
    tampered["model"]["dual_coef"][0] += 1e-3
    tampered["probes"]["tolerance"] = 0.5  # within the schema, far above 1e-9 x the terms
    path = tmp_path / "model.json"
    path.write_text(json.dumps(_rehashed(tampered)), encoding="utf-8")
    report = verify(path)
    assert [check.ok for check in report.checks] == [True, True, False, True]
    assert "exceeds" in report.checks[2].detail


@pytest.mark.parametrize("text, fragment", [
    ("[" * 100_000, "nests"),
    ('{"schema": "svrqp.model/1", "n": 1' + "0" * 400 + "}", "digits"),
    ('{"schema": "svrqp.model/1", "n": 1.' + "0" * 400 + "}", "characters"),
    ('{"schema": "svrqp.model/1", "n": 1e400}', "overflows"),
    ("\xff\xfe", "utf-8"),
])
def test_verify_reports_hostile_text_without_raising(tmp_path, text, fragment):
    """Reproducer: verify raised RecursionError on '[' x 100000 and OverflowError on a 400-digit number."""
    path = tmp_path / "hostile.json"
    path.write_bytes(text.encode("latin-1") if text.startswith("\xff") else text.encode("utf-8"))
    report = verify(path)
    assert not report.ok
    assert report.checks[0].name == "schema" and fragment in report.checks[0].detail


def test_verify_reports_an_oversized_file(tmp_path, monkeypatch, document):
    (path,) = write(document, tmp_path / "model.json")
    monkeypatch.setattr(canonical, "MAX_BYTES", 1000)
    report = verify(path)
    assert not report.ok and "bytes" in report.checks[0].detail


def test_created_utc_must_be_a_real_date(document, tmp_path):
    tampered = json.loads(json.dumps(document))
    tampered["created_utc"] = "2026-13-45T99:99:99Z"
    path = tmp_path / "model.json"
    path.write_text(json.dumps(_rehashed(tampered)), encoding="utf-8")
    report = verify(path)
    assert not report.ok and "created_utc" in report.checks[0].detail


def test_export_does_not_follow_a_dangling_symlink(document, tmp_path):
    """Reproducer: ``export -o`` wrote through a dangling symbolic link. Without force it is refused;
    with force the link itself is replaced (svrqp.output) and its target is never created."""
    elsewhere = tmp_path / "elsewhere.json"
    link = tmp_path / "model.json"
    link.symlink_to(elsewhere)
    with pytest.raises(FileExistsError, match="symbolic link"):
        write(document, link)
    assert link.is_symlink() and not elsewhere.exists()
    write(document, link, force=True)
    assert not link.is_symlink() and link.is_file() and not elsewhere.exists()


def test_verify_command_reports_hostile_text_with_exit_1(tmp_path, capsys):
    path = tmp_path / "hostile.json"
    path.write_text("[" * 100_000, encoding="utf-8")
    with pytest.raises(SystemExit) as exit_:
        main(["verify", str(path)])
    assert exit_.value.code == 1
    assert "FAIL schema" in capsys.readouterr().out


def test_verify_reports_a_path_that_is_not_a_regular_file(tmp_path):
    fifo = tmp_path / "model.json"
    os.mkfifo(fifo)
    for path in (fifo, tmp_path, tmp_path / "missing.json"):
        report = verify(path)
        assert not report.ok and "not a regular file" in report.checks[0].detail

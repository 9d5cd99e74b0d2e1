"""``verify``: schema, content hash and probe re-evaluation; tampering is detected."""

from __future__ import annotations

import json

import pytest

from support.export_cases import lssvr, svr_scaled
from svrqp.export import build_document, content_sha256, verify, write


@pytest.fixture
def exported(tmp_path):
    case = svr_scaled()
    document = build_document(case.model, case.X, case.y)
    (path,) = write(document, tmp_path / "model.json")
    return document, path


def test_untouched_file_verifies(exported):
    _, path = exported
    report = verify(path)
    assert report.ok, report.checks
    assert [check.name for check in report.checks] == ["schema", "hash", "probes", "guard"]
    assert report.max_deviation <= report.tolerance


def _change_one_byte_of_a_coefficient(text: str, document: dict) -> str:
    """Change the last digit of the text of ``dual_coef[0]`` (one byte)."""
    number = repr(document["model"]["dual_coef"][0])
    position = text.index(number) + len(number) - 1
    digit = "1" if text[position] != "1" else "2"
    return text[:position] + digit + text[position + 1:]


def test_one_byte_change_in_a_coefficient_is_detected(exported):
    document, path = exported
    text = path.read_text(encoding="utf-8")
    tampered = _change_one_byte_of_a_coefficient(text, document)
    assert sum(a != b for a, b in zip(text, tampered, strict=True)) == 1
    path.write_text(tampered, encoding="utf-8")
    report = verify(path)
    assert not report.ok
    failed = {check.name for check in report.checks if not check.ok}
    assert "hash" in failed


def test_rehashed_tampering_is_caught_by_the_probes(exported):
    """Someone who edits a coefficient and recomputes the hash is still caught by the probes."""
    document, path = exported
    tampered = json.loads(path.read_text(encoding="utf-8"))
    tampered["model"]["dual_coef"][0] += 1.0
    tampered["content_sha256"] = content_sha256(tampered)
    path.write_text(json.dumps(tampered), encoding="utf-8")
    report = verify(path)
    assert [check.ok for check in report.checks] == [True, True, False, True]
    assert report.max_deviation > report.tolerance


def test_schema_invalid_file_fails_with_the_field_named(tmp_path):
    case = lssvr()
    document = build_document(case.model, case.X, case.y)
    document["model"]["C"] = "ten"
    (tmp_path / "bad.json").write_text(json.dumps(document), encoding="utf-8")
    report = verify(tmp_path / "bad.json")
    assert not report.ok
    assert report.checks[0].name == "schema" and "model.C" in report.checks[0].detail

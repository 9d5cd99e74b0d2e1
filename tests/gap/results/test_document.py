"""The report's JSON document: the version written, and the previous version still read."""

import json
from pathlib import Path

import pytest

from svrqp.exceptions import SvrqpError
from svrqp.gap import load_schema, read_document
from svrqp.gap.results.document import SCHEMA_ID, validate_document

OLD = Path(__file__).with_name("gap_v1_miao2013.json")
"""The README example's document as svrqp.gap/1 wrote it (before round and p_paired were dropped)."""


def test_the_written_version_has_no_dead_cause_fields():
    causes = load_schema()["properties"]["causes"]["items"]["properties"]
    assert SCHEMA_ID == "svrqp.gap/2" and load_schema()["properties"]["schema"]["const"] == SCHEMA_ID
    assert "round" not in causes and "p_paired" not in causes


def test_a_previous_version_file_is_still_read(tmp_path):
    document = read_document(OLD)
    assert document["schema"] == "svrqp.gap/1"
    assert document["causes"][0]["round"] == 1 and "p_paired" in document["causes"][0]
    assert load_schema("svrqp.gap/1")["properties"]["causes"]["items"]["properties"]["round"]["minimum"] == 1


def test_a_previous_version_file_is_checked_against_its_own_schema(tmp_path):
    document = json.loads(OLD.read_text(encoding="utf-8"))
    document["causes"][0]["round"] = 0  # the old schema wants a round of at least 1
    with pytest.raises(SvrqpError, match="svrqp.gap/1"):
        validate_document(document)


@pytest.mark.parametrize("version", ["svrqp.gap/0", None])
def test_an_unknown_version_is_refused_by_name(version, tmp_path):
    document = json.loads(OLD.read_text(encoding="utf-8")) | {"schema": version}
    with pytest.raises(SvrqpError, match="unknown gap report schema"):
        validate_document(document)


def test_a_file_that_is_no_json_is_refused_by_name(tmp_path):
    path = tmp_path / "gap.json"
    path.write_text("{not json", encoding="utf-8")
    with pytest.raises(SvrqpError, match="not a JSON gap report"):
        read_document(path)

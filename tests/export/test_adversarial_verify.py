"""Second hostile campaign (issue #39) on ``verify``: probe-blind edits and budgets checked before work."""

from __future__ import annotations

import json

import numpy as np
import pytest

from svrqp import EpsilonSVR, LSSVR
from svrqp.exceptions import ProblemError
from svrqp.export import build_document, content_sha256, verify, write
from svrqp.export.budget import MAX_SUPPORT_VECTORS, check_budget


def narrow_rbf_document(model_class=EpsilonSVR) -> dict:
    """RBF with γ = 1e3 on 60 rows: each support vector's bump is invisible from the others."""
    X = np.random.default_rng(0).uniform(-1, 1, (60, 2))
    y = np.sin(3 * X[:, 0]) + 1.5 * X[:, 1]
    parameters = {"C": 10.0, "gamma": 1e3}
    if model_class is EpsilonSVR:
        parameters["epsilon"] = 0.01
    return build_document(model_class(**parameters).fit(X, y), X, y)


def rehashed(document: dict) -> dict:
    document["content_sha256"] = content_sha256(document)
    return document


def save(document: dict, path) -> str:
    path.write_text(json.dumps(document), encoding="utf-8")
    return str(path)


@pytest.mark.parametrize("model_class", [EpsilonSVR, LSSVR])
def test_edit_of_a_support_vector_far_from_every_probe_is_detected(tmp_path, model_class):
    """#4: +5.0 on the dual coefficient of the support vector farthest from the 16 probes, re-hashed,
    probes left alone: verify said ok while the predictions at the training rows moved by 5."""
    document = narrow_rbf_document(model_class)
    support = np.asarray(document["model"]["support_vectors"])
    probes = np.asarray(document["probes"]["X"])
    farthest = int(((support[:, None, :] - probes[None]) ** 2).sum(-1).min(1).argmax())
    document["model"]["dual_coef"][farthest] += 5.0
    report = verify(save(rehashed(document), tmp_path / "m.json"))
    assert not report.ok
    assert "support vectors" in report.failures() and report.max_deviation == pytest.approx(5.0, rel=1e-6)


def test_untouched_narrow_rbf_model_verifies(tmp_path):
    document = narrow_rbf_document()
    path = tmp_path / "m.json"
    write(document, path)
    report = verify(path)
    assert report.ok, report.failures()
    assert f"{len(document['model']['support_vectors'])} support vectors" in report.checks[2].detail


def test_removing_the_support_predictions_is_refused(tmp_path):
    """Dropping probes.support_prediction (and re-hashing) must not switch the check off."""
    document = narrow_rbf_document()
    del document["probes"]["support_prediction"]
    report = verify(save(rehashed(document), tmp_path / "m.json"))
    assert not report.ok and "support_prediction" in report.failures()


def test_degree_10_to_the_14_is_refused(tmp_path):
    """#13: a re-hashed file with ``"degree": 10**14`` made verify run for minutes."""
    document = narrow_rbf_document()
    document["model"]["kernel"].update(name="poly", degree=10**14, gamma=1.0, coef0=0.0, g=None, sigma_s0=None,
                                       sigma_s4=None)
    report = verify(save(rehashed(document), tmp_path / "m.json"))
    assert not report.ok and "degree" in report.checks[0].detail


@pytest.mark.parametrize("shape", ["rows", "flat"])
def test_two_million_probe_values_are_refused(tmp_path, shape):
    """#18: an 8 MB file with 2 million extra probe values took 23 s to reject. Rows of probe
    inputs are counted in the text before parsing; a flat vector is counted before the schema."""
    document = narrow_rbf_document()
    if shape == "rows":
        document["probes"]["X"] += [[0.5, 0.5]] * 1_000_000
        expected = "arrays"
    else:
        document["probes"]["prediction"] += [0.0] * 2_000_000
        expected = "probes.prediction"
    path = save(rehashed(document), tmp_path / "m.json")
    report = verify(path)
    assert not report.ok and expected in report.checks[0].detail


def test_budget_counts_support_vectors():
    """The exporter and verify share one budget (check_budget), so no file is written that verify refuses."""
    document = narrow_rbf_document()
    document["model"]["support_vectors"] *= MAX_SUPPORT_VECTORS // 10
    with pytest.raises(ProblemError, match="model.support_vectors"):
        check_budget(document)

"""Tampered model files (hypothesis, seeded): a failed report or SvrqpError, never a silent pass.

The tampering operations and the outcome rule live in ``benchmarks/adversarial_documents.py``
(its longer run is the benchmark); here hypothesis draws the document, the operation and the
generator seed that fixes the operation's details.
"""

from __future__ import annotations

import copy
import json

import numpy as np
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from support.benchmark_modules import load_benchmark
from svrqp.export import content_sha256, evaluate

adversarial = load_benchmark("adversarial_documents")


@settings(max_examples=300, derandomize=True, deadline=None, database=None,
          suppress_health_check=[HealthCheck.too_slow])
@given(base=st.sampled_from(adversarial.BASES), tamper=st.sampled_from(sorted(adversarial.TAMPERS)),
       seed=st.integers(0, 2**32 - 1))
def test_tampered_file_fails_or_keeps_the_model(base, tamper, seed):
    label, text = adversarial.tampered(np.random.default_rng(seed), base, tamper)
    result = adversarial.outcome(adversarial.base_documents()[base], text)
    assert result in ("documented error", "right answer"), f"{label}: {result}"


def test_the_benchmark_cases_reach_both_allowed_outcomes():
    """60 seeded benchmark cases: both allowed outcomes occur (the rule is not vacuous), no other."""
    results = {case() for case in adversarial.cases(np.random.default_rng(7), 60)}
    assert results == {"documented error", "right answer"}


def test_classifier_sees_a_silent_wrong_answer():
    """A forged file (changed coefficient, recomputed probe predictions and hash) verifies: the
    hash proves integrity, not authorship, and the outcome rule calls the result what it is."""
    original = adversarial.base_documents()["mlr"]
    forged = copy.deepcopy(original)
    forged["model"]["coef"][0] += 1.0
    forged["probes"]["prediction"] = evaluate.predict(forged, np.asarray(forged["probes"]["X"])).tolist()
    forged["content_sha256"] = content_sha256(forged)
    assert adversarial.outcome(original, json.dumps(forged)) == "silent wrong"


def test_base_document_names_are_known_up_front():
    assert tuple(adversarial.base_documents()) == adversarial.BASES

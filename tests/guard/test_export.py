"""A guarded model in the svrqp.model/1 file: round trip, verify re-checks, and the C evaluator.

The C evaluator's ``svrqp_predict_guarded`` is compiled with the system C compiler like the other C
export tests and compared with the live Python model (``Guarded.predict_interval`` and
``check_domain``) on points inside and outside the training domain.
"""

from __future__ import annotations

import json
import warnings

import numpy as np
import pandas as pd
import pytest
from sklearn.linear_model import LinearRegression
from sklearn.pipeline import make_pipeline
from sklearn.preprocessing import StandardScaler

from support.c_driver import run_driver
from support.export_cases import thermal_raw
from svrqp import EpsilonSVR, ExtrapolationWarning, Guarded
from svrqp.exceptions import ProblemError
from svrqp.export import build_document, content_sha256, read_document, verify, write
from svrqp.export.guarded import predict_guarded
from svrqp.estimators import LinearLS

DRIVER = r"""
#include <stdio.h>
#include "svrqp_model.h"

int main(void)
{
    double x[SVRQP_N_INPUTS], prediction, lower, upper;
    for (;;) {
        int j, outside;
        for (j = 0; j < SVRQP_N_INPUTS; ++j) {
            if (scanf("%lf", &x[j]) != 1) {
                return 0;
            }
        }
        outside = svrqp_predict_guarded(x, &prediction, &lower, &upper);
        printf("%.17g %.17g %.17g %d\n", prediction, lower, upper, outside);
    }
}
"""


def guarded_svr(method: str) -> tuple[Guarded, pd.DataFrame, pd.Series]:
    X, y = thermal_raw()
    groups = np.arange(len(y)) * 6 // len(y)  # six contiguous runs
    model = Guarded(make_pipeline(StandardScaler(), EpsilonSVR(C=100.0, epsilon=0.2, gamma=0.5)),
                    coverage=0.8, method=method).fit(X, y, groups=groups)
    return model, X, y


def points(X: pd.DataFrame) -> np.ndarray:
    """400 points on a box 20 % wider than the training range: many are outside the domain."""
    low, high = X.min().to_numpy(), X.max().to_numpy()
    pad = 0.2 * (high - low)
    a, b = np.meshgrid(np.linspace(low[0] - pad[0], high[0] + pad[0], 20),
                       np.linspace(low[1] - pad[1], high[1] + pad[1], 20))
    return np.column_stack([a.ravel(), b.ravel()])


def python_reference(model: Guarded, P: np.ndarray, columns) -> tuple[np.ndarray, ...]:
    frame = pd.DataFrame(P, columns=columns)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ExtrapolationWarning)
        prediction, interval = model.predict(frame), model.predict_interval(frame)
    return prediction, interval[:, 0], interval[:, 1], model.check_domain(frame)["outside"].to_numpy()


@pytest.mark.parametrize("method", ["absolute", "normalized"])
def test_file_round_trip_reproduces_intervals_and_flags(method, tmp_path):
    model, X, y = guarded_svr(method)
    document = build_document(model, X, y)
    (path,) = write(document, tmp_path / "model.json")
    report = verify(path)
    assert report.ok, report.failures()
    assert report.checks[3].name == "guard" and "conformal order statistic" in report.checks[3].detail
    loaded = read_document(path)
    assert loaded["interval"]["calibration"]["groups"] == ["0", "1", "2", "3", "4", "5"]
    assert loaded["interval"]["coverage"] == 0.8 and loaded["interval"]["method"] == method
    P = points(X)
    expected = python_reference(model, P, X.columns)
    got = predict_guarded(loaded, P)
    for a, b in zip(got[:3], expected[:3], strict=True):  # values of order 1e3: a relative tolerance
        np.testing.assert_allclose(a, b, rtol=1e-12, atol=1e-12 * np.max(np.abs(b)))
    assert np.array_equal(got[3], expected[3]) and 0 < got[3].sum() < len(P)


def _rewrite(path, change) -> None:
    document = json.loads(path.read_text(encoding="utf-8"))
    change(document)
    document["content_sha256"] = content_sha256(document)
    path.write_text(json.dumps(document), encoding="utf-8")


@pytest.mark.parametrize("change, message", [
    (lambda d: d["interval"].update(quantile=d["interval"]["quantile"] * 0.5), "order statistic|not the"),
    (lambda d: d["interval"].update(coverage=0.5), "not the"),
    (lambda d: d["domain"].update(threshold=d["domain"]["threshold"] * 10), "flags"),
    (lambda d: d["domain"]["precision"][0].__setitem__(1, 5.0), "symmetric"),
    (lambda d: d["probes"]["upper"].__setitem__(0, d["probes"]["upper"][0] + 1.0), "deviate"),
])
def test_verify_rechecks_the_guard_from_the_file(change, message, tmp_path):
    model, X, y = guarded_svr("absolute")
    # probes on the points grid so that some are outside: a wider threshold changes their flags
    (path,) = write(build_document(model, X, y, probes=points(X)), tmp_path / "model.json")
    _rewrite(path, change)
    report = verify(path)
    assert [check.name for check in report.checks if not check.ok] == ["guard"]
    assert any(fragment in report.checks[3].detail for fragment in message.split("|"))


def test_a_guarded_document_needs_both_sections(tmp_path):
    model, X, y = guarded_svr("absolute")
    (path,) = write(build_document(model, X, y), tmp_path / "model.json")
    _rewrite(path, lambda d: d.pop("domain"))
    report = verify(path)
    assert not report.ok and "interval" in report.checks[0].detail


def c_guarded(gcc: str, document: dict, P: np.ndarray, directory) -> np.ndarray:
    source, header = write(document, directory)
    assert "int svrqp_predict_guarded(" in header.read_text()
    output = run_driver(gcc, DRIVER, source, P, directory)
    return np.array([[float(v) for v in line.split()] for line in output.splitlines()])


@pytest.mark.parametrize("method", ["absolute", "normalized"])
def test_c_matches_python_to_1e12_with_flags(gcc, method, tmp_path):
    model, X, y = guarded_svr(method)
    P = points(X)
    c = c_guarded(gcc, build_document(model, X, y), P, tmp_path)
    prediction, lower, upper, outside = python_reference(model, P, X.columns)
    assert c.shape == (len(P), 4)
    scale = max(1.0, np.max(np.abs(prediction)))  # relative past values of order 1
    assert np.max(np.abs(c[:, 0] - prediction)) <= 1e-12 * scale
    for j, python in ((1, lower), (2, upper)):
        assert np.all(np.abs(c[:, j] - python) <= 1e-12 * scale + width_rounding_bound(model, P))
    assert np.array_equal(c[:, 3].astype(bool), outside) and 0 < outside.sum() < len(P)


def width_rounding_bound(model: Guarded, P: np.ndarray) -> np.ndarray:
    """A-priori bound on how far two double evaluations of the half width q·σ(x) may differ.

    σ(x) = exp(c₀ + cᵀz) turns an absolute rounding error of its argument into the same relative
    error of σ: summing the d + 1 terms in another order (numpy's matmul against the C loop) and
    the standardisation cost at most ~(d + 3)·eps·Σ|terms| each side (Higham, recursive
    summation), and exp itself a few eps. Outside the domain σ grows to thousands, where that is
    more than 1e-12 absolute although it is a few units in the last place. Zero for the absolute
    method, whose half width is the stored constant q.
    """
    calibration = model.calibration_
    if calibration.difficulty_coef is None:
        return np.zeros(len(P))
    Z = (P - model.domain_.mean) / model.domain_.scale
    terms = abs(calibration.difficulty_intercept) + np.abs(Z * calibration.difficulty_coef).sum(axis=1)
    half_width = calibration.quantile * np.exp(calibration.difficulty_intercept + Z @ calibration.difficulty_coef)
    eps = np.finfo(float).eps
    return 2 * ((P.shape[1] + 3) * eps * terms + 4 * eps) * half_width


def test_c_flags_nan_and_training_rows(gcc, tmp_path):
    """Every training row is inside in C too (rounding margin); a NaN input is outside."""
    X, y = thermal_raw()
    model = Guarded(LinearLS(), coverage=0.9).fit(X, y)
    P = np.vstack([X.to_numpy(), [[np.nan, 30.0]]])
    c = c_guarded(gcc, build_document(model, X, y), P, tmp_path)
    assert c[:-1, 3].sum() == 0 and c[-1, 3] == 1


def test_csv_table_names_the_interval(tmp_path):
    model, X, y = guarded_svr("normalized")
    document = build_document(model, X, y)
    (path,) = write(document, tmp_path / "table.csv")
    comments = [line for line in path.read_text(encoding="utf-8").splitlines() if line.startswith("#")]
    assert any(f"prediction +- {document['interval']['quantile']!r} * sigma(x)" in line for line in comments)


def test_a_guarded_foreign_regressor_is_refused_by_name():
    X, y = thermal_raw()
    with pytest.raises(ProblemError, match="cannot export a LinearRegression"):
        build_document(Guarded(LinearRegression()).fit(X, y), X, y)

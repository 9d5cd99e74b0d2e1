"""Transfer numbers of a kernel baseline (svrqp.gap.transfer.kernel) against independent refits.

The references refit the same family leave one run out over all rows with the baseline's C, ε and
γ: LS-SVR as its KKT system solved by :func:`numpy.linalg.solve`, ε-SVR as scikit-learn's ``SVR``
— features and target standardised on each fit's own rows, as the baseline does.
"""

import json

import jsonschema
import numpy as np
import pandas as pd
import pytest
from sklearn.svm import SVR

from svrqp.gap import GapQuestion, diagnose, load_schema
from svrqp.gap.model import LSSVR_C, SVR_C, SVR_EPSILON
from svrqp.gap.transfer.kernel import KERNEL_CAUSES, MIN_KERNEL_ROWS


def kernel_problem(seed: int = 0, runs: int = 5, rows: int = 60) -> pd.DataFrame:
    """A non-linear model of ``f_C`` and an unmodelled level of ``c_C``, which holds still on the train
    run r0 and swings within every real run over the same range (a refit can transfer it); ``d_C``
    is a decoy."""
    rng = np.random.default_rng(seed)
    t = np.arange(rows, dtype=float)
    parts = []
    for run in range(runs):
        f = np.sin(2 * np.pi * (t / 45 + rng.random())) + 0.1 * rng.normal(size=rows)
        c = np.sin(2 * np.pi * (t / 25 + rng.random())) if run else 0.01 * rng.normal(size=rows)
        d = np.sin(2 * np.pi * (t / 33 + rng.random()))
        y = 2 * np.tanh(f) + 1.5 * c + 0.1 * rng.normal(size=rows)
        parts.append(pd.DataFrame({"run": f"r{run}", "time_min": t, "f_C": f, "c_C": c, "d_C": d, "error_um": y}))
    return pd.concat(parts, ignore_index=True)


QUESTION = {"target": "error_um", "train": "run == 'r0'", "features": ["f_C"], "candidates": ["c_C", "d_C"],
            "order": "time_min", "group": "run"}


def _standardised(fit: np.ndarray, *others: np.ndarray) -> list[np.ndarray]:
    """Columns centred and scaled by the mean and (population) standard deviation of the fit rows."""
    mean, std = fit.mean(axis=0), fit.std(axis=0)
    return [(M - mean) / std for M in (fit, *others)]


def _rbf(A: np.ndarray, B: np.ndarray, gamma: float) -> np.ndarray:
    return np.exp(-gamma * ((A[:, None, :] - B[None, :, :]) ** 2).sum(axis=2))


def _lssvr(X: np.ndarray, y: np.ndarray, X_new: np.ndarray, gamma: float) -> np.ndarray:
    """LS-SVR: [[0, 1'], [1, K + I/C]] [b; α] = [0; y] by numpy.linalg.solve, on standardised X and y."""
    Xs, Xn = _standardised(X, X_new)
    ys = (y - y.mean()) / y.std()
    n = len(ys)
    system = np.zeros((n + 1, n + 1))
    system[0, 1:] = system[1:, 0] = 1.0
    system[1:, 1:] = _rbf(Xs, Xs, gamma) + np.eye(n) / LSSVR_C
    b_alpha = np.linalg.solve(system, np.concatenate([[0.0], ys]))
    return (_rbf(Xn, Xs, gamma) @ b_alpha[1:] + b_alpha[0]) * y.std() + y.mean()


def _svr(X: np.ndarray, y: np.ndarray, X_new: np.ndarray, gamma: float) -> np.ndarray:
    """scikit-learn's ε-SVR with the baseline's C and ε (in target standard deviations), tol 1e-10."""
    Xs, Xn = _standardised(X, X_new)
    model = SVR(kernel="rbf", C=SVR_C, epsilon=SVR_EPSILON, gamma=gamma, tol=1e-10)
    return model.fit(Xs, (y - y.mean()) / y.std()).predict(Xn) * y.std() + y.mean()


def _reference(df: pd.DataFrame, fit_predict, effect: str) -> dict[str, float]:
    """rmse_before (fitted on r0), and the leave-one-run-out rmse_refit and rmse_after over all rows."""
    y, runs = df["error_um"].to_numpy(), df["run"].to_numpy()
    X, XE = df[["f_C"]].to_numpy(), df[["f_C", effect]].to_numpy()
    train = runs == "r0"
    gamma = 1.0 / (X.shape[1] * _standardised(X[train])[0].var())  # the baseline's "scale" on its train rows
    before = y[~train] - fit_predict(X[train], y[train], X[~train], gamma)
    refit, after = [], []
    for run in np.unique(runs[~train]):
        held = runs == run
        refit.append(y[held] - fit_predict(X[~held], y[~held], X[held], gamma))
        after.append(y[held] - fit_predict(XE[~held], y[~held], XE[held], gamma))
    rms = lambda e: float(np.sqrt(np.mean(np.concatenate(e) ** 2)))
    return {"before": rms([before]), "refit": rms(refit), "after": rms(after)}


@pytest.mark.parametrize(("model", "fit_predict", "rel"), [("lssvr", _lssvr, 1e-8), ("svr", _svr, 1e-5)])
def test_verdict_shrink_equals_an_independent_same_family_refit(model, fit_predict, rel):
    df = kernel_problem()
    report = diagnose(df, GapQuestion(**QUESTION, model=model))
    verdict = report.verdict
    assert verdict.column == "c_C" and verdict.transform == "level", verdict.reason
    assert verdict.family == model and report.transfer["family"] == model
    assert report.transfer["screened_by"] == "linear"
    ref = _reference(df, fit_predict, "c_C")
    assert verdict.rmse_before == pytest.approx(ref["before"], rel=rel)
    assert report.transfer["rmse_refit"] == pytest.approx(ref["refit"], rel=rel)
    assert verdict.rmse_refit == pytest.approx(ref["refit"], rel=rel)
    assert verdict.rmse_after == pytest.approx(ref["after"], rel=rel)
    assert verdict.shrink == pytest.approx(1 - ref["after"] / ref["before"], rel=rel)
    assert verdict.shrink_beyond_refit == pytest.approx(1 - ref["after"] / ref["refit"], rel=rel)
    assert "refit the " + model in verdict.reason


def test_causes_below_the_best_few_keep_the_linear_screen_and_say_so():
    df = kernel_problem()
    t = df["time_min"].to_numpy()
    df = df.assign(e_C=np.cos(2 * np.pi * t / 37), g_C=t / 60, h_C=np.sin(2 * np.pi * t / 19))  # more decoys
    report = diagnose(df, GapQuestion(**QUESTION | {"candidates": ["c_C", "d_C", "e_C", "g_C", "h_C"]}, model="lssvr"))
    families = [c.family for c in report.causes]
    assert families == ["lssvr"] * KERNEL_CAUSES + ["linear"] * (len(families) - KERNEL_CAUSES)
    assert report.verdict.column == "c_C" and report.verdict.family == "lssvr"
    header, rows = report.tables()["causes"]
    assert [row[header.index("refitted family")] for row in rows] == families


def _few_rows(train_rows: int) -> pd.DataFrame:
    """Three real runs of 7 rows and a train run of ``train_rows``, ``c_C`` recorded on the real rows only."""
    df = kernel_problem(seed=1, runs=4, rows=30)
    keep = np.where(df["run"] == "r0", df["time_min"] < train_rows, df["time_min"] < 7)
    df = df[keep].reset_index(drop=True)
    return df.assign(c_C=df["c_C"].where(df["run"] != "r0"))


@pytest.mark.parametrize("train_rows", [4, 30])
def test_too_few_rows_for_a_kernel_refit_fall_back_to_the_linear_family_and_say_so(train_rows):
    report = diagnose(_few_rows(train_rows), GapQuestion(**QUESTION, model="lssvr"))
    document = report.to_dict()
    jsonschema.validate(json.loads(report.to_json()), load_schema())
    c_c = next(c for c in report.causes if c.column == "c_C")
    assert c_c.family == "linear"  # its fits would hold 14 real rows
    if train_rows + 14 < MIN_KERNEL_ROWS:  # even the same-input refit is too small: the report is linear
        assert document["transfer"]["family"] == "linear"
        assert "fewer than 20 rows" in document["transfer"]["family_note"]
    else:
        assert document["transfer"]["family"] == "lssvr" and document["transfer"]["family_note"] is None
        assert "too few rows" in c_c.note


def _failing_fit_predict(monkeypatch, fails):
    """Make the kernel module's refits raise the solver's certificate failure where ``fails(design)`` is true."""
    from svrqp.exceptions import SolverError
    from svrqp.gap.transfer import kernel

    real = kernel.fit_predict

    def fit_predict(kind, X_train, y_train, X, gamma="scale"):
        if fails(X_train):
            raise SolverError("gap certificate 2.31e-06 > 1e-06\nsecond line")
        return real(kind, X_train, y_train, X, gamma)

    monkeypatch.setattr(kernel, "fit_predict", fit_predict)


def test_a_failed_same_input_refit_falls_back_to_the_linear_family(monkeypatch):
    """One certificate failure in the same-input kernel refit: the diagnosis goes on with the linear
    family's numbers, and the JSON and the reason say which refit failed and why."""
    _failing_fit_predict(monkeypatch, lambda X: X.shape[1] == 1)  # the features alone: the same-input refit
    report = diagnose(kernel_problem(), GapQuestion(**QUESTION, model="svr"))
    document = json.loads(report.to_json())
    jsonschema.validate(document, load_schema())
    assert document["transfer"]["family"] == "linear"
    assert "refit of the svr failed (gap certificate 2.31e-06 > 1e-06)" in document["transfer"]["family_note"]
    assert all(cause["family"] == "linear" for cause in document["causes"])
    assert document["causes"] and document["verdict"]["reason"]


def test_a_failed_refit_of_one_cause_keeps_its_linear_numbers(monkeypatch):
    """A cause whose kernel refit fails keeps the linear screen's numbers with a note; the others are
    refitted with the kernel family as usual."""
    _failing_fit_predict(monkeypatch, lambda X: X.shape[1] > 1)  # any refit with an effect added
    report = diagnose(kernel_problem(), GapQuestion(**QUESTION, model="svr"))
    document = json.loads(report.to_json())
    jsonschema.validate(document, load_schema())
    assert document["transfer"]["family"] == "svr" and document["transfer"]["family_note"] is None
    noted = [c for c in document["causes"] if "its svr refit failed (gap certificate" in (c["note"] or "")]
    assert noted and all(c["family"] == "linear" for c in noted)


def test_a_failed_train_refit_of_the_verdict_is_said_not_raised(monkeypatch):
    import importlib

    from svrqp.exceptions import SolverError

    engine = importlib.import_module("svrqp.gap.diagnose")  # the module, not the function

    def refit_shrink(data, baseline, effect):
        raise SolverError("gap certificate 2.31e-06 > 1e-06")

    monkeypatch.setattr(engine, "refit_shrink", refit_shrink)
    report = diagnose(kernel_problem(), GapQuestion(**QUESTION, model="svr"))
    assert report.verdict.column == "c_C" and report.verdict.refit_shrink is None
    assert "could not be refitted with it as an input: its solver failed (gap certificate" in report.verdict.reason
    jsonschema.validate(json.loads(report.to_json()), load_schema())

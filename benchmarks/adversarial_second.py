"""The second hostile campaign's families (issue #39), run by ``benchmarks/adversarial.py``.

Each family ``cases(rng, n)`` returns zero-argument callables with a ``label``, like the first
campaign's; a case returns one of ``documented error``, ``right answer``, ``silent wrong``,
``crash`` or ``hang`` (it ran past :data:`BUDGET_S`, or blocked). References are independent of
svrqp: pandas masks on the exact column, scipy's ``lstsq`` (weighted, on centred data), the file
system itself (what exists where after a write).

* ``dtype_container_cases`` — inputs as lists, pandas frames, int/bool/object arrays, ``groups``
  of one or of mixed types, ``Guarded(None)``;
* ``query_name_cases`` — placeholder-clashing, full-width and backtick-in-string filters, and
  integer literals of up to 400 digits;
* ``budget_cases`` — polynomial degree up to 2**40 and coef0 up to 1e200, forgetting factors down
  to 1e-30, inputs offset by 1.7e9, nearly collinear columns with ``rank_deficient="lstsq"``;
* ``path_cases`` — outputs named by a dangling link, a link to a file, a FIFO or a folder, with
  and without ``force``: nothing may be written anywhere but the named path, nothing may block;
* ``huge_header_cases`` — header-only CSVs of 10 000 to 100 000 columns, some repeating a name;
* ``probe_blind_cases`` — a dual coefficient far from every probe changed and the file re-hashed;
* ``scale_cases`` — ε-SVR targets of 1e-14 to 1e-9 with tubes down to 1e-3 of them, constant
  targets, a linear kernel on inputs up to ×1e8 (findings 14 and 15), against cvxpy and Clarabel
  on the stated dual in units of std(y), or on the primal in unit inputs.
"""

from __future__ import annotations

import json
import os
import tempfile
import threading
import warnings
from fractions import Fraction
from functools import partial
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import scipy.linalg
from adversarial_cases import (  # what every family shares, beside this script
    BUDGET_S,
    CRASH,
    DOCUMENTED,
    HANG,
    PREDICTION_TOL,
    RIGHT,
    WRONG,
    Case,
    classify,
)

from svrqp import LSSVR, EpsilonSVR, Guarded, output
from svrqp.cli._common import read_table
from svrqp.estimators import LinearLS, RecursiveLS
from svrqp.exceptions import SvrqpError
from svrqp.export import build_document, content_sha256, verify
from svrqp.query import select_rows

#: The second campaign's files and paths: refusing to replace a file without force
#: (``FileExistsError``, which the CLI reports as one line) is documented too.
classify = partial(classify, documented=(SvrqpError, FileExistsError))


# -- dtypes and containers -------------------------------------------------------------------

CONTAINERS = ("list", "frame", "int", "bool", "object", "groups-mixed", "groups-text", "no-estimator")


def check_container(p: dict[str, Any]) -> str:
    rng = np.random.default_rng(p["seed"])
    X = rng.uniform(-1, 1, (30, 2))
    y = X[:, 0] + 0.5 * X[:, 1]
    kind = p["kind"]

    def run() -> bool:
        if kind in ("groups-mixed", "groups-text", "no-estimator"):
            groups = {"groups-mixed": np.array([0, "a", 1] * 10, dtype=object),
                      "groups-text": np.array(["a", "b", "c"] * 10, dtype=object)}.get(kind)
            model = Guarded(None if kind == "no-estimator" else LinearLS(), n_splits=3).fit(X, y, groups=groups)
            return bool(np.allclose(model.predict(X), y, atol=1e-9))
        given = {"list": X.tolist(), "frame": pd.DataFrame(X, columns=["a", "b"]), "int": np.round(X * 10).astype(int),
                 "bool": X > 0, "object": X.astype(object)}[kind]
        values = np.asarray(given, dtype=float)
        fitted = LinearLS().fit(given, y)
        expected = np.column_stack([np.ones(30), values]) @ scipy.linalg.lstsq(
            np.column_stack([np.ones(30), values]), y)[0]
        return bool(np.max(np.abs(fitted.predict(given) - expected)) <= PREDICTION_TOL * y.std())

    return classify(run)


def dtype_container_cases(rng: np.random.Generator, n: int) -> list[Case]:
    """Inputs as lists, frames, int/bool/object arrays; Guarded with mixed or text groups, or no model."""
    return [Case(f"container/{kind}", check_container, {"seed": int(rng.integers(2**31)), "kind": kind})
            for kind in (str(rng.choice(CONTAINERS)) for _ in range(n))]


# -- filters whose names or literals the parser could rewrite --------------------------------

def check_query_names(p: dict[str, Any]) -> str:
    rng = np.random.default_rng(p["seed"])
    table = pd.DataFrame({"T 7": rng.integers(0, 10, 12), "svrqp_column_0": rng.integers(0, 40, 12),
                          "t": rng.integers(0, 5, 12), "ｔ": rng.integers(0, 5, 12),
                          "b": rng.choice(["it's `T 7`", "x"], 12), "f": rng.uniform(0, 1, 12)})
    k = int(rng.integers(0, 10))
    digits = int(rng.integers(20, 400))  # beyond 308 digits the literal overflows float64: refused
    queries = {
        "clash": (f"`T 7` > {k} and svrqp_column_0 < 25", (table["T 7"] > k) & (table["svrqp_column_0"] < 25)),
        "full-width": (f"ｔ > {k % 5}", table["ｔ"] > k % 5),
        "backtick-in-string": ("b == '''it's `T 7`'''", table["b"] == "it's `T 7`"),
        "huge-literal": ("f < " + "9" * digits, table["f"] < float("9" * digits) if digits <= 308 else None),
    }
    query, expected = queries[p["kind"]]

    def run() -> bool:
        mask = select_rows(table, query)
        return expected is not None and bool(mask.equals(expected))

    return classify(run)


def query_name_cases(rng: np.random.Generator, n: int) -> list[Case]:
    """Filters with a placeholder-named column, full-width names, backticks in strings, huge literals."""
    kinds = ("clash", "full-width", "backtick-in-string", "huge-literal")
    return [Case(f"query/{kind}", check_query_names, {"seed": int(rng.integers(2**31)), "kind": kind})
            for kind in (str(rng.choice(kinds)) for _ in range(n))]


# -- parameters and data at the edge of what float64 and the budgets allow -------------------

def _weighted_lstsq(X: np.ndarray, y: np.ndarray, forgetting: float) -> np.ndarray:
    """Fitted values of the exponentially weighted least-squares problem, in exact rational arithmetic.

    With weights down to 1e-30 an SVD lstsq of the weighted rows loses up to 1e-4·std(y) (its
    backward error is relative to the largest row), so the reference solves the normal equations
    on the floats exactly (``Fraction``) and rounds only the fitted values.
    """
    A = [[Fraction(1), *map(Fraction, row)] for row in X.tolist()]
    targets = list(map(Fraction, y.tolist()))
    lam, n, p = Fraction(forgetting), len(targets), len(A[0])
    weights = [lam ** (n - 1 - i) for i in range(n)]
    M = [[sum(w * a[j] * a[k] for w, a in zip(weights, A)) for k in range(p)] for j in range(p)]
    rhs = [sum(w * a[j] * t for w, a, t in zip(weights, A, targets)) for j in range(p)]
    for column in range(p):  # Gauss-Jordan, exact
        pivot = next(row for row in range(column, p) if M[row][column] != 0)
        M[column], M[pivot], rhs[column], rhs[pivot] = M[pivot], M[column], rhs[pivot], rhs[column]
        for row in range(p):
            if row != column and M[row][column] != 0:
                factor = M[row][column] / M[column][column]
                M[row] = [x - factor * z for x, z in zip(M[row], M[column])]
                rhs[row] -= factor * rhs[column]
    coef = [rhs[j] / M[j][j] for j in range(p)]
    return np.array([float(sum(c * a_j for c, a_j in zip(coef, a))) for a in A])


def check_budget(p: dict[str, Any]) -> str:
    rng = np.random.default_rng(p["seed"])
    X = rng.uniform(-1, 1, (30, 2))
    y = np.sin(3 * X[:, 0]) + 0.1 * rng.normal(size=30)
    kind = p["kind"]

    def run() -> bool:
        if kind in ("degree", "coef0"):
            parameters = {"degree": 2 ** int(rng.integers(7, 41))} if kind == "degree" else \
                {"coef0": 10.0 ** rng.uniform(60, 200)}
            model_class = LSSVR if rng.random() < 0.5 else EpsilonSVR
            model_class(kernel="poly", **parameters).fit(X, y)
            return False  # an answer from such a kernel cannot be right: it must be refused
        if kind == "forgetting":
            forgetting = 10.0 ** rng.uniform(-30, -1)
            fitted = RecursiveLS(forgetting=forgetting).fit(X, y)
            expected = _weighted_lstsq(X, y, forgetting)
            return bool(np.max(np.abs(fitted.predict(X) - expected)) <= 1e-6 * y.std())
        if kind == "offset":
            shifted = X + np.array([1.7e9, 0.0])
            fitted = (LinearLS() if rng.random() < 0.5 else RecursiveLS()).fit(shifted, y)
            A = np.column_stack([np.ones(30), X])  # the same problem without the offset
            expected = A @ scipy.linalg.lstsq(A, y)[0]
            return bool(np.max(np.abs(fitted.predict(shifted) - expected)) <= 1e-6 * y.std())
        collinear = np.column_stack([X[:, 0], 2 * X[:, 0] + 10.0 ** rng.uniform(-13, -9) * rng.normal(size=30)])
        fitted = LinearLS(rank_deficient="lstsq").fit(collinear, y)
        centred = collinear - collinear.mean(axis=0)
        expected = centred @ scipy.linalg.lstsq(centred, y - y.mean())[0] + y.mean()
        predicted = fitted.predict(collinear)
        # Coefficients of ~1/noise make the predictions sums of huge terms: they are determined only
        # to ~eps·|a|·|x| (the reference's too), and the residual to ~eps·κ(design) relative (the
        # answer to data perturbed at eps, which centring does). Right: scipy's residual and its
        # predictions within those bounds (at least the contract's 1e-5·std).
        eps = np.finfo(float).eps
        bound = max(PREDICTION_TOL * y.std(), 64 * eps * np.abs(fitted.coef_).sum() * np.abs(collinear).max())
        kappa = np.sqrt(fitted.condition_number_) if np.isfinite(fitted.condition_number_) else 1.0
        slack = max(1e-9, 64 * eps * kappa)
        residual_ok = np.linalg.norm(y - predicted) <= np.linalg.norm(y - expected) * (1 + slack)
        return bool(residual_ok and np.max(np.abs(predicted - expected)) <= bound)

    return classify(run)


def budget_cases(rng: np.random.Generator, n: int) -> list[Case]:
    """Degree up to 2**40, coef0 up to 1e200, forgetting to 1e-30, offsets of 1.7e9, collinear columns."""
    kinds = ("degree", "coef0", "forgetting", "offset", "collinear")
    return [Case(f"budget/{kind}", check_budget, {"seed": int(rng.integers(2**31)), "kind": kind})
            for kind in (str(rng.choice(kinds)) for _ in range(n))]


# -- output paths -------------------------------------------------------------------------------

PATH_KINDS = ("dangling-link", "link-to-file", "fifo", "folder", "existing-file", "new-file")


def _prepare(folder: Path, kind: str) -> tuple[Path, Path]:
    """The named output path and the file a link points to."""
    named, elsewhere = folder / "out.json", folder / "elsewhere.json"
    if kind == "dangling-link":
        named.symlink_to(elsewhere)
    elif kind == "link-to-file":
        elsewhere.write_text("precious")
        named.symlink_to(elsewhere)
    elif kind == "fifo":
        os.mkfifo(named)
    elif kind == "folder":
        named.mkdir()
    elif kind == "existing-file":
        named.write_text("mine")
    return named, elsewhere


def check_path(p: dict[str, Any]) -> str:
    with tempfile.TemporaryDirectory() as name:
        folder = Path(name)
        named, elsewhere = _prepare(folder, p["kind"])
        before = elsewhere.read_text() if elsewhere.exists() else None
        result: list[str] = []

        def attempt() -> None:
            result.append(classify(lambda: output.write_text(named, "{}", force=p["force"]) is not None))

        worker = threading.Thread(target=attempt, daemon=True)
        worker.start()
        worker.join(BUDGET_S)
        if worker.is_alive():
            if p["kind"] == "fifo":  # release the blocked writer
                os.close(os.open(named, os.O_RDONLY | os.O_NONBLOCK))
            return HANG
        after = elsewhere.read_text() if elsewhere.exists() else None
        if after != before or sorted(path.name for path in folder.iterdir()) not in (["out.json"], [
                "elsewhere.json", "out.json"]):
            return WRONG  # something written outside the named path
        outcome = result[0]
        if outcome == RIGHT and not (named.is_file() and not named.is_symlink() and named.read_text() == "{}"):
            return WRONG
        return outcome


def path_cases(rng: np.random.Generator, n: int) -> list[Case]:
    """Outputs named by a dangling link, a link to a file, a FIFO, a folder, a file; force or not."""
    return [Case(f"path/{kind}/{'force' if force else 'no-force'}", check_path, {"kind": kind, "force": force})
            for kind, force in ((str(rng.choice(PATH_KINDS)), bool(rng.random() < 0.5)) for _ in range(n))]


# -- huge headers -------------------------------------------------------------------------------

def check_header(p: dict[str, Any]) -> str:
    with tempfile.TemporaryDirectory() as name:
        path = Path(name) / "wide.csv"
        names = [f"c{i}" for i in range(p["columns"])] + (["c7"] if p["repeat"] else [])
        path.write_text(",".join(names) + "\n")
        return classify(lambda: read_table(path) is None)


def huge_header_cases(rng: np.random.Generator, n: int) -> list[Case]:
    """Header-only CSVs of 10 000 to 100 000 columns, some repeating a name."""
    return [Case("header/" + ("repeated" if repeat else "unique"), check_header, {"columns": columns, "repeat": repeat})
            for columns, repeat in ((int(rng.integers(10_000, 100_001)), bool(rng.random() < 0.5)) for _ in range(n))]


# -- probe-blind edits of model files -----------------------------------------------------------

def check_probe_blind(p: dict[str, Any]) -> str:
    rng = np.random.default_rng(p["seed"])
    X = rng.uniform(-1, 1, (60, 2))
    y = np.sin(3 * X[:, 0]) + X[:, 1]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        document = build_document(EpsilonSVR(C=10.0, gamma=float(10 ** rng.uniform(1, 3)), epsilon=0.01).fit(X, y), X, y)
    support = np.asarray(document["model"]["support_vectors"])
    probes = np.asarray(document["probes"]["X"])
    farthest = int(((support[:, None, :] - probes[None]) ** 2).sum(-1).min(1).argmax())
    document["model"]["dual_coef"][farthest] += float(rng.choice([-1, 1]) * 10 ** rng.uniform(-3, 1))
    document["content_sha256"] = content_sha256(document)
    with tempfile.TemporaryDirectory() as name:
        path = Path(name) / "m.json"
        path.write_text(json.dumps(document))
        try:
            return DOCUMENTED if not verify(path).ok else WRONG
        except Exception:  # noqa: BLE001 - verify must report, never raise
            return CRASH


def probe_blind_cases(rng: np.random.Generator, n: int) -> list[Case]:
    """A dual coefficient far from every probe changed by 1e-3..10, the file re-hashed."""
    return [Case("document/probe-blind edit", check_probe_blind, {"seed": int(rng.integers(2**31))})
            for _ in range(n)]


# -- ε-SVR on hostile scales (findings 14 and 15) --------------------------------------------

SCALE_KINDS = ("tiny-targets", "constant", "linear-scale")
TINY_TARGET_SOLVERS = ("auto", "smo_crossover", "dual_ipm", "proxqp", "osqp", "highs", "clarabel")


def _tube_dual_predictions(K: np.ndarray, y: np.ndarray, epsilon: float, C: float) -> np.ndarray:
    """The stated ε-SVR dual by cvxpy and Clarabel in units of std(y): predictions at the training
    points. A box wider than 1e6 in those units is left out and must come out inactive."""
    import cvxpy as cp

    a, m = float(np.std(y)), float(np.mean(y))
    target, box = (y - m) / a, C / a
    beta = cp.Variable(y.size)
    objective = (0.5 * cp.quad_form(beta, cp.psd_wrap(K)) - target @ beta
                 + epsilon / a * cp.norm1(beta))
    constraints = [cp.sum(beta) == 0] + ([cp.abs(beta) <= box] if box <= 1e6 else [])
    cp.Problem(cp.Minimize(objective), constraints).solve(
        solver=cp.CLARABEL, tol_gap_abs=1e-10, tol_gap_rel=1e-10, tol_feas=1e-10)
    value = beta.value
    if box > 1e6 and np.abs(value).max() >= 1e-3 * box:
        raise RuntimeError("the reference's dropped box is active")
    free = (np.abs(value) > 1e-6 * np.abs(value).max()) & (np.abs(value) < box * (1 - 1e-6))
    residual = target - K @ value
    b = float(np.median(residual[free] - epsilon / a * np.sign(value[free])))
    return a * (K @ value + b) + m


def _linear_primal_predictions(Z: np.ndarray, y: np.ndarray, scale: float, C: float,
                               epsilon: float) -> np.ndarray:
    """The linear-kernel ε-SVR on inputs ``scale``·Z from its primal on the unit inputs Z (cvxpy
    and Clarabel, relative gap 1e-12): with w = v/s the objective is ½|v|² + C s² Σξ (over s²),
    v of order 1. Written as ½|v|²/(C s²) + Σξ instead, with every point in the tube the
    objective was 1e-11 at inputs of 1e5 and Clarabel stopped 3 % short of it (and 70 % at C s² =
    9e10); that form is used only where the first does not solve (C s² of 1e18: nearly a linear
    programme)."""
    import cvxpy as cp

    v, b, xi = cp.Variable(Z.shape[1]), cp.Variable(), cp.Variable(y.size, nonneg=True)
    residual = y - Z @ v - b
    weight = C * scale**2
    forms = [0.5 * cp.sum_squares(v) + weight * cp.sum(xi),
             0.5 * cp.sum_squares(v) / weight + cp.sum(xi)]
    for objective in forms:
        problem = cp.Problem(cp.Minimize(objective),
                             [residual <= epsilon + xi, -residual <= epsilon + xi])
        try:
            problem.solve(solver=cp.CLARABEL, tol_gap_abs=0.0, tol_gap_rel=1e-12, tol_feas=1e-12)
        except cp.error.SolverError:
            continue
        if problem.status == cp.OPTIMAL:
            return Z @ v.value + b.value
    raise RuntimeError("the reference primal did not solve")


def check_scale(p: dict[str, Any]) -> str:
    """One ε-SVR fit on a hostile scale; an answer is judged against its independent reference
    (computed only for an answer: a refusal needs none, and a reference that cannot be solved
    stops the campaign instead of counting against svrqp)."""
    rng = np.random.default_rng(p["seed"])
    kind, solver = p["kind"], p["solver"]
    if kind == "linear-scale":
        Z = rng.standard_normal((p["n"], p["d"]))
        y = Z @ rng.normal(size=p["d"]) + p["noise"] * rng.standard_normal(p["n"])
        X, model = Z * p["scale"], EpsilonSVR(C=p["C"], epsilon=0.1, kernel="linear", **(
            {"formulation": "primal"} if solver == "primal" else {"solver": solver}))

        def reference() -> np.ndarray:
            return _linear_primal_predictions(Z, y, p["scale"], p["C"], 0.1)
    else:
        X = rng.uniform(-1, 1, (p["n"], 2))
        y = (np.full(p["n"], p["level"]) if kind == "constant"
             else p["level"] * np.sin(3 * X[:, 0]) + p["level"] * 0.3 * X[:, 1])
        epsilon = p["tube"] * (float(np.std(y)) or abs(p["level"]) or 1.0)
        model = EpsilonSVR(C=p["C"], epsilon=epsilon, gamma=1.0, solver=solver)

        def reference() -> np.ndarray:
            K = np.exp(-np.square(X[:, None, :] - X[None, :, :]).sum(axis=2))
            return y if kind == "constant" else _tube_dual_predictions(K, y, epsilon, p["C"])
    answers: list[np.ndarray] = []
    outcome = classify(lambda: answers.append(model.fit(X, y).predict(X)) is None)
    if outcome != RIGHT:
        return outcome
    if kind == "constant":  # b = y exactly, and no support vector
        return RIGHT if model.support_.size == 0 and np.all(answers[0] == y[0]) else WRONG
    error = float(np.max(np.abs(answers[0] - reference())))
    return RIGHT if error <= PREDICTION_TOL * float(np.std(y)) else WRONG


def scale_cases(rng: np.random.Generator, n: int) -> list[Case]:
    """Targets of 1e-14 to 1e-9 with tubes down to 1e-3 of them, constant targets, a linear kernel on
    inputs ×1 to ×1e8, on the exact paths and the QP backends."""
    cases = []
    for _ in range(n):
        kind = str(rng.choice(SCALE_KINDS))
        p = {"seed": int(rng.integers(2**31)), "kind": kind, "C": float(10 ** rng.uniform(-1, 2))}
        if kind == "linear-scale":
            p.update(n=int(rng.integers(20, 120)), d=int(rng.integers(1, 5)),
                     noise=float(rng.choice([0.01, 0.1, 0.5])), scale=float(10 ** rng.uniform(0, 8)),
                     solver=str(rng.choice(["auto", "dual_ipm", "clarabel", "primal"])))
        else:
            level = (float(rng.choice([0.0, 3.0, 1e-12, -1e6])) if kind == "constant"
                     else float(10 ** rng.uniform(-14, -9)))
            p.update(n=int(rng.integers(6, 16)), level=level,
                     tube=float(rng.choice([0.0, 1e-3, 1e-2, 0.1])),
                     solver=str(rng.choice(TINY_TARGET_SOLVERS)))
        cases.append(Case(f"scale/{kind}/{p['solver']}", check_scale, p))
    return cases


#: The families, in the order the campaign runs them.
FAMILIES = [dtype_container_cases, query_name_cases, budget_cases, path_cases, huge_header_cases,
            probe_blind_cases, scale_cases]

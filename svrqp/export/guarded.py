r"""The interval and domain of a :class:`svrqp.Guarded` model in an ``svrqp.model/1`` document.

Two optional sections (present together, only for guarded models):

``interval``
    ``coverage`` :math:`1-\alpha`, ``method`` (``absolute`` | ``normalized``), the conformal
    ``quantile`` :math:`q`, the sorted calibration ``scores`` it was taken from, the ``calibration``
    folds and the ``groups`` used, and for ``normalized`` the ``difficulty``
    :math:`\sigma(x) = \exp(c_0 + c^\top z)`. Interval: :math:`f(x) \pm q\,\sigma(x)`.
``domain``
    Per-input training range ``low``/``high`` (raw units), ``mean``/``scale`` of :math:`z`, the
    ``precision`` matrix :math:`P` and the distance ``threshold`` :math:`\tau`
    (:mod:`svrqp.guard.domain`). Outside: some :math:`x_j \notin [\ell_j, h_j]` or
    :math:`\sqrt{z^\top P z} > \tau`.

``verify`` re-checks them from the file alone (:func:`check_guard`): ``q`` must be the
:math:`\lceil (n+1)(1-\alpha) \rceil`-th smallest stored score, ``P`` symmetric positive
semi-definite, ``low <= high``, and the probes' stored ``lower``/``upper``/``outside`` must be
reproduced.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from svrqp.export import evaluate
from svrqp.guard.conformal import difficulty
from svrqp.guard.domain import outside_rows, standardised


def is_guarded(model: Any) -> bool:
    """True for a fitted :class:`svrqp.Guarded` (or anything with its fitted attributes)."""
    return hasattr(model, "calibration_") and hasattr(model,
                                                      "domain_") and hasattr(model, "estimator_")


def _floats(values: ArrayLike) -> list[float]:
    return [float(v) for v in np.asarray(values, dtype=float).ravel()]


def sections(guarded: Any) -> dict[str, Any]:
    """The ``interval`` and ``domain`` sections of a fitted Guarded model."""
    calibration, domain = guarded.calibration_, guarded.domain_
    interval = {
        "coverage": float(guarded.coverage),
        "method": guarded.method,
        "quantile": float(calibration.quantile),
        "scores": _floats(calibration.scores),
        "calibration": {"folds": calibration.folds, "n_splits": int(calibration.n_splits),
                        "groups": None if calibration.groups is None else list(calibration.groups)},
        "difficulty": None if calibration.difficulty_coef is None else {
            "coef": _floats(calibration.difficulty_coef),
            "intercept": float(calibration.difficulty_intercept)},
    }
    return {"interval": interval, "domain": {
        "low": _floats(domain.low), "high": _floats(domain.high), "mean": _floats(domain.mean),
        "scale": _floats(domain.scale), "precision": [_floats(row) for row in domain.precision],
        "threshold": float(domain.threshold), "quantile": float(domain.quantile)}}


def outside(document: dict[str, Any], X: ArrayLike) -> NDArray[np.bool_]:
    """Rows of raw ``X`` outside the document's domain (NaN inputs count as outside)."""
    domain = document["domain"]
    arrays = (np.asarray(domain[key],
                         dtype=float) for key in ("low", "high", "mean", "scale", "precision"))
    return outside_rows(np.asarray(X, dtype=float), *arrays, domain["threshold"])


def half_width(document: dict[str, Any], X: ArrayLike) -> NDArray[np.float64]:
    """:math:`q\\,\\sigma(x)` per row of raw ``X``."""
    interval = document["interval"]
    X = np.asarray(X, dtype=float)
    if interval["difficulty"] is None:
        return np.full(len(X), interval["quantile"])
    domain = document["domain"]
    Z = standardised(X, np.asarray(domain["mean"]), np.asarray(domain["scale"]))
    return interval["quantile"] * difficulty(Z, np.asarray(interval["difficulty"]["coef"]),
                                             interval["difficulty"]["intercept"])


def predict_guarded(document: dict[str, Any],
                    X: ArrayLike) -> tuple[NDArray, NDArray, NDArray, NDArray]:
    """``(prediction, lower, upper, outside)`` at raw ``X`` from the document alone."""
    prediction = evaluate.predict(document, X)
    width = half_width(document, X)
    return prediction, prediction - width, prediction + width, outside(document, X)


def conformal_rank(n: int, coverage: float) -> int:
    """:math:`\\lceil (n+1)(1-\\alpha) \\rceil` written
    as :math:`n + 1 - \\lfloor (n+1)\\alpha \\rfloor`."""
    return n + 1 - math.floor((1.0 - coverage) * (n + 1))


def guard_problems(document: dict[str, Any], tolerance: float) -> list[str]:
    """What is inconsistent in the interval, domain and guarded probes (empty: nothing)."""
    interval, domain, probes = document["interval"], document["domain"], document["probes"]
    problems = []
    scores = np.asarray(interval["scores"])
    rank = conformal_rank(len(scores), interval["coverage"])
    if np.any(np.diff(scores) < 0) or np.any(scores < 0):
        problems.append("interval.scores must be non-negative and sorted ascending")
    elif not 1 <= rank <= len(scores):
        problems.append(f"interval: {len(scores)} scores are too few for coverage "
                        f"{interval['coverage']}")
    elif scores[rank - 1] != interval["quantile"]:
        problems.append(f"interval.quantile {interval['quantile']!r} is not the {rank}-th smallest "
                        f"of the {len(scores)} scores ({scores[rank - 1]!r})")
    precision = np.asarray(domain["precision"])
    if not np.array_equal(precision, precision.T):
        problems.append("domain.precision is not symmetric")
    elif np.linalg.eigvalsh(precision).min() < -1e-12 * np.abs(precision).max():
        problems.append("domain.precision is not positive semi-definite")
    if np.any(np.asarray(domain["low"]) > np.asarray(domain["high"])):
        problems.append("domain.low exceeds domain.high")
    if not problems:
        with np.errstate(all="ignore"):
            _, lower, upper, flags = predict_guarded(document, np.asarray(probes["X"], dtype=float))
            deviation = max(float(np.max(np.abs(lower - probes["lower"]))),
                            float(np.max(np.abs(upper - probes["upper"]))))
        if not deviation <= tolerance:
            problems.append(f"probe intervals deviate by {deviation:.3g} > tolerance "
                            f"{tolerance:.3g}")
        if flags.tolist() != probes["outside"]:
            problems.append("probe out-of-domain flags are not reproduced")
    return problems

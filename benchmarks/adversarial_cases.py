"""What every adversarial campaign family shares (``benchmarks/adversarial.py`` and
``benchmarks/adversarial_second.py``): the outcomes, the time budget, the prediction tolerance, the
:class:`Case` and :func:`classify`."""

from __future__ import annotations

import time
import warnings
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

from svrqp.exceptions import SvrqpError

DOCUMENTED, RIGHT, WRONG, CRASH, HANG = (
    "documented error", "right answer", "silent wrong", "crash", "hang")
OUTCOMES = (DOCUMENTED, RIGHT, WRONG, CRASH, HANG)
#: Longest a case may take (seconds) before it counts as a hang.
BUDGET_S = 10.0
#: DESIGN §3: predictions within 1e-5·std(y) of the reference.
PREDICTION_TOL = 1e-5


@dataclass(frozen=True)
class Case:
    """One adversarial case: ``case()`` runs it and returns its outcome (one of :data:`OUTCOMES`),
    :data:`HANG` when it ran past ``budget_s`` (``None``: no budget; the first campaign's cases,
    whose libsvm references at tol = 1e-8 take up to a minute on a nearly hard margin and whose
    stock backends are bounded by their own time or iteration limits)."""

    label: str
    check: Callable[[dict[str, Any]], str] = field(repr=False)
    parameters: dict[str, Any] = field(default_factory=dict)
    budget_s: float | None = BUDGET_S

    def __call__(self) -> str:
        start = time.perf_counter()
        outcome = self.check(self.parameters)
        late = self.budget_s is not None and time.perf_counter() - start > self.budget_s
        return HANG if late else outcome


def classify(run: Callable[[], bool],
             documented: tuple[type[BaseException], ...] = (SvrqpError,)) -> str:
    """Outcome of ``run`` (which fits, predicts and compares with a reference computed
    beforehand): an exception of ``documented`` (the library's own errors) is a documented error,
    any other escaping the library a crash."""
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            right = run()
    except documented:
        return DOCUMENTED
    except Exception:  # noqa: BLE001 - anything else escaping the library is a crash
        return CRASH
    return RIGHT if right else WRONG

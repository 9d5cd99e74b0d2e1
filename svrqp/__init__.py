"""svrqp — support vector regression stated as explicit convex problems.

Every model is an explicit mathematical object (a quadratic program or a linear system)
that is handed to a real solver and certificate-checked before it is returned.

The estimators are imported on first use (``svrqp.EpsilonSVR``), so ``import svrqp`` and the
``svrqp`` command stay quick; ``from svrqp import EpsilonSVR`` works as usual.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

from svrqp._version import __version__
from svrqp.exceptions import (
    BackendNotAvailableError,
    ExtrapolationWarning,
    ProblemError,
    SingularSystemError,
    SolverError,
    SvrqpError,
)

if TYPE_CHECKING:
    from svrqp.estimators import LSSVR, EpsilonSVR, LinearLS, PolynomialLS, RecursiveLS
    from svrqp.guard import Guarded

#: Public name -> module that defines it, imported when the name is first asked for.
_LAZY = {
    "EpsilonSVR": "svrqp.estimators",
    "LSSVR": "svrqp.estimators",
    "LinearLS": "svrqp.estimators",
    "PolynomialLS": "svrqp.estimators",
    "RecursiveLS": "svrqp.estimators",
    "Guarded": "svrqp.guard",
}

__all__ = [
    "BackendNotAvailableError",
    "EpsilonSVR",
    "ExtrapolationWarning",
    "Guarded",
    "LSSVR",
    "LinearLS",
    "PolynomialLS",
    "ProblemError",
    "RecursiveLS",
    "SingularSystemError",
    "SolverError",
    "SvrqpError",
    "__version__",
]


def __getattr__(name: str) -> Any:
    if name not in _LAZY:
        raise AttributeError(f"module 'svrqp' has no attribute {name!r}")
    value = getattr(importlib.import_module(_LAZY[name]), name)
    globals()[name] = value  # later look-ups skip this function
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(_LAZY))

"""svrqp — support vector regression stated as explicit convex problems.

Every model is an explicit mathematical object (a quadratic program or a linear system)
that is handed to a real solver and certificate-checked before it is returned.
"""

from __future__ import annotations

from importlib.metadata import PackageNotFoundError, version

from svrqp.exceptions import (
    BackendNotAvailableError,
    ExtrapolationWarning,
    ProblemError,
    SingularSystemError,
    SolverError,
    SvrqpError,
)

try:
    __version__ = version("svrqp")
except PackageNotFoundError:  # running from a source tree that was not installed
    __version__ = "0.0.0"

__all__ = [
    "BackendNotAvailableError",
    "ExtrapolationWarning",
    "ProblemError",
    "SingularSystemError",
    "SolverError",
    "SvrqpError",
    "__version__",
]

from svrqp.estimators import LSSVR, EpsilonSVR  # noqa: E402  (after __version__ on purpose)

__all__ += ["EpsilonSVR", "LSSVR"]

from svrqp.guard import Guarded  # noqa: E402

__all__ += ["Guarded"]

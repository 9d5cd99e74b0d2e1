"""Which QP backends the tests run on, and the certificate check each gets.

In CI every backend of the ``solvers`` extra is installed, so a missing backend fails there; on a
developer's machine it is skipped with its reason (never silently dropped).
"""

from __future__ import annotations

import os

import pytest

from svrqp.solvers import BACKENDS, available_backends

ALL_BACKENDS = tuple(BACKENDS)

#: Backends that cannot meet the default certificate check (100·tol = 1e-6 relative) on these
#: problems, the check they get instead, and why. Cross-checks against scikit-learn keep the
#: contract tolerances for every backend.
CHECK_TOLERANCE = {
    # quadprog needs a positive definite P: svrqp adds 1e-8·max|P_ii| to the diagonal
    # (svrqp.solvers.qp_backends.PD_REGULARISATION), which leaves a duality gap of ~4e-6 relative on the
    # dual forms (whose P is singular by construction). Smaller shifts make P so ill conditioned
    # that Goldfarb–Idnani's dual residual grows to 1e-3.
    "quadprog": 1e-5,
}


def require(backend: str) -> None:
    """Skip (locally) or fail (in CI) when ``backend`` is not installed."""
    if backend in available_backends():
        return
    message = f"backend {backend!r} is not installed ({BACKENDS[backend].install_hint})"
    if os.environ.get("CI"):
        pytest.fail(message + " — every backend must be installed in CI")
    pytest.skip(message)

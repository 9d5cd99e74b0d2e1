"""Shared fixtures and the per-backend tolerance table of the cross-checks.

In CI every backend of the ``solvers`` extra is installed, so a missing backend fails there; on a
developer's machine it is skipped with its reason (never silently dropped).
"""

from __future__ import annotations

import os
import shutil

import pytest

from svrqp.solve import BACKENDS, available_backends

ALL_BACKENDS = tuple(BACKENDS)

#: Backends that cannot meet the default certificate check (100·tol = 1e-6 relative) on these
#: problems, the check they get instead, and why. Cross-checks against scikit-learn keep the
#: contract tolerances for every backend.
CHECK_TOLERANCE = {
    # quadprog needs a positive definite P: svrqp adds 1e-8·max|P_ii| to the diagonal
    # (svrqp.solve.PD_REGULARISATION), which leaves a duality gap of ~4e-6 relative on the
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


@pytest.fixture(params=ALL_BACKENDS)
def backend(request) -> str:
    require(request.param)
    return request.param


@pytest.fixture(scope="module")
def gcc() -> str:
    """The system C compiler for the generated-C tests: skipped locally, a failure in CI, when absent."""
    path = shutil.which("gcc")
    if path is None:
        message = "gcc is not installed: the generated C cannot be compiled here"
        if os.environ.get("CI"):
            pytest.fail(message + " — CI must have a C compiler")
        pytest.skip(message)
    return path

"""Shared fixtures: one test per installed QP backend, and the C compiler of the export tests."""

from __future__ import annotations

import os
import shutil

import pytest

from support.backends import ALL_BACKENDS, require


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

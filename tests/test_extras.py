"""svrqp.extras: an optional package missing is one error that names the extra to install."""

from __future__ import annotations

import sys

import pytest

from svrqp import extras
from svrqp.exceptions import BackendNotAvailableError


@pytest.mark.parametrize("extra", sorted(extras.EXTRA_MODULES))
def test_a_missing_extra_is_named_with_its_install_command(extra, monkeypatch):
    monkeypatch.setitem(sys.modules, extras.EXTRA_MODULES[extra], None)  # as if not installed
    assert not extras.has_extra(extra)
    with pytest.raises(BackendNotAvailableError) as error:
        extras.require(extra, "this feature")
    message = str(error.value)
    assert message.startswith("this feature: needs the") and f"pip install 'svrqp[{extra}]'" in message
    assert "\n" not in message


def test_an_installed_extra_passes():
    extras.require("guard", "calibrated intervals")  # the dev install has every extra
    assert extras.has_extra("guard")


def test_every_extra_named_here_is_declared_in_pyproject():
    import tomllib
    from pathlib import Path

    import svrqp

    declared = tomllib.loads((Path(svrqp.__file__).parents[1] / "pyproject.toml").read_text())
    assert set(extras.EXTRA_MODULES) <= set(declared["project"]["optional-dependencies"])


def test_an_unknown_extra_is_a_key_error():
    with pytest.raises(KeyError, match="unknown extra 'gpu'"):
        extras.has_extra("gpu")

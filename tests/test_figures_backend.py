"""Importing svrqp's figure modules leaves matplotlib's backend alone (inline plots in notebooks)."""

import subprocess
import sys

import pytest


@pytest.mark.parametrize("module", ["svrqp.gap.words.figures", "svrqp.demo.figures", "svrqp.bench.report",
                                    "svrqp.fleet.report"])
def test_import_keeps_the_chosen_backend(module):
    code = ("import matplotlib; matplotlib.use('svg'); import importlib; "
            f"importlib.import_module({module!r}); print(matplotlib.get_backend())")
    result = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert result.stdout.strip() == "svg"

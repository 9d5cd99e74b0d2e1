"""A fit writes nothing to the terminal: solver banners are kept off stdout."""

from __future__ import annotations

import subprocess
import sys

import pytest

pytest.importorskip("highspy")

# min ½‖x‖² s.t. x₁ + x₂ = 5: x = (2.5, 2.5), a closed form the script checks.
SCRIPT = """
import numpy as np
from svrqp.problems import QuadraticProgram
from svrqp.solvers import solve_qp
qp = QuadraticProgram(P=np.eye(2), q=np.zeros(2), A=np.ones((1, 2)), b=np.array([5.0]))
print("before", flush=True)
for _ in range(2):
    assert np.allclose(solve_qp(qp, "highs").x, 2.5)
print("after")
"""


def test_highs_prints_no_banner_and_stdout_still_works():
    # A fresh interpreter: HiGHS prints its banner only once per process.
    done = subprocess.run([sys.executable, "-c", SCRIPT], capture_output=True, text=True, check=True)
    assert done.stdout == "before\nafter\n"
    assert "HiGHS" not in done.stderr

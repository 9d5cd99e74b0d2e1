"""Compile a generated C evaluator with a small driver and run it on points (the C export tests)."""

from __future__ import annotations

import subprocess
from pathlib import Path

import numpy as np

#: Strict C99: the generated code must compile without a warning.
CFLAGS = ["-std=c99", "-O2", "-Wall", "-Wextra", "-pedantic", "-Werror"]


def run_driver(gcc: str, driver: str, source: Path, points: np.ndarray, directory: Path) -> str:
    """Standard output of ``driver`` (C source reading rows of inputs from stdin) linked with ``source``,
    fed ``points`` one row per line at full precision."""
    (directory / "driver.c").write_text(driver)
    binary = directory / "driver"
    subprocess.run([gcc, *CFLAGS, "-o", str(binary), str(directory / "driver.c"), str(source), "-lm"],
                   check=True, capture_output=True, text=True)
    text = "\n".join(" ".join(repr(float(v)) for v in row) for row in points)
    return subprocess.run([str(binary)], input=text, check=True, capture_output=True, text=True).stdout

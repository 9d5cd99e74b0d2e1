"""Where the tests find the repository's files, and the FL_THERMAL measurements shipped in the package."""

from pathlib import Path

REPO = Path(__file__).resolve().parents[2]
BENCHMARKS = REPO / "benchmarks"
NOTEBOOKS = REPO / "notebooks"
FL_THERMAL = REPO / "svrqp" / "datasets" / "fl_thermal" / "data.csv"

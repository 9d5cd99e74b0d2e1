"""Where the tests find the repository's files and the real-data case study (``../shared``)."""

from pathlib import Path

REPO = Path(__file__).resolve().parents[2]
BENCHMARKS = REPO / "benchmarks"
NOTEBOOKS = REPO / "notebooks"
FL_THERMAL = REPO.parent / "shared" / "data" / "fl_thermal" / "data.csv"

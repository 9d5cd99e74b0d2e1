"""Benchmark scripts imported as modules for the tests (benchmarks/ is not a package)."""

import importlib.util
import sys
from types import ModuleType

from support.paths import BENCHMARKS


def load_benchmark(stem: str) -> ModuleType:
    """Import ``benchmarks/<stem>.py`` from its file and register it under ``stem``."""
    if str(BENCHMARKS) not in sys.path:  # a script imports its siblings, as when run from benchmarks/
        sys.path.insert(0, str(BENCHMARKS))
    spec = importlib.util.spec_from_file_location(stem, BENCHMARKS / f"{stem}.py")
    module = importlib.util.module_from_spec(spec)
    sys.modules[stem] = module
    spec.loader.exec_module(module)
    return module

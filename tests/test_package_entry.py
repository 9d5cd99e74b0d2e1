"""What ``import svrqp`` offers: the estimators at the top level, loaded on first use, and the version."""

from __future__ import annotations

import subprocess
import sys

import pytest

import svrqp


def _modules_after(code: str) -> set[str]:
    """Top-level package names in ``sys.modules`` after running ``code`` in a fresh interpreter."""
    script = f"{code}\nimport sys\nprint(' '.join(sorted({{name.split('.')[0] for name in sys.modules}})))"
    done = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, check=True)
    return set(done.stdout.split("\n")[-2].split())


def test_estimators_import_from_the_top_level():
    from svrqp import LSSVR, EpsilonSVR, Guarded, LinearLS, PolynomialLS, RecursiveLS
    from svrqp import estimators, guard
    from svrqp.estimators import linear as linear_models

    assert (EpsilonSVR, LSSVR) == (estimators.EpsilonSVR, estimators.LSSVR)
    assert (LinearLS, PolynomialLS, RecursiveLS) == (
        linear_models.LinearLS, linear_models.PolynomialLS, linear_models.RecursiveLS)
    assert Guarded is guard.Guarded
    assert set(svrqp.__all__) <= set(dir(svrqp))


def test_unknown_attribute_is_an_attribute_error():
    with pytest.raises(AttributeError, match="no attribute 'EpsilonSvr'"):
        svrqp.EpsilonSvr  # noqa: B018


def test_import_svrqp_loads_no_estimator_stack():
    loaded = _modules_after("import svrqp")
    assert not loaded & {"sklearn", "scipy", "pandas", "matplotlib", "cvxpy"}


def test_version_is_the_constant_pyproject_reads():
    import tomllib
    from pathlib import Path

    pyproject = tomllib.loads((Path(svrqp.__file__).parents[1] / "pyproject.toml").read_text())
    assert "version" in pyproject["project"]["dynamic"]
    assert pyproject["tool"]["setuptools"]["dynamic"]["version"] == {"attr": "svrqp._version.__version__"}
    assert svrqp.__version__.count(".") == 2 and all(part.isdigit() for part in svrqp.__version__.split("."))


def test_nothing_reads_outside_the_repository():
    """A clone on its own must pass: no code, notebook or doc page reads the folder beside the repository."""
    import re
    from pathlib import Path

    repo = Path(svrqp.__file__).parents[1]
    outside = re.compile(r"\.\./" + "shared" + r"|parents?\[?\d?\]?\s*/\s*[\"']" + "shared" + r"[\"']")
    offenders = [str(path.relative_to(repo))
                 for folder in ("svrqp", "tests", "notebooks", "benchmarks", "docs")
                 for path in (repo / folder).rglob("*")
                 if path.suffix in {".py", ".ipynb", ".md", ".yml"} and outside.search(path.read_text(encoding="utf-8"))]
    assert offenders == []


def test_python_dash_m_svrqp_is_the_command():
    done = subprocess.run([sys.executable, "-m", "svrqp", "--version"], capture_output=True, text=True, check=True)
    assert done.stdout == f"svrqp {svrqp.__version__}\n"

"""The notebooks: every ``.ipynb`` is its jupytext source, executed, with its outputs stored.

Executing them is ``pytest --nbmake notebooks`` (part of ``make test``); these checks need no
kernel. A notebook edited on one side only, a missing pair, random cell ids or stripped outputs
fail here.
"""

from __future__ import annotations

import importlib.util

import nbformat
import pytest
from support.paths import NOTEBOOKS

_spec = importlib.util.spec_from_file_location("notebook_build", NOTEBOOKS / "build.py")
build = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(build)
SOURCES = build.sources()
TEACHING = [path for path in SOURCES if path.name[:2] in {"01", "02", "03", "04", "05"}]


def test_every_notebook_has_a_source_and_every_source_a_notebook():
    assert len(SOURCES) >= 8
    ipynb = {path.stem for path in NOTEBOOKS.glob("*.ipynb")}
    assert ipynb == {path.stem for path in SOURCES}


@pytest.mark.parametrize("source", SOURCES, ids=lambda path: path.stem)
def test_notebook_matches_its_jupytext_source(source):
    assert build.drift(source) == []


def test_drift_is_detected(tmp_path):
    source = tmp_path / "01_example.py"
    source.write_text("# %% [markdown]\n# # Title\n\n# %%\nprint(1)\n", encoding="utf-8")
    assert build.drift(source) == ["01_example.ipynb is missing"]
    notebook = build.from_source(source)
    nbformat.write(notebook, source.with_suffix(".ipynb"))
    assert build.drift(source) == []
    source.write_text("# %% [markdown]\n# # Title\n\n# %%\nprint(2)\n", encoding="utf-8")
    assert build.drift(source) == ["01_example.ipynb: cell 1 differs from 01_example.py"]


@pytest.mark.parametrize("source", SOURCES, ids=lambda path: path.stem)
def test_outputs_are_stored_for_most_code_cells(source):
    notebook = nbformat.read(source.with_suffix(".ipynb"), as_version=4)
    code = [cell for cell in notebook.cells if cell.cell_type == "code"]
    with_output = [cell for cell in code if cell.outputs]
    assert len(with_output) >= 0.8 * len(code), f"{len(with_output)} of {len(code)} code cells have outputs"
    errors = [output for cell in code for output in cell.outputs if output.output_type == "error"]
    assert not errors
    assert all(cell.execution_count is not None for cell in code)


@pytest.mark.parametrize("source", TEACHING, ids=lambda path: path.stem)
def test_teaching_notebooks_state_solve_twice_and_cross_check(source):
    """01–05: the model's QP or linear system in LaTeX from the model object, at least two
    backends, and an outside referee (scikit-learn, or NumPy for the least-squares family)."""
    text = source.read_text(encoding="utf-8")
    notebook = nbformat.read(source.with_suffix(".ipynb"), as_version=4)
    latex = [output for cell in notebook.cells if cell.cell_type == "code" for output in cell.outputs
             if "text/latex" in output.get("data", {})]
    assert latex, "no LaTeX output"
    assert "to_latex()" in text
    solved_twice = ('solver in ("clarabel"' in text or "solve_linear_system" in text
                    or 'solver="lu"' in text)
    assert solved_twice
    assert "sklearn" in text or "np.linalg.lstsq" in text or "np.polynomial" in text

"""The committed notebooks: written by notebooks/make_notebooks.py and committed executed.

nbmake (pytest's ``--nbmake``, see pyproject) re-executes them in CI; here: their cells are the
generator's, and every code cell has run, in order, with outputs and figures.
"""

from __future__ import annotations

import sys
from pathlib import Path

import nbformat
import pytest

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "notebooks"))
import make_notebooks  # noqa: E402

NAMES = sorted(make_notebooks.NOTEBOOKS)


@pytest.mark.parametrize("name", NAMES)
def test_committed_cells_are_the_generators(name):
    committed = nbformat.read(ROOT / "notebooks" / f"{name}.ipynb", as_version=4)
    expected = make_notebooks.build(name)
    as_cells = [(c.cell_type, c.source, c.get("id")) for c in committed.cells]
    assert as_cells == [(c.cell_type, c.source, c.get("id")) for c in expected.cells], (
        f"notebooks/{name}.ipynb is out of date: run python notebooks/make_notebooks.py"
    )


@pytest.mark.parametrize("name", NAMES)
def test_committed_notebook_is_executed_with_outputs(name):
    notebook = nbformat.read(ROOT / "notebooks" / f"{name}.ipynb", as_version=4)
    code = [cell for cell in notebook.cells if cell.cell_type == "code"]
    assert [cell.execution_count for cell in code] == list(range(1, len(code) + 1))
    for cell in code:
        assert cell.outputs, f"{name}: a cell without output: {cell.source[:60]!r}"
        assert not [o for o in cell.outputs if o.output_type == "error"], cell.source[:60]
    figures = [o for c in code for o in c.outputs if "image/png" in o.get("data", {})]
    assert figures, f"{name} has no figure"

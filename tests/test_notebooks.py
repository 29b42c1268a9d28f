"""Every notebook in notebooks/ runs top to bottom (quick mode)."""

from pathlib import Path

import nbformat
import pytest
from nbclient import NotebookClient

NOTEBOOKS = sorted((Path(__file__).parent.parent / "notebooks").glob("*.ipynb"))


SLOW = {"gradients_and_tuning.ipynb"}  # ~50 s: in the slow set (CI runs it), for the suite's time


@pytest.mark.parametrize(
    "path",
    [pytest.param(p, marks=pytest.mark.slow) if p.name in SLOW else p for p in NOTEBOOKS],
    ids=lambda p: p.name,
)
def test_notebook_runs(path, monkeypatch):
    monkeypatch.setenv("JAXBEARING_QUICK", "1")
    monkeypatch.setenv("MPLBACKEND", "Agg")
    nb = nbformat.read(path, as_version=4)
    client = NotebookClient(nb, timeout=600, kernel_name="python3", resources={"metadata": {"path": str(path.parent)}})
    client.execute()  # raises CellExecutionError at the first cell that fails (allow_errors=False)


def test_there_are_notebooks():
    assert NOTEBOOKS

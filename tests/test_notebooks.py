"""Every notebook in notebooks/ runs top to bottom (quick mode) and makes its figures; the
outputs committed with them, which the documentation site renders as they are (mkdocs.yml:
``execute: false``), hold every figure their cells make and nothing a reader should not see:
no stderr stream (a red box on the site), no warning, no path of the machine that ran them, one
repr per result (an HTML repr carries a text copy of itself, which the site shows too)."""

import re
from pathlib import Path

import nbformat
import pytest
from nbclient import NotebookClient

NOTEBOOKS = sorted((Path(__file__).parent.parent / "notebooks").glob("*.ipynb"))


# in the slow set (CI runs it), for the suite's time (issue 75): the tuning notebook (~50 s), the
# quickstart (~28 s: the paper's case, its figures and an animation, each checked in the default
# set by tests/test_xu2014.py and tests/test_report_draw.py), the sweeps (~12 s: the sweep of
# studies/clearance_sweep.py, whose quick run tests/test_studies.py keeps in the default set)
SLOW = {"gradients_and_tuning.ipynb", "quickstart.ipynb", "sweeps.ipynb"}
# makes a figure: pyplot's, or a picture, plot or animation of jb.report (an animation shows as
# HTML)
FIGURE = re.compile(r"\bplt\.(?:subplots|figure|subplot_mosaic)\(|\bjb\.report\.(?:draw|animate|plot_\w+)\(")
PLOT = re.compile(r"\bplt\.(?!subplots|figure|subplot_mosaic|show|close|rc|style)\w+\(")  # draws on the current one
LOCAL_PATH = re.compile(r"(?:^|[\s'\"(=:])(?:/(?:home|work|tmp|root|Users|usr|opt|var|private|mnt)/|[A-Za-z]:\\)"
                        r"|site-packages|dist-packages")  # fmt: skip
WARNING = re.compile(r"\w*(?:Warning|Error|Traceback)\b")


def figures_made(source: str) -> int:
    """The figures a cell's code makes: one a ``plt.subplots``/``plt.figure`` call, or one where
    it draws with pyplot on the current figure without making one."""
    made = len(FIGURE.findall(source))
    return made if made else int(bool(PLOT.search(source)))


def figures_shown(cell) -> int:
    """The pictures a cell shows: PNGs, and animations (HTML with JavaScript)."""
    return sum(
        "image/png" in data or "<script" in data.get("text/html", "")
        for data in (output.get("data", {}) for output in cell.get("outputs", []))
    )


def code_cells(nb):
    return [cell for cell in nb.cells if cell.cell_type == "code"]


def missing_figures(nb) -> list[str]:
    """The cells that show fewer figures than their code makes, with both counts."""
    return [
        f"cell {cell.get('id')}: {figures_shown(cell)} of {figures_made(cell.source)} figures"
        for cell in code_cells(nb)
        if figures_shown(cell) < figures_made(cell.source)
    ]


@pytest.mark.parametrize(
    "path",
    [pytest.param(p, marks=pytest.mark.slow) if p.name in SLOW else p for p in NOTEBOOKS],
    ids=lambda p: p.name,
)
def test_notebook_runs(path, monkeypatch):
    """Quick mode, with MPLBACKEND=Agg as a script would have it: every figure still shows
    (each notebook asks for the inline backend; a re-execution under Agg lost the sweeps
    notebook's map)."""
    monkeypatch.setenv("JAXBEARING_QUICK", "1")
    monkeypatch.setenv("MPLBACKEND", "Agg")
    nb = nbformat.read(path, as_version=4)
    client = NotebookClient(nb, timeout=600, kernel_name="python3", resources={"metadata": {"path": str(path.parent)}})
    client.execute()  # raises CellExecutionError at the first cell that fails (allow_errors=False)
    assert not missing_figures(nb)


def test_there_are_notebooks():
    assert NOTEBOOKS
    assert all(any(figures_made(cell.source) for cell in code_cells(nbformat.read(p, as_version=4)))
               for p in NOTEBOOKS)  # fmt: skip


@pytest.mark.parametrize("path", NOTEBOOKS, ids=lambda p: p.name)
def test_committed_outputs_hold_every_figure_their_cells_make(path):
    """The outputs the site shows hold at least the figures each plotting cell makes (the
    sweeps notebook's map cell had none)."""
    nb = nbformat.read(path, as_version=4)
    assert all(cell.get("execution_count") for cell in code_cells(nb)), "a cell was not executed"
    assert not missing_figures(nb)


def _texts(output) -> list[str]:
    if output.output_type == "stream":
        return [output.text]
    if output.output_type == "error":
        return [output.ename, output.evalue, *output.traceback]
    return [v for k, v in output.get("data", {}).items() if k.startswith("text/")]


@pytest.mark.parametrize("path", NOTEBOOKS, ids=lambda p: p.name)
def test_committed_outputs_are_clean(path):
    """No stderr stream (progress bars, warnings: red boxes on the site), no warning or error
    text, no absolute local path (a warning's ``.../site-packages/tqdm/auto.py``), and no HTML
    repr of a result (xarray's carries its text repr as a fallback: the site showed the dataset
    twice); an animation's HTML is a picture."""
    nb = nbformat.read(path, as_version=4)
    for cell in code_cells(nb):
        for output in cell.get("outputs", []):
            where = f"{path.name}, cell {cell.get('id')}"
            assert output.output_type != "error", where
            assert not (output.output_type == "stream" and output.name == "stderr"), f"{where}: {output.text[:300]!r}"
            html = output.get("data", {}).get("text/html", "")
            assert not html or "<script" in html, f"{where}: an HTML repr"
            for text in _texts(output):
                if "<script" in text:  # an animation's frames: no prose
                    continue
                assert not WARNING.search(text), f"{where}: {WARNING.search(text).group()} in {text[:300]!r}"
                assert not LOCAL_PATH.search(text), f"{where}: a local path in {text[:300]!r}"


def test_a_progress_bar_in_a_notebook_without_ipywidgets_warns_nothing():
    """tqdm.auto in a kernel without ipywidgets warned "IProgress not found" (with tqdm's path)
    before falling back to the text bar; the sweep's bar is the text bar there from the start."""
    pytest.importorskip("tqdm")
    code = ("from jaxbearing._sweep.progress import Progress\n"
            "bar = Progress(2, 0, True)\nbar.update(3, 1.0)\nbar.update(3, 1.0)\nbar.close()")  # fmt: skip
    nb = nbformat.v4.new_notebook(cells=[nbformat.v4.new_code_cell(code)])
    NotebookClient(nb, timeout=120, kernel_name="python3").execute()
    text = "".join(t for output in nb.cells[0].outputs for t in _texts(output))
    assert "sweep: 100%" in text and "2/2" in text, text
    assert "IProgress" not in text and not WARNING.search(text), text

"""The documentation's code runs: each page's Python blocks, in order, in a fresh Python process
(as a reader pastes them into one session; a page may set process-wide options such as the
compilation cache's folder). The page on building a mechanism runs in the default set, the
other user-guide pages, whose blocks simulate the paper's case, in the slow set; the site's
front page shows README's example, which runs once. A picture a page shows and its code writes
(docs/images/NAME, written as NAME) is the one the code draws, and the code's lines fit the
site's page width."""

import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

ROOT = Path(__file__).resolve().parents[1]
QUICK_PAGES = ["docs/mechanisms.md"]
WIDTH = 88  # characters of a code line the site shows without scrolling
# pixels that differ by more than a quarter of full scale in some channel, at most this
# fraction of a picture: another font rasteriser moves a few edge pixels of the labels (the
# labels are 0.13 % of the four-bar's picture), while the machine moved by 2 mm changes 5.8 %
PICTURE_TOLERANCE = 0.02
SLOW_PAGES = [  # each compiles the paper's case one or more times
    "README.md", "docs/elements.md", "docs/simulate.md", "docs/metrics.md", "docs/sweeps.md",
    "docs/gradients.md", "docs/life.md", "docs/package.md", "docs/platforms.md", "docs/xu2014.md",
    "docs/plain_bearings.md",
]


def blocks(page: str) -> list[str]:
    return re.findall(r"```python\n(.*?)```", (ROOT / page).read_text(), re.S)


def pictures(page: str) -> list[str]:
    """The files of docs/images that ``page`` shows."""
    return re.findall(r"\]\((?:docs/)?images/([^)\s]+)\)", (ROOT / page).read_text())


def changed_pixels(drawn: Path, shown: Path) -> float:
    """The largest fraction of pixels, over the frames of two pictures of the same size and
    frame count, that differ by more than a quarter of full scale."""
    with Image.open(drawn) as a, Image.open(shown) as b:
        assert (a.size, getattr(a, "n_frames", 1)) == (b.size, getattr(b, "n_frames", 1)), shown
        worst = 0.0
        for frame in range(getattr(a, "n_frames", 1)):
            a.seek(frame)
            b.seek(frame)
            x, y = (np.asarray(im.convert("RGB"), dtype=float) / 255 for im in (a, b))
            worst = max(worst, float(np.mean(np.max(np.abs(x - y), axis=-1) > 0.25)))
        return worst


@pytest.mark.parametrize(
    "page", QUICK_PAGES + [pytest.param(p, marks=pytest.mark.slow) for p in SLOW_PAGES]
)
def test_the_page_s_code_runs(page, tmp_path):
    code = blocks(page)
    assert code, f"{page} has no Python block"
    script = tmp_path / "page.py"
    script.write_text("\n".join(code))
    done = subprocess.run([sys.executable, str(script)], cwd=tmp_path, capture_output=True, text=True, timeout=1200)
    assert done.returncode == 0, f"{page}:\n{done.stderr[-4000:]}"
    drawn = [name for name in pictures(page) if (tmp_path / name).exists()]
    if page == "docs/mechanisms.md":  # every picture of this page is drawn by its code
        assert drawn == pictures(page) and len(drawn) == 3
    for name in drawn:
        changed = changed_pixels(tmp_path / name, ROOT / "docs" / "images" / name)
        assert changed <= PICTURE_TOLERANCE, (
            f"{page} shows docs/images/{name}, and its code draws another picture ({changed:.1%} "
            "of the pixels differ): run the page's code in docs/images and commit its pictures"
        )


def test_building_a_mechanism_takes_at_most_40_lines():
    assert len(blocks("docs/mechanisms.md")[0].strip().splitlines()) <= 40


def test_the_front_page_shows_readme_s_example():
    """docs/index.md's code is README's first block, run as README's (the slow set)."""
    assert blocks("docs/index.md") == blocks("README.md")[:1]


def test_code_lines_fit_the_page():
    """Every line of every code block on the site's pages and in README fits WIDTH characters."""
    pages = sorted(ROOT.glob("docs/*.md")) + [ROOT / "README.md"]
    long = [
        f"{page.relative_to(ROOT)}: {line}"
        for page in pages
        for block in re.findall(r"```[^\n]*\n(.*?)```", page.read_text(), re.S)
        for line in block.splitlines()
        if len(line) > WIDTH
    ]
    assert not long, "\n".join(long)

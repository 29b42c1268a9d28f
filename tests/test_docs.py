"""The documentation's code runs: each page's Python blocks, in order, in a fresh Python process
(as a reader pastes them into one session; a page may set process-wide options such as the
compilation cache's folder). The page on building a mechanism runs in the default set, the
other user-guide pages, whose blocks simulate the paper's case, in the slow set; the site's
front page shows README's example, which runs once."""

import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
QUICK_PAGES = ["docs/mechanisms.md"]
SLOW_PAGES = [  # each compiles the paper's case one or more times
    "README.md", "docs/simulate.md", "docs/metrics.md", "docs/sweeps.md",
    "docs/gradients.md", "docs/life.md", "docs/package.md", "docs/platforms.md", "docs/xu2014.md",
]


def blocks(page: str) -> list[str]:
    return re.findall(r"```python\n(.*?)```", (ROOT / page).read_text(), re.S)


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


def test_building_a_mechanism_takes_at_most_40_lines():
    assert len(blocks("docs/mechanisms.md")[0].strip().splitlines()) <= 40


def test_the_front_page_shows_readme_s_example():
    """docs/index.md's code is README's first block, run as README's (the slow set)."""
    assert blocks("docs/index.md") == blocks("README.md")[:1]

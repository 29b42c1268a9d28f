"""The documentation's code runs: each page listed executes its Python blocks in order, in one
namespace, as a reader would paste them."""

import re
from pathlib import Path

import pytest

DOCS = Path(__file__).resolve().parents[1] / "docs"
PAGES = ["mechanisms.md"]  # pages whose every block runs in seconds


def blocks(page: str) -> list[str]:
    return re.findall(r"```python\n(.*?)```", (DOCS / page).read_text(), re.S)


@pytest.mark.parametrize("page", PAGES)
def test_the_page_s_code_runs(page):
    code = blocks(page)
    assert code, f"{page} has no Python block"
    namespace = {}
    for block in code:
        exec(compile(block, f"docs/{page}", "exec"), namespace)


def test_building_a_mechanism_takes_at_most_40_lines():
    assert len(blocks("mechanisms.md")[0].strip().splitlines()) <= 40

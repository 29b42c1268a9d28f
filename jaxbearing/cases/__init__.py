"""Ready-made mechanisms: the paper's impact slider–crank (`xu2014`, with its Table 5 and figure
window) and a rotor hung in a bearing (`rotor`)."""

from ._rotor import rotor
from ._xu2014 import (
    FIGURE_WINDOW,
    GROOVE_INNER,
    GROOVE_OUTER,
    SLIDER,
    TABLE5,
    TABLE5_TIMES,
    TARGET,
    WINDOW_START,
    skf98205,
    xu2014,
)

__all__ = [
    "FIGURE_WINDOW",
    "GROOVE_INNER",
    "GROOVE_OUTER",
    "SLIDER",
    "TABLE5",
    "TABLE5_TIMES",
    "TARGET",
    "WINDOW_START",
    "rotor",
    "skf98205",
    "xu2014",
]

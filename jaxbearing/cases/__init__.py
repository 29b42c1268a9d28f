"""Ready-made mechanisms: the paper's impact slider–crank (`xu2014`, with its Table 5 and figure
window), a rotor hung in a bearing (`rotor`) and a crank–rocker four-bar with a bearing at its
coupler–rocker joint (`four_bar`)."""

from ._four_bar import four_bar
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
    "four_bar",
    "WINDOW_START",
    "rotor",
    "skf98205",
    "xu2014",
]

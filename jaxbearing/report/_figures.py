"""The paper's Figs. 12–15 as PNGs, with several cases overlaid (matplotlib's object API with the
Agg canvas: no pyplot, no global backend switch).

Each figure is a list of panels, each panel a list of curves; one loop draws them all.
"""

from __future__ import annotations

import math
import string
from collections.abc import Mapping
from pathlib import Path
from typing import NamedTuple

import numpy as np

from .. import _files
from ..cases import FIGURE_WINDOW
from ._series import as_series, ball_keys

BODIES = (("slider", "C0"), ("target", "C3"))  # Fig. 12's bodies and their colours
ENVELOPE_BINS = 2000  # a curve above twice this many samples is drawn as its min-max envelope
# [in] `_place`: the figure's edges, the gaps between panels, and the room a panel title adds
# above each row
MARGINS = {"left": 0.95, "right": 0.2, "bottom": 0.55, "top": 0.5, "gap_x": 0.95, "gap_y": 0.15, "title": 0.25}
_STYLE = {  # per case (with impact or not): line style; colours are per quantity
    True: {"linestyle": "-", "linewidth": 0.8, "alpha": 0.9},
    False: {"linestyle": "--", "linewidth": 1.3, "alpha": 1.0},
}


class _Curve(NamedTuple):
    key: str  # series name
    scale: float = 1.0  # factor from SI to the axis unit
    colour: str | None = None  # None: red with impact, black without
    name: str | None = None  # legend prefix before the case label


class _Panel(NamedTuple):
    ylabel: str
    curves: tuple[_Curve, ...]
    title: str | None = None


class _Figure(NamedTuple):
    file: str
    title: str
    size: tuple[float, float]  # [in]
    columns: int
    panels: tuple[_Panel, ...]


def _figures(balls: list[str]) -> tuple[_Figure, ...]:
    """Figs. 12–15; Fig. 15 has one panel per ball in two columns."""
    rows = math.ceil(len(balls) / 2)
    return (
        _Figure(
            "fig12_slider_target.png",
            "Fig. 12: slider and target (a) displacement, (b) velocity, (c) acceleration",
            (9, 9),
            1,
            tuple(
                _Panel(ylabel, tuple(_Curve(f"{body}_{q}", scale, colour, body) for body, colour in BODIES))
                for q, scale, ylabel in (
                    ("x", 1e3, "displacement x [mm]"),
                    ("v", 1.0, "velocity [m/s]"),
                    ("a", 1.0, "acceleration [m/s²]"),
                )
            ),
        ),
        _Figure(
            "fig13_impact_force.png",
            "Fig. 13: slider–target contact force",
            (9, 4),
            1,
            (_Panel("impact force [N]", (_Curve("contact_force"),)),),
        ),
        _Figure(
            "fig14_bearing_force.png",
            "Fig. 14: bearing reaction on the crank (a) F_x, (b) F_y, (c) |F|",
            (9, 9),
            1,
            tuple(
                _Panel(ylabel, (_Curve(key),))
                for key, ylabel in (("bearing_fx", "F_x [N]"), ("bearing_fy", "F_y [N]"), ("bearing_f", "|F| [N]"))
            ),
        ),
        _Figure(
            "fig15_ball_loads.png",
            "Fig. 15: ball loads",
            (11, 2.75 * max(rows, 1)),
            2,
            tuple(
                _Panel("load [N]", (_Curve(key),), f"({string.ascii_lowercase[i % 26]}) ball {key[4:]}")
                for i, key in enumerate(balls)
            ),
        ),
    )


def _is_impact(label: str) -> bool:
    return "without" not in label.lower()


FIGURE_FILES = tuple(figure.file for figure in _figures([]))  # the files `plot_figures` writes


def plot_figures(out_dir, cases: Mapping[str, Mapping | object], window=FIGURE_WINDOW) -> list[Path]:
    """Draw the paper's Figs. 12–15 with the given cases overlaid and write them as PNGs.

    Args:
        out_dir: folder for ``fig12_slider_target.png``, ``fig13_impact_force.png``,
            ``fig14_bearing_force.png``, ``fig15_ball_loads.png``.
        cases: label -> `Solution` or `series` dict, e.g. ``{"with impact": ..., "without
            impact": ...}``; a label containing "without" is drawn dashed (and last, on top).
        window: time window [s] (default `cases.FIGURE_WINDOW`, the paper's).

    Returns the paths written.
    """
    cases = {label: as_series(d) for label, d in cases.items()}
    ordered = sorted(cases.items(), key=lambda kv: not _is_impact(kv[0]))
    balls = ball_keys(next(iter(cases.values()))) if cases else []
    t_end = max((float(np.nanmax(d["t"])) for d in cases.values()), default=window[1])
    xlim = (window[0], min(window[1], t_end)) if t_end > window[0] else window
    return [_draw(Path(out_dir), figure, ordered, window, xlim) for figure in _figures(balls)]


def envelope(t, y, bins: int):
    """(t, y) thinned to the samples that hold the minimum and the maximum of each of ``bins``
    runs of consecutive samples, in time order: drawn, the same picture as every sample at any
    width up to ``bins`` pixels (each extreme, e.g. a 1 us impact peak, is kept), with about
    2 ``bins`` points instead of millions. Fewer than 2 ``bins`` samples are returned as they are."""
    t, y = np.asarray(t), np.asarray(y, dtype=float)
    if t.size <= 2 * bins:
        return t, y
    k = -(-t.size // bins)  # samples a run; the last run is padded
    padded = np.concatenate([y, np.full(k * bins - y.size, np.nan)]).reshape(bins, k)
    finite = np.isfinite(padded)
    start = k * np.arange(bins)
    lows = start + np.argmin(np.where(finite, padded, np.inf), axis=1)
    highs = start + np.argmax(np.where(finite, padded, -np.inf), axis=1)
    keep = np.unique(np.minimum(np.concatenate([lows, highs]), t.size - 1))
    return t[keep], y[keep]


def _place(fig, figure: _Figure, rows: int) -> None:
    """Fixed margins [in] around and between the panels (`MARGINS`): room for the tick labels
    (up to 7 characters), the axis labels, the panel titles and the figure title. A layout
    engine would measure every text before drawing, which costs about as much as the drawing."""
    width, height = figure.size
    left, right, bottom, top, gap_x, gap_y = (
        MARGINS[k] for k in ("left", "right", "bottom", "top", "gap_x", "gap_y")
    )
    if any(panel.title for panel in figure.panels):
        top, gap_y = top + MARGINS["title"], gap_y + MARGINS["title"]
    panel_w = (width - left - right - (figure.columns - 1) * gap_x) / figure.columns
    panel_h = (height - bottom - top - (rows - 1) * gap_y) / rows
    fig.subplots_adjust(
        left=left / width,
        right=1.0 - right / width,
        bottom=bottom / height,
        top=1.0 - top / height,
        wspace=gap_x / panel_w,
        hspace=gap_y / panel_h,
    )


def _draw(out_dir: Path, figure: _Figure, ordered, window, xlim) -> Path:
    from matplotlib.figure import Figure

    fig = Figure(figsize=figure.size)
    rows = max(1, math.ceil(len(figure.panels) / figure.columns))
    axes = fig.subplots(rows, figure.columns, sharex=True, squeeze=False).ravel()
    _place(fig, figure, rows)
    for ax, panel in zip(axes, figure.panels):
        for label, d in ordered:
            inside = (d["t"] >= window[0]) & (d["t"] <= window[1])
            impact = _is_impact(label)
            for curve in panel.curves:
                if curve.key not in d:  # e.g. no bearing
                    continue
                ax.plot(
                    *envelope(d["t"][inside], d[curve.key][inside] * curve.scale, ENVELOPE_BINS),
                    color=curve.colour or ("C3" if impact else "k"),
                    label=label if curve.name is None else f"{curve.name}, {label}",
                    **_STYLE[impact],
                )
        if panel.title:
            ax.set_title(panel.title, fontsize=10)
        ax.set_ylabel(panel.ylabel)
    for ax in axes:
        ax.grid(True, linewidth=0.3, alpha=0.5)
        ax.set_xlim(*xlim)
    for ax in axes[-figure.columns :]:
        ax.set_xlabel("time t [s]")
    if figure.panels and ordered:
        axes[0].legend(fontsize=8, ncol=len(figure.panels[0].curves), loc="best")
    fig.suptitle(figure.title)
    path = out_dir / figure.file
    with _files.atomic_path(path) as tmp:
        fig.savefig(tmp, format="png", dpi=120)
    return path

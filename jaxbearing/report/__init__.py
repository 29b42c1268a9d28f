"""Pictures of any machine and its motion, plots of any element's samples, and reports on
simulations of the paper's impact slider–crank (Xu 2014, Sect. 3; docs/model.md, 'The paper's
case'). NumPy and matplotlib's object API throughout (no pyplot): call them on concrete models
and results, not under ``jit``.

Seven rooms, one job each:

- `_draw`: a picture of any machine at its initial state or any coordinates (`draw`): bodies
  as links, joints, bearings with their rolling elements at their cage angles, contacts,
  springs, gravity; each kind of force element by its own drawer.
- `_animate`: the motion in a `Solution` as a matplotlib animation (`animate`), with the
  bearings' element loads as bars and a panel of any sampled quantity; GIF or video files.
- `_plots`: one element's samples from any machine: a bearing's element loads
  (`plot_ball_loads`, the paper's Fig. 15) and force (`plot_bearing_force`), a contact's force
  (`plot_contact_force`), a bearing's or a plain bearing's orbit (`plot_orbit`, `orbit`).

- `_series`: named time series of a `Solution` (`series`), peaks over a time window (`peak`),
  contact onsets, the contacts from the solve's records (`contacts`) and contact intervals
  read off samples (`contact_intervals`). They accept a `Solution` or any object with the same
  fields (or, where noted, the dict that `series` returns), so they can be tested on hand-made
  inputs.
- `_paper`: the paper's Table 5 read off a simulation (`table5`, `table5_rms`,
  `table5_mismatches`, `table5_summary`), a JSON-ready summary (`summarize`, `life_summary`,
  and `figure_peaks`, the peaks the figures show) and their text (`format_summary`, which says
  where each peak lies against the figures, `format_table5`). The paper's numbers (Table 5, the bodies, the
  figure window) live in `jaxbearing.cases` (`cases.TABLE5`, `cases.FIGURE_WINDOW`).
- `_figures`: the paper's Figs. 12–15 as PNGs (`plot_figures`).
- `_writers`: CSV time series and ``summary.json``; every file (figures too) is written
  atomically with `jaxbearing._files`, so an interrupted run leaves the previous file or the new
  one, never a truncated one.

Units are SI throughout (s, m, m/s, m/s^2, N) except on figure axes, which show displacements in
mm. Series names (and CSV columns, which carry the unit as a suffix):

    t [s]; slider_x, target_x [m] (x of the centroid, along the slide);
    slider_v, target_v [m/s]; slider_a, target_a [m/s^2];
    contact_force [N] (normal force of the slider–target contact, 0 without impact);
    bearing_fx, bearing_fy, bearing_f [N] (resultant of the ball loads on the outer race, the
    crank, and its magnitude |F|); ball1 ... ballN [N] (ball 1 at +x at t = 0, numbered
    counter-clockwise); penetration [m] (of the slider–target circles; negative when apart).
"""

from ._animate import animate
from ._draw import draw
from ._figures import plot_figures
from ._paper import (
    LOADED_THRESHOLD,
    PEAK_FROM,
    figure_peaks,
    format_summary,
    format_table5,
    life_summary,
    summarize,
    table5,
    table5_mismatches,
    table5_rms,
    table5_summary,
)
from ._plots import orbit, plot_ball_loads, plot_bearing_force, plot_contact_force, plot_orbit
from ._series import (
    UNITS,
    Contact,
    Peak,
    ball_keys,
    contact_intervals,
    contacts,
    first_contact,
    onsets,
    peak,
    series,
)
from ._writers import csv_columns, write_csv, write_json

__all__ = [
    "LOADED_THRESHOLD",
    "PEAK_FROM",
    "UNITS",
    "Contact",
    "Peak",
    "animate",
    "ball_keys",
    "contact_intervals",
    "contacts",
    "csv_columns",
    "draw",
    "figure_peaks",
    "first_contact",
    "format_summary",
    "format_table5",
    "life_summary",
    "onsets",
    "orbit",
    "peak",
    "plot_ball_loads",
    "plot_bearing_force",
    "plot_contact_force",
    "plot_figures",
    "plot_orbit",
    "series",
    "summarize",
    "table5",
    "table5_mismatches",
    "table5_rms",
    "table5_summary",
    "write_csv",
    "write_json",
]

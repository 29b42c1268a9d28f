"""Plots of one element's samples from any machine's `Solution`, one function each, returning
the matplotlib Figure (object API, no pyplot; a notebook shows it as a cell's value):

- `plot_ball_loads`: a bearing's rolling-element loads, one panel per element in two columns
  (the paper's Fig. 15);
- `plot_bearing_force`: a bearing's resultant on its outer-race body, F_x, F_y and |F| (Fig. 14);
- `plot_contact_force`: a contact's normal force (Fig. 13), with each contact's peak from the
  solve's records;
- `plot_orbit`: a bearing's orbit, the path of the inner race's centre about the outer race's
  (the eccentricity e, Eq. 4), within its clearance circle; or a plain bearing's, the
  journal's centre in its hole (``element=``).

``sol`` is one `Solution`, or a mapping label -> `Solution` to overlay several runs of the same
machine (each curve labelled). Bearings and contacts are chosen by their index into
``model.bearings`` and ``model.contacts`` (None: the only one). The time window defaults to the
model's (from ``sol.window_start`` to the end; the whole run without one). Curves of more than
2 `ENVELOPE_BINS` samples are drawn as their min–max envelope (every extreme kept).
"""

from __future__ import annotations

import math
import string
from collections.abc import Mapping

import numpy as np

from ..metrics import bearing_index, contact_index
from ._draw import new_figure, place
from ._figures import ENVELOPE_BINS, envelope
from ._series import contacts

PANEL = (4.6, 1.9)  # [in] a panel's width and height


def _cases(sol) -> list[tuple[str | None, object]]:
    """(label, Solution) of each run: one unlabelled run, or the mapping's items."""
    cases = list(sol.items()) if isinstance(sol, Mapping) else [(None, sol)]
    if not cases:
        raise ValueError("No solution to plot: give a Solution or a mapping label -> Solution.")
    for label, s in cases:
        if np.ndim(s.ts) != 1:
            name = "the solution" if label is None else f"solution {label!r}"
            raise ValueError(
                f"{name} has output times of shape {np.shape(s.ts)}: plot one member of a batch "
                "at a time."
            )
    return cases


def _inside(s, window) -> np.ndarray:
    """Which output times of ``s`` lie in ``window`` (t_start, t_end) [s]; None: from the
    model's ``window_start`` (the first time without one) to the last."""
    ts = np.asarray(s.ts, dtype=float)
    if window is None:
        start = -math.inf if s.window_start is None else float(s.window_start)
        return ts >= start
    start, end = (float(x) for x in window)
    return (ts >= start) & (ts <= end)


def _figure(rows: int, columns: int, title: str):
    fig = new_figure((PANEL[0] * columns, 0.8 + PANEL[1] * rows))
    axes = fig.subplots(rows, columns, sharex=True, squeeze=False)
    fig.suptitle(title, fontsize=10)
    return fig, axes


def _curve(ax, label, i: int, t, y) -> None:
    style = {"lw": 0.9, "ls": ("-", "--", ":", "-.")[i % 4], "color": f"C{i}"}
    ax.plot(*envelope(t, y, ENVELOPE_BINS), label=label, **style)


def _dress(fig, axes, cases, xlabel="time t [s]") -> None:
    """Grids, the bottom row's time axis and a legend where runs are labelled."""
    for ax in axes.ravel():
        ax.grid(True, linewidth=0.3, alpha=0.5)
    for ax in axes[-1]:
        ax.set_xlabel(xlabel)
    if len(cases) > 1 or cases[0][0] is not None:
        axes.ravel()[0].legend(fontsize=7)


def plot_ball_loads(sol, bearing=None, window=None):
    """A bearing's rolling-element loads [N] against time, one panel per element in two columns,
    element 1 first (at +x at t = 0, numbered counter-clockwise): the paper's Fig. 15 for any
    machine (module docstring for ``sol``, ``bearing`` and ``window``)."""
    cases = _cases(sol)
    index = bearing_index(cases[0][1], bearing)
    n = np.shape(cases[0][1].bearings[index].ball_loads)[-1]
    fig, axes = _figure(math.ceil(n / 2), 2, f"bearing {index}: rolling-element loads")
    for i, (label, s) in enumerate(cases):
        inside = _inside(s, window)
        loads = np.asarray(s.bearings[bearing_index(s, index)].ball_loads, dtype=float)[inside]
        for r, ax in enumerate(axes.ravel()[:n]):
            _curve(ax, label, i, np.asarray(s.ts)[inside], loads[:, r])
    for r, ax in enumerate(axes.ravel()):
        if r >= n:
            ax.set_visible(False)
            continue
        ax.set_title(f"({string.ascii_lowercase[r % 26]}) ball {r + 1}", fontsize=9)
        ax.set_ylabel("load [N]")
    _dress(fig, axes, cases)
    if n % 2:  # the last panel of the left column carries the time axis
        axes[-2, 1].xaxis.set_tick_params(labelbottom=True)
        axes[-2, 1].set_xlabel("time t [s]")
    return fig


def plot_bearing_force(sol, bearing=None, window=None):
    """A bearing's resultant on its outer-race body [N] against time: F_x, F_y and |F|
    (Eq. 28; the paper's Fig. 14 for any machine)."""
    cases = _cases(sol)
    index = bearing_index(cases[0][1], bearing)
    fig, axes = _figure(3, 1, f"bearing {index}: force on the outer-race body")
    for i, (label, s) in enumerate(cases):
        inside = _inside(s, window)
        force = np.asarray(s.bearings[bearing_index(s, index)].force, dtype=float)[inside]
        t = np.asarray(s.ts)[inside]
        for ax, y in zip(
            axes[:, 0], (force[:, 0], force[:, 1], np.hypot(force[:, 0], force[:, 1]))
        ):
            _curve(ax, label, i, t, y)
    for ax, name in zip(axes[:, 0], ("F_x [N]", "F_y [N]", "|F| [N]")):
        ax.set_ylabel(name)
    _dress(fig, axes, cases)
    return fig


def plot_contact_force(sol, contact=None, window=None):
    """A contact's normal force [N] against time (Eq. 23; the paper's Fig. 13 for any machine),
    with a marker at each contact's peak as the solve recorded it (`contacts`: located on the
    solver's steps, so also where the output times miss it)."""
    cases = _cases(sol)
    index = contact_index(cases[0][1], contact)
    if index is None:
        raise ValueError("This solution has no impact contact.")
    fig, axes = _figure(1, 1, f"contact {index}: normal force")
    ax = axes[0, 0]
    for i, (label, s) in enumerate(cases):
        inside = _inside(s, window)
        own = contact_index(s, index)
        force = np.asarray(s.contact_forces, dtype=float)[inside, own]
        t = np.asarray(s.ts)[inside]
        _curve(ax, label, i, t, force)
        peaks = [c for c in contacts(s, own) if t.size and t[0] <= c.peak_time <= t[-1]]
        ax.plot(
            [c.peak_time for c in peaks],
            [c.peak_force for c in peaks],
            "v",
            ms=4,
            color=f"C{i}",
            gid=f"peaks {i}",
            label=None if label is None else f"{label}: peaks",
        )
    ax.set_ylabel("normal force [N]")
    _dress(fig, axes, cases)
    return fig


def _with_play(sol, model, bearing, element):
    """(the element, its title) of a bearing ``bearing`` (index into ``model.bearings``) or,
    where ``element`` is given (an index into ``model.forces`` or a name), of that element,
    which must have play and a centre to orbit (`AbstractForceElement.centred`: a bearing
    joint, a `ClearanceJoint`)."""
    if element is None:
        index = bearing_index(sol, bearing)
        return model.bearings[index], f"bearing {index}: orbit of the inner race"
    if bearing is not None:
        raise ValueError("give bearing= or element=, not both.")
    k = model.element_index(element)
    chosen = model.forces[k]
    if chosen.centred() is None:
        raise ValueError(
            f"{model.force_label(k)} has no orbit: element= must name a bearing joint or a "
            "ClearanceJoint."
        )
    return chosen, f"{model.force_label(k)}: orbit"


def orbit(sol, model, bearing=None, *, element=None) -> np.ndarray:
    """(T, 2) [m]: a bearing's eccentricity e = r_j^P - r_i^P at each output time, the inner
    race's centre about the outer race's (Eq. 4); or, where ``element`` names one (an index
    into ``model.forces`` or a name), a plain bearing's (`ClearanceJoint`), the journal's centre
    about the hole's."""
    (body_a, point_a), (body_b, point_b) = _with_play(sol, model, bearing, element)[0].centred()
    q = np.asarray(sol.q, dtype=float)
    return place(q, body_b, np.asarray(point_b)) - place(q, body_a, np.asarray(point_a))


def plot_orbit(sol, model, bearing=None, window=None, *, element=None):
    """A bearing's orbit: the path of the inner race's centre about the outer race's [µm]
    (`orbit`), in the global frame, with the clearance circle of radius P_d/2 (an element
    touches where e reaches it along the element's direction, Eq. 12) and each run's start
    marked; equal axes. ``element`` (an index into ``model.forces`` or a name) chooses a plain
    bearing (`ClearanceJoint`) instead: the journal's centre about the hole's, within the circle
    of radius c where it touches the hole."""
    from matplotlib.patches import Circle

    cases = _cases(sol)
    chosen, title = _with_play(cases[0][1], model, bearing, element)
    fig, axes = _figure(1, 1, title)
    fig.set_size_inches(5.2, 5.2)
    ax = axes[0, 0]
    radius = 0.5e6 * float(chosen.play())  # P_d/2 of a bearing, c of a journal
    if radius > 0.0:
        label = "P_d/2" if element is None else "c"
        ax.add_patch(Circle((0, 0), radius, fill=False, ls="--", ec="0.4", lw=0.8, label=label))
    for i, (label, s) in enumerate(cases):
        e = 1e6 * orbit(s, model, bearing, element=element)[_inside(s, window)]
        ax.plot(e[:, 0], e[:, 1], lw=0.8, color=f"C{i}", label=label, gid=f"orbit {i}")
        ax.plot(e[:1, 0], e[:1, 1], "o", ms=4, color=f"C{i}")
    ax.set_aspect("equal", adjustable="datalim")
    ax.set_xlabel("e_x [µm]")
    ax.set_ylabel("e_y [µm]")
    ax.grid(True, linewidth=0.3, alpha=0.5)
    if ax.get_legend_handles_labels()[1]:
        ax.legend(fontsize=7)
    return fig

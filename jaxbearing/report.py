"""Reports on simulations of the paper's impact slider–crank (Xu 2014, Sect. 3; docs/model.md,
'The paper's case').

Two layers, both NumPy (call them on concrete results, not under ``jit``):

- Pure helpers: named time series of a `Solution` (`series`), peaks over a time window
  (`peak`), contact onsets and contact intervals, the paper's Table 5 read off a simulation
  (`table5`, `table5_rms`, `table5_mismatches`) and a JSON-ready summary (`summarize`). They
  accept a `Solution` or any object with the same fields (or, where noted, the dict that
  `series` returns), so they can be tested on hand-made inputs.
- Writers: CSV time series, ``summary.json`` and the PNG figures of the paper's Figs. 12–15.
  Each file is written to a temporary file in the target folder and moved into place with
  `os.replace`, so an interrupted run leaves either the previous file or the new one, never a
  truncated one.

Units are SI throughout (s, m, m/s, m/s^2, N) except on figure axes, which show displacements in
mm. Series names (and CSV columns, which carry the unit as a suffix):

    t [s]; slider_x, target_x [m] (x of the centroid, along the slide);
    slider_v, target_v [m/s]; slider_a, target_a [m/s^2];
    contact_force [N] (normal force of the slider–target contact, 0 without impact);
    bearing_fx, bearing_fy, bearing_f [N] (resultant of the ball loads on the outer race, the
    crank, and its magnitude |F|); ball1 ... ballN [N] (ball 1 at +x at t = 0, numbered
    counter-clockwise); penetration [m] (of the slider–target circles; negative when apart).
"""

from __future__ import annotations

import contextlib
import json
import math
import os
import tempfile
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import NamedTuple

import numpy as np

from .cases.xu2014 import TABLE5, TABLE5_TIMES

SLIDER = 2  # body index of the slider in `cases.xu2014` (crank, rod, slider, target)
TARGET = 3  # body index of the target
# [s] peaks are taken after the bearing's start-up transient (docs/model.md, 'Start-up transient
# and metric window')
PEAK_FROM = 0.04
FIGURE_WINDOW = (0.04, 0.14)  # [s] one crank revolution, the window of the paper's figures
LOADED_THRESHOLD = 0.05  # [N] a ball is "loaded" at or above this: the paper prints 0.1 N steps

UNITS = {
    "t": "s",
    "slider_x": "m",
    "slider_v": "m/s",
    "slider_a": "m/s2",
    "target_x": "m",
    "target_v": "m/s",
    "target_a": "m/s2",
    "contact_force": "N",
    "bearing_fx": "N",
    "bearing_fy": "N",
    "bearing_f": "N",
    "penetration": "m",
}


def _unit(key: str) -> str:
    return "N" if key.startswith("ball") else UNITS[key]


# ---------------------------------------------------------------------------------------------
# Pure helpers
# ---------------------------------------------------------------------------------------------


def series(sol, slider: int = SLIDER, target: int = TARGET) -> dict[str, np.ndarray]:
    """Named time series of a simulation of the paper's case, as NumPy arrays, SI units.

    Args:
        sol: a `Solution` of `cases.xu2014` (or an object with its fields ``ts, q, qd, qdd,
            contact_force, bearing_force, ball_loads, penetration``; ``bearing_force`` and
            ``ball_loads`` may be None, and their series are then left out).
        slider, target: body indices of the slider and the target.

    Returns:
        A dict in the order of the module docstring: ``t``, ``slider_x/v/a``, ``target_x/v/a``,
        ``contact_force``, ``bearing_fx/fy/f``, ``ball1..ballN``, ``penetration``; each (T,).
    """
    q, qd, qdd = (np.asarray(a, dtype=float) for a in (sol.q, sol.qd, sol.qdd))
    out = {"t": np.asarray(sol.ts, dtype=float)}
    for name, body in (("slider", slider), ("target", target)):
        out[f"{name}_x"] = q[:, 3 * body]
        out[f"{name}_v"] = qd[:, 3 * body]
        out[f"{name}_a"] = qdd[:, 3 * body]
    out["contact_force"] = np.asarray(sol.contact_force, dtype=float)
    if sol.bearing_force is not None:
        force = np.asarray(sol.bearing_force, dtype=float)
        out["bearing_fx"] = force[:, 0]
        out["bearing_fy"] = force[:, 1]
        out["bearing_f"] = np.hypot(force[:, 0], force[:, 1])
    if sol.ball_loads is not None:
        loads = np.asarray(sol.ball_loads, dtype=float)
        for r in range(loads.shape[1]):
            out[f"ball{r + 1}"] = loads[:, r]
    out["penetration"] = np.asarray(sol.penetration, dtype=float)
    return out


def _as_series(data) -> Mapping[str, np.ndarray]:
    return data if isinstance(data, Mapping) else series(data)


def ball_keys(data) -> list[str]:
    """Names ``ball1 .. ballN`` of the ball-load series of ``data`` (a `Solution` or `series`)."""
    data = _as_series(data)
    return [k for k in data if k.startswith("ball") and k[4:].isdigit()]


class Peak(NamedTuple):
    """Largest value of one or several series over a window: ``value`` [unit of the series],
    the sample ``time`` [s] at which it occurs, and the ``key`` of the series that holds it.
    NaN, NaN, None when the window holds no finite sample."""

    value: float
    time: float
    key: str | None


def peak(data, key: str | Sequence[str], t_min: float = -math.inf, t_max: float = math.inf) -> Peak:
    """Largest sampled value of series ``key`` over ``t_min <= t <= t_max`` [s].

    Args:
        data: a `Solution` (or Solution-like object) or the dict of `series`.
        key: a series name (e.g. ``"bearing_f"``, ``"contact_force"``), a sequence of names
            (the largest over all of them), or ``"ball_loads"`` for all balls.
        t_min, t_max: the window [s], inclusive.

    The peak is the maximum of the signed values (all force series here are >= 0 or signed
    components; take ``bearing_f`` for the magnitude). It is read off the samples, so it is as
    accurate as the sampling resolves the peak. NaN samples (a failed solve) are ignored.
    """
    data = _as_series(data)
    keys = ball_keys(data) if key == "ball_loads" else [key] if isinstance(key, str) else list(key)
    t = np.asarray(data["t"], dtype=float)
    window = (t >= t_min) & (t <= t_max)
    best = Peak(math.nan, math.nan, None)
    for k in keys:
        values = np.where(window, np.asarray(data[k], dtype=float), np.nan)
        if not np.isfinite(values).any():
            continue
        i = int(np.nanargmax(values))
        if not values[i] <= best.value:  # also true while best is NaN
            best = Peak(float(values[i]), float(t[i]), k)
    return best


def onsets(sol) -> tuple[np.ndarray, np.ndarray]:
    """Times [s] and approach speeds [m/s] (penetration rate at onset, > 0 when closing) of all
    contact onsets, in time order, read from the padded ``sol.contacts`` (only ``valid`` slots)."""
    c = sol.contacts
    valid = np.asarray(c.valid, dtype=bool)
    times = np.asarray(c.time, dtype=float)[valid]
    speeds = np.asarray(c.approach_speed, dtype=float)[valid]
    order = np.argsort(times)
    return times[order], speeds[order]


def first_contact(sol) -> tuple[float, float]:
    """(time [s], approach speed [m/s]) of the first contact onset; (NaN, NaN) without one."""
    times, speeds = onsets(sol)
    return (float(times[0]), float(speeds[0])) if times.size else (math.nan, math.nan)


def contact_intervals(data, threshold: float = 0.0) -> list[tuple[float, float, float]]:
    """Sampled intervals of contact: ``(start [s], end [s], peak force [N])`` for each run of
    consecutive samples with ``contact_force > threshold``. Start and end are the first and last
    sample in contact, so they are accurate to the sample spacing (the exact onsets are in
    ``sol.contacts``)."""
    data = _as_series(data)
    t = np.asarray(data["t"], dtype=float)
    f = np.asarray(data["contact_force"], dtype=float)
    on = np.nan_to_num(f, nan=0.0) > threshold
    edges = np.diff(on.astype(np.int8), prepend=0, append=0)
    starts, ends = np.flatnonzero(edges == 1), np.flatnonzero(edges == -1) - 1
    return [(float(t[a]), float(t[b]), float(np.max(f[a : b + 1]))) for a, b in zip(starts, ends)]


def table5(data, times=TABLE5_TIMES) -> np.ndarray:
    """Ball loads [N] at the times of the paper's Table 5, shape (N_b, len(times)), ball 1 first.

    Linear interpolation between samples (exact where a time is a sample); NaN for times outside
    the sampled span. Compare with `cases.TABLE5` on a run *without* impact.
    """
    data = _as_series(data)
    t = np.asarray(data["t"], dtype=float)
    times = np.asarray(times, dtype=float)
    inside = (times >= t[0] - 1e-12) & (times <= t[-1] + 1e-12)
    rows = [
        np.where(inside, np.interp(times, t, np.asarray(data[k], dtype=float)), np.nan)
        for k in ball_keys(data)
    ]
    return np.array(rows)


def table5_rms(simulated, paper=TABLE5) -> float:
    """RMS difference [N] between simulated and paper ball loads over the entries where the
    simulated value is finite (all 40 for a run to t >= 0.12 s); NaN if none is."""
    diff = np.asarray(simulated, dtype=float) - np.asarray(paper, dtype=float)
    diff = diff[np.isfinite(diff)]
    return float(np.sqrt(np.mean(diff**2))) if diff.size else math.nan


def table5_mismatches(simulated, paper=TABLE5, threshold: float = LOADED_THRESHOLD) -> int:
    """Number of (finite) entries where one table has the ball loaded (>= ``threshold`` [N]) and
    the other has it unloaded."""
    simulated, paper = np.asarray(simulated, dtype=float), np.asarray(paper, dtype=float)
    finite = np.isfinite(simulated)
    return int(np.sum(finite & ((simulated >= threshold) != (paper >= threshold))))


def table5_summary(data, times=TABLE5_TIMES, paper=TABLE5) -> dict:
    """JSON-ready comparison with Table 5: ``times_s``, ``paper_N`` and ``simulated_N`` (lists
    of rows, ball 1 first), ``rms_N``, ``loaded_state_mismatches``, ``entries_compared`` and
    ``loaded_threshold_N``."""
    sim = table5(data, times)
    return {
        "times_s": [float(x) for x in times],
        "paper_N": np.asarray(paper, dtype=float).tolist(),
        "simulated_N": sim.tolist(),
        "rms_N": table5_rms(sim, paper),
        "loaded_state_mismatches": table5_mismatches(sim, paper),
        "entries_compared": int(np.isfinite(sim).sum()),
        "loaded_threshold_N": LOADED_THRESHOLD,
    }


def summarize(sol, t_min: float = PEAK_FROM) -> dict:
    """JSON-ready summary of one simulation (numbers only, no timings).

    Keys (units in the suffix): ``t_final_s``, ``samples``, ``first_contact_time_s``,
    ``first_contact_approach_speed_m_per_s``, ``contact_count`` (onsets), ``onsets`` (list of
    ``[time_s, approach_speed_m_per_s]``), ``contact_intervals`` (sampled ``[start_s, end_s,
    peak_N]``), ``peak_impact_force_N`` / ``_time_s`` (whole run), ``peak_bearing_force_N`` /
    ``_time_s`` (|F| over t >= ``t_min``), ``peak_ball_load_N`` / ``_time_s`` /
    ``peak_ball_load_ball`` (over t >= ``t_min``), ``peak_window_from_s``, ``max_drift``
    (max |Phi| [m or rad]), ``num_steps``, ``num_rejected_steps``, ``num_segments``.
    """
    data = series(sol)
    times, speeds = onsets(sol)
    first_t, first_v = first_contact(sol)
    impact = peak(data, "contact_force")
    bearing = (
        peak(data, "bearing_f", t_min) if "bearing_f" in data else Peak(math.nan, math.nan, None)
    )
    ball = peak(data, "ball_loads", t_min)
    drift = np.asarray(sol.drift, dtype=float)
    return {
        "t_final_s": float(sol.t_final),
        "samples": int(data["t"].size),
        "first_contact_time_s": first_t,
        "first_contact_approach_speed_m_per_s": first_v,
        "contact_count": int(times.size),
        "onsets": [[float(a), float(b)] for a, b in zip(times, speeds)],
        "contact_intervals": [list(x) for x in contact_intervals(data)],
        "peak_impact_force_N": impact.value,
        "peak_impact_force_time_s": impact.time,
        "peak_bearing_force_N": bearing.value,
        "peak_bearing_force_time_s": bearing.time,
        "peak_ball_load_N": ball.value,
        "peak_ball_load_time_s": ball.time,
        "peak_ball_load_ball": int(ball.key[4:]) if ball.key else None,
        "peak_window_from_s": float(t_min),
        "max_drift": float(np.nanmax(drift)) if np.isfinite(drift).any() else math.nan,
        "num_steps": int(sol.num_steps),
        "num_rejected_steps": int(sol.num_rejected_steps),
        "num_segments": int(sol.num_segments),
    }


def life_summary(sol, model, t_min: float = PEAK_FROM) -> dict:
    """Bearing life of an xu2014 run (`jaxbearing.life`): ISO 281 (C_r/P)^3 and Lundberg–Palmgren
    with the case's groove ratios, in millions of relative revolutions and hours."""
    from . import life
    from .cases.xu2014 import GROOVE_INNER, GROOVE_OUTER

    iso = life.iso_life(sol, model, t_min=t_min)
    lp = life.lp_life(sol, model, groove_inner=GROOVE_INNER, groove_outer=GROOVE_OUTER, t_min=t_min)
    return {
        "load_rating_N": float(iso.load_rating),
        "equivalent_load_N": float(iso.equivalent_load),
        "l10_iso_mrev": float(iso.l10),
        "l10_iso_hours": float(iso.l10_hours),
        "l10_lp_mrev": float(lp.l10),
        "l10_lp_hours": float(lp.l10_hours),
    }


# ---------------------------------------------------------------------------------------------
# Text
# ---------------------------------------------------------------------------------------------


def _fmt(x, spec: str) -> str:
    return "n/a" if x is None or (isinstance(x, float) and math.isnan(x)) else format(x, spec)


def format_summary(label: str, s: Mapping) -> str:
    """Human-readable lines for a `summarize` dict (plus ``wall_*_s`` timings when present)."""
    lines = [f"== {label} =="]
    if s.get("contact_count"):
        speed = _fmt(s["first_contact_approach_speed_m_per_s"], ".4f")
        lines.append(
            f"  first contact        t = {_fmt(s['first_contact_time_s'], '.6f')} s, "
            f"approach speed {speed} m/s"
        )
        lines.append(f"  contacts (onsets)    {s['contact_count']}")
        lines.append(
            f"  peak impact force    {_fmt(s['peak_impact_force_N'], '.1f')} N at t = "
            f"{_fmt(s['peak_impact_force_time_s'], '.6f')} s"
        )
    else:
        lines.append("  contacts (onsets)    0")
    t_min = s.get("peak_window_from_s", PEAK_FROM)
    lines.append(
        f"  peak bearing |F|     {_fmt(s['peak_bearing_force_N'], '.1f')} N at t = "
        f"{_fmt(s['peak_bearing_force_time_s'], '.6f')} s  (t >= {t_min:g} s)"
    )
    lines.append(
        f"  peak ball load       {_fmt(s['peak_ball_load_N'], '.1f')} N, "
        f"ball {s['peak_ball_load_ball']} at t = {_fmt(s['peak_ball_load_time_s'], '.6f')} s"
        f"  (t >= {t_min:g} s)"
    )
    lines.append(f"  max constraint drift {_fmt(s['max_drift'], '.3e')}")
    lines.append(
        f"  steps                {s['num_steps']} ({s['num_rejected_steps']} rejected), "
        f"{s['num_segments']} segments"
    )
    if "l10_iso_hours" in s:
        lines.append(
            f"  bearing life L10     ISO 281 {s['l10_iso_hours']:.3g} h (C_r {s['load_rating_N']:.0f} N, "
            f"P {s['equivalent_load_N']:.1f} N), Lundberg-Palmgren {s['l10_lp_hours']:.3g} h"
        )
    if "wall_first_s" in s:
        second = s.get("wall_second_s")
        lines.append(
            f"  wall time            {s['wall_first_s']:.2f} s (compile + run)"
            + (f", {second:.2f} s (second run, compiled)" if second is not None else "")
        )
    return "\n".join(lines)


def format_table5(t5: Mapping) -> str:
    """Table 5 side by side, "paper / simulated" [N] per ball and time, with RMS and mismatches."""
    times = t5["times_s"]
    head = "ball " + "".join(f"{f't = {t:g} s':>18}" for t in times)
    lines = ["Table 5 (without impact): paper / simulated ball load [N]", head]
    for r, (p_row, s_row) in enumerate(zip(t5["paper_N"], t5["simulated_N"])):
        cells = "".join(f"{_fmt(p, '.1f'):>8} / {_fmt(s, '7.1f'):>7}" for p, s in zip(p_row, s_row))
        lines.append(f"{r + 1:>4} {cells}")
    lines.append(
        f"RMS difference {_fmt(t5['rms_N'], '.2f')} N over {t5['entries_compared']} entries; "
        f"loaded/unloaded state differs in {t5['loaded_state_mismatches']} "
        f"(loaded: >= {t5['loaded_threshold_N']} N)"
    )
    return "\n".join(lines)


# ---------------------------------------------------------------------------------------------
# Writers (atomic: temp file in the same folder + os.replace)
# ---------------------------------------------------------------------------------------------


@contextlib.contextmanager
def atomic_path(path):
    """Yield a temporary path next to ``path``; on success move it onto ``path`` (os.replace),
    on error delete it and leave ``path`` untouched."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    os.close(fd)
    try:
        yield Path(tmp)
        os.chmod(tmp, 0o666 & ~_umask())  # mkstemp makes it private; give it a normal file's mode
        os.replace(tmp, path)
    except BaseException:
        with contextlib.suppress(FileNotFoundError):
            os.remove(tmp)
        raise


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


def _json_ready(x):
    if isinstance(x, Mapping):
        return {str(k): _json_ready(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [_json_ready(v) for v in x]
    if isinstance(x, np.ndarray):
        return _json_ready(x.tolist())
    if isinstance(x, np.generic):
        x = x.item()
    if isinstance(x, float) and not math.isfinite(x):
        return None  # strict JSON has no NaN/inf
    return x


def write_json(path, obj) -> Path:
    """Write ``obj`` as indented strict JSON (NaN and inf become null), atomically."""
    with atomic_path(path) as tmp:
        tmp.write_text(json.dumps(_json_ready(obj), indent=2) + "\n")
    return Path(path)


def csv_columns(data) -> list[str]:
    """CSV column names: series names with their unit as a suffix (``t_s``, ``slider_x_m``,
    ``slider_v_m/s`` is written ``slider_v_m_per_s``, ``ball1_N``, ...)."""
    data = _as_series(data)
    return [f"{k}_{_unit(k).replace('/', '_per_')}" for k in data]


def write_csv(path, data, stride: int = 1) -> Path:
    """Write the series of ``data`` (a `Solution` or `series` dict) as CSV, one header row of
    `csv_columns`, every ``stride``-th sample (the last sample always included), atomically."""
    data = _as_series(data)
    n = data["t"].size
    rows = np.unique(np.append(np.arange(0, n, max(1, int(stride))), n - 1))
    table = np.column_stack([np.asarray(v, dtype=float)[rows] for v in data.values()])
    with atomic_path(path) as tmp:
        np.savetxt(
            tmp, table, delimiter=",", fmt="%.10g", header=",".join(csv_columns(data)), comments=""
        )
    return Path(path)


# ---------------------------------------------------------------------------------------------
# Figures (matplotlib's object API with the Agg canvas: no pyplot, no global backend switch)
# ---------------------------------------------------------------------------------------------

_STYLE = {  # per case label: line style; colours are per quantity
    True: {"linestyle": "-", "linewidth": 0.8, "alpha": 0.9},
    False: {"linestyle": "--", "linewidth": 1.3, "alpha": 1.0},
}


def _is_impact(label: str) -> bool:
    return "without" not in label.lower()


def _window(data, window):
    t = data["t"]
    m = (t >= window[0]) & (t <= window[1])
    return m, t[m]


def _save(fig, path) -> Path:
    with atomic_path(path) as tmp:
        fig.savefig(tmp, format="png", dpi=120)
    return Path(path)


def _cases_in_order(cases: Mapping):
    # without impact drawn last (dashed, on top) so the smooth curves stay visible
    return sorted(cases.items(), key=lambda kv: not _is_impact(kv[0]))


def plot_figures(
    out_dir, cases: Mapping[str, Mapping | object], window=FIGURE_WINDOW
) -> list[Path]:
    """Draw the paper's Figs. 12–15 with the given cases overlaid and write them as PNGs.

    Args:
        out_dir: folder for ``fig12_slider_target.png``, ``fig13_impact_force.png``,
            ``fig14_bearing_force.png``, ``fig15_ball_loads.png``.
        cases: label -> `Solution` or `series` dict, e.g. ``{"with impact": ..., "without
            impact": ...}``; a label containing "without" is drawn dashed.
        window: time window [s] (default the paper's 0.04–0.14 s).

    Returns the paths written.
    """
    from matplotlib.figure import Figure

    out_dir = Path(out_dir)
    cases = {label: _as_series(d) for label, d in cases.items()}
    ordered = _cases_in_order(cases)
    paths = []

    t_end = max((float(np.nanmax(d["t"])) for d in cases.values()), default=window[1])
    xlim = (window[0], min(window[1], t_end)) if t_end > window[0] else window

    def finish(fig, axes, name, title):
        for ax in axes:
            ax.grid(True, linewidth=0.3, alpha=0.5)
            ax.set_xlim(*xlim)
        fig.suptitle(title)
        paths.append(_save(fig, out_dir / name))

    # Fig. 12: slider and target displacement, velocity, acceleration
    fig = Figure(figsize=(9, 9), layout="constrained")
    axes = fig.subplots(3, 1, sharex=True)
    panels = (
        ("x", 1e3, "displacement x [mm]"),
        ("v", 1.0, "velocity [m/s]"),
        ("a", 1.0, "acceleration [m/s²]"),
    )
    for ax, (q, scale, ylabel) in zip(axes, panels):
        for label, d in ordered:
            m, t = _window(d, window)
            for body, colour in (("slider", "C0"), ("target", "C3")):
                ax.plot(
                    t,
                    d[f"{body}_{q}"][m] * scale,
                    color=colour,
                    label=f"{body}, {label}",
                    **_STYLE[_is_impact(label)],
                )
        ax.set_ylabel(ylabel)
    axes[0].legend(fontsize=8, ncol=2, loc="best")
    axes[-1].set_xlabel("time t [s]")
    finish(
        fig,
        axes,
        "fig12_slider_target.png",
        "Fig. 12: slider and target (a) displacement, (b) velocity, (c) acceleration",
    )

    # Fig. 13: impact force
    fig = Figure(figsize=(9, 4), layout="constrained")
    ax = fig.subplots()
    for label, d in ordered:
        m, t = _window(d, window)
        ax.plot(
            t,
            d["contact_force"][m],
            color="C3" if _is_impact(label) else "k",
            label=label,
            **_STYLE[_is_impact(label)],
        )
    ax.set_ylabel("impact force [N]")
    ax.set_xlabel("time t [s]")
    ax.legend(fontsize=8)
    finish(fig, [ax], "fig13_impact_force.png", "Fig. 13: slider–target contact force")

    # Fig. 14: bearing reaction
    fig = Figure(figsize=(9, 9), layout="constrained")
    axes = fig.subplots(3, 1, sharex=True)
    for ax, (key, ylabel) in zip(
        axes, (("bearing_fx", "F_x [N]"), ("bearing_fy", "F_y [N]"), ("bearing_f", "|F| [N]"))
    ):
        for label, d in ordered:
            if key in d:
                m, t = _window(d, window)
                ax.plot(
                    t,
                    d[key][m],
                    color="C3" if _is_impact(label) else "k",
                    label=label,
                    **_STYLE[_is_impact(label)],
                )
        ax.set_ylabel(ylabel)
    axes[0].legend(fontsize=8)
    axes[-1].set_xlabel("time t [s]")
    finish(
        fig,
        axes,
        "fig14_bearing_force.png",
        "Fig. 14: bearing reaction on the crank (a) F_x, (b) F_y, (c) |F|",
    )

    # Fig. 15: ball loads, 4 x 2 panels
    balls = ball_keys(next(iter(cases.values()))) if cases else []
    fig = Figure(figsize=(11, 11), layout="constrained")
    axes = fig.subplots(4, 2, sharex=True).ravel()
    for i, (ax, key) in enumerate(zip(axes, balls)):
        for label, d in ordered:
            m, t = _window(d, window)
            ax.plot(
                t,
                d[key][m],
                color="C3" if _is_impact(label) else "k",
                label=label,
                **_STYLE[_is_impact(label)],
            )
        ax.set_title(f"({'abcdefgh'[i] if i < 8 else i}) ball {key[4:]}", fontsize=10)
        ax.set_ylabel("load [N]")
    for ax in axes[-2:]:
        ax.set_xlabel("time t [s]")
    if balls:
        axes[0].legend(fontsize=8)
    finish(fig, axes, "fig15_ball_loads.png", "Fig. 15: ball loads")
    return paths

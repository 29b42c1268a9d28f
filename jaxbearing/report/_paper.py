"""The paper's Table 5 read off a simulation, JSON-ready summaries of a run and their text."""

from __future__ import annotations

import math
from collections.abc import Mapping

import equinox as eqx
import jax.numpy as jnp
import numpy as np

from .. import life, metrics
from ..cases import FIGURE_WINDOW, GROOVE_INNER, GROOVE_OUTER, TABLE5, TABLE5_TIMES, WINDOW_START
from ..params import BallBearing
from ..solution import Solution
from ._series import as_series, ball_keys, contacts, first_contact, onsets, peak, series

PEAK_FROM = WINDOW_START  # [s] peaks are taken after the paper case's start-up transient (docs/model.md)
LOADED_THRESHOLD = 0.05  # [N] a ball is "loaded" at or above this: the paper prints 0.1 N steps


def table5(data, times=TABLE5_TIMES) -> np.ndarray:
    """Ball loads [N] at the times of the paper's Table 5, shape (N_b, len(times)), ball 1 first.

    Linear interpolation between samples (exact where a time is a sample); NaN for times outside
    the sampled span. Compare with `cases.TABLE5` on a run *without* impact.
    """
    data = as_series(data)
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


def summarize(sol, t_min: float = PEAK_FROM, model=None) -> dict:
    """JSON-ready summary of one simulation (numbers only, no timings).

    Keys (units in the suffix): ``t_final_s``, ``samples``, ``first_contact_time_s``,
    ``first_contact_approach_speed_m_per_s``, ``contact_count`` (onsets), ``onsets`` (list of
    ``[time_s, approach_speed_m_per_s]``), ``contact_intervals`` (``[start_s, end_s, peak_N,
    peak_time_s]`` of each contact of the first impact contact: `contacts`),
    ``peak_impact_force_N`` (whole run), ``peak_bearing_force_N`` (|F| over t >= ``t_min``, a
    stop of the solve), ``peak_ball_load_N`` (over t >= ``t_min``), each with its ``_time_s``,
    and ``peak_ball_load_ball``; ``peak_window_from_s``, ``max_drift`` (max |Phi| [m or rad]
    over the output samples), ``num_steps``, ``num_rejected_steps``, ``num_segments``, ``num_events``.

    The peaks, their times and the ball are `jaxbearing.metrics`' (from every solver step and
    its interpolant, whatever the output times; NaN, and ball None, where the run ended before
    ``t_min``), and the contacts come from the solve's records as well; the balls are numbered
    from 1.

    Given the run's ``model``, the summary holds `life_summary`'s keys as well (NaN where the
    peaks over t >= ``t_min`` are), computed in the same compiled call as the peaks.
    """
    data = series(sol)
    times, speeds = onsets(sol)
    first_t, first_v = first_contact(sol)
    windowed = sol.bearing_force is not None and float(sol.t_final) > t_min
    if not isinstance(sol, Solution):  # a Solution-like object of other arrays: eagerly
        peaks, lives = _peaks(sol, float(t_min), windowed), None
    else:
        peaks, lives = _numbers(sol, model if windowed else None, float(t_min), windowed)
    impact, impact_t, bearing, bearing_t, ball, ball_t, which = (float(x) for x in peaks)
    which = int(which) + 1 if math.isfinite(ball) else None
    drift = np.asarray(sol.drift, dtype=float)
    summary = {
        "t_final_s": float(sol.t_final),
        "samples": int(data["t"].size),
        "first_contact_time_s": first_t,
        "first_contact_approach_speed_m_per_s": first_v,
        "contact_count": int(times.size),
        "onsets": [[float(a), float(b)] for a, b in zip(times, speeds)],
        "contact_intervals": [list(x[:4]) for x in contacts(sol)],
        "peak_impact_force_N": impact,
        "peak_impact_force_time_s": impact_t,
        "peak_bearing_force_N": bearing,
        "peak_bearing_force_time_s": bearing_t,
        "peak_ball_load_N": ball,
        "peak_ball_load_time_s": ball_t,
        "peak_ball_load_ball": which,
        "peak_window_from_s": float(t_min),
        "max_drift": float(np.nanmax(drift)) if np.isfinite(drift).any() else math.nan,
        "num_steps": int(sol.num_steps),
        "num_rejected_steps": int(sol.num_rejected_steps),
        "num_segments": int(sol.num_segments),
        "num_events": int(sol.num_events),
    }
    if model is not None:
        summary.update(_life_dict(lives))
    return summary


def _peaks(sol, t_min: float, windowed: bool) -> tuple:
    """The peak impact force [N] over the whole run and its time [s], the peak bearing |F| and
    ball load over t >= ``t_min`` with their times, and the ball (its index); NaN for the last
    five unless ``windowed``. A `Solution`'s run compiled, in `_numbers`: run eagerly, each of
    its operations would compile by itself."""
    impact = metrics.peak_impact_force
    out = (impact(sol, t_min=-math.inf), metrics.peak_time(sol, impact, t_min=-math.inf))
    if not windowed:
        return out + (math.nan,) * 5
    for metric in (metrics.peak_bearing_force, metrics.peak_ball_load):
        out += (metric(sol, t_min=t_min), metrics.peak_time(sol, metric, t_min=t_min))
    return out + (metrics.peak_ball(sol, t_min=t_min),)


def _lives(sol, model, t_min: float) -> tuple:
    """ISO 281 and Lundberg–Palmgren lives and ISO 76 static safety of `life_summary`."""
    iso = life.iso_life(sol, model, t_min=t_min)
    grooves = dict(groove_inner=GROOVE_INNER, groove_outer=GROOVE_OUTER)
    if isinstance(model.bearing, BallBearing):
        lp = life.lp_life(sol, model, **grooves, t_min=t_min)
        lp_lives = (lp.l10, lp.l10_hours)
    else:  # Lundberg–Palmgren rates ball bearings only (`life.lp_life`)
        lp_lives = (jnp.nan, jnp.nan)
    static = life.static_safety(sol, model, t_min=t_min, **grooves)
    return (
        iso.load_rating, iso.equivalent_load, iso.l10, iso.l10_hours, *lp_lives,
        static.c0, static.p0, static.s0, static.contact_stress, static.permissible_stress,
    )  # fmt: skip


_compiled_lives = eqx.filter_jit(_lives)


@eqx.filter_jit
def _numbers(sol, model, t_min: float, windowed: bool) -> tuple:
    """`_peaks` and, given a model, `_lives` (else None), in one compiled call."""
    return _peaks(sol, t_min, windowed), None if model is None else _lives(sol, model, t_min)


_LIFE_NAMES = (
    "load_rating_N", "equivalent_load_N", "l10_iso_mrev", "l10_iso_hours", "l10_lp_mrev", "l10_lp_hours",
    "static_load_rating_N", "static_equivalent_load_N", "static_safety", "contact_stress_Pa",
    "permissible_contact_stress_Pa",
)  # fmt: skip


def _life_dict(lives) -> dict:
    """`life_summary`'s keys: the lives' values, or NaN for each where ``lives`` is None."""
    if lives is None:  # the run ended before the window: no life
        return dict.fromkeys(_LIFE_NAMES, math.nan)
    return {name: float(x) for name, x in zip(_LIFE_NAMES, lives)}


def life_summary(sol, model, t_min: float = PEAK_FROM) -> dict:
    """Bearing life of an xu2014 run (`jaxbearing.life`): ISO 281 (C_r/P)^p and Lundberg–Palmgren
    with the case's groove ratios (NaN for a roller bearing, which it does not rate), in
    millions of relative revolutions and hours, and the ISO 76 static capacity
    (`life.static_safety`: C_0r, the peak equivalent static load P_0r, s_0 and the most loaded
    element's contact stress beside the permissible one), over t >= ``t_min``; NaN where the
    run ended before it."""
    if float(sol.t_final) <= t_min:
        return _life_dict(None)
    return _life_dict(_compiled_lives(sol, model, float(t_min)))



_FIGURE_PEAKS = (("impact_force", "contact_force"), ("bearing_force", "bearing_f"), ("ball_load", "ball_loads"))


def figure_peaks(data, window=FIGURE_WINDOW) -> dict:
    """The peaks the figures show, over their ``window`` [s] (`cases.FIGURE_WINDOW`, Figs.
    12–15), read off the samples as the figures draw them: JSON-ready keys ``figure_window_s``,
    ``figure_peak_impact_force_N``, ``figure_peak_bearing_force_N`` (|F|),
    ``figure_peak_ball_load_N``, each with its ``_time_s``, and ``figure_peak_ball_load_ball``
    (numbered from 1; None where the window holds no sample). `format_summary` says where each
    of the run's peaks lies against the figures and gives these where it lies outside."""
    out = {"figure_window_s": [float(window[0]), float(window[1])]}
    for name, key in _FIGURE_PEAKS:
        found = peak(data, key, *window)
        out[f"figure_peak_{name}_N"], out[f"figure_peak_{name}_time_s"] = found.value, found.time
        if name == "ball_load":
            out["figure_peak_ball_load_ball"] = None if found.key is None else int(found.key[4:])
    return out


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
            f"{_fmt(s['peak_impact_force_time_s'], '.6f')} s  (whole run{_shown(s, 'impact_force')})"
        )
        lines += _in_figures(s, "impact_force")
    else:
        lines.append("  contacts (onsets)    0")
    t_min = s.get("peak_window_from_s", PEAK_FROM)
    lines.append(
        f"  peak bearing |F|     {_fmt(s['peak_bearing_force_N'], '.1f')} N at t = "
        f"{_fmt(s['peak_bearing_force_time_s'], '.6f')} s  (t >= {t_min:g} s{_shown(s, 'bearing_force')})"
    )
    lines += _in_figures(s, "bearing_force")
    lines.append(
        f"  peak ball load       {_fmt(s['peak_ball_load_N'], '.1f')} N, "
        f"ball {s['peak_ball_load_ball']} at t = {_fmt(s['peak_ball_load_time_s'], '.6f')} s"
        f"  (t >= {t_min:g} s{_shown(s, 'ball_load')})"
    )
    lines += _in_figures(s, "ball_load")
    lines.append(f"  max constraint drift {_fmt(s['max_drift'], '.3e')}")
    lines.append(
        f"  steps                {s['num_steps']} ({s['num_rejected_steps']} rejected), "
        f"{s['num_events']} events located"
    )
    if "l10_iso_hours" in s:
        lines.append(
            f"  bearing life L10     ISO 281 {s['l10_iso_hours']:.3g} h (C_r {s['load_rating_N']:.0f} N, "
            f"P {s['equivalent_load_N']:.1f} N), Lundberg-Palmgren {s['l10_lp_hours']:.3g} h"
        )
        lines.append(
            f"  static safety s0     {s['static_safety']:.3g} (C_0r {s['static_load_rating_N']:.0f} N, "
            f"P_0r {s['static_equivalent_load_N']:.1f} N), contact stress "
            f"{1e-6 * s['contact_stress_Pa']:.0f} MPa of {1e-6 * s['permissible_contact_stress_Pa']:.0f} MPa"
        )
    if "wall_first_s" in s:
        second = s.get("wall_second_s")
        lines.append(
            f"  wall time            {s['wall_first_s']:.2f} s (compile + run)"
            + (f", {second:.2f} s (second run, compiled)" if second is not None else "")
        )
    return "\n".join(lines)


def _where(s: Mapping, name: str) -> str | None:
    """Where the run's peak ``name`` lies against the figures' window (`figure_peaks`): "in",
    "before" or "after"; None without figures or without the peak's time."""
    window, t = s.get("figure_window_s"), s.get(f"peak_{name}_time_s")
    if window is None or t is None or not math.isfinite(t):
        return None
    return "before" if t < window[0] else "after" if t > window[1] else "in"


def _shown(s: Mapping, name: str) -> str:
    """``; in the figures`` or ``; after the figures' 0.04-0.14 s``: where the peak is drawn."""
    where = _where(s, name)
    if where is None:
        return ""
    a, b = s["figure_window_s"]
    return "; in the figures" if where == "in" else f"; {where} the figures' {a:g}-{b:g} s"


def _in_figures(s: Mapping, name: str) -> list[str]:
    """The line of the peak the figures show, where the run's lies outside them."""
    if _where(s, name) not in ("before", "after"):
        return []
    value, t = s[f"figure_peak_{name}_N"], s[f"figure_peak_{name}_time_s"]
    ball = f", ball {s['figure_peak_ball_load_ball']}" if name == "ball_load" else ""
    return [f"{'':23}{_fmt(value, '.1f')} N{ball} at t = {_fmt(t, '.6f')} s  the figures' peak (sampled)"]


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


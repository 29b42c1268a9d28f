"""Named time series of a simulation of the paper's case, and what is read off them: peaks over a
window, contact onsets, the contacts from the solve's records and contact intervals read off
samples (names and units in `jaxbearing.report`)."""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import NamedTuple

import numpy as np

from ..cases import SLIDER, TARGET
from ..metrics import contact_index

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


def unit(key: str) -> str:
    return "N" if key.startswith("ball") else UNITS[key]


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



def as_series(data) -> Mapping[str, np.ndarray]:
    """``data`` itself if it is a `series` dict, else `series` of it."""
    return data if isinstance(data, Mapping) else series(data)

def ball_keys(data) -> list[str]:
    """Names ``ball1 .. ballN`` of the ball-load series of ``data`` (a `Solution` or `series`)."""
    data = as_series(data)
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
    data = as_series(data)
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


class Contact(NamedTuple):
    """One impact contact of a solve (`contacts`)."""

    start: float  # onset [s]
    end: float  # separation event [s] (`jaxbearing.Contacts.end`); the time reached if later
    peak_force: float  # largest normal force over the contact [N]
    peak_time: float  # when it is attained [s]
    approach_speed: float  # penetration rate at onset [m/s]


def contacts(sol, contact: int | None = None) -> list[Contact]:
    """Every contact of one impact contact of the model (``contact``: index into
    ``model.contacts``; None: the only one, a ValueError on a model with several), in time
    order, from the solve's records (``sol.contacts``): onset and end located as events, the
    peak force over the solution's steps and interpolants, so the same whatever the output
    times. A contact that lasted to the end of the run ends at ``sol.t_final``; a model
    without impact contact has none."""
    index = contact_index(sol, contact)
    if index is None:
        return []
    c = sol.contacts
    chosen = np.asarray(c.valid, dtype=bool) & (np.asarray(c.index) == index)
    fields = [np.asarray(x, dtype=float)[chosen] for x in
              (c.time, c.end, c.peak_force, c.peak_time, c.approach_speed)]
    t_final = float(sol.t_final)
    found = [Contact(a, t_final if math.isnan(b) else b, f, p, v) for a, b, f, p, v in zip(*fields)]
    return sorted(found)


def contact_intervals(data, threshold: float = 0.0) -> list[tuple[float, float, float]]:
    """Sampled intervals of contact: ``(start [s], end [s], peak force [N])`` for each run of
    consecutive samples with ``contact_force > threshold``, from series (e.g. read back from a
    CSV file). Start and end are the first and last sample in contact, so they are accurate to
    the sample spacing, and the peak is the largest sample: a contact shorter than the spacing
    can be missed. From a `Solution`, `contacts` gives them from the solve's records."""
    data = as_series(data)
    t = np.asarray(data["t"], dtype=float)
    f = np.asarray(data["contact_force"], dtype=float)
    on = np.nan_to_num(f, nan=0.0) > threshold
    edges = np.diff(on.astype(np.int8), prepend=0, append=0)
    starts, ends = np.flatnonzero(edges == 1), np.flatnonzero(edges == -1) - 1
    return [(float(t[a]), float(t[b]), float(np.max(f[a : b + 1]))) for a, b in zip(starts, ends)]


"""Scalar metrics of a `Solution`, over a time window ``[t_min, t_max]`` [s]: by default
(``t_min="model"``, ``t_max=None``) from the model's ``window_start`` (`Mechanism`; the paper's
case starts it after the start-up transient in which the rod falls onto the race and rings;
None: the whole span) to the end of the solve; ``t_min=None`` starts it with the solve.

They are computed from the solution itself, not from its output times: `simulate` records, per
interval between its stops, the peaks and integrals over every accepted solver step and the
step's interpolant (`SegmentStats`), and a metric combines the intervals inside its window. So a
metric has the same value whatever ``ts`` the simulation was asked for. A window's edges must be
stops: t0, the model's ``window_start`` and t1 always are, and ``SolveOptions.window_edges``
adds others. An edge that is not raises ValueError, or, under `jax.jit` / `jax.vmap` where that
cannot be checked in Python, makes the metric NaN (`jaxbearing.sweep` marks such a member failed
with the reason, `jaxbearing.sensitivity` and `jaxbearing.tune` raise it). No warning is issued
from inside a compiled program: its host callback would keep the program out of JAX's
persistent compilation cache.

All are pure functions of the solution arrays, so they run under `jax.jit`, `jax.vmap` and the
differentiation transforms:

- the exact peaks (``peak_*``, ``max_*``) are maxima of each step's interpolant (its end, 3
  Gauss–Legendre points and, where the step may hold a new peak between them, the vertex of a
  parabola through them, the interpolant's maximum to third order; `SegmentStats`):
  differentiable almost everywhere, with the derivative of the point that attains the maximum,
  which jumps when another point takes over; fine for sensitivities at one design point, poor
  for optimisation;
- `peak_time` and `peak_ball` say when an exact peak is attained and which ball carries the
  peak ball load, `loads_at_peak` every ball's load then: the earliest recorded point that
  attains the peak (no derivative of the time);
- the smooth versions (``smooth_*``) replace the maximum by the power mean
  (1/T integral x^p dt)^(1/p) over the window of duration T, which lies below the maximum,
  approaches it as p grows, and is differentiable everywhere: use them as objectives for
  `jax.grad` and optax. The RMS bearing force is smooth already. Their integrals are 3-point
  Gauss–Legendre quadratures of each step's interpolant (exact for integrands of degree <= 5
  over a step), recorded at p = `solution.POWER` (16).

Forces in N, displacements in m.

A window that holds none of the solved span (e.g. a run that ends before the default t_min)
has no value: with a concrete solution and window the metric raises a `ValueError` naming
``t_min`` and the span; traced (under jit or vmap, in sweeps) it is NaN, as above.

A metric that needs the model as well (bearing life: the bearing's geometry and the ring speeds)
is a function ``fn(sol, model)`` wrapped in `WithModel`, which tells `jaxbearing.sweep` to pass
each member's model; `jaxbearing.life.metric` makes one.

`converged` says whether a metric is a result at all: it simulates the model at several solver
tolerances and compares the metric's values (docs/metrics.md).
"""

from __future__ import annotations

import dataclasses
import math
import numbers
from collections.abc import Callable
from typing import final

import jax
import jax.numpy as jnp
import numpy as np

from ._checks import is_concrete
from .solution import (
    AbstractRecord,
    FORCE_SCALE,
    INT_TIME,
    POWER,
    RESULTS,
    SimulationError,
    Solution,
    integral_column,
    peak_column,
)


@dataclasses.dataclass(frozen=True)
class WithModel:
    """A metric of the solution and the model: ``fn(sol, model) -> scalar``.

    `jaxbearing.sweep` calls a plain metric as ``fn(sol)`` and a WithModel as ``fn(sol, model)``
    with the member's own model (its swept parameters set). Calling a WithModel calls ``fn``.
    """

    fn: Callable

    def __call__(self, sol: Solution, model) -> jax.Array:
        return self.fn(sol, model)


def window(ts, t_min=None, t_max=None) -> jax.Array:
    """Weights [s] of the output times over the window ``[t_min, t_max]`` (`window_weights`), for
    metrics of sampled series; checked by `check_window` (a window without output times)."""
    lo = -jnp.inf if t_min is None else t_min
    w = window_weights(ts, lo, jnp.inf if t_max is None else t_max)
    check_window(ts, w, t_min, t_max)
    return w


@jax.jit
def window_weights(ts, lo, hi) -> jax.Array:
    """Weights w [s] with sum_i w_i f(t_i) = the integral over ``[lo, hi]`` of the piecewise-linear
    interpolant of the samples f(t_i) (trapezoid rule, each interval cut at the window's edges).

    So a function linear between samples integrates exactly, whether the edges fall on samples
    (then it is the trapezoid rule over the intervals inside) or between them (the part of an
    interval inside counts by the interpolant there); samples outside the window carry weight
    only through an interval that the window cuts. One rule for `window` and the life's
    revolution weights (`jaxbearing.life`). ``lo``, ``hi`` may be infinite; ts (T,)
    non-decreasing [s]."""
    t_a, t_b = ts[:-1], ts[1:]
    a, b = jnp.clip(t_a, lo, hi), jnp.clip(t_b, lo, hi)
    length = jnp.maximum(b - a, 0.0)
    h = t_b - t_a
    safe_h = jnp.where(h > 0.0, h, 1.0)
    mid = 0.5 * (a + b)
    left = jnp.where(h > 0.0, length * (t_b - mid) / safe_h, 0.0)
    right = jnp.where(h > 0.0, length * (mid - t_a) / safe_h, 0.0)
    return jnp.zeros_like(ts).at[:-1].add(left).at[1:].add(right)


def check_window(ts, weights, t_min, t_max, need="one"):
    """A window whose weights [s] are all zero holds fewer than ``need`` output times: raise a
    `ValueError` when ``ts`` and the window ``[t_min, t_max]`` [s] are concrete; traced, the
    metrics of that window are NaN."""
    if is_concrete(ts, weights):  # in NumPy: eager JAX operations would each compile a program
        t = np.asarray(ts)
        filled = bool(np.any(np.asarray(weights) > 0))
        what = f"at least {need} of the output times, which span"
        _check_not_empty(filled, t_min, t_max, t[0], t[-1], what)


def _check_not_empty(filled, t_min, t_max, first, last, what):
    """A `ValueError` when ``filled`` is concretely False; traced, nothing (the metric is NaN:
    a host callback would keep the compiled program out of JAX's persistent cache)."""
    if is_concrete(filled, t_min, t_max, first, last) and not bool(filled):
        raise ValueError(_empty_window(t_min, t_max, first, last, what) + ".")


def _empty_window(t_min, t_max, first, last, what):
    t_min = -np.inf if t_min is None else float(t_min)
    t_max = np.inf if t_max is None else float(t_max)
    return (
        f"the window t_min = {t_min:.6g} s to t_max = {t_max:.6g} s must hold {what} "
        f"[{float(first):.6g}, {float(last):.6g}] s: lower t_min (a metric of a Solution "
        "starts by default at the model's window_start) or simulate longer"
    )


EDGE_TOLERANCE = 1e-12  # [s] a window edge this close to an interval end counts as that end
_END_IS = "the window's end, or None (to the end of the run)"


def _inside(sol: Solution, t_min, t_max):
    """Which intervals of ``sol.segments`` lie in ``[t_min, t_max]``, and whether the window
    has a value: both edges are stops (or outside the solved span) and the run reached its end
    (`reached`). SimulationError or ValueError when not and that is known in Python (a run
    that stopped short first: what else is wrong with the window follows from that)."""
    ok = reached(sol, t_max)
    inside, on_stops = intervals_inside(sol.segments, window_start(sol, t_min), t_max, "stop intervals")
    return inside, ok & on_stops


def reached(sol: Solution, t_max):
    """Whether the run reached the end of a window that ends at ``t_max`` [s] (None: the t1
    asked for; a later t_max counts as t1). A run that stopped short (``throw=False``) has no
    metric there: a `SimulationError` saying when and why it stopped where that is known in
    Python; traced, False (the metric is NaN)."""
    if t_max is not None:
        t_max = _window_edge("t_max", t_max, _END_IS)
    end = sol.t1 if t_max is None else jnp.minimum(t_max, sol.t1)
    ok = sol.t_final >= end - EDGE_TOLERANCE
    if is_concrete(ok) and not bool(ok):
        why = RESULTS[sol.result] if is_concrete(sol.result._value) else "it failed"
        raise SimulationError(
            f"The window ends at t = {float(end):.6g} s, but the run stopped at t_final = "
            f"{float(sol.t_final):.6g} s of t1 = {float(sol.t1):.6g} s ({why}): a metric of a "
            "run that did not reach its window's end is no result. A solution of throw=False "
            f"can be inspected over [t0, {float(sol.t_final):.6g}] s (pass t_max <= t_final)."
        )
    return ok


def window_start(sol: Solution, t_min):
    """The window's start [s]: ``t_min``, or for ``"model"`` the model's ``window_start`` that
    ``sol`` carries (None: the start of the solve)."""
    if isinstance(t_min, str) and t_min == "model":
        return sol.window_start
    return t_min


def intervals_inside(stats, t_min, t_max, name: str):
    """Which intervals of ``stats`` (fields t_start, t_end, valid: `SegmentStats`,
    `FatigueStats`) lie in ``[t_min, t_max]`` [s], and whether both edges are interval ends (or
    outside the solved span): a ValueError naming the ``name`` when they are not and that is
    known in Python; traced, the second value is False (the metric is NaN)."""
    if t_min is None:
        t_min = -jnp.inf
    start_is = 'the window\'s start, "model" (the model\'s window_start) or None (from t0)'
    t_min = _window_edge("t_min", t_min, start_is)
    if t_max is None:
        t_max = jnp.inf
    t_max = _window_edge("t_max", t_max, _END_IS)
    if is_concrete(t_min, t_max) and not t_max > t_min:
        raise ValueError(f"t_max must exceed t_min; got the window [{float(t_min)}, {float(t_max)}] s.")
    start = jnp.min(jnp.where(stats.valid, stats.t_start, jnp.inf))
    end = jnp.max(jnp.where(stats.valid, stats.t_end, -jnp.inf))

    def is_edge(t, ends):
        near = stats.valid & (jnp.abs(ends - t) <= EDGE_TOLERANCE)
        return (t <= start + EDGE_TOLERANCE) | (t >= end - EDGE_TOLERANCE) | jnp.any(near)

    edges = ((t_min, is_edge(t_min, stats.t_start)), (t_max, is_edge(t_max, stats.t_end)))
    ok = edges[0][1] & edges[1][1]
    if is_concrete(ok) and not bool(ok):
        missing = tuple(float(t) for t, edge in edges if not bool(edge))
        raise ValueError(
            f"The window [{float(t_min)}, {float(t_max)}] s needs its edges to be ends of the "
            f"solution's {name} (not: {', '.join(map(str, missing))} s): pass the edges to "
            f"simulate, as simulate(..., options=jaxbearing.SolveOptions(window_edges={missing}))."
        )
    inside = (
        stats.valid
        & (stats.t_start >= t_min - EDGE_TOLERANCE)
        & (stats.t_end <= t_max + EDGE_TOLERANCE)
    )
    _check_not_empty(jnp.any(inside), t_min, t_max, start, end, "part of the solved span")
    return inside, ok


def _window_edge(name, value, what) -> jax.Array:
    """A window edge [s] as a float64 scalar; a ValueError saying what it must be."""
    edge = None
    if not isinstance(value, (bool, str, type(None))):
        try:
            edge = jnp.asarray(value, jnp.float64)
        except (TypeError, ValueError):
            pass
    if edge is None or edge.ndim != 0:
        raise ValueError(f"{name} must be a time [s], one number, {what}; got {value!r}.")
    return edge


def _peak(sol: Solution, column, t_min, t_max):
    """Max of ``segments.peaks[:, column]`` over the window; NaN if the window has no value.
    ``column`` None (an element the model lacks): 0."""
    inside, ok = _inside(sol, t_min, t_max)
    if column is None:
        return jnp.where(ok & jnp.any(inside), 0.0, jnp.nan)
    peak = jnp.max(jnp.where(inside, sol.segments.peaks[:, column], -jnp.inf))
    return jnp.where(ok & jnp.any(inside), peak, jnp.nan)


def _integral(sol: Solution, column, t_min, t_max):
    """(integral of ``segments.integrals[:, column]``, duration) over the window [.., s]; NaN
    duration if the window has no value. ``column`` None: an integral of 0."""
    inside, ok = _inside(sol, t_min, t_max)
    total = jnp.sum(jnp.where(inside[:, None], sol.segments.integrals, 0.0), axis=0)
    value = 0.0 * total[INT_TIME] if column is None else total[column]
    return value, jnp.where(ok, total[INT_TIME], jnp.nan)


def _power_mean(sol: Solution, column, t_min, t_max, p, count=1):
    """FORCE_SCALE (integral / (count T))^(1/p) [N] of a recorded power integral."""
    if is_concrete(p) and float(p) != POWER:
        raise ValueError(
            f"The solution records power means of order p = {POWER} only; got p = {p}."
        )
    total, duration = _integral(sol, column, t_min, t_max)
    return FORCE_SCALE * (total / (count * duration)) ** (1.0 / POWER)


def element_index(name: str, value, count: int, element: str):
    """``value`` checked as an index into the model's ``count`` elements (``name`` the keyword,
    ``element`` what they are); None means the only one."""
    plural = f"{count} {element}{'s' if count != 1 else ''}"
    if value is None:
        if count > 1:
            raise ValueError(
                f"This model has {plural}: pass {name}= (an index from 0 to {count - 1}, model "
                "order) to say which."
            )
        return 0
    if isinstance(value, bool) or not isinstance(value, numbers.Integral) or not 0 <= value < count:
        allowed = f"an integer from 0 to {count - 1}" if count else "none: it has no such element"
        raise ValueError(f"{name} must index one of the model's {plural} ({allowed}); got {value!r}.")
    return int(value)


def bearing_index(sol: Solution, bearing=None) -> int:
    """The index into ``model.bearings`` that ``bearing`` names (None: the only one); a
    ValueError for a model without bearing joint, for None on a model with several, and for an
    index it does not have."""
    if not sol.n_bearings:
        raise ValueError("This solution has no bearing joint.")
    return element_index("bearing", bearing, sol.n_bearings, "bearing joint")


def contact_index(sol: Solution, contact=None) -> int | None:
    """The index into ``model.contacts`` that ``contact`` names (None: the only one, or None
    for a model without contact); a ValueError for None on a model with several, and for an
    index it does not have."""
    if contact is None and not sol.n_contacts:
        return None
    return element_index("contact", contact, sol.n_contacts, "impact contact")


def _column(sol: Solution, kind: str, index) -> int | None:
    """`peak_column` of ``kind`` for element ``index`` of ``sol``'s model (None stays None)."""
    if index is None:
        return None
    return peak_column(kind, index, sol.n_bearings, sol.n_contacts)


def peak_ball_load(sol: Solution, t_min="model", t_max=None, *, bearing=None) -> jax.Array:
    """Largest load on any ball [N] of a bearing joint (``bearing``: index into
    ``model.bearings``; None: the only one) in the window, the maximum of each solver step's
    interpolant (`SegmentStats`)."""
    return _peak(sol, _column(sol, "ball_load", bearing_index(sol, bearing)), t_min, t_max)


def peak_bearing_force(sol: Solution, t_min="model", t_max=None, *, bearing=None) -> jax.Array:
    """Largest magnitude |F| of a bearing joint's resultant (Eq. 28) [N] in the window, the
    maximum of each solver step's interpolant (`SegmentStats`); ``bearing`` as in
    `peak_ball_load`."""
    return _peak(sol, _column(sol, "bearing_force", bearing_index(sol, bearing)), t_min, t_max)


def rms_bearing_force(sol: Solution, t_min="model", t_max=None, *, bearing=None) -> jax.Array:
    """Root-mean-square of a bearing joint's |F| over the window (time-weighted) [N]:
    Gauss–Legendre quadrature of each step's interpolant (exact for integrands of degree <= 5
    over a step). Smooth. ``bearing`` as in `peak_ball_load`."""
    column = integral_column("force_squared", bearing_index(sol, bearing), sol.n_bearings)
    total, duration = _integral(sol, column, t_min, t_max)
    return jnp.sqrt(total / duration)


def peak_impact_force(sol: Solution, t_min="model", t_max=None, *, contact=None) -> jax.Array:
    """Largest normal impact force [N] of a contact (``contact``: index into
    ``model.contacts``; None: the only one) in the window, the maximum of each solver step's
    interpolant (`SegmentStats`), so independent of the output times; 0 for a model without
    contact (nothing is struck)."""
    return _peak(sol, _column(sol, "contact_force", contact_index(sol, contact)), t_min, t_max)


def max_target_displacement(
    sol: Solution, t_min="model", t_max=None, coordinate=None, *, contact=None
) -> jax.Array:
    """Largest |q_c(t) - q_c(t0)| [m or rad] of one coordinate in the window, the maximum of
    each solver step's interpolant (`SegmentStats`). Default coordinate: the x of the impact
    target of ``contact`` (`Solution.targets`; None: the only contact; in `cases.xu2014` the
    target, body 3); a model without impact contact has no target, and the value is 0 (nothing
    is struck), as `peak_impact_force`'s."""
    if coordinate is not None:
        n = sol.q.shape[-1]
        if isinstance(coordinate, bool) or not isinstance(coordinate, numbers.Integral) or not 0 <= coordinate < n:
            raise ValueError(
                f"coordinate must be an index into q, an integer in [0, {n}); got {coordinate!r}."
            )
        return _peak(sol, _column(sol, "displacement", int(coordinate)), t_min, t_max)
    c = contact_index(sol, contact)
    target = None if c is None else sol.targets[c]
    return _peak(sol, _column(sol, "displacement", target), t_min, t_max)


def _peak_column(sol: Solution, metric, bearing, contact) -> int | None:
    """The `SegmentStats` column of an exact peak metric (None: an element the model lacks)."""
    if metric in (peak_ball_load, peak_bearing_force):
        kind = "ball_load" if metric is peak_ball_load else "bearing_force"
        return _column(sol, kind, bearing_index(sol, bearing))
    if metric is peak_impact_force:
        return _column(sol, "contact_force", contact_index(sol, contact))
    if metric is max_target_displacement:
        c = contact_index(sol, contact)
        if c is None:
            raise ValueError("This solution has no impact target (its model has no contact).")
        return _column(sol, "displacement", sol.targets[c])
    given = f"the string {metric!r}" if isinstance(metric, str) else repr(metric)
    raise ValueError(
        "metric must be the function (not its name) of an exact peak: "
        "jaxbearing.metrics.peak_ball_load, peak_bearing_force, peak_impact_force or "
        f"max_target_displacement; got {given}."
    )


def _where_peak(sol: Solution, column, t_min, t_max):
    """(interval attaining the peak of ``column`` in the window (the earliest of equals), the
    peak, and whether the window has a value)."""
    inside, ok = _inside(sol, t_min, t_max)
    peaks = jnp.where(inside, sol.segments.peaks[:, column], -jnp.inf)
    i = jnp.argmax(peaks)
    return i, peaks[i], ok & jnp.any(inside)


def peak_time(
    sol: Solution, metric, t_min="model", t_max=None, *, bearing=None, contact=None
) -> jax.Array:
    """Time [s] at which the exact peak ``metric`` (`peak_ball_load`, `peak_bearing_force`,
    `peak_impact_force`, or `max_target_displacement` of the target; of the bearing joint or
    contact named by ``bearing`` / ``contact`` as there) is attained in the window: the earliest
    recorded point that attains it (`SegmentStats.peak_times`), so independent of the output
    times; NaN where the peak is 0 (the element never acted in the window: no impact). No
    derivative: the point that attains a maximum jumps between steps. In a sweep, pass e.g.
    ``functools.partial(peak_time, metric=peak_impact_force)``."""
    column = _peak_column(sol, metric, bearing, contact)
    if column is None:  # no contact: nothing was struck, at no time
        _inside(sol, t_min, t_max)  # the window's checks
        return jnp.asarray(jnp.nan)
    i, peak, has_value = _where_peak(sol, column, t_min, t_max)
    time = jax.lax.stop_gradient(sol.segments.peak_times[i, column])
    return jnp.where(has_value & (peak > 0.0), time, jnp.nan)


def loads_at_peak(sol: Solution, t_min="model", t_max=None, *, bearing=None) -> jax.Array:
    """Every ball's load [N] of a bearing joint (``bearing`` as in `peak_ball_load`) at the time
    of its `peak_ball_load` in the window (its `peak_time`), (N_b,), ball 1 first: the load
    distribution at the worst instant (`SegmentStats.peak_loads`); NaN for a window without
    value (traced). A vector: in a sweep, take one ball's entry."""
    b = bearing_index(sol, bearing)
    i, _, has_value = _where_peak(sol, _column(sol, "ball_load", b), t_min, t_max)
    return jnp.where(has_value, sol.segments.peak_loads[b][i], jnp.nan)


def peak_ball(sol: Solution, t_min="model", t_max=None, *, bearing=None) -> jax.Array:
    """The ball that carries `peak_ball_load` in the window: its column of the bearing's
    ``ball_loads`` (0 = ball 1), an int; -1 for a window without value (traced)."""
    loads = loads_at_peak(sol, t_min, t_max, bearing=bearing)
    return jnp.where(jnp.isnan(loads[0]), -1, jnp.argmax(loads))


def smooth_peak_ball_load(
    sol: Solution, t_min="model", t_max=None, p=16.0, *, bearing=None
) -> jax.Array:
    """Power mean of order p of all ball loads of a bearing joint (``bearing`` as in
    `peak_ball_load`) over the window and the balls [N]: a differentiable stand-in for
    `peak_ball_load` (below it; closer as p grows). Gauss–Legendre quadrature of each step's
    interpolant; p must be `solution.POWER` (16)."""
    b = bearing_index(sol, bearing)
    n_balls = sol.bearings[b].ball_loads.shape[-1]
    column = integral_column("ball_load_power", b, sol.n_bearings)
    return _power_mean(sol, column, t_min, t_max, p, n_balls)


def smooth_peak_bearing_force(
    sol: Solution, t_min="model", t_max=None, p=16.0, *, bearing=None
) -> jax.Array:
    """Power mean of order p of a bearing joint's |F| over the window [N]: differentiable
    stand-in for the peak. Gauss–Legendre quadrature of each step's interpolant; p must be
    `solution.POWER` (16)."""
    column = integral_column("force_power", bearing_index(sol, bearing), sol.n_bearings)
    return _power_mean(sol, column, t_min, t_max, p)


def smooth_peak_impact_force(
    sol: Solution, t_min="model", t_max=None, p=16.0, *, contact=None
) -> jax.Array:
    """Power mean of order p of a contact's impact force (``contact`` as in
    `peak_impact_force`) over the window [N]. Gauss–Legendre quadrature of each step's
    interpolant; p must be `solution.POWER` (16); 0 for a model without contact."""
    c = contact_index(sol, contact)
    column = None if c is None else integral_column("contact_force_power", c, sol.n_bearings)
    return _power_mean(sol, column, t_min, t_max, p)


class _Own(AbstractRecord):
    """What `Peak` and `Mean` share: declared by name before the solve
    (``SolveOptions(records={name: metric})``), recorded from every accepted step, and read
    from the solution by calling the metric on it."""

    def __init__(self, fn: Callable, t_min: float | None = None, t_max: float | None = None):
        if not callable(fn):
            raise TypeError(f"fn must be a function fn(model, x) -> scalar; got {fn!r}.")
        for name, value in (("t_min", t_min), ("t_max", t_max)):
            if value is not None and (
                isinstance(value, (bool, str)) or not isinstance(value, numbers.Real) or not math.isfinite(value)
            ):
                raise ValueError(f"{name} must be a time [s] or None; got {value!r}.")
        if t_min is not None and t_max is not None and not t_max > t_min:
            raise ValueError(f"t_max must exceed t_min; got the window [{t_min}, {t_max}] s.")
        self.fn = fn
        self.t_min = None if t_min is None else float(t_min)
        self.t_max = None if t_max is None else float(t_max)

    def __call__(self, sol: Solution) -> jax.Array:
        """The value the solve recorded for this metric (`Solution.records`)."""
        for name, record in sol.declared:
            if record == self:
                return sol.records[name]
        raise ValueError(
            "This metric was not recorded by the solve: declare it before, as simulate(..., "
            "options=jaxbearing.SolveOptions(records={'name': metric})) (jaxbearing.sweep, "
            "sensitivity and tune declare the metrics they are given)."
        )

    def _window(self):
        return ("model" if self.t_min is None else self.t_min), self.t_max


@final
class Peak(_Own):
    """The largest value over the window of ``fn(model, x)`` (x: the `solution.Instant` of each
    recorded point), recorded like the built-in exact peaks: at every accepted step's end, its 3
    Gauss–Legendre points and, where the step may hold a new peak between them, the vertex of a
    parabola through them. Window from ``t_min`` to ``t_max`` [s]: None, the model's
    ``window_start`` (t0 without one) and t1."""

    reduction = "peak"

    def read(self, sol: Solution, column: int) -> jax.Array:
        return _peak(sol, column, *self._window())


@final
class Mean(_Own):
    """The time mean over the window of ``fn(model, x)`` (x: the `solution.Instant`), by 3-point
    Gauss–Legendre quadrature of every accepted step's interpolant (exact for integrands of
    degree <= 5 over a step). Window as `Peak`'s."""

    reduction = "mean"

    def read(self, sol: Solution, column: int) -> jax.Array:
        total, duration = _integral(sol, column, *self._window())
        return total / duration


def max_drift(sol: Solution) -> jax.Array:
    """The largest constraint violation max |Phi(q, t)| [m or rad] at the end of every accepted
    step of the whole run (`Solution.max_drift`; `solution.drift_bound` says how much is too
    much). A sweep records it for every member."""
    return sol.max_drift


STANDARD = {
    "peak_ball_load": peak_ball_load,
    "peak_bearing_force": peak_bearing_force,
    "rms_bearing_force": rms_bearing_force,
    "peak_impact_force": peak_impact_force,
    "max_target_displacement": max_target_displacement,
}
"""The standard metrics (name -> function of a Solution), used by default in sweeps."""

SMOOTH = {
    "smooth_peak_ball_load": smooth_peak_ball_load,
    "smooth_peak_bearing_force": smooth_peak_bearing_force,
    "rms_bearing_force": rms_bearing_force,
    "smooth_peak_impact_force": smooth_peak_impact_force,
}
"""Differentiable metrics, for gradients and optimisation."""


CONVERGED_SPREAD = 1e-3  # relative spread of a metric over tolerances below which it is converged


@dataclasses.dataclass(frozen=True)
class Convergence:
    """What `converged` found: the metric at each relative tolerance, their relative spread
    (max - min) / max |value| (NaN if a value is not finite), and whether it is at most the
    tolerance asked for."""

    rtols: tuple[float, ...]
    values: tuple[float, ...]
    spread: float
    converged: bool


def converged(
    model, metric, t1, rtols=(1e-8, 1e-10), tolerance=CONVERGED_SPREAD, ts=None, **simulate_kwargs
) -> Convergence:
    """Whether ``metric`` of ``model`` simulated to ``t1`` [s] is converged in the solver's
    tolerance: it is computed at each relative tolerance of ``rtols`` (absolute tolerance
    rtol / 100 [m, rad, m/s], the ratio of `default_controller`'s defaults) and is converged
    when the values' relative spread is at most ``tolerance`` (default `CONVERGED_SPREAD`).

    A metric that moves with the tolerance by more than that (a peak of a chaotic rattle, a
    very stiff contact) is not a result at any one tolerance: tighten the tolerances, shorten
    the span or report the spread with the value. ``metric`` is a function of a `Solution`
    (or a `WithModel`); ``ts`` and ``simulate_kwargs`` go to `simulate`, which runs once per
    tolerance (one compilation for all)."""
    from .solve import default_controller, simulate  # the metrics alone never import the solver
    from .solve._options import declaring

    rtols = tuple(float(r) for r in rtols)
    if len(rtols) < 2:
        raise ValueError(f"rtols must hold at least two relative tolerances; got {rtols}.")
    if not tolerance > 0:
        raise ValueError(f"tolerance must be a relative spread > 0; got {tolerance!r}.")
    if "stepsize_controller" in simulate_kwargs:
        raise TypeError("converged sets the step-size controller itself, one for each of rtols.")
    options = declaring(simulate_kwargs.pop("options", None), (("metric", metric),))
    values = []
    for rtol in rtols:
        controller = default_controller(rtol=rtol, atol=rtol / 100)
        sol = simulate(model, t1, ts, stepsize_controller=controller, options=options, **simulate_kwargs)
        values.append(float(metric(sol, model) if isinstance(metric, WithModel) else metric(sol)))
    v = np.asarray(values)
    scale = np.abs(v).max()
    if not np.isfinite(v).all():
        spread = np.nan
    else:
        spread = 0.0 if scale == 0 else float((v.max() - v.min()) / scale)
    return Convergence(rtols, tuple(values), spread, bool(spread <= tolerance))

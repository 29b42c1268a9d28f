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

Every metric is an `AbstractMetric`: the built-ins are instances of `BuiltinMetric` (called as
functions, ``peak_ball_load(sol, t_min, t_max, bearing=1)``; ``peak_ball_load.replace(bearing=1)``
is the metric with other defaults), `Peak` and `Mean` are metrics of your own that the solve
records, and `jaxbearing.life.metric` is the bearing life, which reads the model too. A plain
function of a `Solution` is a metric that reads the output samples (`as_metric`).
`jaxbearing.sweep`, `jaxbearing.sensitivity` and `converged` ask a metric what it needs of the
solve (`AbstractMetric.records`, ``edges``, ``reads_samples``, ``reads_fatigue``) and its
``value(sol, model)``.

`converged` says whether a metric is a result at all: it simulates the model at several solver
tolerances and compares the metric's values (docs/metrics.md).
"""

from __future__ import annotations

import abc
import dataclasses
import functools
import inspect
import itertools
import math
import numbers
from collections.abc import Callable
from typing import ClassVar, final

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from ._checks import is_concrete, to_float64
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


class AbstractMetric(eqx.Module):
    """A scalar metric of a `Solution`, the one kind `jaxbearing.sweep`, `jaxbearing.sensitivity`
    and `converged` take: they ask it what the solve must record (`records`, `edges`, the flags
    ``reads_samples``: it reads the output samples; ``reads_fatigue``: it reads the bearings'
    `solution.FatigueStats`), then its `value`, and name it by its `label`. Hashable and
    compared by value (static fields only). A metric that needs the model (its parameters
    seen by derivatives and sweeps) is a subclass whose `value` reads ``model``."""

    reads_samples: eqx.AbstractClassVar[bool]
    reads_fatigue: eqx.AbstractClassVar[bool]

    @abc.abstractmethod
    def value(self, sol: Solution, model) -> jax.Array:
        """The metric of ``sol``, a solution of ``model``: a float64 scalar."""

    def edges(self) -> tuple[float, ...]:
        """Window edges [s] the solve must stop at, given as numbers (none by default)."""
        return ()

    def records(self) -> tuple:
        """((name, `solution.AbstractRecord`), ...) to declare before the solve (none by
        default)."""
        return ()

    @property
    def label(self) -> str:
        """How a sweep's manifest names the metric: its class and fields."""
        return " ".join(repr(self).split())


def finite_numbers(*values) -> tuple[float, ...]:
    """The finite real numbers (not bools) among ``values``, as floats: window edges [s]."""
    return tuple(
        float(v) for v in values
        if isinstance(v, numbers.Real) and not isinstance(v, bool) and math.isfinite(v)
    )  # fmt: skip


def _time(name, value, allowed, *, model=False):
    """``value`` of the field ``name`` checked as a window edge [s] (a finite number, None, or
    "model" where ``model``): a float, or a ValueError saying ``allowed``."""
    if value is None or (model and isinstance(value, str) and value == "model"):
        return value
    if not finite_numbers(value):
        raise ValueError(f"{name} must be {allowed}; got {value!r}.")
    return float(value)


def _index(name, value):
    """``value`` of the field ``name`` checked as None or an index (an integer >= 0); the
    model's count is checked when the metric is computed."""
    if value is None:
        return None
    if isinstance(value, bool) or not isinstance(value, numbers.Integral) or value < 0:
        raise ValueError(
            f"{name} must be None (the only one) or an index, an integer >= 0; got {value!r}."
        )
    return int(value)


def _field(name, value):
    """A field of a `BuiltinMetric` checked (`BuiltinMetric.replace`)."""
    if name == "t_min":
        start = 'a time [s], "model" (the model\'s window_start) or None (from t0)'
        return _time(name, value, start, model=True)
    if name == "t_max":
        return _time(name, value, "a time [s] or None (to the end of the run)")
    if name == "p":
        if not finite_numbers(value) or float(value) != POWER:
            raise ValueError(f"p must be {POWER}, the order the solution records; got {value!r}.")
        return float(value)
    if name == "metric":
        return _exact_peak(value)
    return _index(name, value)  # bearing, contact, coordinate


def _shown(value) -> str:
    """A field's value as a label shows it."""
    return value.label if isinstance(value, AbstractMetric) else repr(value)


class BuiltinMetric(AbstractMetric):
    """One of jaxbearing's metrics (`peak_ball_load`, `STANDARD`, `SMOOTH`, ...): a function of a
    `Solution` whose other arguments (``t_min``, ``t_max``, ``bearing``, ``contact``,
    ``coordinate``, ``p``, ``metric``) are its fields. Calling it calls the function with the
    fields as the defaults of the call; `replace` returns the metric with other fields, which is
    what a sweep, `jaxbearing.sensitivity` or `converged` takes:
    ``peak_ball_load.replace(bearing=1, t_min=0.05)``. Fields are readable as attributes
    (``peak_ball_load.t_min``). It reads the solve's records, not the output samples."""

    function: Callable = eqx.field(static=True)
    arguments: tuple = eqx.field(static=True)  # ((name, value), ...) in the call's order
    reads_samples: ClassVar[bool] = False
    reads_fatigue: ClassVar[bool] = False

    def __call__(self, sol: Solution, *args, **kwargs) -> jax.Array:
        """The metric of ``sol``; arguments not given take the fields' values."""
        given = inspect.signature(self.function).bind_partial(sol, *args, **kwargs).arguments
        return self.function(**{**dict(self.arguments), **given})

    def __getattr__(self, name):
        for field, value in self.__dict__.get("arguments", ()):
            if field == name:
                return value
        raise AttributeError(name)

    def value(self, sol: Solution, model) -> jax.Array:
        """The metric of ``sol`` with the fields' values (``model`` is not read)."""
        return self(sol)

    def edges(self) -> tuple[float, ...]:
        """``t_min`` and ``t_max`` where numbers, and those of a ``metric`` field [s]."""
        fields = dict(self.arguments)
        inner = fields.get("metric")
        own = finite_numbers(fields.get("t_min"), fields.get("t_max"))
        return own + (() if inner is None else inner.edges())

    def replace(self, **fields) -> BuiltinMetric:
        """This metric with the ``fields`` given (each checked: a ValueError naming it and what
        is allowed; an index is checked against the model when the metric is computed)."""
        current = dict(self.arguments)
        unknown = sorted(set(fields) - set(current))
        if unknown:
            raise TypeError(
                f"{self.function.__name__} has no field {', '.join(unknown)}; its fields: "
                f"{', '.join(current) or 'none'}."
            )
        current.update({name: _field(name, value) for name, value in fields.items()})
        t_min, t_max = current.get("t_min"), current.get("t_max")
        if finite_numbers(t_min) and finite_numbers(t_max) and not t_max > t_min:
            raise ValueError(f"t_max must exceed t_min; got the window [{t_min}, {t_max}] s.")
        return BuiltinMetric(self.function, tuple(current.items()))

    @property
    def label(self) -> str:
        """The function's name and the fields that differ from its defaults, e.g.
        ``peak_ball_load(t_min=0.05, bearing=1)``."""
        defaults = dict(_defaults(self.function))
        changed = [f"{k}={_shown(v)}" for k, v in self.arguments if v != defaults[k]]
        name = self.function.__name__
        return f"{name}({', '.join(changed)})" if changed else name

    def __repr__(self) -> str:
        return f"jaxbearing.metrics.{self.label}"


def _defaults(function) -> tuple:
    """((name, default), ...) of ``function``'s arguments after the solution."""
    parameters = list(inspect.signature(function).parameters.values())[1:]
    return tuple((p.name, p.default) for p in parameters)


def _builtin(function) -> BuiltinMetric:
    """``function`` of a `Solution` as a `BuiltinMetric` whose fields are its defaults."""
    return BuiltinMetric(function, _defaults(function))


@final
class SampledMetric(AbstractMetric):
    """A function of a `Solution`, ``fn(sol) -> scalar``, as a metric (`as_metric`): it may read
    the output samples (``sol.ts``, ``sol.q``, ...), so a sweep solves its members with output
    times; no window edge is seen, nothing is declared, no fatigue is recorded for it. A
    `functools.partial` is such a function too: its keywords are not read (pass
    ``peak_ball_load.replace(t_min=0.05)``, not a partial, for the sweep to see the edge)."""

    fn: Callable = eqx.field(static=True)
    reads_samples: ClassVar[bool] = True
    reads_fatigue: ClassVar[bool] = False

    def value(self, sol: Solution, model) -> jax.Array:
        """``fn(sol)`` (``model`` is not read)."""
        return self.fn(sol)

    @property
    def label(self) -> str:
        """``module.qualname`` of the function (its repr where it has none)."""
        name = getattr(self.fn, "__qualname__", None)
        return repr(self.fn) if name is None else f"{getattr(self.fn, '__module__', '?')}.{name}"


def as_metric(metric, name: str = "metric") -> AbstractMetric:
    """``metric`` as an `AbstractMetric`: itself, or a function of a `Solution` as a
    `SampledMetric`; a TypeError naming the argument ``name`` otherwise."""
    if isinstance(metric, AbstractMetric):
        return metric
    if not callable(metric):
        raise TypeError(
            f"{name} must be a metric (a jaxbearing.metrics.AbstractMetric, e.g. "
            f"jaxbearing.metrics.peak_ball_load.replace(bearing=1)) or a function of a Solution; "
            f"got {metric!r}."
        )
    return SampledMetric(metric)


def solve_options(options, metrics, t1, window_start=None):
    """``options`` (None: the defaults) with what ``metrics`` (`AbstractMetric`) need of a solve
    from ``options.t0`` to ``t1`` [s]: their `records` declared, and their `edges` inside (t0,
    t1) that are not stops already (t0, t1, ``window_start`` [s] unless None, the
    ``window_edges``) added to ``window_edges``, so that their windows end on stops. A record
    declared already is not declared again; a name taken already gets a number (``#2``, ...),
    in the order of ``metrics``, so that a sweep's settings are the same in every process."""
    from .solve._options import SolveOptions, declaring  # the metrics alone never import the solver

    options = SolveOptions() if options is None else options
    declared = list(options.records)
    for name, record in (r for m in metrics for r in m.records()):
        if any(record == other for _, other in declared):
            continue
        taken = {n for n, _ in declared}
        numbered = (f"{name}#{k}" for k in itertools.count(2))
        unique = name if name not in taken else next(n for n in numbered if n not in taken)
        declared.append((unique, record))
    options = declaring(options, tuple(declared[len(options.records):]))
    t0, t1 = float(options.t0), float(t1)
    start = [] if window_start is None else [float(window_start)]
    stops = [t0, t1, *options.window_edges, *start]
    new = sorted({
        e for m in metrics for e in m.edges()
        if t0 < e < t1 and all(abs(e - s) > EDGE_TOLERANCE for s in stops)
    })  # fmt: skip
    if not new:
        return options
    return dataclasses.replace(options, window_edges=(*options.window_edges, *new))


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


def checked_window(sol: Solution, t_min, t_max):
    """`window_edges` for a jitted metric of ``sol``, after the window's checks (`_inside`),
    which run in NumPy where ``sol`` and the window are known in Python."""
    _inside(sol, t_min, t_max)
    return window_edges(sol, t_min, t_max)


def window_edges(sol: Solution, t_min, t_max):
    """The window's edges (lo, hi) [s] as float64 scalars (``"model"``: the model's
    ``window_start``; None: -inf, +inf)."""
    lo = window_start(sol, t_min)
    return (
        _window_edge("t_min", -np.inf if lo is None else lo, "a time"),
        _window_edge("t_max", np.inf if t_max is None else t_max, "a time"),
    )


def reached(sol: Solution, t_max):
    """Whether the run reached the end of a window that ends at ``t_max`` [s] (None: the t1
    asked for; a later t_max counts as t1). A run that stopped short (``throw=False``) has no
    metric there: a `SimulationError` saying when and why it stopped where that is known in
    Python; traced, False (the metric is NaN)."""
    if t_max is not None:
        t_max = _window_edge("t_max", t_max, _END_IS)
    xp = np if is_concrete(sol.t_final, sol.t1, t_max) else jnp  # NumPy compiles nothing
    t1 = xp.asarray(sol.t1)
    end = t1 if t_max is None else xp.minimum(t_max, t1)
    ok = xp.asarray(sol.t_final) >= end - EDGE_TOLERANCE
    if xp is np and not bool(ok):
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
    concrete = is_concrete(t_min, t_max, stats.valid, stats.t_start, stats.t_end)
    xp = np if concrete else jnp  # NumPy compiles nothing
    valid, t_start, t_end = (xp.asarray(x) for x in (stats.valid, stats.t_start, stats.t_end))
    start = xp.min(xp.where(valid, t_start, xp.inf))
    end = xp.max(xp.where(valid, t_end, -xp.inf))

    def is_edge(t, ends):
        near = valid & (xp.abs(ends - t) <= EDGE_TOLERANCE)
        return (t <= start + EDGE_TOLERANCE) | (t >= end - EDGE_TOLERANCE) | xp.any(near)

    edges = ((t_min, is_edge(t_min, t_start)), (t_max, is_edge(t_max, t_end)))
    ok = edges[0][1] & edges[1][1]
    if concrete and not bool(ok):
        missing = tuple(float(t) for t, edge in edges if not bool(edge))
        raise ValueError(
            f"The window [{float(t_min)}, {float(t_max)}] s needs its edges to be ends of the "
            f"solution's {name} (not: {', '.join(map(str, missing))} s): pass the edges to "
            f"simulate, as simulate(..., options=jaxbearing.SolveOptions(window_edges={missing}))."
        )
    inside = valid & (t_start >= t_min - EDGE_TOLERANCE) & (t_end <= t_max + EDGE_TOLERANCE)
    _check_not_empty(xp.any(inside), t_min, t_max, start, end, "part of the solved span")
    return inside, ok


def _window_edge(name, value, what) -> jax.Array:
    """A window edge [s] as a float64 scalar (NumPy where known in Python: compiles nothing); a
    ValueError saying what it must be."""
    edge = None
    if not isinstance(value, (bool, str, type(None))):
        xp = np if is_concrete(value) else jnp
        try:
            edge = xp.asarray(value, xp.float64)
        except (TypeError, ValueError):
            pass
    if edge is None or edge.ndim != 0:
        raise ValueError(f"{name} must be a time [s], one number, {what}; got {value!r}.")
    return edge


def _peak(sol: Solution, column, t_min, t_max):
    """Max of ``segments.peaks[:, column]`` over the window; NaN if the window has no value.
    ``column`` None (an element the model lacks): 0. One jitted call after the window's
    checks."""
    return _peak_of(sol, *checked_window(sol, t_min, t_max), column)


@functools.partial(jax.jit, static_argnums=3)
def _peak_of(sol: Solution, lo, hi, column):
    """`_peak` over the window [lo, hi] [s]."""
    inside, ok = _inside(sol, lo, hi)
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
    """FORCE_SCALE (integral / (count T))^(1/p) [N] of a recorded power integral, one jitted
    call after the checks."""
    if is_concrete(p) and float(p) != POWER:
        raise ValueError(
            f"The solution records power means of order p = {POWER} only; got p = {p}."
        )
    return _power_mean_of(sol, *checked_window(sol, t_min, t_max), column, count)


@functools.partial(jax.jit, static_argnums=(3, 4))
def _power_mean_of(sol: Solution, lo, hi, column, count):
    total, duration = _integral(sol, column, lo, hi)
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


@_builtin
def peak_ball_load(sol: Solution, t_min="model", t_max=None, *, bearing=None) -> jax.Array:
    """Largest load on any ball [N] of a bearing joint (``bearing``: index into
    ``model.bearings``; None: the only one) in the window, the maximum of each solver step's
    interpolant (`SegmentStats`)."""
    return _peak(sol, _column(sol, "ball_load", bearing_index(sol, bearing)), t_min, t_max)


@_builtin
def peak_bearing_force(sol: Solution, t_min="model", t_max=None, *, bearing=None) -> jax.Array:
    """Largest magnitude |F| of a bearing joint's resultant (Eq. 28) [N] in the window, the
    maximum of each solver step's interpolant (`SegmentStats`); ``bearing`` as in
    `peak_ball_load`."""
    return _peak(sol, _column(sol, "bearing_force", bearing_index(sol, bearing)), t_min, t_max)


@_builtin
def rms_bearing_force(sol: Solution, t_min="model", t_max=None, *, bearing=None) -> jax.Array:
    """Root-mean-square of a bearing joint's |F| over the window (time-weighted) [N]:
    Gauss–Legendre quadrature of each step's interpolant (exact for integrands of degree <= 5
    over a step). Smooth. ``bearing`` as in `peak_ball_load`."""
    column = integral_column("force_squared", bearing_index(sol, bearing), sol.n_bearings)
    return _rms_of(sol, *checked_window(sol, t_min, t_max), column)


@functools.partial(jax.jit, static_argnums=3)
def _rms_of(sol: Solution, lo, hi, column):
    total, duration = _integral(sol, column, lo, hi)
    return jnp.sqrt(total / duration)


@_builtin
def peak_impact_force(sol: Solution, t_min="model", t_max=None, *, contact=None) -> jax.Array:
    """Largest normal impact force [N] of a contact (``contact``: index into
    ``model.contacts``; None: the only one) in the window, the maximum of each solver step's
    interpolant (`SegmentStats`), so independent of the output times; 0 for a model without
    contact (nothing is struck)."""
    return _peak(sol, _column(sol, "contact_force", contact_index(sol, contact)), t_min, t_max)


def _coordinate(sol: Solution, coordinate) -> int:
    """``coordinate`` checked as an index into q."""
    n = sol.q.shape[-1]
    integral = isinstance(coordinate, numbers.Integral) and not isinstance(coordinate, bool)
    if not (integral and 0 <= coordinate < n):
        raise ValueError(
            f"coordinate must be an index into q, an integer in [0, {n}); got {coordinate!r}."
        )
    return int(coordinate)


@_builtin
def max_target_displacement(
    sol: Solution, t_min="model", t_max=None, coordinate=None, *, contact=None
) -> jax.Array:
    """Largest |q_c(t) - q_c(t0)| [m or rad] of one coordinate in the window, the maximum of
    each solver step's interpolant (`SegmentStats`). Default coordinate: the x of the impact
    target of ``contact`` (`Solution.targets`; None: the only contact; in `cases.xu2014` the
    target, body 3); a model without impact contact has no target, and the value is 0 (nothing
    is struck), as `peak_impact_force`'s."""
    if coordinate is not None:
        return _peak(sol, _column(sol, "displacement", _coordinate(sol, coordinate)), t_min, t_max)
    c = contact_index(sol, contact)
    target = None if c is None else sol.targets[c]
    return _peak(sol, _column(sol, "displacement", target), t_min, t_max)


def _exact_peak(metric) -> BuiltinMetric:
    """``metric`` checked to be an exact peak (`peak_ball_load`, `peak_bearing_force`,
    `peak_impact_force`, `max_target_displacement`, or one of them replaced)."""
    exact = (peak_ball_load, peak_bearing_force, peak_impact_force, max_target_displacement)
    functions = [m.function for m in exact]
    if not (isinstance(metric, BuiltinMetric) and any(metric.function is f for f in functions)):
        given = f"the string {metric!r}" if isinstance(metric, str) else repr(metric)
        raise ValueError(
            "metric must be an exact peak (the metric, not its name): "
            "jaxbearing.metrics.peak_ball_load, peak_bearing_force, peak_impact_force or "
            f"max_target_displacement, or one of them .replace(...)d; got {given}."
        )
    return metric


def _peak_column(sol: Solution, metric: BuiltinMetric, bearing, contact, coordinate) -> int | None:
    """The `SegmentStats` column of the exact peak ``metric`` of the element named (None: an
    element the model lacks)."""
    if metric.function in (peak_ball_load.function, peak_bearing_force.function):
        kind = "ball_load" if metric.function is peak_ball_load.function else "bearing_force"
        return _column(sol, kind, bearing_index(sol, bearing))
    if metric.function is peak_impact_force.function:
        return _column(sol, "contact_force", contact_index(sol, contact))
    if coordinate is not None:
        return _column(sol, "displacement", _coordinate(sol, coordinate))
    c = contact_index(sol, contact)
    if c is None:
        raise ValueError("This solution has no impact target (its model has no contact).")
    return _column(sol, "displacement", sol.targets[c])


def _either(name, own, default, theirs):
    """peak_time's ``own`` value of field ``name``, or its metric's (``theirs``) where ``own``
    is the default; a ValueError where both are set and differ."""
    def is_default(v):
        return v is None if default is None else (isinstance(v, str) and v == default)

    if is_default(own):
        return theirs
    same = finite_numbers(own) and finite_numbers(own) == finite_numbers(theirs)
    if is_default(theirs) or same:
        return own
    raise ValueError(
        f"peak_time got {name}={own!r} and a metric with {name}={theirs!r}: give {name} once."
    )


def _where_peak(sol: Solution, column, t_min, t_max):
    """(interval attaining the peak of ``column`` in the window (the earliest of equals), the
    peak, and whether the window has a value)."""
    inside, ok = _inside(sol, t_min, t_max)
    peaks = jnp.where(inside, sol.segments.peaks[:, column], -jnp.inf)
    i = jnp.argmax(peaks)
    return i, peaks[i], ok & jnp.any(inside)


@_builtin
def peak_time(
    sol: Solution, metric=None, t_min="model", t_max=None, *, bearing=None, contact=None
) -> jax.Array:
    """Time [s] at which the exact peak ``metric`` (`peak_ball_load`, `peak_bearing_force`,
    `peak_impact_force`, or `max_target_displacement`; of the bearing joint or contact named by
    ``bearing`` / ``contact`` as there, or by the metric's own fields:
    ``peak_time(sol, peak_ball_load.replace(bearing=1))`` is bearing 1's) is attained in the
    window: the earliest recorded point that attains it (`SegmentStats.peak_times`), so
    independent of the output times; NaN where the peak is 0 (the element never acted in the
    window: no impact). The window and the element are peak_time's where given, else the
    metric's. No derivative: the point that attains a maximum jumps between steps. In a sweep,
    pass ``peak_time.replace(metric=peak_impact_force)``."""
    metric = _exact_peak(metric)
    theirs = dict(metric.arguments)
    t_min = _either("t_min", t_min, "model", theirs["t_min"])
    t_max = _either("t_max", t_max, None, theirs["t_max"])
    bearing = _either("bearing", bearing, None, theirs.get("bearing"))
    contact = _either("contact", contact, None, theirs.get("contact"))
    column = _peak_column(sol, metric, bearing, contact, theirs.get("coordinate"))
    edges = checked_window(sol, t_min, t_max)
    if column is None:  # no contact: nothing was struck, at no time
        return to_float64(np.nan)
    return _peak_time_of(sol, *edges, column)


@functools.partial(jax.jit, static_argnums=3)
def _peak_time_of(sol: Solution, lo, hi, column):
    i, peak, has_value = _where_peak(sol, column, lo, hi)
    time = jax.lax.stop_gradient(sol.segments.peak_times[i, column])
    return jnp.where(has_value & (peak > 0.0), time, jnp.nan)


@_builtin
def loads_at_peak(sol: Solution, t_min="model", t_max=None, *, bearing=None) -> jax.Array:
    """Every ball's load [N] of a bearing joint (``bearing`` as in `peak_ball_load`) at the time
    of its `peak_ball_load` in the window (its `peak_time`), (N_b,), ball 1 first: the load
    distribution at the worst instant (`SegmentStats.peak_loads`); NaN for a window without
    value (traced). A vector: in a sweep, take one ball's entry."""
    b = bearing_index(sol, bearing)
    return _loads_at_peak_of(sol, *checked_window(sol, t_min, t_max), b)


@functools.partial(jax.jit, static_argnums=3)
def _loads_at_peak_of(sol: Solution, lo, hi, b):
    i, _, has_value = _where_peak(sol, _column(sol, "ball_load", b), lo, hi)
    return jnp.where(has_value, sol.segments.peak_loads[b][i], jnp.nan)


@_builtin
def peak_ball(sol: Solution, t_min="model", t_max=None, *, bearing=None) -> jax.Array:
    """The ball that carries `peak_ball_load` in the window: its column of the bearing's
    ``ball_loads`` (0 = ball 1), an int; -1 for a window without value (traced)."""
    b = bearing_index(sol, bearing)
    return _peak_ball_of(sol, *checked_window(sol, t_min, t_max), b)


@functools.partial(jax.jit, static_argnums=3)
def _peak_ball_of(sol: Solution, lo, hi, b):
    loads = _loads_at_peak_of(sol, lo, hi, b)
    return jnp.where(jnp.isnan(loads[0]), -1, jnp.argmax(loads))


@_builtin
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


@_builtin
def smooth_peak_bearing_force(
    sol: Solution, t_min="model", t_max=None, p=16.0, *, bearing=None
) -> jax.Array:
    """Power mean of order p of a bearing joint's |F| over the window [N]: differentiable
    stand-in for the peak. Gauss–Legendre quadrature of each step's interpolant; p must be
    `solution.POWER` (16)."""
    column = integral_column("force_power", bearing_index(sol, bearing), sol.n_bearings)
    return _power_mean(sol, column, t_min, t_max, p)


@_builtin
def smooth_peak_impact_force(
    sol: Solution, t_min="model", t_max=None, p=16.0, *, contact=None
) -> jax.Array:
    """Power mean of order p of a contact's impact force (``contact`` as in
    `peak_impact_force`) over the window [N]. Gauss–Legendre quadrature of each step's
    interpolant; p must be `solution.POWER` (16); 0 for a model without contact."""
    c = contact_index(sol, contact)
    column = None if c is None else integral_column("contact_force_power", c, sol.n_bearings)
    return _power_mean(sol, column, t_min, t_max, p)


class _Own(AbstractRecord, AbstractMetric):
    """What `Peak` and `Mean` share: declared by name before the solve
    (``SolveOptions(records={name: metric})``, or by a sweep, `jaxbearing.sensitivity` and
    `converged` from `records`), recorded from every accepted step, and read from the
    solution (`value`, or calling the metric on it)."""

    reads_samples: ClassVar[bool] = False
    reads_fatigue: ClassVar[bool] = False

    def __init__(self, fn: Callable, t_min: float | None = None, t_max: float | None = None):
        if not callable(fn):
            raise TypeError(f"fn must be a function fn(model, x) -> scalar; got {fn!r}.")
        t_min, t_max = (
            _time(k, v, "a time [s] or None") for k, v in (("t_min", t_min), ("t_max", t_max))
        )
        if t_min is not None and t_max is not None and not t_max > t_min:
            raise ValueError(f"t_max must exceed t_min; got the window [{t_min}, {t_max}] s.")
        self.fn = fn
        self.t_min = t_min
        self.t_max = t_max

    def __call__(self, sol: Solution) -> jax.Array:
        """The value the solve recorded for this metric (`Solution.records`)."""
        for name, record in sol.declared:
            if record == self:
                return sol.records[name]
        raise ValueError(
            "This metric was not recorded by the solve: declare it before, as simulate(..., "
            "options=jaxbearing.SolveOptions(records={'name': metric})) (jaxbearing.sweep, "
            "sensitivity and converged declare the metrics they are given)."
        )

    def value(self, sol, model) -> jax.Array:
        """The value the solve recorded in ``sol``, a solution of ``model`` (as calling it)."""
        return self(sol)

    def records(self) -> tuple:
        """This metric under its label (`solve_options` numbers labels that repeat)."""
        return ((self.label, self),)

    @property
    def label(self) -> str:
        """``Peak(fn)`` or ``Mean(fn)``, with the window where given."""
        name = getattr(self.fn, "__qualname__", None) or repr(self.fn)
        edges = (("t_min", self.t_min), ("t_max", self.t_max))
        window = [f"{k}={v!r}" for k, v in edges if v is not None]
        return f"{type(self).__name__}({', '.join([name, *window])})"

    def replace(self, **fields):
        """This metric with other ``fn``, ``t_min`` or ``t_max`` (checked as by the constructor)."""
        current = {"fn": self.fn, "t_min": self.t_min, "t_max": self.t_max}
        unknown = sorted(set(fields) - set(current))
        if unknown:
            raise TypeError(
                f"{type(self).__name__} has no field {', '.join(unknown)}; its fields: fn, "
                "t_min, t_max."
            )
        return type(self)(**{**current, **fields})

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


@_builtin
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
"""The standard metrics (name -> `BuiltinMetric`), used by default in sweeps."""

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
    the span or report the spread with the value. ``metric`` is an `AbstractMetric` (declared,
    its window edges added to the solve's stops: `solve_options`) or a function of a
    `Solution`; ``ts`` and ``simulate_kwargs`` go to `simulate`, which runs once per tolerance
    (one compilation for all)."""
    from .solve import default_controller, simulate  # the metrics alone never import the solver

    rtols = tuple(float(r) for r in rtols)
    if len(rtols) < 2:
        raise ValueError(f"rtols must hold at least two relative tolerances; got {rtols}.")
    if not tolerance > 0:
        raise ValueError(f"tolerance must be a relative spread > 0; got {tolerance!r}.")
    if "stepsize_controller" in simulate_kwargs:
        raise TypeError("converged sets the step-size controller itself, one for each of rtols.")
    metric = as_metric(metric)
    options = solve_options(simulate_kwargs.pop("options", None), (metric,), t1, model.window_start)
    values = []
    for rtol in rtols:
        controller = default_controller(rtol=rtol, atol=rtol / 100)
        sol = simulate(model, t1, ts, stepsize_controller=controller, options=options, **simulate_kwargs)
        values.append(float(metric.value(sol, model)))
    v = np.asarray(values)
    scale = np.abs(v).max()
    if not np.isfinite(v).all():
        spread = np.nan
    else:
        spread = 0.0 if scale == 0 else float((v.max() - v.min()) / scale)
    return Convergence(rtols, tuple(values), spread, bool(spread <= tolerance))

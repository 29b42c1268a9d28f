"""Scalar metrics of a `Solution`, over a time window ``[t_min, t_max]`` [s]: by default
(``t_min="model"``, ``t_max=None``) from the model's ``window_start`` (`Mechanism`; the paper's
case starts it after the start-up transient in which the rod falls onto the race and rings;
None: the whole span) to the end of the solve; ``t_min=None`` starts it with the solve.

They are computed from the solution itself, not from its output times: `simulate` records, per
interval between its stops, the peaks and integrals that each force element declares over
every accepted solver step and the step's interpolant (`solution.ElementRecords`), and a metric
combines the intervals inside its window. So a metric has the same value whatever ``ts`` the
simulation was asked for. A window's edges must be stops: t0, the model's ``window_start`` and
t1 always are, and ``SolveOptions.window_edges`` adds others. An edge that is not raises
ValueError, or, under `jax.jit` / `jax.vmap` where that cannot be checked in Python, makes the
metric NaN (`jaxbearing.sweep` marks such a member failed with the reason,
`jaxbearing.sensitivity` and `jaxbearing.tune` raise it). No warning is issued from inside a
compiled program: its host callback would keep the program out of JAX's persistent
compilation cache.

Metrics of one kind for every element (final Modules, their fields typed and checked):

- `ElementPeak`: the exact peak of one of an element's peak records (`AbstractForceElement.
  peak_records`), the maximum of each step's interpolant (its end, 3 Gauss–Legendre points
  and, where the step may hold a new peak between them, the vertex of a parabola through
  them, the interpolant's maximum to third order): differentiable almost everywhere, with the
  derivative of the point that attains the maximum, which jumps when another point takes
  over; fine for sensitivities at one design point, poor for optimisation;
- `PowerMean`: the power mean (scale (1/T integral (x/scale)^p dt)^(1/p)) of one of an
  element's power integrals over the window of duration T: the RMS (p = 2), or a smooth,
  differentiable stand-in for a peak (p = `solution.POWER`, below the maximum, closer as p
  grows): use those as objectives for `jax.grad` and optax;
- `CoordinatePeak`: the exact peak of a coordinate's displacement |q_c - q0_c|;
- `PeakTime`, `AtPeak`, `PeakIndex`: when an exact peak is attained (the earliest recorded
  point that attains it; no derivative of the time), the array its record carries then (a
  bearing's element loads), and which entry of it is the largest;
- `Peak` and `Mean`: metrics of your own, ``fn(model, x)`` of each recorded instant;
- `MaxDrift`.

An element is chosen within a view of the model's force elements: ``view="bearings"`` (the
bearing joints, ``bearing=i``), ``"contacts"`` (the impact contacts, ``contact=i``) or
``"elements"`` (all of them, ``element=i`` or a name); None: the only one. The built-ins are
presets of these (`peak_ball_load` is ``ElementPeak("max_element_load", view="bearings")``),
called as functions (``peak_ball_load(sol, t_min, t_max, bearing=1)``) or set with `replace`
(``peak_ball_load.replace(bearing=1)``, what a sweep takes). A plain function of a `Solution`
is a metric that reads the output samples (`as_metric`); `jaxbearing.life.metric` is the
bearing life, which reads the model too. `jaxbearing.sweep`, `jaxbearing.sensitivity` and
`converged` ask a metric what it needs of the solve (`AbstractMetric.records`, ``edges``,
``reads_samples``, ``reads_fatigue``) and its ``value(sol, model)``.

Forces in N, displacements in m. A window that holds none of the solved span (e.g. a run that
ends before the default t_min) has no value: with a concrete solution and window the metric
raises a `ValueError` naming ``t_min`` and the span; traced (under jit or vmap, in sweeps) it
is NaN, as above.

`converged` says whether a metric is a result at all: it simulates the model at several solver
tolerances and compares the metric's values (docs/metrics.md).
"""

from __future__ import annotations

import abc
import dataclasses
import functools
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
from ._options import SolveOptions, declaring
from .simulation import default_controller, simulate
from .solution import EDGE_TOLERANCE, RESULTS, AbstractRecord, SimulationError, Solution


class AbstractMetric(eqx.Module):
    """A scalar metric of a `Solution`, the one kind `jaxbearing.sweep`, `jaxbearing.sensitivity`
    and `converged` take: they ask it what the solve must record (`records`, `edges`, the flags
    ``reads_samples``: it reads the output samples; ``reads_fatigue``: it reads the bearings'
    fatigue integrals), then its `value`, and name it by its `label`. Hashable and compared by
    value (static fields only). A metric that needs the model (its parameters seen by
    derivatives and sweeps) is a subclass whose `value` reads ``model``."""

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


_END_IS = "the window's end, or None (to the end of the run)"


def _inside(sol: Solution, t_min, t_max):
    """Which intervals of ``sol.intervals`` lie in ``[t_min, t_max]``, and whether the window
    has a value: both edges are stops (or outside the solved span) and the run reached its end
    (`reached`). SimulationError or ValueError when not and that is known in Python (a run
    that stopped short first: what else is wrong with the window follows from that)."""
    ok = reached(sol, t_max)
    inside, on_stops = intervals_inside(sol.intervals, window_start(sol, t_min), t_max, "stop intervals")
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
    """Whether the run covers a window that ends at ``t_max`` [s] (None or +inf: the t1 asked
    for): the window ends at or before t1, and the run reached its end. A window that ends
    after t1 has no value (the run says nothing of what follows t1): a `ValueError` where that
    is known in Python. A run that stopped short (``throw=False``) has none either: a
    `SimulationError` saying when and why it stopped. Traced, False (the metric is NaN)."""
    if t_max is not None:
        t_max = _window_edge("t_max", t_max, _END_IS)
    xp = np if is_concrete(sol.t_final, sol.t1, t_max) else jnp  # NumPy compiles nothing
    t1 = xp.asarray(sol.t1)
    end = t1 if t_max is None else xp.where(t_max == xp.inf, t1, t_max)
    within = end <= t1 + EDGE_TOLERANCE
    ok = within & (xp.asarray(sol.t_final) >= end - EDGE_TOLERANCE)
    if xp is np and not bool(within):
        raise ValueError(
            f"The window ends at t_max = {float(end):.6g} s, after the end of the run, t1 = "
            f"{float(t1):.6g} s: the run says nothing of what follows t1. Pass t_max <= t1 "
            "(None: to the end of the run), or simulate to a later t1."
        )
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
    """Which intervals of ``stats`` (fields t_start, t_end, valid: `solution.Intervals`,
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


VIEWS = {"bearings": "bearing", "contacts": "contact", "elements": "element"}
"""The views of a model's force elements a metric chooses its element in, and the keyword
that names the element in each."""

_UNSET = object()  # a keyword the call did not give

_START_IS = 'a time [s], "model" (the model\'s window_start) or None (from t0)'
_STOP_IS = "a time [s] or None (to the end of the run)"


def _time(name, value, allowed, *, model=False):
    """``value`` of the field ``name`` checked as a window edge [s] (a number, +-inf included,
    None, or "model" where ``model``): a float, or a ValueError saying ``allowed``."""
    if value is None or (model and isinstance(value, str) and value == "model"):
        return value
    real = isinstance(value, numbers.Real) and not isinstance(value, bool)
    if not real or math.isnan(value):
        raise ValueError(f"{name} must be {allowed}; got {value!r}.")
    return float(value)


def _element_key(name, value, view):
    """``value`` of the element keyword ``name`` checked: None (the only one), an index (an
    integer >= 0), or in the ``"elements"`` view a name; the model's count is checked when
    the metric is computed."""
    if value is None:
        return None
    if view == "elements" and isinstance(value, str) and value:
        return value
    if isinstance(value, bool) or not isinstance(value, numbers.Integral) or value < 0:
        names = " or an element's name" if view == "elements" else ""
        raise ValueError(
            f"{name} must be None (the only one) or an index, an integer >= 0{names}; got {value!r}."
        )
    return int(value)


class _Windowed(AbstractMetric):
    """What the metrics over a window share: ``t_min``, ``t_max`` [s] (checked), the
    ``preset`` name they are labelled by (None: their class), the call with the window and
    other fields as keywords, and `replace`. Subclasses list their keyword fields in
    ``_keywords`` (the window's first), with their defaults as a preset's."""

    _keywords: ClassVar[tuple[str, ...]]
    reads_samples: ClassVar[bool] = False
    reads_fatigue: ClassVar[bool] = False

    def edges(self) -> tuple[float, ...]:
        """``t_min`` and ``t_max`` where numbers [s]."""
        return finite_numbers(self.t_min, self.t_max)

    def _check_window(self):
        if finite_numbers(self.t_min) and finite_numbers(self.t_max) and not self.t_max > self.t_min:
            raise ValueError(f"t_max must exceed t_min; got the window [{self.t_min}, {self.t_max}] s.")

    def _fields(self) -> dict:
        """The keyword fields, name -> value, as the call and `replace` name them."""
        return {k: getattr(self, k) for k in self._field_names()}

    def _field_names(self) -> tuple[str, ...]:
        return self._keywords

    def replace(self, **fields):
        """This metric with the ``fields`` given (each checked: a ValueError naming it and what
        is allowed; an index is checked against the model when the metric is computed)."""
        current = self._fields()
        unknown = sorted(set(fields) - set(current))
        if unknown:
            raise TypeError(
                f"{self._name()} has no field {', '.join(unknown)}; its fields: "
                f"{', '.join(current) or 'none'}."
            )
        return self._with({**current, **fields})

    @abc.abstractmethod
    def _with(self, fields: dict):
        """This metric with the keyword ``fields`` (all of them), checked."""

    def _name(self) -> str:
        return self.preset or type(self).__name__

    @property
    def label(self) -> str:
        """The preset's name (or the class's) and the fields that differ from its defaults,
        e.g. ``peak_ball_load(t_min=0.05, bearing=1)``."""
        defaults = _PRESETS.get(self.preset)
        base = defaults._fields() if defaults is not None else {}
        changed = [
            f"{k}={_shown(v)}" for k, v in self._fields().items() if k not in base or v != base[k]
        ]
        return f"{self._name()}({', '.join(changed)})" if changed or defaults is None else self._name()

    def __repr__(self) -> str:
        return f"jaxbearing.metrics.{self.label}"


def _shown(value) -> str:
    """A field's value as a label shows it."""
    return value.label if isinstance(value, AbstractMetric) else repr(value)


class _OfElement(_Windowed):
    """A metric of one of a force element's records, ``record`` (its declared name), the
    element chosen within a ``view`` (`VIEWS`) by ``element``; over the window ``t_min``,
    ``t_max`` [s]; labelled by ``preset`` (None: its class)."""

    record: str = eqx.field(static=True)
    view: str = eqx.field(static=True)
    element: int | str | None = eqx.field(static=True)
    t_min: float | str | None = eqx.field(static=True)
    t_max: float | None = eqx.field(static=True)
    preset: str | None = eqx.field(static=True)

    def __init__(self, record: str, view="elements", element=None, t_min="model", t_max=None, preset=None):
        self.record, self.view, self.preset = _name("record", record), _view(view), preset
        self.element = _element_key(VIEWS[self.view], element, self.view)
        self.t_min = _time("t_min", t_min, _START_IS, model=True)
        self.t_max = _time("t_max", t_max, _STOP_IS)
        self._check_window()

    def _with(self, fields):
        keyword = VIEWS[self.view]
        return type(self)(self.record, self.view, fields[keyword], fields["t_min"], fields["t_max"], self.preset)

    def _field_names(self) -> tuple[str, ...]:
        return ("t_min", "t_max", VIEWS[self.view])

    def _fields(self) -> dict:
        return {"t_min": self.t_min, "t_max": self.t_max, VIEWS[self.view]: self.element}

    @property
    def bearing(self) -> int | None:
        """``element`` of a metric of the bearing joints (its keyword's name)."""
        return self._keyword("bearings")

    @property
    def contact(self) -> int | None:
        """``element`` of a metric of the impact contacts (its keyword's name)."""
        return self._keyword("contacts")

    def _keyword(self, view):
        if self.view != view:
            raise AttributeError(f"{self._name()} chooses its element by {VIEWS[self.view]}=, not {VIEWS[view]}=.")
        return self.element

    def _element(self, sol: Solution) -> int | None:
        """The element's index in ``model.forces`` (None: the view is empty and no element was
        named)."""
        return element_of(sol, self.view, self.element)

    def __call__(self, sol: Solution, t_min=_UNSET, t_max=_UNSET, **element) -> jax.Array:
        """The metric of ``sol`` over the window given (default: this metric's; edges may be
        traced) of the element named by the view's keyword (``bearing=``, ``contact=``,
        ``element=``; default: this metric's)."""
        metric = self.replace(**element) if element else self
        window = _given(t_min=t_min, t_max=t_max)
        return metric._at(sol, window.get("t_min", metric.t_min), window.get("t_max", metric.t_max))

    def value(self, sol: Solution, model=None) -> jax.Array:
        """The metric of ``sol`` over its window (``model`` is not read)."""
        return self._at(sol, self.t_min, self.t_max)

    def _at(self, sol: Solution, t_min, t_max) -> jax.Array:
        """The metric of ``sol`` over the window [t_min, t_max] [s]: of its element's records,
        or 0 where the view is empty and no element is named (nothing acted)."""
        e = self._element(sol)
        edges = checked_window(sol, t_min, t_max)
        if e is None:
            return _nothing_of(sol, *edges)
        return self._of(sol, edges, e)

    @abc.abstractmethod
    def _of(self, sol: Solution, edges, e: int) -> jax.Array:
        """The metric of element ``e``'s record over the window ``edges`` (lo, hi) [s]."""


def _given(**keywords) -> dict:
    """The keywords a call gave (not `_UNSET`)."""
    return {k: v for k, v in keywords.items() if v is not _UNSET}


@final
class ElementPeak(_OfElement):
    """The exact peak [the record's unit] of the peak record ``record`` of one force element
    over the window: the maximum of each solver step's interpolant
    (`solution.ElementRecords.peaks`); 0 where the view is empty and no element is named (a
    model without contact has no impact force). ``record``: the peak record's name, e.g.
    ``"max_element_load"`` of a bearing joint, ``"normal_force"`` of a contact."""

    def _of(self, sol: Solution, edges, e: int) -> jax.Array:
        _has_peak(sol, e, self.record)
        return _peak_of(sol, *edges, e, self.record)


@final
class PowerMean(_OfElement):
    """The power mean scale (integral / (T scale^p))^(1/p) [the quantity's unit] over the
    window of duration T of the power integral ``record`` of one force element (its power p
    and scale as the element declares them: `IntegralRecord`): the RMS for p = 2, a smooth
    stand-in for a peak for p = `solution.POWER`; Gauss–Legendre quadrature of each step's
    interpolant (exact for integrands of degree <= 5 over a step); 0 where the view is empty
    and no element is named."""

    def _of(self, sol: Solution, edges, e: int) -> jax.Array:
        power, scale = sol.records.elements[e].power(self.record)
        return _power_mean_of(sol, *edges, e, self.record, power, scale)


@final
class CoordinatePeak(_Windowed):
    """The largest |q_c(t) - q_c(t0)| [m or rad] of one coordinate over the window, the maximum
    of each solver step's interpolant (`solution.Records.displacement`). ``coordinate``: an
    index into q; None: the x of the impact target of ``contact`` (`Solution.targets`; None:
    the only contact; in `cases.xu2014` the target, body 3), 0 for a model without contact
    (nothing is struck)."""

    coordinate: int | None = eqx.field(static=True)
    contact: int | None = eqx.field(static=True)
    t_min: float | str | None = eqx.field(static=True)
    t_max: float | None = eqx.field(static=True)
    preset: str | None = eqx.field(static=True)
    _keywords: ClassVar[tuple[str, ...]] = ("t_min", "t_max", "coordinate", "contact")

    def __init__(self, coordinate=None, contact=None, t_min="model", t_max=None, preset=None):
        if coordinate is not None and (
            isinstance(coordinate, bool) or not isinstance(coordinate, numbers.Integral) or coordinate < 0
        ):
            raise ValueError(
                "coordinate must be None (the impact target's x) or an index into q, an integer "
                f">= 0; got {coordinate!r}."
            )
        self.coordinate = None if coordinate is None else int(coordinate)
        self.contact = _element_key("contact", contact, "contacts")
        self.t_min = _time("t_min", t_min, _START_IS, model=True)
        self.t_max = _time("t_max", t_max, _STOP_IS)
        self.preset = preset
        self._check_window()

    def _with(self, fields):
        return CoordinatePeak(fields["coordinate"], fields["contact"], fields["t_min"], fields["t_max"], self.preset)

    def __call__(self, sol: Solution, t_min=_UNSET, t_max=_UNSET, coordinate=_UNSET, *, contact=_UNSET):
        """The metric of ``sol`` with the fields given (default: this metric's; window edges
        may be traced)."""
        changes = _given(coordinate=coordinate, contact=contact)
        metric = self.replace(**changes) if changes else self
        window = _given(t_min=t_min, t_max=t_max)
        return metric._at(sol, window.get("t_min", metric.t_min), window.get("t_max", metric.t_max))

    def _coordinate(self, sol: Solution) -> int | None:
        if self.coordinate is not None:
            n = sol.q.shape[-1]
            if not self.coordinate < n:
                raise ValueError(
                    f"coordinate must be an index into q, an integer in [0, {n}); got {self.coordinate!r}."
                )
            return self.coordinate
        c = contact_index(sol, self.contact)
        return None if c is None else sol.targets[c]

    def value(self, sol: Solution, model=None) -> jax.Array:
        """The metric of ``sol`` over its window (``model`` is not read)."""
        return self._at(sol, self.t_min, self.t_max)

    def _at(self, sol: Solution, t_min, t_max) -> jax.Array:
        c = self._coordinate(sol)
        edges = checked_window(sol, t_min, t_max)
        if c is None:
            return _nothing_of(sol, *edges)
        return _displacement_of(sol, *edges, c)


def _exact_peak(metric):
    """``metric`` checked to be an exact peak (an `ElementPeak` or `CoordinatePeak`, e.g.
    `peak_ball_load`, `peak_bearing_force`, `peak_impact_force`, `max_target_displacement`)."""
    if not isinstance(metric, (ElementPeak, CoordinatePeak)):
        given = f"the string {metric!r}" if isinstance(metric, str) else repr(metric)
        raise ValueError(
            "metric must be an exact peak (the metric, not its name): an ElementPeak or "
            "CoordinatePeak, e.g. jaxbearing.metrics.peak_ball_load, peak_bearing_force, "
            f"peak_impact_force or max_target_displacement, or one of them .replace(...)d; got {given}."
        )
    return metric


class _OfPeak(_Windowed):
    """A metric of an exact peak ``metric`` (`ElementPeak`, `CoordinatePeak`): its window
    (``t_min``, ``t_max``) and element (``bearing``, ``contact``) are its own where set, else
    the metric's; set in both, differently, they are refused."""

    metric: AbstractMetric | None = eqx.field(static=True)
    t_min: float | str | None = eqx.field(static=True)
    t_max: float | None = eqx.field(static=True)
    bearing: int | None = eqx.field(static=True)
    contact: int | None = eqx.field(static=True)
    preset: str | None = eqx.field(static=True)

    def __init__(self, metric=None, t_min="model", t_max=None, bearing=None, contact=None, preset=None):
        self.metric = None if metric is None else _exact_peak(metric)
        self.t_min = _time("t_min", t_min, _START_IS, model=True)
        self.t_max = _time("t_max", t_max, _STOP_IS)
        self.bearing = _element_key("bearing", bearing, "bearings")
        self.contact = _element_key("contact", contact, "contacts")
        self.preset = preset
        self._check_window()

    def _with(self, fields):
        every = {"bearing": None, "contact": None, **fields}
        return type(self)(every["metric"], every["t_min"], every["t_max"], every["bearing"], every["contact"], self.preset)

    def __call__(self, sol: Solution, *args, **fields) -> jax.Array:
        """The metric of ``sol`` with the fields given (positionally in ``_keywords`` order
        after the solution), others as they are."""
        names = self._keywords
        if len(args) > len(names):
            raise TypeError(f"{self._name()} takes at most {len(names)} fields after the solution.")
        given = {**dict(zip(names, args)), **fields}
        return (self.replace(**given) if given else self).value(sol)

    def edges(self) -> tuple[float, ...]:
        """Its own window edges and its metric's [s]."""
        own = finite_numbers(self.t_min, self.t_max)
        return own + (() if self.metric is None else self.metric.edges())

    def peak(self) -> AbstractMetric:
        """The exact peak it reads: its metric with its own window and element where set."""
        peak = _exact_peak(self.metric)
        theirs = peak._fields()
        defaults = {"t_min": "model", "t_max": None, "bearing": None, "contact": None}
        changes = {}
        for name, default in defaults.items():
            own = getattr(self, name)
            if own == default and (name != "t_min" or isinstance(own, str)):
                continue
            if name not in theirs:
                raise TypeError(f"{self._name()} got {name}={own!r}; its metric {peak.label} has no field {name}.")
            mine = theirs[name]
            mine_default = mine == default and (name != "t_min" or isinstance(mine, str))
            if not mine_default and mine != own:
                raise ValueError(
                    f"{self._name()} got {name}={own!r} and a metric with {name}={mine!r}: give "
                    f"{name} once."
                )
            changes[name] = own
        return peak.replace(**changes) if changes else peak


@final
class PeakTime(_OfPeak):
    """Time [s] at which the exact peak ``metric`` (`ElementPeak`, `CoordinatePeak`) is
    attained in the window: the earliest recorded point that attains it (`solution.
    ElementRecords.peak_times`), so independent of the output times; NaN where the peak is 0
    (the element never acted in the window: no impact). No derivative: the point that attains
    a maximum jumps between steps. The window and element are its own where given, else the
    metric's: ``peak_time(sol, peak_ball_load, bearing=1)``; in a sweep,
    ``peak_time.replace(metric=peak_impact_force)``."""

    _keywords: ClassVar[tuple[str, ...]] = ("metric", "t_min", "t_max", "bearing", "contact")

    def value(self, sol: Solution, model=None) -> jax.Array:
        peak = self.peak()
        edges = checked_window(sol, peak.t_min, peak.t_max)
        if isinstance(peak, CoordinatePeak):
            c = peak._coordinate(sol)
            if c is None:  # no contact: nothing was struck, at no time
                return to_float64(np.nan)
            return _displacement_time_of(sol, *edges, c)
        e = peak._element(sol)
        if e is None:
            return to_float64(np.nan)
        _has_peak(sol, e, peak.record)
        return _peak_time_of(sol, *edges, e, peak.record)


def _carrying(sol: Solution, peak) -> int:
    """The element of ``peak``, whose record must carry an array at its peak (a bearing
    joint's ``max_element_load`` carries its element loads)."""
    e = peak._element(sol) if isinstance(peak, ElementPeak) else None
    if e is None or peak.record not in sol.records.elements[e].at_peak:
        raise ValueError(
            f"{peak.label}: its record carries no array at its peak (a bearing joint's "
            "max_element_load carries its element loads)."
        )
    return e


@final
class AtPeak(_OfPeak):
    """The array the peak record of ``metric`` (an `ElementPeak` whose record carries one: a
    bearing joint's ``max_element_load`` carries its ``element_loads``) holds at the peak's
    time in the window (`PeakTime`): a bearing's every ball load [N] at its worst instant,
    ball 1 first; NaN for a window without value (traced). A vector: in a sweep, take one
    entry."""

    _keywords: ClassVar[tuple[str, ...]] = ("t_min", "t_max", "bearing", "metric")

    def value(self, sol: Solution, model=None) -> jax.Array:
        peak = self.peak()
        e = _carrying(sol, peak)
        return _at_peak_of(sol, *checked_window(sol, peak.t_min, peak.t_max), e, peak.record)


@final
class PeakIndex(_OfPeak):
    """Which entry of the array `AtPeak` gives is the largest: the ball that carries
    `peak_ball_load` (0 = ball 1), an int; -1 for a window without value (traced)."""

    _keywords: ClassVar[tuple[str, ...]] = ("t_min", "t_max", "bearing", "metric")

    def value(self, sol: Solution, model=None) -> jax.Array:
        peak = self.peak()
        e = _carrying(sol, peak)
        return _peak_index_of(sol, *checked_window(sol, peak.t_min, peak.t_max), e, peak.record)


@final
class MaxDrift(AbstractMetric):
    """The largest constraint violation max |Phi(q, t)| [m or rad] at the end of every accepted
    step of the whole run (`Solution.max_drift`; `Mechanism.drift_bound` says how much is too
    much). A sweep records it for every member."""

    reads_samples: ClassVar[bool] = False
    reads_fatigue: ClassVar[bool] = False

    def __call__(self, sol: Solution) -> jax.Array:
        return self.value(sol)

    def value(self, sol: Solution, model=None) -> jax.Array:
        return sol.max_drift

    @property
    def label(self) -> str:
        return "max_drift"

    def __repr__(self) -> str:
        return "jaxbearing.metrics.max_drift"


def _name(field: str, value) -> str:
    if not isinstance(value, str) or not value:
        raise ValueError(f"{field} must name a record (a non-empty string); got {value!r}.")
    return value


def _view(view) -> str:
    if view not in VIEWS:
        raise ValueError(f"view must be one of {', '.join(map(repr, VIEWS))}; got {view!r}.")
    return view


def element_of(sol: Solution, view: str, key) -> int | None:
    """The index in ``model.forces`` of the element ``key`` of ``view`` (`VIEWS`; None: the only
    one, or None for an empty view of contacts or elements); a ValueError for a view without
    such an element, for None with several, and for an index it lacks."""
    if view == "elements":
        if key is None:
            count = len(sol.layout.kinds)
            return element_index("element", None, count, "force element") if count else None
        if isinstance(key, str):
            return sol.layout.index(key)
        return element_index("element", key, len(sol.layout.kinds), "force element")
    if view == "bearings":
        return sol.layout.bearings[bearing_index(sol, key)]
    c = contact_index(sol, key)
    return None if c is None else sol.layout.contacts[c]


def _has_peak(sol: Solution, e: int, quantity: str) -> None:
    peaks = sol.records.elements[e].peaks
    if quantity not in peaks:
        raise ValueError(
            f"Force element {e} ({sol.layout.kinds[e]}) records no peak {quantity!r}; its peak "
            f"records: {sorted(peaks) or 'none'}."
        )


def _where_peak(values, sol: Solution, lo, hi):
    """(interval attaining the peak of ``values`` (C,) in the window (the earliest of equals),
    the peak, and whether the window has a value)."""
    inside, ok = _inside(sol, lo, hi)
    peaks = jnp.where(inside, values, -jnp.inf)
    i = jnp.argmax(peaks)
    return i, peaks[i], ok & jnp.any(inside)


@functools.partial(jax.jit, static_argnums=(3, 4))
def _peak_of(sol: Solution, lo, hi, e, quantity):
    """The peak of element ``e``'s record ``quantity`` over the window [lo, hi] [s]; NaN for a
    window without value."""
    _, peak, has_value = _where_peak(sol.records.elements[e].peaks[quantity], sol, lo, hi)
    return jnp.where(has_value, peak, jnp.nan)


@jax.jit
def _nothing_of(sol: Solution, lo, hi):
    """0 over the window [lo, hi] [s] (an element the model lacks: nothing acted); NaN for a
    window without value."""
    inside, ok = _inside(sol, lo, hi)
    return jnp.where(ok & jnp.any(inside), 0.0, jnp.nan)


@functools.partial(jax.jit, static_argnums=3)
def _displacement_of(sol: Solution, lo, hi, c):
    _, peak, has_value = _where_peak(sol.records.displacement[:, c], sol, lo, hi)
    return jnp.where(has_value, peak, jnp.nan)


@functools.partial(jax.jit, static_argnums=(3, 4))
def _peak_time_of(sol: Solution, lo, hi, e, quantity):
    records = sol.records.elements[e]
    i, peak, has_value = _where_peak(records.peaks[quantity], sol, lo, hi)
    time = jax.lax.stop_gradient(records.peak_times[quantity][i])
    return jnp.where(has_value & (peak > 0.0), time, jnp.nan)


@functools.partial(jax.jit, static_argnums=3)
def _displacement_time_of(sol: Solution, lo, hi, c):
    i, peak, has_value = _where_peak(sol.records.displacement[:, c], sol, lo, hi)
    time = jax.lax.stop_gradient(sol.records.displacement_times[i, c])
    return jnp.where(has_value & (peak > 0.0), time, jnp.nan)


@functools.partial(jax.jit, static_argnums=(3, 4))
def _at_peak_of(sol: Solution, lo, hi, e, quantity):
    records = sol.records.elements[e]
    i, _, has_value = _where_peak(records.peaks[quantity], sol, lo, hi)
    return jnp.where(has_value, records.at_peak[quantity][i], jnp.nan)


@functools.partial(jax.jit, static_argnums=(3, 4))
def _peak_index_of(sol: Solution, lo, hi, e, quantity):
    loads = _at_peak_of(sol, lo, hi, e, quantity)
    return jnp.where(jnp.isnan(loads[0]), -1, jnp.argmax(loads))


def _integral(sol: Solution, values, lo, hi):
    """(integral over the window of ``values`` (C, ...) per interval, duration) [.., s]; NaN
    duration if the window has no value."""
    inside, ok = _inside(sol, lo, hi)
    where = inside.reshape(inside.shape + (1,) * (values.ndim - 1))
    total = jnp.sum(jnp.where(where, values, 0.0), axis=0)
    duration = jnp.sum(jnp.where(inside, sol.intervals.duration, 0.0))
    return total, jnp.where(ok, duration, jnp.nan)


@functools.partial(jax.jit, static_argnums=(3, 4, 5, 6))
def _power_mean_of(sol: Solution, lo, hi, e, name, power, scale):
    total, duration = _integral(sol, sol.records.elements[e].integrals[name], lo, hi)
    return scale * (total / duration) ** (1.0 / power)


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
    recorded point), recorded like the elements' exact peaks: at every accepted step's end, its
    3 Gauss–Legendre points and, where the step may hold a new peak between them, the vertex of
    a parabola through them. Window from ``t_min`` to ``t_max`` [s]: None, the model's
    ``window_start`` (t0 without one) and t1."""

    reduction = "peak"

    def read(self, sol: Solution, name: str) -> jax.Array:
        """Its value over its window from the record ``name`` of ``sol``."""
        return _own_peak_of(sol, *checked_window(sol, *self._window()), name)


@final
class Mean(_Own):
    """The time mean over the window of ``fn(model, x)`` (x: the `solution.Instant`), by 3-point
    Gauss–Legendre quadrature of every accepted step's interpolant (exact for integrands of
    degree <= 5 over a step). Window as `Peak`'s."""

    reduction = "mean"

    def read(self, sol: Solution, name: str) -> jax.Array:
        """Its value over its window from the record ``name`` of ``sol``."""
        return _own_mean_of(sol, *checked_window(sol, *self._window()), name)


@functools.partial(jax.jit, static_argnums=3)
def _own_peak_of(sol: Solution, lo, hi, name):
    _, peak, has_value = _where_peak(sol.records.own.peaks[name], sol, lo, hi)
    return jnp.where(has_value, peak, jnp.nan)


@functools.partial(jax.jit, static_argnums=3)
def _own_mean_of(sol: Solution, lo, hi, name):
    total, duration = _integral(sol, sol.records.own.integrals[name], lo, hi)
    return total / duration


peak_ball_load = ElementPeak("max_element_load", "bearings", preset="peak_ball_load")
"""Largest load on any ball [N] of a bearing joint (``bearing``: index into
``model.bearings``; None: the only one) in the window, the maximum of each solver step's
interpolant."""

peak_bearing_force = ElementPeak("force_magnitude", "bearings", preset="peak_bearing_force")
"""Largest magnitude |F| of a bearing joint's resultant (Eq. 28) [N] in the window;
``bearing`` as in `peak_ball_load`."""

peak_impact_force = ElementPeak("normal_force", "contacts", preset="peak_impact_force")
"""Largest normal impact force [N] of a contact (``contact``: index into ``model.contacts``;
None: the only one) in the window; 0 for a model without contact (nothing is struck)."""

rms_bearing_force = PowerMean("force_squared", "bearings", preset="rms_bearing_force")
"""Root-mean-square of a bearing joint's |F| over the window (time-weighted) [N]. Smooth."""

smooth_peak_ball_load = PowerMean("element_load_power", "bearings", preset="smooth_peak_ball_load")
"""Power mean of order `solution.POWER` of all ball loads of a bearing joint over the window
and the balls [N]: a differentiable stand-in for `peak_ball_load` (below it)."""

smooth_peak_bearing_force = PowerMean("force_power", "bearings", preset="smooth_peak_bearing_force")
"""Power mean of order `solution.POWER` of a bearing joint's |F| over the window [N]."""

smooth_peak_impact_force = PowerMean("normal_force_power", "contacts", preset="smooth_peak_impact_force")
"""Power mean of order `solution.POWER` of a contact's normal force over the window [N]; 0 for
a model without contact."""

max_target_displacement = CoordinatePeak(preset="max_target_displacement")
"""Largest displacement [m] of the impact target (or of a ``coordinate``) in the window."""

peak_time = PeakTime(preset="peak_time")
"""When an exact peak is attained [s]: ``peak_time(sol, peak_impact_force)``."""

loads_at_peak = AtPeak(peak_ball_load, preset="loads_at_peak")
"""Every ball's load [N] of a bearing joint at its `peak_ball_load` in the window, (N_b,)."""

peak_ball = PeakIndex(peak_ball_load, preset="peak_ball")
"""The ball that carries `peak_ball_load` in the window (0 = ball 1); -1 without value."""

max_drift = MaxDrift()
"""The largest constraint violation of the run [m or rad]."""

_PRESETS = {
    m.preset: m
    for m in (
        peak_ball_load, peak_bearing_force, peak_impact_force, rms_bearing_force,
        smooth_peak_ball_load, smooth_peak_bearing_force, smooth_peak_impact_force,
        max_target_displacement, peak_time, loads_at_peak, peak_ball,
    )
}  # fmt: skip

STANDARD = {
    "peak_ball_load": peak_ball_load,
    "peak_bearing_force": peak_bearing_force,
    "rms_bearing_force": rms_bearing_force,
    "peak_impact_force": peak_impact_force,
    "max_target_displacement": max_target_displacement,
}
"""The standard metrics (name -> metric), used by default in sweeps."""

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

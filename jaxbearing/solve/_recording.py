"""What the solve records of every step it takes, whatever it records: the maxima of P peak
columns and the integrals of I integrands over each interval between stops, defined at one
state by an `AbstractRecorder` (the application's: `jaxbearing.recorder.Recorder` for a
mechanism's force elements and metrics). The engine knows columns, not what they hold.

Each step contributes the values at its end and at its 3 Gauss–Legendre points, and their
Gauss–Legendre quadrature over the step; its peaks also at the vertices of parabolas through
those points, where the step may rise above the peaks so far (`step_stats`).
"""

from __future__ import annotations

import abc
import math
from typing import NamedTuple

import equinox as eqx
import equinox.internal as eqxi
import jax
import jax.numpy as jnp

# 3-point Gauss–Legendre rule on [0, 1]: nodes and weights
GAUSS_NODES = (0.5 - math.sqrt(15.0) / 10.0, 0.5, 0.5 + math.sqrt(15.0) / 10.0)
GAUSS_WEIGHTS = (5.0 / 18.0, 8.0 / 18.0, 5.0 / 18.0)
_NODES = GAUSS_NODES + (1.0,)  # the fractions of a step at which `step_stats` records peaks


class Peaks(NamedTuple):
    """Peaks of a span of the solution: ``values`` (..., P), the ``times`` (..., P) [s] that
    attain them, and the ``carried`` arrays (`AbstractRecorder.carried_columns`), each as it was
    when its column attained its peak."""

    values: jax.Array
    times: jax.Array
    carried: tuple


class RecordState(NamedTuple):
    """The record state of a solve, one row per interval between stops: `Peaks` (n_stops, ...)
    and ``integrals`` (n_stops, I)."""

    peaks: Peaks
    integrals: jax.Array


class AbstractRecorder(eqx.Module):
    """What the solve records at one state y with the system's discrete ``states`` in force
    (`AbstractSystem`).

    ``observe`` computes what a state holds (any pytree: the forces); ``peaks`` and
    ``integrands`` read it. Peak columns are evaluated between a step's points in groups
    (``vertex_groups``, contiguous column ranges covering all P, each evaluated only where one of
    its columns may rise: ``peaks_at``), so that a group of costly columns is not evaluated for
    another's sake.

    Properties (static):
        n_peaks: P.  n_integrals: I.
        carried_shapes: the shape of each carried array.
        carried_columns: for each carried array, the peak column whose maximum it follows
            (increasing, each inside one vertex group).
        vertex_groups: ((start, stop), ...) column ranges, in order, covering [0, P).
        episode_columns: for each element with episodes (`AbstractSystem.episodes`, in that
            order), the column whose maximum over each of its episodes the engine logs.
    """

    @property
    @abc.abstractmethod
    def n_peaks(self) -> int: ...

    @property
    @abc.abstractmethod
    def n_integrals(self) -> int: ...

    @property
    @abc.abstractmethod
    def carried_shapes(self) -> tuple: ...

    @property
    @abc.abstractmethod
    def carried_columns(self) -> tuple: ...

    @property
    @abc.abstractmethod
    def vertex_groups(self) -> tuple: ...

    @property
    @abc.abstractmethod
    def episode_columns(self) -> tuple: ...

    @abc.abstractmethod
    def observe(self, t, y, states):
        """What the state (t, y) holds, a pytree read by `peaks` and `integrands`."""

    @abc.abstractmethod
    def peaks(self, t, y, states, observed) -> tuple:
        """(values (P,), carried arrays) at (t, y) with ``states`` and ``observed`` there."""

    @abc.abstractmethod
    def integrands(self, t, y, states, observed) -> jax.Array:
        """The integrands (I,) at (t, y) with ``states`` and ``observed`` there."""

    @abc.abstractmethod
    def peaks_at(self, group: int, interpolation, times, states) -> tuple:
        """The columns of vertex group ``group``, each at its own time of ``times`` [s] along
        ``interpolation`` (y(t)), and the carried arrays whose columns lie in the group, each
        at its column's time."""


def no_peaks(recorder: AbstractRecorder, rows=()) -> Peaks:
    """`Peaks` of an empty span (``rows`` of them): values -inf, times and carried 0."""
    shape = tuple(rows) + (recorder.n_peaks,)
    carried = tuple(jnp.zeros(tuple(rows) + s) for s in recorder.carried_shapes)
    return Peaks(jnp.full(shape, -jnp.inf), jnp.zeros(shape), carried)


def no_records(recorder: AbstractRecorder, rows: int) -> RecordState:
    """The `RecordState` of ``rows`` intervals before any step."""
    return RecordState(no_peaks(recorder, (rows,)), jnp.zeros((rows, recorder.n_integrals)))


def point_peaks(recorder: AbstractRecorder, t, y, states, observed) -> Peaks:
    """`Peaks` of the single point (t, y) with ``states`` and ``observed`` there."""
    values, carried = recorder.peaks(t, y, states, observed)
    return Peaks(values, jnp.full_like(values, t), tuple(carried))


def step_stats(recorder: AbstractRecorder, interpolation, t_a, t_b, states, running: Peaks):
    """(`Peaks`, integrals (I,)) over [t_a, t_b] of one step's interpolant: peaks at t_b and at
    the 3 Gauss–Legendre points, and, where the step may rise above ``running`` (`Peaks` so
    far), at each column's `_vertices`; the Gauss–Legendre quadrature of the integrands.
    Whether to evaluate a vertex group is decided once for a whole vmapped batch
    (`eqxi.unvmap_any`), so that a batch branches rather than evaluating both sides of a
    select."""
    times = jnp.concatenate([t_a + (t_b - t_a) * jnp.asarray(GAUSS_NODES), t_b[None]])
    ys = jnp.stack([interpolation.evaluate(t) for t in times])  # alone: docs/performance.md
    observed = jax.vmap(lambda t, y: recorder.observe(t, y, states))(times, ys)
    points = jax.vmap(lambda t, y, o: point_peaks(recorder, t, y, states, o))(times, ys, observed)
    peaks = _largest_of(recorder.carried_columns, points)
    # between the points: the interpolant at the vertex of a parabola through them, for the
    # columns whose parabola rises there, in a step that may rise above the span's peaks so far
    # (``running``; by twice the parabola's rise), group by group. Only the columns that may
    # rise take their vertex's value, whichever branch ran, so that a batch member's peaks do
    # not depend on whether another member (or column) branched.
    vertex, rise = _vertices(points.values)
    at = t_a + (t_b - t_a) * vertex
    may_rise = (rise > 0.0) & (peaks.values + 2.0 * rise > running.values)
    values, carried = [], []
    for g, (start, stop) in enumerate(recorder.vertex_groups):
        if stop == start:
            continue
        shapes = _carried_in(recorder, start, stop)
        value, held = jax.lax.cond(
            eqxi.unvmap_any(jnp.any(may_rise[start:stop])),
            lambda g=g, start=start, stop=stop: _group(recorder, g, interpolation, at[start:stop], states),
            lambda start=start, stop=stop, shapes=shapes: (
                jnp.full(stop - start, -jnp.inf, at.dtype),
                tuple(jnp.zeros(s, at.dtype) for s in shapes),
            ),
        )
        values.append(value)
        carried += list(held)
    top = jnp.where(may_rise, jnp.concatenate(values), -jnp.inf)
    peaks = add_peaks(recorder.carried_columns, peaks, Peaks(top, at, tuple(carried)))
    gauss = jax.tree_util.tree_map(lambda x: x[:3], observed)
    integrands = jax.vmap(lambda t, y, o: recorder.integrands(t, y, states, o))(times[:3], ys[:3], gauss)
    return peaks, (t_b - t_a) * _gauss_sum(integrands)


def _carried_in(recorder: AbstractRecorder, start: int, stop: int) -> tuple:
    """The shapes of the carried arrays whose columns lie in [start, stop)."""
    return tuple(
        s for s, c in zip(recorder.carried_shapes, recorder.carried_columns) if start <= c < stop
    )


def _group(recorder: AbstractRecorder, g: int, interpolation, times, states) -> tuple:
    """`AbstractRecorder.peaks_at` of group ``g``, as (values, tuple of carried arrays)."""
    values, carried = recorder.peaks_at(g, interpolation, times, states)
    return values, tuple(carried)


def _vertices(values):
    """For each column of ``values`` (4, C), recorded at the `_NODES` of a step: the vertex
    (C,) [fraction of the step] of the parabola through the 3 consecutive points around the
    largest (the first 3 or the last 3), clamped to the step, and the parabola's rise (C,) there
    above the largest point; where the parabola has no maximum, its middle point and 0."""
    v = values
    s = jnp.asarray(_NODES, v.dtype)
    first = jnp.maximum(v[0], v[1]) >= jnp.maximum(v[2], v[3])
    pick = lambda a, b: jnp.where(first, a, b)  # noqa: E731
    x0, x1, x2 = pick(s[0], s[1]), pick(s[1], s[2]), pick(s[2], s[3])
    y0, y1, y2 = pick(v[0], v[1]), pick(v[1], v[2]), pick(v[2], v[3])
    d0 = (y1 - y0) / (x1 - x0)
    curvature = ((y2 - y1) / (x2 - x1) - d0) / (x2 - x0)  # the parabola's x^2 coefficient
    has_max = curvature < 0.0
    vertex = 0.5 * (x0 + x1) - d0 / (2.0 * jnp.where(has_max, curvature, -1.0))
    vertex = jnp.where(has_max, jnp.clip(vertex, pick(0.0, s[1]), pick(s[2], 1.0)), x1)
    top = y0 + (vertex - x0) * (d0 + curvature * (vertex - x1))
    return vertex, jnp.where(has_max, jnp.maximum(top - jnp.max(v, axis=0), 0.0), 0.0)


def _largest_of(columns: tuple, points: Peaks) -> Peaks:
    """`Peaks` of a step from those of its points (4, ...), in time order: each value's
    maximum, and the earliest point that attains it (`add_peaks` over the points: selects,
    which cost a one-loop run less than an argmax and a gather); ``columns``: the carried
    arrays' (`AbstractRecorder.carried_columns`)."""
    point = lambda i: jax.tree_util.tree_map(lambda x: x[i], points)  # noqa: E731
    peaks = point(0)
    for i in range(1, points.values.shape[0]):
        peaks = add_peaks(columns, peaks, point(i))
    return peaks


def add_peaks(columns: tuple, old: Peaks, new: Peaks) -> Peaks:
    """`Peaks` of two spans together, ``old``'s first: a peak keeps its time (and the carried
    array of its column, ``columns`` as `AbstractRecorder.carried_columns`) unless ``new``'s is
    larger."""
    later = new.values > old.values

    def held(c, o, n):
        w = later[..., c]
        return jnp.where(w.reshape(w.shape + (1,) * (n.ndim - w.ndim)), n, o)

    carried = tuple(held(c, o, n) for c, o, n in zip(columns, old.carried, new.carried))
    return Peaks(
        jnp.maximum(old.values, new.values),  # NaN wins, as in the forces
        jnp.where(later, new.times, old.times),
        carried,
    )


def _gauss_sum(values):
    """sum_i GAUSS_WEIGHTS[i] values[i] over the 3 Gauss points."""
    w = GAUSS_WEIGHTS
    return w[0] * values[0] + w[1] * values[1] + w[2] * values[2]

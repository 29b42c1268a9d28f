"""What the solve records of every step it takes: the `SegmentStats` peaks and integrals and
the `FatigueStats` integrals (`_step_stats`) of the forces the outputs report and the integrands
at one state (`jaxbearing.solution`: `_forces`, `_integrands`, `_fatigue_integrands`).

Each step contributes the forces at its end and at its 3 Gauss–Legendre points, and their
Gauss–Legendre quadrature over the step; its peaks also at the vertices of parabolas through
those points, where the step may rise above the peaks so far (`jaxbearing.solution`).
"""

from __future__ import annotations

import math
from typing import NamedTuple

import equinox.internal as eqxi
import jax
import jax.numpy as jnp

from ..solution import (
    _bearing_forces,
    _contact_forces,
    _fatigue_integrands,
    _forces,
    _integrands,
    _magnitude,
    _peaks,
    of_kind,
    peak_column,
    record_values,
)

# 3-point Gauss–Legendre rule on [0, 1]: nodes and weights
GAUSS_NODES = (0.5 - math.sqrt(15.0) / 10.0, 0.5, 0.5 + math.sqrt(15.0) / 10.0)
GAUSS_WEIGHTS = (5.0 / 18.0, 8.0 / 18.0, 5.0 / 18.0)


@jax.jit
def _accelerations(model, t, q, qd, approach_speeds, engaged):
    """`Mechanism.accelerations` by the entry-by-entry elimination, behind its own jit, so that
    it is traced once per solve: diffrax traces the vector field several times. XLA inlines the
    call, so the compiled program is unchanged."""
    return model.accelerations(t, q, qd, approach_speeds, engaged, sparse=True)


class Peaks(NamedTuple):
    """Peaks of a span of the solution (`SegmentStats`): ``values`` (..., 2 B + K + n)
    (`solution._peaks`), the ``times`` (..., 2 B + K + n) [s] that attain them, and for each
    bearing joint the ball ``loads`` (..., N_b) [N] at the time of its largest ball load."""

    values: jax.Array
    times: jax.Array
    loads: tuple


def no_peaks(model, records, rows=()) -> Peaks:
    """`Peaks` of an empty span (``rows`` of them): values -inf, times and loads 0; the
    columns of `solution._peaks`, then one per peak record of ``records``."""
    columns = 2 * len(model.bearings) + len(model.contacts) + model.n_coordinates
    shape = tuple(rows) + (columns + len(of_kind(records, "peak")),)
    loads = tuple(jnp.zeros(tuple(rows) + (j.bearing.n_balls,)) for j in model.bearings)
    return Peaks(jnp.full(shape, -jnp.inf), jnp.zeros(shape), loads)


def point_peaks(model, records, t, q, qd, f) -> Peaks:
    """`Peaks` of the single point (t, q, qd) with forces ``f``."""
    values = jnp.concatenate([_peaks(model, q, f), record_values(model, records, "peak", t, q, qd, f)])
    return Peaks(values, jnp.full_like(values, t), tuple(b["ball_loads"] for b in f["bearings"]))


def _step_stats(model, records, interpolation, t_a, t_b, args, fatigue, running):
    """Peaks and integrals over [t_a, t_b] of one step's interpolant: peaks at t_b and at the 3
    Gauss–Legendre points, and, where the step may rise above ``running`` (`Peaks` so far), at
    each column's `_vertices`; the Gauss–Legendre quadrature of the `SegmentStats` and
    `FatigueStats` integrands. Whether to evaluate at the vertices is decided once for a whole
    vmapped batch (`eqxi.unvmap_any`), so that a batch branches rather than evaluating both
    sides of a select."""
    approach, _, engaged = args
    n = model.n_coordinates
    times = jnp.concatenate([t_a + (t_b - t_a) * jnp.asarray(GAUSS_NODES), t_b[None]])
    ys = jnp.stack([interpolation.evaluate(t) for t in times])  # alone: docs/performance.md
    q, qd = ys[:, :n], ys[:, n:]
    f = jax.vmap(lambda t, q_, qd_: _forces(model, t, q_, qd_, approach, engaged))(times, q, qd)
    points = jax.vmap(lambda *a: point_peaks(model, records, *a))(times, q, qd, f)
    peaks = _largest_of(points)
    # between the points: the interpolant at the vertex of a parabola through them, for the
    # columns whose parabola rises there, in a step that may rise above the span's peaks so far
    # (``running``; by twice the parabola's rise): the bearing's columns and the others apart.
    # Only the columns that may rise take their vertex's value, whichever branch ran, so that a
    # batch member's peaks do not depend on whether another member (or column) branched.
    vertex, rise = _vertices(points.values)
    at = t_a + (t_b - t_a) * vertex
    may_rise = (rise > 0.0) & (peaks.values + 2.0 * rise > running.values)
    split = 2 * len(model.bearings)
    bearing, loads = jax.lax.cond(
        eqxi.unvmap_any(jnp.any(may_rise[:split])),
        lambda: _bearing_vertex(model, interpolation, at[:split], engaged),
        lambda: (jnp.full(split, -jnp.inf, at.dtype), no_peaks(model, ()).loads),
    )
    others = jax.lax.cond(
        eqxi.unvmap_any(jnp.any(may_rise[split:])),
        lambda: _other_vertex(model, records, interpolation, at[split:], args),
        lambda: jnp.full(at.shape[0] - split, -jnp.inf, at.dtype),
    )
    top = jnp.where(may_rise, jnp.concatenate([bearing, others]), -jnp.inf)
    peaks = _add((peaks,), (Peaks(top, at, loads),))[0]
    gauss = jax.tree_util.tree_map(lambda x: x[:3], f)
    means = jax.vmap(lambda *a: record_values(model, records, "mean", *a))(
        times[:3], q[:3], qd[:3], gauss
    )
    integrands = jax.vmap(_integrands)(times[:3], gauss, means)
    h = t_b - t_a
    if not (model.bearings and fatigue):
        return peaks, h * _gauss_sum(integrands), jnp.zeros((0,), q.dtype)
    life = jax.vmap(lambda q_, qd_, f_: _fatigue_integrands(model, q_, qd_, f_))(
        q[:3], qd[:3], gauss
    )
    return peaks, h * _gauss_sum(integrands), h * _gauss_sum(life)


_NODES = GAUSS_NODES + (1.0,)  # the fractions of a step at which `_step_stats` records peaks


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


def _bearing_vertex(model, interpolation, times, engaged):
    """For each bearing joint b, its largest ball load at times[2 b] and |F| at times[2 b + 1]
    [s] of the interpolant, (2 B,) [N], and every ball's load (N_b,) [N] at times[2 b]."""
    n = model.n_coordinates
    if not model.bearings:
        return jnp.zeros((0,), times.dtype), ()
    ys = jnp.stack([interpolation.evaluate(t) for t in times])  # alone: docs/performance.md
    values, loads = [], []
    for b in range(len(model.bearings)):
        f = jax.vmap(lambda t, y: _bearing_forces(model, b, t, y[:n], y[n:], engaged))(
            times[2 * b : 2 * b + 2], ys[2 * b : 2 * b + 2]
        )
        first = f["ball_loads"][0]
        values += [jnp.max(first), _magnitude(jax.tree_util.tree_map(lambda x: x[1], f))]
        loads.append(first)
    return jnp.stack(values), tuple(loads)


def _other_vertex(model, records, interpolation, times, args):
    """The normal force [N] of each contact c at times[c] [s] of the interpolant, each
    |q_j - q0_j| at times[K + j], and each peak record's value at times[K + n + u]:
    (K + n + U,)."""
    approach, _, engaged = args
    n, k = model.n_coordinates, len(model.contacts)
    forces = []
    for c in range(k):
        y = interpolation.evaluate(times[c])
        forces.append(_contact_forces(model, times[c], y[:n], y[n:], approach, (c,))["contact_force"])
    displacements = jnp.abs(_coordinates_at(interpolation, n, times[k : k + n]) - model.q0)
    peaks = of_kind(records, "peak")
    values = []
    for u in range(len(peaks)):
        t = times[k + n + u]
        y = interpolation.evaluate(t)
        f = _forces(model, t, y[:n], y[n:], approach, engaged)
        values.append(record_values(model, peaks[u : u + 1], "peak", t, y[:n], y[n:], f))
    return jnp.concatenate([*forces, displacements, *values])


def _coordinates_at(interpolation, n, times):
    """q_j of the interpolant at times[j] [s] (n,): each coordinate's interpolant alone, cut
    from ``interpolation``'s state-sized arrays (diffrax's interpolations treat each component
    of the state by itself), so that it costs n scalar evaluations, not n of the whole state."""
    state_sized = lambda x: jnp.ndim(x) > 0 and x.shape[-1] == 2 * n  # noqa: E731
    cut = jax.tree_util.tree_map(
        lambda x: jnp.moveaxis(x[..., :n], -1, 0) if state_sized(x) else x, interpolation
    )
    axes = jax.tree_util.tree_map(lambda x: 0 if state_sized(x) else None, interpolation)
    return jax.vmap(lambda one, t: one.evaluate(t), in_axes=(axes, 0))(cut, times)


def _largest_of(points: Peaks) -> Peaks:
    """`Peaks` of a step from those of its points (4, ...), in time order: each value's
    maximum, and the earliest point that attains it (`_add` over the points: selects, which
    cost a one-loop run less than an argmax and a gather)."""
    point = lambda i: jax.tree_util.tree_map(lambda x: x[i], points)  # noqa: E731
    peaks = point(0)
    for i in range(1, points.values.shape[0]):
        peaks = _add((peaks,), (point(i),))[0]
    return peaks


def _gauss_sum(values):
    """sum_i GAUSS_WEIGHTS[i] values[i] over the 3 Gauss points."""
    w = GAUSS_WEIGHTS
    return w[0] * values[0] + w[1] * values[1] + w[2] * values[2]


def _add(stats, more):
    """(`Peaks`, integrals, fatigue integrals) of two spans together, ``stats``' first: a peak
    keeps its time (and the largest ball load its ball loads) unless ``more``'s is larger."""
    (old, *sums), (new, *more_sums) = stats, more
    later = new.values > old.values
    loads = tuple(
        jnp.where(later[..., peak_column("ball_load", b, 0, 0), None], n, o)
        for b, (o, n) in enumerate(zip(old.loads, new.loads))
    )
    peaks = Peaks(
        jnp.maximum(old.values, new.values),  # NaN wins, as in the forces
        jnp.where(later, new.times, old.times),
        loads,
    )
    return (peaks,) + tuple(a + b for a, b in zip(sums, more_sums))

"""A `Mechanism` as the integrator sees it, what the solve records of it, and the `Solution`
made of that.

The integrator (`jaxbearing.solve`) integrates an `AbstractSystem` and records columns of
peaks and integrals per interval between its stops, whatever they hold (`AbstractRecorder`).
`MechanismSystem` gives it a mechanism's equations of motion (Eq. 36) and its force elements'
discrete states and events; `Recorder` lays out the columns from what each force element
declares (`AbstractForceElement.peak_records`, ``integral_records``, its `observe` and
`integrands`), adds the mechanism's own (each coordinate's displacement |q_c - q0_c|) and the
metrics of your own (`solution.AbstractRecord`), and turns the engine's final state into the
`Solution`, each element's records under its declared names.
"""

from __future__ import annotations

import dataclasses
import math
from typing import NamedTuple

import equinox as eqx
import jax
import jax.numpy as jnp

from .multibody.forces import BearingJoint, CircleContact
from .multibody.mechanism import Mechanism
from .solution import (
    Contacts,
    ElementRecords,
    Episodes,
    Instant,
    Intervals,
    Layout,
    Records,
    Samples,
    Solution,
)
from .solve import AbstractRecorder, AbstractSystem


@jax.jit
def accelerations(model: Mechanism, t, q, qd, states):
    """`Mechanism.accelerations` by the entry-by-entry elimination, behind its own jit, so that
    it is traced once per solve: diffrax traces the vector field several times. XLA inlines the
    call, so the compiled program is unchanged."""
    return model.accelerations(t, q, qd, states, sparse=True)


class MechanismSystem(AbstractSystem):
    """A `Mechanism` as the integrator's system: y = [q, qd], dy/dt from Eq. 36 with the force
    elements' discrete states, their events and episodes, and the constraint drift."""

    model: Mechanism

    def _split(self, y):
        n = self.model.n_coordinates
        return y[:n], y[n:]

    def initial_states(self, t0, y0) -> tuple:
        return self.model.initial_states(t0, *self._split(y0))

    def vector_field(self, t, y, states):
        q, qd = self._split(y)
        return jnp.concatenate([qd, accelerations(self.model, t, q, qd, states)])

    def event_values(self, t, y, states):
        return self.model.event_values(t, *self._split(y), states)

    def on_events(self, t, y, states, crossed) -> tuple:
        return self.model.on_events(t, *self._split(y), states, crossed)

    def episodes(self, states):
        return self.model.episodes(states)

    def drift(self, t, y):
        """max |Phi(q, t)| [m or rad], the constraint violation (0 without joints)."""
        if not self.model.joints:
            return jnp.zeros((), y.dtype)
        return jnp.max(jnp.abs(self.model.constraints(self._split(y)[0], t)))


def layout(model: Mechanism) -> Layout:
    """The `solution.Layout` of ``model``'s force elements."""
    return Layout(
        names=model.force_names,
        kinds=tuple(type(f).__name__ for f in model.forces),
        bearings=model.indices(BearingJoint),
        contacts=model.indices(CircleContact),
        episodic=model.episodic,
        targets=tuple(3 * c.body_k for c in model.contacts),
    )


class _Integral(NamedTuple):
    """Where an element's integral record lies among the integrals: [start, start + size)."""

    name: str
    start: int
    shape: tuple


class _Columns(NamedTuple):
    """Where every record lies among the engine's columns (static), from the elements'
    declarations."""

    peaks: tuple  # per element: ((name, column), ...)
    carried: tuple  # ((element, peak name, carried name, column, shape), ...), in column order
    displacement: int  # the first of the n coordinates' displacement columns
    own_peaks: int  # the first column of the peak records of your own
    n_peaks: int
    integrals: tuple  # per element: (`_Integral`, ...)
    own_means: int  # the first integral of the mean records of your own
    duration: int  # the integral of 1
    n_integrals: int
    groups: tuple  # vertex groups: ((start, stop, element or -1 for the mechanism's), ...)


def _declared(model: Mechanism, fatigue: bool) -> tuple:
    """Each element's `observe` and `integrands` shapes: ((observed, integrands), ...)."""
    n = model.n_coordinates
    t = jax.ShapeDtypeStruct((), model.q0.dtype)
    q = jax.ShapeDtypeStruct((n,), model.q0.dtype)
    states = jax.eval_shape(model.initial_states, t, q, q)
    inputs = model.inputs
    out = []
    for element, state in zip(model.forces, states):

        def shapes(t, q, qd, state, element=element):
            observed = element.observe(t, q, qd, state, inputs)
            return observed, element.integrands(t, q, qd, state, observed, inputs, fatigue)

        out.append(jax.eval_shape(shapes, t, q, q, state))
    return tuple(out)


def _columns(model: Mechanism, records: tuple, fatigue: bool) -> _Columns:
    """The `_Columns` of ``model``'s elements, then its displacements, then ``records``."""
    declared = _declared(model, fatigue)
    peaks, carried, groups, column = [], [], [], 0
    for e, (element, (observed, _)) in enumerate(zip(model.forces, declared)):
        mine = []
        for record in element.peak_records:
            _check_peak(element, record, observed)
            mine.append((record.name, column))
            if record.carried is not None:
                carried.append((e, record.name, record.carried, column, observed[record.carried].shape))
            column += 1
        if mine:
            groups.append((mine[0][1], column, e))
        peaks.append(tuple(mine))
    displacement = column
    own_peaks = displacement + model.n_coordinates
    n_peaks = own_peaks + len(of_kind(records, "peak"))
    groups.append((displacement, n_peaks, -1))
    integrals, start = [[] for _ in model.forces], 0
    for want_fatigue in (False, True):
        if want_fatigue and not fatigue:
            break
        for e, (element, (_, integrands)) in enumerate(zip(model.forces, declared)):
            for record in element.integral_records:
                if record.fatigue != want_fatigue:
                    continue
                if record.name not in integrands:
                    raise ValueError(
                        f"{type(element).__name__} declares the integral record {record.name!r} "
                        f"that its integrands() does not give (it gives {sorted(integrands)})."
                    )
                shape = integrands[record.name].shape
                integrals[e].append(_Integral(record.name, start, shape))
                start += math.prod(shape)
        if not want_fatigue:
            own_means, duration = start, start + len(of_kind(records, "mean"))
            start = duration + 1
    return _Columns(
        tuple(peaks), tuple(carried), displacement, own_peaks, n_peaks,
        tuple(tuple(i) for i in integrals), own_means, duration, start, tuple(groups),
    )  # fmt: skip


def _check_peak(element, record, observed) -> None:
    """A `ValueError` where a peak record does not name a scalar of the element's `observe`
    (or its carried array an array of it)."""
    kind = type(element).__name__
    if record.name not in observed or observed[record.name].shape != ():
        raise ValueError(
            f"{kind} declares the peak record {record.name!r}, which must name a scalar of its "
            f"observe() (it gives {sorted(observed)})."
        )
    if record.carried is not None and record.carried not in observed:
        raise ValueError(
            f"{kind}'s peak record {record.name!r} carries {record.carried!r}, which its "
            f"observe() does not give (it gives {sorted(observed)})."
        )


def of_kind(records, reduction: str) -> tuple:
    """The (name, record) pairs of ``records`` whose ``reduction`` is ``reduction``."""
    return tuple((name, r) for name, r in records if r.reduction == reduction)


class Recorder(AbstractRecorder):
    """What the solve records of ``model``: each force element's declared peaks (with their
    carried arrays) and integrals, each coordinate's |q_c - q0_c| peak, the metrics of your own
    (``records``: ((name, `solution.AbstractRecord`), ...)), and the duration; the fatigue
    integrals where ``fatigue``. Columns: `_Columns`."""

    model: Mechanism
    records: tuple = eqx.field(static=True)
    fatigue: bool = eqx.field(static=True)
    columns: _Columns = eqx.field(static=True)

    def __init__(self, model: Mechanism, records: tuple, fatigue: bool):
        self.model = model
        self.records = records
        self.fatigue = fatigue
        self.columns = _columns(model, records, fatigue)

    @property
    def n_peaks(self) -> int:
        return self.columns.n_peaks

    @property
    def n_integrals(self) -> int:
        return self.columns.n_integrals

    @property
    def carried_shapes(self) -> tuple:
        return tuple(c[4] for c in self.columns.carried)

    @property
    def carried_columns(self) -> tuple:
        return tuple(c[3] for c in self.columns.carried)

    @property
    def vertex_groups(self) -> tuple:
        return tuple((start, stop) for start, stop, _ in self.columns.groups)

    @property
    def episode_columns(self) -> tuple:
        model = self.model
        return tuple(
            dict(self.columns.peaks[i])[model.forces[i].episode_peak] for i in model.episodic
        )

    def _split(self, y):
        n = self.model.n_coordinates
        return y[:n], y[n:]

    def observe(self, t, y, states) -> tuple:
        """Each force element's `observe` at (t, y) with its state, ``model.forces`` order."""
        q, qd = self._split(y)
        inputs = self.model.inputs
        return tuple(f.observe(t, q, qd, s, inputs) for f, s in zip(self.model.forces, states))

    def _instant(self, t, q, qd, observed) -> Instant:
        return Instant(t, q, qd, observed, layout(self.model))

    def _own_values(self, reduction: str, t, q, qd, observed) -> list:
        """The values of the records of your own of that ``reduction`` at (t, q, qd)."""
        chosen = of_kind(self.records, reduction)
        if not chosen:
            return []
        x = self._instant(t, q, qd, observed)
        return [jnp.stack([r.at(self.model, x) for _, r in chosen])]

    def peaks(self, t, y, states, observed):
        """Each element's peak records, each |q_c - q0_c|, each peak record of your own; carried:
        the peaks' carried arrays."""
        q, qd = self._split(y)
        values = [
            jnp.stack([observed[e][name] for name, _ in mine])
            for e, mine in enumerate(self.columns.peaks) if mine
        ]  # fmt: skip
        values += [jnp.abs(q - self.model.q0)] + self._own_values("peak", t, q, qd, observed)
        carried = tuple(observed[e][name] for e, _, name, _, _ in self.columns.carried)
        return jnp.concatenate(values), carried

    def integrands(self, t, y, states, observed):
        """Each element's integrands (its non-fatigue ones), the means of your own, 1, then the
        elements' fatigue integrands where recorded (`_Columns` order)."""
        q, qd = self._split(y)
        inputs = self.model.inputs
        given = [
            f.integrands(t, q, qd, s, o, inputs, self.fatigue)
            for f, s, o in zip(self.model.forces, states, observed)
        ]
        parts = [[], []]
        for e, mine in enumerate(self.columns.integrals):
            for integral in mine:
                fatigue = integral.start >= self.columns.duration
                parts[fatigue].append(jnp.ravel(given[e][integral.name]))
        means = self._own_values("mean", t, q, qd, observed)
        return jnp.concatenate([*parts[0], *means, jnp.ones_like(t)[None], *parts[1]])

    def peaks_at(self, group, interpolation, times, states):
        start, stop, e = self.columns.groups[group]
        if e >= 0:
            return self._element_vertex(e, interpolation, times, states)
        return self._mechanism_vertex(interpolation, times, states), ()

    def _element_vertex(self, e, interpolation, times, states):
        """Element ``e``'s peak records, column k at times[k] [s] of the interpolant, and its
        carried arrays, each at its column's time."""
        model = self.model
        element, state, inputs = model.forces[e], states[e], model.inputs
        ys = jnp.stack([interpolation.evaluate(t) for t in times])  # alone: docs/performance.md
        observed = jax.vmap(lambda t, y: element.observe(t, *self._split(y), state, inputs))(times, ys)
        mine = self.columns.peaks[e]
        values = jnp.stack([observed[name][k] for k, (name, _) in enumerate(mine)])
        first = mine[0][1]
        carried = tuple(
            observed[name][column - first]
            for owner, _, name, column, _ in self.columns.carried if owner == e
        )  # fmt: skip
        return values, carried

    def _mechanism_vertex(self, interpolation, times, states):
        """Each |q_j - q0_j| at times[j], each peak record of your own at times[n + u] [s] of
        the interpolant: (n + U,)."""
        model = self.model
        n = model.n_coordinates
        values = [jnp.abs(_coordinates_at(interpolation, n, times[:n]) - model.q0)]
        peaks = of_kind(self.records, "peak")
        for u in range(len(peaks)):
            t = times[n + u]
            y = interpolation.evaluate(t)
            q, qd = self._split(y)
            observed = self.observe(t, y, states)
            x = self._instant(t, q, qd, observed)
            values.append(peaks[u][1].at(model, x)[None])
        return jnp.concatenate(values)

    def outputs(self, t, y, states) -> dict:
        """What an output time holds: ``q``, ``qd``, ``drift`` (max |Phi(q, t)|) and each
        element's quantities (``elements``); the accelerations are evaluated when read
        (`Solution.qdd`), from these and the states there."""
        model = self.model
        q, qd = self._split(y)
        drift = jnp.max(jnp.abs(model.constraints(q, t))) if model.joints else jnp.zeros(())
        return {"q": q, "qd": qd, "drift": drift, "elements": self.observe(t, y, states)}

    def solution(self, x, outputs: dict, ts, stops, t0, result, n_segments) -> Solution:
        """The `Solution` of a solve that ended in state ``x`` (the engine's `solve.State`) with
        ``result``: the per-time fields from ``outputs`` (at the output times ``ts``, keyed as
        `outputs` keys them), and from ``x`` the records of the intervals between the ``stops``
        [s] after t0, cut at the time reached (peaks 0 and their times NaN in the intervals
        not reached), the episodes, and the value of each of the ``records`` over its
        window."""
        model, columns = self.model, self.columns
        t_start = jnp.minimum(jnp.concatenate([t0[None], stops[:-1]]), x.t)
        t_end = jnp.minimum(stops, x.t)
        valid = t_end > t_start  # the interval holds part of the solved span
        reached = lambda rows, rest: jnp.where(valid, rows, rest)  # noqa: E731
        peaks, integrals = x.records
        values = reached(peaks.values.T, 0.0)  # (P, C)
        times = reached(peaks.times.T, jnp.nan)
        intervals = Intervals(t_start, t_end, integrals[:, columns.duration], valid)
        at_peak = {}
        for (e, name, _, column, shape), loads in zip(columns.carried, peaks.carried):
            rows = jnp.where(valid.reshape((-1,) + (1,) * len(shape)), loads, 0.0)
            at_peak.setdefault(e, {})[name] = rows
        elements = []
        for e, element in enumerate(model.forces):
            mine = columns.peaks[e]
            elements.append(
                ElementRecords(
                    {name: values[c] for name, c in mine},
                    {name: times[c] for name, c in mine},
                    at_peak.get(e, {}),
                    {i.name: _integral(integrals, i) for i in columns.integrals[e]},
                    tuple((r.name, r.power, r.scale) for r in element.integral_records if r.power is not None),
                )
            )
        own_peaks = of_kind(self.records, "peak")
        own_means = of_kind(self.records, "mean")
        own = ElementRecords(
            {name: values[columns.own_peaks + u] for u, (name, _) in enumerate(own_peaks)},
            {name: times[columns.own_peaks + u] for u, (name, _) in enumerate(own_peaks)},
            {},
            {name: integrals[:, columns.own_means + u] for u, (name, _) in enumerate(own_means)},
        )
        n = model.n_coordinates
        displacement = values[columns.displacement : columns.displacement + n].T
        displacement_times = times[columns.displacement : columns.displacement + n].T
        o = outputs
        samples = Samples(o["q"], o["qd"], o["drift"], o["elements"], o["states"], model)
        shape = layout(model)
        episodes = _episodes(x, shape)
        records = Records(
            intervals, tuple(elements), displacement, displacement_times, own, episodes,
            _contacts(episodes, shape), x.max_drift, {}, tuple(self.records),
        )  # fmt: skip
        stats = {
            "num_steps": x.steps,
            "num_rejected_steps": x.rejected,
            "num_segments": n_segments,
            "num_events": x.events,
        }
        # the time reached has no derivative (t1, or where a run failed): without a tangent it
        # stays a concrete value under jax.grad, and a failure raises in Python
        # (`solution.raise_on_failure`) instead of through a host callback
        t_final = jax.lax.stop_gradient(x.t)
        sol = Solution(ts, samples, records, stats, result, t_final, stops[-1], model.window_start, shape)
        values = {name: record.read(sol, name) for name, record in self.records}
        return dataclasses.replace(sol, records=dataclasses.replace(records, values=values))


def _integral(integrals, integral: _Integral) -> jax.Array:
    """An element's integral record (C, *shape) from the engine's integrals (C, I)."""
    size = math.prod(integral.shape)
    rows = integrals[:, integral.start : integral.start + size]
    return rows.reshape((-1,) + integral.shape)


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


def _episodes(x, shape: Layout) -> Episodes:
    """The `Episodes` of the core's final state ``x``: its onsets (time, logged value, episodic
    element) and their spans (end, peak, peak time), each (max_onsets,)."""
    time, value, index = x.onsets
    kept = jnp.arange(time.shape[0]) < x.n_onsets
    end, peak, peak_time = x.spans
    found = kept & (peak > -jnp.inf)
    elements = jnp.asarray(shape.episodic or (-1,))
    return Episodes(
        jnp.where(kept, time, jnp.nan),
        jnp.where(kept, value, jnp.nan),
        jnp.where(kept, elements[jnp.maximum(index, 0)], -1),
        kept,
        jnp.where(kept, end, jnp.nan),
        jnp.where(found, peak, jnp.nan),
        jnp.where(found, peak_time, jnp.nan),
    )


def _contacts(e: Episodes, shape: Layout) -> Contacts:
    """The `Contacts` view of the episodes: those of the impact contacts, each indexed into
    ``model.contacts``, in time order."""
    lookup = jnp.asarray([shape.contacts.index(i) if i in shape.contacts else -1 for i in range(len(shape.kinds))] or [-1])
    index = jnp.where(e.valid, lookup[jnp.maximum(e.element, 0)], -1)
    mine = e.valid & (index >= 0)
    if len(shape.contacts) != len(shape.episodic):  # other elements' episodes: moved behind
        order = jnp.argsort(~mine, stable=True)
        e = jax.tree_util.tree_map(lambda a: a[order], e)
        index, mine = index[order], mine[order]
    nan = lambda a: jnp.where(mine, a, jnp.nan)  # noqa: E731
    return Contacts(
        nan(e.time), nan(e.value), jnp.where(mine, index, -1), mine, nan(e.end), nan(e.peak),
        nan(e.peak_time),
    )  # fmt: skip

"""What the solve observes and records of a mechanism, and the `Solution` made of it.

The integrator (`jaxbearing.solve`) records columns of peaks and integrals per interval between
its stops, whatever they hold (`solve._recording.AbstractRecorder`); `Recorder` says what they
hold for a `Mechanism`: at one state, the forces the outputs report (`forces`: each bearing
joint's ball loads, resultant (Eq. 28) and cage angle, each contact's normal force and
penetration), the peak candidates and integrands of `solution.SegmentStats` (columns
`solution.peak_column`, `solution.integral_column`), each bearing's `solution.FatigueStats`
integrands, and the metrics of your own (`solution.AbstractRecord`). `Recorder.solution` turns
the engine's final state into the `Solution`.
"""

from __future__ import annotations

import dataclasses

import equinox as eqx
import jax
import jax.numpy as jnp

from .laws import bearing as bearing_law
from .solution import (
    FORCE_SCALE,
    POWER,
    RING_POINTS_PER_BALL,
    BearingInstant,
    BearingSamples,
    ContactInstant,
    Contacts,
    FatigueStats,
    Instant,
    Records,
    Samples,
    SegmentStats,
    Solution,
    integral_column,
    peak_column,
)
from .solve._recording import AbstractRecorder

FATIGUE_SCALARS = 5  # the scalar integrands of each bearing's `FatigueStats` (columns ``FAT_*``)


def forces(model, t, q, qd, approach_speeds, engaged) -> dict:
    """Forces that the outputs and the metrics report: ``bearings``, a tuple with each bearing
    joint's ``ball_loads`` (N_b,) [N], ``cage`` [rad] and ``bearing_force`` (2,) [N]; and
    ``contact_force`` (K,) [N] and ``penetration`` (K,) [m] of the impact contacts."""
    return {
        "bearings": tuple(
            _bearing_forces(model, b, t, q, qd, engaged) for b in range(len(model.bearings))
        ),
        **_contact_forces(model, t, q, qd, approach_speeds),
    }


def _bearing_forces(model, b, t, q, qd, engaged) -> dict:
    """Bearing joint ``b``'s part of `forces`."""
    joint = model.bearings[b]
    switches = model.engaged_by_bearing(engaged)[b]
    loads, cage = joint.ball_loads(t, q, qd, model.q0, model.qd0, switches)
    return {"ball_loads": loads, "cage": cage, "bearing_force": bearing_law.resultant(loads, cage)}


def _contact_forces(model, t, q, qd, approach_speeds, contacts=None) -> dict:
    """The impact contacts' part of `forces` (those of ``contacts``, indices; None: all)."""
    chosen = range(len(model.contacts)) if contacts is None else contacts
    force = [model.contacts[c].forces(t, q, qd, approach_speeds[c])[0] for c in chosen]
    gap = [model.contacts[c].gap(q, qd)[0] for c in chosen]
    stack = lambda x: jnp.stack(x) if x else jnp.zeros((0,), q.dtype)  # noqa: E731
    return {"contact_force": stack(force), "penetration": stack(gap)}


def instant(t, q, qd, f) -> Instant:
    """The `solution.Instant` at (t, q, qd) with forces ``f`` (`forces`)."""
    bearings = tuple(
        BearingInstant(b["ball_loads"], b["bearing_force"], b["cage"]) for b in f["bearings"]
    )
    contacts = tuple(
        ContactInstant(force, gap) for force, gap in zip(f["contact_force"], f["penetration"])
    )
    return Instant(t, q, qd, bearings, contacts)


def of_kind(records, reduction: str) -> tuple:
    """The (name, record) pairs of ``records`` whose ``reduction`` is ``reduction``."""
    return tuple((name, r) for name, r in records if r.reduction == reduction)


def _record_values(model, records, reduction: str, t, q, qd, f) -> jax.Array:
    """The values (U,) of the ``records`` of that ``reduction`` at (t, q, qd) with forces
    ``f``."""
    chosen = of_kind(records, reduction)
    if not chosen:
        return jnp.zeros((0,), q.dtype)
    x = instant(t, q, qd, f)
    return jnp.stack([r.at(model, x) for _, r in chosen])


def _squared(b):
    """|F|^2 [N^2] of the resultant of a bearing's forces ``b``."""
    resultant = b["bearing_force"]
    return jnp.sum(resultant * resultant)


def _magnitude(b):
    """|F| [N] of the resultant of a bearing's forces ``b``."""
    return jnp.sqrt(_squared(b) + 1e-30)


def fatigue_sizes(model, fatigue: bool) -> tuple[int, ...]:
    """Lengths of each bearing joint's `FatigueStats` integrands, 5 + 2 M (M ring points);
    empty where they are not recorded."""
    if not fatigue:
        return ()
    return tuple(
        FATIGUE_SCALARS + 2 * RING_POINTS_PER_BALL * j.bearing.n_balls for j in model.bearings
    )


class Recorder(AbstractRecorder):
    """What the solve records of ``model``: the `SegmentStats` columns (peaks
    `solution.peak_column`, then one per peak record of ``records``; integrals
    `solution.integral_column`, one per mean record, the duration), and, where ``fatigue``, each
    bearing joint's `FatigueStats` integrands after them (`fatigue_sizes`). ``records``:
    ((name, `solution.AbstractRecord`), ...)."""

    model: object  # the Mechanism
    records: tuple = eqx.field(static=True)
    fatigue: bool = eqx.field(static=True)

    @property
    def n_segment_peaks(self) -> int:
        """The built-in peak columns, 2 B + K + n_coordinates (the peak records' follow)."""
        return self._column("displacement", self.model.n_coordinates)

    @property
    def n_segment_integrals(self) -> int:
        """Columns of `SegmentStats.integrals`: 3 B + K + the mean records + 1."""
        return self._first_mean + len(of_kind(self.records, "mean")) + 1

    @property
    def _first_mean(self) -> int:
        """The column of the first mean record's integral, after the contacts' (3 B + K)."""
        m = self.model
        return integral_column("contact_force_power", len(m.contacts), len(m.bearings))

    @property
    def n_peaks(self) -> int:
        return self.n_segment_peaks + len(of_kind(self.records, "peak"))

    @property
    def n_integrals(self) -> int:
        return self.n_segment_integrals + sum(fatigue_sizes(self.model, self.fatigue))

    @property
    def carried_shapes(self) -> tuple:
        return tuple((j.bearing.n_balls,) for j in self.model.bearings)

    def _column(self, kind: str, index: int) -> int:
        return peak_column(kind, index, len(self.model.bearings), len(self.model.contacts))

    @property
    def carried_columns(self) -> tuple:
        return tuple(self._column("ball_load", b) for b in range(len(self.model.bearings)))

    @property
    def vertex_groups(self) -> tuple:
        split = self._column("contact_force", 0)  # the bearings' columns, then the others
        return ((0, split), (split, self.n_peaks))

    @property
    def contact_columns(self) -> tuple:
        return tuple(self._column("contact_force", c) for c in range(len(self.model.contacts)))

    def observe(self, t, y, switches):
        """`forces` at (t, y) with the ``switches`` (approach speeds, engaged balls)."""
        n = self.model.n_coordinates
        return forces(self.model, t, y[:n], y[n:], *switches)

    def peaks(self, t, y, f):
        """Each bearing's largest ball load and |F|, each contact's force, each |q_j - q0_j|,
        each peak record's value; carried: each bearing's ball loads."""
        model = self.model
        q, qd = y[: model.n_coordinates], y[model.n_coordinates :]
        bearings = [jnp.stack([jnp.max(b["ball_loads"]), _magnitude(b)]) for b in f["bearings"]]
        values = jnp.concatenate(
            [
                *bearings,
                f["contact_force"],
                jnp.abs(q - model.q0),
                _record_values(model, self.records, "peak", t, q, qd, f),
            ]
        )
        return values, tuple(b["ball_loads"] for b in f["bearings"])

    def integrands(self, t, y, f):
        """The `SegmentStats` integrands, then the `FatigueStats` ones where recorded."""
        model = self.model
        q, qd = y[: model.n_coordinates], y[model.n_coordinates :]
        bearings = [
            jnp.stack(
                [
                    _squared(b),
                    jnp.sum((b["ball_loads"] / FORCE_SCALE) ** POWER),
                    (_magnitude(b) / FORCE_SCALE) ** POWER,
                ]
            )
            for b in f["bearings"]
        ]
        contacts = (f["contact_force"] / FORCE_SCALE) ** POWER
        means = _record_values(model, self.records, "mean", t, q, qd, f)
        fatigue = self._fatigue_integrands(q, qd, f) if self.fatigue else []
        return jnp.concatenate([*bearings, contacts, means, jnp.ones_like(t)[None], *fatigue])

    def _fatigue_integrands(self, q, qd, f) -> list:
        """Each bearing joint's `FatigueStats` integrands, 5 + 2 M in turn (`fatigue_sizes`)."""
        per_bearing = []
        for joint, b in zip(self.model.bearings, f["bearings"]):
            w = jnp.abs(joint.relative_speed(q, qd)) / (2.0 * jnp.pi)
            balls = b["ball_loads"] / FORCE_SCALE
            force = b["bearing_force"] / FORCE_SCALE
            points = joint.ring_point_loads(q, qd, RING_POINTS_PER_BALL * joint.bearing.n_balls)
            scalars = jnp.stack(
                [
                    jnp.ones_like(w),
                    w,
                    w * jnp.sum(force * force) ** (0.5 * joint.bearing.life_exponent),
                    w * jnp.mean(balls**3),
                    w * jnp.mean(balls ** (10.0 / 3.0)),
                ]
            )
            per_bearing += [scalars, w * jnp.ravel((points / FORCE_SCALE) ** 3)]
        return per_bearing

    def peaks_at(self, group, interpolation, times, switches):
        if group == 0:
            return self._bearing_vertex(interpolation, times, switches)
        return self._other_vertex(interpolation, times, switches), ()

    def _bearing_vertex(self, interpolation, times, switches):
        """For each bearing joint b, its largest ball load at times[2 b] and |F| at
        times[2 b + 1] [s] of the interpolant, (2 B,) [N], and every ball's load (N_b,) [N]
        at times[2 b]."""
        model = self.model
        n = model.n_coordinates
        ys = jnp.stack([interpolation.evaluate(t) for t in times])  # alone: docs/performance.md
        values, loads = [], []
        for b in range(len(model.bearings)):
            f = jax.vmap(
                lambda t, y: _bearing_forces(model, b, t, y[:n], y[n:], switches[1])
            )(times[2 * b : 2 * b + 2], ys[2 * b : 2 * b + 2])
            first = f["ball_loads"][0]
            values += [jnp.max(first), _magnitude(jax.tree_util.tree_map(lambda x: x[1], f))]
            loads.append(first)
        return jnp.stack(values), tuple(loads)

    def _other_vertex(self, interpolation, times, switches):
        """The normal force [N] of each contact c at times[c] [s] of the interpolant, each
        |q_j - q0_j| at times[K + j], and each peak record's value at times[K + n + u]:
        (K + n + U,)."""
        model = self.model
        approach, engaged = switches
        n, k = model.n_coordinates, len(model.contacts)
        values = []
        for c in range(k):
            y = interpolation.evaluate(times[c])
            values.append(
                _contact_forces(model, times[c], y[:n], y[n:], approach, (c,))["contact_force"]
            )
        values.append(jnp.abs(_coordinates_at(interpolation, n, times[k : k + n]) - model.q0))
        peaks = of_kind(self.records, "peak")
        for u in range(len(peaks)):
            t = times[k + n + u]
            y = interpolation.evaluate(t)
            f = forces(model, t, y[:n], y[n:], approach, engaged)
            values.append(_record_values(model, peaks[u : u + 1], "peak", t, y[:n], y[n:], f))
        return jnp.concatenate(values)

    def outputs(self, t, y, switches, accelerations) -> dict:
        """What an output time holds: ``q``, ``qd``, ``qdd`` (``accelerations``), ``drift``
        (max |Phi(q, t)|), ``approach`` and the `forces`."""
        model = self.model
        q, qd = y[: model.n_coordinates], y[model.n_coordinates :]
        drift = jnp.max(jnp.abs(model.constraints(q, t))) if model.joints else jnp.zeros(())
        out = {"q": q, "qd": qd, "qdd": accelerations, "drift": drift, "approach": switches[0]}
        out.update(self.observe(t, y, switches))
        return out

    def solution(self, x, outputs: dict, ts, stops, t0, result, n_segments) -> Solution:
        """The `Solution` of a solve that ended in state ``x`` (the engine's `_core.State`) with
        ``result``: the per-time fields from ``outputs`` (at the output times ``ts``, keyed as
        `outputs` keys them), and from ``x`` the records: `SegmentStats` and each bearing's
        `FatigueStats` of the intervals between the ``stops`` [s] after t0, cut at the time
        reached (peaks 0 and their times NaN in the intervals not reached), the `Contacts`, and
        the value of each of the ``records`` over its window."""
        model = self.model
        t_start = jnp.minimum(jnp.concatenate([t0[None], stops[:-1]]), x.t)
        t_end = jnp.minimum(stops, x.t)
        valid = t_end > t_start  # the interval holds part of the solved span
        reached = lambda rows, rest: jnp.where(valid[:, None], rows, rest)  # noqa: E731
        peaks, integrals = x.records
        segments = SegmentStats(
            t_start,
            t_end,
            reached(peaks.values, 0.0),
            integrals[:, : self.n_segment_integrals],
            valid,
            reached(peaks.times, jnp.nan),
            tuple(reached(loads, 0.0) for loads in peaks.carried),
        )
        sizes = fatigue_sizes(model, self.fatigue)  # empty where not recorded: None each
        ends = [self.n_segment_integrals + sum(sizes[:i]) for i in range(len(sizes) + 1)]
        fatigue = [None] * len(model.bearings)
        for b, size in enumerate(sizes):
            stats = integrals[:, ends[b] : ends[b + 1]]
            m = FATIGUE_SCALARS + (size - FATIGUE_SCALARS) // 2  # the outer ring's first column
            fatigue[b] = FatigueStats(
                t_start, t_end, stats[:, :FATIGUE_SCALARS], stats[:, FATIGUE_SCALARS:m],
                stats[:, m:], valid,
            )  # fmt: skip
        o = outputs
        samples = Samples(
            q=o["q"],
            qd=o["qd"],
            qdd=o["qdd"],
            bearings=tuple(
                BearingSamples(f["ball_loads"], f["bearing_force"], f["cage"]) for f in o["bearings"]
            ),
            contact_forces=o["contact_force"],
            penetrations=o["penetration"],
            approach_speed=o["approach"],
            drift=o["drift"],
        )
        records = Records(segments, _contacts(x), tuple(fatigue), x.max_drift, {}, tuple(self.records))
        stats = {
            "num_steps": x.steps,
            "num_rejected_steps": x.rejected,
            "num_segments": n_segments,
            "num_events": x.events,
        }
        targets = tuple(3 * c.body_k for c in model.contacts)
        # the time reached has no derivative (t1, or where a run failed): without a tangent it
        # stays a concrete value under jax.grad, and a failure raises in Python
        # (`solution.raise_on_failure`) instead of through a host callback
        t_final = jax.lax.stop_gradient(x.t)
        sol = Solution(ts, samples, records, stats, result, t_final, stops[-1], model.window_start, targets)
        # the records of your own: the columns after the built-in ones, in declared order
        first = {"peak": self.n_segment_peaks, "mean": self._first_mean}
        values = {}
        for reduction, start in first.items():
            for u, (name, record) in enumerate(of_kind(self.records, reduction)):
                values[name] = record.read(sol, start + u)
        return dataclasses.replace(sol, records=dataclasses.replace(records, values=values))


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


def _contacts(x) -> Contacts:
    """The `Contacts` of the core's final state ``x``: its onsets (time, approach speed, contact
    index) and their contacts' spans (end, peak force, peak time), each (max_onsets,)."""
    time, speed, index = x.onsets
    kept = jnp.arange(time.shape[0]) < x.n_onsets
    end, peak, peak_time = x.spans
    found = kept & (peak > -jnp.inf)
    return Contacts(
        jnp.where(kept, time, jnp.nan),
        jnp.where(kept, speed, jnp.nan),
        jnp.where(kept, index, -1),
        kept,
        jnp.where(kept, end, jnp.nan),
        jnp.where(found, peak, jnp.nan),
        jnp.where(found, peak_time, jnp.nan),
    )

"""What `jaxbearing.simulate` returns, and what the metrics and the life read from it: the
`Solution`, its `Contacts`, `SegmentStats` and `FatigueStats`, the result codes (`RESULTS`,
`SimulationError`) and the columns of the statistics, each defined once.
`jaxbearing.recorder` says what the columns hold at one state and makes the `Solution` of the
solve's records; `raise_on_failure` is the error a result code stands for; `jaxbearing.metrics`
and `jaxbearing.life` read the `Solution` without importing the solver.
"""

from __future__ import annotations

import dataclasses
import functools
import warnings
from collections.abc import Callable

import diffrax
import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from . import _checks
from ._checks import is_concrete

POWER = 16  # order p of the power integrals in `SegmentStats` (the smooth metrics' p)
FORCE_SCALE = 1e3  # [N] forces are divided by it before the power p: no overflow below 1e22 N
# Columns of SegmentStats.peaks (and .peak_times), for a model of B bearing joints, K impact
# contacts and n coordinates, in model order: bearing b's largest ball load at 2 b and the
# magnitude |F| of its resultant at 2 b + 1, contact c's normal force at 2 B + c, then |q_j -
# q0_j| at 2 B + K + j (`peak_column`). Bearing 0's columns, where the model has a bearing:
PEAK_BALL_LOAD, PEAK_BEARING_FORCE = 0, 1
# Columns of SegmentStats.integrals: bearing b's |F|^2 at 3 b, its ball loads' power sum at
# 3 b + 1 and |F|^POWER at 3 b + 2, contact c's force^POWER at 3 B + c, the duration last
# (`integral_column`).
INT_TIME = -1


def peak_column(kind: str, index: int, n_bearings: int, n_contacts: int) -> int:
    """The column of `SegmentStats.peaks` that holds ``kind`` ("ball_load", "bearing_force" of
    bearing ``index``, "contact_force" of contact ``index``, "displacement" of coordinate
    ``index``) for a model of ``n_bearings`` bearing joints and ``n_contacts`` contacts."""
    base = {"ball_load": 0, "bearing_force": 1}
    if kind in base:
        return 2 * index + base[kind]
    if kind == "contact_force":
        return 2 * n_bearings + index
    return 2 * n_bearings + n_contacts + index  # "displacement"


def integral_column(kind: str, index: int, n_bearings: int) -> int:
    """The column of `SegmentStats.integrals` that holds ``kind`` ("force_squared",
    "ball_load_power", "force_power" of bearing ``index``; "contact_force_power" of contact
    ``index``)."""
    base = {"force_squared": 0, "ball_load_power": 1, "force_power": 2}
    if kind in base:
        return 3 * index + base[kind]
    return 3 * n_bearings + index  # "contact_force_power"


RING_POINTS_PER_BALL = 8  # points of each ring per ball spacing that `FatigueStats` follows
# columns of FatigueStats.integrals
(FAT_TIME, FAT_REVOLUTIONS, FAT_FORCE_POWER, FAT_BALL_CUBED, FAT_BALL_TEN_THIRDS) = range(5)


class RESULTS(diffrax.RESULTS):
    """diffrax's result codes plus the ones of the segmented solve."""

    max_segments_reached = (
        "More iterations than max_segments x segment_steps allow (each step, accepted or "
        "rejected, and each step of an event's root finder is one). Increase `max_segments` "
        "(jaxbearing.SolveOptions)."
    )
    max_onsets_reached = (
        "More contact onsets than max_onsets records. Increase `max_onsets` "
        "(jaxbearing.SolveOptions)."
    )
    contact_overlap = (
        "The event found a contact switched on (its active_from) while its surfaces overlap: "
        "switch it on when they are apart."
    )
    event_not_located = (
        "The event's root finder did not narrow an event time within its steps: "
        "the event value is likely not finite along the step."
    )
    invalid_input = (
        "A parameter value, the initial state or the times are outside what is allowed (the "
        "error raised with throw=True names which); nothing was integrated."
    )


class SimulationError(RuntimeError):
    """A solve failed: the message says when (simulated time) and what to change."""


class Contacts(eqx.Module):
    """Impact contacts, each from its onset to its end, one slot per onset (``max_onsets`` of
    `SolveOptions`, padded; read ``valid``). Onsets and ends are the solve's events, located to 1e-13 s, and the peak is
    the maximum of the solution over the contact's steps and their interpolants (as
    `SegmentStats`' peaks), so none of them depends on the output times.

    Fields (each (max_onsets,)):
        time: onset times [s], NaN in unused slots.
        approach_speed: penetration rate at onset, delta_dot^(-) of Eq. 23 [m/s].
        index: which contact of ``model.contacts`` started, -1 in unused slots.
        valid: True where the slot holds an onset.
        end: when that contact ended [s]: its separation event, where the penetration has
            fallen to -1 nm (`_core.SEPARATION_OFFSET`: the force vanished 1 nm / separation
            speed before); NaN where it lasted to the time reached, and in unused slots.
        peak_force: the largest normal force over the contact [N], up to its end or the time
            reached (every contact of the model).
        peak_time: when the solution attains it [s] (the earliest recorded point).
    """

    time: jax.Array
    approach_speed: jax.Array
    index: jax.Array
    valid: jax.Array
    end: jax.Array
    peak_force: jax.Array
    peak_time: jax.Array

    @property
    def count(self) -> jax.Array:
        """Number of contact onsets."""
        return jnp.sum(self.valid, axis=-1)


class SegmentStats(eqx.Module):
    """Peaks and integrals of the solution over each interval between the solve's stops (t0,
    the model's ``window_start``, the ``window_edges`` asked for, t1), taken from the solution
    itself: every accepted solver step and its interpolant (`_recording._step_stats`), not from
    the output times. `jaxbearing.metrics` combines the intervals inside a window, so
    a window's edges must be stops.

    Each step contributes the values at its end and at its 3 Gauss–Legendre points, and their
    Gauss–Legendre quadrature over the step; a step across an event counts only up to the
    event. Peaks are maxima of the interpolant: where a step may rise
    above the interval's peak so far between those 4 points, each value is also taken at the
    vertex of the parabola through the 3 points around its largest, which is the step's maximum
    to the parabola's third-order error. Integrals are exact for integrands that are
    polynomials of degree <= 5 over each step.

    Fields (C = number of stops; one entry per interval, so the size does not grow with the steps
    or the events):
        t_start, t_end: (C,) [s] of each interval, up to where the solve reached.
        peaks: (C, 2 B + K + n_coordinates), the maxima over the interval of: for each bearing
            joint (B of them, model order) its largest ball load [N] and the magnitude |F| of its
            resultant (Eq. 28) [N]; the normal force of each impact contact (K) [N]; then
            |q_c - q0_c| of each coordinate [m or rad]; 0 in intervals the solve did not reach.
            Columns: `peak_column`.
        integrals: (C, 3 B + K + 1), the integrals over the interval of: for each bearing
            |F|^2 [N^2 s], the sum over balls of (F_r / FORCE_SCALE)^POWER [s] and
            (|F| / FORCE_SCALE)^POWER [s]; for each contact (contact force /
            FORCE_SCALE)^POWER [s]; and 1 (the interval's solved duration) [s], last.
            Columns: `integral_column`, ``INT_TIME``.
        valid: (C,) bool, True where the interval holds part of the solved span.
        peak_times: (C, 2 B + K + n_coordinates) [s], where each of ``peaks`` is attained: the
            earliest recorded point (step point or vertex) that attains it; NaN in intervals
            the solve did not reach.
        peak_loads: one (C, N_b) array per bearing joint [N]: every ball's load at the time of
            the interval's largest ball load of that bearing, ball 1 first; 0 in intervals the
            solve did not reach.
    """

    t_start: jax.Array
    t_end: jax.Array
    peaks: jax.Array
    integrals: jax.Array
    valid: jax.Array
    peak_times: jax.Array
    peak_loads: tuple


class FatigueStats(eqx.Module):
    """What the bearing's fatigue life (`jaxbearing.life`) needs, integrated over the solution
    itself per interval between the solve's stops (t0, the model's ``window_start``, the
    ``window_edges`` asked for, t1), for one bearing joint (`BearingResult.fatigue`).

    Every integrand is weighted by the relative revolutions the rings turn, w = |omega_inner -
    omega_outer| / (2 pi) [rev/s], and integrated as `SegmentStats`' integrals are (3-point
    Gauss–Legendre quadrature of each accepted step's interpolant, a step across an event only
    up to the event). Loads Q are divided by `FORCE_SCALE` before their powers.

    Fields (C = number of stops):
        t_start, t_end: (C,) [s] of each interval, up to where the solve reached.
        integrals: (C, 5), the integrals over the interval of: 1 (its duration) [s], w [rev],
            w (|F| / FORCE_SCALE)^p (F the resultant, Eq. 28; p the bearing's
            ``life_exponent``, 3 for balls, 10/3 for rollers), w mean over balls of
            (Q_r / FORCE_SCALE)^3, and of (Q_r / FORCE_SCALE)^(10/3). Columns ``FAT_*``.
        inner, outer: (C, M), w (Q_k / FORCE_SCALE)^3 integrated for each of M =
            `RING_POINTS_PER_BALL` x N_b points fixed in the inner and the outer ring, point k
            at 2 pi k / M in its ring body's frame (`BearingJoint.ring_point_loads`).
        valid: (C,) bool, True where the interval holds part of the solved span.
    """

    t_start: jax.Array
    t_end: jax.Array
    integrals: jax.Array
    inner: jax.Array
    outer: jax.Array
    valid: jax.Array


class BearingInstant(eqx.Module):
    """One bearing joint at one instant (`Instant.bearings`): ``ball_loads`` (N_b,) [N], ball 1
    first; ``force`` (2,) [N], the resultant on its outer-race body (Eq. 28); ``cage_angle``
    [rad]."""

    ball_loads: jax.Array
    force: jax.Array
    cage_angle: jax.Array


class ContactInstant(eqx.Module):
    """One impact contact at one instant (`Instant.contacts`): its normal ``force`` [N] and
    ``penetration`` [m] (negative when apart)."""

    force: jax.Array
    penetration: jax.Array


class Instant(eqx.Module):
    """The solution at one instant, as the solve computed it (what a metric of your own reads,
    `metrics.Peak`, `metrics.Mean`): time ``t`` [s], coordinates ``q`` and velocities ``qd``
    (n_coordinates,), and the forces there with the solve's switches in force (each ball's
    engagement, each contact's approach speed): ``bearings`` (a `BearingInstant` per bearing
    joint, model order) and ``contacts`` (a `ContactInstant` per impact contact)."""

    t: jax.Array
    q: jax.Array
    qd: jax.Array
    bearings: tuple
    contacts: tuple


class AbstractRecord(eqx.Module):
    """A quantity of your own that the solve records from every accepted step (`metrics.Peak`,
    `metrics.Mean`): ``fn(model, x) -> scalar`` with ``x`` an `Instant`, over the window
    from ``t_min`` to ``t_max`` [s] (None: the model's ``window_start``, or t0 without one; t1),
    whose edges the solve stops at. ``reduction`` is "peak" (a column of
    `SegmentStats.peaks`) or "mean" (of `SegmentStats.integrals`)."""

    fn: Callable = eqx.field(static=True)
    t_min: float | None = eqx.field(static=True)
    t_max: float | None = eqx.field(static=True)
    reduction: eqx.AbstractClassVar[str]

    def at(self, model, x: Instant) -> jax.Array:
        """``fn(model, x)`` at one instant, a float64 scalar; a ValueError where it is not a
        scalar."""
        v = jnp.asarray(self.fn(model, x), jnp.float64)
        if v.shape != ():
            raise ValueError(
                f"A record's fn(model, x) must return a scalar; {self.fn!r} returned shape {v.shape}."
            )
        return v

    def edges(self) -> tuple:
        """The window edges [s] the solve stops at for this record."""
        return tuple(float(t) for t in (self.t_min, self.t_max) if t is not None)


class BearingSamples(eqx.Module):
    """One bearing joint at the output times (`Samples.bearings`, model order; T of them, NaN
    at the times a failed run did not reach): ``ball_loads`` (T, N_b) [N], ball 1 first
    ("ball" names a rolling element of any kind); ``force`` (T, 2) [N], the resultant on its
    outer-race body (Eq. 28); ``cage_angle`` (T,) [rad]."""

    ball_loads: jax.Array
    force: jax.Array
    cage_angle: jax.Array


class BearingResult(eqx.Module):
    """What a solve gives of one bearing joint (`Solution.bearings`, in model order): its
    samples (`BearingSamples`: ``ball_loads``, ``force``, ``cage_angle``) and its ``fatigue``
    record (`FatigueStats`, what its life reads; None where not recorded:
    ``SolveOptions(fatigue=False)``)."""

    ball_loads: jax.Array
    force: jax.Array
    cage_angle: jax.Array
    fatigue: FatigueStats | None


class Samples(eqx.Module):
    """What the solve evaluated at the output times (`Solution.samples`). Fields (T = number
    of output times; NaN at the times a run that failed did not reach):

        q, qd, qdd: (T, n_coordinates) coordinates [m, rad], velocities, accelerations; bodies
            in model order, [x, y, theta] each.
        bearings: one `BearingSamples` per bearing joint (``model.bearings`` order).
        contact_forces: (T, K) [N], the normal force of each impact contact
            (``model.contacts`` order).
        penetrations: (T, K) [m], the penetration of each contact (negative when apart).
        approach_speed: (T, K) [m/s], approach speed in force at each output time.
        drift: (T,) max |Phi(q, t)| [m or rad], the constraint violation.
    """

    q: jax.Array
    qd: jax.Array
    qdd: jax.Array
    bearings: tuple
    contact_forces: jax.Array
    penetrations: jax.Array
    approach_speed: jax.Array
    drift: jax.Array


class Records(eqx.Module):
    """What the solve recorded from every accepted step and its interpolant, whatever the
    output times (`Solution.records`): the built-in records and, read as a mapping
    (``sol.records[name]``), the value of each metric of your own declared for the solve
    (``SolveOptions(records=...)``: `metrics.Peak`, `metrics.Mean`) over its window.

    Fields:
        segments: `SegmentStats`, peaks and integrals between the stops (what the metrics read).
        contacts: `Contacts`, the onsets, ends and peak forces of the impact contacts.
        fatigue: one `FatigueStats` per bearing joint, model order (None where not recorded).
        max_drift: the largest constraint violation max |Phi(q, t)| [m or rad] at the end of
            every accepted step (0 without joints); `simulate` warns where it exceeds
            `drift_bound` of the model.
        values: name -> value of each metric of your own.
        declared: the ((name, record), ...) the solve recorded (static).
    """

    segments: SegmentStats
    contacts: Contacts
    fatigue: tuple
    max_drift: jax.Array
    values: dict
    declared: tuple = eqx.field(static=True, default=())

    def __getitem__(self, name: str) -> jax.Array:
        if name not in self.values:
            raise KeyError(
                f"No record named {name!r}: the solve recorded {sorted(self.values)} (declare "
                "yours in SolveOptions(records={name: metric}))."
            )
        return self.values[name]

    def __iter__(self):
        return iter(self.values)

    def __len__(self) -> int:
        return len(self.values)

    def __contains__(self, name) -> bool:
        return name in self.values

    def keys(self):
        return self.values.keys()

    def items(self):
        return self.values.items()


class Solution(eqx.Module):
    """Result of `simulate`, as diffrax's: the output ``ts`` and what the solve evaluated there
    (``samples``), what it recorded of every accepted step (``records``), its solver statistics
    (``stats``) and ``result``.

    Fields:
        ts: (T,) the output times [s].
        samples: `Samples` at the output times (q, qd, qdd, each bearing's ball loads, resultant
            and cage angle, each contact's force and penetration, drift).
        records: `Records` (`SegmentStats`, `Contacts`, each bearing's `FatigueStats`, the max
            drift, and ``sol.records[name]`` of each metric of your own).
        stats: solver statistics: ``num_steps``, ``num_rejected_steps`` (over all segments),
            ``num_segments`` (segments of ``segment_steps`` iterations `simulate` used; 1 for
            `simulate_one_loop`), ``num_events`` (contact onsets and separations, ball
            engagements and releases located).
        result: a `RESULTS` code (successful unless a segment failed).
        t_final: time reached [s] (t1 unless the solve failed).
        t1: the final time asked for [s]; a metric's window ends there by default, and one
            that ends after ``t_final`` has no value (`metrics.reached`).
        window_start: the model's ``window_start`` [s], where the metrics' and the life's
            default window starts; None: at the start of the solve.
        targets: for each contact, the index in q of the x coordinate of its body k (the body
            its normal force pushes along +n: `CircleContact`) (static).

    Each field of `Samples`, `Records` and ``stats`` is also read directly (``sol.q``,
    ``sol.segments``, ``sol.num_steps``, ...); ``sol.bearings[i]`` is bearing i's
    `BearingResult` (samples and fatigue). A model with one bearing joint or one contact reads
    it by the short names ``ball_loads``, ``bearing_force``, ``cage_angle``, ``fatigue``,
    ``contact_force``, ``penetration`` and ``target``; on a model with several they raise a
    `ValueError` naming ``sol.bearings[i]`` or ``sol.contact_forces[:, j]``.
    """

    ts: jax.Array
    samples: Samples
    records: Records
    stats: dict
    result: RESULTS
    t_final: jax.Array
    t1: jax.Array
    window_start: jax.Array | None = None
    targets: tuple = eqx.field(static=True, default=())

    q = property(lambda self: self.samples.q, doc="(T, n_coordinates) [m, rad] (`Samples`).")
    qd = property(lambda self: self.samples.qd, doc="(T, n_coordinates) velocities (`Samples`).")
    qdd = property(lambda self: self.samples.qdd, doc="(T, n_coordinates) accelerations (`Samples`).")
    contact_forces = property(lambda self: self.samples.contact_forces, doc="(T, K) [N] (`Samples`).")
    penetrations = property(lambda self: self.samples.penetrations, doc="(T, K) [m] (`Samples`).")
    approach_speed = property(lambda self: self.samples.approach_speed, doc="(T, K) [m/s] (`Samples`).")
    drift = property(lambda self: self.samples.drift, doc="(T,) max |Phi| [m or rad] (`Samples`).")
    segments = property(lambda self: self.records.segments, doc="`SegmentStats` (`Records`).")
    contacts = property(lambda self: self.records.contacts, doc="`Contacts` (`Records`).")
    max_drift = property(lambda self: self.records.max_drift, doc="max |Phi| over the run (`Records`).")
    declared = property(lambda self: self.records.declared, doc="((name, record), ...) (`Records`).")
    num_steps = property(lambda self: self.stats["num_steps"], doc="Solver steps (``stats``).")
    num_rejected_steps = property(lambda self: self.stats["num_rejected_steps"], doc="Rejected steps (``stats``).")
    num_segments = property(lambda self: self.stats["num_segments"], doc="Segments used (``stats``).")
    num_events = property(lambda self: self.stats["num_events"], doc="Events located (``stats``).")

    @property
    def bearings(self) -> tuple:
        """One `BearingResult` per bearing joint, model order: its samples and its fatigue."""
        return tuple(
            BearingResult(b.ball_loads, b.force, b.cage_angle, fatigue)
            for b, fatigue in zip(self.samples.bearings, self.records.fatigue)
        )

    @property
    def n_bearings(self) -> int:
        """Bearing joints of the model (B)."""
        return len(self.samples.bearings)

    @property
    def n_contacts(self) -> int:
        """Impact contacts of the model (K)."""
        return self.contact_forces.shape[-1]

    def _only_bearing(self):
        """The model's one bearing joint's `BearingResult` (None without); a ValueError with
        several."""
        if self.n_bearings > 1:
            raise ValueError(
                f"This model has {self.n_bearings} bearing joints: read each as "
                f"sol.bearings[i] (i from 0 to {self.n_bearings - 1}, model order), e.g. "
                "sol.bearings[1].ball_loads."
            )
        return self.bearings[0] if self.n_bearings else None

    def _only_contact(self, x):
        """Column 0 of ``x`` (T, K) for a model with one contact (zeros without); a ValueError
        with several."""
        if x.shape[-1] > 1:
            raise ValueError(
                f"This model has {x.shape[-1]} impact contacts: read each as a column of "
                "sol.contact_forces or sol.penetrations (model order)."
            )
        return x[..., 0] if x.shape[-1] else jnp.zeros(x.shape[:-1], x.dtype)

    @property
    def ball_loads(self) -> jax.Array | None:
        """(T, N_b) [N] of the model's only bearing joint (None without one)."""
        only = self._only_bearing()
        return None if only is None else only.ball_loads

    @property
    def bearing_force(self) -> jax.Array | None:
        """(T, 2) [N], the only bearing's resultant on its outer-race body (Eq. 28)."""
        only = self._only_bearing()
        return None if only is None else only.force

    @property
    def cage_angle(self) -> jax.Array | None:
        """(T,) [rad] of the only bearing's cage."""
        only = self._only_bearing()
        return None if only is None else only.cage_angle

    @property
    def fatigue(self) -> FatigueStats | None:
        """`FatigueStats` of the only bearing (None without one, or not recorded)."""
        only = self._only_bearing()
        return None if only is None else only.fatigue

    @property
    def contact_force(self) -> jax.Array:
        """(T,) [N], normal force of the model's only impact contact (zeros without)."""
        return self._only_contact(self.contact_forces)

    @property
    def penetration(self) -> jax.Array:
        """(T,) [m], penetration of the model's only impact contact (zeros without)."""
        return self._only_contact(self.penetrations)

    @property
    def target(self) -> int | None:
        """Index in q of the x coordinate of the only contact's body k (None without a
        contact)."""
        if len(self.targets) > 1:
            raise ValueError(
                f"This model has {len(self.targets)} impact contacts: their targets are "
                "sol.targets (model order)."
            )
        return self.targets[0] if self.targets else None


def map_per_time(fn, sol: Solution, *more: Solution) -> Solution:
    """``sol`` with ``ts`` and each array of its `Samples` x (first axis: the output times)
    replaced by ``fn(x, *the same array of each of more)``."""
    ts = fn(sol.ts, *(m.ts for m in more))
    samples = jax.tree_util.tree_map(fn, sol.samples, *(m.samples for m in more))
    return dataclasses.replace(sol, ts=ts, samples=samples)


@functools.partial(jax.jit, static_argnums=1)
def first_rows(sol: Solution, n: int) -> Solution:
    """``sol`` with its per-time fields cut to the first ``n`` output times (a solve padded its
    output times to share a compiled solve: `solve._simulate._bucketed`)."""
    return map_per_time(lambda x: x[:n], sol)


DRIFT_FRACTION = 0.01  # of the smallest positive diametral bearing clearance: `drift_bound`
DRIFT_SIZE_FRACTION = 1e-4  # of the mechanism's size, where no bearing has a clearance


def drift_bound(model) -> float:
    """The constraint drift [m] above which a run is not trusted (`warn_if_drifting`):
    `DRIFT_FRACTION` of the smallest positive diametral clearance of the model's bearing
    joints (the joints then move by a visible fraction of the play the bearing forces act
    over), else `DRIFT_SIZE_FRACTION` of the mechanism's size (the largest distance between
    two bodies' initial positions, at least 1 m where all start at one point)."""
    clearances = [float(np.asarray(j.bearing.clearance)) for j in model.bearings]
    positive = [c for c in clearances if c > 0.0]
    if positive:
        return DRIFT_FRACTION * min(positive)
    xy = np.asarray(model.q0).reshape(-1, 3)[:, :2]
    size = float(np.max(np.linalg.norm(xy[:, None] - xy[None], axis=-1))) if len(xy) else 0.0
    return DRIFT_SIZE_FRACTION * (size if size > 0.0 else 1.0)


class DriftWarning(UserWarning):
    """A run's joints drifted further than `drift_bound`: its forces are not trusted."""


def warn_if_drifting(sol: Solution, model) -> None:
    """Warn (`DriftWarning`) where ``sol.max_drift`` exceeds `drift_bound` of ``model``; nothing
    where either is traced (under your own transformations: read ``sol.max_drift``)."""
    if not is_concrete(sol.max_drift, model.q0, *(j.bearing.clearance for j in model.bearings)):
        return
    drift, bound = float(sol.max_drift), drift_bound(model)
    if drift > bound:
        warnings.warn(
            f"The joints drifted by up to {drift:.3g} m (max |Phi|, sol.max_drift), beyond the "
            f"{bound:.3g} m this model allows (jaxbearing.solution.drift_bound): the solver met "
            "its tolerance, the joints did not. Tighten the tolerances, e.g. "
            "stepsize_controller=jaxbearing.default_controller(rtol=1e-8, atol=1e-10), and check "
            "the metrics with jaxbearing.metrics.converged.",
            DriftWarning,
            stacklevel=3,
        )


def raise_on_failure(sol: Solution, t1, broken: _checks.Broken, root_steps: int) -> Solution:
    """``sol``, or the error its result code stands for: a `SimulationError` saying when and what
    to change (``root_steps``: the steps the solve's root finder has to locate an event); for
    `RESULTS.invalid_input` the `ValueError` of the broken rule that the solve returned
    (``broken``), where the values are concrete. Under your own transformations (traced
    results) the same messages come from `eqx.error_if` checks after the solve."""
    failed = sol.result != RESULTS.successful
    if is_concrete(failed, broken.index) and bool(sol.result == RESULTS.invalid_input):
        _checks.raise_broken(broken)
    if is_concrete(failed, sol.t_final):
        if bool(failed):
            if bool(sol.result == RESULTS.contact_overlap):
                cause = ""  # the result says it all
            elif bool(sol.result == RESULTS.event_not_located):
                cause = f" The root finder takes at most {root_steps} steps."
            else:
                cause = (
                    " Likely cause: a step limit too low for stiff contacts (raise max_steps), more "
                    "iterations than max_segments x segment_steps (raise max_segments), tolerances float64 "
                    "cannot meet (rtol below about 1e-13), or parameters that make the model blow "
                    "up (check stiffness, clearance and masses)."
                )
            raise SimulationError(
                f"The simulation stopped at t = {float(sol.t_final):.6g} s of t1 = {float(t1):.6g} s: "
                f"{RESULTS[sol.result]}{cause} Pass throw=False to inspect the partial solution."
            )
        return sol
    # under jit/vmap/grad: the broken rule's message, else the failing member's (`RESULTS`)
    sol = _checks.enforce(sol, broken)
    return sol.result.error_if(sol, failed)

"""What `jaxbearing.simulate` returns, and what the metrics and the life read from it: the
`Solution`, its `Contacts`, `SegmentStats` and `FatigueStats`, the result codes (`RESULTS`,
`SimulationError`) and the columns of the statistics, each defined once, with what each holds
at one state (`_forces`, `_integrands`, `_fatigue_integrands`).
The integrator (`jaxbearing.solve`) writes these (`assemble`: the `Solution` from the solve's
final state and its outputs; `raise_on_failure`: the error a result code stands for);
`jaxbearing.metrics` and `jaxbearing.life` read them without importing the solver.
"""

from __future__ import annotations

import functools

import diffrax
import equinox as eqx
import jax
import jax.numpy as jnp

from . import _checks
from ._checks import is_concrete
from .laws import bearing as bearing_law

POWER = 16  # order p of the power integrals in `SegmentStats` (the smooth metrics' p)
FORCE_SCALE = 1e3  # [N] forces are divided by it before the power p: no overflow below 1e22 N
# columns of SegmentStats.peaks and .integrals
PEAK_BALL_LOAD, PEAK_BEARING_FORCE, PEAK_CONTACT_FORCE, PEAK_DISPLACEMENT = 0, 1, 2, 3
(INT_BEARING_FORCE_SQUARED, INT_BALL_LOAD_POWER, INT_BEARING_FORCE_POWER, INT_CONTACT_FORCE_POWER,
 INT_TIME) = range(5)

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
            reached; recorded for the model's first contact only, NaN for the others.
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
        peaks: (C, 3 + n_coordinates), the maxima over the interval of: the largest ball load
            of the model's first bearing [N], the magnitude |F| of its resultant (Eq. 28) [N],
            the normal force of the first impact contact [N], then |q_c - q0_c| of each
            coordinate [m or rad]; 0 for an element the model lacks, and in intervals the solve
            did not reach. Columns ``PEAK_*``.
        integrals: (C, 5), the integrals over the interval of: |F|^2 [N^2 s], the sum over balls
            of (F_r / FORCE_SCALE)^POWER [s], (|F| / FORCE_SCALE)^POWER [s], (contact force /
            FORCE_SCALE)^POWER [s], and 1 (the interval's solved duration) [s]. Columns
            ``INT_*``.
        valid: (C,) bool, True where the interval holds part of the solved span.
        peak_times: (C, 3 + n_coordinates) [s], where each of ``peaks`` is attained: the
            earliest recorded point (step point or vertex) that attains it; NaN in intervals
            the solve did not reach.
        peak_loads: (C, N_b) [N], every ball's load at the time of the interval's largest ball
            load (``peak_times[:, PEAK_BALL_LOAD]``), ball 1 first; (C, 0) without a bearing, 0
            in intervals the solve did not reach.
    """

    t_start: jax.Array
    t_end: jax.Array
    peaks: jax.Array
    integrals: jax.Array
    valid: jax.Array
    peak_times: jax.Array
    peak_loads: jax.Array


class FatigueStats(eqx.Module):
    """What the bearing's fatigue life (`jaxbearing.life`) needs, integrated over the solution
    itself per interval between the solve's stops (t0, the model's ``window_start``, the
    ``window_edges`` asked for, t1), for the model's first bearing joint.

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


class Solution(eqx.Module):
    """Result of `simulate`: states and force outputs at the requested times.

    Fields (T = number of output times; the per-time fields are NaN at the times a run that
    failed did not reach):
        ts: (T,) [s].
        q, qd, qdd: (T, n_coordinates) coordinates [m, rad], velocities, accelerations; bodies
            in model order, [x, y, theta] each.
        ball_loads: (T, N_b) [N] of the model's first bearing joint, ball 1 first (None
            without a bearing).
        bearing_force: (T, 2) [N], resultant on its outer-race body (Eq. 28) (None without).
        cage_angle: (T,) [rad] of that bearing (None without).
        contact_force: (T,) [N], normal force of the first impact contact (zeros without).
        penetration: (T,) [m], penetration of the first impact contact (zeros without).
        approach_speed: (T, n_contacts) [m/s], approach speed in force at each output time.
        drift: (T,) max |Phi(q, t)| [m or rad], the constraint violation.
        contacts: `Contacts`, the onsets.
        segments: `SegmentStats`, peaks and integrals between the stops (what the metrics read).
        fatigue: `FatigueStats`, what the bearing's life reads (None without a bearing).
        result: a `RESULTS` code (successful unless a segment failed).
        t_final: time reached [s] (t1 unless the solve failed).
        num_steps, num_rejected_steps: solver steps over all segments.
        num_segments: segments of ``segment_steps`` iterations the solve used (`simulate`; 1
            for `simulate_one_loop`).
        num_events: events located: contact onsets and separations, ball engagements and
            releases.
        target: index in q of the x coordinate of the impact target, body k of the model's
            first contact (`CircleContact`: the body its normal force pushes along +n); None
            for a model without impact contact (static).
        window_start: the model's ``window_start`` [s], where the metrics' and the life's
            default window starts; None: at the start of the solve.
    """

    ts: jax.Array
    q: jax.Array
    qd: jax.Array
    qdd: jax.Array
    ball_loads: jax.Array | None
    bearing_force: jax.Array | None
    cage_angle: jax.Array | None
    contact_force: jax.Array
    penetration: jax.Array
    approach_speed: jax.Array
    drift: jax.Array
    contacts: Contacts
    segments: SegmentStats
    fatigue: FatigueStats | None
    result: RESULTS
    t_final: jax.Array
    num_steps: jax.Array
    num_rejected_steps: jax.Array
    num_segments: jax.Array
    num_events: jax.Array
    window_start: jax.Array | None = None
    target: int | None = eqx.field(static=True, default=None)


# What the solution holds at one state, which the solve evaluates at the output times and along
# each step (`solve._recording`): the forces the outputs report, and the integrands and peak
# candidates of the statistics' columns.

INTEGRALS = 5  # integrands of `SegmentStats` (`_integrands`)


def _forces(model, t, q, qd, approach_speeds, engaged):
    """Forces that the outputs and the metrics report: ``ball_loads`` (N_b,) [N], ``cage`` [rad]
    and ``bearing_force`` (2,) [N] of the first bearing joint, ``contact_force`` [N] and
    ``penetration`` [m] of the first impact contact (each only where the model has one)."""
    bearing = _bearing_forces(model, t, q, qd, engaged)
    return bearing | _contact_forces(model, t, q, qd, approach_speeds)


def _bearing_forces(model, t, q, qd, engaged):
    """The first bearing joint's part of `_forces` (empty without one)."""
    if not model.bearings:
        return {}
    first = model.engaged_by_bearing(engaged)[0]
    loads, cage = model.bearings[0].ball_loads(t, q, qd, model.q0, model.qd0, first)
    return {"ball_loads": loads, "cage": cage, "bearing_force": bearing_law.resultant(loads, cage)}


def _contact_forces(model, t, q, qd, approach_speeds):
    """The first impact contact's part of `_forces` (empty without one)."""
    if not model.contacts:
        return {}
    return {
        "contact_force": model.contacts[0].forces(t, q, qd, approach_speeds[0])[0],
        "penetration": model.contacts[0].gap(q, qd)[0],
    }


def _peaks(model, q, f):
    """The peak candidates (3 + n,) of `SegmentStats` at one state with forces ``f``."""
    zero = jnp.zeros((), q.dtype)
    contact = f.get("contact_force", zero)
    largest = jnp.max(f.get("ball_loads", zero[None]))
    return jnp.concatenate([jnp.stack([largest, _magnitude(f), contact]), jnp.abs(q - model.q0)])


def _squared(f):
    """|F|^2 [N^2] of the bearing resultant in ``f`` (0 without a bearing)."""
    resultant = f.get("bearing_force", jnp.zeros(2))
    return jnp.sum(resultant * resultant)


def _magnitude(f):
    """|F| [N] of the bearing resultant in ``f`` (0 without a bearing)."""
    return jnp.sqrt(_squared(f) + 1e-30)


def _integrands(t, f):
    """The integrands (`INTEGRALS`,) of `SegmentStats` at one state with forces ``f``."""
    zero = jnp.zeros((), t.dtype)
    magnitude = _magnitude(f)
    return jnp.stack(
        [
            _squared(f),
            jnp.sum((f.get("ball_loads", zero[None]) / FORCE_SCALE) ** POWER),
            (magnitude / FORCE_SCALE) ** POWER,
            (f.get("contact_force", zero) / FORCE_SCALE) ** POWER,
            jnp.ones_like(t),
        ]
    )


def _fatigue_integrands(model, q, qd, f):
    """The integrands (5 + 2 M,) of `FatigueStats` at one state with forces ``f`` (a model
    with a bearing)."""
    joint = model.bearings[0]
    w = jnp.abs(joint.relative_speed(q, qd)) / (2.0 * jnp.pi)
    balls = f["ball_loads"] / FORCE_SCALE
    force = f["bearing_force"] / FORCE_SCALE
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
    return jnp.concatenate([scalars, w * jnp.ravel((points / FORCE_SCALE) ** 3)])


def fatigue_size(model, fatigue: bool) -> int:
    """Length of the `FatigueStats` integrands: 5 + 2 M with a bearing, else (or when not
    recorded) 0."""
    if not (model.bearings and fatigue):
        return 0
    return 5 + 2 * RING_POINTS_PER_BALL * model.bearings[0].bearing.n_balls


_PER_TIME = (
    "ts", "q", "qd", "qdd", "ball_loads", "bearing_force", "cage_angle", "contact_force",
    "penetration", "approach_speed", "drift",
)


def assemble(model, x, outputs: dict, ts, stops, t0, result, n_segments) -> Solution:
    """The `Solution` of a solve of ``model`` that ended in state ``x`` (the integrator core's
    `State`) with ``result``: the per-time fields from ``outputs`` (at the output times ``ts``:
    ``q``, ``qd``, ``qdd``, ``drift``, ``approach`` and the forces the model has, keyed as
    `_forces` keys them), and from ``x`` the records: `SegmentStats` and
    `FatigueStats` of the intervals between the ``stops`` [s] after t0, cut at the time reached
    (peaks 0 and their times NaN in the intervals not reached), and the `Contacts`."""
    t_start = jnp.minimum(jnp.concatenate([t0[None], stops[:-1]]), x.t)
    t_end = jnp.minimum(stops, x.t)
    valid = t_end > t_start  # the interval holds part of the solved span
    reached = lambda rows, rest: jnp.where(valid[:, None], rows, rest)  # noqa: E731
    peaks = x.peaks
    segments = SegmentStats(
        t_start,
        t_end,
        reached(peaks.values, 0.0),
        x.integrals,
        valid,
        reached(peaks.times, jnp.nan),
        reached(peaks.loads, 0.0),
    )
    fatigue = None
    if x.fatigue.shape[-1]:  # (n_stops, 5 + 2 M): recorded, for a model with a bearing
        m = (x.fatigue.shape[1] - 5) // 2
        inner, outer = x.fatigue[:, 5 : 5 + m], x.fatigue[:, 5 + m :]
        fatigue = FatigueStats(t_start, t_end, x.fatigue[:, :5], inner, outer, valid)
    o, zeros = outputs, jnp.zeros_like(ts)
    return Solution(
        ts=ts,
        q=o["q"],
        qd=o["qd"],
        qdd=o["qdd"],
        ball_loads=o.get("ball_loads"),
        bearing_force=o.get("bearing_force"),
        cage_angle=o.get("cage"),
        contact_force=o.get("contact_force", zeros),
        penetration=o.get("penetration", zeros),
        approach_speed=o["approach"],
        drift=o["drift"],
        contacts=_contacts(x),
        segments=segments,
        fatigue=fatigue,
        result=result,
        t_final=x.t,
        num_steps=x.steps,
        num_rejected_steps=x.rejected,
        num_segments=n_segments,
        num_events=x.events,
        target=3 * model.contacts[0].body_k if model.contacts else None,
        window_start=model.window_start,
    )


def _contacts(x) -> Contacts:
    """The `Contacts` of the core's final state ``x``: its onsets (time, approach speed, contact
    index) and their contacts' spans (end, peak force, peak time), each (max_onsets,)."""
    time, speed, index = x.onsets
    kept = jnp.arange(time.shape[0]) < x.n_onsets
    end, peak, peak_time = x.spans
    found = kept & (index == 0) & (peak > -jnp.inf)
    return Contacts(
        jnp.where(kept, time, jnp.nan),
        jnp.where(kept, speed, jnp.nan),
        jnp.where(kept, index, -1),
        kept,
        jnp.where(kept, end, jnp.nan),
        jnp.where(found, peak, jnp.nan),
        jnp.where(found, peak_time, jnp.nan),
    )


@functools.partial(jax.jit, static_argnums=1)
def first_rows(sol: Solution, n: int) -> Solution:
    """``sol`` with its per-time fields cut to the first ``n`` output times (a solve padded its
    output times to share a compiled solve: `solve._simulate._bucketed`)."""
    fields = [f for f in _PER_TIME if getattr(sol, f) is not None]
    return eqx.tree_at(
        lambda s: [getattr(s, f) for f in fields], sol, [getattr(sol, f)[:n] for f in fields]
    )


def raise_on_failure(sol: Solution, t1, rules, root_steps: int) -> Solution:
    """``sol``, or the error its result code stands for: a `SimulationError` saying when and what
    to change (``root_steps``: the steps the solve's root finder has to locate an event); for
    `RESULTS.invalid_input` the broken rule of ``rules()`` (`_checks.start_rules`), a
    `ValueError` where the values are concrete. Under your own transformations (traced results)
    the same messages come from `eqx.error_if` checks around the solve."""
    failed = sol.result != RESULTS.successful
    if is_concrete(failed) and bool(sol.result == RESULTS.invalid_input):
        _checks.raise_if_concrete(rules())
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
    sol = _checks.enforce(sol, rules())
    return sol.result.error_if(sol, failed)

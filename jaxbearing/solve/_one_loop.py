"""`simulate_one_loop`: the solve as one while loop per member, for large batches on accelerators.

`simulate` runs a `lax.scan` of segments, each a `diffrax.diffeqsolve` with its own loops (the
step loop, the event's root find, the output writes): on a GPU every loop iteration is a host
round trip and every step launches a few hundred kernels (docs/platforms.md). Here one
iteration of one `lax.while_loop` does all of a step's work with selects instead of branches, so
that a vmapped batch runs as one loop whose body XLA fuses into few kernels:

1. a member that is locating an event takes one step of the ITP root finder (`_segment`'s
   `_EventRoot` method, on the stored step's interpolant); once the bracket is narrower than
   `EVENT_TIME_TOLERANCE` it ends the step at the bracket's upper end, records it, and switches
   what the event found, as `simulate`'s segment ends do (`_segment._switch`);
2. every member then evaluates Tsit5's stages 2–7 (diffrax's tableau, FSAL). A member that has
   just switched uses the first of these evaluations for its new first stage instead (the
   right-hand side changed with the switch), and attempts its next step in the next iteration;
3. diffrax's `PIDController` (simulate's default: pcoeff = icoeff = 0.3) accepts or rejects the
   step, and proposes the next one; steps end at the stops (`WINDOW_START`, ``window_edges``,
   t1), so that the metrics' windows line up with the recorded intervals;
4. an accepted step after which an event value is positive is not taken: its member locates
   the event (1.) in the next iterations. Otherwise the step's `SegmentStats` (and
   `FatigueStats`) are recorded from its interpolant exactly as `simulate` records them
   (`_recording._step_stats`).

It integrates the same equations with the same solver, controller and event rules as `simulate`,
so its metrics agree with `simulate`'s to the solver's accuracy (not to the last bit: the steps
differ where `simulate` restarts a segment). It keeps no output times (the `Solution` has two:
t0 and the time reached). It is differentiable in forward mode (`jax.jvp`, `jax.jacfwd`, also
under `jax.vmap`: batched sensitivities): each located event time carries the tangent of the
implicit function theorem (`_event_time`), as `simulate`'s segments do; reverse mode raises
(a while loop), use `simulate` there. Where `simulate` counts
``max_steps`` per segment, here it bounds the steps (accepted and rejected) of the whole run.
A member fails (`RESULTS`) when its steps run out, when a proposed step falls below
`SMALLEST_STEP`, and, as in `simulate`, when a contact switches on while its surfaces overlap
(there its force jumps, so such a member's steps shrink until they fall below `SMALLEST_STEP`).
"""

from __future__ import annotations

import functools
from typing import NamedTuple

import diffrax
import equinox.internal as eqxi
import equinox as eqx
import jax
import jax.numpy as jnp

from .. import _checks
from ..multibody.mechanism import Mechanism
from ..solution import PEAK_CONTACT_FORCE, RESULTS, Contacts
from ._recording import (
    INTEGRALS,
    Peaks,
    _accelerations,
    _add,
    _forces,
    _step_stats,
    fatigue_size,
    no_peaks,
    point_peaks,
)
from ._segment import (
    EVENT_TIME_TOLERANCE,
    JUMP,
    _ITPState,
    _switch,
    event_values,
    first_contact_peaks,
    itp_start,
    itp_step,
)
from ._options import SolveOptions
from ._simulate import (
    INITIAL_STEP,
    _check_max_steps,
    _checked_controller,
    _checked_options,
    _checked_span,
    _fatigue_stats,
    _intervals,
    _outputs,
    _raise_on_failure,
    _where_rows,
    segment_stats,
    start_rules,
    window_stops,
)
from ._stops import _stops

ONSET_SLOTS = 64  # contact onsets kept in `Solution.contacts` (later ones are counted only)
ROOT_STEPS = 64  # root-finder steps after which an event is taken at its bracket's upper end
SMALLEST_STEP = 1e-15  # [s] a member whose proposed step falls below it has failed (dt_min_reached)

_TSIT5 = diffrax.Tsit5()
_ERROR_ORDER = 5  # Tsit5's, as diffrax passes it to the controller


def simulate_one_loop(
    model: Mechanism,
    t1: float,
    *,
    stepsize_controller: diffrax.PIDController | None = None,
    max_steps: int = 1_000_000,
    throw: bool = True,
    options: SolveOptions | None = None,
):
    """Integrate Eq. 36 from ``options.t0`` (default 0) to ``t1`` [s] in one while loop (module
    docstring) and return the `Solution` with what the metrics and the life read
    (``segments``, ``fatigue``, ``contacts``), and outputs at two times only: t0 and the time
    reached.

    Args:
        model: a `Mechanism`; starts from ``model.q0, qd0``.
        t1: final time [s], > t0.
        stepsize_controller: a `diffrax.PIDController` (default `default_controller()`), as in
            `simulate`.
        max_steps: steps (accepted and rejected) of the whole run, an integer >= 1.
        throw: raise on failure, as in `simulate`; with False, inspect ``sol.result``.
        options: `SolveOptions`; its ``t0``, ``window_edges`` and ``fatigue`` apply (the one
            loop has no segments).

    ``sol.contacts`` keeps the first `ONSET_SLOTS` contact onsets; ``num_segments`` counts the
    stops and events passed, as `simulate`'s segments would. Forward-mode derivatives
    (`jax.jvp`, `jax.jacfwd`) agree with `simulate`'s; reverse mode raises (use `simulate`).
    """
    _checks.require_x64()
    if not isinstance(model, Mechanism):
        raise TypeError(f"simulate_one_loop needs a jaxbearing Mechanism, got {type(model).__name__}.")
    model = _checks.float_leaves(model)
    options = _checked_options(options)
    controller = _checked_controller(stepsize_controller)
    if not isinstance(controller, diffrax.PIDController):
        raise TypeError(
            "simulate_one_loop steps with a diffrax.PIDController; got "
            f"{type(controller).__name__}."
        )
    t0, t1 = _checked_span(options.t0, t1)
    _check_max_steps(max_steps)
    stops = window_stops(options.window_edges)
    sol = _one_loop(model, t0, t1, controller, jnp.asarray(max_steps), stops, options.fatigue is not False)
    return _raise_on_failure(sol, t1, lambda: start_rules(model, t0, t1)) if throw else sol


class _State(NamedTuple):
    """The loop's state, one member."""

    t: jax.Array  # [s]
    y: jax.Array  # [q, qd] at t
    f: jax.Array  # dy/dt at t (Tsit5's first stage)
    h: jax.Array  # next step [s], as the controller proposed it
    control: tuple  # the PID controller's state
    cell: jax.Array  # index of the next stop
    approach: jax.Array  # (n_contacts,) [m/s]
    in_contact: jax.Array  # (n_contacts,) bool
    engaged: jax.Array  # (n_switched_balls,) bool
    locating: jax.Array  # an accepted step crossed an event: its root is being found
    step_end: jax.Array  # [s] that step's end
    step_k: jax.Array  # (7, 2n) its stage increments (the interpolant's data)
    step_h: jax.Array  # [s] the step the controller proposed after it
    root: _ITPState  # the root finder's state
    root_steps: jax.Array
    peaks: Peaks  # (n_stops, ...), as `simulate`'s carry
    integrals: jax.Array  # (n_stops, INTEGRALS)
    fatigue: jax.Array  # (n_stops, 5 + 2 M)
    onsets: tuple  # (time, approach speed, index) each (ONSET_SLOTS,)
    n_onsets: jax.Array
    spans: tuple  # (end [s], peak force [N], its time [s]) of each onset's contact (`Contacts`)
    current: jax.Array  # (n_contacts,) the onset slot of each contact in force, -1 for none
    events: jax.Array
    steps: jax.Array
    rejected: jax.Array
    done: jax.Array
    result: RESULTS


def _stages(vector_field, t, y, f, h, args, first):
    """Tsit5's step of ``h`` from (t, y) with first stage ``f`` (diffrax's tableau): (y1, error
    estimate, stage increments h f_i (7, 2n), the right-hand side at y1 (FSAL), the first
    evaluation's value). ``first`` = (where, t, y, args): where true, the first evaluation is
    made there instead of at the second stage's point."""
    tableau = _TSIT5.tableau
    k = [h * f]
    for i, (c, a) in enumerate(zip(tableau.c, tableau.a_lower)):
        ti = t + float(c) * h
        yi = y + sum(float(a[j]) * k[j] for j in range(len(a)))
        args_i = args
        if i == 0:
            instead, t_first, y_first, args_first = first
            ti, yi = jnp.where(instead, t_first, ti), jnp.where(instead, y_first, yi)
            args_i = jax.tree_util.tree_map(functools.partial(jnp.where, instead), args_first, args)
        value = vector_field(ti, yi, args_i)
        if i == 0:
            first_value = value
        k.append(h * value)
    y1 = y + sum(float(b) * k[j] for j, b in enumerate(tableau.b_sol) if b != 0.0)
    error = sum(float(b) * k[j] for j, b in enumerate(tableau.b_error))
    return y1, error, jnp.stack(k), value, first_value


@eqx.filter_jit
def _one_loop(model, t0, t1, controller, max_steps, extra_stops, fatigue):
    invalid = _checks.any_violated(start_rules(model, t0, t1))
    y0 = jnp.concatenate([model.q0, model.qd0])
    n = model.n_coordinates
    stops = _stops(t0, t1, 1, extra_stops)

    def vector_field(t, y, args):
        approach, _, engaged = args
        q, qd = y[:n], y[n:]
        return jnp.concatenate([qd, _accelerations(model, t, q, qd, approach, engaged)])

    def event_max(t, y, in_contact, engaged):
        return jnp.max(event_values(model, t, y, in_contact, engaged))

    has_events = bool(model.contacts or model.n_switched_balls)
    state = _initial_state(model, vector_field, stops, t0, t1, y0, fatigue, invalid)

    def body(s: _State) -> _State:
        args = (s.approach, s.in_contact, s.engaged)
        interpolation = _TSIT5.interpolation_cls(t0=s.t, t1=s.step_end, y0=s.y, y1=s.y, k=s.step_k)

        # 1. one root-finder step for the members locating an event
        def along(t):  # the event value along the step's interpolant
            return event_max(t, interpolation.evaluate(t), s.in_contact, s.engaged)

        root = s.root
        if has_events:
            root = jax.lax.stop_gradient(itp_step(root, along(root.next)))  # tangents: `_event_time`
            narrow = jnp.abs(root.upper - root.lower) < EVENT_TIME_TOLERANCE
            small = jnp.abs(root.error) < EVENT_TIME_TOLERANCE
            located = s.locating & ~s.done & narrow & (small | (s.root_steps + 1 >= ROOT_STEPS))
        else:
            located = jnp.zeros((), bool)
        t_event = root.upper
        if has_events:
            t_event = _event_time(along, t_event)
        y_event = interpolation.evaluate(t_event)
        approach, in_contact, engaged = s.approach, s.in_contact, s.engaged
        record = (s.t, s.t, jnp.asarray(-1), jnp.asarray(False))  # no onset
        separated = jnp.zeros_like(s.in_contact)
        overlap = jnp.zeros((), bool)
        if has_events:
            approach, in_contact, engaged, record, separated, overlap = _switch(
                model, s, t_event, y_event, located
            )
        events = s.events + located

        # 2. the stages: a step from (t, y), or the first stage after a switch
        t, y = jnp.where(located, t_event, s.t), jnp.where(located, y_event, s.y)
        new_args = (approach, in_contact, engaged)
        here = jnp.arange(stops.shape[0]) == s.cell  # one-hot rows: no gather or scatter (below)
        stop = jnp.sum(jnp.where(here, stops, 0.0))
        last = s.h >= stop - s.t
        h = jnp.where(last, stop - s.t, s.h)
        t_b = jnp.where(last, stop, s.t + h)
        y1, error, ks, f1, first = _stages(
            vector_field, s.t, s.y, s.f, h, args, (located, t, y, new_args)
        )
        stepping = ~s.done & ~s.locating
        keep, _, next_t1, _, control, _ = controller.adapt_step_size(
            s.t, t_b, s.y, y1, args, error, _ERROR_ORDER, s.control
        )
        finite = jnp.all(jnp.isfinite(y1)) & jnp.isfinite(next_t1)
        keep = keep & finite
        h_next = jnp.where(finite, next_t1 - jnp.where(keep, t_b, s.t), 0.2 * h)
        # a step cut short at a stop proposes from its short length: go on with the longer one
        h_next = jnp.where(keep & last, jnp.maximum(h_next, s.h), h_next)
        control = jax.tree_util.tree_map(lambda a, b: jnp.where(stepping & finite, a, b), control, s.control)
        crossed = jnp.zeros((), bool)
        if has_events:
            value_b = event_max(t_b, y1, s.in_contact, s.engaged)
            crossed = keep & (value_b > 0)
        accept = stepping & keep & ~crossed
        start = stepping & keep & crossed

        # 3. the stats of the step that ends here: an accepted one, or a located event's
        recorded = accept | located
        r_end = jnp.where(located, t_event, t_b)
        r_k = jnp.where(located, s.step_k, ks)
        r_step_end = jnp.where(located, s.step_end, t_b)
        stepped = _TSIT5.interpolation_cls(t0=s.t, t1=r_step_end, y0=s.y, y1=s.y, k=r_k)
        row = jax.tree_util.tree_map(lambda x: _row(x, here), (s.peaks, s.integrals, s.fatigue))
        stats = _step_stats(model, stepped, s.t, r_end, args, fatigue, _running(s, row[0]))
        row = jax.tree_util.tree_map(lambda a, b: jnp.where(recorded, a, b), _add(row, stats), row)
        into = lambda x, r: _where_rows(here, jnp.broadcast_to(r, x.shape), x)  # noqa: E731

        # 4. where each member goes on
        t_next = jnp.where(accept, t_b, t)
        y_next = jnp.where(accept, y1, y)
        at_stop = (accept & last) | (located & (t_event >= stop))
        reached = at_stop & (stop >= t1)
        too_small = stepping & ~keep & (h_next < SMALLEST_STEP)
        out_of_steps = stepping & (s.steps + 1 >= max_steps) & ~reached
        if has_events:
            # a step shrunk to nothing whose event value at its end is above `JUMP` holds a
            # jump: a contact switched on (``active_from``) while its surfaces overlap, whose
            # force jumps too, so that no step across is accepted (a continuous event value
            # cannot move by 1 nm in such a step)
            overlap = overlap | (too_small & (value_b > JUMP))
        result = RESULTS.where(too_small, RESULTS.dt_min_reached, s.result)
        result = RESULTS.where(out_of_steps & ~too_small, RESULTS.max_steps_reached, result)
        result = RESULTS.where(overlap, RESULTS.contact_overlap, result)
        if has_events:
            started = jax.lax.stop_gradient(itp_start(
                s.t, t_b, event_max(s.t, s.y, s.in_contact, s.engaged), value_b, EVENT_TIME_TOLERANCE
            ))
            root = jax.tree_util.tree_map(lambda a, b: jnp.where(start, a, b), started, root)
        onset = located & record[3]
        slot = onset & (jnp.arange(ONSET_SLOTS) == s.n_onsets)
        onsets = tuple(jnp.where(slot, v, o) for o, v in zip(s.onsets, record[:3]))
        spans, current = _spans(s, recorded, stats[0], separated, t_event, onset, record[2])
        return _State(
            t=t_next,
            y=y_next,
            f=jnp.where(located, first, jnp.where(accept, f1, s.f)),
            h=jnp.where(located, s.step_h, jnp.where(stepping, h_next, s.h)),
            control=control,
            cell=s.cell + (at_stop & ~reached),
            approach=approach,
            in_contact=in_contact,
            engaged=engaged,
            locating=(s.locating & ~located) | start,
            step_end=jnp.where(start, t_b, s.step_end),
            step_k=jnp.where(start, ks, s.step_k),
            step_h=jnp.where(start, h_next, s.step_h),
            root=root,
            root_steps=jnp.where(start, 0, s.root_steps + s.locating),
            peaks=jax.tree_util.tree_map(into, s.peaks, row[0]),
            integrals=into(s.integrals, row[1]),
            fatigue=into(s.fatigue, row[2]),
            onsets=onsets,
            n_onsets=s.n_onsets + onset,
            spans=spans,
            current=current,
            events=events,
            steps=s.steps + stepping,
            rejected=s.rejected + (stepping & ~keep),
            done=s.done | reached | too_small | out_of_steps | overlap,
            result=result,
        )

    final = jax.lax.while_loop(lambda s: ~s.done, body, state)
    final = eqxi.nondifferentiable_backward(
        final, msg="simulate_one_loop supports forward mode (jax.jvp, jax.jacfwd) only: use simulate for reverse mode."
    )
    t_final = final.t
    t_start, t_end, valid = _intervals(stops, t0, t_final)
    segments = segment_stats(t_start, t_end, final.peaks, final.integrals, valid)
    recorded = model.bearings and fatigue
    fatigue_stats = _fatigue_stats(final.fatigue, t_start, t_end, valid) if recorded else None
    ts = jnp.stack([t0, final.t])
    ends = (
        jnp.stack([y0, final.y]),
        jnp.stack([state.approach, final.approach]),
        jnp.stack([state.engaged, final.engaged]),
    )
    time, speed, index = final.onsets
    kept = jnp.arange(ONSET_SLOTS) < final.n_onsets
    end, peak, peak_time = final.spans
    contacts = Contacts(jnp.where(kept, time, jnp.nan), jnp.where(kept, speed, jnp.nan),
                        jnp.where(kept, index, -1), kept, jnp.where(kept, end, jnp.nan),
                        *first_contact_peaks(kept, index, peak, peak_time))
    return _outputs(
        model,
        ts,
        lambda start, size, in_blocks=False: tuple(
            jax.lax.dynamic_slice_in_dim(x, start, size) for x in ends
        ),
        2,
        2,
        contacts,
        segments,
        fatigue_stats,
        final.result,
        t_final,
        final.steps,
        final.rejected,
        jnp.sum(valid) + final.events,
    )


def _event_time(event, t_root):
    """The event time ``t_root`` [s] that the root finder located, with the tangent of the
    implicit function theorem: the event value ``event(t)`` (along the step's interpolant) is 0
    there, so dt = -(d event / d parameters) / (d event / dt). Its value is ``t_root``; the
    bracketing iterates carry no derivative."""
    t_root = jax.lax.stop_gradient(t_root)
    value, slope = jax.jvp(event, (t_root,), (jnp.ones_like(t_root),))
    slope = jax.lax.stop_gradient(slope)
    moved = value - jax.lax.stop_gradient(value)  # 0, with the tangent of the value at fixed t
    return t_root - jnp.where(slope != 0, moved / jnp.where(slope != 0, slope, 1.0), 0.0)


def _running(s: _State, peaks: Peaks) -> Peaks:
    """The peaks so far that decide whether a step is refined between its points: the stop
    interval's (``peaks``), and for the contact force the lower of that and the current
    contact's so far (-inf outside a contact), so that both peaks are the interpolant's."""
    if not s.current.shape[0]:
        return peaks
    current = jnp.arange(ONSET_SLOTS) == s.current[0]
    so_far = jnp.max(jnp.where(current & s.in_contact[0], s.spans[1], -jnp.inf))
    contact = jnp.minimum(peaks.values[PEAK_CONTACT_FORCE], so_far)
    return peaks._replace(values=peaks.values.at[PEAK_CONTACT_FORCE].set(contact))


def _spans(s: _State, recorded, peaks: Peaks, separated, t_event, onset, index):
    """`_State.spans` and ``current`` after an iteration: the first contact's peak joins its
    contact's where a step in contact was recorded (``peaks``: the step's), the contacts that
    ``separated`` end at ``t_event``, and an ``onset`` of contact ``index`` takes the next slot
    (none beyond `ONSET_SLOTS`)."""
    if not s.current.shape[0]:
        return s.spans, s.current
    slots = jnp.arange(ONSET_SLOTS)
    end, peak, peak_time = s.spans
    value, when = peaks.values[PEAK_CONTACT_FORCE], peaks.times[PEAK_CONTACT_FORCE]
    later = recorded & s.in_contact[0] & (slots == s.current[0]) & (value > peak)
    peak, peak_time = jnp.where(later, value, peak), jnp.where(later, when, peak_time)
    ends = jnp.any(separated[:, None] & (slots[None, :] == s.current[:, None]), axis=0)
    end = jnp.where(ends, t_event, end)
    contacts = jnp.arange(s.current.shape[0])
    starts = onset & (contacts == index) & (s.n_onsets < ONSET_SLOTS)
    current = jnp.where(separated, -1, jnp.where(starts, s.n_onsets, s.current))
    return (end, peak, peak_time), current


def _row(x, here):
    """The row of ``x`` (rows, ...) where the one-hot ``here`` (rows,) is true: a sum of
    selects, which a batch evaluates elementwise (a vmapped index would be a gather)."""
    return jnp.sum(_where_rows(here, x, jnp.zeros((), x.dtype)), axis=0, dtype=x.dtype)


def _initial_state(model, vector_field, stops, t0, t1, y0, fatigue, invalid) -> _State:
    """At t0: nothing in contact, the balls with delta_r > 0 engaged (as `simulate`), the
    initial state's peaks recorded in the first interval; done at once, with
    `RESULTS.invalid_input`, where ``invalid`` (a rule of the run is broken)."""
    n, n_contacts = model.n_coordinates, len(model.contacts)
    approach = jnp.zeros(n_contacts)
    in_contact = jnp.zeros(n_contacts, bool)
    engaged = model.ball_deflections(t0, model.q0) > 0.0
    q, qd = y0[:n], y0[n:]
    start = point_peaks(model, t0, q, _forces(model, t0, q, qd, approach, engaged))
    peaks = jax.tree_util.tree_map(lambda x, v: x.at[0].set(v), no_peaks(model, stops.shape[:1]), start)
    zero = jnp.zeros((), y0.dtype)
    root = _ITPState(zero, zero, zero, zero, jnp.zeros((), bool), zero, zero, zero, zero)
    return _State(
        t=t0,
        y=y0,
        f=vector_field(t0, y0, (approach, in_contact, engaged)),
        h=(t1 - t0) * INITIAL_STEP,
        control=(jnp.asarray(1.0), jnp.asarray(1.0), jnp.asarray(False)),
        cell=jnp.asarray(0),
        approach=approach,
        in_contact=in_contact,
        engaged=engaged,
        locating=jnp.asarray(False),
        step_end=t0,
        step_k=jnp.zeros((7, 2 * n)),
        step_h=zero,
        root=root,
        root_steps=jnp.asarray(0),
        peaks=peaks,
        integrals=jnp.zeros((stops.shape[0], INTEGRALS)),
        fatigue=jnp.zeros((stops.shape[0], fatigue_size(model, fatigue))),
        onsets=(jnp.full(ONSET_SLOTS, jnp.nan), jnp.full(ONSET_SLOTS, jnp.nan), jnp.full(ONSET_SLOTS, -1)),
        n_onsets=jnp.asarray(0),
        spans=tuple(jnp.full(ONSET_SLOTS, x) for x in (jnp.nan, -jnp.inf, jnp.nan)),
        current=jnp.full(n_contacts, -1),
        events=jnp.asarray(0),
        steps=jnp.asarray(0),
        rejected=jnp.asarray(0),
        done=invalid,
        result=RESULTS.where(invalid, RESULTS.invalid_input, RESULTS.successful),
    )

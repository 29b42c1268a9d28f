"""The integrator core: one iteration of the solve (`advance`), which both drivers repeat.

The system (`AbstractSystem`) has a state y and a tuple of discrete states that change only at
events, where an event value crosses zero (for a mechanism: a contact's onset and separation,
a paper-force ball's engagement and release, each element's own); between events the
right-hand side is smooth. The core knows neither what the states hold nor what the events
mean. An iteration is either

- a step attempt: the solver's step (``solver.step``, diffrax's public solver API) to the
  controller's proposed time, cut at the next stop; the step-size controller
  (``adapt_step_size``) accepts or rejects it. An accepted step after which an event value is
  positive is not taken: its member locates the event in the next iterations. Otherwise the
  step is recorded: its peaks and integrals (`_recording.step_stats`, columns the
  `AbstractRecorder` defines), and the dense row the outputs are read from (`Row`);
- or one step of the ITP root finder (`itp_step`) on the held step's interpolant. When the
  bracket is narrower than `EVENT_TIME_TOLERANCE`, the step is recorded up to the event time
  (the bracket's upper end, where the event value is across zero), the system switches its
  states for the events found (`_switch`), and the next step starts there with the solver's first stage evaluated
  anew (diffrax's ``made_jump``). The event time carries the tangent of the implicit function
  theorem (`_event_time`), not that of the bisection iterates.

A single run branches between the two (`jax.lax.cond`); under `jax.vmap` both are evaluated and
each member selects its own, so a batch runs as one loop in which every member goes its own way.
"""

from __future__ import annotations

import dataclasses
from typing import NamedTuple

import diffrax
import equinox as eqx
import equinox.internal as eqxi
import jax
import jax.numpy as jnp

from ._recording import (
    AbstractRecorder, Peaks, RecordState, add_peaks, no_peaks, no_records, point_peaks, step_stats,
)  # fmt: skip
from ._results import RESULTS
from ._system import AbstractSystem

EVENT_TIME_TOLERANCE = 1e-13  # [s] width of the bracket that locates an event time
JUMP = 1e-9  # an event value this far above 0 where the event is located, or after a step
# shrunk below `SMALLEST_STEP`, jumped there (a continuous one, in m, would move at 1e6 m/s)
ROOT_STEPS = 64  # root-finder steps after which an event counts as not located (a NaN value)
SMALLEST_STEP = 1e-15  # [s] a member whose proposed step falls below it has failed
ITP_KAPPA = 0.2  # truncation: the nudge is ITP_KAPPA (width)^2 / (initial width)
ITP_SLACK = 1  # steps allowed beyond bisection's (the method's n0)


class ITPState(eqx.Module):
    """The ITP root finder's state (Oliveira and Takahashi, ACM Trans. Math. Software 47(1),
    2020): each step evaluates f at a regula-falsi point nudged towards the bracket's midpoint
    and kept within a radius of it that shrinks as bisection's bracket would, then keeps the
    half that holds the sign change. It never takes more than `ITP_SLACK` steps more than
    bisection to the same bracket width, and converges superlinearly on a smooth f (the step's
    interpolant), so a batch waits few iterations for its slowest member. Times in s."""

    lower: jax.Array  # bracket [lower, upper] [s], g(lower) <= 0 <= g(upper)
    upper: jax.Array
    g_lower: jax.Array  # g = f, or -f where f falls over the bracket
    g_upper: jax.Array
    flip: jax.Array  # f(lower) > f(upper)
    next: jax.Array  # where the next step evaluates f [s]
    reach: jax.Array  # [s] half the bracket width bisection would allow at this step, plus
    # `ITP_SLACK` halvings: the point stays within reach - width / 2 of the midpoint
    kappa: jax.Array  # truncation factor [1/s]


def itp_start(lower, upper, f_lower, f_upper, atol) -> ITPState:
    """The ITP state for the bracket [lower, upper] [s] with f there, and its first point."""
    lower = jnp.where(f_upper == 0, upper, lower)
    flip = f_lower > f_upper
    width = upper - lower
    halvings = jnp.ceil(jnp.log2(jnp.maximum(width / atol, 1.0)))
    state = ITPState(
        lower=lower,
        upper=upper,
        g_lower=jnp.where(flip, -f_lower, f_lower),
        g_upper=jnp.where(flip, -f_upper, f_upper),
        flip=flip,
        next=upper,
        reach=(0.5 * atol) * 2.0 ** (halvings + ITP_SLACK),
        kappa=ITP_KAPPA / jnp.where(width > 0, width, 1.0),
    )
    return eqx.tree_at(lambda s: s.next, state, _itp_point(state))


def itp_step(state: ITPState, value) -> ITPState:
    """One ITP step: ``value`` is f at ``state.next``; the bracket keeps the half that holds
    the sign change, and ``next`` becomes the point to evaluate after it."""
    x = state.next
    g = jnp.where(state.flip, -value, value)
    below, above = g <= 0, g >= 0  # both at a root: the bracket collapses onto it
    state = dataclasses.replace(
        state,
        lower=jnp.where(below, x, state.lower),
        upper=jnp.where(above, x, state.upper),
        g_lower=jnp.where(below, g, state.g_lower),
        g_upper=jnp.where(above, g, state.g_upper),
        reach=0.5 * state.reach,
    )
    return eqx.tree_at(lambda s: s.next, state, _itp_point(state))


def _itp_point(state: ITPState) -> jax.Array:
    """The regula-falsi point of ``state``'s bracket, nudged towards the midpoint (truncation)
    and kept within ``reach`` of it (projection)."""
    a, b, ga, gb = state.lower, state.upper, state.g_lower, state.g_upper
    half = 0.5 * (a + b)
    width = b - a
    radius = jnp.maximum(state.reach - 0.5 * width, 0.0)
    nudge = state.kappa * (width * width)
    secant = gb != ga
    falsi = jnp.where(secant, a - (ga * width) / jnp.where(secant, gb - ga, 1.0), half)
    sigma = jnp.sign(half - falsi)
    truncated = jnp.where(nudge <= jnp.abs(half - falsi), falsi + sigma * nudge, half)
    point = jnp.where(jnp.abs(truncated - half) <= radius, truncated, half - sigma * radius)
    return jnp.clip(point, a, b)


def _event_value(s: Setup, t, y, states):
    """The largest event value: it crosses zero at the first event (-1 without events)."""
    return jnp.max(s.system.event_values(t, y, states), initial=-1.0)


def _event_time(values_along, t_root):
    """The event time ``t_root`` [s] located by the root finder, with the tangent of the implicit
    function theorem, and the event values there ((E,), without tangents). The located event is
    the largest value at ``t_root``; its value along the step's interpolant (a smooth function
    of t) is 0 there, so dt = -(d value / d parameters) / (d value / dt). The located event's
    own value, not the largest's: JAX's derivative of a maximum divides by how many entries
    equal it, and none may where the compiled program rounds the maximum and the entry apart (a
    NaN event time was seen with two bearings' balls)."""
    t_root = jax.lax.stop_gradient(t_root)
    values, slopes = jax.jvp(values_along, (t_root,), (jnp.ones_like(t_root),))
    which = jax.lax.stop_gradient(jnp.argmax(values))
    value, slope = values[which], jax.lax.stop_gradient(slopes[which])
    moved = value - jax.lax.stop_gradient(value)  # 0, with the tangent of the value at fixed t
    t_event = t_root - jnp.where(slope != 0, moved / jnp.where(slope != 0, slope, 1.0), 0.0)
    return t_event, jax.lax.stop_gradient(values)


def _switch(s: Setup, x: State, t, y, values, hit):
    """Switch the states for the event at (t, y), where the event values are ``values``, the
    located (largest) value and any other already across: (states, onset (time, logged value,
    episodic element, any), separated (K,) bool, jumped). ``jumped``: a switched event value
    lies above `JUMP` there, so it jumped across zero instead of crossing it (a contact switched
    on, by its ``active_from``, while its surfaces overlap)."""
    located = jnp.arange(values.shape[0]) == jnp.argmax(values)
    crossed = (located | (values > 0)) & hit
    jumped = jnp.any(crossed & (values > JUMP))
    states = s.system.on_events(t, y, x.states, crossed)
    before, _ = s.system.episodes(x.states)
    after, logged = s.system.episodes(states)
    onset, separated = after & ~before, before & ~after
    first = jnp.argmax(onset).astype(int) if onset.shape[0] else jnp.asarray(-1)
    record = (t, jnp.sum(jnp.where(onset, logged, 0.0)), first, jnp.any(onset))
    return states, record, separated, jumped


class Setup(NamedTuple):
    """What every iteration of one solve shares."""

    system: AbstractSystem
    n_events: int  # the system's event values (static)
    term: diffrax.ODETerm
    solver: diffrax.AbstractSolver
    controller: diffrax.AbstractStepSizeController
    stops: jax.Array  # (n_stops,) step ends [s], increasing; the last is t1
    t1: jax.Array  # [s]
    max_steps: jax.Array  # int: steps (accepted and rejected) the run may take
    recorder: AbstractRecorder  # what each step records


class State(NamedTuple):
    """The solve's state between two iterations, one member."""

    t: jax.Array  # [s]
    y: jax.Array  # [q, qd] at t
    solver_state: object  # the solver's state at (t, y)
    made_jump: jax.Array  # the right-hand side changed at t (the solver re-evaluates its first stage)
    h: jax.Array  # next step [s], as the controller proposed it
    control: object  # the step-size controller's state
    cell: jax.Array  # index of the next stop
    states: tuple  # the system's discrete states in force
    value: jax.Array  # the largest event value at (t, y) (`_event_value`): negative
    locating: jax.Array  # the held step crossed an event: its time is being located
    step_end: jax.Array  # [s] the held step's end
    step_dense: object  # its interpolant's data (the solver's dense info)
    step_h: jax.Array  # [s] the step the controller proposed after it
    root: ITPState
    root_steps: jax.Array
    records: RecordState  # peaks and integrals of each stop interval so far
    onsets: tuple  # (time, logged value, episodic element) of each episode's onset, each
    # (max_onsets,)
    spans: tuple  # (end [s], peak, its time [s]) of each onset's episode (its element's
    # episode column)
    n_onsets: jax.Array
    max_drift: jax.Array  # the largest `AbstractSystem.drift` at the end of a recorded step
    current: jax.Array  # (K,) the onset slot of each episodic element's episode, -1 for none
    events: jax.Array  # events located
    steps: jax.Array
    rejected: jax.Array
    done: jax.Array  # reached t1 or failed
    result: RESULTS


class Row(NamedTuple):
    """What an iteration records for the output times: the step it took, [start, end] of the
    interpolant over [start, step_end] (end < step_end where it ends at an event), and the
    states in force during it."""

    recorded: jax.Array
    start: jax.Array
    end: jax.Array
    step_end: jax.Array
    dense: object
    states: tuple


def initial_state(s: Setup, t0, y0, dt0, max_onsets: int, invalid) -> State:
    """At t0: the system's initial states, the initial state's peaks recorded in the first
    interval; done at once, with `RESULTS.invalid_input`, where ``invalid`` (a rule of the run
    is broken)."""
    states = s.system.initial_states(t0, y0)
    n_episodic = s.system.episodes(states)[0].shape[0]
    args = states
    observed = s.recorder.observe(t0, y0, states)
    empty = no_records(s.recorder, s.stops.shape[0])
    first = lambda x, v: x.at[0].set(v)  # noqa: E731
    peaks = jax.tree_util.tree_map(first, empty.peaks, point_peaks(s.recorder, t0, y0, states, observed))
    error_order = s.solver.error_order(s.term)
    func = s.solver.func
    t_next, control = s.controller.init(s.term, t0, s.t1, y0, dt0, args, func, error_order)
    solver_state = s.solver.init(s.term, t0, t_next, y0, args)
    # zeros shaped as the solver's dense info, y0 in its state-shaped leaves (made_jump an array:
    # a Python bool would be a constant there, which eager operations compile programs for)
    made_jump = jnp.asarray(False)
    out = eqx.filter_eval_shape(s.solver.step, s.term, t0, t_next, y0, args, solver_state, made_jump)
    dense = jax.tree_util.tree_map(
        lambda x: y0 if x.shape == y0.shape else jnp.zeros(x.shape, x.dtype), out[2]
    )
    zero = jnp.zeros((), y0.dtype)
    slots = lambda x: jnp.full(max_onsets, x)  # noqa: E731
    return State(
        t=t0,
        y=y0,
        solver_state=solver_state,
        made_jump=made_jump,
        h=t_next - t0,
        control=control,
        cell=jnp.asarray(0),
        states=states,
        value=_event_value(s, t0, y0, states),
        locating=jnp.asarray(False),
        step_end=t0,
        step_dense=dense,
        step_h=zero,
        root=ITPState(zero, zero, zero, zero, jnp.zeros((), bool), zero, zero, zero),
        root_steps=jnp.asarray(0),
        records=empty._replace(peaks=peaks),
        onsets=(slots(jnp.nan), slots(jnp.nan), slots(-1)),
        spans=(slots(jnp.nan), slots(-jnp.inf), slots(jnp.nan)),
        n_onsets=jnp.asarray(0),
        max_drift=s.system.drift(t0, y0),
        current=jnp.full(n_episodic, -1),
        events=jnp.asarray(0),
        steps=jnp.asarray(0),
        rejected=jnp.asarray(0),
        done=invalid,
        result=RESULTS.where(invalid, RESULTS.invalid_input, RESULTS.successful),
    )


class _Outcome(NamedTuple):
    """What an iteration's branch (`_locate`, `_attempt`) reports besides the next state (whose
    fields from ``t`` to ``root_steps`` it sets)."""

    row: Row  # the step recorded by this iteration (``row.recorded``)
    onset: tuple  # (time, logged value, episodic element, any)
    separated: jax.Array  # (K,) bool: episodes that ended
    at_stop: jax.Array  # the iteration ends at the next stop
    located: jax.Array
    failure: RESULTS  # successful unless this iteration failed
    rejected: jax.Array


def _select(where, a, b):
    """``a`` where ``where``, else ``b``, leaf by leaf of two trees of one structure."""
    return jax.tree_util.tree_map(lambda u, v: jnp.where(where, u, v), a, b)


def _stop(s: Setup, x: State):
    """The next stop [s] (a sum of selects: a batch evaluates it elementwise)."""
    return jnp.sum(jnp.where(jnp.arange(s.stops.shape[0]) == x.cell, s.stops, 0.0))


def _interpolation(s: Setup, t0, t1, dense):
    return s.solver.interpolation_cls(t0=t0, t1=t1, **dense)


def _no_onset(t):
    nan = jnp.full((), jnp.nan, t.dtype)
    return nan, nan, jnp.asarray(-1), jnp.asarray(False)


def _locate(s: Setup, x: State) -> tuple[State, _Outcome]:
    """One root-finder step on the held step; where the bracket is narrow enough, the event."""
    interpolation = _interpolation(s, x.t, x.step_end, x.step_dense)

    def along(t):  # the event value along the held step's interpolant
        return _event_value(s, t, interpolation.evaluate(t), x.states)

    root = jax.lax.stop_gradient(itp_step(x.root, along(x.root.next)))  # tangents: `_event_time`
    located = jnp.abs(root.upper - root.lower) < EVENT_TIME_TOLERANCE
    lost = ~located & (x.root_steps + 1 >= ROOT_STEPS)

    def values_along(t):
        return s.system.event_values(t, interpolation.evaluate(t), x.states)

    def event():  # the event, and the event value after its switch
        t_event, values = _event_time(values_along, root.upper)
        y_event = interpolation.evaluate(t_event)
        states, onset, separated, jumped = _switch(s, x, t_event, y_event, values, located)
        value = _event_value(s, t_event, y_event, states)
        return t_event, y_event, states, onset, separated, jumped, value

    def no_event():
        none = _no_onset(root.upper)
        return root.upper, x.y, x.states, none, jnp.zeros_like(x.current, bool), jnp.asarray(False), x.value

    # a batch (unvmapped predicate) evaluates the event only in iterations where a member has one
    t_event, y_event, states, onset, separated, jumped, value = jax.lax.cond(
        eqxi.unvmap_any(located), event, no_event
    )
    failure = RESULTS.where(lost, RESULTS.event_not_located, RESULTS.successful)
    failure = RESULTS.where(located & jumped, RESULTS.contact_overlap, failure)
    state = x._replace(
        t=jnp.where(located, t_event, x.t),
        y=jnp.where(located, y_event, x.y),
        made_jump=x.made_jump | located,
        h=jnp.where(located, x.step_h, x.h),
        states=_select(located, states, x.states),
        value=jnp.where(located, value, x.value),
        locating=~located,
        root=root,
        root_steps=x.root_steps + 1,
    )
    return state, _Outcome(
        row=Row(located, x.t, t_event, x.step_end, x.step_dense, x.states),
        onset=onset,
        separated=separated,
        at_stop=located & (t_event >= _stop(s, x)),
        located=located,
        failure=failure,
        rejected=jnp.asarray(False),
    )


def _attempt(s: Setup, x: State) -> tuple[State, _Outcome]:
    """A step attempt: the solver's step to the proposed time, cut at the next stop, and the
    controller's verdict; an accepted step across an event starts locating it."""
    args = x.states
    stop = _stop(s, x)
    last = x.h >= stop - x.t
    h = jnp.where(last, stop - x.t, x.h)
    t_b = jnp.where(last, stop, x.t + h)
    y1, y_error, dense, solver_state, solver_ok = s.solver.step(
        s.term, x.t, t_b, x.y, args, x.solver_state, x.made_jump
    )
    failed = (solver_ok != diffrax.RESULTS.successful) | ~jnp.all(jnp.isfinite(y1))
    y_error = jnp.where(failed | jnp.isnan(y_error), jnp.inf, y_error)
    error_order = s.solver.error_order(s.term)
    keep, _, next_t1, _, control, _ = s.controller.adapt_step_size(
        x.t, t_b, x.y, y1, args, y_error, error_order, x.control
    )
    keep = keep & ~failed & jnp.isfinite(next_t1)
    h_next = jnp.where(jnp.isfinite(next_t1), next_t1 - jnp.where(keep, t_b, x.t), 0.2 * h)
    # a step cut short at a stop proposes from its short length: go on with the longer one
    h_next = jnp.where(keep & last, jnp.maximum(h_next, x.h), h_next)
    value_b = _event_value(s, t_b, y1, x.states)
    crossed = keep & (value_b > 0)
    accept = keep & ~crossed
    started = jax.lax.stop_gradient(itp_start(x.t, t_b, x.value, value_b, EVENT_TIME_TOLERANCE))
    too_small = ~keep & (h_next < SMALLEST_STEP)
    # a step shrunk to nothing whose event value at its end is above `JUMP` holds a jump: a
    # contact switched on (``active_from``) while its surfaces overlap, whose force jumps too,
    # so that no step across is accepted
    failure = RESULTS.where(too_small, RESULTS.dt_min_reached, RESULTS.successful)
    failure = RESULTS.where(too_small & (value_b > JUMP), RESULTS.contact_overlap, failure)
    step_end, step_dense, step_h = _select(
        crossed, (t_b, dense, h_next), (x.step_end, x.step_dense, x.step_h)
    )
    state = x._replace(
        t=jnp.where(accept, t_b, x.t),
        y=jnp.where(accept, y1, x.y),
        solver_state=_select(accept, solver_state, x.solver_state),
        made_jump=jnp.where(accept, False, x.made_jump),
        h=h_next,
        control=control,
        value=jnp.where(accept, value_b, x.value),
        locating=crossed,
        step_end=step_end,
        step_dense=step_dense,
        step_h=step_h,
        root=_select(crossed, started, x.root),
        root_steps=jnp.zeros_like(x.root_steps),
    )
    return state, _Outcome(
        row=Row(accept, x.t, t_b, t_b, dense, x.states),
        onset=_no_onset(x.t),
        separated=jnp.zeros_like(x.current, bool),
        at_stop=accept & last,
        located=jnp.asarray(False),
        failure=failure,
        rejected=~keep,
    )


def advance(s: Setup, x: State) -> tuple[State, Row]:
    """One iteration (module docstring) of a member that is not done: a step attempt, or a
    root-finder step where an event is being located. Returns the next state and the step it
    recorded. (The drivers' loops stop at ``done``; under vmap a while loop keeps the state of
    a member whose condition is false.)"""
    if s.n_events:
        new, o = jax.lax.cond(x.locating, lambda x: _locate(s, x), lambda x: _attempt(s, x), x)
    else:
        new, o = _attempt(s, x)
    row = o.row
    here = jnp.arange(s.stops.shape[0]) == x.cell
    peaks, integrals = jax.tree_util.tree_map(lambda a: _row(a, here), x.records)
    step_peaks, step_integrals = jax.lax.cond(
        row.recorded,
        lambda: step_stats(
            s.recorder, _interpolation(s, row.start, row.step_end, row.dense), row.start, row.end,
            row.states, _running(s, x, peaks),
        ),
        lambda: (no_peaks(s.recorder), jnp.zeros_like(integrals)),
    )
    # an iteration that recorded no step adds an empty span (peaks -inf, integrals 0): no change
    rows = RecordState(add_peaks(s.recorder.carried_columns, peaks, step_peaks), integrals + step_integrals)
    into = lambda a, r: _where_rows(here, jnp.broadcast_to(r, a.shape), a)  # noqa: E731
    onset = o.located & o.onset[3]
    overflow = onset & (x.n_onsets >= x.onsets[0].shape[0])
    slot = onset & (jnp.arange(x.onsets[0].shape[0]) == x.n_onsets)
    onsets = tuple(jnp.where(slot, v, a) for a, v in zip(x.onsets, o.onset[:3]))
    spans, current = _spans(s, x, row.recorded, step_peaks, o.separated, new.t, onset, o.onset[2])
    reached = o.at_stop & (_stop(s, x) >= s.t1)
    stepped = ~x.locating  # a step attempt (`_attempt`), which counts against max_steps
    out_of_steps = stepped & (x.steps + 1 >= s.max_steps) & ~reached
    failure = RESULTS.where(out_of_steps, RESULTS.max_steps_reached, o.failure)
    failure = RESULTS.where(overflow, RESULTS.max_onsets_reached, failure)
    failed = failure != RESULTS.successful
    state = new._replace(
        cell=x.cell + (o.at_stop & ~reached),
        records=jax.tree_util.tree_map(into, x.records, rows),
        onsets=onsets,
        spans=spans,
        n_onsets=x.n_onsets + (onset & ~overflow),
        max_drift=jnp.where(row.recorded, jnp.maximum(x.max_drift, s.system.drift(new.t, new.y)), x.max_drift),
        current=current,
        events=x.events + o.located,
        steps=x.steps + stepped,
        rejected=x.rejected + o.rejected,
        done=reached | failed,
        result=RESULTS.where(failed, failure, x.result),
    )
    return state, row


def _episode_columns(s: Setup):
    """The `Peaks` columns of the episodic elements' episode peaks
    (`AbstractRecorder.episode_columns`): a slice where they are consecutive (no gather), else
    their indices."""
    columns = s.recorder.episode_columns
    if columns == tuple(range(columns[0], columns[0] + len(columns))):
        return slice(columns[0], columns[0] + len(columns))
    return jnp.asarray(columns)


def _in_slot(s: Setup, x: State):
    """(K, max_onsets) bool: episodic element k is in an episode and it is onset slot s."""
    slots = jnp.arange(x.spans[0].shape[0])
    return (slots[None, :] == x.current[:, None]) & s.system.episodes(x.states)[0][:, None]


def _running(s: Setup, x: State, peaks: Peaks) -> Peaks:
    """The peaks so far that decide whether a step is refined between its points: the stop
    interval's, and for each episode column the lower of that and the current episode's so far
    (-inf outside an episode), so that both peaks are the interpolant's."""
    if not x.current.shape[0]:
        return peaks
    so_far = jnp.max(jnp.where(_in_slot(s, x), x.spans[1][None, :], -jnp.inf), axis=1)
    columns = _episode_columns(s)
    contact = jnp.minimum(peaks.values[columns], so_far)
    return peaks._replace(values=peaks.values.at[columns].set(contact))


def _spans(s: Setup, x: State, recorded, peaks: Peaks, separated, t_event, onset, index):
    """``spans`` and ``current`` after an iteration: each episodic element's episode peak in a
    recorded step (``peaks``: the step's) joins its current episode's, the episodes that
    ``separated`` end at ``t_event``, and an ``onset`` of element ``index`` takes the next
    slot."""
    if not x.current.shape[0]:
        return x.spans, x.current
    slots = jnp.arange(x.spans[0].shape[0])
    end, peak, peak_time = x.spans
    columns = _episode_columns(s)
    match = _in_slot(s, x)  # at most one element per slot
    value = jnp.max(jnp.where(match, peaks.values[columns][:, None], -jnp.inf), axis=0)
    when = jnp.sum(jnp.where(match, peaks.times[columns][:, None], 0.0), axis=0)
    later = recorded & jnp.any(match, axis=0) & (value > peak)
    peak, peak_time = jnp.where(later, value, peak), jnp.where(later, when, peak_time)
    ends = jnp.any(separated[:, None] & (slots[None, :] == x.current[:, None]), axis=0)
    end = jnp.where(ends, t_event, end)
    starts = onset & (jnp.arange(x.current.shape[0]) == index) & (x.n_onsets < slots.shape[0])
    current = jnp.where(separated, -1, jnp.where(starts, x.n_onsets, x.current))
    return (end, peak, peak_time), current


def _where_rows(rows, x, y):
    """x in the ``rows`` (R,) where true, else y (x: (R, ...))."""
    return jnp.where(rows.reshape(rows.shape + (1,) * (x.ndim - 1)), x, y)


def _row(x, here):
    """The row of ``x`` (rows, ...) where the one-hot ``here`` is true: a sum of selects, which
    a batch evaluates elementwise (a vmapped index would be a gather)."""
    return jnp.sum(_where_rows(here, x, jnp.zeros((), x.dtype)), axis=0, dtype=x.dtype)


@jax.custom_jvp
def _identity(tree):
    return tree


def _identity_jvp(primals, tangents):
    (tree,), (tangents,) = primals, tangents
    zero = lambda t: isinstance(t, jax.custom_derivatives.SymbolicZero)  # noqa: E731
    leaves = jax.tree_util.tree_leaves(tangents, is_leaf=zero)
    anchor = jnp.sum(next(t for t in leaves if not zero(t)))
    # a zero selected from a tangent: JAX takes a zero computed from constants for none
    fill = lambda t, x: jnp.where(False, anchor, jnp.zeros_like(x)) if zero(t) else t  # noqa: E731
    return tree, jax.tree_util.tree_map(fill, tangents, tree, is_leaf=zero)


_identity.defjvp(_identity_jvp, symbolic_zeros=True)


def perturbed(tree):
    """``tree``; under differentiation, with a tangent on every floating leaf (zero where it
    had none). The solve's loops find which carried values carry tangents by a fixed point, one
    trace of their whole body per pass: JAX's scan and while loops by JVPs of the body,
    equinox's checkpointed loop by linearising it, in the forward pass and again in the
    backward one. From a carry whose floating values all carry tangents each converges in one
    pass (docs/performance.md gives the primitives that tracing `jax.grad` binds)."""
    dynamic, static = eqx.partition(tree, eqx.is_inexact_array)
    return eqx.combine(_identity(dynamic), static)

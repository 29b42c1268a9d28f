"""One segment of the solve: from the carry's time to the next stop or the first event, then
the switch of what the event found (contact onsets and separations, ball engagements and
releases). `_simulate` scans `slot` (a segment, or nothing once every member is done) over a
fixed number of slots."""

from __future__ import annotations

import functools
from typing import ClassVar, NamedTuple

import diffrax
import equinox as eqx
import equinox.internal as eqxi
import jax
import jax.numpy as jnp
import optimistix as optx

from ..laws.bearing import BALL_RELEASE
from ..solution import PEAK_CONTACT_FORCE, RESULTS
from ._progress import _Progress
from ._recording import INTEGRALS, Peaks, _add, _close, fatigue_size, no_peaks

SEPARATION_OFFSET = 1e-9  # [m] separation is located at penetration = -1 nm: restarts never stall
EVENT_TIME_TOLERANCE = 1e-13  # [s] root-finding tolerance on event times


class _ITPState(eqx.Module):
    """State of `_EventRoot` between its steps (times in s, values in f's unit)."""

    lower: jax.Array  # bracket [lower, upper] [s], g(lower) <= 0 <= g(upper)
    upper: jax.Array
    g_lower: jax.Array  # g = f, or -f where f falls over the bracket
    g_upper: jax.Array
    flip: jax.Array  # f(lower) > f(upper)
    next: jax.Array  # where the next step evaluates f [s]
    error: jax.Array  # f at the point evaluated last
    reach: jax.Array  # [s] half the bracket width bisection would allow at this step, plus
    # `ITP_SLACK` halvings: the point stays within reach - width / 2 of the midpoint
    kappa: jax.Array  # truncation factor [1/s]


class _EventRoot(optx.AbstractRootFinder):
    """The event time in the last step's bracket [lower, upper]: the ITP method (interpolate,
    truncate, project; Oliveira and Takahashi, ACM Trans. Math. Software 47(1), 2020).

    Each step evaluates f at a regula-falsi point nudged towards the bracket's midpoint and kept
    within a radius of it that shrinks as bisection's bracket would, then keeps the half that
    holds the sign change. It never takes more than ``ITP_SLACK`` steps more than bisection to
    the same bracket width, and converges superlinearly on a smooth f (the step's interpolant),
    so a batch waits far fewer iterations for its slowest member than with bisection (each an
    iteration of a while loop; docs/performance.md). It stops, like `optx.Bisection`, when the
    bracket is narrower than ``atol`` and the last value is smaller than ``atol``; or, narrower
    than ``atol`` with a value above `JUMP` (f jumps there: a contact switched on while its
    surfaces overlap), at the bracket's upper end, where `_switch` then says so.

    Under vmap diffrax root-finds for every member when any member has an event; for the others
    it asks for the root of t_next - t, which sits exactly at the upper end. Such a bracket
    collapses onto its upper end, so their root find succeeds in one step (their end time and
    state are then read from their last accepted step: `_end`).
    """

    rtol: float
    atol: float
    norm: ClassVar = jnp.abs  # all norms agree on scalars

    def init(self, fn, y, args, options, f_struct, aux_struct, tags):
        lower = jnp.asarray(options["lower"], f_struct.dtype)
        upper = jnp.asarray(options["upper"], f_struct.dtype)
        f_lower, _ = fn(lower, args)
        f_upper, _ = fn(upper, args)
        return itp_start(lower, upper, f_lower, f_upper, self.atol)

    def step(self, fn, y, args, options, state, tags):
        del y, options
        error, aux = fn(state.next, args)
        state = itp_step(state, error)
        return state.next, state, aux

    def terminate(self, fn, y, args, options, state, tags):
        y_small = jnp.abs(state.upper - state.lower) < self.atol + self.rtol * jnp.abs(y)
        f_small = jnp.abs(state.error) < self.atol
        return y_small & (f_small | _jumped(state, self.atol)), optx.RESULTS.successful

    def postprocess(self, fn, y, aux, args, options, state, tags, result):
        return jnp.where(_jumped(state, self.atol), state.upper, y), aux, {}


JUMP = SEPARATION_OFFSET  # [m] an event value this far from 0 across a bracket of
# `EVENT_TIME_TOLERANCE` is a jump: a continuous one would move at 1e4 m/s


def _jumped(state, atol) -> jax.Array:
    """Whether the bracket, narrower than ``atol`` [s], holds a jump of the event value rather
    than a crossing (`_EventRoot`; before its first step the value is +inf)."""
    narrow = jnp.abs(state.upper - state.lower) < atol
    return narrow & jnp.isfinite(state.error) & (jnp.abs(state.error) > JUMP)


ITP_KAPPA = 0.2  # truncation: the nudge is ITP_KAPPA (width)^2 / (initial width)
ITP_SLACK = 1  # steps allowed beyond bisection's (the method's n0)


def itp_start(lower, upper, f_lower, f_upper, atol) -> _ITPState:
    """The ITP method's state for the bracket [lower, upper] [s] with f there, and the point it
    evaluates first (`_EventRoot`)."""
    lower = jnp.where(f_upper == 0, upper, lower)
    flip = f_lower > f_upper
    width = upper - lower
    state = _ITPState(
        lower=lower,
        upper=upper,
        g_lower=jnp.where(flip, -f_lower, f_lower),
        g_upper=jnp.where(flip, -f_upper, f_upper),
        flip=flip,
        next=upper,
        error=jnp.full_like(f_upper, jnp.inf),
        reach=_initial_reach(width, atol),
        kappa=ITP_KAPPA / jnp.where(width > 0, width, 1.0),
    )
    return eqx.tree_at(lambda s: s.next, state, _itp_point(state))


def itp_step(state: _ITPState, error) -> _ITPState:
    """One step of the ITP method: ``error`` is f at ``state.next``; the bracket keeps the half
    that holds the sign change, and ``next`` is the point to evaluate after it."""
    x = state.next
    g = jnp.where(state.flip, -error, error)
    below, above = g <= 0, g >= 0  # both at a root: the bracket collapses onto it
    state = _ITPState(
        lower=jnp.where(below, x, state.lower),
        upper=jnp.where(above, x, state.upper),
        g_lower=jnp.where(below, g, state.g_lower),
        g_upper=jnp.where(above, g, state.g_upper),
        flip=state.flip,
        next=x,
        error=error,
        reach=0.5 * state.reach,
        kappa=state.kappa,
    )
    return eqx.tree_at(lambda s: s.next, state, _itp_point(state))


def _initial_reach(width, atol):
    """``atol / 2`` times the smallest power of two >= width / atol, times 2^`ITP_SLACK`: half
    the bracket that bisection reaches in as many steps, plus the slack."""
    halvings = jnp.ceil(jnp.log2(jnp.maximum(width / atol, 1.0)))
    return (0.5 * atol) * 2.0 ** (halvings + ITP_SLACK)


def _itp_point(state: _ITPState) -> jax.Array:
    """The next point of the ITP method in the bracket of ``state``: the regula-falsi point,
    nudged towards the midpoint (truncation) and kept within ``reach`` of it (projection)."""
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


class _Resumable(diffrax.AbstractStepSizeController):
    """The user's step-size controller, remembering the step it proposes next: state (inner
    state, next step [s]). A paused segment hands both to the next solve, which so continues
    with the very steps it would have taken without the pause. It also holds the segment's first
    step [s] (``first_step``), which `diffrax.diffeqsolve` then takes without a ``dt0`` of its
    own: its check of a given ``dt0`` is a host callback, which would keep the compiled solve out
    of JAX's persistent compilation cache."""

    controller: diffrax.AbstractStepSizeController
    first_step: jax.Array | None = None

    def wrap(self, direction):
        return _Resumable(self.controller.wrap(direction), self.first_step)

    def init(self, terms, t0, t1, y0, dt0, args, func, error_order):
        dt0 = self.first_step if dt0 is None else dt0
        tnext, inner = self.controller.init(terms, t0, t1, y0, dt0, args, func, error_order)
        return tnext, (inner, tnext - t0)

    def adapt_step_size(self, t0, t1, y0, y1_candidate, args, y_error, error_order, controller_state):
        inner, _ = controller_state
        keep, tprev, tnext, jump, inner, result = self.controller.adapt_step_size(
            t0, t1, y0, y1_candidate, args, y_error, error_order, inner
        )
        return keep, tprev, tnext, jump, (inner, tnext - tprev), result


def resumable(controller):
    """The controller of a segment's solve: ``controller``, resumable after a pause."""
    return _Resumable(controller)


class _Carry(NamedTuple):
    """State of the segment loop between two segments."""

    t: jax.Array  # start of the next segment [s]
    cell: jax.Array  # index of the next stop (time-cell end or window edge) it runs to
    dt: jax.Array  # its first step [s]
    y: jax.Array  # state [q, qd] at t
    approach: jax.Array  # (n_contacts,) approach speed of each contact's current contact [m/s]
    in_contact: jax.Array  # (n_contacts,) bool
    engaged: jax.Array  # (n_switched_balls,) bool, balls of paper-force bearings that touch
    # at the output times: (states [q, qd] (2n,), approach speeds in force (n_contacts,),
    # engaged balls (n_switched_balls,)), in blocks of ``block`` times, (n_blocks, block, ...):
    # output r is row [r // block, r % block]
    outputs: tuple
    pending: tuple  # the rows of the block that holds time ``written`` (block, ...): written to
    # ``outputs`` when that block is full (`output_rows` reads the last one here)
    written: jax.Array  # output times evaluated so far: the first ``written`` of ``ts``
    peaks: Peaks  # (n_stops, ...) `SegmentStats` peaks of each stop interval so far
    integrals: jax.Array  # (n_stops, INTEGRALS) `SegmentStats` integrals of each stop interval
    fatigue: jax.Array  # (n_stops, 5 + 2 M) `FatigueStats` integrals of each stop interval
    done: jax.Array  # reached t1 or failed
    result: RESULTS
    steps: jax.Array
    rejected: jax.Array
    control: object  # state of the step-size controller (`_Resumable`) where a segment paused
    resume: jax.Array  # the next segment continues a paused one
    since: jax.Array  # steps since the last segment end that was not a pause
    began: jax.Array  # where the segment that paused began [s]
    accepted: jax.Array  # steps it accepted so far


class _Setup(NamedTuple):
    """What every segment of one solve shares (fixed while the segments run)."""

    model: object  # the Mechanism
    ts: jax.Array  # (n_blocks * block,) output times [s], padded with +inf (`padded_times`)
    t0: jax.Array  # [s]
    t1: jax.Array  # [s]
    stops: jax.Array  # (n_stops,) segment ends [s], increasing (`_stops`)
    term: diffrax.ODETerm
    recording: diffrax.AbstractSolver  # the `_Recording` wrapper of ``solver``
    solver: diffrax.AbstractSolver  # the user's solver (its interpolation closes the stats)
    controller: diffrax.AbstractStepSizeController
    event: diffrax.Event | None
    max_steps: jax.Array  # int: steps a segment may take, its pauses together
    segment_steps: int  # steps after which a segment pauses (its dense output's rows)
    block: int  # output times evaluated and written together
    progress: jax.Array | None  # the progress label's key (`_progress.label_key`), or None
    adjoint: diffrax.AbstractAdjoint


def event_values(model, t, y, in_contact, engaged):
    """One value per contact, then one per switched ball, each negative until its next
    event. Contacts: the penetration while apart (onset at 0), -(penetration +
    SEPARATION_OFFSET) while touching, -1 while switched off. Balls: delta_r while free
    (engages at 0), -(delta_r + BALL_RELEASE) while engaged."""
    n = model.n_coordinates
    q, qd = y[:n], y[n:]
    penetration, _ = model.contact_gaps(q, qd)
    contact = jnp.where(in_contact, -(penetration + SEPARATION_OFFSET), penetration)
    active = jnp.stack([c.active(t) for c in model.contacts]) if model.contacts else contact > 0
    delta = model.ball_deflections(t, q)
    ball = jnp.where(engaged, -(delta + BALL_RELEASE), delta)
    return jnp.concatenate([jnp.where(active, contact, -1.0), ball])


def make_event(model) -> diffrax.Event | None:
    """The event that ends a segment at the first switch (None for a model without any)."""
    if not (model.contacts or model.n_switched_balls):
        return None

    def first_event(t, y, args, **kwargs):
        # every value starts a segment negative, so the maximum crosses zero at the first event
        return jnp.max(event_values(model, t, y, args[1], args[2]))

    root_finder = _EventRoot(rtol=0.0, atol=EVENT_TIME_TOLERANCE)
    return diffrax.Event(first_event, root_finder=root_finder, direction=True)


def padded_times(ts, block: int) -> jax.Array:
    """The output times ``ts`` padded with +inf to a whole number of blocks of ``block``."""
    return jnp.concatenate([ts, jnp.full(-ts.shape[0] % block, jnp.inf, ts.dtype)])


def initial_carry(s: _Setup, y0, initial_step, invalid) -> _Carry:
    """The carry before the first segment: at t0, nothing in contact, the balls with
    delta_r > 0 engaged, no outputs written, no pause; done at once, with
    `RESULTS.invalid_input`, where ``invalid`` (a rule of the run is broken)."""
    model, t0, t1, block = s.model, s.t0, s.t1, s.block
    n, n_contacts, n_balls = model.n_coordinates, len(model.contacts), model.n_switched_balls
    blocks = s.ts.shape[0] // block
    carry = _Carry(
        t=t0,
        cell=jnp.asarray(0),
        dt=(t1 - t0) * initial_step,
        y=y0,
        approach=jnp.zeros(n_contacts),
        in_contact=jnp.zeros(n_contacts, bool),
        engaged=model.ball_deflections(t0, model.q0) > 0.0,
        outputs=(
            jnp.full((blocks, block, 2 * n), jnp.nan),
            jnp.zeros((blocks, block, n_contacts)),
            jnp.zeros((blocks, block, n_balls), bool),
        ),
        pending=(
            jnp.full((block, 2 * n), jnp.nan),
            jnp.zeros((block, n_contacts)),
            jnp.zeros((block, n_balls), bool),
        ),
        written=jnp.asarray(0),
        peaks=no_peaks(model, s.stops.shape[:1]),
        integrals=jnp.zeros((s.stops.shape[0], INTEGRALS)),
        fatigue=jnp.zeros((s.stops.shape[0], fatigue_size(model, s.recording.fatigue))),
        done=invalid,
        result=RESULTS.where(invalid, RESULTS.invalid_input, RESULTS.successful),
        steps=jnp.asarray(0),
        rejected=jnp.asarray(0),
        control=None,
        resume=jnp.asarray(False),
        since=jnp.asarray(0),
        began=t0,
        accepted=jnp.asarray(0),
    )
    args = (carry.approach, carry.in_contact, carry.engaged)
    _, control = s.controller.init(s.term, t0, t1, y0, carry.dt, args, s.recording.func, None)
    return carry._replace(control=jax.tree_util.tree_map(jnp.asarray, control))


def _solve(s: _Setup, c: _Carry, t_stop, args):
    """diffrax's solve of [c.t, t_stop] for at most ``segment_steps`` steps, saving its end and
    its accepted steps' interpolants (dense output)."""
    meter = (
        diffrax.NoProgressMeter()
        if s.progress is None
        else _Progress(t_start=c.t, t_stop=t_stop, t0=s.t0, t1=s.t1, label=s.progress)
    )
    dt0 = jnp.minimum(c.dt, t_stop - c.t)
    # a paused segment goes on with its controller's state
    fresh = s.controller.init(s.term, c.t, t_stop, c.y, dt0, args, s.recording.func, None)[1]
    state = jax.tree_util.tree_map(lambda a, b: jnp.where(c.resume, a, b), c.control, fresh)
    dt0 = jnp.where(c.resume, jnp.minimum(c.control[1], t_stop - c.t), dt0)
    # the peaks start from the stop interval's so far: steps are refined only above them;
    # the contact force's from none, so that the segment's own peak is recorded (`segment`)
    start = jax.tree_util.tree_map(lambda x: x[c.cell], c.peaks)
    start = start._replace(values=start.values.at[PEAK_CONTACT_FORCE].set(-jnp.inf))
    return diffrax.diffeqsolve(
        s.term,
        eqx.tree_at(lambda r: r.start, s.recording, start, is_leaf=lambda x: x is None),
        c.t,
        t_stop,
        None,  # the controller's first_step
        c.y,
        args=args,
        saveat=diffrax.SaveAt(t1=True, dense=True, solver_state=True, controller_state=True),
        stepsize_controller=eqx.tree_at(
            lambda r: r.first_step, s.controller, dt0, is_leaf=lambda x: x is None
        ),
        event=s.event,
        max_steps=s.segment_steps,
        throw=False,
        progress_meter=meter,
        adjoint=s.adjoint,
        controller_state=jax.lax.stop_gradient(state),
    )


def _end(s: _Setup, c: _Carry, sol, last):
    """Where the segment ended: (t_end, y_end, paused, steps since the last segment end that
    was not a pause, controller state to resume with).

    A segment pauses at ``segment_steps`` steps; one that took ``max_steps`` since its start has
    failed. A segment that did not stop at an event ends at its last accepted step, read from the
    recording solver: under vmap, when another member stopped at an event, diffrax moves every
    member without one to the end of its last *attempted* step (possibly a rejected one, at a
    pause) and interpolates its state there. ``last`` is the recording solver's latest accepted
    step (t0, t1, dense_info)."""
    t_end, y_end = sol.ts[0], sol.ys[0]
    since = c.since + sol.stats["num_steps"]
    paused = (sol.result == diffrax.RESULTS.max_steps_reached) & (since < s.max_steps)
    control = jax.lax.stop_gradient(sol.controller_state)
    if s.event is not None:
        settled = sol.result != diffrax.RESULTS.event_occurred
        t_end = jnp.where(settled, last[1], t_end)
        y_end = jnp.where(settled, last[2]["y1"], y_end)
    return t_end, y_end, paused, since, control


def _switch(model, c: _Carry, t_end, y_end, hit):
    """Switch what the event found, the located one and any other already across: (approach,
    in_contact, engaged, onset record (time, approach speed, contact index, valid), separated
    (n_contacts,) bool (the contacts that end here), overlap).
    ``overlap``: a contact switched on (its ``active_from``) with its surfaces overlapping by more
    than `SEPARATION_OFFSET` (a crossing located to `EVENT_TIME_TOLERANCE` overlaps by about
    1e-13 m); the solve then fails with `RESULTS.contact_overlap`."""
    approach, in_contact = c.approach, c.in_contact
    record = _no_onset(c.t)
    overlap = jnp.zeros((), bool)
    n, n_contacts = model.n_coordinates, len(model.contacts)
    separated = jnp.zeros(n_contacts, bool)
    values = event_values(model, t_end, y_end, in_contact, c.engaged)
    located = jnp.arange(values.shape[0]) == jnp.argmax(values)
    switch = (located | (values > 0)) & hit
    contact_switch, ball_switch = switch[:n_contacts], switch[n_contacts:]
    engaged = jnp.where(ball_switch, ~c.engaged, c.engaged)
    if n_contacts:
        penetration, rate = model.contact_gaps(y_end[:n], y_end[n:])
        onset = contact_switch & ~in_contact
        approach = jnp.where(onset, rate, approach)
        overlap = jnp.any(onset & (penetration > SEPARATION_OFFSET))
        separated = contact_switch & in_contact
        in_contact = jnp.where(contact_switch, ~in_contact, in_contact)
        has_onset = jnp.any(onset)
        record = (
            jnp.where(has_onset, t_end, jnp.nan),
            jnp.where(has_onset, jnp.sum(jnp.where(onset, rate, 0.0)), jnp.nan),
            jnp.where(has_onset, jnp.argmax(onset), -1).astype(int),
            has_onset,
        )
    return approach, in_contact, engaged, record, separated, overlap


def _no_onset(t) -> tuple:
    """The onset record of a segment without a contact onset (time, approach speed, contact
    index, valid); ``t`` gives the dtype."""
    nan = jnp.full((), jnp.nan, t.dtype)
    return nan, nan, jnp.asarray(-1, int), jnp.asarray(False)


def _loop_kind(adjoint) -> str:
    """The kind of `eqxi.while_loop` that ``adjoint`` differentiates, as diffrax picks it for its
    own loops: "checkpointed" (reverse mode) for `diffrax.RecursiveCheckpointAdjoint`, "bounded"
    (both modes) for `diffrax.DirectAdjoint`, "lax" (forward mode) for the others."""
    if isinstance(adjoint, diffrax.RecursiveCheckpointAdjoint):
        return "checkpointed"
    return "bounded" if isinstance(adjoint, diffrax.DirectAdjoint) else "lax"


def _states_at(dense: diffrax.DenseInterpolation, times, y0):
    """States [q, qd] at ``times`` [s] from the interpolant of the accepted step that ends at or
    after each (as diffrax saves at given times); ``y0`` where the solve took no step."""

    def one(t):
        last = jnp.maximum(dense.ts_size - 2, 0)
        i = jnp.clip(jnp.searchsorted(dense.ts, t, side="left") - 1, 0, last)
        info = jax.tree_util.tree_map(lambda x: x[i], dense.infos)
        return dense.interpolation_cls(t0=dense.ts[i], t1=dense.ts[i + 1], **info).evaluate(t)

    return jnp.where(dense.ts_size > 1, jax.vmap(one)(times), y0)


def _write_outputs(s: _Setup, c: _Carry, dense, t_end, through_end):
    """(outputs, pending, written) with this segment's output times evaluated from its dense
    output: those in [c.t, t_end), and t_end as well where the run ends (``through_end``), so
    that each time is evaluated exactly once, by the last segment that starts at or before it
    (the ``c.written`` times before c.t are done).

    A loop over the blocks that hold these times: a block's times are evaluated at once, and a
    block that is then full is written to ``outputs`` whole, in one update in place; the last
    one waits in ``pending`` for the next segment's rows (`output_rows` reads it there after the
    run). So each block is written once and never read, as `eqxi.while_loop`'s buffers require
    for reverse mode."""
    ts, block = s.ts, s.block
    rows = jnp.arange(block)
    start = c.written // block
    mine = lambda t: ~c.done & jnp.where(through_end, t <= t_end, t < t_end)
    switches = tuple(jnp.broadcast_to(x, (block,) + x.shape) for x in (c.approach, c.engaged))

    def more(carry):
        first = c.written + carry[1]
        return (first < ts.shape[0]) & mine(ts[jnp.minimum(first, ts.shape[0] - 1)])

    def body(carry):
        i, count, pending, outputs = carry
        j = start + i
        times = jax.lax.dynamic_slice(ts, (j * block,), (block,))
        ours = (j * block + rows >= c.written) & mine(times)
        values = (_states_at(dense, jnp.clip(times, c.t, t_end), c.y),) + switches
        # rows before ours (in the first block) were evaluated by earlier segments
        pending = tuple(_where_rows(ours, x, old) for x, old in zip(values, pending))
        count = count + jnp.sum(ours)
        full = (j + 1) * block <= c.written + count
        outputs = tuple(b.at[j].set(x, pred=full) for b, x in zip(outputs, pending))
        return i + 1, count, pending, outputs

    _, count, pending, outputs = eqxi.while_loop(
        more,
        body,
        (jnp.asarray(0), jnp.asarray(0), c.pending, c.outputs),
        max_steps=c.outputs[0].shape[0],
        buffers=lambda carry: carry[3],
        kind=_loop_kind(s.adjoint),
    )
    return outputs, pending, c.written + count


def output_rows(c: _Carry, start, size: int, in_blocks: bool = False) -> tuple:
    """Rows [start, start + size) of the outputs after the run, one an output time: from the
    blocks, and from the pending block for the times it holds (its rows before ``c.written``
    are evaluated; the blocks do not hold them). ``in_blocks``: the rows lie before
    `full_rows`, so the blocks alone hold them."""
    block = c.pending[0].shape[0]
    index = start + jnp.arange(size)

    def rows(blocks, pending):
        flat = blocks.reshape((blocks.shape[0] * block,) + blocks.shape[2:])
        x = jax.lax.dynamic_slice_in_dim(flat, start, size)
        if in_blocks:
            return x
        return _where_rows(index // block == c.written // block, pending[index % block], x)

    return tuple(rows(b, p) for b, p in zip(c.outputs, c.pending))


def full_rows(c: _Carry) -> jax.Array:
    """The number of output times that full blocks hold after the run: all evaluated."""
    block = c.pending[0].shape[0]
    return c.written // block * block


def _where_rows(rows, x, y):
    """x in the ``rows`` (block,) where true, else y."""
    return jnp.where(rows.reshape(rows.shape + (1,) * (x.ndim - 1)), x, y)


def segment(s: _Setup, c: _Carry, slot):
    """One slot of the segment loop: (next carry, (onset record, t reached, used, `_Span`)).
    The segment's peaks and integrals join those of its stop interval in the carry."""
    # finished members (reached t1, or failed: then t is set to t1 with the stop where it
    # failed) idle in zero-length solves, never backwards from t1 to their stop
    t_stop = jnp.where(c.done, c.t, s.stops[c.cell])
    args = (c.approach, c.in_contact, c.engaged)
    sol = _solve(s, c, t_stop, args)
    _, stats, last = sol.solver_state
    t_end, y_end, paused, since, control = _end(s, c, sol, last)
    ok = (sol.result == diffrax.RESULTS.successful) | (sol.result == diffrax.RESULTS.event_occurred) | paused
    hit = (sol.result == diffrax.RESULTS.event_occurred) & ~c.done
    # stats of the segment: its accepted steps, the last one only up to t_end (an event); a
    # finished member's idle solve adds nothing. They join those of the stop interval.
    closing = _close(s.model, s.solver, last, t_end, args, s.recording.fatigue, stats[0])
    ours = _add(stats, closing)
    nothing = (no_peaks(s.model), jnp.zeros_like(ours[1]), jnp.zeros_like(ours[2]))
    ours = jax.tree_util.tree_map(lambda x, y: jnp.where(c.done, y, x), ours, nothing)
    cell = lambda x: x[c.cell]  # noqa: E731
    interval = _add(jax.tree_util.tree_map(cell, (c.peaks, c.integrals, c.fatigue)), ours)
    approach, in_contact, engaged = c.approach, c.in_contact, c.engaged
    record = _no_onset(c.t)
    separated = jnp.zeros_like(c.in_contact)
    overlap = jnp.zeros((), bool)
    if s.event is not None:
        approach, in_contact, engaged, record, separated, overlap = _switch(
            s.model, c, t_end, y_end, hit
        )
    failure = RESULTS.where(overlap, RESULTS.contact_overlap, RESULTS.promote(sol.result))
    ok = ok & ~overlap
    t_reached = jnp.where(c.done, c.t, t_end)
    cell_done = ok & ~hit & ~paused
    finished = c.done | ~ok | (cell_done & ((c.cell == s.stops.shape[0] - 1) | (t_stop >= s.t1)))
    outputs, pending, written = _write_outputs(s, c, sol.interpolation, t_end, finished)
    # the next segment starts with the mean accepted step of this one, its paused parts included
    # (no step-size search; no gradient through the step sizes, as in diffrax's controllers)
    accepted = sol.stats["num_accepted_steps"] + jnp.where(c.resume, c.accepted, 0)
    began = jnp.where(c.resume, c.began, c.t)
    mean_step = jax.lax.stop_gradient((t_end - began) / jnp.maximum(accepted, 1))
    carry = _Carry(
        t=jnp.where(finished, s.t1, t_end),
        cell=jnp.where(cell_done & ~finished, c.cell + 1, c.cell),
        dt=jnp.where(c.done | (accepted == 0), c.dt, mean_step),
        y=jnp.where(c.done, c.y, y_end),
        approach=approach,
        in_contact=in_contact,
        engaged=engaged,
        outputs=outputs,
        pending=pending,
        written=written,
        peaks=jax.tree_util.tree_map(lambda x, v: x.at[c.cell].set(v), c.peaks, interval[0]),
        integrals=c.integrals.at[c.cell].set(interval[1]),
        fatigue=c.fatigue.at[c.cell].set(interval[2]),
        done=finished,
        result=RESULTS.where(c.done | ok, c.result, failure),
        steps=c.steps + jnp.where(c.done, 0, sol.stats["num_steps"]),
        rejected=c.rejected + jnp.where(c.done, 0, sol.stats.get("num_rejected_steps", 0)),
        control=control,
        resume=paused & ~finished,
        since=jnp.where(paused, since, 0),
        began=began,
        accepted=accepted,
    )
    span = _Span(
        separated,
        c.in_contact & ~c.done,
        ours[0].values[PEAK_CONTACT_FORCE],
        ours[0].times[PEAK_CONTACT_FORCE],
    )
    return carry, record + (t_reached, ~c.done, span)


class _Span(NamedTuple):
    """A segment's part in the contacts it ran in (`contact_spans`): which contacts end at its
    end, which it ran in, and its own peak of the first contact's normal force [N] and when
    [s]."""

    separated: jax.Array  # (n_contacts,) bool
    in_contact: jax.Array  # (n_contacts,) bool
    peak: jax.Array
    peak_time: jax.Array


def contact_spans(onset_index, onset_valid, t_reached, span: _Span):
    """The end [s] of each onset's contact (NaN where it lasts past the time reached, and in
    slots without an onset), and its peak normal force [N] and when [s] (the first contact's
    only; NaN for the others), from the slots' records (S,): each onset owns the slots from it
    to its contact's separation."""
    slots = onset_index.shape[0]
    index = jnp.arange(slots)
    end = jnp.full(slots, jnp.nan, t_reached.dtype)
    peak = jnp.full(slots, -jnp.inf, t_reached.dtype)
    peak_time = jnp.full(slots, jnp.inf, t_reached.dtype)
    for k in range(span.separated.shape[-1]):
        opened = onset_valid & (onset_index == k)
        owner = jax.lax.cummax(jnp.where(opened, index, -1))  # the latest onset of contact k
        ends_here = span.separated[:, k] & (owner >= 0)
        end = end.at[jnp.where(ends_here, owner, slots)].set(t_reached, mode="drop")
        if k == 0:  # the peaks record the first contact's force
            ran = span.in_contact[:, 0] & (owner >= 0)
            at = jnp.where(ran, owner, slots)
            peak = peak.at[at].max(span.peak, mode="drop")
            attains = ran & (span.peak >= peak[jnp.minimum(at, slots - 1)])
            earliest = jnp.where(attains, span.peak_time, jnp.inf)
            peak_time = peak_time.at[jnp.where(attains, owner, slots)].min(earliest, mode="drop")
    return (end,) + first_contact_peaks(onset_valid, onset_index, peak, peak_time)


def first_contact_peaks(valid, index, peak, peak_time):
    """``Contacts.peak_force`` and ``peak_time`` from running peaks per onset slot (-inf where
    none was recorded): NaN in slots without an onset of the first contact, whose force is the
    one recorded (`simulate`'s `contact_spans` and `simulate_one_loop`)."""
    found = valid & (index == 0) & (peak > -jnp.inf)
    return jnp.where(found, peak, jnp.nan), jnp.where(found, peak_time, jnp.nan)


def slot(s: _Setup, c: _Carry, index):
    """One slot of the segment loop: `segment`, or, once the run (under `jax.vmap`: every member
    of the batch) is done, what `segment` gives a finished member (the same carry, an unused
    record) without solving, so that the slots a run leaves unused cost next to nothing."""

    def idle(c, index):
        none, nan = jnp.zeros_like(c.in_contact), jnp.full((), jnp.nan, c.t.dtype)
        span = _Span(none, none, jnp.full((), -jnp.inf, c.t.dtype), nan)
        return c, _no_onset(c.t) + (c.t, jnp.asarray(False), span)

    # unbatched under vmap, so that the conditional stays a branch (a batched predicate would
    # evaluate both)
    return jax.lax.cond(eqxi.unvmap_any(~c.done), functools.partial(segment, s), idle, c, index)

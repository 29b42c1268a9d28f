"""Integration of a `Mechanism` with diffrax: the only place that calls `diffeqsolve`.

State y = [q, q_dot]. Impact contacts need the approach speed at the onset of each contact
(Lankarani–Nikravesh, Eq. 23), so the solve is split into segments at contact events: a
`diffrax.Event` locates, by bisection on the step's interpolant (robust also for grazing
contacts, where Newton stalls), the time at which a penetration crosses zero
(onset) or falls below -`SEPARATION_OFFSET` (separation); the next segment restarts there with the
approach speed recorded at the onset. Segments also end at the ends of ``time_cells`` equal
intervals of [t0, t1], so that the members of a vmapped batch stay aligned in time: a batch runs
each segment until its slowest member is done, and without the cells a member that has had one
contact event more than another would integrate an unrelated span beside it (measured: a batch
of 8 clearances of the paper's case then cost as much as 8 single runs). Segments run in a
`lax.scan` of fixed length ``time_cells + max_segments`` (reverse- and forward-mode
differentiable, vmappable); finished members idle in zero-length solves. A run that needs more
segments than that fails loudly.
"""

from __future__ import annotations

import equinox as eqx
import equinox.internal as eqxi
import diffrax
import jax
import jax.numpy as jnp
import numpy as np
import optimistix as optx
from optimistix._solver.bisection import _BisectionState  # state of the subclass below

from . import _checks
from .compile import jit
from .multibody.mechanism import Mechanism

SEPARATION_OFFSET = 1e-9  # [m] separation is located at penetration = -1 nm: restarts never stall
EVENT_TIME_TOLERANCE = 1e-13  # [s] root-finding tolerance on event times
INITIAL_STEP = 1e-7  # first step as a fraction of t1 - t0; the controller grows it 10x a step


class RESULTS(diffrax.RESULTS):
    """diffrax's result codes plus the ones of the segmented solve."""

    max_segments_reached = (
        "More contact events than max_segments allow (each onset and each separation starts a "
        "segment). Increase `max_segments`."
    )


class SimulationError(RuntimeError):
    """A solve failed: the message says when (simulated time) and what to change."""


class Contacts(eqx.Module):
    """Onsets of impact contacts, one slot per segment (padded; read ``valid``).

    Fields:
        time: onset times [s], NaN in unused slots, (time_cells + max_segments,).
        approach_speed: penetration rate at onset, delta_dot^(-) of Eq. 23 [m/s].
        index: which contact of ``model.contacts`` started, -1 in unused slots.
        valid: True where the slot holds an onset.
    """

    time: jax.Array
    approach_speed: jax.Array
    index: jax.Array
    valid: jax.Array

    @property
    def count(self) -> jax.Array:
        """Number of contact onsets."""
        return jnp.sum(self.valid, axis=-1)


class Solution(eqx.Module):
    """Result of `simulate`: states and force outputs at the requested times.

    Fields (T = number of output times):
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
        result: a `RESULTS` code (successful unless a segment failed).
        t_final: time reached [s] (t1 unless the solve failed).
        num_steps, num_rejected_steps: solver steps over all segments.
        num_segments: number of segments used (time cells plus contact events).
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
    result: RESULTS
    t_final: jax.Array
    num_steps: jax.Array
    num_rejected_steps: jax.Array
    num_segments: jax.Array


class _Progress(diffrax.AbstractProgressMeter):
    """Prints the simulated time every ``every`` of the whole span, across segments."""

    t_start: jax.Array
    t0: jax.Array
    t1: jax.Array
    label: str = eqx.field(static=True)
    every: float = eqx.field(static=True, default=0.05)

    def _fraction(self, progress):
        return (self.t_start - self.t0 + progress * (self.t1 - self.t_start)) / (self.t1 - self.t0)

    def init(self):
        return self._fraction(jnp.zeros(()))

    def step(self, state, progress):
        fraction = self._fraction(progress)
        pred = eqxi.unvmap_all((fraction - state >= self.every) | (progress == 1))

        def report():
            jax.debug.callback(_print_progress, self.label, fraction, self.t0 + fraction * (self.t1 - self.t0))
            return fraction

        return jax.lax.cond(eqxi.nonbatchable(pred), report, lambda: state)

    def close(self, state):
        return None


def _print_progress(label, fraction, t):
    print(f"{label}: t = {float(t):.4f} s ({100 * float(fraction):5.1f} %)", flush=True)


def default_solver() -> diffrax.AbstractSolver:
    """Tsit5: on the paper's case it is the fastest at equal accuracy (README, benchmarks)."""
    return diffrax.Tsit5()


def kvaerno5(newton_rtol=1e-2, newton_atol=1e-5) -> diffrax.Kvaerno5:
    """Kvaerno5, the stiff (ESDIRK) solver, with a loose simplified-Newton iteration.

    The step error control (``simulate``'s rtol, atol) still sets the accuracy; a Newton
    tolerance as tight as the step tolerance makes the iteration fail at every ball engagement
    (a force kink) and multiplies rejected steps (measured: 4624 steps for 0.01 s of the paper's
    case at diffrax's default). Over 0.2 s of the paper's case with impact (rtol 1e-8): 15 112
    steps (3 624 rejected) in 6.2 s at Newton tolerances 1e-4/1e-7, 11 045 (2 748) in 4.1 s at
    these; against a run at 1000x tighter tolerances both stay within 7e-8 m in position and
    0.11 N in ball load (benchmarks/run.py checks this).
    """
    return diffrax.Kvaerno5(
        root_finder=diffrax.VeryChord(rtol=newton_rtol, atol=newton_atol, norm=optx.max_norm)
    )


def simulate(
    model: Mechanism,
    t1: float,
    ts=None,
    *,
    t0: float = 0.0,
    solver: diffrax.AbstractSolver | None = None,
    rtol: float = 1e-8,
    atol: float = 1e-10,
    stepsize_controller: diffrax.AbstractStepSizeController | None = None,
    max_steps: int = 200_000,
    max_segments: int = 64,
    time_cells: int = 64,
    throw: bool = True,
    progress: str | None = None,
    adjoint: diffrax.AbstractAdjoint | None = None,
) -> Solution:
    """Integrate the equations of motion (Eq. 36) from ``t0`` to ``t1`` [s].

    Args:
        model: a `Mechanism` (e.g. `jaxbearing.cases.xu2014()`); starts from ``model.q0, qd0``.
        t1: final time [s], finite, > t0.
        ts: output times, 1-D, finite, increasing, within [t0, t1] (default 1001 points).
        solver: a diffrax solver (default `default_solver()`, Tsit5); `kvaerno5()` for the
            stiff solver.
        rtol, atol: error control of the PID step-size controller (state in m, rad, m/s).
        stepsize_controller: overrides the default `PIDController(rtol, atol, pcoeff=0.3,
            icoeff=0.3)` (on the paper's case with impact the PI terms halve the rejected steps
            of Tsit5 against the plain I controller: 2187 against 4917, 8 % fewer steps).
        max_steps: step limit of each segment.
        max_segments: contact events allowed (each onset and each separation starts a
            segment); the run fails if it needs more.
        time_cells: number of equal intervals of [t0, t1] at whose ends segments also stop,
            which keeps vmapped batches aligned in time (module docstring); 1 for none. Each
            costs a restart of the solver (measured: about 1.3 steps).
        throw: raise `SimulationError` (or an equinox runtime error under transformations) on
            failure; with False, inspect ``sol.result`` and ``sol.t_final``.
        progress: a label to print progress under, or None.
        adjoint: how diffrax differentiates each segment. The default (None) is
            `diffrax.RecursiveCheckpointAdjoint()`, which serves `jax.grad` and `jax.jacrev`
            (reverse mode), and becomes `diffrax.ForwardMode()` when `simulate` is traced
            under `jax.jacfwd` or `jax.jvp` (forward mode, the cheaper for a few parameters;
            `jaxbearing.sensitivity`). Forward mode around your own `jax.jit` of `simulate`
            (``jax.jacfwd(jax.jit(f))``) traces `simulate` before the jvp: pass
            ``adjoint=diffrax.ForwardMode()`` there.
    """
    _checks.require_x64()
    if not isinstance(model, Mechanism):
        raise TypeError(f"simulate needs a jaxbearing Mechanism, got {type(model).__name__}.")
    _checks.raise_if_concrete(_checks.finite_leaves(model))  # NaN passes the other rules
    t0, t1 = _checked_span(t0, t1)
    ts = _checked_ts(jnp.linspace(t0, t1, 1001) if ts is None else ts, t0, t1)
    if max_segments < 1:
        raise ValueError(f"max_segments must be at least 1; got {max_segments}.")
    if time_cells < 1:
        raise ValueError(f"time_cells must be at least 1; got {time_cells}.")
    solver = default_solver() if solver is None else solver
    if stepsize_controller is None:
        stepsize_controller = diffrax.PIDController(rtol=rtol, atol=atol, pcoeff=0.3, icoeff=0.3)
    sol = _with_adjoint(
        adjoint,
        _simulate,
        model,
        t0,
        t1,
        ts,
        solver,
        stepsize_controller,
        max_steps,
        max_segments,
        time_cells,
        progress,
    )
    if throw:
        sol = _raise_on_failure(sol, t1)
    return sol


_NO_JVP = "can't apply forward-mode autodiff (jvp) to a custom_vjp function"


def _with_adjoint(adjoint, solve, *args):
    """``solve(*args, adjoint)``; the default (None) is `diffrax.RecursiveCheckpointAdjoint()`,
    and, when forward-mode autodiff (`jax.jacfwd`, `jax.jvp`) meets it (diffrax's reverse-mode
    adjoints are `jax.custom_vjp`s and refuse jvp while tracing), `diffrax.ForwardMode()`. An
    explicit adjoint that refuses forward mode gets a `TypeError` naming the one to pass."""
    try:
        return solve(*args, diffrax.RecursiveCheckpointAdjoint() if adjoint is None else adjoint)
    except TypeError as err:
        if _NO_JVP not in str(err):
            raise
        if adjoint is None:
            return solve(*args, diffrax.ForwardMode())
        raise TypeError(
            f"simulate is differentiated in forward mode (jax.jacfwd, jax.jvp), which "
            f"adjoint={type(adjoint).__name__}() does not support (it is reverse mode only): "
            "pass adjoint=diffrax.ForwardMode(), or leave adjoint unset."
        ) from err


def _checked_span(t0, t1):
    """t0 and t1 [s] as float64 arrays: a `ValueError` now if they are concrete and not finite
    or t1 <= t0, an error at run time if traced and not finite (`_simulate` checks t1 > t0)."""
    t0, t1 = jnp.asarray(t0, jnp.float64), jnp.asarray(t1, jnp.float64)
    if _concrete(t0) and _concrete(t1):
        for name, t in (("t0", t0), ("t1", t1)):
            if t.ndim or not jnp.isfinite(t):
                raise ValueError(f"{name} must be a finite number [s]; got {name} = {t}.")
        if not t1 > t0:
            raise ValueError(f"t1 must be greater than t0 = {float(t0)} s; got t1 = {float(t1)} s.")
        return t0, t1
    finite = jnp.isfinite(t0) & jnp.isfinite(t1)
    return t0, eqx.error_if(t1, ~finite, "t0 and t1 must be finite [s]")


def _checked_ts(ts, t0, t1):
    """The output times as a float64 array; a `ValueError` now if they are not 1-D, or, when
    concrete, not finite, decreasing somewhere or outside [t0, t1] (traced: `_simulate`)."""
    ts = jnp.asarray(ts, jnp.float64)
    if ts.ndim != 1 or ts.shape[0] == 0:
        raise ValueError(f"ts must be a 1-D array of at least one output time [s]; got shape {ts.shape}.")
    if not (_concrete(ts) and _concrete(t0) and _concrete(t1)):
        return ts
    t = np.asarray(ts)
    bad = np.flatnonzero(~np.isfinite(t))
    if bad.size:
        raise ValueError(f"ts must be finite [s]; got ts[{bad[0]}] = {t[bad[0]]}.")
    back = np.flatnonzero(t[1:] < t[:-1])
    if back.size:
        i = back[0]
        raise ValueError(
            f"ts must be increasing (equal neighbours allowed) [s]; got ts[{i + 1}] = {t[i + 1]:.6g} "
            f"after ts[{i}] = {t[i]:.6g}."
        )
    out = np.flatnonzero((t < float(t0)) | (t > float(t1)))
    if out.size:
        i = out[0]
        raise ValueError(
            f"ts must lie within [t0, t1] = [{float(t0):.6g}, {float(t1):.6g}] s; got ts[{i}] = {t[i]:.6g}."
        )
    return ts


def _ahead(ts, t_start, t_end, done):
    """The output times in [t_start, t_end] first, then NaN for the others.

    A segment thus saves only what lies in its span instead of re-saving every earlier time at
    its start. NaN passes diffrax's range check and never satisfies its save condition
    ``t_save <= t_next``; finished members (``done``) get only NaN, so their zero-length solves
    save nothing. (Under vmap diffrax re-runs the step body of members whose loop has ended and
    discards the result; a finished member with every time at t1 re-saved all T times in each of
    those steps, which made batches 10x slower than serial runs.)
    """
    k = jnp.searchsorted(ts, t_start, side="left")
    rolled = jnp.roll(ts, -k)
    ahead = (jnp.arange(ts.shape[0]) < ts.shape[0] - k) & (rolled <= t_end) & ~done
    return jnp.where(ahead, jnp.clip(rolled, t_start, t_end), jnp.nan)


def _behind(ys, ts, t_start):
    """Undo `_ahead` on the saved values."""
    k = jnp.searchsorted(ts, t_start, side="left")
    return jnp.roll(ys, k, axis=0)


class _EventBisection(optx.Bisection):
    """Bisection for the event time that also serves batch members without an event.

    Under vmap, diffrax root-finds for every member when any member has an event; for the others
    it asks for the root of t_next - t, which sits exactly at the upper end, where
    `optx.Bisection`'s bracket check fails. Here such a bracket collapses onto its upper end, so
    those members keep t_next exactly.
    """

    def init(self, fn, y, args, options, f_struct, aux_struct, tags):
        lower = jnp.asarray(options["lower"], f_struct.dtype)
        upper = jnp.asarray(options["upper"], f_struct.dtype)
        lower_val, _ = fn(lower, args)
        upper_val, _ = fn(upper, args)
        return _BisectionState(
            lower=jnp.where(upper_val == 0, upper, lower),
            upper=upper,
            flip=lower_val > upper_val,
            error=jnp.array(jnp.inf, f_struct.dtype),
        )


@jax.jit
def _accelerations(model, t, q, qd, approach_speeds):
    """`Mechanism.accelerations` behind its own jit, so that it is traced once per solve:
    diffrax traces the vector field six times (measured: 2.1 s of a 4.3 s trace of the paper's
    case). XLA inlines the call, so the compiled program is unchanged."""
    return model.accelerations(t, q, qd, approach_speeds)


def _concrete(x) -> bool:
    return not isinstance(x, jax.core.Tracer)


@jit
def _simulate(model, t0, t1, ts, solver, controller, max_steps, max_segments, time_cells, progress, adjoint):
    rules = model.violations()
    rules.append(
        (t1 <= t0, "t1 must be greater than t0 [s]", t1)
    )
    rules.append(
        ((ts[0] < t0) | (ts[-1] > t1) | jnp.any(ts[1:] < ts[:-1]),
         "ts must be increasing and lie within [t0, t1]", ts)
    )
    y0 = _checks.enforce(jnp.concatenate([model.q0, model.qd0]), rules)
    n = model.n_coordinates
    n_contacts = len(model.contacts)
    T = ts.shape[0]

    def vector_field(t, y, args):
        approach, _ = args
        q, qd = y[:n], y[n:]
        return jnp.concatenate([qd, _accelerations(model, t, q, qd, approach)])

    def event_values(t, y, in_contact):
        """One value per contact, negative until its next event: the penetration while apart
        (onset at 0), -(penetration + SEPARATION_OFFSET) while touching, -1 while switched off."""
        penetration, _ = model.contact_gaps(y[:n], y[n:])
        value = jnp.where(in_contact, -(penetration + SEPARATION_OFFSET), penetration)
        active = jnp.stack([c.active(t) for c in model.contacts])
        return jnp.where(active, value, -1.0)

    def first_event(t, y, args, **kwargs):
        # every value starts a segment negative, so the maximum crosses zero at the first event
        return jnp.max(event_values(t, y, args[1]))

    event = None
    if n_contacts:
        event = diffrax.Event(
            first_event,
            root_finder=_EventBisection(rtol=0.0, atol=EVENT_TIME_TOLERANCE),
            direction=True,
        )
    term = diffrax.ODETerm(vector_field)
    cell_ends = jnp.linspace(t0, t1, time_cells + 1)[1:].at[-1].set(t1)

    def segment(carry, slot):
        t_start, cell, dt, y_start, approach, in_contact, out_y, out_approach, done, result, steps, rejected = carry
        t_stop = cell_ends[cell]
        meter = (
            diffrax.NoProgressMeter()
            if progress is None
            else _Progress(t_start=t_start, t0=t0, t1=t1, label=progress)
        )
        sol = diffrax.diffeqsolve(
            term,
            solver,
            t_start,
            t_stop,
            jnp.minimum(dt, t_stop - t_start),
            y_start,
            args=(approach, in_contact),
            saveat=diffrax.SaveAt(
                subs=[diffrax.SubSaveAt(ts=_ahead(ts, t_start, t_stop, done)), diffrax.SubSaveAt(t1=True)]
            ),
            stepsize_controller=controller,
            event=event,
            max_steps=max_steps,
            throw=False,
            progress_meter=meter,
            adjoint=adjoint,
        )
        (_, t_end), (ys, y_end) = sol.ts, sol.ys
        t_end, y_end = t_end[0], y_end[0]
        ys = _behind(ys, ts, t_start)
        ok = (sol.result == diffrax.RESULTS.successful) | (sol.result == diffrax.RESULTS.event_occurred)
        hit = sol.result == diffrax.RESULTS.event_occurred
        # outputs of this segment: output times in [t_start, t_end]
        mine = (~done) & (ts >= t_start) & (ts <= t_end)
        out_y = jnp.where(mine[:, None], ys, out_y)
        out_approach = jnp.where(mine[:, None], approach[None, :], out_approach)
        # contact bookkeeping at the event
        if n_contacts:
            values = event_values(t_end, y_end, in_contact)
            triggered = (jnp.arange(n_contacts) == jnp.argmax(values)) & hit & ~done
            _, rate = model.contact_gaps(y_end[:n], y_end[n:])
            onset = triggered & ~in_contact
            approach = jnp.where(onset, rate, approach)
            in_contact = jnp.where(triggered, ~in_contact, in_contact)
            has_onset = jnp.any(onset)
            record = (
                jnp.where(has_onset, t_end, jnp.nan),
                jnp.where(has_onset, jnp.sum(jnp.where(onset, rate, 0.0)), jnp.nan),
                jnp.where(has_onset, jnp.argmax(onset), -1),
                has_onset,
            )
        else:
            record = (jnp.nan, jnp.nan, -1, jnp.asarray(False))
        result = RESULTS.where(done | ok, result, RESULTS.promote(sol.result))
        steps = steps + jnp.where(done, 0, sol.stats["num_steps"])
        rejected = rejected + jnp.where(done, 0, sol.stats.get("num_rejected_steps", 0))
        t_reached = jnp.where(done, t_start, t_end)
        cell_done = ok & ~hit
        finished = done | ~ok | (cell_done & (cell == time_cells - 1))  # reached t1, or failed
        # the next segment starts with the mean accepted step of this one (no step-size search;
        # no gradient through the step sizes, as in diffrax's controllers)
        accepted = sol.stats["num_accepted_steps"]
        mean_step = jax.lax.stop_gradient((t_end - t_start) / jnp.maximum(accepted, 1))
        carry = (
            jnp.where(finished, t1, t_end),
            jnp.where(cell_done & ~finished, cell + 1, cell),
            jnp.where(done | (accepted == 0), dt, mean_step),
            jnp.where(done, y_start, y_end),
            approach,
            in_contact,
            out_y,
            out_approach,
            finished,
            result,
            steps,
            rejected,
        )
        return carry, record + (t_reached, ~done)

    init = (
        t0,
        jnp.asarray(0),
        (t1 - t0) * INITIAL_STEP,
        y0,
        jnp.zeros(n_contacts),
        jnp.zeros(n_contacts, bool),
        jnp.full((T, 2 * n), jnp.nan),
        jnp.zeros((T, n_contacts)),
        jnp.asarray(False),
        RESULTS.successful,
        jnp.asarray(0),
        jnp.asarray(0),
    )
    final, records = jax.lax.scan(segment, init, jnp.arange(time_cells + max_segments))
    _, _, _, _, _, _, out_y, out_approach, done, result, steps, rejected = final
    onset_t, onset_v, onset_i, onset_valid, t_reached, used = records
    t_final = jnp.max(jnp.where(used, t_reached, t0))
    result = RESULTS.where(done, result, RESULTS.max_segments_reached)
    return _outputs(
        model,
        ts,
        out_y,
        out_approach,
        Contacts(onset_t, onset_v, onset_i, onset_valid),
        result,
        t_final,
        steps,
        rejected,
        jnp.sum(used),
    )


def _outputs(model, ts, ys, approach, contacts, result, t_final, steps, rejected, n_used):
    n = model.n_coordinates
    q, qd = ys[:, :n], ys[:, n:]
    valid = jnp.isfinite(ys).all(axis=1)
    safe_q = jnp.where(valid[:, None], q, model.q0)
    safe_qd = jnp.where(valid[:, None], qd, model.qd0)

    def at(t, q_, qd_, a_):
        qdd = _accelerations(model, t, q_, qd_, a_)
        drift = jnp.max(jnp.abs(model.constraints(q_, t))) if model.joints else jnp.zeros(())
        out = {"qdd": qdd, "drift": drift}
        if model.bearings:
            joint = model.bearings[0]
            loads, cage = joint.ball_loads(t, q_, qd_, model.q0, model.qd0)
            out.update(ball_loads=loads, cage=cage, bearing_force=joint.force(t, q_, qd_, model.q0, model.qd0))
        if model.contacts:
            out["contact_force"] = model.contacts[0].forces(t, q_, qd_, a_[0])[0]
            out["penetration"] = model.contacts[0].gap(q_, qd_)[0]
        return out

    o = jax.vmap(at)(ts, safe_q, safe_qd, approach)
    nan_where_invalid = lambda x: jnp.where(valid.reshape((-1,) + (1,) * (x.ndim - 1)), x, jnp.nan)
    o = jax.tree_util.tree_map(nan_where_invalid, o)
    zeros = jnp.zeros_like(ts)
    return Solution(
        ts=ts,
        q=q,
        qd=qd,
        qdd=o["qdd"],
        ball_loads=o.get("ball_loads"),
        bearing_force=o.get("bearing_force"),
        cage_angle=o.get("cage"),
        contact_force=o.get("contact_force", zeros),
        penetration=o.get("penetration", zeros),
        approach_speed=approach,
        drift=o["drift"],
        contacts=contacts,
        result=result,
        t_final=t_final,
        num_steps=steps,
        num_rejected_steps=rejected,
        num_segments=n_used,
    )


def _raise_on_failure(sol: Solution, t1) -> Solution:
    failed = sol.result != RESULTS.successful
    if _concrete(failed) and _concrete(sol.t_final):
        if bool(failed):
            raise SimulationError(
                f"The simulation stopped at t = {float(sol.t_final):.6g} s of t1 = {float(t1):.6g} s: "
                f"{RESULTS[sol.result]} Likely causes: a step limit too low for stiff contacts "
                "(raise max_steps), more contact events than max_segments (raise max_segments), "
                "or parameters that make the model blow up (check stiffness, clearance and "
                "masses). Pass throw=False to inspect the partial solution."
            )
        return sol
    # under jit/vmap/grad: the failing member's own message (see `RESULTS`)
    return sol.result.error_if(sol, failed)

"""Integration of a `Mechanism` with diffrax: the only place that calls `diffeqsolve`.

State y = [q, q_dot]. Impact contacts need the approach speed at the onset of each contact
(Lankarani–Nikravesh, Eq. 23), and the paper's ball force (Eq. 9) switches each ball's damping on
at first touch, so the solve is split into segments at events: a `diffrax.Event` locates, by
bisection on the step's interpolant (robust also for grazing contacts, where Newton stalls), the
time at which a penetration crosses zero (onset) or falls below -`SEPARATION_OFFSET`
(separation), or a paper-force ball's deflection crosses zero (engagement) or falls below
-`BALL_RELEASE` (release); the next segment restarts there with the approach speed recorded at
the onset and the ball switched. Within a segment the right-hand side is smooth, and derivatives
of the solution include the jump of every switch through the event times' implicit derivatives. Segments also end at the ends of ``time_cells`` equal
intervals of [t0, t1], so that the members of a vmapped batch stay aligned in time: a batch runs
each segment until its slowest member is done, and without the cells a member that has had one
contact event more than another would integrate an unrelated span beside it (measured: a batch
of 8 clearances of the paper's case then cost as much as 8 single runs). They end as well at
`WINDOW_START` and at the ``window_edges`` asked for, the edges of the metrics' windows. Segments
run in a `lax.scan` of fixed length (the number of stops plus ``max_segments``; reverse- and
forward-mode differentiable, vmappable); finished members idle in zero-length solves. A run that
needs more segments than that fails loudly.

While it integrates, the solver records per segment the peaks and integrals that
`jaxbearing.metrics` needs (`SegmentStats`), from every accepted step and the step's
interpolant, so that the metrics do not depend on the output times.
"""

from __future__ import annotations

import math
from typing import NamedTuple

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
from .laws import bearing as bearing_law
from .laws.bearing import BALL_RELEASE
from .multibody.mechanism import Mechanism

SEPARATION_OFFSET = 1e-9  # [m] separation is located at penetration = -1 nm: restarts never stall
EVENT_TIME_TOLERANCE = 1e-13  # [s] root-finding tolerance on event times
INITIAL_STEP = 1e-7  # first step as a fraction of t1 - t0; the controller grows it 10x a step
OUTPUT_BATCH = 1024  # output times evaluated together (forces, accelerations) after the solve
EVENT_RATE = 4000.0  # [1/s] events per simulated second that the default max_segments allows
STEP_RATE = 100_000.0  # [1/s] steps per simulated second that it allows for pauses (segment_steps)
WINDOW_START = 0.04  # [s] start of the metrics' default window (`metrics.T_MIN`); always a stop
POWER = 16  # order p of the power integrals in `SegmentStats` (the smooth metrics' p)
FORCE_SCALE = 1e3  # [N] forces are divided by it before the power p: no overflow below 1e22 N
# 3-point Gauss–Legendre rule on [0, 1]: nodes and weights
GAUSS_NODES = (0.5 - math.sqrt(15.0) / 10.0, 0.5, 0.5 + math.sqrt(15.0) / 10.0)
GAUSS_WEIGHTS = (5.0 / 18.0, 8.0 / 18.0, 5.0 / 18.0)
# columns of SegmentStats.peaks and .integrals
PEAK_BALL_LOAD, PEAK_BEARING_FORCE, PEAK_CONTACT_FORCE, PEAK_DISPLACEMENT = 0, 1, 2, 3
(INT_BEARING_FORCE_SQUARED, INT_BALL_LOAD_POWER, INT_BEARING_FORCE_POWER, INT_CONTACT_FORCE_POWER,
 INT_TIME) = range(5)


class RESULTS(diffrax.RESULTS):
    """diffrax's result codes plus the ones of the segmented solve."""

    max_segments_reached = (
        "More segments than max_segments allow (each contact onset and separation, each ball "
        "engagement and release, and with segment_steps each pause starts one). Increase "
        "`max_segments`."
    )


class SimulationError(RuntimeError):
    """A solve failed: the message says when (simulated time) and what to change."""


class Contacts(eqx.Module):
    """Onsets of impact contacts, one slot per segment (padded; read ``valid``).

    Fields:
        time: onset times [s], NaN in unused slots, (number of segment slots,).
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


class SegmentStats(eqx.Module):
    """Peaks and integrals over each segment of the solve, one slot per segment (padded; read
    ``valid``), taken from the solution itself: every accepted solver step and its interpolant
    (`_Recording`), not from the output times. `jaxbearing.metrics` combines them over a window.

    Each step contributes the values at its end and at its 3 Gauss–Legendre points, and their
    Gauss–Legendre quadrature over the step; the last step of a segment that ends at an event
    counts only up to the event. Peaks are therefore the maxima over those points (and the
    segment's start): exact there, and low by at most the interpolant's rise between points a
    quarter of a step apart. Integrals are exact for integrands that are polynomials of degree
    <= 5 over each step.

    Fields (S = number of segment slots):
        t_start, t_end: (S,) [s] of each segment, NaN in unused slots.
        peaks: (S, 3 + n_coordinates), the maxima over the segment of: the largest ball load of
            the model's first bearing [N], the magnitude |F| of its resultant (Eq. 28) [N], the
            normal force of the first impact contact [N], then |q_c - q0_c| of each coordinate
            [m or rad]; 0 for an element the model lacks. Columns ``PEAK_*``.
        integrals: (S, 5), the integrals over the segment of: |F|^2 [N^2 s], the sum over balls
            of (F_r / FORCE_SCALE)^POWER [s], (|F| / FORCE_SCALE)^POWER [s], (contact force /
            FORCE_SCALE)^POWER [s], and 1 (the segment's duration) [s]. Columns ``INT_*``.
        valid: (S,) bool, True where the slot holds a segment.
    """

    t_start: jax.Array
    t_end: jax.Array
    peaks: jax.Array
    integrals: jax.Array
    valid: jax.Array


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
        segments: `SegmentStats`, peaks and integrals of each segment (what the metrics read).
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
    segments: SegmentStats
    result: RESULTS
    t_final: jax.Array
    num_steps: jax.Array
    num_rejected_steps: jax.Array
    num_segments: jax.Array


class _Progress(diffrax.AbstractProgressMeter):
    """Moves one tqdm bar per label over the whole span [t0, t1], across segments.

    Each segment's solve runs [t_start, t_stop]; the meter reports the fraction of [t0, t1]
    reached to the host (`_advance`) at the start of the run and whenever it crosses a
    multiple of ``every``, so a run costs about 1/every + 1 callbacks however many segments it
    has (a segment that ends at an event may report its last cell once more). Under vmap it
    reports the slowest member. Under `jax.grad` the backward pass re-runs parts of the solve and restarts the bar.
    """

    t_start: jax.Array
    t_stop: jax.Array
    t0: jax.Array
    t1: jax.Array
    label: str = eqx.field(static=True)
    every: float = eqx.field(static=True, default=0.02)

    def _fraction(self, progress):
        inside = self.t_start + progress * (self.t_stop - self.t_start)
        t = jnp.where(progress >= 1, self.t_stop, inside)  # t_stop exactly at the end
        return -eqxi.unvmap_max(-(t - self.t0) / (self.t1 - self.t0))

    def _report(self, fraction):
        jax.debug.callback(_advance, self.label, fraction, eqxi.unvmap_max(self.t1 - self.t0))

    def init(self):
        fraction = self._fraction(jnp.zeros(()))
        start = eqxi.unvmap_all(self.t_start == self.t0)
        jax.lax.cond(eqxi.nonbatchable(start), lambda: self._report(fraction), lambda: None)
        return jnp.floor(fraction / self.every)

    def step(self, state, progress):
        fraction = self._fraction(progress)
        cell = jnp.floor(fraction / self.every)
        state = eqxi.unvmap_max(state)  # a vmapped loop batches its carry

        def report():
            self._report(fraction)
            return cell

        return jax.lax.cond(eqxi.nonbatchable(cell > state), report, lambda: state)

    def close(self, state):
        return None


_BARS: dict = {}  # label -> the tqdm bar of the run in progress under that label


def _advance(label, fraction, span):
    """Host side of `_Progress`: fraction 0 opens a bar for ``label`` (closing an older one),
    a larger fraction moves it forward, 1 closes it. The bar counts simulated seconds of the
    span [s]."""
    from tqdm.auto import tqdm

    fraction, span = float(fraction), float(span)
    bar = _BARS.get(label)
    if bar is None or fraction == 0.0:
        if bar is not None:  # a run that did not finish (an error, or a backward pass)
            bar.leave = False
            bar.close()
        bar = _BARS[label] = tqdm(
            total=span,
            desc=label,
            bar_format="{desc}: {percentage:3.0f}%|{bar}| {n:.4f} of {total:.4g} s "
            "[{elapsed}<{remaining}]",
            dynamic_ncols=True,
        )
    bar.update(max(0.0, min(fraction, 1.0) * span - bar.n))
    if fraction >= 1.0:
        bar.close()
        del _BARS[label]


def default_solver() -> diffrax.AbstractSolver:
    """Tsit5: on the paper's case it is the fastest at equal accuracy (README, benchmarks)."""
    return diffrax.Tsit5()


def kvaerno5(newton_rtol=1e-2, newton_atol=1e-5) -> diffrax.Kvaerno5:
    """Kvaerno5, the stiff (ESDIRK) solver, with a loose simplified-Newton iteration.

    The step error control (``simulate``'s rtol, atol) still sets the accuracy; a Newton
    tolerance as tight as the step tolerance makes the iteration fail at sharp force changes and
    multiplies rejected steps. benchmarks/run.py checks its accuracy against a run at 1000x
    tighter tolerances; README's benchmark table gives its steps and cost.
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
    max_segments: int | None = None,
    segment_steps: int | None = None,
    time_cells: int = 64,
    window_edges: tuple = (),
    output_block: int | None = None,
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
        max_steps: step limit of each segment (between events and stops; its pauses count
            together).
        max_segments: segments allowed beyond the stops (each contact onset and separation,
            each engagement and release of a paper-force ball, and each pause starts one); the
            run fails if it needs more. Default: `default_max_segments`.
        segment_steps: steps after which a segment pauses; the next iteration of the segment
            loop resumes it with the step-size controller's state and proposed step, so the
            solution is the same, to the last bit, as without pauses. Under `jax.vmap` the
            members run in lock-step, segment by segment: with pauses a member that reached an
            event waits for the others at most ``segment_steps`` steps, not until the longest
            segment of the batch ends, which is what makes batches (sweeps) fast. None (the
            default): no pauses, the cheapest for a single run. `jaxbearing.sweep` pauses
            every ``jaxbearing._sweep.SEGMENT_STEPS`` steps.
        time_cells: number of equal intervals of [t0, t1] at whose ends segments also stop,
            which keeps vmapped batches aligned in time (module docstring); 1 for none. Each
            costs a restart of the solver (measured: about 1.3 steps).
        window_edges: further times [s] at which segments end, so that `jaxbearing.metrics`
            can use them as window edges (a metric over a window needs its edges to be segment
            ends; `WINDOW_START`, the default window's start, always is). A tuple: its length
            is part of the compiled solve.
        output_block: output times one segment may write; default `default_output_block`, the most
            that fall in one time cell, so that each output time costs one write.
        throw: raise `SimulationError` (or an equinox runtime error under transformations) on
            failure; with False, inspect ``sol.result`` and ``sol.t_final``.
        progress: a label for one progress bar (tqdm, on stderr) over [t0, t1], or None.
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
    if segment_steps is not None and not 1 <= segment_steps:
        raise ValueError(f"segment_steps must be None or at least 1; got {segment_steps}.")
    if max_segments is None:
        max_segments = default_max_segments(model, t0, t1, segment_steps)
    if max_segments < 1:
        raise ValueError(f"max_segments must be at least 1; got {max_segments}.")
    if time_cells < 1:
        raise ValueError(f"time_cells must be at least 1; got {time_cells}.")
    if output_block is None:
        output_block = default_output_block(ts, t0, t1, time_cells)
    if not 1 <= output_block:
        raise ValueError(f"output_block must be at least 1; got {output_block}.")
    output_block = min(int(output_block), ts.shape[0])
    solver = default_solver() if solver is None else solver
    if stepsize_controller is None:
        stepsize_controller = diffrax.PIDController(rtol=rtol, atol=atol, pcoeff=0.3, icoeff=0.3)
    solver = _with_root_tolerances(solver, stepsize_controller)
    stops = jnp.asarray((WINDOW_START,) + tuple(window_edges), jnp.float64)
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
        segment_steps,
        time_cells,
        stops,
        output_block,
        progress,
    )
    if throw:
        sol = _raise_on_failure(sol, t1)
    return sol


def default_max_segments(model: Mechanism, t0, t1, segment_steps: int | None = None) -> int:
    """Segments `simulate` allows by default beyond its stops: for events, 1 for a model without
    contacts or paper-force balls, else 64 + `EVENT_RATE` (t1 - t0); with ``segment_steps``, for
    pauses, `STEP_RATE` (t1 - t0) / segment_steps more. Rounded up to a power of two, so that
    runs of similar spans share one compiled solve (a traced span counts as 1 s). README gives
    the event counts of the paper's case."""
    events = bool(model.contacts) or bool(model.n_switched_balls)
    span = float(t1) - float(t0) if _concrete(t1) and _concrete(t0) else 1.0
    span = max(span, 0.0)
    allowed = (64 + EVENT_RATE * span if events else 1) + (
        0 if segment_steps is None else STEP_RATE * span / segment_steps
    )
    return 1 << math.ceil(math.log2(allowed))


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




def default_output_block(ts, t0, t1, time_cells: int) -> int:
    """The most output times in one time cell, ends included (+2 for rounding of the cell
    ends): a segment never spans more than one cell, so it never writes more. All of ``ts``
    when ``ts`` or the span are traced."""
    if not (_concrete(ts) and _concrete(t0) and _concrete(t1)):
        return ts.shape[0]
    times = np.asarray(ts)
    edges = np.linspace(float(t0), float(t1), time_cells + 1)
    first = np.searchsorted(times, edges[:-1], side="left")
    last = np.searchsorted(times, edges[1:], side="right")
    return int(min(times.shape[0], np.max(last - first, initial=0) + 2))


def _block(ts, t_start, t_stop, done, size):
    """The ``size`` output times from the first one >= t_start: their index ``k``, and the times
    inside [t_start, t_stop] with NaN for the others. NaN passes diffrax's range check and never
    satisfies its save condition ``t_save <= t_next``; finished members (``done``) get only NaN,
    so their zero-length solves save nothing. (Under vmap diffrax re-runs the step body of
    members whose loop has ended and discards the result.)"""
    k = jnp.searchsorted(ts, t_start, side="left")
    index = k + jnp.arange(size)
    times = ts[jnp.minimum(index, ts.shape[0] - 1)]
    inside = (index < ts.shape[0]) & (times <= t_stop) & ~done
    return k, jnp.where(inside, jnp.clip(times, t_start, t_stop), jnp.nan)


def _write(buffer, k, rows, mask):
    """``buffer[k : k + len(rows)] = rows`` where ``mask``; ``buffer`` has len(rows) rows of
    padding at its end, so the slice always fits."""
    old = jax.lax.dynamic_slice_in_dim(buffer, k, rows.shape[0])
    mask = mask.reshape(mask.shape + (1,) * (rows.ndim - 1))
    return jax.lax.dynamic_update_slice_in_dim(buffer, jnp.where(mask, rows, old), k, 0)


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
def _accelerations(model, t, q, qd, approach_speeds, engaged):
    """`Mechanism.accelerations` behind its own jit, so that it is traced once per solve:
    diffrax traces the vector field six times (measured: 2.1 s of a 4.3 s trace of the paper's
    case). XLA inlines the call, so the compiled program is unchanged."""
    return model.accelerations(t, q, qd, approach_speeds, engaged)


def _forces(model, t, q, qd, approach_speeds, engaged):
    """Forces that the outputs and the metrics report: ``ball_loads`` (N_b,) [N], ``cage`` [rad]
    and ``bearing_force`` (2,) [N] of the first bearing joint, ``contact_force`` [N] and
    ``penetration`` [m] of the first impact contact (each only where the model has one)."""
    out = {}
    if model.bearings:
        first = model.engaged_by_bearing(engaged)[0]
        loads, cage = model.bearings[0].ball_loads(t, q, qd, model.q0, model.qd0, first)
        out.update(ball_loads=loads, cage=cage, bearing_force=bearing_law.resultant(loads, cage))
    if model.contacts:
        out["contact_force"] = model.contacts[0].forces(t, q, qd, approach_speeds[0])[0]
        out["penetration"] = model.contacts[0].gap(q, qd)[0]
    return out


def _quantities(model, t, y, args):
    """The peak candidates (3 + n,) and the integrands (5,) of `SegmentStats` at one state."""
    approach, _, engaged = args
    n = model.n_coordinates
    q, qd = y[:n], y[n:]
    f = _forces(model, t, q, qd, approach, engaged)
    zero = jnp.zeros((), y.dtype)
    loads = f.get("ball_loads", zero[None])
    resultant = f.get("bearing_force", jnp.zeros(2, y.dtype))
    squared = jnp.sum(resultant * resultant)
    magnitude = jnp.sqrt(squared + 1e-30)
    contact = f.get("contact_force", zero)
    peaks = jnp.concatenate(
        [jnp.stack([jnp.max(loads), magnitude, contact]), jnp.abs(q - model.q0)]
    )
    integrands = jnp.stack(
        [
            squared,
            jnp.sum((loads / FORCE_SCALE) ** POWER),
            (magnitude / FORCE_SCALE) ** POWER,
            (contact / FORCE_SCALE) ** POWER,
            jnp.ones_like(t),
        ]
    )
    return peaks, integrands


def _step_stats(model, interpolation, t_a, t_b, args):
    """Peaks and integrals over [t_a, t_b] of one step's interpolant: the values at t_b and at
    the 3 Gauss–Legendre points, and their Gauss–Legendre quadrature."""
    times = jnp.concatenate([t_a + (t_b - t_a) * jnp.asarray(GAUSS_NODES), t_b[None]])
    ys = jax.vmap(interpolation.evaluate)(times)
    peaks, integrands = jax.vmap(lambda t, y: _quantities(model, t, y, args))(times, ys)
    integral = (t_b - t_a) * (jnp.asarray(GAUSS_WEIGHTS) @ integrands[:3])
    return jnp.max(peaks, axis=0), integral


class _Recording(diffrax.AbstractAdaptiveSolver):
    """The user's solver, plus the `SegmentStats` of the steps it takes.

    State: (inner state, (peaks, integrals) over all accepted steps but the latest, the latest
    accepted step (t0, t1, dense_info)). Each step adds its predecessor's stats: diffrax keeps
    the old state when it rejects a step, so only accepted steps count, and the latest one is
    left open, so that `_close` counts it up to the end of the segment, which lies before its t1
    when the segment ends at an event. The state starts with a placeholder step of length zero
    at y0 (values y0, slopes zero), which counts the segment's initial state.
    """

    solver: diffrax.AbstractSolver
    model: Mechanism

    @property
    def term_structure(self):
        return self.solver.term_structure

    @property
    def interpolation_cls(self):  # pyright: ignore
        return self.solver.interpolation_cls

    @property
    def term_compatible_contr_kwargs(self):
        return self.solver.term_compatible_contr_kwargs

    def order(self, terms):
        return self.solver.order(terms)

    def error_order(self, terms):
        return self.solver.error_order(terms)

    def init(self, terms, t0, t1, y0, args):
        inner = self.solver.init(terms, t0, t1, y0, args)
        _, _, dense_struct, _, _ = eqx.filter_eval_shape(
            self.solver.step, terms, t0, t1, y0, args, inner, False
        )
        dense = jax.tree_util.tree_map(
            lambda s: y0 if s.shape == y0.shape else jnp.zeros(s.shape, s.dtype), dense_struct
        )
        k = 3 + self.model.n_coordinates
        stats = (jnp.full(k, -jnp.inf, y0.dtype), jnp.zeros(5, y0.dtype))
        t0 = jnp.asarray(t0, y0.dtype)
        return inner, stats, (t0, t0, dense)

    def step(self, terms, t0, t1, y0, args, solver_state, made_jump):
        inner, stats, last = solver_state
        y1, error, dense, inner, result = self.solver.step(
            terms, t0, t1, y0, args, inner, made_jump
        )
        stats = _add(stats, _close(self.model, self.solver, last, last[1], args))
        t0, t1 = jnp.asarray(t0, y0.dtype), jnp.asarray(t1, y0.dtype)
        return y1, error, dense, (inner, stats, (t0, t1, dense)), result

    def func(self, terms, t0, y0, args):
        return self.solver.func(terms, t0, y0, args)


def _close(model, solver, last, t_end, args):
    """Stats of the step ``last`` = (t0, t1, dense_info) over [t0, t_end]."""
    t_a, t_b, dense = last
    return _step_stats(model, solver.interpolation_cls(t0=t_a, t1=t_b, **dense), t_a, t_end, args)


def _add(stats, more):
    return jnp.maximum(stats[0], more[0]), stats[1] + more[1]


def _with_root_tolerances(solver, controller):
    """An implicit solver whose root finder takes the step controller's tolerances where it asks
    for them (`diffrax.with_stepsize_controller_tols`), as `diffeqsolve` does for an unwrapped
    solver."""
    if not (
        isinstance(solver, diffrax.AbstractImplicitSolver)
        and isinstance(controller, diffrax.AbstractAdaptiveStepSizeController)
    ):
        return solver
    names = [
        a for a in ("rtol", "atol", "norm")
        if getattr(solver.root_finder, a) is diffrax._root_finder.use_stepsize_tol
    ]
    if not names:
        return solver
    return eqx.tree_at(
        lambda s: tuple(getattr(s.root_finder, a) for a in names),
        solver,
        tuple(getattr(controller, a) for a in names),
    )


class _Resumable(diffrax.AbstractStepSizeController):
    """The user's step-size controller, remembering the step it proposes next: state (inner
    state, next step [s]). A paused segment hands both to the next solve, which so continues
    with the very steps it would have taken without the pause."""

    controller: diffrax.AbstractStepSizeController

    def wrap(self, direction):
        return _Resumable(self.controller.wrap(direction))

    def init(self, terms, t0, t1, y0, dt0, args, func, error_order):
        tnext, inner = self.controller.init(terms, t0, t1, y0, dt0, args, func, error_order)
        return tnext, (inner, tnext - t0)

    def adapt_step_size(self, t0, t1, y0, y1_candidate, args, y_error, error_order, controller_state):
        inner, _ = controller_state
        keep, tprev, tnext, jump, inner, result = self.controller.adapt_step_size(
            t0, t1, y0, y1_candidate, args, y_error, error_order, inner
        )
        return keep, tprev, tnext, jump, (inner, tnext - tprev), result


def _stops(t0, t1, time_cells, extra):
    """Times at which segments end, increasing: the ends of the ``time_cells`` equal cells of
    [t0, t1] and the ``extra`` times inside (t0, t1). A static count: the extra times outside,
    and a stop equal to its predecessor, move to t1, where the loop finishes."""
    cells = jnp.linspace(t0, t1, time_cells + 1)[1:].at[-1].set(t1)
    extra = jnp.where((extra > t0) & (extra < t1), extra, t1)
    stops = jnp.sort(jnp.concatenate([cells, extra]))
    repeated = jnp.concatenate([jnp.zeros(1, bool), stops[1:] == stops[:-1]])
    return jnp.sort(jnp.where(repeated, t1, stops))


def _for_adjoint(solver, adjoint):
    """A Runge–Kutta solver whose stage loop forward mode can differentiate ("lax"), as
    `diffeqsolve` chooses it for an unwrapped solver under `diffrax.ForwardMode`."""
    runge_kutta = isinstance(solver, diffrax.AbstractRungeKutta)
    if not isinstance(adjoint, diffrax.ForwardMode) or not runge_kutta or solver.scan_kind is not None:
        return solver
    return eqx.tree_at(lambda s: s.scan_kind, solver, "lax", is_leaf=lambda x: x is None)


def _concrete(x) -> bool:
    return not isinstance(x, jax.core.Tracer)


class _Carry(NamedTuple):
    """State of the segment loop between two segments."""

    t: jax.Array  # start of the next segment [s]
    cell: jax.Array  # index of the next stop (time-cell end or window edge) it runs to
    dt: jax.Array  # its first step [s]
    y: jax.Array  # state [q, qd] at t
    approach: jax.Array  # (n_contacts,) approach speed of each contact's current contact [m/s]
    in_contact: jax.Array  # (n_contacts,) bool
    engaged: jax.Array  # (n_switched_balls,) bool, balls of paper-force bearings that touch
    out_y: jax.Array  # (T + block, 2n) states at the output times, NaN where not yet reached
    out_approach: jax.Array  # (T + block, n_contacts) approach speeds in force at the output times
    out_engaged: jax.Array  # (T + block, n_switched_balls) engaged balls at the output times
    done: jax.Array  # reached t1 or failed
    result: RESULTS
    steps: jax.Array
    rejected: jax.Array
    control: object  # state of the step-size controller (`_Resumable`) where a segment paused
    resume: jax.Array  # the next segment continues a paused one
    since: jax.Array  # steps since the last segment end that was not a pause
    began: jax.Array  # where the segment that paused began [s]
    accepted: jax.Array  # steps it accepted so far


@jit
def _simulate(
    model, t0, t1, ts, solver, controller, max_steps, max_segments, segment_steps, time_cells, extra_stops, block,
    progress, adjoint,
):
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
    n_balls = model.n_switched_balls
    T = ts.shape[0]

    def vector_field(t, y, args):
        approach, _, engaged = args
        q, qd = y[:n], y[n:]
        return jnp.concatenate([qd, _accelerations(model, t, q, qd, approach, engaged)])

    def event_values(t, y, in_contact, engaged):
        """One value per contact, then one per switched ball, each negative until its next
        event. Contacts: the penetration while apart (onset at 0), -(penetration +
        SEPARATION_OFFSET) while touching, -1 while switched off. Balls: delta_r while free
        (engages at 0), -(delta_r + BALL_RELEASE) while engaged."""
        q, qd = y[:n], y[n:]
        penetration, _ = model.contact_gaps(q, qd)
        contact = jnp.where(in_contact, -(penetration + SEPARATION_OFFSET), penetration)
        active = jnp.stack([c.active(t) for c in model.contacts]) if n_contacts else contact > 0
        delta = model.ball_deflections(t, q)
        ball = jnp.where(engaged, -(delta + BALL_RELEASE), delta)
        return jnp.concatenate([jnp.where(active, contact, -1.0), ball])

    def first_event(t, y, args, **kwargs):
        # every value starts a segment negative, so the maximum crosses zero at the first event
        return jnp.max(event_values(t, y, args[1], args[2]))

    event = None
    if n_contacts + n_balls:
        event = diffrax.Event(
            first_event,
            root_finder=_EventBisection(rtol=0.0, atol=EVENT_TIME_TOLERANCE),
            direction=True,
        )
    term = diffrax.ODETerm(vector_field)
    recording = _Recording(_for_adjoint(solver, adjoint), model)
    if segment_steps is not None:
        controller = _Resumable(controller)
    stops = _stops(t0, t1, time_cells, extra_stops)
    n_stops = stops.shape[0]

    def segment(c: _Carry, slot):
        # finished members (reached t1, or failed: then t is set to t1 with the stop where it
        # failed) idle in zero-length solves, never backwards from t1 to their stop
        t_stop = jnp.where(c.done, c.t, stops[c.cell])
        k, save_ts = _block(ts, c.t, t_stop, c.done, block)
        meter = (
            diffrax.NoProgressMeter()
            if progress is None
            else _Progress(t_start=c.t, t_stop=t_stop, t0=t0, t1=t1, label=progress)
        )
        args = (c.approach, c.in_contact, c.engaged)
        dt0 = jnp.minimum(c.dt, t_stop - c.t)
        resumed = {}
        if segment_steps is not None:  # a paused segment goes on with its controller's state
            fresh = controller.init(term, c.t, t_stop, c.y, dt0, args, recording.func, None)[1]
            state = jax.tree_util.tree_map(lambda a, b: jnp.where(c.resume, a, b), c.control, fresh)
            dt0 = jnp.where(c.resume, jnp.minimum(c.control[1], t_stop - c.t), dt0)
            resumed = dict(controller_state=jax.lax.stop_gradient(state))
        sol = diffrax.diffeqsolve(
            term,
            recording,
            c.t,
            t_stop,
            dt0,
            c.y,
            args=args,
            saveat=diffrax.SaveAt(
                subs=[diffrax.SubSaveAt(ts=save_ts), diffrax.SubSaveAt(t1=True)],
                solver_state=True,
                controller_state=segment_steps is not None,
            ),
            stepsize_controller=controller,
            event=event,
            max_steps=max_steps if segment_steps is None else segment_steps,
            throw=False,
            progress_meter=meter,
            adjoint=adjoint,
            **resumed,
        )
        (_, t_end), (ys, y_end) = sol.ts, sol.ys
        t_end, y_end = t_end[0], y_end[0]
        _, stats, last = sol.solver_state
        paused, control, since = jnp.asarray(False), None, c.since
        if segment_steps is not None:
            # a segment pauses at segment_steps steps; one that took max_steps since its start
            # has failed
            since = c.since + sol.stats["num_steps"]
            paused = (sol.result == diffrax.RESULTS.max_steps_reached) & (since < max_steps)
            control = jax.lax.stop_gradient(sol.controller_state)
        if event is not None:
            # a segment that did not stop at an event ends where its latest accepted step does.
            # Under vmap, when another member stopped at an event, diffrax moves every member
            # without one to the end of its last *attempted* step (possibly a rejected one, at a
            # pause) and interpolates its state there
            settled = sol.result != diffrax.RESULTS.event_occurred
            t_end = jnp.where(settled, last[1], t_end)
            y_end = jnp.where(settled, last[2]["y1"], y_end)
        ok = (sol.result == diffrax.RESULTS.successful) | (sol.result == diffrax.RESULTS.event_occurred) | paused
        hit = (sol.result == diffrax.RESULTS.event_occurred) & ~c.done
        # stats of the segment: its accepted steps, the last one only up to t_end (an event)
        peaks, integrals = _add(stats, _close(model, solver, last, t_end, args))
        # outputs of this segment: its block's times in [t_start, t_end], each written once
        mine = save_ts <= t_end  # False for NaN
        out_y = _write(c.out_y, k, ys, mine)
        out_approach = _write(c.out_approach, k, jnp.broadcast_to(c.approach, (block, n_contacts)), mine)
        out_engaged = _write(c.out_engaged, k, jnp.broadcast_to(c.engaged, (block, n_balls)), mine)
        # switch what the event found: the located one and any other already across
        approach, in_contact, engaged = c.approach, c.in_contact, c.engaged
        record = (jnp.nan, jnp.nan, -1, jnp.asarray(False))
        if event is not None:
            values = event_values(t_end, y_end, in_contact, engaged)
            located = jnp.arange(values.shape[0]) == jnp.argmax(values)
            switch = (located | (values > 0)) & hit
            contact_switch, ball_switch = switch[:n_contacts], switch[n_contacts:]
            engaged = jnp.where(ball_switch, ~engaged, engaged)
            if n_contacts:
                _, rate = model.contact_gaps(y_end[:n], y_end[n:])
                onset = contact_switch & ~in_contact
                approach = jnp.where(onset, rate, approach)
                in_contact = jnp.where(contact_switch, ~in_contact, in_contact)
                has_onset = jnp.any(onset)
                record = (
                    jnp.where(has_onset, t_end, jnp.nan),
                    jnp.where(has_onset, jnp.sum(jnp.where(onset, rate, 0.0)), jnp.nan),
                    jnp.where(has_onset, jnp.argmax(onset), -1),
                    has_onset,
                )
        result = RESULTS.where(c.done | ok, c.result, RESULTS.promote(sol.result))
        steps = c.steps + jnp.where(c.done, 0, sol.stats["num_steps"])
        rejected = c.rejected + jnp.where(c.done, 0, sol.stats.get("num_rejected_steps", 0))
        t_reached = jnp.where(c.done, c.t, t_end)
        cell_done = ok & ~hit & ~paused
        finished = c.done | ~ok | (cell_done & ((c.cell == n_stops - 1) | (t_stop >= t1)))
        # the next segment starts with the mean accepted step of this one (no step-size search;
        # no gradient through the step sizes, as in diffrax's controllers)
        # (over the whole segment: its paused parts count from where it began)
        accepted = sol.stats["num_accepted_steps"] + jnp.where(c.resume, c.accepted, 0)
        began = jnp.where(c.resume, c.began, c.t)
        mean_step = jax.lax.stop_gradient((t_end - began) / jnp.maximum(accepted, 1))
        carry = _Carry(
            t=jnp.where(finished, t1, t_end),
            cell=jnp.where(cell_done & ~finished, c.cell + 1, c.cell),
            dt=jnp.where(c.done | (accepted == 0), c.dt, mean_step),
            control=control,
            resume=paused & ~finished,
            since=jnp.where(paused, since, 0),
            began=began,
            accepted=accepted,
            y=jnp.where(c.done, c.y, y_end),
            approach=approach,
            in_contact=in_contact,
            engaged=engaged,
            out_y=out_y,
            out_approach=out_approach,
            out_engaged=out_engaged,
            done=finished,
            result=result,
            steps=steps,
            rejected=rejected,
        )
        segment_record = (
            jnp.where(c.done, jnp.nan, c.t),
            jnp.where(c.done, jnp.nan, t_reached),
            jnp.where(c.done, 0.0, peaks),
            jnp.where(c.done, 0.0, integrals),
        )
        return carry, record + (t_reached, ~c.done) + segment_record

    init = _Carry(
        t=t0,
        cell=jnp.asarray(0),
        dt=(t1 - t0) * INITIAL_STEP,
        y=y0,
        approach=jnp.zeros(n_contacts),
        in_contact=jnp.zeros(n_contacts, bool),
        engaged=model.ball_deflections(t0, model.q0) > 0.0,
        out_y=jnp.full((T + block, 2 * n), jnp.nan),
        out_approach=jnp.zeros((T + block, n_contacts)),
        out_engaged=jnp.zeros((T + block, n_balls), bool),
        done=jnp.asarray(False),
        result=RESULTS.successful,
        steps=jnp.asarray(0),
        rejected=jnp.asarray(0),
        control=None,
        resume=jnp.asarray(False),
        since=jnp.asarray(0),
        began=t0,
        accepted=jnp.asarray(0),
    )
    if segment_steps is not None:
        args0 = (init.approach, init.in_contact, init.engaged)
        control = controller.init(term, t0, t1, y0, init.dt, args0, recording.func, None)[1]
        init = init._replace(control=jax.tree_util.tree_map(jnp.asarray, control))
    final, records = jax.lax.scan(segment, init, jnp.arange(n_stops + max_segments))
    onset_t, onset_v, onset_i, onset_valid, t_reached, used, *segment_stats = records
    t_final = jnp.max(jnp.where(used, t_reached, t0))
    result = RESULTS.where(final.done, final.result, RESULTS.max_segments_reached)
    return _outputs(
        model,
        ts,
        final.out_y[:T],
        final.out_approach[:T],
        final.out_engaged[:T],
        Contacts(onset_t, onset_v, onset_i, onset_valid),
        SegmentStats(*segment_stats, used),
        result,
        t_final,
        final.steps,
        final.rejected,
        jnp.sum(used),
    )


def _outputs(
    model, ts, ys, approach, engaged, contacts, segments, result, t_final, steps, rejected, n_used
):
    n = model.n_coordinates
    q, qd = ys[:, :n], ys[:, n:]
    valid = jnp.isfinite(ys).all(axis=1)
    safe_q = jnp.where(valid[:, None], q, model.q0)
    safe_qd = jnp.where(valid[:, None], qd, model.qd0)

    def at(t, q_, qd_, a_, e_):
        qdd = _accelerations(model, t, q_, qd_, a_, e_)
        drift = jnp.max(jnp.abs(model.constraints(q_, t))) if model.joints else jnp.zeros(())
        return {"qdd": qdd, "drift": drift, **_forces(model, t, q_, qd_, a_, e_)}

    # in batches: a vmap over all T output times streams every intermediate through memory
    o = jax.lax.map(lambda x: at(*x), (ts, safe_q, safe_qd, approach, engaged), batch_size=OUTPUT_BATCH)
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
        segments=segments,
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

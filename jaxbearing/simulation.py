"""The public entry of the solve: `simulate` and `simulate_one_loop` of a `Mechanism`, their
defaults, their arguments and their outputs.

`simulate` repeats the integrator core (`jaxbearing.solve`: a solver step with step-size
control, or a step of the event's root finder, and the records of each step taken) in
segments of ``segment_steps`` iterations: a `lax.scan` of fixed length (``max_segments``;
reverse- and forward-mode differentiable, vmappable) whose segments are `eqxi.while_loop`s. A
run that needs more segments than that fails loudly. `simulate_one_loop` repeats the same core
in one while loop.

The mechanism enters the engine as an `AbstractSystem` (`recorder.MechanismSystem`: its
equations of motion, its force elements' discrete states and events) and what each step
records as an `AbstractRecorder` (`recorder.Recorder`: each element's declared peaks and
integrals, from every accepted step and its interpolant, so that the metrics do not depend on
the output times, per interval between stops: the model's ``window_start``, the window edges
asked for, t1). The engine knows only states and columns; the recorder says what they hold
and makes the `Solution` of them.
"""

from __future__ import annotations

import contextlib
import contextvars
import functools
import math
import warnings
from typing import NamedTuple

import diffrax
import equinox as eqx
import equinox.internal as eqxi
import jax
import jax.numpy as jnp
import numpy as np
import optimistix as optx

from . import _checks
from ._checks import is_concrete
from ._options import SolveOptions, check_record_windows, record_edges
from ._trust import warn_if_loose, warn_if_rattling
from .multibody.mechanism import Mechanism
from .recorder import MechanismSystem, Recorder
from .solution import DriftWarning, Solution, first_rows, raise_on_failure
from .solve import (
    RESULTS,
    check_count,
    checked_controller,
    checked_dt0,
    checked_solver,
    checked_span,
    checked_tolerances,
    checked_ts,
    window_stops,
    ROOT_STEPS,
    SegmentPlan,
    Setup,
    default_output_block,
    for_loop_kind,
    for_restarts,
    initial_state,
    label_key,
    loop_kind,
    output_rows,
    padded_times,
    run_one_loop,
    run_segments,
    stops as _stops,
    with_root_tolerances,
)

INITIAL_STEP = 1e-7  # first step as a fraction of t1 - t0; the controller grows it 10x a step
RTOL, ATOL = 1e-8, 1e-10  # the default step-size control's tolerances (state in m, rad, m/s)
OUTPUT_BATCH = 2048  # output times evaluated together (forces, drift) after the solve
OUTPUT_BUCKET = 2048  # fewer output times share one compiled solve of this many (`_bucketed`)
SEGMENT_STEPS = 128  # default iterations of a segment: the rows of its record of steps
ITERATION_RATE = 500_000.0  # [1/s] iterations per simulated second the default max_segments allows
ONSET_RATE = 320.0  # [1/s] contact onsets per simulated second the default max_onsets allows


_ADJOINT = contextvars.ContextVar("jaxbearing_default_adjoint", default=None)


@contextlib.contextmanager
def default_adjoint(adjoint: diffrax.AbstractAdjoint | None):
    """Within this block, `simulate` called without an ``adjoint`` (or with None) uses
    ``adjoint``: e.g. ``diffrax.ForwardMode()``, so that a function that calls `simulate` with
    its defaults can be differentiated by `jax.jvp` or `jax.jacfwd` unchanged (`tune` does this
    in forward mode). An ``adjoint`` passed to `simulate` wins. None restores the default
    (reverse mode). The setting is per thread and per asyncio task (a `contextvars` variable)
    and applies where `simulate` is traced: a function compiled outside the block keeps the
    adjoint it was compiled with."""
    if adjoint is not None and not isinstance(adjoint, diffrax.AbstractAdjoint):
        raise TypeError(
            f"default_adjoint takes a diffrax adjoint (e.g. diffrax.ForwardMode()) or None; got "
            f"{type(adjoint).__name__}."
        )
    token = _ADJOINT.set(adjoint)
    try:
        yield adjoint
    finally:
        _ADJOINT.reset(token)


def default_solver() -> diffrax.AbstractSolver:
    """Tsit5: on the paper's case it is the fastest at equal accuracy (docs/performance.md)."""
    return diffrax.Tsit5()


def kvaerno5(newton_rtol=1e-2, newton_atol=1e-5) -> diffrax.Kvaerno5:
    """Kvaerno5, the stiff (ESDIRK) solver, with a loose simplified-Newton iteration.

    The step error control (the step-size controller's rtol, atol) still sets the accuracy; a
    Newton tolerance as tight as the step tolerance makes the iteration fail at sharp force changes and
    multiplies rejected steps. benchmarks/run.py checks its accuracy against a run at 1000x
    tighter tolerances; docs/performance.md gives its steps and cost.
    """
    return diffrax.Kvaerno5(
        root_finder=diffrax.VeryChord(rtol=newton_rtol, atol=newton_atol, norm=optx.max_norm)
    )


def default_controller(rtol=RTOL, atol=ATOL) -> diffrax.PIDController:
    """The step-size control `simulate` uses by default: diffrax's `PIDController` with
    proportional and integral coefficients 0.3, which reject fewer steps than a plain I
    controller on the paper's case with impact, and the error tolerances ``rtol`` and ``atol``
    on the state (m, rad, m/s). Other tolerances compile nothing new."""
    rtol, atol = checked_tolerances(rtol, atol)
    return diffrax.PIDController(rtol=rtol, atol=atol, pcoeff=0.3, icoeff=0.3)


def simulate(
    model: Mechanism,
    t1: float,
    ts=None,
    *,
    solver: diffrax.AbstractSolver | None = None,
    stepsize_controller: diffrax.AbstractStepSizeController | None = None,
    adjoint: diffrax.AbstractAdjoint | None = None,
    max_steps: int = 1_000_000,
    throw: bool = True,
    progress: str | None = None,
    options: SolveOptions | None = None,
) -> Solution:
    """Integrate the equations of motion (Eq. 36) from ``options.t0`` (default 0) to ``t1`` [s].

    Args:
        model: a `Mechanism` (e.g. `jaxbearing.cases.xu2014()`); starts from ``model.q0, qd0``.
        t1: final time [s], finite, > t0.
        ts: output times, 1-D, finite, increasing, within [t0, t1] (default 1001 points). Up to
            `OUTPUT_BUCKET` of them share one compiled solve (`_bucketed`).
        solver: a diffrax solver (default `default_solver()`, Tsit5); `kvaerno5()` for the
            stiff solver.
        stepsize_controller: a diffrax step-size controller; default `default_controller()`
            (rtol 1e-8, atol 1e-10). Its rtol and atol are values of the compiled solve, like
            ``max_steps``: other values compile nothing. ``diffrax.ConstantStepSize()`` takes
            its step from ``options.dt0``; ``diffrax.StepTo`` is refused (its grid cannot
            survive the restarts at events).
        adjoint: how the solve's loops are differentiated, as in diffrax. None: the adjoint
            of the enclosing `default_adjoint` block, else reverse mode, for `jax.grad` and
            `jax.jacrev` (as
            `diffrax.RecursiveCheckpointAdjoint`, storing every step of a segment:
            docs/gradients.md says why). For `jax.jacfwd` and `jax.jvp` pass
            ``diffrax.ForwardMode()`` (the cheaper for a few parameters; `jaxbearing.sensitivity`
            does).
        max_steps: steps (accepted and rejected) the whole run may take, an integer >= 1.
        throw: raise on failure (`SimulationError`; a `ValueError` naming the rule for an invalid
            parameter value); with False, inspect ``sol.result`` (`RESULTS`) and ``sol.t_final``.
            The compiled solve itself raises nothing: failures come back as result codes.
        progress: a label for one progress bar (tqdm, on stderr) over [t0, t1], or None. Another
            label compiles nothing.
        options: `SolveOptions` (start time, window edges, fatigue records, segmentation);
            None: the defaults.
    """
    a = solve_arguments("simulate", model, t1, solver, stepsize_controller, max_steps, options)
    model, options, t0, t1, solver, stepsize_controller = a.model, a.options, a.t0, a.t1, a.solver, a.controller
    ts = checked_ts(jnp.linspace(t0, t1, 1001) if ts is None else ts, t0, t1)
    n_out = ts.shape[0]
    ts = _bucketed(ts)
    sizes = _segmentation(model, options, a.span, ts) + (a.max_onsets,)
    if progress is not None and not isinstance(progress, str):
        raise ValueError(f"progress must be a label (str) or None; got {progress!r}.")
    sol, broken = _with_adjoint(
        _ADJOINT.get() if adjoint is None else adjoint,
        model,
        t0,
        t1,
        a.dt0,
        ts,
        solver,
        stepsize_controller,
        jax.device_put(np.asarray(max_steps)),  # an array, like rtol and atol: another value compiles nothing
        window_stops(options.window_edges, model.window_start, record_edges(options.records)),
        options.fatigue is not False,
        options.records,
        sizes,
        None if progress is None else label_key(progress),
    )
    if throw:
        sol = raise_on_failure(sol, t1, broken, ROOT_STEPS)
    warn_if_drifting(sol, model)
    sol = sol if ts.shape[0] == n_out else first_rows(sol, n_out)
    warn_if_rattling(sol)
    return sol


class SolveArguments(NamedTuple):
    """The arguments both drivers (`simulate`, `simulate_one_loop`) take, checked."""

    model: Mechanism  # its numeric leaves float64 arrays
    options: SolveOptions
    span: tuple  # (t0, t1) as given: Python numbers stay concrete under the caller's jit
    t0: jax.Array  # [s]
    t1: jax.Array  # [s]
    dt0: jax.Array  # [s] the first step (`SolveOptions.dt0`)
    solver: diffrax.AbstractSolver
    controller: diffrax.AbstractStepSizeController
    max_onsets: int


def solve_arguments(caller: str, model, t1, solver, controller, max_steps, options) -> SolveArguments:
    """The arguments of a solve checked (a `TypeError` or `ValueError` naming the fix) and their
    defaults filled in."""
    _checks.require_x64()
    if not isinstance(model, Mechanism):
        raise TypeError(f"{caller} needs a jaxbearing Mechanism, got {type(model).__name__}.")
    model = _checks.float_leaves(model)  # a Python float set by eqx.tree_at compiles nothing
    options = _checked_options(options)
    span = (options.t0, t1)
    t0, t1 = checked_span(options.t0, t1)
    check_record_windows(options.records, span[1], model.window_start)
    check_count("max_steps", max_steps)
    check_count("max_onsets", options.max_onsets, optional=True)
    max_onsets = default_max_onsets(*span) if options.max_onsets is None else int(options.max_onsets)
    solver = default_solver() if solver is None else checked_solver(solver)
    controller = (
        default_controller() if controller is None else checked_controller(controller)
    )
    warn_if_loose(controller, stacklevel=4)  # the caller's caller: simulate's user
    solver = with_root_tolerances(solver, controller)
    dt0 = checked_dt0(options.dt0, controller, t0, t1)
    if dt0 is None:  # NumPy where t0 and t1 are known: an eager operation compiles a program
        length = np.asarray(t1) - np.asarray(t0) if is_concrete(t0, t1) else t1 - t0
        dt0 = _checks.to_float64(length * INITIAL_STEP)
    return SolveArguments(model, options, span, t0, t1, dt0, solver, controller, max_onsets)


def _segmentation(model, options: SolveOptions, span, ts) -> tuple[int, int, int]:
    """(max_segments, segment_steps, output_block) of ``options``, defaults filled in; a
    `ValueError` for a value below 1."""
    for name in ("max_segments", "segment_steps", "output_block"):
        check_count(name, getattr(options, name), optional=True)
    segment_steps = SEGMENT_STEPS if options.segment_steps is None else int(options.segment_steps)
    max_segments = options.max_segments
    if max_segments is None:
        max_segments = default_max_segments(model, *span, segment_steps)
    block = default_output_block(ts) if options.output_block is None else options.output_block
    return int(max_segments), segment_steps, min(int(block), ts.shape[0])


def _bucketed(ts):
    """``ts`` padded with copies of its last time to `OUTPUT_BUCKET` times where it has fewer and
    `simulate` compiles its own solve (called outside any transformation: then only the number
    of output times is part of the compiled solve, not their values), so that runs with up to
    that many output times share one compiled solve; else ``ts``. Each output time's values come
    from the interpolant of the step that covers it, so the padding changes none of them."""
    n = ts.shape[0]
    if n >= OUTPUT_BUCKET or not is_concrete(ts):
        return ts
    t = np.asarray(ts)  # NumPy: eager operations on ``ts`` would compile a program each
    return jax.device_put(np.concatenate([t, np.full(OUTPUT_BUCKET - n, t[-1])]))


def _span(t0, t1) -> float:
    """t1 - t0 [s] where both are concrete, else 1 s."""
    return max(float(t1) - float(t0) if is_concrete(t1, t0) else 1.0, 0.0)


def default_max_segments(model: Mechanism, t0, t1, segment_steps: int = SEGMENT_STEPS) -> int:
    """Segments `simulate` allows by default: 16 + `ITERATION_RATE` (t1 - t0) / segment_steps
    rounded up to a power of two, so that
    runs of similar spans share one compiled solve (a traced span counts as 1 s). An iteration
    is a step (accepted or rejected) or a step of an event's root finder; docs/performance.md
    gives the counts of the paper's case."""
    allowed = 16 + ITERATION_RATE * _span(t0, t1) / segment_steps
    return 1 << math.ceil(math.log2(allowed))


def default_max_onsets(t0, t1) -> int:
    """Contact onsets `simulate` records by default: 32 + `ONSET_RATE` (t1 - t0), rounded up
    to a power of two (a traced span counts as 1 s)."""
    return 1 << math.ceil(math.log2(32 + ONSET_RATE * _span(t0, t1)))


def _with_adjoint(adjoint, *args):
    """`_simulate` ``(*args, kind)`` with the loop kind of ``adjoint`` (`loop_kind`; None: reverse
    mode, "checkpointed", as diffrax's default). Reverse-mode loops are `jax.custom_vjp`s, which
    JAX refuses to differentiate in forward mode: a `TypeError` raised while tracing under such a
    loop carries a note naming the adjoint to pass."""
    kind = "checkpointed" if adjoint is None else loop_kind(adjoint)
    try:
        return _simulate(*args, kind)  # (the `Solution`, the broken rule: `_checks.Broken`)
    except TypeError as err:
        if kind == "checkpointed" and str(err) != NESTED_DERIVATIVE:
            err.add_note(
                "simulate differentiates in reverse mode (jax.grad, jax.jacrev) unless told: for "
                "forward mode (jax.jacfwd, jax.jvp) pass adjoint=diffrax.ForwardMode(), call it "
                "within jaxbearing.default_adjoint(diffrax.ForwardMode()), or use "
                "jaxbearing.sensitivity (jaxbearing.tune: mode='forward')."
            )
        raise


def _checked_options(options) -> SolveOptions:
    """``options``, or the default `SolveOptions`; a `TypeError` for anything else."""
    if options is None:
        return SolveOptions()
    if not isinstance(options, SolveOptions):
        raise TypeError(f"options must be a jaxbearing.SolveOptions; got {type(options).__name__}.")
    return options


NESTED_DERIVATIVE = (
    "jaxbearing's solve is differentiable once: jax.grad, jax.jacrev, jax.jacfwd, jax.jvp and "
    "jaxbearing.sensitivity give exact first derivatives, but a derivative of a derivative "
    "(jax.hessian, jax.jacfwd of jax.jacfwd, ...) is refused: the derivative of each event "
    "time (a contact onset, a ball engagement) holds its first-order term only, so second "
    "derivatives would be wrong. Take differences of first derivatives instead "
    "(docs/gradients.md)."
)


def differentiable_once(tree):
    """``tree``, whose floating arrays may be differentiated once but not twice. The first
    derivative (forward or reverse mode, under `jax.vmap` too) passes their tangents as they
    are and puts their values through `_refuse_derivative`, which only a second
    differentiation of the same values differentiates: it raises a `TypeError`
    (`NESTED_DERIVATIVE`)."""
    dynamic, static = eqx.partition(tree, eqx.is_inexact_array)
    return eqx.combine(_once(dynamic), static)


@jax.custom_jvp
def _once(tree):
    return tree


def _once_jvp(primals, tangents):
    (tree,), (tangent,) = primals, tangents
    return _refuse_derivative(tree), tangent  # zero tangents stay symbolic: nothing to carry


_once.defjvp(_once_jvp, symbolic_zeros=True)


@jax.custom_jvp
def _refuse_derivative(tree):
    """``tree``; its derivative raises (`differentiable_once`)."""
    return tree


@_refuse_derivative.defjvp
def _refuse_derivative_jvp(primals, tangents):
    raise TypeError(NESTED_DERIVATIVE)


def start_rules(model, t0, t1, ts=None) -> list:
    """Every rule a run must meet, in `jax.numpy` (inside the compiled solve: `first_broken`):
    the model's at ``t0`` (named by their paths in the model), t1 > t0, and the output times
    ``ts`` finite, increasing and within [t0, t1]."""
    rules = model.violations(jnp, t0)
    rules.append((t1 <= t0, "t1 must be greater than t0 [s]", t1))
    if ts is not None:
        rules.append(
            ((ts[0] < t0) | (ts[-1] > t1) | jnp.any(ts[1:] < ts[:-1]) | jnp.any(~jnp.isfinite(ts)),
             "ts must be finite, increasing and lie within [t0, t1]", ts)
        )
    return rules


def core_start(
    model, t0, t1, dt0, ts, solver, controller, max_steps, extra_stops, fatigue, records, max_onsets, kind
):
    """The core's `Setup` of one solve, its `State` at t0 (both drivers), done at once where a
    rule of the run (`start_rules`) is broken, and which rule (`_checks.Broken`).
    ``dt0``: the first step [s]. Every value the solve is differentiable in passes
    `differentiable_once`."""
    model, t0, t1, dt0, ts, controller = differentiable_once((model, t0, t1, dt0, ts, controller))
    system = MechanismSystem(model)
    setup = Setup(
        system=system,
        n_events=sum(model.event_counts()),
        term=diffrax.ODETerm(system.vector_field),
        solver=for_loop_kind(solver, kind),
        controller=for_restarts(controller),
        stops=_stops(t0, t1, extra_stops),
        t1=t1,
        max_steps=max_steps,
        recorder=Recorder(model, records, fatigue),
    )
    broken = _checks.broken(start_rules(model, t0, t1, ts))
    y0 = jnp.concatenate([model.q0, model.qd0])
    return setup, initial_state(setup, t0, y0, dt0, max_onsets, broken.index >= 0), broken


@eqx.filter_jit
def _simulate(
    model, t0, t1, dt0, ts, solver, controller, max_steps, extra_stops, fatigue, records, sizes, progress,
    kind,
):
    max_segments, segment_steps, block, max_onsets = sizes
    setup, state, broken = core_start(
        model, t0, t1, dt0, ts, solver, controller, max_steps, extra_stops, fatigue, records, max_onsets,
        kind,
    )
    plan = SegmentPlan(setup, padded_times(ts, block), t0, segment_steps, block, progress, kind)
    final, used = run_segments(plan, state, max_segments)
    x = final.state
    result = RESULTS.where(x.done, x.result, RESULTS.max_segments_reached)
    sol = solution(
        setup.recorder, ts, setup.stops, t0, x, result,
        functools.partial(output_rows, final, jax.tree_util.tree_structure(state.states)),
        final.written, final.written // block * block, used,  # full blocks: evaluated
    )
    return sol, broken


def solution(recorder, ts, stops, t0, x, result, rows, written, full, n_segments) -> Solution:
    """The `Solution` (`Recorder.solution`) of a run that ended in state ``x`` (`solve.State`)
    with ``result``: its records, and the outputs at every output time (`Recorder.outputs`),
    evaluated from y and the discrete states there in batches of `OUTPUT_BATCH` times
    (vmapped): NaN at the times after the first ``written`` (the run did not reach them).

    ``rows(start, size, in_blocks)`` gives the rows of those times (`_segments.output_rows`). A
    batch within the first ``full`` (in a vmapped run, for every member) reads them from the full
    blocks as they are: every batch of a successful run but the last one or two. Any other merges
    the pending block and puts the rows the run did not reach at q0, qd0 and zero states, so
    that no NaN enters a derivative (their outputs become NaN). Each batch is written in place into
    the outputs; the last one ends at T and so overlaps its predecessor, whose rows it evaluates
    again, identically (no remainder to evaluate and concatenate apart)."""
    model = recorder.model
    T = ts.shape[0]
    batch = min(OUTPUT_BATCH, T)
    index = jnp.arange(batch)

    def at(t, y, states):
        return recorder.outputs(t, y, states)  # outputs at one time

    def at_rest(reached, y, states):
        start = jnp.concatenate([model.q0, model.qd0])
        keep = lambda x: _where_rows(reached, x, jnp.zeros((), x.dtype))  # noqa: E731
        return _where_rows(reached, y, start), jax.tree_util.tree_map(keep, states)

    @jax.jit  # traced once for both the shapes below and the loop
    def evaluate(start):
        t = jax.lax.dynamic_slice_in_dim(ts, start, batch)
        reached = start + index < written
        row = jax.lax.cond(
            eqxi.unvmap_all(start + batch <= full),
            lambda: rows(start, batch, True),
            lambda: at_rest(reached, *rows(start, batch)),
        )
        values = jax.vmap(at)(t, *row)
        values = jax.tree_util.tree_map(lambda x: _where_rows(reached, x, jnp.nan), values)
        return {**values, "states": row[1]}  # states not reached: zero (`at_rest`)

    shapes = jax.eval_shape(evaluate, jax.ShapeDtypeStruct((), jnp.int32))
    outputs = jax.tree_util.tree_map(lambda s: jnp.zeros((T,) + s.shape[1:], s.dtype), shapes)

    def body(i, outputs):
        start = jnp.minimum(i * batch, T - batch).astype(jnp.int32)
        put = lambda buffer, x: jax.lax.dynamic_update_slice_in_dim(buffer, x, start, 0)
        return jax.tree_util.tree_map(put, outputs, evaluate(start))

    outputs = jax.lax.fori_loop(0, -(-T // batch), body, outputs)
    return recorder.solution(x, outputs, ts, stops, t0, result, n_segments)


def simulate_one_loop(
    model: Mechanism,
    t1: float,
    *,
    solver: diffrax.AbstractSolver | None = None,
    stepsize_controller: diffrax.AbstractStepSizeController | None = None,
    max_steps: int = 1_000_000,
    throw: bool = True,
    options: SolveOptions | None = None,
):
    """Integrate Eq. 36 from ``options.t0`` (default 0) to ``t1`` [s] in one while loop
    (`solve.run_one_loop`: a vmapped batch runs as one loop, the faster on accelerators) and
    return the `Solution` with what the metrics and the life read (its records), and outputs at
    two times only: t0 and the time reached. It integrates the same equations with the same
    solver, controller and event rules as `simulate` and takes the same steps, so its metrics
    agree with `simulate`'s to the solver's accuracy.

    Args:
        model: a `Mechanism`; starts from ``model.q0, qd0``.
        t1: final time [s], > t0.
        solver, stepsize_controller, max_steps, throw: as in `simulate`.
        options: `SolveOptions`; its ``t0``, ``dt0``, ``window_edges``, ``fatigue``,
            ``records`` and ``max_onsets`` apply (the one loop has no segments).

    Forward-mode derivatives (`jax.jvp`, `jax.jacfwd`, also under `jax.vmap`) agree with
    `simulate`'s; reverse mode raises (use `simulate`).
    """
    a = solve_arguments("simulate_one_loop", model, t1, solver, stepsize_controller, max_steps, options)
    records = a.options.records
    stops = window_stops(a.options.window_edges, a.model.window_start, record_edges(records))
    fatigue = a.options.fatigue is not False
    sol, broken = _one_loop(
        a.model, a.t0, a.t1, a.dt0, a.solver, a.controller, jnp.asarray(max_steps), stops, fatigue,
        records, a.max_onsets,
    )
    sol = raise_on_failure(sol, a.t1, broken, ROOT_STEPS) if throw else sol
    warn_if_drifting(sol, a.model)
    return sol


@eqx.filter_jit
def _one_loop(model, t0, t1, dt0, solver, controller, max_steps, extra_stops, fatigue, records, max_onsets):
    setup, state, broken = core_start(
        model, t0, t1, dt0, None, solver, controller, max_steps, extra_stops, fatigue, records, max_onsets,
        "lax",
    )
    final = run_one_loop(
        setup, state,
        "simulate_one_loop supports forward mode (jax.jvp, jax.jacfwd) only: use simulate for reverse mode.",
    )  # fmt: skip
    ends = jax.tree_util.tree_map(lambda a, b: jnp.stack([a, b]), (state.y, state.states), (final.y, final.states))
    rows = lambda start, size, in_blocks=False: jax.tree_util.tree_map(  # noqa: E731
        lambda x: jax.lax.dynamic_slice_in_dim(x, start, size), ends
    )
    sol = solution(
        setup.recorder, jnp.stack([t0, final.t]), setup.stops, t0, final, final.result, rows, 2, 2,
        jnp.asarray(1),
    )
    return sol, broken


def _where_rows(rows, x, y):
    """x in the ``rows`` (R,) where true, else y (x: (R, ...))."""
    return jnp.where(rows.reshape(rows.shape + (1,) * (x.ndim - 1)), x, y)


def warn_if_drifting(sol: Solution, model) -> None:
    """Warn (`DriftWarning`) where ``sol.max_drift`` exceeds ``model.drift_bound()``; nothing
    where either is traced (under your own transformations: read ``sol.max_drift``)."""
    plays = [p for f in model.forces if (p := f.play()) is not None]
    if not is_concrete(sol.max_drift, model.q0, *plays):
        return
    drift, bound = float(sol.max_drift), model.drift_bound()
    if drift > bound:
        warnings.warn(
            f"The joints drifted by up to {drift:.3g} m (max |Phi|, sol.max_drift), beyond the "
            f"{bound:.3g} m this model allows (Mechanism.drift_bound): the solver met its "
            "tolerance, the joints did not. Tighten the tolerances, e.g. "
            "stepsize_controller=jaxbearing.default_controller(rtol=1e-8, atol=1e-10), and check "
            "the metrics with jaxbearing.metrics.converged.",
            DriftWarning,
            stacklevel=3,
        )

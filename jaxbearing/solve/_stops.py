"""Where steps end (the stops: the model's window start, the window edges, t1), the output block
of a segment, and the solver and controller settings that depend on the adjoint and the
controller."""

from __future__ import annotations

import diffrax
import equinox as eqx
import jax.numpy as jnp
import optimistix as optx

# what a root finder made by `diffrax.with_stepsize_controller_tols` holds in place of its tolerances
_FROM_CONTROLLER = diffrax.with_stepsize_controller_tols(optx.Chord)().rtol
OUTPUT_BLOCK = 64  # output times a segment evaluates and writes together (`default_output_block`)

def stops(t0, t1, extra):
    """The times at which steps end, increasing: the model's window start and the window edges
    (``extra``) inside (t0, t1), and t1. A static count: the times outside (t0, t1), and a
    time equal to its predecessor, move to t1, where the run finishes."""
    extra = jnp.where((extra > t0) & (extra < t1), extra, t1)
    times = jnp.sort(jnp.concatenate([extra, t1[None]]))
    repeated = jnp.concatenate([jnp.zeros(1, bool), times[1:] == times[:-1]])
    return jnp.sort(jnp.where(repeated, t1, times))


def default_output_block(ts) -> int:
    """Output times a segment evaluates and writes together: `OUTPUT_BLOCK`, or all of ``ts``
    when fewer."""
    return min(OUTPUT_BLOCK, ts.shape[0])


def with_root_tolerances(solver, controller):
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
        if getattr(solver.root_finder, a) is _FROM_CONTROLLER
    ]
    if not names:
        return solver
    return eqx.tree_at(
        lambda s: tuple(getattr(s.root_finder, a) for a in names),
        solver,
        tuple(getattr(controller, a) for a in names),
    )


def for_loop_kind(solver, kind: str):
    """A Runge–Kutta solver whose stage loop is of the ``kind`` of the solve's loops
    (`_segments.loop_kind`), as `diffeqsolve` chooses it for an unwrapped solver: "lax" for
    forward mode, "bounded" for both modes; diffrax's default (reverse mode) otherwise."""
    runge_kutta = isinstance(solver, diffrax.AbstractRungeKutta)
    if kind == "checkpointed" or not runge_kutta or solver.scan_kind is not None:
        return solver
    return eqx.tree_at(lambda s: s.scan_kind, solver, kind, is_leaf=lambda x: x is None)


class _StepFromEachEnd(diffrax.AbstractStepSizeController):
    """A constant step dt0 (the ``dt0`` that ``init`` gets) from wherever the last step ended.
    diffrax's `ConstantStepSize` steps to a grid over [t0, t1] fixed at the start, which the
    solve leaves at each stop or event (the step after one would be up to 2 dt0 long). Accepts
    every step whose error is finite; a step whose result is not finite (the core makes its
    error infinite) gets a next step of 0, which fails the run at once (`_core.SMALLEST_STEP`)."""

    def wrap(self, direction):
        return self

    def init(self, terms, t0, t1, y0, dt0, args, func, error_order):
        return t0 + dt0, jnp.asarray(dt0)

    def adapt_step_size(self, t0, t1, y0, y1_candidate, args, y_error, error_order, dt0):
        finite = jnp.all(jnp.isfinite(y_error))
        return finite, t1, jnp.where(finite, t1 + dt0, t0), False, dt0, diffrax.RESULTS.successful


def for_restarts(controller):
    """The step-size controller the core runs: ``controller``, a `diffrax.ConstantStepSize` as
    `_StepFromEachEnd`."""
    return _StepFromEachEnd() if isinstance(controller, diffrax.ConstantStepSize) else controller

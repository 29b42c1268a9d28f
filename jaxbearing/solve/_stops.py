"""Where segments end and what each writes: the stops (time-cell ends and window edges), the
output block of a segment, and the solver settings that depend on the adjoint and controller."""

from __future__ import annotations

import diffrax
import equinox as eqx
import jax.numpy as jnp
import optimistix as optx

# what a root finder made by `diffrax.with_stepsize_controller_tols` holds in place of its tolerances
_FROM_CONTROLLER = diffrax.with_stepsize_controller_tols(optx.Chord)().rtol
OUTPUT_BLOCK = 64  # output times a segment evaluates and writes together (`default_output_block`)

def _stops(t0, t1, time_cells, extra):
    """Times at which segments end, increasing: the ends of the ``time_cells`` equal cells of
    [t0, t1] and the ``extra`` times inside (t0, t1). A static count: the extra times outside,
    and a stop equal to its predecessor, move to t1, where the loop finishes."""
    cells = jnp.linspace(t0, t1, time_cells + 1)[1:].at[-1].set(t1)
    extra = jnp.where((extra > t0) & (extra < t1), extra, t1)
    stops = jnp.sort(jnp.concatenate([cells, extra]))
    repeated = jnp.concatenate([jnp.zeros(1, bool), stops[1:] == stops[:-1]])
    return jnp.sort(jnp.where(repeated, t1, stops))


def default_output_block(ts) -> int:
    """Output times a segment evaluates and writes together: `OUTPUT_BLOCK`, or all of ``ts``
    when fewer."""
    return min(OUTPUT_BLOCK, ts.shape[0])


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
        if getattr(solver.root_finder, a) is _FROM_CONTROLLER
    ]
    if not names:
        return solver
    return eqx.tree_at(
        lambda s: tuple(getattr(s.root_finder, a) for a in names),
        solver,
        tuple(getattr(controller, a) for a in names),
    )


def _for_adjoint(solver, adjoint):
    """A Runge–Kutta solver whose stage loop forward mode can differentiate ("lax"), as
    `diffeqsolve` chooses it for an unwrapped solver under `diffrax.ForwardMode`."""
    runge_kutta = isinstance(solver, diffrax.AbstractRungeKutta)
    if not isinstance(adjoint, diffrax.ForwardMode) or not runge_kutta or solver.scan_kind is not None:
        return solver
    return eqx.tree_at(lambda s: s.scan_kind, solver, "lax", is_leaf=lambda x: x is None)

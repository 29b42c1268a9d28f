"""`simulate_one_loop`: the solve as one `lax.while_loop` of the integrator core
(`_core.advance`), for large batches on accelerators.

`simulate` repeats the same core in a `lax.scan` of segments, which reverse mode needs and which
writes the output times. Here a vmapped batch runs as one loop whose body XLA fuses into few
kernels: every iteration each member takes its own step or root-finder step, with selects
instead of branches (docs/platforms.md). It integrates the same equations with the same solver,
controller and event rules as `simulate` and takes the same steps, so its metrics agree with
`simulate`'s to the solver's accuracy. It keeps no output times (the `Solution` has two: t0 and
the time reached). It is differentiable in forward mode (`jax.jvp`, `jax.jacfwd`, also under
`jax.vmap`: batched sensitivities), each event time carrying the tangent of the implicit
function theorem; reverse mode raises (a while loop): use `simulate` there.
"""

from __future__ import annotations

import diffrax
import equinox as eqx
import equinox.internal as eqxi
import jax
import jax.numpy as jnp

from .. import _checks
from ..multibody.mechanism import Mechanism
from ..solution import raise_on_failure, warn_if_drifting
from ._core import ROOT_STEPS, advance, perturbed
from ._options import SolveOptions, record_edges
from ._simulate import core_start, solution, solve_arguments


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
    """Integrate Eq. 36 from ``options.t0`` (default 0) to ``t1`` [s] in one while loop (module
    docstring) and return the `Solution` with what the metrics and the life read
    (``segments``, ``fatigue``, ``contacts``), and outputs at two times only: t0 and the time
    reached.

    Args:
        model: a `Mechanism`; starts from ``model.q0, qd0``.
        t1: final time [s], > t0.
        solver, stepsize_controller, max_steps, throw: as in `simulate`.
        options: `SolveOptions`; its ``t0``, ``dt0``, ``window_edges``, ``fatigue`` and
            ``max_onsets`` apply (the one loop has no segments).

    Forward-mode derivatives (`jax.jvp`, `jax.jacfwd`) agree with `simulate`'s; reverse mode
    raises (use `simulate`).
    """
    a = solve_arguments("simulate_one_loop", model, t1, solver, stepsize_controller, max_steps, options)
    records = a.options.records
    stops = _checks.window_stops(a.options.window_edges, a.model.window_start, record_edges(records))
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
    final = jax.lax.while_loop(lambda x: ~x.done, lambda x: advance(setup, x)[0], perturbed(state))
    final = eqxi.nondifferentiable_backward(
        final, msg="simulate_one_loop supports forward mode (jax.jvp, jax.jacfwd) only: use simulate for reverse mode."
    )
    fields = ("y", "approach", "engaged")  # the rows an output time reads (`_simulate.solution`)
    ends = tuple(jnp.stack([getattr(state, f), getattr(final, f)]) for f in fields)
    rows = lambda start, size, in_blocks=False: tuple(  # noqa: E731
        jax.lax.dynamic_slice_in_dim(x, start, size) for x in ends
    )
    sol = solution(
        setup.recorder, jnp.stack([t0, final.t]), setup.stops, t0, final, final.result, rows, 2, 2,
        jnp.asarray(1),
    )
    return sol, broken

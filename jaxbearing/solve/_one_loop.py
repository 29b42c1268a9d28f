"""The solve as one `lax.while_loop` of the integrator core (`_core.advance`), for large
batches on accelerators: a vmapped batch runs as one loop whose body XLA fuses into few
kernels, every iteration each member taking its own step or root-finder step, with selects
instead of branches (docs/platforms.md). It takes the same steps as the segments (`_segments`)
and keeps no output times. Forward mode only: each event time carries the tangent of the
implicit function theorem; reverse mode raises (a while loop)."""

from __future__ import annotations

import equinox.internal as eqxi
import jax

from ._core import Setup, State, advance, perturbed


def run_one_loop(setup: Setup, state: State, message: str) -> State:
    """The core's final state from ``state``, iterating until done in one while loop; reverse
    mode raises ``message``."""
    final = jax.lax.while_loop(lambda x: ~x.done, lambda x: advance(setup, x)[0], perturbed(state))
    return eqxi.nondifferentiable_backward(final, msg=message)

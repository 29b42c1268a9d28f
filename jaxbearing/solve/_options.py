"""`SolveOptions`: what `simulate` needs besides the model, the span and diffrax's objects."""

from __future__ import annotations

import equinox as eqx


class SolveOptions(eqx.Module):
    """Options of a solve (`jaxbearing.simulate`, `jaxbearing.simulate_one_loop`,
    `jaxbearing.sweep`). Every default follows from the model and the span; most runs need none.

    Fields:
        t0: start time [s]; ``model.q0, qd0`` must satisfy the joints there (default 0).
        window_edges: further times [s] at which the solve stops, so that `jaxbearing.metrics`
            and `jaxbearing.life` can use them as window edges (t0, `WINDOW_START` and t1
            always are). A tuple: its length is part of the compiled solve.
        fatigue: record `Solution.fatigue`, the integrals the bearing's life reads
            (`jaxbearing.life`); False: ``sol.fatigue`` is None and the life functions refuse
            the solution. None (the default): True for a single run; in `jaxbearing.sweep`,
            only where a metric reads them.
        max_segments: segments allowed beyond the stops (each contact onset and separation,
            each engagement and release of a paper-force ball, and each pause starts one); the
            run fails if it needs more. None: `default_max_segments`.
        segment_steps: steps after which a segment pauses and the next iteration of the segment
            loop resumes it with the step-size controller's state (the same steps as without
            the pause). Under `jax.vmap` a member that reached an event waits for the others at
            most this many steps; reverse mode stores every step of a segment, so its memory
            grows with it. None: `SEGMENT_STEPS`, at most ``max_steps``.
        time_cells: equal intervals of [t0, t1] at whose ends segments also stop, which keeps
            the members of a vmapped batch aligned in time; 1 for none.
        output_block: output times a segment evaluates and writes together (None:
            `default_output_block`); any value gives the same outputs.
    """

    t0: float = 0.0
    window_edges: tuple = eqx.field(default=(), static=True)
    fatigue: bool | None = eqx.field(default=None, static=True)
    max_segments: int | None = eqx.field(default=None, static=True)
    segment_steps: int | None = eqx.field(default=None, static=True)
    time_cells: int = eqx.field(default=64, static=True)
    output_block: int | None = eqx.field(default=None, static=True)

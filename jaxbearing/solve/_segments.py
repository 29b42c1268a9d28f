"""`simulate`'s driver of the core (`_core.advance`): a `lax.scan` over segments of
``segment_steps`` iterations, each an `eqxi.while_loop` that diffrax's adjoints differentiate
(reverse mode stores every iteration of a segment, so the backward pass replays nothing), and
the output times each segment passes, evaluated from the steps it recorded.

A segment is only a pause: the core's state carries everything on (the solver's and the
controller's state, an event being located), so a run takes the same steps however it is cut.
Under `jax.vmap` every member runs its own steps in each segment; once every member is done the
remaining slots are segments of no iterations (`slot`).
"""

from __future__ import annotations

from typing import NamedTuple

import diffrax
import equinox.internal as eqxi
import jax
import jax.numpy as jnp

from ._core import Row, Setup, State, _interpolation, _where_rows, advance, perturbed
from ._progress import report


class Carry(NamedTuple):
    """State of the segment loop between two segments."""

    state: State
    # at the output times: (y, the leaves of the discrete states in force, a list), in blocks of
    # ``block`` times, each (n_blocks, block, ...): output r is row [r // block, r % block]
    outputs: tuple
    pending: tuple  # the rows of the block that holds time ``written`` (block, ...): written to
    # ``outputs`` when that block is full (`output_rows` reads the last one here)
    written: jax.Array  # output times evaluated so far: the first ``written`` of ``ts``
    reported: jax.Array  # progress reported so far (`_progress.report`)


class SegmentPlan(NamedTuple):
    """What every segment of one solve shares."""

    core: Setup
    ts: jax.Array  # (n_blocks * block,) output times [s], padded with +inf (`padded_times`)
    t0: jax.Array  # [s]
    segment_steps: int  # iterations of a segment (the rows it records at most)
    block: int  # output times evaluated and written together
    progress: jax.Array | None  # the progress label's key (`_progress.label_key`), or None
    kind: str  # the kind of `eqxi.while_loop` the adjoint differentiates (`loop_kind`)


def loop_kind(adjoint) -> str:
    """The kind of `eqxi.while_loop` that ``adjoint`` differentiates, as diffrax picks it for its
    own loops: "checkpointed" (reverse mode) for `diffrax.RecursiveCheckpointAdjoint`, "bounded"
    (both modes) for `diffrax.DirectAdjoint`, "lax" (forward mode) for the others."""
    if isinstance(adjoint, diffrax.RecursiveCheckpointAdjoint):
        return "checkpointed"
    return "bounded" if isinstance(adjoint, diffrax.DirectAdjoint) else "lax"


def padded_times(ts, block: int) -> jax.Array:
    """The output times ``ts`` padded with +inf to a whole number of blocks of ``block``."""
    return jnp.concatenate([ts, jnp.full(-ts.shape[0] % block, jnp.inf, ts.dtype)])


def initial_carry(d: SegmentPlan, state: State) -> Carry:
    """The carry before the first segment: no outputs written."""
    blocks = d.ts.shape[0] // d.block

    def empty(*shape):
        zeros = lambda a: jnp.zeros(shape + jnp.shape(a), jnp.result_type(a))  # noqa: E731
        return jnp.full(shape + state.y.shape, jnp.nan), [zeros(a) for a in _leaves(state.states)]

    reported = report(d.progress, state.t, d.t0, d.core.t1, jnp.asarray(-1.0))
    return Carry(state, empty(blocks, d.block), empty(d.block), jnp.asarray(0), reported)


def _leaves(states) -> list:
    """The arrays of the discrete ``states``, as the buffers of `eqxi.while_loop` hold them:
    a list (its buffers cannot hold an empty tuple, which a state may contain)."""
    return jax.tree_util.tree_leaves(states)


def _empty_rows(d: SegmentPlan, x: State) -> Row:
    """A segment's record of its steps before it starts: starts +inf (none recorded); the
    states as their leaves (`_leaves`)."""
    rows = lambda a: jnp.zeros((d.segment_steps,) + jnp.shape(a), jnp.result_type(a))  # noqa: E731
    t = jnp.full(d.segment_steps, jnp.inf)
    return Row(
        recorded=rows(False),
        start=t,
        end=t,
        step_end=t,
        dense=jax.tree_util.tree_map(rows, x.step_dense),
        states=[rows(a) for a in _leaves(x.states)],
    )


def segment(d: SegmentPlan, c: Carry):
    """``segment_steps`` iterations of the core, and the output times they passed."""
    x0 = c.state

    def more(loop):
        i, x, _, _ = loop
        return ~x.done & (i < d.segment_steps)

    def body(loop):
        i, x, rows, n = loop
        x, row = advance(d.core, x)
        row = row._replace(states=_leaves(row.states))
        write = lambda buffer, v: buffer.at[n].set(v, pred=row.recorded)  # noqa: E731
        # a leaf of the rows as `eqxi.while_loop` hands them to the body: a buffer or an array
        rows = jax.tree_util.tree_map(write, rows, row, is_leaf=lambda b: hasattr(b, "at"))
        return i + 1, x, rows, n + row.recorded

    _, x, rows, n = eqxi.while_loop(
        more,
        body,
        (jnp.asarray(0), *perturbed((x0, _empty_rows(d, x0))), jnp.asarray(0)),
        max_steps=d.segment_steps,
        buffers=lambda loop: loop[2],
        kind=d.kind,
        checkpoints=d.segment_steps if d.kind == "checkpointed" else None,
    )
    outputs, pending, written = _write_outputs(d, c, rows, n, x.t, x.done)
    reported = report(d.progress, x.t, d.t0, d.core.t1, c.reported)
    return Carry(x, outputs, pending, written, reported)


def slot(d: SegmentPlan, c: Carry, index):
    """One slot of the segment loop: `segment` (once the run is done, under `jax.vmap` every
    member, one of no iterations), and whether the slot ran. Not a `lax.cond` around the
    segment: reverse mode traced the segment's backward pass once per branch."""
    del index
    return segment(d, c), ~c.state.done


def _rows_at(d: SegmentPlan, rows: Row, n, times, x0: State):
    """(y, the leaves of the discrete states) at ``times`` [s] from the recorded step that
    starts last at or
    before each (after an event, the step that starts there); ``x0``'s where the segment
    recorded none."""

    def one(t):
        i = jnp.clip(jnp.searchsorted(rows.start, t, side="right") - 1, 0, d.segment_steps - 1)
        row = jax.tree_util.tree_map(lambda a: a[i], rows)
        y = _interpolation(d.core, row.start, row.step_end, row.dense).evaluate(t)
        return y, row.states

    values = jax.vmap(one)(times)
    start = (x0.y, _leaves(x0.states))
    return jax.tree_util.tree_map(lambda v, s: jnp.where(n > 0, v, s), values, start)


def _write_outputs(d: SegmentPlan, c: Carry, recorded: Row, n, t_end, through_end):
    """(outputs, pending, written) with this segment's output times evaluated from its recorded
    steps: those in [start, t_end), and t_end as well where the run ends (``through_end``), so
    that each time is evaluated exactly once, by the last segment that starts at or before it.

    A loop over the blocks that hold these times: a block's times are evaluated at once, and a
    block that is then full is written to ``outputs`` whole, in one update in place; the last
    one waits in ``pending`` for the next segment's rows. So each block is written once and
    never read, as `eqxi.while_loop`'s buffers require for reverse mode."""
    ts, block, x0 = d.ts, d.block, c.state
    rows = jnp.arange(block)
    start = c.written // block
    mine = lambda t: ~x0.done & jnp.where(through_end, t <= t_end, t < t_end)  # noqa: E731

    def more(carry):
        first = c.written + carry[1]
        return (first < ts.shape[0]) & mine(ts[jnp.minimum(first, ts.shape[0] - 1)])

    def body(carry):
        i, count, pending, outputs = carry
        j = start + i
        times = jax.lax.dynamic_slice(ts, (j * block,), (block,))
        ours = (j * block + rows >= c.written) & mine(times)
        values = _rows_at(d, recorded, n, jnp.clip(times, x0.t, t_end), x0)
        # rows before ours (in the first block) were evaluated by earlier segments
        pending = jax.tree_util.tree_map(lambda x, old: _where_rows(ours, x, old), values, pending)
        count = count + jnp.sum(ours)
        full = (j + 1) * block <= c.written + count
        # a leaf of the outputs as `eqxi.while_loop` hands them to the body: a buffer or an array
        outputs = jax.tree_util.tree_map(
            lambda b, x: b.at[j].set(x, pred=full), outputs, pending, is_leaf=lambda b: hasattr(b, "at")
        )
        return i + 1, count, pending, outputs

    _, count, pending, outputs = eqxi.while_loop(
        more,
        body,
        (jnp.asarray(0), jnp.asarray(0), c.pending, c.outputs),
        max_steps=c.outputs[0].shape[0],  # the blocks
        buffers=lambda carry: carry[3],
        kind=d.kind,
    )
    return outputs, pending, c.written + count


def run_segments(d: SegmentPlan, state: State, max_segments: int):
    """The segment loop from ``state``: ``max_segments`` slots (`slot`), a `lax.scan`; the
    final `Carry` and how many segments ran."""
    final, used = jax.lax.scan(
        lambda c, i: slot(d, c, i), perturbed(initial_carry(d, state)), jnp.arange(max_segments)
    )
    return final, jnp.sum(used)


def output_rows(c: Carry, structure, start, size: int, in_blocks: bool = False) -> tuple:
    """Rows [start, start + size) of the outputs after the run, one an output time, as (y,
    discrete states of ``structure``, their treedef): from the blocks, and from the pending
    block for the times it holds. ``in_blocks``: the rows lie in the full blocks (before
    ``written // block * block``), so the blocks alone hold them."""
    block = c.pending[0].shape[0]  # the pending block's y
    index = start + jnp.arange(size)

    def rows(blocks, pending):
        flat = blocks.reshape((blocks.shape[0] * block,) + blocks.shape[2:])
        x = jax.lax.dynamic_slice_in_dim(flat, start, size)
        if in_blocks:
            return x
        return _where_rows(index // block == c.written // block, pending[index % block], x)

    y, leaves = jax.tree_util.tree_map(rows, c.outputs, c.pending)
    return y, jax.tree_util.tree_unflatten(structure, leaves)

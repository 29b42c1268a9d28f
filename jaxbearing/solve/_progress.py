"""The progress bar of a solve: one tqdm bar per label over the whole span, across segments.

The label enters the compiled solve as an integer key (`label_key`), a value like the span, so
that a run under another label compiles nothing."""

from __future__ import annotations

import equinox as eqx
import equinox.internal as eqxi
import diffrax
import jax
import jax.numpy as jnp


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
    label: jax.Array  # int, the label's `label_key`
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


_LABELS: list = []  # the labels seen in this process; a label's key is its index
_BARS: dict = {}  # label -> the tqdm bar of the run in progress under that label


def label_key(label: str) -> jax.Array:
    """The integer key that stands for ``label`` in the compiled solve."""
    if label not in _LABELS:
        _LABELS.append(label)
    return jnp.asarray(_LABELS.index(label))


def _advance(key, fraction, span):
    """Host side of `_Progress`: fraction 0 opens a bar for the label of ``key`` (closing an
    older one), a larger fraction moves it forward, 1 closes it. The bar counts simulated
    seconds of the span [s]."""
    from tqdm.auto import tqdm

    label, fraction, span = _LABELS[int(key)], float(fraction), float(span)
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

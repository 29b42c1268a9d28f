"""The progress bar of a solve: one tqdm bar per label over the whole span, across segments.

The label enters the compiled solve as an integer key (`label_key`), a value like the span, so
that a run under another label compiles nothing."""

from __future__ import annotations

import importlib.util

import equinox.internal as eqxi
import jax
import jax.numpy as jnp


EVERY = 0.02  # fraction of the span between two reports to the host


def report(label, t, t0, t1, reported):
    """Tell the host (`_advance`) the fraction of [t0, t1] reached at ``t`` [s] (under vmap, by
    the slowest member) when it has crossed a multiple of `EVERY` since ``reported`` (the last
    multiple reported; -1 before the first report, which opens the bar); returns the new one. A
    run so costs about 1 / `EVERY` callbacks however many segments it has. No ``label`` (None):
    no bar, ``reported`` as it is."""
    if label is None:
        return reported
    fraction = -eqxi.unvmap_max(-(t - t0) / (t1 - t0))
    cell = jnp.floor(fraction / EVERY)
    span = eqxi.unvmap_max(t1 - t0)

    def tell():
        jax.debug.callback(_advance, label, fraction, span)
        return cell

    reported = eqxi.unvmap_max(reported)
    return jax.lax.cond(eqxi.nonbatchable(cell > reported), tell, lambda: reported)


_LABELS: list = []  # the labels seen in this process; a label's key is its index
_BARS: dict = {}  # label -> the tqdm bar of the run in progress under that label


def label_key(label: str) -> jax.Array:
    """The integer key that stands for ``label`` in the compiled solve."""
    if label not in _LABELS:
        _LABELS.append(label)
    return jnp.asarray(_LABELS.index(label))


def bar_class():
    """tqdm's bar: the notebook's widget where ipywidgets is installed (`tqdm.auto`), else the
    text bar, which `tqdm.auto` would fall back to after a TqdmWarning ("IProgress not found")."""
    if importlib.util.find_spec("ipywidgets") is None:
        from tqdm.std import tqdm
    else:
        from tqdm.auto import tqdm
    return tqdm


def _advance(key, fraction, span):
    """Host side of `report`: fraction 0 opens a bar for the label of ``key`` (closing an
    older one), a larger fraction moves it forward, 1 closes it. The bar counts simulated
    seconds of the span [s]."""
    tqdm = bar_class()
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

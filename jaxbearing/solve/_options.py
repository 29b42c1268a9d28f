"""`SolveOptions`: what `simulate` needs besides the model, the span and diffrax's objects."""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping

import equinox as eqx

from ..solution import AbstractRecord


def _records(records) -> tuple:
    """``records`` (name -> `metrics.Peak` / `metrics.Mean`) as ((name, record), ...); a
    TypeError or ValueError naming what is wrong."""
    if isinstance(records, tuple) and all(isinstance(r, tuple) and len(r) == 2 for r in records):
        records = dict(records)
    if not isinstance(records, Mapping):
        raise TypeError(
            "records must map names to jaxbearing.metrics.Peak or Mean objects, e.g. "
            f"{{'speed': jb.metrics.Peak(fn)}}; got {type(records).__name__}."
        )
    for name, record in records.items():
        if not isinstance(name, str) or not name:
            raise ValueError(f"records: each name must be a non-empty string; got {name!r}.")
        if not isinstance(record, AbstractRecord):
            raise TypeError(
                f"records[{name!r}] must be a jaxbearing.metrics.Peak or Mean (fn(model, x) -> "
                f"scalar, x a jaxbearing.solution.Instant); got {type(record).__name__}."
            )
    return tuple(records.items())


def record_edges(records) -> tuple:
    """The window edges [s] of ``records`` ((name, record), ...), where the solve stops."""
    return tuple(t for _, record in records for t in record.edges())


class SolveOptions(eqx.Module):
    """Options of a solve (`jaxbearing.simulate`, `jaxbearing.simulate_one_loop`,
    `jaxbearing.sweep`). Every default follows from the model and the span; most runs need none.

    Fields:
        t0: start time [s]; ``model.q0, qd0`` must satisfy the joints there (default 0).
        dt0: the first step [s], finite, > 0 and below t1 - t0; with
            ``stepsize_controller=diffrax.ConstantStepSize()`` (which needs it) every step: each
            step is dt0 long from where the last one ended, cut short at a stop (window edge,
            t1) or an event, and a step whose result is not finite fails the run
            (``dt_min_reached``). A constant step takes (t1 - t0) / dt0 steps or more: raise
            ``max_steps`` and ``max_segments`` where they do not allow them. None (the default):
            1e-7 (t1 - t0), from which an adaptive controller grows the step. Another
            value compiles nothing new.
        window_edges: further times [s] at which the solve stops, so that `jaxbearing.metrics`
            and `jaxbearing.life` can use them as window edges (t0, the model's
            ``window_start`` and t1 always are). A tuple: its length is part of the compiled solve.
        fatigue: record `Solution.fatigue`, the integrals the bearing's life reads
            (`jaxbearing.life`); False: ``sol.fatigue`` is None and the life functions refuse
            the solution. None (the default): True for a single run; in `jaxbearing.sweep`,
            only where a metric reads them.
        max_segments: segments of ``segment_steps`` iterations that `simulate` allows (an
            iteration is a step, accepted or rejected, or a step of an event's root finder);
            the run fails if it needs more. None: `default_max_segments`.
        segment_steps: iterations of a segment: the steps a segment records for the output
            times and, in reverse mode, stores for the backward pass (its memory grows with
            it). Segments are pauses: a run takes the same steps however it is cut. None:
            `SEGMENT_STEPS`.
        output_block: output times a segment evaluates and writes together (None:
            `default_output_block`); any value gives the same outputs.
        max_onsets: contact onsets recorded in `Solution.contacts`; a run with more fails.
            None: `default_max_onsets`.
        records: metrics of your own to record from every accepted step, name ->
            `jaxbearing.metrics.Peak` or `jaxbearing.metrics.Mean`; read as
            ``sol.records[name]`` (or by calling the metric on the solution). The solve stops
            at their windows' edges.
    """

    t0: float = 0.0
    dt0: float | None = None
    window_edges: tuple = eqx.field(default=(), static=True)
    fatigue: bool | None = eqx.field(default=None, static=True)
    max_segments: int | None = eqx.field(default=None, static=True)
    segment_steps: int | None = eqx.field(default=None, static=True)
    output_block: int | None = eqx.field(default=None, static=True)
    max_onsets: int | None = eqx.field(default=None, static=True)
    records: tuple = eqx.field(default=(), static=True, converter=_records)


def declaring(options, metrics) -> SolveOptions:
    """``options`` (None: the defaults) with the metrics of your own among ``metrics`` ((name,
    metric), ...: `metrics.Peak`, `metrics.Mean`) added to its ``records``."""
    options = SolveOptions() if options is None else options
    own = tuple((name, m) for name, m in metrics if isinstance(m, AbstractRecord))
    if not own:
        return options
    return dataclasses.replace(options, records=options.records + own)

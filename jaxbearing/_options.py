"""`SolveOptions`: what `simulate` needs besides the model, the span and diffrax's objects."""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping

import equinox as eqx

from ._checks import is_concrete
from .solution import EDGE_TOLERANCE, AbstractRecord


def _records(records) -> tuple:
    """``records`` (name -> `metrics.Peak` / `metrics.Mean`) as ((name, record), ...); a
    TypeError or ValueError naming what is wrong."""
    if isinstance(records, tuple) and all(isinstance(r, tuple) and len(r) == 2 for r in records):
        names = [name for name, _ in records]
        repeated = sorted({repr(n) for n in names if names.count(n) > 1})
        if repeated:
            raise ValueError(
                f"records: each name must be given once; got {', '.join(repeated)} more than "
                "once (a record's value is read by its name: sol.records[name])."
            )
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


def check_record_windows(records, t1, window_start=None) -> None:
    """A `ValueError` for the first of ``records`` ((name, record), ...) whose window lies
    past the end of a run to ``t1`` [s]: it ends after t1, or starts at or after t1 (a
    ``t_min`` of None starts it at ``window_start``, the model's). Nothing where t1 or
    ``window_start`` is traced: then such a record reads NaN (`metrics.reached`)."""
    if not is_concrete(t1, window_start):
        return
    end = float(t1)
    for name, record in records:
        start = record.t_min if record.t_min is not None else window_start
        if record.t_max is not None and record.t_max > end + EDGE_TOLERANCE:
            what = f"ends at t_max = {record.t_max:.6g} s, after"
        elif start is not None and float(start) >= end - EDGE_TOLERANCE:
            origin = "t_min" if record.t_min is not None else "the model's window_start"
            what = f"starts at {origin} = {float(start):.6g} s, at or after"
        else:
            continue
        raise ValueError(
            f"records[{name!r}]: its window {what} the end of the run, t1 = {end:.6g} s, so "
            "it would have no value: simulate to a later t1, or give the record a window "
            "within the run (its t_min, t_max)."
        )


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

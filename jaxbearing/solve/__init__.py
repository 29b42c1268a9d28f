"""The integrator: diffrax's solvers and step-size controllers driven through events, for any
system that declares itself (`AbstractSystem`) and any record of its steps
(`AbstractRecorder`). It knows no mechanism, element or metric: `jaxbearing.simulate` passes a
mechanism in (`jaxbearing.recorder.MechanismSystem`, `jaxbearing.recorder.Recorder`).

The integrator core (`_core`) is one iteration of the solve: a solver step with step-size
control, or a step of an event's root finder, and the records of each step taken
(`_recording`: columns of peaks and integrals). `run_segments` (`_segments`) repeats it in a
scan of segments, which reverse mode differentiates and which writes the output times;
`run_one_loop` (`_one_loop`) in one while loop, for large batches on accelerators. The stops
are in `_stops`, the progress bar in `_progress`, the result codes in `_results`, the checks of
a solve's arguments in `_arguments`.
"""

from ._arguments import (
    check_count,
    checked_controller,
    checked_dt0,
    checked_solver,
    checked_span,
    checked_tolerances,
    checked_ts,
    window_stops,
)
from ._core import ROOT_STEPS, Setup, State, initial_state, perturbed
from ._one_loop import run_one_loop
from ._progress import label_key
from ._recording import AbstractRecorder, RecordState
from ._results import RESULTS
from ._segments import SegmentPlan, loop_kind, output_rows, padded_times, run_segments
from ._stops import default_output_block, for_loop_kind, for_restarts, stops, with_root_tolerances
from ._system import AbstractSystem

__all__ = [
    "RESULTS",
    "ROOT_STEPS",
    "AbstractRecorder",
    "AbstractSystem",
    "RecordState",
    "SegmentPlan",
    "Setup",
    "State",
    "check_count",
    "checked_controller",
    "checked_dt0",
    "checked_solver",
    "checked_span",
    "checked_tolerances",
    "checked_ts",
    "default_output_block",
    "for_loop_kind",
    "for_restarts",
    "initial_state",
    "label_key",
    "loop_kind",
    "output_rows",
    "padded_times",
    "perturbed",
    "run_one_loop",
    "run_segments",
    "stops",
    "window_stops",
    "with_root_tolerances",
]

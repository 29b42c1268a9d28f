"""Integration of a `Mechanism` with diffrax's solvers and step-size controllers.

The integrator core (`_core`) is one iteration of the solve: a solver step with step-size
control, or a step of an event's root finder, and the records of each step taken
(`_recording`: columns of peaks and integrals, whose meaning the application's recorder
defines, `jaxbearing.recorder`). `simulate` (in `_simulate`) repeats it in a scan of segments
(`_segments`), which reverse mode differentiates and which writes the output times;
`simulate_one_loop` (in `_one_loop`) repeats it in one while loop, for large batches on
accelerators. The stops are in
`_stops`, the progress bar in `_progress`, the result types in `jaxbearing.solution`.
"""

from ..solution import RESULTS, Contacts, FatigueStats, SegmentStats, SimulationError, Solution
from ._one_loop import simulate_one_loop
from ._options import SolveOptions
from ._simulate import (
    default_controller,
    default_max_onsets,
    default_max_segments,
    default_solver,
    kvaerno5,
    simulate,
)
from ._stops import default_output_block

__all__ = [
    "RESULTS",
    "Contacts",
    "FatigueStats",
    "SegmentStats",
    "SimulationError",
    "Solution",
    "SolveOptions",
    "default_controller",
    "default_max_onsets",
    "default_max_segments",
    "default_output_block",
    "default_solver",
    "kvaerno5",
    "simulate",
    "simulate_one_loop",
]

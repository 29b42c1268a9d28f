"""Integration of a `Mechanism` with diffrax: the only place that calls `diffeqsolve`, or steps
diffrax's Tsit5 tableau itself (`simulate_one_loop`).

`simulate` (in `_simulate`) runs the segment loop (`_segment`) between the stops (`_stops`) with
the recording solver (`_recording`), which records the `SegmentStats` the metrics read and the
`FatigueStats` the life reads; the progress bar lives in `_progress`. `simulate_one_loop` (in
`_one_loop`) integrates the same equations in one while loop, for large batches on accelerators. The result types are in
`jaxbearing.solution`.
"""

from ..solution import RESULTS, Contacts, FatigueStats, SegmentStats, SimulationError, Solution
from ._one_loop import simulate_one_loop
from ._options import SolveOptions
from ._simulate import default_controller, default_max_segments, default_solver, kvaerno5, simulate
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
    "default_max_segments",
    "default_output_block",
    "default_solver",
    "kvaerno5",
    "simulate",
    "simulate_one_loop",
]

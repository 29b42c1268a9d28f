"""jaxbearing: a differentiable simulator of planar multibody machines with a rolling ball
bearing joint and impacts (after Xu 2014, Nonlinear Dynamics 78:857–879).

Data flows one way: parameters (`params`, SI units) -> force laws (`laws`) -> mechanism
assembly and equations of motion (`multibody`) -> diffrax solve (`solve`) -> outputs
(`solution`). Ready-made models live in `cases`.

jaxbearing computes in float64 and does not switch JAX's global mode for you: call
``jax.config.update("jax_enable_x64", True)`` first (building a model in float32 raises).
Importing jaxbearing makes two process-wide settings, each with an opt-out
(`jaxbearing._process`): XLA:CPU compiles the solver's loops whole (import jaxbearing before the
process's first JAX computation; not added later), and JAX's persistent compilation cache,
bounded in size, keeps compiled solves for the next process (docs/platforms.md lists each
setting and its opt-out).
"""

from ._process import apply_compilation_cache, apply_loop_kernels

apply_loop_kernels()  # before anything that may start JAX's backends (jaxbearing._process)
apply_compilation_cache()

from . import cases, laws, life, metrics, multibody, paths, report
from .multibody import JournalBearing, Mechanism
from .params import AbstractBearing, BallBearing, Impact, RollerBearing
from ._options import SolveOptions
from .solution import RESULTS, Contacts, DriftWarning, SimulationError, Solution
from .simulation import (
    default_adjoint,
    default_controller,
    default_max_onsets,
    default_max_segments,
    default_solver,
    kvaerno5,
    simulate,
    simulate_one_loop,
)
from ._sweep import sweep
from ._tune import (
    DERIVATIVE_RTOL,
    FORWARD_MAX_PARAMETERS,
    TuneResult,
    TuneWarning,
    derivative_controller,
    sensitivity,
    tune,
)

__version__ = "0.1.0"

__all__ = [
    "DERIVATIVE_RTOL",
    "FORWARD_MAX_PARAMETERS",
    "RESULTS",
    "AbstractBearing",
    "BallBearing",
    "Contacts",
    "DriftWarning",
    "Impact",
    "JournalBearing",
    "Mechanism",
    "RollerBearing",
    "SimulationError",
    "TuneResult",
    "TuneWarning",
    "Solution",
    "SolveOptions",
    "cases",
    "default_adjoint",
    "default_controller",
    "default_max_onsets",
    "default_max_segments",
    "default_solver",
    "derivative_controller",
    "kvaerno5",
    "laws",
    "life",
    "metrics",
    "multibody",
    "paths",
    "report",
    "sensitivity",
    "simulate",
    "simulate_one_loop",
    "sweep",
    "tune",
]

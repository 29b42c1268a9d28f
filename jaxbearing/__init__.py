"""jaxbearing: a differentiable simulator of planar multibody machines with a rolling ball
bearing joint and impacts (after Xu 2014, Nonlinear Dynamics 78:857–879).

Data flows one way: parameters (`params`, SI units) -> force laws (`laws`) -> mechanism
assembly and equations of motion (`multibody`) -> diffrax solve (`solve`) -> outputs
(`solution`). Ready-made models live in `cases`.

jaxbearing computes in float64 and does not switch JAX's global mode for you: call
``jax.config.update("jax_enable_x64", True)`` first (building a model in float32 raises).
On the CPU, call `enable_loop_kernels()` before the first computation: the solver's loops then
run as whole functions, much faster; `enable_memory_reuse()` keeps freed memory in the
process, which saves runs with many output times their page faults (`jaxbearing.compile`).
`enable_entry_elimination()` turns XLA:CPU's fused multiply–adds off for the process; it no
longer makes a run faster.
"""

from . import cases, laws, life, metrics, multibody, paths
from .compile import enable_entry_elimination, enable_loop_kernels, enable_memory_reuse, jit
from .multibody import Mechanism
from .params import BallBearing, Impact
from .solution import RESULTS, Contacts, SimulationError, Solution
from .solve import (
    default_max_segments,
    default_solver,
    kvaerno5,
    simulate,
    simulate_one_loop,
)
from ._sweep import sweep
from ._tune import TuneResult, sensitivity, tune

__version__ = "0.1.0"

__all__ = [
    "RESULTS",
    "BallBearing",
    "Contacts",
    "Impact",
    "Mechanism",
    "SimulationError",
    "TuneResult",
    "Solution",
    "cases",
    "default_max_segments",
    "default_solver",
    "enable_entry_elimination",
    "enable_loop_kernels",
    "enable_memory_reuse",
    "jit",
    "kvaerno5",
    "laws",
    "life",
    "metrics",
    "multibody",
    "paths",
    "sensitivity",
    "simulate",
    "simulate_one_loop",
    "sweep",
    "tune",
]

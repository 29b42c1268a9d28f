"""Whether a run's numbers can be trusted, judged from what the solve already holds (nothing
is solved again): `warn_if_loose` (the step-size control's tolerances) and `warn_if_rattling`
(a bearing that carried no load for most of the metrics' window after the model's start-up
transient). Both warn on the host, where the run is known in Python; under your own
`jax.jit` or `jax.vmap` (and in sweeps) they say nothing. The figures behind their
thresholds: docs/simulate.md, 'Trusting a run'."""

from __future__ import annotations

import warnings

import diffrax
import numpy as np

from ._checks import is_concrete
from .solution import RESULTS, RattleWarning, Solution, ToleranceWarning

# the loosest tolerances at which the peak ball load of the paper's case and of a rotor lies
# within `metrics.CONVERGED_SPREAD` of its converged value (docs/simulate.md)
LOOSEST_RTOL = 1e-6
LOOSEST_ATOL = 1e-8  # [m, rad, m/s, rad/s]
RATTLE_FRACTION = 0.5  # of the output times in the window: no ball loaded
RATTLE_SAMPLES = 20  # output times the window needs for a judgement


def warn_if_loose(controller, stacklevel: int = 3) -> None:
    """Warn (`solution.ToleranceWarning`) where an adaptive ``controller``'s rtol exceeds
    `LOOSEST_RTOL` or its atol `LOOSEST_ATOL`: looser than the tolerances at which the
    metrics were found converged. Nothing for a constant step or traced tolerances."""
    if not isinstance(controller, diffrax.AbstractAdaptiveStepSizeController):
        return
    rtol, atol = getattr(controller, "rtol", None), getattr(controller, "atol", None)
    if rtol is None or atol is None or not is_concrete(rtol, atol):
        return
    rtol, atol = float(rtol), float(atol)
    loose = [
        f"{name} = {value:.3g} (above {limit:g})"
        for name, value, limit in (("rtol", rtol, LOOSEST_RTOL), ("atol", atol, LOOSEST_ATOL))
        if value > limit
    ]
    if loose:
        warnings.warn(
            f"The step-size control is looser than the tolerances at which the metrics were "
            f"found converged: {' and '.join(loose)}. At rtol 1e-4 the paper's peak ball load "
            "was 14 % too high, without a sign in the drift. Tighten it (the default: "
            "jaxbearing.default_controller(rtol=1e-8, atol=1e-10)) or check the metric with "
            "jaxbearing.metrics.converged (docs/simulate.md, 'Trusting a run').",
            ToleranceWarning,
            stacklevel=stacklevel,
        )


def free_fraction(sol: Solution) -> tuple[float, ...] | None:
    """For each bearing joint of ``sol``, the fraction of the output times in the metrics'
    default window, from the model's ``window_start`` (where its start-up transient has ended)
    to t1, at which no ball carries load; None for a model without a ``window_start`` (a
    transient, such as a rotor dropped onto its balls, cannot be told from a rattle), where
    fewer than `RATTLE_SAMPLES` output times lie in the window, or where the run is traced or
    failed."""
    loads = [b.ball_loads for b in sol.bearings]
    known = is_concrete(sol.ts, sol.t_final, sol.t1, sol.window_start, sol.result._value, *loads)
    if sol.window_start is None or not known or sol.result != RESULTS.successful:
        return None
    t = np.asarray(sol.ts)
    window = (t >= float(sol.window_start)) & (t <= float(sol.t1))
    if np.count_nonzero(window) < RATTLE_SAMPLES:
        return None
    return tuple(float(np.mean(np.all(np.asarray(q)[window] <= 0.0, axis=1))) for q in loads)


def warn_if_rattling(sol: Solution, stacklevel: int = 3) -> None:
    """Warn (`solution.RattleWarning`) for each bearing joint of ``sol`` that carried no load
    at more than `RATTLE_FRACTION` of the output times in the metrics' window after the
    model's start-up transient (`free_fraction`): its journal flies across the clearance and
    strikes the balls, and such a rattle is chaotic. Nothing where `free_fraction` cannot
    judge."""
    fractions = free_fraction(sol)
    for b, free in enumerate(fractions or ()):
        if free > RATTLE_FRACTION:
            warnings.warn(
                f"Bearing joint {b} carried no load at {100 * free:.0f} % of the output times "
                "in the metrics' window (after the model's window_start): its journal rattles "
                "in the clearance, striking the balls. Such a rattle is chaotic (a change of "
                "the tolerance, the solver or a parameter's 9th digit gives other impacts), so "
                "its peaks and means are not converged at any tolerance: check them with "
                "jaxbearing.metrics.converged and report their spread, or give the bearing "
                "more damping or load (docs/simulate.md, 'Trusting a run').",
                RattleWarning,
                stacklevel=stacklevel,
            )

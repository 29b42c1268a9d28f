"""`jaxbearing.metrics.converged`: a metric's spread over the solver's tolerances, and whether it
is a result. The paper's peak ball load after its window start is converged; with the bearing
1000x stiffer the same metric moves by tens of per cent between rtol 1e-8 and 1e-10 (the rod's
journal rattles in the clearance, and the rattle is chaotic: docs/simulate.md), so it is not,
and `simulate` says so (`jb.solution.RattleWarning`).

The slow check runs over 0-0.1 s, the warnings over the paper's span, 0-0.2 s, in the compiled
solve of tests/conftest.py's group paper_0.2s (the stiffness is a parameter value).
"""

import warnings

import equinox as eqx
import numpy as np
import pytest

import jaxbearing as jb
from jaxbearing import metrics as M
from jaxbearing import _trust

T1 = 0.1  # [s] the slow check's span
SPAN = 0.2  # [s] the warnings' span


@pytest.mark.slow  # 10 s: two tolerances of two models; the clearance study's quick run calls it by default
def test_the_papers_peak_ball_load_is_converged_and_a_stiff_bearings_is_not():
    paper = jb.cases.xu2014()
    found = M.converged(paper, M.peak_ball_load, T1)
    assert found.rtols == (1e-8, 1e-10) and found.converged
    assert found.spread <= M.CONVERGED_SPREAD
    assert found.spread == pytest.approx(abs(found.values[0] - found.values[1]) / max(found.values))
    sol = jb.simulate(paper, T1)  # the default tolerances are the first
    np.testing.assert_allclose(found.values[0], M.peak_ball_load(sol), rtol=1e-12)

    stiff = eqx.tree_at(lambda m: m.bearing.stiffness, paper, paper.bearing.stiffness * 1000)
    with pytest.warns(jb.solution.RattleWarning, match="Bearing joint 0 carried no load"):
        found = M.converged(stiff, M.peak_ball_load, T1)  # it rattles (issue 71)
    assert not found.converged
    assert found.spread > 10 * M.CONVERGED_SPREAD


def test_bad_arguments_are_refused():
    paper = jb.cases.xu2014()
    with pytest.raises(ValueError, match=r"rtols must hold at least two relative tolerances; got \(1e-08,\)"):
        M.converged(paper, M.peak_ball_load, T1, rtols=(1e-8,))
    with pytest.raises(ValueError, match=r"tolerance must be a relative spread > 0; got 0\.0"):
        M.converged(paper, M.peak_ball_load, T1, tolerance=0.0)
    with pytest.raises(TypeError, match="converged sets the step-size controller itself"):
        M.converged(paper, M.peak_ball_load, T1, stepsize_controller=jb.default_controller())


def test_a_rattling_bearing_warns_and_the_papers_does_not():
    """Issue 71: the paper's case with its bearing 1e4x stiffer flies free of the balls most of
    the time and strikes them chaotically: no tolerance converges its peaks (docs/simulate.md),
    and the default run warns; the paper's own bearing stays loaded and does not."""
    paper = jb.cases.xu2014()
    with warnings.catch_warnings():
        warnings.simplefilter("error", jb.solution.AccuracyWarning)
        sol = jb.simulate(paper, SPAN)
    assert _trust.free_fraction(sol)[0] < 0.1  # the impacts part the rod from the balls briefly
    stiff = eqx.tree_at(lambda m: m.bearing.stiffness, paper, paper.bearing.stiffness * 1e4)
    with pytest.warns(jb.solution.RattleWarning, match=r"Bearing joint 0 carried no load at 9\d % of the output times"):
        sol = jb.simulate(stiff, SPAN)
    assert _trust.free_fraction(sol)[0] > 0.9
    few = jb.simulate(stiff, SPAN, np.linspace(0.0, SPAN, 24))  # 19 output times in the window: too few
    assert _trust.free_fraction(few) is None  # to judge, no warning

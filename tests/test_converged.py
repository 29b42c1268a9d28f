"""`jaxbearing.metrics.converged`: a metric's spread over the solver's tolerances, and whether it
is a result. The paper's peak ball load after its window start is converged; with the bearing
1000x stiffer the same metric moves by tens of per cent between rtol 1e-8 and 1e-10 (the ball
contacts ring far faster than the state's tolerance resolves), so it is not.

Over 0-0.1 s, both cases share one compiled solve (the stiffness is a parameter value).
"""

import equinox as eqx
import numpy as np
import pytest

import jaxbearing as jb
from jaxbearing import metrics as M

T1 = 0.1


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
    found = M.converged(stiff, M.peak_ball_load, T1)
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

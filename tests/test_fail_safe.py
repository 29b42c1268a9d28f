"""A failed or untrustworthy run yields no number (issue 64): the paper's case over 0-0.005 s
(the compiled solve of the group paper_0.005s; its contact, switched on at 0.05 s, does not act
yet), and the same run stopped by its step limit."""

import warnings

import jax
import numpy as np
import pytest

import jaxbearing as jb

M = jb.metrics
T1 = 0.005  # [s]


@pytest.fixture(scope="module")
def model():
    return jb.cases.xu2014()


@pytest.fixture(scope="module")
def short(model):
    return jb.simulate(model, T1, max_steps=20, throw=False)


def test_a_metric_or_life_of_a_run_that_stopped_short_raises(model, short):
    assert short.result == jb.RESULTS.max_steps_reached and float(short.t_final) < T1
    assert float(short.t1) == T1
    for metric in (M.peak_ball_load, M.rms_bearing_force, M.peak_impact_force, M.smooth_peak_ball_load):
        with pytest.raises(jb.SimulationError, match=r"stopped at t_final = .* of t1 = 0\.005 s \(The maximum number of solver steps"):
            metric(short, t_min=None)
    with pytest.raises(jb.SimulationError, match=r"inspected over \[t0, "):
        M.peak_time(short, M.peak_ball_load, t_min=None)
    with pytest.raises(jb.SimulationError, match=r"no result"):
        jb.life.iso_life(short, model, t_min=None)
    own = M.Peak(lambda m, x: jax.numpy.max(x.bearings[0].ball_loads), t_min=0.0)
    stopped = jb.simulate(model, T1, max_steps=20, throw=False, options=jb.SolveOptions(records={"own": own}))
    assert np.isnan(float(stopped.records["own"]))  # read inside the compiled solve: NaN
    # traced (under jit, as in sweeps) the metric is NaN, never a plausible number
    assert np.isnan(float(jax.jit(lambda s: M.peak_ball_load(s, t_min=None))(short)))
    # up to where it stopped, the run is there to inspect
    reached = float(M.peak_ball_load(short, t_min=None, t_max=float(short.t_final)))
    assert np.isfinite(reached) and reached > 0.0


def test_an_element_that_never_acted_peaks_at_zero_at_no_time(model):
    sol = jb.simulate(model, T1)  # the contact is switched on at 0.05 s
    assert float(M.peak_impact_force(sol, t_min=None)) == 0.0
    assert np.isnan(float(M.peak_time(sol, M.peak_impact_force, t_min=None)))
    assert float(M.peak_time(sol, M.peak_ball_load, t_min=None)) > 0.0


def test_a_run_whose_joints_drift_warns(model):
    """At rtol 1e-2 the joints drift by micrometres in 5 ms (the bound: 1 % of the 40 µm
    clearance, 0.4 µm); at the default tolerances by about 1e-13 m, without a warning."""
    loose = jb.default_controller(rtol=1e-2, atol=1e-4)
    with pytest.warns(jb.solution.DriftWarning, match=r"drifted by up to .* beyond the 4e-07 m .*rtol="):
        sol = jb.simulate(model, T1, stepsize_controller=loose)
    assert float(sol.max_drift) > jb.solution.drift_bound(model) == pytest.approx(4e-7)
    sampled = float(np.nanmax(np.asarray(sol.drift)))
    assert float(sol.max_drift) >= sampled  # every accepted step, not only the output times
    with warnings.catch_warnings():
        warnings.simplefilter("error", jb.solution.DriftWarning)
        tight = jb.simulate(model, T1)
    assert float(tight.max_drift) < 1e-3 * jb.solution.drift_bound(model)


def test_the_drift_bound_without_a_bearing_clearance():
    """1e-4 of the largest distance between two bodies' initial positions (the four-bar's)."""
    four_bar = jb.cases.four_bar(jb.cases.skf98205(clearance=0.0))
    xy = np.asarray(four_bar.q0).reshape(-1, 3)[:, :2]
    size = max(np.linalg.norm(a - b) for a in xy for b in xy)
    assert jb.solution.drift_bound(four_bar) == pytest.approx(1e-4 * size, rel=1e-12)

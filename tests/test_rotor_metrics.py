"""The general metrics on a mechanism without impact: `cases.rotor` (a disc in a bearing).

Every standard metric must have a value for it (issue 14: `max_target_displacement` once read
the paper's target coordinate, which a rotor does not have): the bearing metrics are finite and
positive, the impact metrics are 0 (there is no contact, nothing is struck)."""

import numpy as np
import pytest

import jaxbearing as jb

K_B = 9.57e9  # [N/m^1.5]
T1 = 0.06  # [s]
TS = np.linspace(0.0, T1, 3001)


def rotor(clearance=20e-6, window_start=None):
    bearing = jb.BallBearing(clearance, K_B, 200.0, 29.2e-3, 46.6e-3, 8, ball_force="smooth")
    return jb.cases.rotor(bearing, mass=2.0, speed=300.0, eccentricity=2e-5, window_start=window_start)


@pytest.fixture(scope="module")
def solution():
    return jb.simulate(rotor(), T1, TS)


def test_a_new_mechanism_s_metrics_cover_its_span_or_its_own_window(solution):
    """A mechanism without a window start has its metrics over the whole span; one with its
    own window start has them from there: the exact peak |F| against the largest of 20 us
    samples of each window (within 1e-3: the samples miss the peak between them by up to
    f'' h^2 / 8; never above it by more than rounding)."""
    force = np.linalg.norm(np.asarray(solution.bearing_force), axis=1)
    assert solution.window_start is None
    whole = float(jb.metrics.peak_bearing_force(solution))
    assert whole == float(jb.metrics.peak_bearing_force(solution, t_min=None))
    assert force.max() * (1 - 1e-12) <= whole == pytest.approx(force.max(), rel=1e-3)
    own = jb.simulate(rotor(window_start=0.03), T1, TS)
    assert float(own.window_start) == 0.03
    later = float(jb.metrics.peak_bearing_force(own))
    sampled = force[TS >= 0.03].max()
    assert later == float(jb.metrics.peak_bearing_force(own, t_min=0.03))
    assert sampled * (1 - 1e-12) <= later == pytest.approx(sampled, rel=1e-3)
    assert later < whole  # the start-up transient is outside the window


def test_a_rotor_has_no_target(solution):
    assert solution.target is None


@pytest.mark.parametrize("name", sorted(jb.metrics.STANDARD))
def test_every_standard_metric_has_a_value_for_a_rotor(solution, name):
    value = float(jb.metrics.STANDARD[name](solution))
    assert np.isfinite(value)
    if name in ("peak_impact_force", "max_target_displacement"):
        assert value == 0.0
    else:
        assert value > 0.0


def test_smooth_metrics_of_a_rotor(solution):
    assert float(jb.metrics.smooth_peak_impact_force(solution)) == 0.0
    smooth = float(jb.metrics.smooth_peak_bearing_force(solution))
    assert 0.0 < smooth <= float(jb.metrics.peak_bearing_force(solution))


def test_an_explicit_coordinate_still_reads_that_coordinate(solution):
    # the centroid's x: it turns at 2e-5 m about the axis (up to 2 e from its start), and the
    # axis moves within half the 20 um clearance plus the balls' deflection
    x = float(jb.metrics.max_target_displacement(solution, coordinate=0))
    assert 2e-5 < x < 2 * 2e-5 + 20e-6


def test_default_sweep_of_a_rotor_gives_finite_metrics():
    ds = jb.sweep(rotor(), {"bearing.clearance": [20e-6, 30e-6]}, t1=T1, progress=False)
    assert not ds["failed"].any()
    for name in jb.metrics.STANDARD:
        values = ds[name].values
        assert values.shape == (2,) and np.all(np.isfinite(values)), name
    assert np.all(ds["peak_impact_force"].values == 0.0)
    assert np.all(ds["max_target_displacement"].values == 0.0)
    assert np.all(ds["peak_bearing_force"].values > 0.0)

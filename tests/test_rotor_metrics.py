"""The general metrics on a mechanism without impact: `cases.rotor` (a disc in a bearing).

Every standard metric must have a value for it (issue 14: `max_target_displacement` once read
the paper's target coordinate, which a rotor does not have): the bearing metrics are finite and
positive, the impact metrics are 0 (there is no contact, nothing is struck)."""

import numpy as np
import pytest

import jaxbearing as jb

K_B = 9.57e9  # [N/m^1.5]
T1 = 0.06  # [s]: past the default window's start, 0.04 s


def rotor(clearance=20e-6):
    bearing = jb.BallBearing(clearance, K_B, 200.0, 29.2e-3, 46.6e-3, 8, ball_force="smooth")
    return jb.cases.rotor(bearing, mass=2.0, speed=300.0, eccentricity=2e-5)


@pytest.fixture(scope="module")
def solution():
    return jb.simulate(rotor(), T1, np.linspace(0.0, T1, 301))


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

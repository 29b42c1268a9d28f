"""Bad input gets a clear error naming the parameter and what is allowed; failures never hand
back silent NaNs."""

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import pytest

import jaxbearing as jb
from jaxbearing.multibody import GROUND, Body, Driver, Mechanism, Revolute, Translational


def bearing(**kw):
    args = dict(
        clearance=4e-5,
        stiffness=9.57e9,
        damping=300.0,
        inner_race_diameter=29.2e-3,
        outer_race_diameter=46.6e-3,
        n_balls=8,
    )
    args.update(kw)
    return jb.BallBearing(**args)


@pytest.mark.parametrize(
    "make, message",
    [
        (lambda: bearing(clearance=-1e-6), "bearing clearance must be zero or positive"),
        (lambda: bearing(n_balls=2), "n_balls must be an integer of at least 3"),
        (lambda: bearing(stiffness=0.0), "bearing stiffness must be positive"),
        (lambda: bearing(damping=-1.0), "bearing damping must be zero or positive"),
        (lambda: bearing(outer_race_diameter=20e-3), "outer raceway diameter must exceed"),
        (lambda: bearing(cage="free"), "cage must be 'kinematic' or 'constant'"),
        (lambda: bearing(ball_force="linear"), "ball_force must be 'paper' or 'smooth'"),
        (lambda: bearing(exponent=1.0), "exponent must exceed 1"),
        (lambda: jb.Impact(1e10, 0.0), r"restitution must lie in \(0.0, 1.0\]"),
        (lambda: jb.Impact(1e10, 1.2), r"restitution must lie in \(0.0, 1.0\]"),
        (lambda: jb.Impact(-1e10, 0.9), "impact stiffness must be positive"),
        (lambda: jb.Impact(1e10, 0.9, friction=-0.1), "friction coefficient must be zero or positive"),
        (lambda: Body(0.0, 1.0), "body mass must be positive"),
        (lambda: Body(1.0, -1.0), "body moment of inertia must be positive"),
        (lambda: jb.cases.xu2014(clearance=-1e-5), "bearing clearance must be zero or positive"),
        (lambda: jb.cases.xu2014(restitution=1.5), "restitution must lie in"),
        (lambda: jb.cases.xu2014(bearing_damping=-300.0), "bearing damping must be zero or positive"),
    ],
)
def test_constructors_reject_bad_values(make, message):
    with pytest.raises(ValueError, match=message):
        make()


def test_message_names_the_value():
    with pytest.raises(ValueError, match=r"got -1e-06"):
        bearing(clearance=-1e-6)


def test_inconsistent_initial_positions_are_rejected():
    body = Body(1.0, 0.1)
    with pytest.raises(ValueError, match="initial positions q0 violate the joints"):
        Mechanism([body], [Revolute(GROUND, (0.0, 0.0), 0, (-0.5, 0.0))], [0.4, 0.0, 0.0], [0.0] * 3)


def test_inconsistent_initial_velocities_are_rejected():
    body = Body(1.0, 0.1)
    joints = [Revolute(GROUND, (0.0, 0.0), 0, (-0.5, 0.0)), Driver(0, speed=2.0)]
    with pytest.raises(ValueError, match="initial velocities qd0 violate"):
        Mechanism([body], joints, [0.5, 0.0, 0.0], [0.0, 0.0, 0.0])


def test_overconstrained_mechanism_is_rejected():
    with pytest.raises(ValueError, match="over-determine"):
        Mechanism(
            [Body(1.0, 0.1)],
            [Translational(0), Translational(0, line_angle=1.0)],
            [0.0] * 3,
            [0.0] * 3,
        )


@pytest.mark.parametrize("t1", [0.0, -0.1])
def test_simulate_rejects_non_positive_span(t1):
    with pytest.raises(ValueError, match="t1 must be greater than t0"):
        jb.simulate(jb.cases.xu2014(impact=False), t1)


def test_values_changed_after_construction_are_checked_in_simulate():
    """eqx.tree_at bypasses constructors: simulate checks the values again."""
    model = eqx.tree_at(lambda m: m.bearing.clearance, jb.cases.xu2014(impact=False), -1e-5)
    with pytest.raises(Exception, match="bearing clearance must be zero or positive"):
        jb.simulate(model, 1e-3, jnp.linspace(0.0, 1e-3, 3))


def test_traced_bad_values_are_checked_under_vmap():
    model = jb.cases.xu2014(impact=False)

    def run(c):
        m = eqx.tree_at(lambda m: m.bearing.clearance, model, c)
        return jb.simulate(m, 1e-4, jnp.linspace(0.0, 1e-4, 3)).q

    with pytest.raises(Exception, match="bearing clearance must be zero or positive"):
        jax.vmap(run)(jnp.array([4e-5, -1e-5]))


def test_solver_failure_raises_with_time_and_advice():
    model = jb.cases.xu2014(impact=False)
    with pytest.raises(jb.SimulationError, match=r"stopped at t = .* s of t1 = 0.01 s.*max_steps"):
        jb.simulate(model, 0.01, max_steps=50)


def test_solver_failure_without_throw_reports_and_marks_nan():
    model = jb.cases.xu2014(impact=False)
    ts = jnp.linspace(0.0, 0.01, 11)
    sol = jb.simulate(model, 0.01, ts, max_steps=50, throw=False)
    assert sol.result == jb.RESULTS.max_steps_reached
    assert 0.0 < float(sol.t_final) < 0.01
    after = np.asarray(ts) > float(sol.t_final)
    assert np.isnan(np.asarray(sol.q)[after]).all()
    assert np.isnan(np.asarray(sol.ball_loads)[after]).all()
    assert np.isfinite(np.asarray(sol.q)[~after]).all()


def test_too_few_segments_fails_loudly():
    model = jb.cases.xu2014(impact=True)
    with pytest.raises(jb.SimulationError, match="max_segments"):
        jb.simulate(model, 0.1, jnp.linspace(0.0, 0.1, 11), max_segments=3)


def test_float32_mode_is_refused(monkeypatch):
    monkeypatch.setattr(jax.config, "read", lambda name: False)
    with pytest.raises(RuntimeError, match="jax_enable_x64"):
        Body(1.0, 1.0)

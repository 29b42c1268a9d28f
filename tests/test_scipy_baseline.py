"""The SciPy baseline (benchmarks/scipy_baseline.py) against jaxbearing: an independent NumPy
implementation of the paper's case, so agreement cross-checks jaxbearing's equations of motion
(Eq. 36 with Baumgarte terms, Eqs. 9, 12–14, 23, 28–34) and its event handling."""

import importlib.util
import sys
from pathlib import Path

import equinox as eqx
import jax.numpy as jnp
import numpy as np
import pytest

import jaxbearing as jb
from jaxbearing.multibody import CircleContact, ContactState


def _load_baseline():
    path = Path(__file__).resolve().parents[1] / "benchmarks" / "scipy_baseline.py"
    spec = importlib.util.spec_from_file_location("scipy_baseline", path)
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module  # dataclasses look their module up here
    spec.loader.exec_module(module)
    return module


sb = _load_baseline()


VELOCITY_SCALE = np.array([0.5, 0.5, 1.0, 0.5, 0.5, 20.0, 1.0, 1e-3, 1e-3, 1.0, 1e-3, 1e-3])


def _states(params, rng, count):
    """Near-consistent states of the slider–crank (q [m, rad], qd [m/s, rad/s]) with the bearing's
    races off-centre by 15–40 um (against P_d/2 = 20 um: some balls loaded, some not), the
    slider–target circles from 5 um apart to 20 um overlapping and velocities scattered about the
    initial ones by VELOCITY_SCALE; times [s] on both sides of the contact's switch-on at 0.05 s;
    approach speeds [m/s], non-positive ones included."""
    l2, l3 = params.crank_length, params.rod_length
    for _ in range(count):
        theta, direction = rng.uniform(0.0, 2.0 * np.pi, 2)
        phi = np.arcsin(-l2 * np.sin(theta) / l3)
        pin = l2 * np.array([np.cos(theta), np.sin(theta)])
        ecc = rng.uniform(15e-6, 40e-6) * np.array([np.cos(direction), np.sin(direction)])
        rod = pin + ecc + 0.5 * l3 * np.array([np.cos(phi), np.sin(phi)])
        slider = rod[0] + 0.5 * l3 * np.cos(phi)
        target = slider + 0.02 - rng.uniform(-5e-6, 20e-6)
        q = np.array([*(0.5 * pin), theta, *rod, phi, slider, 0.0, 0.0, target, 0.0, 0.0])
        qd = params.qd0 + rng.normal(scale=VELOCITY_SCALE)
        yield rng.uniform(0.03, 0.2), q, qd, rng.uniform(-0.5, 2.5)


def test_equations_of_motion_agree_state_by_state():
    """Accelerations, ball loads and contact force of both implementations at 40 states.

    Both solve the same float64 linear system of Eq. 36 (jaxbearing by Gauss–Jordan elimination
    on the Schur complement, the baseline by LU of the dense augmented matrix, whose condition number is
    about 1.5e3), so they differ by rounding only: measured 1e-15 relative to the largest
    acceleration, 2e-13 N in the ball loads. The bounds (1e-10 relative, 1e-9 N and 1e-9
    relative) leave a wide margin, while any wrong term (a sign, a Baumgarte factor, an arm, the
    cage angle) shows at order 1.
    """
    model = jb.cases.xu2014(impact=True)
    params = sb.Params.from_model(model)
    baseline = sb.SliderCrank(params)
    joint, contact = model.bearings[0], model.contacts[0]

    @eqx.filter_jit
    def reference(t, q, qd, approach):
        # the balls with delta_r > 0 engaged, the contact touching since approach [m/s]
        states = list(model.initial_states(t, q, qd))
        states[model.indices(CircleContact)[0]] = ContactState(approach, jnp.asarray(True))
        return (
            model.accelerations(t, q, qd, tuple(states)),
            joint.ball_loads(t, q, qd, model.q0, model.qd0)[0],
            contact.forces(t, q, qd, approach)[0],
        )

    loaded = touching = 0
    for t, q, qd, approach in _states(params, np.random.default_rng(5), 40):
        qdd = baseline.accelerations(t, q.tolist(), qd.tolist(), approach)
        # (t and approach as arrays: filter_jit would recompile for every Python float)
        qdd_jb, loads_jb, force_jb = map(np.asarray, reference(*map(jnp.asarray, (t, q, qd, approach))))
        np.testing.assert_allclose(qdd, qdd_jb, rtol=0, atol=1e-10 * np.max(np.abs(qdd_jb)))
        loads = baseline.balls(q, qd)[0]
        np.testing.assert_allclose(loads, loads_jb, rtol=1e-9, atol=1e-9)
        force = baseline.contact_force(t, q, qd, approach)
        assert force == pytest.approx(force_jb, rel=1e-9, abs=1e-9)
        loaded += np.sum(loads > 0) > 0
        touching += force > 0
    assert loaded >= 20 and touching >= 10  # the states exercise both force laws


def test_no_impact_start_agrees():
    """0–0.02 s without impact: the start-up rattling of the rod in the bearing clearance.

    Both integrate at rtol 1e-10, atol 1e-12 (jaxbearing Tsit5, SciPy LSODA), so each is within
    about 1e-10 m of the exact solution; measured: positions 6.5e-11 m apart, ball loads 2.2e-3 N
    (a 1e-10 m deflection difference is ~1e-3 N at the Hertz slope 1.5 K_b delta^0.5 of a
    ~1 um deflection). The bounds, 1e-9 m and 0.05 N, keep a 10-20x margin over that; the
    benchmark's own criteria (1e-7 m, 0.5 N) are 100x looser still.
    """
    ts = np.linspace(0.0, 0.02, 201)
    ref = jb.simulate(jb.cases.xu2014(impact=False), 0.02, ts, stepsize_controller=jb.default_controller(rtol=1e-10, atol=1e-12))
    run = sb.simulate(0.02, ts, impact=False, method="LSODA", rtol=1e-10, atol=1e-12)
    pos = sb.POSITIONS
    assert np.max(np.abs(run["q"][:, pos] - np.asarray(ref.q)[:, pos])) < 1e-9
    assert np.max(np.abs(run["ball_loads"] - np.asarray(ref.ball_loads))) < 0.05
    assert np.max(np.abs(run["bearing_force"] - np.asarray(ref.bearing_force))) < 0.05
    assert np.max(np.asarray(ref.ball_loads)) > 500.0  # the rattling is in the span


@pytest.mark.slow  # 8 s; tests/test_one_loop.py compares the one loop with simulate by default
def test_one_loop_start_agrees():
    """`simulate_one_loop` against the independent implementation over the span and with the
    tolerances of `test_no_impact_start_agrees` (so the same bounds: each run within about 1e-10 m
    of the exact solution), at the span's end; the ball engagements are its events here.
    Measured: positions 1.4e-11 m, ball loads 4.8e-5 N apart; 36 stops and events."""
    sol = jb.simulate_one_loop(jb.cases.xu2014(impact=False), 0.02, stepsize_controller=jb.default_controller(rtol=1e-10, atol=1e-12))
    run = sb.simulate(0.02, np.array([0.0, 0.02]), impact=False, method="LSODA", rtol=1e-10, atol=1e-12)
    pos = sb.POSITIONS
    assert np.max(np.abs(run["q"][-1, pos] - np.asarray(sol.q)[-1, pos])) < 1e-9
    assert np.max(np.abs(run["ball_loads"][-1] - np.asarray(sol.ball_loads)[-1])) < 0.05
    assert float(jb.metrics.peak_ball_load(sol, t_min=0.0)) > 500.0  # the rattling is in the span
    assert int(sol.num_events) > 10  # and the loop located ball events in it


@pytest.mark.slow
def test_impact_run_agrees():
    """0–0.1 s with impact, both at rtol 1e-11, atol 1e-13: the six contacts of the first
    revolution, located by solve_ivp's events and by jaxbearing's root finder. Measured over
    0–0.2 s: positions 1.8e-11 m, ball loads 8e-4 N, onset times 3e-11 s, approach speeds
    5e-8 m/s apart; bounds 10-100x above those."""
    ts = np.linspace(0.0, 0.1, 1001)
    model = jb.cases.xu2014(impact=True)
    ref = jb.simulate(model, 0.1, ts, stepsize_controller=jb.default_controller(rtol=1e-11, atol=1e-13), max_steps=1_000_000)
    run = sb.simulate(0.1, ts, impact=True, method="DOP853", rtol=1e-11, atol=1e-13)
    valid = np.asarray(ref.contacts.valid)
    onsets = np.asarray(ref.contacts.time)[valid]
    speeds = np.asarray(ref.contacts.approach_speed)[valid]
    assert run["onset_times"].size == onsets.size == 6
    np.testing.assert_allclose(run["onset_times"], onsets, rtol=0, atol=1e-9)
    # the separations: events like the onsets; the sixth contact lasts past 0.1 s
    ends = np.asarray(ref.contacts.end)[valid]
    assert run["end_times"].size == 5 and np.isnan(ends[5])
    np.testing.assert_allclose(run["end_times"], ends[:5], rtol=0, atol=1e-9)
    np.testing.assert_allclose(run["approach_speeds"], speeds, rtol=0, atol=1e-6)
    pos = sb.POSITIONS
    assert np.max(np.abs(run["q"][:, pos] - np.asarray(ref.q)[:, pos])) < 1e-9
    assert np.max(np.abs(run["ball_loads"] - np.asarray(ref.ball_loads))) < 0.05
    assert np.max(np.abs(run["contact_force"] - np.asarray(ref.contact_force))) < 0.5

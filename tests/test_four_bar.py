"""A mechanism of your own: the crank–rocker four-bar of `cases.four_bar` (ground 0.30 m, crank
0.10 m at 1000 rpm, coupler 0.28 m, rocker 0.25 m, gravity) with the paper's bearing at the
coupler–rocker joint, assembled from a rough guess.

The independent truth is a rigid-pin reaction: position, velocity and acceleration of the
four-bar from its loop closure in closed form (circle intersection, then two 2x2 linear
solves), and the pin forces from the Newton–Euler equations of the coupler and the rocker (a
6x6 linear solve), in NumPy. As the bearing stiffens (no clearance, damped), the simulated
bearing force must converge to the pin force at the coupler–rocker joint.
"""

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import pytest

import jaxbearing as jb
from jaxbearing.cases._four_bar import LENGTHS, MASSES

W = 1000.0 * 2.0 * np.pi / 60.0  # [rad/s] the crank's speed
TURN = 2.0 * np.pi / W  # [s] one crank turn, 0.06 s
T1 = 2.0 * TURN
# 60 us apart: up to 2048 output times share one compiled solve, that of docs/mechanisms.md's
# example (the same model structure and span), which runs first on the same worker
TS = np.linspace(0.0, T1, 2001)


def rigid_pin_force(ts, lengths=LENGTHS, masses=MASSES, g=9.80665):
    """(T, 2) [N]: the force of the coupler on the rocker at their pin, rigid links."""
    ground, crank, coupler, rocker = lengths
    _, m1, m2 = masses
    j1, j2 = m1 * coupler**2 / 12.0, m2 * rocker**2 / 12.0
    u = lambda a: np.array([np.cos(a), np.sin(a)])  # noqa: E731
    n = lambda a: np.array([-np.sin(a), np.cos(a)])  # noqa: E731
    out = []
    for t in ts:
        phi = W * t
        b, d = crank * u(phi), np.array([ground, 0.0])
        span = np.linalg.norm(d - b)
        along = (coupler**2 - rocker**2 + span**2) / (2.0 * span)
        e = (d - b) / span
        c = b + along * e + np.sqrt(coupler**2 - along**2) * np.array([-e[1], e[0]])  # elbow up
        beta, gamma = np.arctan2(*(c - b)[::-1]), np.arctan2(*(c - d)[::-1])
        a = np.column_stack([coupler * n(beta), -rocker * n(gamma)])
        beta_d, gamma_d = np.linalg.solve(a, -crank * W * n(phi))
        rhs = crank * W**2 * u(phi) + coupler * beta_d**2 * u(beta) - rocker * gamma_d**2 * u(gamma)
        beta_dd, gamma_dd = np.linalg.solve(a, rhs)
        a1 = -crank * W**2 * u(phi) + coupler / 2 * (beta_dd * n(beta) - beta_d**2 * u(beta))
        a2 = rocker / 2 * (gamma_dd * n(gamma) - gamma_d**2 * u(gamma))
        r1, r2 = b + coupler / 2 * u(beta), d + rocker / 2 * u(gamma)
        weight = np.array([0.0, -g])
        # unknowns: pin forces on the coupler at b, on the rocker at c (by the coupler) and at d
        m = np.zeros((6, 6))
        rhs = np.zeros(6)
        m[0:2, 0:2], m[0:2, 2:4], rhs[0:2] = np.eye(2), -np.eye(2), m1 * (a1 - weight)
        m[2, 0:2], m[2, 2:4], rhs[2] = [-(b - r1)[1], (b - r1)[0]], [(c - r1)[1], -(c - r1)[0]], j1 * beta_dd
        m[3:5, 2:4], m[3:5, 4:6], rhs[3:5] = np.eye(2), np.eye(2), m2 * (a2 - weight)
        m[5, 2:4], m[5, 4:6], rhs[5] = [-(c - r2)[1], (c - r2)[0]], [-(d - r2)[1], (d - r2)[0]], j2 * gamma_dd
        out.append(np.linalg.solve(m, rhs)[2:4])
    return np.array(out)


@pytest.fixture(scope="module")
def rigid():
    return rigid_pin_force(TS)


def stiff(scale, clearance=0.0, damping=3000.0):
    """The four-bar with the paper's bearing, ``scale`` times stiffer, its metrics over the
    second crank turn."""
    bearing = jb.cases.skf98205(ball_force="smooth", clearance=clearance, damping=damping)
    bearing = eqx.tree_at(lambda b: b.stiffness, bearing, bearing.stiffness * scale)
    return jb.cases.four_bar(bearing, window_start=TURN)


def test_assembly_from_a_rough_guess_closes_every_joint_and_centres_the_bearing():
    model = jb.cases.four_bar()  # assembled from a guess 4 cm and 45 degrees off
    q, qd = model.q0, model.qd0
    assert np.abs(np.asarray(model.constraints(q, 0.0))).max() < 1e-12
    assert np.abs(np.asarray(model.constraint_velocity(q, qd, 0.0))).max() < 1e-10
    joint = model.bearings[0]
    e, v = joint.eccentricity(q, qd)
    assert np.abs(np.asarray(e)).max() < 1e-12 and np.abs(np.asarray(v)).max() < 1e-10
    assert float(qd[2]) == pytest.approx(W, rel=1e-14)  # the driver held
    assert float(q[8]) == pytest.approx(1.8141924, abs=1e-6)  # the rocker's angle, elbow up


@pytest.mark.slow  # 19 s: jacfwd and jacrev through the root finder
def test_assembly_is_differentiable_in_a_joint_point():
    """d(q0, qd0)/d(ground pivot's x) by the implicit function theorem (forward and reverse)
    against central differences (h = 1e-6 m: truncation ~1e-12, round-off ~1e-10 of entries
    up to 260)."""
    model = jb.cases.four_bar()

    def state(ground):
        moved = eqx.tree_at(lambda m: m.joints[3].point_i, model, jnp.stack([ground, 0.0]))
        assembled = moved.assemble()
        return jnp.concatenate([assembled.q0, assembled.qd0])

    h = 1e-6
    difference = (state(0.3 + h) - state(0.3 - h)) / (2 * h)
    for derivative in (jax.jacfwd(state)(0.3), jax.jacrev(state)(0.3)):
        np.testing.assert_allclose(derivative, difference, rtol=0, atol=1e-6)
    assert abs(float(difference[6])) > 0.5  # the rocker's centre moves with its pivot


def test_bearing_force_converges_to_the_rigid_pin_reaction(rigid):
    """Over the second crank turn (the first holds the start-up transient of a bearing that
    starts centred and unloaded): the bearing's peak and RMS force approach the rigid pin's
    as it stiffens; at 100x the paper's stiffness, without clearance, within 1e-3 (measured
    3e-5 and 4e-5), and the force vector within 2 % of the peak at every sample."""
    after = TS >= TURN
    magnitude = np.linalg.norm(rigid, axis=1)[after]
    peak = magnitude.max()
    rms = np.sqrt(np.trapezoid(magnitude**2, TS[after]) / TURN)
    errors = []
    for scale in (1.0, 100.0):
        sol = jb.simulate(stiff(scale), T1, TS)
        assert float(sol.window_start) == TURN
        errors.append(abs(float(jb.metrics.rms_bearing_force(sol)) / rms - 1))
        if scale == 100.0:
            assert float(jb.metrics.peak_bearing_force(sol)) == pytest.approx(peak, rel=1e-3)
            assert errors[-1] < 1e-3
            deviation = np.abs(np.asarray(sol.bearing_force)[after] - rigid[after]).max()
            assert deviation < 0.02 * peak
    assert errors[1] < errors[0]


@pytest.mark.slow
def test_a_sweep_and_a_gradient_on_the_four_bar():
    """With a well-damped bearing (3000 N s/m a ball), the sweep's members equal their single
    runs within the solver's tolerance (1e-6 relative on the metric), and d RMS|F| / d
    clearance by forward mode matches central differences within 2 % (rtol 1e-10: the
    derivative of the discrete solve converges)."""
    model = jb.cases.four_bar(jb.cases.skf98205(ball_force="smooth", damping=3000.0), window_start=TURN)
    clearances = [5e-6, 10e-6]
    ds = jb.sweep(model, {"bearing.clearance": clearances}, t1=T1,
                  metrics={"rms": jb.metrics.rms_bearing_force}, progress=False)
    assert not ds["failed"].any()
    for c, value in zip(clearances, ds["rms"].values):
        single = jb.simulate(eqx.tree_at(lambda m: m.bearing.clearance, model, c), T1)
        assert value == pytest.approx(float(jb.metrics.rms_bearing_force(single)), rel=1e-6)
    controller = jb.default_controller(rtol=1e-10, atol=1e-12)
    at = eqx.tree_at(lambda m: m.bearing.clearance, model, 10e-6)
    _, grad = jb.sensitivity(at, jb.metrics.rms_bearing_force, ["bearing.clearance"], t1=T1,
                             stepsize_controller=controller)

    def rms(c):
        m = eqx.tree_at(lambda m: m.bearing.clearance, model, c)
        return float(jb.metrics.rms_bearing_force(jb.simulate(m, T1, stepsize_controller=controller)))

    h = 1e-8
    difference = (rms(10e-6 + h) - rms(10e-6 - h)) / (2 * h)
    print("d RMS / d clearance", float(grad["bearing.clearance"]), difference)
    assert float(grad["bearing.clearance"]) == pytest.approx(difference, rel=0.02)

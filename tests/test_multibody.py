"""Tests of the planar multibody core (Xu 2014 Sect. 2, Eq. 36) through `jb.simulate`.

Truths: conservation of energy (a double pendulum of `Revolute` joints; a rotor bouncing in an
undamped bearing, with the Hertz potential of the balls), an independent SciPy integration of
the double pendulum's Lagrange equations, the ideal slider–crank pin reaction from rigid-body
inverse dynamics with closed-form kinematics (tests/helpers.py), the static equilibrium of the
bearing law solved with brentq, and finite differences / virtual work for the point kinematics.
"""

import jax

jax.config.update("jax_enable_x64", True)

import equinox as eqx  # noqa: E402
import jax.numpy as jnp  # noqa: E402
import numpy as np  # noqa: E402
import pytest  # noqa: E402
from scipy.integrate import solve_ivp  # noqa: E402

import jaxbearing as jb  # noqa: E402
from jaxbearing.multibody import (  # noqa: E402
    GROUND,
    Body,
    ContactState,
    Gravity,
    Mechanism,
    Revolute,
    point_force,
    point_position,
    point_velocity,
)

import helpers as ref  # noqa: E402

G = ref.G0

# --------------------------------------------------------------------------- point kinematics


def test_point_velocity_is_derivative_of_point_position():
    # d/dh r(q + h qd) at h = 0 equals point_velocity(q, qd). Central difference with h = 1e-6:
    # truncation ~ h^2 |r'''| / 6 ~ 1e-12 * (|w|^3 |s| ~ 10) ~ 2e-12 m/s; rounding ~ 1e-16 / 1e-6.
    # Tolerance 1e-9 m/s absolute on velocities of order 1 m/s.
    h = 1e-6

    @jax.jit
    def both(q, qd, s):
        out = []
        for body in [0, 1]:
            plus, minus = point_position(q + h * qd, body, s), point_position(q - h * qd, body, s)
            fd = (plus - minus) / (2 * h)
            out.append((point_velocity(q, qd, body, s), fd))
        return out

    rng = np.random.default_rng(0)
    for _ in range(5):
        q = jnp.asarray(rng.normal(size=6))
        qd = jnp.asarray(rng.normal(size=6))
        s = jnp.asarray(rng.normal(size=2) * 0.1)
        for vel, fd in both(q, qd, s):
            np.testing.assert_allclose(np.asarray(vel), np.asarray(fd), rtol=0, atol=1e-9)
    # ground points are fixed global points
    q = jnp.asarray(rng.normal(size=6))
    np.testing.assert_array_equal(np.asarray(point_position(q, GROUND, jnp.array([0.3, -0.2]))),
                                  [0.3, -0.2])
    np.testing.assert_array_equal(np.asarray(point_velocity(q, q, GROUND, jnp.array([0.3, 0.2]))),
                                  [0.0, 0.0])


def test_point_force_torque_is_r_cross_f_and_virtual_work():
    # Torque about the centroid is (A s) x F, and the generalised force equals J^T F with
    # J = d r_point / d q (virtual work); both are exact up to rounding (1e-14).
    body = 1

    @jax.jit
    def gen_and_jac(q, s, f):
        return point_force(q, body, s, f), jax.jacfwd(lambda q_: point_position(q_, body, s))(q)

    rng = np.random.default_rng(1)
    for _ in range(5):
        q = jnp.asarray(rng.normal(size=9))
        s = jnp.asarray(rng.normal(size=2) * 0.1)
        f = jnp.asarray(rng.normal(size=2) * 10)
        gen, jac = (np.asarray(x) for x in gen_and_jac(q, s, f))
        theta = float(q[3 * body + 2])
        rot = np.array([[np.cos(theta), -np.sin(theta)], [np.sin(theta), np.cos(theta)]])
        arm = rot @ np.asarray(s)
        np.testing.assert_allclose(gen[3:5], np.asarray(f), rtol=0, atol=1e-14)
        assert gen[5] == pytest.approx(arm[0] * float(f[1]) - arm[1] * float(f[0]), abs=1e-13)
        assert np.all(gen[[0, 1, 2, 6, 7, 8]] == 0.0)
        np.testing.assert_allclose(gen, jac.T @ np.asarray(f), rtol=0, atol=1e-13)
    assert np.all(np.asarray(point_force(q, GROUND, s, f)) == 0.0)


# --------------------------------------------------------------------------- double pendulum

M1, J1, L1 = 1.0, 0.01, 0.3  # link 1 [kg, kg m^2, m], pinned to ground at its -x end
M2, J2, L2 = 0.6, 0.006, 0.25  # link 2, pinned to link 1's +x end
TH0 = (-0.3, 0.5, 2.0, -1.0)  # th1, th2 [rad], w1, w2 [rad/s]: a large, non-periodic swing
DP_TS = np.linspace(0.0, 1.0, 201)


def double_pendulum_state(th1, th2, w1, w2):
    e1, n1 = np.array([np.cos(th1), np.sin(th1)]), np.array([-np.sin(th1), np.cos(th1)])
    e2, n2 = np.array([np.cos(th2), np.sin(th2)]), np.array([-np.sin(th2), np.cos(th2)])
    c1, c2 = 0.5 * L1 * e1, L1 * e1 + 0.5 * L2 * e2
    v1, v2 = 0.5 * L1 * w1 * n1, L1 * w1 * n1 + 0.5 * L2 * w2 * n2
    return [*c1, th1, *c2, th2], [*v1, w1, *v2, w2]


@pytest.fixture(scope="module")
def double_pendulum():
    q0, qd0 = double_pendulum_state(*TH0)
    model = Mechanism(
        (Body(M1, J1), Body(M2, J2)),
        (
            Revolute(GROUND, (0.0, 0.0), 0, (-L1 / 2, 0.0)),
            Revolute(0, (L1 / 2, 0.0), 1, (-L2 / 2, 0.0)),
        ),
        q0,
        qd0,
        forces=(Gravity(),),
    )
    return jb.simulate(model, 1.0, DP_TS, stepsize_controller=jb.default_controller(rtol=1e-10, atol=1e-12))


def test_double_pendulum_energy_and_drift(double_pendulum):
    sol = double_pendulum
    q, qd = np.asarray(sol.q), np.asarray(sol.qd)
    kinetic = 0.5 * (M1 * (qd[:, 0] ** 2 + qd[:, 1] ** 2) + J1 * qd[:, 2] ** 2
                     + M2 * (qd[:, 3] ** 2 + qd[:, 4] ** 2) + J2 * qd[:, 5] ** 2)
    energy = kinetic + G * (M1 * q[:, 1] + M2 * q[:, 4])
    # No damping, ideal pins: energy is conserved up to the integrator (rtol 1e-10 per step,
    # ~300 steps) and the Baumgarte terms, which act only on a drift of ~1e-11 m. Measured
    # ~2e-10 J against an initial kinetic energy of 0.15 J; tolerance 1e-8 relative to it
    # (the brief's suggestion was 1e-7).
    assert np.max(np.abs(energy - energy[0])) < 1e-8 * kinetic[0]
    assert np.max(np.asarray(sol.drift)) < 1e-8
    # joints hold: link 1's -x end at the origin, link ends coincide (the drift, checked here
    # from positions directly)
    th1, th2 = q[:, 2], q[:, 5]
    end1 = q[:, :2] + 0.5 * L1 * np.stack([np.cos(th1), np.sin(th1)], 1)
    start2 = q[:, 3:5] - 0.5 * L2 * np.stack([np.cos(th2), np.sin(th2)], 1)
    assert np.max(np.abs(q[:, :2] - 0.5 * L1 * np.stack([np.cos(th1), np.sin(th1)], 1))) < 1e-8
    assert np.max(np.abs(end1 - start2)) < 1e-8


def test_double_pendulum_matches_lagrange_equations(double_pendulum):
    # Independent model: Lagrange's equations in the two absolute angles, SciPy DOP853 at
    # rtol 1e-12. Over 1 s the two solutions (rtol 1e-10 vs 1e-12) differ by ~1e-10 rad
    # (measured 7e-11); tolerance 1e-8 rad and 1e-7 rad/s.
    sol = double_pendulum
    rhs = ref.compound_double_pendulum_rhs(M1, J1, L1, M2, J2, L2)
    r = solve_ivp(rhs, (0.0, 1.0), list(TH0), method="DOP853", rtol=1e-12, atol=1e-12, t_eval=DP_TS)
    q, qd = np.asarray(sol.q), np.asarray(sol.qd)
    np.testing.assert_allclose(q[:, [2, 5]], r.y[:2].T, rtol=0, atol=1e-8)
    np.testing.assert_allclose(qd[:, [2, 5]], r.y[2:].T, rtol=0, atol=1e-7)


# --------------------------------------------------------------------------- rotor in a bearing

K_B = 9.57e9  # [N/m^1.5]
# output points and segment slots (the default's for the longer run, 0.05 s): the same for both
# rotor runs so that they share one compile
ROTOR_TS, ROTOR_OPTIONS = 501, jb.SolveOptions(max_segments=256)


def rotor_model(clearance, damping, mass=2.0):
    b = jb.BallBearing(clearance, K_B, damping, 29.2e-3, 46.6e-3, 8, cage="constant")
    return jb.cases.rotor(b, mass=mass, inertia=2e-3, speed=0.0, driven=False)


def rotor_run(model, t1):
    return jb.simulate(model, t1, np.linspace(0.0, t1, ROTOR_TS), stepsize_controller=jb.default_controller(rtol=1e-10, atol=1e-14), options=ROTOR_OPTIONS)


def test_rotor_undamped_bearing_conserves_energy():
    # Dropped from the centre of a 40 um clearance: it falls 20 um (2 ms), bounces on the
    # Hertz balls and flies back up, repeatedly (0.02 s). The bearing with C_b = 0 is
    # conservative with potential sum_r K delta_r^(5/2) / (5/2) (its gradient is the ball
    # force). Energy scale m g P_d/2 = 3.9e-4 J; measured error 2.4e-11 J (6e-8 relative:
    # rtol 1e-10 on positions of ~2e-5 m, atol 1e-14 m). Tolerance 1e-6 relative.
    c, m = 40e-6, 2.0
    sol = rotor_run(rotor_model(c, 0.0, m), 0.02)
    q, qd = np.asarray(sol.q), np.asarray(sol.qd)
    delta = q[:, :2] @ ref.ball_unit_vectors(0.0, 8).T - 0.5 * c
    hertz = np.sum(K_B * np.clip(delta, 0, None) ** 2.5 / 2.5, axis=1)
    kinetic = 0.5 * m * (qd[:, 0] ** 2 + qd[:, 1] ** 2) + 0.5 * 2e-3 * qd[:, 2] ** 2
    energy = kinetic + m * G * q[:, 1] + hertz
    scale = m * G * 0.5 * c
    assert np.max(np.abs(energy - energy[0])) < 1e-6 * scale
    # it really bounced: reached the balls (Hertz energy > 10 % of the drop) and came back up
    assert hertz.max() > 0.1 * scale
    assert q[-1, 1] > -0.5 * c
    # no spin and no sideways motion (loads on the symmetric balls 6 and 8 cancel)
    assert np.max(np.abs(q[:, [0, 2]])) < 1e-14


def test_rotor_settles_to_static_equilibrium():
    # A 2 kg rotor on a 1 um clearance (three balls carry it), damping 2000 N s/m per ball:
    # from the centre it settles in a few ms (damping ratio ~0.5). After 0.05 s the residual
    # motion is below 1e-12 m. The equilibrium of the static law solved by brentq (NumPy law,
    # tests/helpers.py) must match: position to 1e-6 of the deflection, and the resultant
    # on the outer race (ground) equal to the weight, pointing down, to 1e-6.
    c, m = 1e-6, 2.0
    sol = rotor_run(rotor_model(c, 2000.0, m), 0.05)
    q = np.asarray(sol.q)
    s = ref.static_eccentricity(m * G, -np.pi / 2, clearance=c, stiffness=K_B, n_balls=8)
    deflection = s - 0.5 * c
    assert abs(q[-1, 0]) < 1e-6 * deflection
    assert q[-1, 1] == pytest.approx(-s, abs=1e-6 * deflection)
    force = np.asarray(sol.bearing_force)[-1]
    np.testing.assert_allclose(force, [0.0, -m * G], rtol=0, atol=1e-6 * m * G)
    loads = np.asarray(sol.ball_loads)[-1]
    assert np.sum(loads > 0) == 3  # balls 6, 7, 8 (at 225, 270, 315 deg)
    assert loads[6] == pytest.approx(np.max(loads))


# --------------------------------------------------------------------------- inverse dynamics


@pytest.mark.slow
def test_stiff_bearing_reaction_equals_ideal_pin():
    # xu2014 without impact, bearing made nearly ideal: K x10, clearance 0.1 um, damping 3000
    # N s/m per ball (damping ratio ~0.5 on the ~3 kHz contact mode), so the start-up
    # rattle has died out by 0.04 s. The bearing deflects ~1 um, which shifts the rod angle by
    # ~1e-5 rad: a negligible change of the inertial loads. Then the force on the crank must
    # equal the ideal pin reaction from Newton–Euler of rod + slider with exact kinematics
    # (tests/helpers.py). The residual is the bearing's own small vibration as the load
    # turns (balls unloading/loading): measured 0.49 N against a 244 N peak. Tolerance
    # 1 % of the peak + 1 N.
    model = jb.cases.xu2014(impact=False, clearance=1e-7, bearing_damping=3000.0)
    model = eqx.tree_at(lambda m: m.forces[0].bearing.stiffness, model,
                        10.0 * model.forces[0].bearing.stiffness)
    ts = np.linspace(0.04, 0.1, 601)
    sol = jb.simulate(model, 0.1, ts, stepsize_controller=jb.default_controller(rtol=1e-8, atol=1e-12))
    f_sim = np.asarray(sol.bearing_force)
    omega, l2, l3 = 20.0 * np.pi, 0.05, 0.12
    f_ideal = ref.slider_crank_pin_force(ts, omega, l2, l3, 0.67, 1.2e-3, 0.30)
    peak = np.max(np.linalg.norm(f_ideal, axis=1))
    assert peak > 200.0  # the comparison is not trivial
    err = np.max(np.linalg.norm(f_sim - f_ideal, axis=1))
    assert err < 0.01 * peak + 1.0
    # the kinematics the reaction was derived from hold in the simulation too
    kin = ref.slider_crank_kinematics(ts, omega, l2, l3)
    q = np.asarray(sol.q)
    assert np.max(np.abs(q[:, 5] - kin["phi"])) < 1e-4  # rod angle [rad]
    assert np.max(np.abs(q[:, 6] - kin["B"][:, 0])) < 1e-5  # slider [m]
    assert np.max(np.asarray(sol.drift)) < 1e-8


def test_slider_crank_reference_kinematics_self_consistent():
    # Guards the reference itself: analytic accelerations of tests/helpers.py against central
    # differences of its closed-form positions (h = 1e-6 s: truncation ~ h^2 |x''''| / 12
    # ~ 1e-12 * 1e7 ~ 1e-5 m/s^2, rounding ~ 1e-16 * 0.2 m / 1e-12 s^2 ~ 2e-5 m/s^2).
    # Tolerance 1e-3 m/s^2 on accelerations up to 280 m/s^2.
    t = np.linspace(0.0, 0.1, 37)
    h = 1e-6
    omega, l2, l3 = 20.0 * np.pi, 0.05, 0.12
    k0, kp, km = (ref.slider_crank_kinematics(t + d, omega, l2, l3) for d in (0.0, h, -h))
    for pos, acc in [("G", "a_G"), ("B", "a_B")]:
        fd = (kp[pos] - 2 * k0[pos] + km[pos]) / h**2
        np.testing.assert_allclose(k0[acc], fd, rtol=0, atol=1e-3)
    np.testing.assert_allclose(k0["B"][:, 1], 0.0, atol=1e-17)
    np.testing.assert_allclose(k0["phi_d"], (kp["phi"] - km["phi"]) / (2 * h), rtol=0, atol=1e-6)


@pytest.mark.parametrize("n", [1, 2, 9, 24])
def test_solve_spd_matches_lapack(n):
    """The unrolled Gauss–Jordan solve of the Schur system against numpy's LAPACK solve, on an
    SPD matrix with condition number ~1e6 (the paper's Schur complement has ~1e3): agreement to
    1e-9 relative (rounding 1e-16 times the condition number, with margin)."""
    from jaxbearing.multibody.mechanism import solve_spd

    rng = np.random.default_rng(n)
    q, _ = np.linalg.qr(rng.normal(size=(n, n)))
    a = q @ np.diag(np.logspace(0, 6, n)) @ q.T
    b = rng.normal(size=n)
    expected = np.linalg.solve(a, b)
    got = np.asarray(solve_spd(jnp.asarray(a), jnp.asarray(b)))
    np.testing.assert_allclose(got, expected, rtol=1e-9, atol=1e-12 * np.abs(expected).max())


@pytest.mark.parametrize("n", [1, 2, 9, 24])
@pytest.mark.parametrize("pattern", ["dense", "sparse"])
def test_solve_spd_entries_matches_lapack(n, pattern):
    """The entry-by-entry LDL^T solve against numpy's LAPACK solve, as above (1e-9 relative at
    condition ~1e6). "sparse": a band plus a full last row and column, whose factors fill in,
    with the structural zeros passed as None."""
    from jaxbearing.multibody.mechanism import solve_spd_entries

    rng = np.random.default_rng(n)
    q, _ = np.linalg.qr(rng.normal(size=(n, n)))
    a = q @ np.diag(np.logspace(0, 6, n)) @ q.T
    i, j = np.indices((n, n))
    structure = np.ones((n, n), bool)
    if pattern == "sparse":
        structure = (abs(i - j) <= 1) | (i == n - 1) | (j == n - 1)
        a = np.where(structure, a, 0.0) + np.diag(np.abs(a).sum(axis=1))  # SPD: dominant diagonal
    b = rng.normal(size=n)
    expected = np.linalg.solve(a, b)
    lower = [[jnp.asarray(a[r, c]) if structure[r, c] else None for c in range(r + 1)] for r in range(n)]
    got = np.asarray(jnp.stack(solve_spd_entries(lower, [jnp.asarray(x) for x in b])))
    np.testing.assert_allclose(got, expected, rtol=1e-9, atol=1e-12 * np.abs(expected).max())


def _pendulum_model():
    q0, qd0 = double_pendulum_state(*TH0)
    joints = (Revolute(GROUND, (0.0, 0.0), 0, (-L1 / 2, 0.0)), Revolute(0, (L1 / 2, 0.0), 1, (-L2 / 2, 0.0)))
    return Mechanism((Body(M1, J1), Body(M2, J2)), joints, q0, qd0, forces=(Gravity(),))


@pytest.mark.parametrize("sparse", [False, True], ids=["dense", "sparse"])
@pytest.mark.parametrize("case", ["paper", "double pendulum"])
def test_accelerations_solve_the_augmented_system(case, sparse):
    """q_ddot of both eliminations equals numpy's solve of the full augmented system of Eq. 36,
    [[M, Phi_q^T], [Phi_q, 0]] [q_ddot, lambda] = [Q_A, rhs] (dense, LAPACK), away from the
    initial state, to rounding (1e-12 of the largest entry)."""
    model = jb.cases.xu2014(impact=True) if case == "paper" else _pendulum_model()
    n = model.n_coordinates
    t = jnp.asarray(0.013)
    q = model.q0 + 1e-5 * jnp.arange(float(n))
    qd = model.qd0 + 1e-2 * jnp.cos(jnp.arange(float(n)))
    # every contact touching with an approach speed of 1 m/s, every ball of a bearing engaged
    states = tuple(
        ContactState(jnp.ones(()), jnp.ones((), bool)) if isinstance(s, ContactState)
        else None if s is None else jnp.ones_like(s)
        for s in model.initial_states(t, q, qd)
    )  # fmt: skip

    @eqx.filter_jit  # one program, not one per operation
    def terms(model, t, q, qd, states):
        jac, rhs = model.constraint_rhs(q, qd, t)
        got = model.accelerations(t, q, qd, states, sparse=sparse)
        return model.generalized_forces(t, q, qd, states), jac, rhs, model.inverse_mass, got

    forces, jac, rhs, inverse_mass, got = (np.asarray(x) for x in terms(model, t, q, qd, states))
    m = rhs.shape[0]
    mass = np.diag(1.0 / inverse_mass)
    augmented = np.block([[mass, jac.T], [jac, np.zeros((m, m))]])
    expected = np.linalg.solve(augmented, np.concatenate([forces, rhs]))[:n]
    np.testing.assert_allclose(got, expected, rtol=0, atol=1e-12 * np.abs(expected).max())


# --------------------------------------------------------------------------- one interface each


def test_force_elements_and_joints_share_one_abstract_interface():
    mb = jb.multibody
    for cls in (mb.BearingJoint, mb.CircleContact, mb.SpringDamper, mb.Gravity):
        assert issubclass(cls, mb.AbstractForceElement)
    for cls in (mb.Revolute, mb.Translational, mb.Driver):
        assert issubclass(cls, mb.AbstractJoint)
    with pytest.raises(TypeError):
        mb.AbstractForceElement()

    class Incomplete(mb.AbstractForceElement):  # no generalized_force, ...
        pass

    with pytest.raises(TypeError):
        Incomplete()


def test_every_force_element_goes_in_one_list():
    """A `CircleContact` passed in ``forces=`` was accepted and failed deep inside diffrax (its
    approach speed was captured only for a separate ``contacts=`` list). There is one list now:
    a contact in it is a contact (its events and episodes the solve's), the views find it, and
    the old keyword is no more."""
    m = jb.cases.xu2014()
    contact = m.contacts[0]
    again = Mechanism(m.bodies, m.joints, m.q0, m.qd0, forces=(m.forces[2], m.forces[0], m.forces[1]))
    assert again.contacts == (contact,) and again.bearings == (m.forces[0],)
    assert again.event_counts() == (1, 8, 0) and again.episodic == (0,)
    with pytest.raises(TypeError, match="contacts"):
        Mechanism(m.bodies, m.joints, m.q0, m.qd0, forces=m.forces[:2], contacts=(contact,))

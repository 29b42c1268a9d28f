"""Tests of the per-ball bearing law `jaxbearing.laws.ball_loads` (Xu 2014 Eqs. 9, 12–14, 28).

Truths: an independent NumPy implementation of Eq. 9 (tests/helpers.py) with SciPy brentq for
static equilibria, Stribeck's closed-form limit 1/J_r(0.5), the exact one-ball law, rotational
symmetry of the model, and central finite differences.
"""

import jax

jax.config.update("jax_enable_x64", True)

import equinox as eqx  # noqa: E402
import jax.numpy as jnp  # noqa: E402
import numpy as np  # noqa: E402
import pytest  # noqa: E402
from scipy.integrate import quad as quad_integral  # noqa: E402

import jaxbearing as jb  # noqa: E402

import helpers as ref  # noqa: E402

K_B = 9.57e9  # paper's SKF 98205 ball stiffness [N/m^1.5]
C_B = 300.0  # paper's per-ball damping [N s/m]
D_I, D_O = 29.2e-3, 46.6e-3


def bearing(clearance=40e-6, stiffness=K_B, damping=C_B, n_balls=8, **kw):
    return jb.BallBearing(clearance, stiffness, damping, D_I, D_O, n_balls, **kw)


loads_fn = jax.jit(jb.laws.ball_loads)


def loads_of(e, v, cage, b):
    return np.asarray(loads_fn(jnp.asarray(e, float), jnp.asarray(v, float), cage, b))


def ref_loads(e, v, cage, b, smooth=False):
    return ref.ball_loads_ref(
        e, v, cage, clearance=float(b.clearance), stiffness=float(b.stiffness),
        damping=float(b.damping), n_balls=b.n_balls, exponent=b.exponent, smooth=smooth,
        ramp=float(b.damping_ramp),
    )


# --------------------------------------------------------------------------- static radial load


@pytest.mark.parametrize("n_balls", [8, 9])
@pytest.mark.parametrize("clearance", [0.0, 40e-6])
@pytest.mark.parametrize("between_balls", [False, True])
def test_static_radial_load_balance(n_balls, clearance, between_balls):
    # brentq on the independent NumPy law gives |e| to ~1e-15 relative (xtol 1e-22 m on
    # |e| ~ 1e-5 m); the resultant goes as delta^1.5, so the library's resultant must equal the
    # load to rounding: 1e-9 relative leaves 5 orders of margin. The load direction is a
    # symmetry axis of the ball set (through a ball or midway between two), so the
    # perpendicular component vanishes up to rounding of sum(F_r sin phi_r) ~ 1e-15 * sum F_r.
    load = 1000.0
    cage = 0.3
    direction = cage + (np.pi / n_balls if between_balls else 0.0)
    b = bearing(clearance=clearance, damping=C_B, n_balls=n_balls)
    s = ref.static_eccentricity(load, direction, clearance=clearance, stiffness=K_B,
                                n_balls=n_balls, cage_angle=cage)
    d = np.array([np.cos(direction), np.sin(direction)])
    loads = loads_of(s * d, (0.0, 0.0), cage, b)
    # our own vector sum, and the library's Eq. 28 helper
    f_ours = ref.resultant_ref(loads, cage)
    f_lib = np.asarray(jb.laws.resultant(jnp.asarray(loads), cage))
    np.testing.assert_allclose(f_lib, f_ours, rtol=0, atol=1e-12 * load)
    along = f_ours @ d
    perp = f_ours @ np.array([-d[1], d[0]])
    assert abs(along - load) < 1e-9 * load
    assert abs(perp) < 1e-12 * load
    # the load is carried by the balls facing the load direction only
    facing = ref.ball_unit_vectors(cage, n_balls) @ d
    assert np.all(loads[facing < 0.5 * clearance / s - 1e-9] == 0.0)


# --------------------------------------------------------------------------- Stribeck


@pytest.mark.parametrize("n_balls", [40, 64, 100])
def test_stribeck_zero_clearance_many_balls(n_balls):
    # Zero clearance: Q_r = Q_max cos^1.5(psi_r) on the loaded half, so Z Q_max / F_r =
    # Z / sum cos_+^2.5(psi_r), a periodic trapezoidal sum of cos_+^2.5, which converges to
    # 1/J_r(0.5) = 2 pi / B(1/2, 7/4) = 4.370096 (checked against scipy quad below; Harris
    # tabulates J_r(0.5) = 0.2288) with error O(Z^-3.5) from the x^2.5 kink at psi = +-pi/2:
    # 1.8e-5 at Z = 40, 8e-7 at Z = 100. We assert Stribeck's rounded 4.37 to 1 %, the exact
    # limit to 1e-4, and the exact finite-Z sum to 1e-9 (rounding and brentq only).
    load = 5000.0
    b = bearing(clearance=0.0, n_balls=n_balls)
    s = ref.static_eccentricity(load, 0.0, clearance=0.0, stiffness=K_B, n_balls=n_balls)
    loads = loads_of((s, 0.0), (0.0, 0.0), 0.0, b)
    ratio = loads.max() * n_balls / load
    limit = ref.stribeck_limit(1.5)
    quad = quad_integral(lambda p: np.cos(p) ** 2.5, -np.pi / 2, np.pi / 2, epsabs=1e-13)[0]
    assert limit == pytest.approx(2 * np.pi / quad, rel=1e-10)
    assert limit == pytest.approx(4.370096, abs=1e-6)
    assert ratio == pytest.approx(4.37, rel=1e-2)
    assert ratio == pytest.approx(limit, rel=1e-4)
    psi = 2 * np.pi * np.arange(n_balls) / n_balls
    exact = n_balls / np.sum(np.clip(np.cos(psi), 0, None) ** 2.5)
    assert ratio == pytest.approx(exact, rel=1e-9)
    # the ball on the load line carries Q_max
    assert np.argmax(loads) == 0


def test_clearance_raises_max_ball_load():
    # Stribeck/Harris: at a fixed radial load, clearance shrinks the loaded zone and raises
    # Q_max. Strictly increasing over 0..40 um (Q_max changes by > 1 % per step, far above the
    # 1e-9 accuracy of the balance above).
    load = 1000.0
    q_max = []
    for c in [0.0, 5e-6, 10e-6, 20e-6, 40e-6]:
        s = ref.static_eccentricity(load, 0.0, clearance=c, stiffness=K_B, n_balls=8)
        q_max.append(loads_of((s, 0.0), (0.0, 0.0), 0.0, bearing(clearance=c)).max())
    q_max = np.array(q_max)
    assert np.all(np.diff(q_max) > 0.01 * q_max[:-1])
    # with zero clearance and Z = 8 the ratio is the exact finite sum (about 4.37 as well)
    assert q_max[0] * 8 / load == pytest.approx(
        8 / np.sum(np.clip(np.cos(2 * np.pi * np.arange(8) / 8), 0, None) ** 2.5), rel=1e-9
    )


# --------------------------------------------------------------------------- pointwise law


def test_matches_reference_law_random_states():
    # Random eccentricities across the clearance circle and random rates: the library and the
    # NumPy law compute the same float64 expressions, so they agree to rounding (1e-12 of the
    # largest load, 1e-9 N absolute for loads that are clamped to 0 in one and ~0 in the other).
    rng = np.random.default_rng(0)
    for ball_force in ["paper", "smooth"]:
        b = bearing(ball_force=ball_force, damping_ramp=2e-6)
        for _ in range(50):
            e = rng.normal(size=2) * 25e-6
            v = rng.normal(size=2) * 0.05
            cage = rng.uniform(0, 2 * np.pi)
            got = loads_of(e, v, cage, b)
            want = ref_loads(e, v, cage, b, smooth=ball_force == "smooth")
            np.testing.assert_allclose(got, want, rtol=1e-12, atol=1e-9)


def test_no_force_inside_clearance():
    # |e| < P_d/2 means every delta_r < 0: exactly zero whatever the rate (damping only acts
    # in contact), for both variants.
    rng = np.random.default_rng(1)
    for ball_force in ["paper", "smooth"]:
        b = bearing(ball_force=ball_force)
        for _ in range(30):
            r = 20e-6 * np.sqrt(rng.uniform(0, 0.999))
            a = rng.uniform(0, 2 * np.pi)
            e = r * np.array([np.cos(a), np.sin(a)])
            v = rng.normal(size=2) * 10.0
            assert np.all(loads_of(e, v, rng.uniform(0, 7), b) == 0.0)


def test_balls_never_pull():
    # Large negative rate (separating at 10 m/s): K delta^1.5 + C v < 0 on the touching balls,
    # which must be clamped to exactly 0, never negative.
    b = bearing()
    e = np.array([25e-6, 3e-6])
    loads = loads_of(e, -10.0 * e / np.linalg.norm(e), 0.0, b)
    assert np.all(loads >= 0.0)
    touching = ref.ball_unit_vectors(0.0, 8) @ e > 20e-6
    assert touching.any() and np.all(loads[touching] == 0.0)
    # and the smooth variant too
    loads = loads_of(e, -10.0 * e / np.linalg.norm(e), 0.0, bearing(ball_force="smooth"))
    assert np.all(loads >= 0.0)


@pytest.mark.parametrize("exponent", [10.0 / 9.0, 1.5])
def test_single_ball_power_law(exponent):
    # Eccentricity along ball 1 just past the clearance: only ball 1 touches (its neighbours at
    # 45 deg see e cos 45 < P_d/2), and F_1 = K delta^n exactly (rounding only: 1e-12).
    k = 1e9
    b = bearing(stiffness=k, damping=0.0, exponent=exponent)
    for delta in [1e-8, 1e-7, 1e-6, 3e-6]:
        loads = loads_of((20e-6 + delta, 0.0), (0.0, 0.0), 0.0, b)
        # delta is rebuilt as (20e-6 + delta) - 20e-6: rounding ~ 4e-21 m / delta
        assert loads[0] == pytest.approx(k * delta**exponent, rel=1e-12 + 10 * 4e-21 / delta)
        assert np.all(loads[1:] == 0.0)


def test_smooth_variant_continuous_at_first_touch_paper_jumps():
    # Approaching at v = 0.2 m/s along ball 1. As delta -> 0+:
    #   paper:  F -> C_b v (the damping switches on at touch: a jump of C_b v = 60 N);
    #   smooth: F -> 0 (damping scaled by 3x^2-2x^3, x = delta/ramp; at delta = 1e-12 m,
    #           F = K delta^1.5 + C v 3e-12 ~ 2e-10 N).
    # Beyond the ramp (delta >= damping_ramp) both variants coincide exactly.
    v = 0.2
    paper, smooth = bearing(), bearing(ball_force="smooth", damping_ramp=1e-6)
    c2 = 20e-6  # P_d / 2
    for delta in [1e-12, 1e-10]:
        e = (c2 + delta, 0.0)
        # delta is reconstructed as (c2 + delta) - c2, exact to ~ 3.4e-21 m (half ulp of c2)
        fp = loads_of(e, (v, 0.0), 0.0, paper)[0]
        fs = loads_of(e, (v, 0.0), 0.0, smooth)[0]
        assert fp == pytest.approx(C_B * v, rel=1e-6)
        assert fs < 1e-6 * C_B * v
    just_inside = loads_of((c2 - 1e-12, 0.0), (v, 0.0), 0.0, paper)[0]
    assert just_inside == 0.0  # the jump: 0 at delta = -1e-12, C_b v at delta = +1e-12
    for delta in [1e-6, 2e-6, 5e-6]:
        e = (c2 + delta, 0.0)
        assert loads_of(e, (v, 0.0), 0.0, smooth)[0] == pytest.approx(
            loads_of(e, (v, 0.0), 0.0, paper)[0], rel=1e-12
        )
    # mid-ramp: damping weighted by s(0.5) = 0.5
    e = (c2 + 0.5e-6, 0.0)
    assert loads_of(e, (v, 0.0), 0.0, smooth)[0] == pytest.approx(
        K_B * (0.5e-6) ** 1.5 + 0.5 * C_B * v, rel=1e-9
    )


def test_resultant_along_symmetric_load_with_damping():
    # Eccentricity and rate along a symmetry axis (ball 3): the resultant lies on that axis.
    b = bearing()
    cage = 0.1
    d = ref.ball_unit_vectors(cage, 8)[2]
    loads = loads_of(30e-6 * d, 0.05 * d, cage, b)
    f = np.asarray(jb.laws.resultant(jnp.asarray(loads), cage))
    assert f @ d > 0
    assert abs(f @ np.array([-d[1], d[0]])) < 1e-12 * np.linalg.norm(f)


def test_rotation_symmetry():
    # Rotating e, v and the cage angle by alpha leaves every ball's load unchanged and rotates
    # the resultant by alpha. Deflections ~5 um are differences of ~25 um numbers: rounding
    # ~1e-15 relative on e gives ~1e-14 on delta, well inside 1e-10.
    rng = np.random.default_rng(2)
    b = bearing()
    for _ in range(10):
        e = rng.normal(size=2)
        e = e / np.linalg.norm(e) * rng.uniform(21e-6, 35e-6)
        v = rng.normal(size=2) * 0.05
        cage = rng.uniform(0, 2 * np.pi)
        alpha = rng.uniform(-np.pi, np.pi)
        rot = np.array([[np.cos(alpha), -np.sin(alpha)], [np.sin(alpha), np.cos(alpha)]])
        l0 = loads_of(e, v, cage, b)
        l1 = loads_of(rot @ e, rot @ v, cage + alpha, b)
        np.testing.assert_allclose(l1, l0, rtol=1e-10, atol=1e-9)
        f0 = np.asarray(jb.laws.resultant(jnp.asarray(l0), cage))
        f1 = np.asarray(jb.laws.resultant(jnp.asarray(l1), cage + alpha))
        np.testing.assert_allclose(f1, rot @ f0, rtol=0, atol=1e-10 * np.linalg.norm(f0) + 1e-9)


# --------------------------------------------------------------------------- gradients


@pytest.mark.parametrize("ball_force", ["paper", "smooth"])
def test_gradients_match_finite_differences(ball_force):
    # Sum of ball loads at a state where 3 balls touch (delta 3.5..15 um, none near 0, so the
    # law is smooth in a neighbourhood) and move (v != 0; for "smooth" ball 8 sits mid-ramp).
    # Central differences: stiffness enters linearly (FD exact up to rounding, step 1e-3 K);
    # clearance step h = 1e-10 m against deflections >= 3.5e-6 m: truncation ~ (h/delta)^2
    # ~ 1e-9, rounding ~ 1e-16 * 1e3 N / 1e-10 m = 1e-3 N/m on ~1e8 N/m. Tolerance 1e-6.
    b = bearing(ball_force=ball_force, damping_ramp=5e-6)
    e = 35e-6 * jnp.array([np.cos(0.05), np.sin(0.05)])
    v = jnp.array([0.03, -0.02])
    cage = 0.0

    @jax.jit
    def total(c, k):
        bb = eqx.tree_at(lambda x: (x.clearance, x.stiffness), b, (c, k))
        return jnp.sum(jb.laws.ball_loads(e, v, cage, bb))

    c0, k0 = b.clearance, b.stiffness
    deltas = ref.ball_unit_vectors(cage, 8) @ np.asarray(e) - 0.5 * float(b.clearance)
    assert np.sum(deltas > 0) == 3 and np.min(deltas[deltas > 0]) > 3e-6
    g_c, g_k = jax.jit(jax.grad(total, argnums=(0, 1)))(c0, k0)
    h = 1e-10
    fd_c = (total(c0 + h, k0) - total(c0 - h, k0)) / (2 * h)
    hk = 1e-3 * k0
    fd_k = (total(c0, k0 + hk) - total(c0, k0 - hk)) / (2 * hk)
    assert float(g_c) == pytest.approx(float(fd_c), rel=1e-6)
    assert float(g_k) == pytest.approx(float(fd_k), rel=1e-9)
    # and the analytic stiffness derivative sum delta_+^1.5 (damping does not depend on K)
    assert float(g_k) == pytest.approx(np.sum(np.clip(deltas, 0, None) ** 1.5), rel=1e-12)
    assert float(g_c) < 0  # more clearance, less load

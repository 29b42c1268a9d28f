"""Tests of the static load distribution, ISO/TS 16281's reference rating life L10r and preload.

Truths: Stribeck's Q_max = 4.37 F_r / Z (point contact) and 4.08 F_r / Z (line contact) at zero
clearance; Harris' load-zone integrals J_r(epsilon), J_1(0.5), J_2(0.5) by quadrature (scipy);
an independent Newton solution of the element balance (scipy's hybrid root finder on the law
of tests/helpers.py); ISO 281's basic rating life (C_r / P)^p and Lundberg–Palmgren's raceway
ratings (`ball_race_load_ratings`, ISO/TR 1281-1's 552 for line contact); the shape of life
against clearance that Harris & Kotzalas show (a maximum at a small preload, steep falls on
both sides); central differences for the derivatives; the static solution for a simulated
rotor under a steady load.
"""

import jax

jax.config.update("jax_enable_x64", True)

import equinox as eqx  # noqa: E402
import jax.numpy as jnp  # noqa: E402
import numpy as np  # noqa: E402
import pytest  # noqa: E402
from scipy.integrate import quad  # noqa: E402
from scipy.optimize import root  # noqa: E402

import jaxbearing as jb  # noqa: E402
from jaxbearing import life  # noqa: E402
from helpers import ball_loads_ref  # noqa: E402

BALL = jb.BallBearing.from_catalogue("98205", clearance=0.0)  # Z = 8, D 8.7 mm
ROLLER = jb.RollerBearing.from_catalogue("NU206", clearance=0.0)  # Z = 13, D 9 mm
BEARINGS = {"ball": BALL, "roller": ROLLER}


def with_clearance(b, c):
    return eqx.tree_at(lambda x: x.clearance, b, c)


# ---------------------------------------------------------------------- load distribution


def test_stribeck_constants_at_zero_clearance():
    """Q_max Z / F_r: Stribeck's 4.37 (balls) and 4.08 (line contact) are the continuous load
    zone's 1 / J_r(0.5) (`load_zone_integrals`); a real bearing's discrete elements, one on the
    load line, give within 0.6 % of them (measured: 98205 4.346, NU 206 4.093), and a bearing of
    many elements converges to them (72 elements: within 2e-4)."""
    j_ball = life.load_zone_integrals(1.5, 3, 10 / 9)
    j_line = life.load_zone_integrals(10 / 9, 4, 9 / 8)
    assert 1 / j_ball[0] == pytest.approx(4.37, abs=5e-3)
    assert 1 / j_line[0] == pytest.approx(4.08, abs=6e-3)  # Harris' n = 1.1 gives 4.078
    for b, stribeck in ((BALL, 4.37), (ROLLER, 4.08)):
        d = life.load_distribution(b, [2000.0, 0.0])
        ratio = float(jnp.max(d.element_loads)) * b.n_balls / 2000.0
        print(f"{type(b).__name__}: Q_max Z / F_r = {ratio:.4f} (Stribeck {stribeck})")
        assert ratio == pytest.approx(stribeck, rel=6e-3)
        assert float(d.load_zone_factor) == pytest.approx(0.5, abs=1e-12)
        assert float(d.zone_half_angle) == pytest.approx(np.pi / 2, abs=1e-12)
    many = jb.BallBearing(0.0, BALL.stiffness, 0.0, 29.2e-3, 46.6e-3, 72)
    d = life.load_distribution(many, [0.0, 5000.0])  # the load along y: element 1 follows it
    assert float(d.element_angles[0]) == pytest.approx(np.pi / 2)
    assert float(jnp.max(d.element_loads)) * 72 / 5000.0 == pytest.approx(1 / j_ball[0], rel=2e-4)


def test_harris_integrals_at_half_load_zone():
    """J_1(0.5) = 0.5625, J_2(0.5) = 0.5875 of Harris' table (point contact), and all three
    against quadrature, also for line contact."""
    assert life.load_zone_integrals(1.5, 3, 10 / 9)[1:] == pytest.approx((0.5625, 0.5875), abs=2e-4)
    for n, m, e in ((1.5, 3, 10 / 9), (10 / 9, 4, 9 / 8)):

        def mean(a):
            return quad(lambda p: np.cos(p) ** a, -np.pi / 2, np.pi / 2)[0] / (2 * np.pi)

        expected = (mean(n + 1), mean(n * m) ** (1 / m), mean(n * m * e) ** (1 / (m * e)))
        np.testing.assert_allclose(life.load_zone_integrals(n, m, e), expected, rtol=1e-10)


def _newton_reference(b, load, cage):
    """The balance sum_r Q_r u_r = F solved by scipy's hybrid method on tests/helpers.py's law,
    from a start along the load past the clearance."""
    k, c, z, n = float(b.stiffness), float(b.clearance), b.n_balls, b.exponent
    law = dict(clearance=c, stiffness=k, damping=0.0, n_balls=z, exponent=n)
    f = np.asarray(load, float)

    def residual(e):
        loads = ball_loads_ref(e, [0.0, 0.0], cage, **law)
        phi = cage + 2 * np.pi * np.arange(z) / z
        return np.array([loads @ np.cos(phi), loads @ np.sin(phi)]) / np.linalg.norm(f) - f / np.linalg.norm(f)

    start = f / np.linalg.norm(f) * (max(c, 0.0) / 2 + 2 * (np.linalg.norm(f) / (z * k)) ** (1 / n)) / np.cos(np.pi / z)
    sol = root(residual, start, method="hybr", options={"xtol": 1e-13})
    assert np.max(np.abs(residual(sol.x))) < 1e-12, sol.message  # converged to round-off
    return sol.x, ball_loads_ref(sol.x, [0.0, 0.0], cage, **law)


@pytest.mark.parametrize("kind", ["ball", "roller"])
@pytest.mark.parametrize("clearance", [-40e-6, -5e-6, 0.0, 20e-6, 80e-6])
def test_distribution_against_an_independent_newton(kind, clearance):
    """Any clearance, preload included, an oblique load and any cage position: the displacement
    and the element loads agree with scipy's root of the same balance to 1e-9 (both converge to
    round-off: residuals below 1e-12 of the load)."""
    b = with_clearance(BEARINGS[kind], clearance)
    load, cage = [1200.0, -1900.0], 0.37
    d = life.load_distribution(b, load, cage)
    e, loads = _newton_reference(b, load, cage)
    np.testing.assert_allclose(np.asarray(d.displacement), e, rtol=1e-9)
    np.testing.assert_allclose(np.asarray(d.element_loads), loads, rtol=1e-9, atol=1e-9 * np.max(loads))
    np.testing.assert_allclose(
        np.asarray(d.element_angles), 0.37 + 2 * np.pi * np.arange(b.n_balls) / b.n_balls, rtol=1e-15
    )
    assert int(d.n_loaded) == int(np.sum(loads > 1e-9 * np.max(loads)))
    # the resultant of the element loads is the load (Eq. 28)
    f = jb.laws.resultant(d.element_loads, 0.37)
    np.testing.assert_allclose(np.asarray(f), load, rtol=1e-9)


def _harris_j_r(epsilon, n):
    """Harris' J_r(epsilon) = (1/2pi) int [1 - (1 - cos psi) / (2 epsilon)]_+^n cos psi dpsi."""
    half = np.arccos(max(1.0 - 2.0 * epsilon, -1.0))
    f = lambda p: max(1.0 - (1.0 - np.cos(p)) / (2.0 * epsilon), 0.0) ** n * np.cos(p)  # noqa: E731
    return quad(f, -half, half, limit=200)[0] / (2.0 * np.pi)


@pytest.mark.parametrize("exponent", [1.5, 10 / 9])
def test_load_zone_factor_against_harris_integrals(exponent):
    """The load zone of a bearing of many elements (72, so the element sum is the integral to
    its trapezoid error: measured up to 1e-4 for point contact, 5e-4 for line contact,
    whose load falls to 0 at the zone's edge with the power 10/9, a kink the rule resolves
    worse) against Harris' F_r = Z Q_max J_r(epsilon) with
    the returned epsilon = (1 - P_d / (2 |e|)) / 2, from a wide clearance (epsilon 0.13) to a
    preload that loads every position (epsilon > 1); and the half-angle cos psi_l =
    P_d / (2 |e|)."""
    k = float((BALL if exponent == 1.5 else ROLLER).stiffness)
    # the stiffer line contacts deflect less: smaller clearances give the same load zones
    clearances = (60e-6, 10e-6, 0.0, -3e-6, -10e-6) if exponent == 1.5 else (12e-6, 4e-6, 0.0, -1e-6, -3e-6)
    for clearance in clearances:
        b = jb.BallBearing(clearance, k, 0.0, 29.2e-3, 46.6e-3, 72, exponent=exponent)
        d = life.load_distribution(b, [3000.0, 0.0])
        e = float(jnp.linalg.norm(d.displacement))
        eps = float(d.load_zone_factor)
        assert eps == pytest.approx(0.5 * (1 - clearance / (2 * e)), rel=1e-12)
        q_max = float(jnp.max(d.element_loads))
        j_r = _harris_j_r(eps, exponent)
        print(f"P_d {clearance * 1e6:5.1f} um: epsilon {eps:.4f}, F_r/(Z Q_max) {3000.0 / (72 * q_max):.5f}, J_r {j_r:.5f}")
        assert 3000.0 / (72 * q_max) == pytest.approx(j_r, rel=3e-4 if exponent == 1.5 else 1e-3)
        expected_half = np.arccos(np.clip(clearance / (2 * e), -1, 1))
        assert float(d.zone_half_angle) == pytest.approx(expected_half, rel=1e-12)


def test_zero_load_centres_the_rings():
    """No load: the rings stay centred; under a preload every element carries K (|P_d|/2)^n."""
    d = life.load_distribution(with_clearance(BALL, -10e-6), [0.0, 0.0])
    np.testing.assert_array_equal(np.asarray(d.displacement), [0.0, 0.0])
    np.testing.assert_allclose(np.asarray(d.element_loads), float(BALL.stiffness) * 5e-6**1.5, rtol=1e-14)
    assert int(d.n_loaded) == 8 and float(d.zone_half_angle) == pytest.approx(np.pi)
    d = life.load_distribution(with_clearance(BALL, 20e-6), [0.0, 0.0])
    assert int(d.n_loaded) == 0 and float(d.load_zone_factor) == 0.0


# ------------------------------------------------------------------------ reference ratings


def test_ball_ratings_are_lundberg_palmgren_s_with_iso_s_factors():
    """From C_r (ISO 281's f_c table) the raceway ratings at the conformities 0.52 are
    Lundberg–Palmgren's times b_m and the standard's reduction: the table is that closed form
    times 0.957 within 0.12 % (tests/test_life.py), so within 0.3 %; the paper's conformities
    move only their ratio."""
    ours = life.reference_ratings(BALL)
    lp = life.ball_race_load_ratings(8, 8.7e-3, 37.9e-3, 0.52, 0.52)
    np.testing.assert_allclose(np.asarray(ours), np.asarray(lp), rtol=3e-3)
    qi, qe = life.reference_ratings(BALL, groove_inner=0.5219, groove_outer=0.5194)
    g = 8.7 / 37.9
    kappa = ((1 - g) / (1 + g)) ** 1.72 * (0.5219 * (2 * 0.5194 - 1) / (0.5194 * (2 * 0.5219 - 1))) ** 0.41
    assert float(qi / qe) == pytest.approx(kappa, rel=1e-12)
    # a catalogue rating scales them
    scaled = life.reference_ratings(BALL, load_rating=2 * float(life.dynamic_rating(BALL)))
    np.testing.assert_allclose(np.asarray(scaled), 2 * np.asarray(ours), rtol=1e-12)


def test_roller_ratings_are_lundberg_palmgren_s_line_contact():
    """ISO/TR 1281-1's roller–raceway rating, q_c = 552 (1 - g)^(29/27) / (1 + g)^(1/4) g^(2/9)
    D^(29/27) L^(7/9) Z^(-1/4) [N, mm] (inner raceway; ISO 281 reduces it by 0.83 and multiplies
    it by b_m), is what the ratings from C_r give: 207.9 = 552 J_r/J_1 within 0.1 %, and f_c's
    table is rounded to 0.1, so within 0.5 %."""
    g, d, length, z = 9 / 46.5, 9.0, 10.0, 13
    q_ci = 552 * 0.83 * 1.1 * (1 - g) ** (29 / 27) / (1 + g) ** 0.25 * g ** (2 / 9) * d ** (29 / 27) * length ** (7 / 9) * z**-0.25
    qi, qe = life.reference_ratings(ROLLER)
    assert float(qi) == pytest.approx(q_ci, rel=5e-3)
    assert float(qi / qe) == pytest.approx(((1 - g) / (1 + g)) ** (143 / 108), rel=1e-12)


# ------------------------------------------------------------------------ reference life


def test_zero_clearance_life_against_iso_281():
    """At zero clearance under a pure radial load L10r is ISO 281's rating, which assumes half
    the elements loaded (Harris' continuous load zone): balls (C_r / F_r)^3 within 2 % for the
    98205's 8 balls (+1.9 % with a ball on the load line, -1.6 % straddling), rollers
    (C_r / F_r)^4 within 1 % (-0.8 %, +0.8 %). ISO 281 rates roller bearings with the exponent
    10/3, a compromise; the line contacts' own exponent 4 makes L10r / L10 = (C_r / F_r)^(2/3),
    4.6 at F_r = 0.1 C_r, and the two agree at F_r = C_r."""
    for b, p in ((BALL, 3), (ROLLER, 4)):
        c = float(life.dynamic_rating(b))
        for f in (0.1 * c, c):
            on, straddling = (
                float(life.reference_life(b, [f, 0.0], cage=cage).l10) for cage in (None, np.pi / b.n_balls)
            )
            print(f"{type(b).__name__} F_r = {f / c:.1f} C_r: L10r / (C_r/F_r)^{p} = {on / (c / f) ** p:.4f}, {straddling / (c / f) ** p:.4f}")
            assert on / (c / f) ** p == pytest.approx(1.0, abs=0.02)
            assert straddling / (c / f) ** p == pytest.approx(1.0, abs=0.02)


def test_static_life_rules():
    """The rotating ring's equivalent load is the elements' cube (m) mean, the stationary
    ring's their 10/3 (m e) mean; the ring lives (Q_c/Q_e)^m combine with slope e; a1 and the
    hours as `iso_life`'s."""
    b = with_clearance(BALL, 10e-6)
    r = life.reference_life(b, [1000.0, 300.0], cage=0.2, reliability=0.99, speed_rpm=600.0)
    q = np.asarray(life.load_distribution(b, [1000.0, 300.0], 0.2).element_loads)
    assert float(r.load_inner) == pytest.approx(np.mean(q**3) ** (1 / 3), rel=1e-13)
    assert float(r.load_outer) == pytest.approx(np.mean(q ** (10 / 3)) ** 0.3, rel=1e-13)
    qi, qe = (float(x) for x in life.reference_ratings(b))
    li, le = (qi / float(r.load_inner)) ** 3, (qe / float(r.load_outer)) ** 3
    assert float(r.life_inner) == pytest.approx(li, rel=1e-12)
    assert float(r.l10) == pytest.approx((li ** (-10 / 9) + le ** (-10 / 9)) ** -0.9, rel=1e-12)
    assert float(r.a1) == pytest.approx(0.25) and float(r.lnm) == pytest.approx(0.25 * float(r.l10))
    assert float(r.l10_hours) == pytest.approx(1e6 * float(r.l10) / (60 * 600), rel=1e-13)
    outer = life.reference_life(b, [1000.0, 300.0], cage=0.2, rotating="outer")
    assert float(outer.load_inner) == pytest.approx(float(r.load_outer), rel=1e-13)
    assert life.reference_life(b, [1000.0, 0.0]).l10_hours is None
    rr = life.reference_life(with_clearance(ROLLER, 10e-6), [4000.0, 0.0])
    q = np.asarray(life.load_distribution(with_clearance(ROLLER, 10e-6), [4000.0, 0.0]).element_loads)
    assert float(rr.load_inner) == pytest.approx(np.mean(q**4) ** 0.25, rel=1e-13)
    assert float(rr.load_outer) == pytest.approx(np.mean(q**4.5) ** (2 / 9), rel=1e-13)
    li, le = (float(x) for x in (rr.life_inner, rr.life_outer))
    assert float(rr.l10) == pytest.approx((li ** (-9 / 8) + le ** (-9 / 8)) ** (-8 / 9), rel=1e-12)


@pytest.mark.parametrize("kind", ["ball", "roller"])
def test_life_against_clearance_peaks_at_a_small_preload(kind):
    """Under 0.1 C_r the life is largest at a small preload (measured: -0.15 % of D for the
    98205, -0.05 % for the NU 206), some 7 % (13 %) above zero clearance, and falls steeply with
    heavy preload (-1 % of D, the rules' limit: below 1 % of the largest) and with a large
    clearance (+1 % of D: below 35 %), as Harris & Kotzalas show."""
    b = BEARINGS[kind]
    d, c = float(b.ball_diameter), float(life.dynamic_rating(b))
    fractions = np.linspace(-0.01, 0.01, 81)
    lives = np.array(
        [float(life.reference_life(with_clearance(b, x * d), [0.1 * c, 0.0]).l10) for x in fractions]
    )
    best = int(np.argmax(lives))
    zero = int(np.argmin(np.abs(fractions)))
    print(f"{kind}: largest L10r at P_d = {fractions[best]:.5f} D, {lives[best] / lives[zero]:.3f} x zero clearance")
    assert -0.003 < fractions[best] < 0.0
    assert lives[best] > 1.05 * lives[zero]
    assert lives[0] < 0.01 * lives[best] and lives[-1] < 0.35 * lives[best]
    assert np.all(np.diff(lives[: best + 1]) > 0) and np.all(np.diff(lives[best:]) < 0)


@pytest.mark.parametrize("kind", ["ball", "roller"])
def test_static_derivatives_match_central_differences(kind):
    """d log L10r / d P_d through the load distribution (implicit function theorem) and the life,
    against central differences of the concrete (NumPy) solution: within 1e-5 (measured 1e-6 or
    better; the step of 1e-9 m leaves truncation ~1e-7 and round-off ~1e-7), at a preload, zero
    clearance and a clearance; and the jitted solution equals the NumPy one."""
    b = BEARINGS[kind]
    load = jnp.array([0.1 * float(life.dynamic_rating(b)), 0.0])

    def log_life(c):
        return jnp.log(life.reference_life(with_clearance(b, c), load).l10)

    grad = jax.jit(jax.grad(log_life))
    for c in (-8e-6, 0.0, 20e-6):
        h = 1e-9
        fd = (float(log_life(c + h)) - float(log_life(c - h))) / (2 * h)
        print(f"{kind} {c * 1e6:+.0f} um: {float(grad(c)):.6e} (central difference {fd:.6e}) 1/m")
        assert float(grad(c)) == pytest.approx(fd, rel=1e-5)
        assert float(jax.jit(log_life)(c)) == pytest.approx(float(log_life(c)), rel=1e-12)
    # and in the load: at zero clearance the element loads are proportional to it, L10r to F^-m
    g = jax.grad(lambda f: jnp.log(life.reference_life(b, f).l10))(load)
    assert float(g[0]) == pytest.approx(-b.raceway_exponent / float(load[0]), rel=1e-8)  # the shift, 1e-9
    assert float(g[1]) == pytest.approx(0.0, abs=1e-9 / float(load[0]))


# ------------------------------------------------------------------------------- inputs


@pytest.mark.parametrize(
    "call, error, message",
    [
        (lambda: life.load_distribution(BALL, [1.0, 2.0, 3.0]), ValueError, r"load must be the radial load vector"),
        (lambda: life.load_distribution(BALL, [np.nan, 0.0]), ValueError, r"load must be finite"),
        (lambda: life.load_distribution("6205", [1.0, 0.0]), TypeError, r"bearing must be"),
        (lambda: life.load_distribution(BALL, [1.0, 0.0], cage=[0.0, 1.0]), ValueError, r"cage must be one angle"),
        (lambda: life.load_distribution(with_clearance(BALL, -1e-4), [1.0, 0.0]), ValueError,
         r"clearance must be at least -0\.01 of the ball diameter"),
        (lambda: life.reference_life(BALL, [1.0, 0.0], rotating="cage"), ValueError, r"rotating must be"),
        (lambda: life.reference_life(ROLLER, [1.0, 0.0], groove_inner=0.52), ValueError, r"line contacts have none"),
        (lambda: life.reference_life(BALL, [1.0, 0.0], groove_outer=0.5), ValueError, r"groove_outer .* must exceed 0\.5"),
        (lambda: life.reference_life(BALL, [1.0, 0.0], load_rating=-1.0), ValueError, r"load_rating must be positive"),
        (lambda: life.reference_life(BALL, [1.0, 0.0], speed_rpm=0.0), ValueError, r"speed_rpm must be positive"),
        (lambda: life.reference_life(BALL, [1.0, 0.0], t_min=0.1), TypeError, r"static form"),
        (lambda: life.metric("reference", cage=0.1), TypeError, r"cage belong to reference_life's static form"),
    ],
)
def test_bad_inputs_raise(call, error, message):
    with pytest.raises(error, match=message):
        call()


# ------------------------------------------------------------------------- from a Solution

MASS, SPEED = 100.0, 100.0  # [kg], [rad/s]: a steady load of 981 N on a rotor at 955 rpm
WINDOW = (0.01, 0.01 + 2 * np.pi / SPEED)  # [s] one revolution after a settling time


def _rotor(b, start_at=None):
    """The rotor of `cases.rotor` carried by ``b`` under its weight, its inner ring (the shaft)
    turning, outer ring fixed, started at the static displacement of ``start_at`` (a bearing;
    default ``b``) so that it barely vibrates."""
    d = life.load_distribution(start_at or b, [0.0, -MASS * 9.80665], cage=0.0)  # the cage at t0
    offset = tuple(float(x) for x in d.displacement)
    return jb.cases.rotor(b, mass=MASS, speed=SPEED, initial_offset=offset, window_start=WINDOW[0])


@pytest.fixture(scope="module")
def rotor_runs():
    """(bearing, model, solution) of ball and roller bearings at a preload and a clearance (one
    compiled solve per bearing kind), with the paper's switched ball force. The segment slots
    are those a run of 0.03 s gets by default, ample for this one (its default for 0.073 s
    would double them): the ball's solve is then tests/test_rollers.py's, on the same worker
    (tests/conftest.py)."""
    runs, options = [], jb.SolveOptions(max_segments=256)
    for b in (
        with_clearance(BALL, -10e-6), with_clearance(BALL, 0.0), with_clearance(BALL, 20e-6),
        with_clearance(ROLLER, -5e-6), with_clearance(ROLLER, 20e-6),
    ):  # fmt: skip
        model = _rotor(b)
        runs.append((b, model, jb.simulate(model, WINDOW[1], jnp.array([0.0, *WINDOW]), options=options)))
    return runs


def test_simulated_steady_load_gives_the_static_life(rotor_runs):
    """A shaft turning under a steady load: the life from the simulation (rotating=None: the
    ring points; "inner": the elements' means) equals the static L10r averaged over the cage
    positions, within 0.5 % for the balls and the preloaded rollers (measured 0.35 %) and 3 %
    for the rollers in clearance (measured 2.3 %: their few loaded rollers make the rotor
    vibrate at the roller-pass frequency, peak roller load 6 % above the static one). At t0
    the dynamics' element loads are the static ones; under a preload the paper force starts
    with every compressed element engaged, those 90 degrees from the load by the preload
    alone, and switches them at events as the cage turns."""
    for b, model, sol in rotor_runs:
        static = np.mean([
            float(life.reference_life(b, [0.0, -MASS * 9.80665], cage=-np.pi / 2 + a).l10)
            for a in np.linspace(0.0, 2 * np.pi / b.n_balls, 9)[:-1]
        ])  # fmt: skip
        points, elements = (life.reference_life(sol, model, rotating=r) for r in (None, "inner"))
        c = float(b.clearance)
        tol = 0.03 if isinstance(b, jb.RollerBearing) and c > 0 else 0.005
        print(f"{type(b).__name__} {c * 1e6:+.0f} um: L10r {float(points.l10):.5g} (elements {float(elements.l10):.5g}), static {static:.5g}")
        assert float(points.l10) == pytest.approx(static, rel=tol)
        assert float(elements.l10) == pytest.approx(static, rel=tol)
        assert float(points.speed) == pytest.approx(SPEED * 60 / (2 * np.pi), rel=1e-9)
        # at rest at t0 (cage angle 0) the law of the dynamics gives the static element loads (to
        # round-off: another program, and the displacement passed through the model's q0)
        at_rest = life.load_distribution(b, [0.0, -MASS * 9.80665], cage=0.0).element_loads
        np.testing.assert_allclose(np.asarray(sol.ball_loads[0]), np.asarray(at_rest), rtol=1e-10, atol=1e-9)
    preloaded = rotor_runs[0][2]  # 5 balls engaged at t0, 2 of them by the preload alone (at 0 and 180 degrees)
    assert np.sum(np.asarray(preloaded.ball_loads[0]) > 0) == 5 and int(preloaded.stats["num_events"]) > 0


def test_reference_life_of_a_solution_against_lundberg_palmgren_and_the_metric(rotor_runs):
    """With ISO 281's conformities the raceway ratings are Lundberg–Palmgren's within 0.3 %
    (test_ball_ratings_are_lundberg_palmgren_s_with_iso_s_factors), so the two lives of the
    same ring-point records agree within 1 %; the metric is the function; the window's and
    the options' rules are `lp_life`'s."""
    b, model, sol = rotor_runs[1]
    ref = life.reference_life(sol, model)
    lp = life.lp_life(sol, model, groove_inner=0.52, groove_outer=0.52)
    assert float(ref.l10) == pytest.approx(float(lp.l10), rel=0.01)
    assert float(ref.load_inner) == pytest.approx(float(lp.load_inner), rel=1e-12)
    for unit, field in (("hours", "l10_hours"), ("mrev", "l10")):
        metric = life.metric("reference", unit, rotating="inner")
        assert float(metric.value(sol, model)) == float(getattr(life.reference_life(sol, model, rotating="inner"), field))
    assert float(life.l10_hours(sol, model, "reference")) == float(ref.l10_hours)
    assert life.metric("reference").label == "life.metric('reference')"
    with pytest.raises(TypeError, match="takes no cage or speed_rpm"):
        life.reference_life(sol, model, cage=0.0)
    with pytest.raises(ValueError, match="window_edges"):
        life.reference_life(sol, model, t_min=0.0123)
    with pytest.raises(ValueError, match="rotating"):
        life.reference_life(sol, model, rotating="crank")


@pytest.mark.slow  # ~1 min: two forward-mode compiles of the rotor
@pytest.mark.parametrize("kind, clearance", [("ball", -10e-6), ("roller", 10e-6)])
def test_simulated_life_derivative_matches_central_differences(kind, clearance):
    """d log L10r / d P_d through the whole simulation (forward mode, smooth element force,
    rtol 1e-10) against central differences of whole solves: within 1 % (measured 7e-5 and
    4e-5: the step of 2e-8 m leaves truncation and solver noise well below it). The rotor starts at
    the nominal clearance's static displacement, so a perturbed run settles by a few
    nanometres within the 10 ms before the window."""
    import diffrax

    b = type(BEARINGS[kind]).from_catalogue("98205" if kind == "ball" else "NU206", clearance=clearance, ball_force="smooth")
    base = _rotor(b)
    controller = jb.default_controller(rtol=1e-10, atol=1e-14)

    def log_life(c, adjoint=None):
        model = jb.paths.replace(base, {"bearing.clearance": c})
        sol = jb.simulate(model, WINDOW[1], jnp.array([0.0, *WINDOW]), stepsize_controller=controller, adjoint=adjoint)
        return jnp.log(life.reference_life(sol, model).l10)

    grad = float(jax.jit(jax.jacfwd(lambda c: log_life(c, diffrax.ForwardMode())))(clearance))
    h = 2e-8
    values = jax.jit(log_life)
    fd = (float(values(clearance + h)) - float(values(clearance - h))) / (2 * h)
    print(f"{kind} {clearance * 1e6:+.0f} um: d log L10r / d P_d {grad:.6e} (central difference {fd:.6e}) 1/m")
    assert grad == pytest.approx(fd, rel=0.01)

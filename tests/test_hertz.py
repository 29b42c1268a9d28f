"""Tests of jaxbearing.laws.hertz against independent truths.

Truths: scipy's elliptic integrals (Cephes, independent of our AGM), the Harris ellipticity
equation solved with scipy's brentq, the exact sphere limit and its series, the Hamrock–Brewe
curve fits, the paper's stiffness numbers (Xu 2014, Sect. 3 and 4), and central finite
differences for gradients. The paper's K_i and K_o are a regression anchor rather than an
independent truth: the groove ratios F_I and F_O were fitted to them through this Eq. 10
(docs/model.md); the hand calculation and the brentq tests check Eq. 10 itself.
"""

import jax

jax.config.update("jax_enable_x64", True)

import jax.numpy as jnp  # noqa: E402
import numpy as np  # noqa: E402
import pytest  # noqa: E402
import scipy.special as sps  # noqa: E402
from scipy.optimize import brentq  # noqa: E402

from jaxbearing.laws import hertz  # noqa: E402

# SKF 98205 (paper Table 2), SI units.
D = 8.7e-3
DM = 37.9e-3
E_STEEL = 207e9
NU_STEEL = 0.3
# groove ratios fitted to the paper's K_i, K_o (the paper omits them; docs/model.md, 'Groove
# curvature ratios')
F_I, F_O = 0.5219, 0.5194


# ---------------------------------------------------------------------------- elliptic integrals


def test_elliptic_integrals_match_scipy():
    # Both sides are float64 implementations of the same functions; the AGM converges to
    # machine precision in 10 steps, so agreement is limited only by rounding (~1e-15).
    m = np.concatenate([np.linspace(0.0, 0.999, 2001), 1.0 - np.geomspace(1e-3, 1e-8, 11)])
    k, e = hertz.elliptic_integrals(m)
    np.testing.assert_allclose(np.asarray(k), sps.ellipk(m), rtol=1e-13, atol=0)
    np.testing.assert_allclose(np.asarray(e), sps.ellipe(m), rtol=1e-13, atol=0)


def test_elliptic_integral_derivatives():
    # dK/dm = (E - (1-m) K) / (2 m (1-m)), dE/dm = (E - K) / (2 m)  (DLMF 19.4.1), evaluated
    # with scipy's K and E; their limits at m = 0 are pi/8 and -pi/8.
    m = np.linspace(0.0, 0.99, 34)
    dk, de = jax.vmap(jax.jacfwd(hertz.elliptic_integrals))(jnp.asarray(m))
    k, e, mm = sps.ellipk(m[1:]), sps.ellipe(m[1:]), m[1:]
    np.testing.assert_allclose(
        np.asarray(dk[1:]), (e - (1 - mm) * k) / (2 * mm * (1 - mm)), rtol=1e-11
    )
    np.testing.assert_allclose(np.asarray(de[1:]), (e - k) / (2 * mm), rtol=1e-11)
    np.testing.assert_allclose(np.asarray([dk[0], de[0]]), [np.pi / 8, -np.pi / 8], rtol=1e-14)


# ---------------------------------------------------------------------------- ellipticity


def _harris_f(kappa):
    """Harris' curvature difference of an ellipse of ellipticity kappa, with scipy."""
    m = 1.0 - 1.0 / kappa**2
    k, e = sps.ellipk(m), sps.ellipe(m)
    return ((kappa**2 + 1) * e - 2 * k) / ((kappa**2 - 1) * e)


def _harris_delta(kappa):
    """Harris' dimensionless deflection of an ellipse of ellipticity kappa, with scipy."""
    m = 1.0 - 1.0 / kappa**2
    return 2 * sps.ellipk(m) / np.pi * np.cbrt(np.pi / (2 * kappa**2 * sps.ellipe(m)))


def _kappa_brentq(f):
    # F(kappa) ~ (3/4) ln(kappa) near 1, so the root lies above 1 + f; kappa = 1e4 gives
    # F ~ 1 - 2e-7. Stay off kappa = 1 where the printed formula is 0/0.
    return brentq(lambda k: _harris_f(k) - f, 1.0 + f, 1e4, xtol=1e-14, rtol=1e-15, maxiter=200)


# Up to F = 0.995 (kappa ~ 40): F of bearings lies near 0.9. The solution's conditioning
# grows like 1/(1 - F), so 1e-10 leaves more than two digits of margin there.
F_GRID = np.array(
    [1e-3, 0.01, 0.1, 0.3, 0.5, 0.7, 0.8, 0.88, 0.9, 0.92, 0.94, 0.96, 0.98, 0.99, 0.995]
)
F_SPHERE = np.array([0.0, 1e-8, 1e-6, 1e-4, 1e-3, 1e-2])
R_HB = np.geomspace(1.0, 10.0, 15)  # R_y/R_x
F_HB = (R_HB - 1) / (R_HB + 1)


@pytest.fixture(scope="module")
def shapes():
    """kappa and delta* on all the grids above, in one batched call each (one compilation)."""
    f = np.concatenate([F_GRID, F_SPHERE, F_HB])
    kappa = np.asarray(hertz.ellipticity(f))
    delta = np.asarray(hertz.dimensionless_deflection(f))
    cuts = np.cumsum([len(F_GRID), len(F_SPHERE)])
    pairs = zip(np.split(kappa, cuts), np.split(delta, cuts), strict=True)
    return dict(zip(["grid", "sphere", "hb"], pairs, strict=True))


def test_ellipticity_and_deflection_match_brentq(shapes):
    kappa, delta = shapes["grid"]
    kappa_ref = np.array([_kappa_brentq(f) for f in F_GRID])
    np.testing.assert_allclose(kappa, kappa_ref, rtol=1e-10)
    np.testing.assert_allclose(delta, _harris_delta(kappa_ref), rtol=1e-10)


def test_sphere_limit(shapes):
    # F = 0 is a circular contact: kappa = 1, K = E = pi/2, so delta* = 1 exactly.
    # Series of Harris' equation about the sphere (sympy, from the power series of K and E):
    # F = 3m/8 + 3m^2/16 + ..., hence kappa = 1 + 4F/3 + 8F^2/9 + 22F^3/27 + O(F^4) and
    # delta* = 1 - 2F^2/9 + O(F^4). The O(F^4) remainders are below F^4 for F <= 0.01.
    kappa, delta = shapes["sphere"]
    f = F_SPHERE
    assert kappa[0] == 1.0
    assert delta[0] == pytest.approx(1.0, abs=1e-15)
    kappa_series = 1 + 4 * f / 3 + 8 * f**2 / 9 + 22 * f**3 / 27
    assert np.all(np.abs(kappa - kappa_series) <= f**4 + 1e-15)
    assert np.all(np.abs(delta - (1 - 2 * f**2 / 9)) <= f**4 + 1e-15)


def test_hamrock_brewe_fits(shapes):
    # Hamrock & Brewe (1983) curve fits, quoted to about 3 % for 1 <= R_y/R_x <= 10:
    # kappa ~ 1.0339 r^0.636, K ~ 1.5277 + 0.6023 ln r, E ~ 1.0003 + 0.5968 / r (K, E here
    # from scipy at our kappa).
    kappa, _ = shapes["hb"]
    m = 1 - 1 / kappa**2
    np.testing.assert_allclose(kappa, 1.0339 * R_HB**0.636, rtol=0.035)  # fit is 3.39 % at r = 1
    np.testing.assert_allclose(sps.ellipk(m), 1.5277 + 0.6023 * np.log(R_HB), rtol=0.03)
    np.testing.assert_allclose(sps.ellipe(m), 1.0003 + 0.5968 / R_HB, rtol=0.03)


def test_shape_gradients_match_implicit_derivatives():
    # dkappa/dF = 1 / (dF/dkappa) and ddelta*/dF = (ddelta*/dkappa) / (dF/dkappa), with the
    # kappa-derivatives by central differences (step 1e-5 kappa, error ~1e-9) of scipy's
    # functions at brentq's kappa. At the sphere: dkappa/dF = 4/3, ddelta*/dF = 0 (series).
    f = [0.1, 0.5, 0.9, 0.95]
    dkappa = jax.vmap(jax.grad(hertz.ellipticity))(jnp.asarray([0.0] + f))
    ddelta = jax.vmap(jax.grad(hertz.dimensionless_deflection))(jnp.asarray([0.0] + f))
    assert float(dkappa[0]) == pytest.approx(4.0 / 3.0, rel=1e-14)
    assert float(ddelta[0]) == pytest.approx(0.0, abs=1e-14)
    kappa = np.array([_kappa_brentq(x) for x in f])
    h = 1e-5 * kappa
    dfdk = (_harris_f(kappa + h) - _harris_f(kappa - h)) / (2 * h)
    dddk = (_harris_delta(kappa + h) - _harris_delta(kappa - h)) / (2 * h)
    np.testing.assert_allclose(np.asarray(dkappa[1:]), 1 / dfdk, rtol=1e-7)
    np.testing.assert_allclose(np.asarray(ddelta[1:]), dddk / dfdk, rtol=1e-7)


# ---------------------------------------------------------------------------- the paper's numbers


def test_curvature_sums_skf98205():
    # Hand evaluation of Harris' formulas: gamma = 8.7/37.9.
    g = D / DM
    rho_i, f_i, rho_o, f_o = hertz.curvature_sums(D, DM, F_I, F_O)
    assert float(rho_i) == pytest.approx((4 - 1 / F_I + 2 * g / (1 - g)) / D, rel=1e-14)
    assert float(rho_o) == pytest.approx((4 - 1 / F_O - 2 * g / (1 + g)) / D, rel=1e-14)
    assert float(f_i) == pytest.approx(0.937366, abs=1e-6)
    assert float(f_o) == pytest.approx(0.912184, abs=1e-6)
    # A contact angle enters only through gamma = D cos(alpha) / d_m.
    alpha = 0.3
    np.testing.assert_allclose(
        np.asarray(hertz.curvature_sums(D, DM, F_I, F_O, alpha)),
        np.asarray(hertz.curvature_sums(D, DM / np.cos(alpha), F_I, F_O)),
        rtol=1e-14,
    )


def test_skf98205_reproduces_paper_stiffness():
    # Paper Sect. 3: K_i = 2.57e10, K_o = 2.86e10, K_b = 9.57e9 N/m^1.5 (three digits printed,
    # f_i and f_o not given; 1 % covers the rounding and the fitted f's).
    k_i, k_o, k_b = hertz.bearing_stiffness(D, DM, F_I, F_O, E_STEEL, NU_STEEL)
    assert float(k_i) == pytest.approx(2.57e10, rel=0.01)
    assert float(k_o) == pytest.approx(2.86e10, rel=0.01)
    assert float(k_b) == pytest.approx(9.57e9, rel=0.01)
    # Eq. 11 by hand.
    assert float(k_b) == pytest.approx(
        (float(k_i) ** (-2 / 3) + float(k_o) ** (-2 / 3)) ** -1.5, rel=1e-14
    )


def test_swapped_groove_ratios_give_same_ball_stiffness():
    # docs/model.md, 'Groove curvature ratios': labels swapped (0.5162/0.5267) fit too: K_i, K_o
    # exchange, K_b unchanged.
    k_i, k_o, k_b = hertz.bearing_stiffness(D, DM, 0.5162, 0.5267, E_STEEL, NU_STEEL)
    assert float(k_i) == pytest.approx(2.86e10, rel=0.01)
    assert float(k_o) == pytest.approx(2.57e10, rel=0.01)
    assert float(k_b) == pytest.approx(9.57e9, rel=0.01)


def test_impact_stiffness_paper_value():
    # Paper Sect. 4: K_d = 1.07e10 N/m^1.5 for R = 0.01 m, steel on steel. Closed form:
    # h = (1 - nu^2)/(pi E), K_d = 4/(3 pi 2h) sqrt(R/2).
    k_d = float(hertz.impact_stiffness(0.01, 0.01, E_STEEL, NU_STEEL))
    assert k_d == pytest.approx(1.07e10, rel=0.01)
    h = (1 - NU_STEEL**2) / (np.pi * E_STEEL)
    assert k_d == pytest.approx(4 / (3 * np.pi * 2 * h) * np.sqrt(0.005), rel=1e-14)
    # Explicit second material equal to the first gives the same; a softer one less.
    same = hertz.impact_stiffness(0.01, 0.01, E_STEEL, NU_STEEL, E_STEEL, NU_STEEL)
    assert float(same) == pytest.approx(k_d, rel=1e-15)
    assert float(hertz.impact_stiffness(0.01, 0.01, E_STEEL, NU_STEEL, 70e9, 0.33)) < k_d


def test_race_and_ball_stiffness_by_hand():
    # Eq. 10 for a ball of radius R on a flat (F = 0, delta* = 1, sum_rho = 2/R):
    # K = 2 sqrt(2) E' / (3 sqrt(sum_rho)) is the classical Hertz K = (4/3) E* sqrt(R) with
    # E* = E'/2 for two bodies of one material.
    radius = 0.004
    k = float(hertz.race_stiffness(2.0 / radius, 0.0, E_STEEL, NU_STEEL))
    e_star = E_STEEL / (1 - NU_STEEL**2) / 2
    assert k == pytest.approx(4 / 3 * e_star * np.sqrt(radius), rel=1e-14)
    # Same law as the impact of a sphere on a flat (R_k -> infinity in Eq. 24).
    assert k == pytest.approx(
        float(hertz.impact_stiffness(radius, 1e12, E_STEEL, NU_STEEL)), rel=1e-12
    )
    # Two equal contacts in series: deflection doubles at a given load, K_b = K / 2^(3/2).
    assert float(hertz.ball_stiffness(k, k)) == pytest.approx(k / 2**1.5, rel=1e-14)


# ---------------------------------------------------------------------------- transformations


def _k_ball(f_i, d):
    return hertz.bearing_stiffness(d, DM, f_i, F_O, E_STEEL, NU_STEEL)[2]


def test_gradient_matches_central_differences():
    # Relative step 1e-5: truncation ~ (h^2/6) |d3K/df3 / dK/df| ~ 1e-8 (K ~ f^-9), rounding
    # ~ 1e-11: both far below the 1e-6 asked for.
    grads = jax.grad(_k_ball, argnums=(0, 1))(F_I, D)
    for argnum, x0 in [(0, F_I), (1, D)]:
        h = 1e-5 * x0
        plus, minus = [F_I, D], [F_I, D]
        plus[argnum] += h
        minus[argnum] -= h
        fd = (float(_k_ball(*plus)) - float(_k_ball(*minus))) / (2 * h)
        assert float(grads[argnum]) == pytest.approx(fd, rel=1e-6)


def test_jit_and_vmap():
    eager = hertz.bearing_stiffness(D, DM, F_I, F_O, E_STEEL, NU_STEEL)
    jitted = jax.jit(hertz.bearing_stiffness)(D, DM, F_I, F_O, E_STEEL, NU_STEEL)
    np.testing.assert_allclose(np.asarray(jitted), np.asarray(eager), rtol=1e-14)

    f_i = jnp.linspace(0.505, 0.56, 7)
    batched = jax.vmap(hertz.bearing_stiffness, in_axes=(None, None, 0, None, None, None))(
        D, DM, f_i, F_O, E_STEEL, NU_STEEL
    )
    looped = [hertz.bearing_stiffness(D, DM, float(f), F_O, E_STEEL, NU_STEEL) for f in f_i]
    np.testing.assert_allclose(np.asarray(batched), np.asarray(looped).T, rtol=1e-14)
    # A tighter groove (f -> 0.5) conforms more: stiffer inner contact.
    assert np.all(np.diff(np.asarray(batched[0])) < 0)

    radii = jnp.array([0.005, 0.01, 0.02])
    k_d = jax.jit(jax.vmap(hertz.impact_stiffness, in_axes=(0, 0, None, None)))(
        radii, radii, E_STEEL, NU_STEEL
    )
    # Equal radii R: K_d grows like sqrt(R / 2).
    k_ref = float(hertz.impact_stiffness(0.01, 0.01, E_STEEL, NU_STEEL))
    np.testing.assert_allclose(
        np.asarray(k_d), k_ref * np.sqrt(np.asarray(radii) / 0.01), rtol=1e-14
    )


# ---------------------------------------------------------------------------- validation

GOOD = dict(
    ball_diameter=D,
    pitch_diameter=DM,
    groove_inner=F_I,
    groove_outer=F_O,
    youngs_modulus=E_STEEL,
    poisson_ratio=NU_STEEL,
    contact_angle=0.0,
)


@pytest.mark.parametrize(
    "name, value, expected",
    [
        ("ball_diameter", 0.0, "ball_diameter"),
        ("ball_diameter", -1e-3, "ball_diameter"),
        ("pitch_diameter", 5e-3, "pitch_diameter"),
        ("groove_inner", 0.5, "groove curvature ratio"),
        ("groove_inner", 0.45, "must exceed 0.5"),
        ("groove_outer", 0.5, "groove_outer"),
        ("groove_outer", 0.3, "must exceed 0.5"),
        ("youngs_modulus", 0.0, "youngs_modulus"),
        ("youngs_modulus", -2e11, "youngs_modulus"),
        ("poisson_ratio", 0.5, "poisson_ratio"),
        ("poisson_ratio", 0.0, "poisson_ratio"),
        ("poisson_ratio", -0.1, "poisson_ratio"),
        ("contact_angle", -0.1, "contact_angle"),
        ("contact_angle", 2.0, "contact_angle"),
    ],
)
def test_bearing_stiffness_rejects_bad_input(name, value, expected):
    with pytest.raises(ValueError, match=expected) as info:
        hertz.bearing_stiffness(**{**GOOD, name: value})
    assert name in str(info.value)
    assert "got" in str(info.value)  # the offending value is reported


@pytest.mark.parametrize(
    "name, value",
    [
        ("radius_j", 0.0),
        ("radius_k", -0.01),
        ("youngs_j", 0.0),
        ("poisson_j", 0.5),
        ("youngs_k", -1.0),
        ("poisson_k", 0.7),
    ],
)
def test_impact_stiffness_rejects_bad_input(name, value):
    good = dict(radius_j=0.01, radius_k=0.01, youngs_j=E_STEEL, poisson_j=NU_STEEL)
    with pytest.raises(ValueError, match=name):
        hertz.impact_stiffness(**{**good, name: value})


@pytest.mark.parametrize("f", [-0.1, 1.0, 1.5])
def test_ellipticity_rejects_bad_curvature_difference(f):
    with pytest.raises(ValueError, match="curvature_difference"):
        hertz.ellipticity(f)


def test_ball_stiffness_rejects_non_positive():
    with pytest.raises(ValueError, match="k_outer"):
        hertz.ball_stiffness(1e10, 0.0)


def test_traced_inputs_are_not_checked():
    # Under jit, validation cannot raise; the function still traces and runs.
    out = jax.jit(hertz.bearing_stiffness)(D, DM, 0.49, F_O, E_STEEL, NU_STEEL)
    assert len(out) == 3

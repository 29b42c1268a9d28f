"""Hertzian point-contact stiffness from geometry (paper Eqs. 10, 11, 24, 25).

Two elastic bodies pressed together by a load Q touch over an ellipse of semi-axes a >= b and
approach each other by

    delta = K^(-2/3) Q^(2/3),   i.e.   Q = K delta^(3/2),

with a stiffness constant K [N/m^1.5] that depends only on the curvatures at the contact point
and on the materials (Hertz 1881; Harris & Kotzalas, *Rolling Bearing Analysis*, 5th ed., Wiley
2006, ch. 6). The geometry enters through two numbers:

- the curvature sum  sum_rho = 1/r_x1 + 1/r_y1 + 1/r_x2 + 1/r_y2  [1/m]
  (concave surfaces, such as a raceway groove, count negative), and
- the curvature difference  F(rho) = ((rho_x1 - rho_y1) + (rho_x2 - rho_y2)) / sum_rho,
  0 <= F < 1, which fixes the shape of the contact ellipse.

The ellipticity kappa = a/b solves the transcendental equation (Harris Eq. 6.26)

    F(rho) = ((kappa^2 + 1) E(m) - 2 K(m)) / ((kappa^2 - 1) E(m)),   m = 1 - 1/kappa^2,

with K(m), E(m) the complete elliptic integrals of the first and second kind (parameter m = k^2,
as in scipy), and the dimensionless deflection is

    delta* = (2 K(m) / pi) * (pi / (2 kappa^2 E(m)))^(1/3).

For a ball between two raceways (paper Eq. 10, balls and rings of one material E, nu):

    K_{i,o} = 2 sqrt(2) E' / (3 sqrt(sum_rho_{i,o})) * delta*_{i,o}^(-3/2),   E' = E/(1 - nu^2),

and the two contacts of one ball act in series (Eq. 11):

    K_b = (1 / ((1/K_i)^(2/3) + (1/K_o)^(2/3)))^(3/2).

A cylindrical roller touches its raceways along lines. Its load–deflection law is Palmgren's
empirical one for bearing steel (Palmgren, *Ball and Roller Bearing Engineering*, 1959; Harris &
Kotzalas, *Essential Concepts of Bearing Technology*, 5th ed., 2006, ch. 6): one contact of
effective length l approaches by delta = 3.84e-5 Q^0.9 / l^0.8 (mm, N), independent of the
curvatures, so a roller between two raceways (the contacts in series) carries

    Q = K_r delta^(10/9),   K_r = 2^(-10/9) (3.84e-5)^(-10/9) l^(8/9)   [N/mm^(10/9), l in mm].

The largest contact pressure of a point contact is p_max = 3 Q / (2 pi a b) with the ellipse's
semi-axes a = a* (3 Q / (E' sum_rho))^(1/3), b = b* (...)^(1/3), a* = (2 kappa^2 E(m) / pi)^(1/3),
b* = (2 E(m) / (pi kappa))^(1/3) (Harris & Kotzalas, ch. 6); of a line contact of length l,
p_max = sqrt(Q E' sum_rho / (2 pi l)) (the contact half-width b = sqrt(8 Q / (pi l E' sum_rho))),
E' = E / (1 - nu^2) as above.

For the impact of two spheres (or circular profiles) of radii R_j, R_k (Eqs. 24–25):

    K_d = 4 / (3 pi (h_j + h_k)) * sqrt(R_j R_k / (R_j + R_k)),   h_u = (1 - nu_u^2) / (pi E_u).

Numerics. K and E come from the arithmetic–geometric mean (fixed 10 steps; quadratic
convergence gives float64 precision for 1 - m down to 1e-8). The curvature-difference function is
evaluated in a cancellation-free form (see `laws._ellipse`), so it is accurate also at
kappa -> 1 (the sphere limit, F -> 0). `ellipticity` is solved by safeguarded Newton in log(kappa)
from the Hamrock–Brewe estimate and differentiated implicitly (`jax.custom_jvp`), so gradients
are exact and do not depend on the iteration history. Every function is pure, elementwise,
float64, and safe under `jax.jit`, `jax.vmap` and `jax.grad`. Concrete inputs are validated with
a `ValueError` that names the parameter, and evaluated in NumPy with the same steps, so that
building a bearing compiles nothing (`_checks.evaluate`); traced inputs are not checked here, and
are evaluated in `jax.numpy` inside the caller's program.
"""

from __future__ import annotations

from .. import _checks
from . import rules
from ._ellipse import elliptic, shape

__all__ = [
    "elliptic_integrals",
    "curvature_sums",
    "ellipticity",
    "dimensionless_deflection",
    "race_stiffness",
    "ball_stiffness",
    "bearing_stiffness",
    "impact_stiffness",
    "roller_stiffness",
    "roller_curvature_sums",
    "point_contact_stress",
    "line_contact_stress",
]

# delta = 3.84e-5 Q^0.9 / l^0.8 [mm] (Q in N, l in mm) of one line contact between steel bodies
PALMGREN_LINE = 3.84e-5


def elliptic_integrals(m):
    """Complete elliptic integrals (K(m), E(m)) of parameter m = k^2, 0 <= m < 1.

    K(m) = int_0^{pi/2} (1 - m sin^2 t)^(-1/2) dt,  E(m) = int_0^{pi/2} (1 - m sin^2 t)^(1/2) dt
    (scipy's ``ellipk``/``ellipe`` convention), by the arithmetic–geometric mean with a fixed
    number of steps: K = pi / (2 AGM(1, sqrt(1 - m))), E = K (1 - sum_n 2^(n-1) c_n^2).
    Derivatives in closed form (DLMF 19.4.1), finite at m = 0. Dimensionless.
    """
    return _checks.evaluate(elliptic, _checks.as_float(m, "elliptic parameter m", "-"))


# --------------------------------------------------------------------------------------------
# Contact geometry
# --------------------------------------------------------------------------------------------


def groove_rules(xp, groove_inner, groove_outer):
    """The rules of a ball's raceway conformities f_i, f_o (`jaxbearing._checks`)."""
    return [
        (
            xp.asarray(groove_inner) <= 0.5,
            "groove_inner (inner raceway groove curvature ratio f_i = r_i/D) must exceed 0.5",
            groove_inner,
        ),
        (
            xp.asarray(groove_outer) <= 0.5,
            "groove_outer (outer raceway groove curvature ratio f_o = r_o/D) must exceed 0.5",
            groove_outer,
        ),
    ]


def _geometry_rules(xp, ball_diameter, pitch_diameter, groove_inner, groove_outer, contact_angle):
    return [
        _checks.positive(xp, "ball_diameter", ball_diameter, "m"),
        rules.pitch_exceeds_ball(xp, pitch_diameter, ball_diameter),
        *groove_rules(xp, groove_inner, groove_outer),
        rules.contact_angle_rule(xp, contact_angle),
    ]


def _curvature_sums(xp, d, dm, fi, fo, alpha):
    gamma = d * xp.cos(alpha) / dm
    gi = 2.0 * gamma / (1.0 - gamma)
    go = 2.0 * gamma / (1.0 + gamma)
    den_i = 4.0 - 1.0 / fi + gi
    den_o = 4.0 - 1.0 / fo - go
    return den_i / d, (1.0 / fi + gi) / den_i, den_o / d, (1.0 / fo - go) / den_o


def curvature_sums(ball_diameter, pitch_diameter, groove_inner, groove_outer, contact_angle=0.0):
    """Curvature sums and differences of the inner and outer ball–raceway contacts (Harris).

    With gamma = D cos(alpha) / d_m and groove curvature ratios f = r/D:

        sum_rho_i = (4 - 1/f_i + 2 gamma/(1 - gamma)) / D,
        F_i = (1/f_i + 2 gamma/(1 - gamma)) / (4 - 1/f_i + 2 gamma/(1 - gamma)),
        sum_rho_o = (4 - 1/f_o - 2 gamma/(1 + gamma)) / D,
        F_o = (1/f_o - 2 gamma/(1 + gamma)) / (4 - 1/f_o - 2 gamma/(1 + gamma)).

    Args:
        ball_diameter: D [m] (> 0). pitch_diameter: d_m [m] (> D).
        groove_inner, groove_outer: f_i, f_o (> 0.5). contact_angle: alpha [rad] in [0, pi/2),
            0 for a radially loaded deep-groove bearing.

    Returns:
        (sum_rho_inner [1/m], F_inner [-], sum_rho_outer [1/m], F_outer [-]).
    """
    args = _checks.as_floats(
        (ball_diameter, "ball_diameter", "m"),
        (pitch_diameter, "pitch_diameter", "m"),
        (groove_inner, "groove_inner", "-"),
        (groove_outer, "groove_outer", "-"),
        (contact_angle, "contact_angle", "rad"),
    )
    _checks.check(_geometry_rules, *args)
    return _checks.evaluate(_curvature_sums, *args)


def _curvature_difference_rules(xp, f):
    v = xp.asarray(f)
    return [((v < 0.0) | (v >= 1.0), "curvature_difference F(rho) must lie in [0, 1)", f)]


def _ellipticity(xp, f):
    return xp.exp(shape(xp, f)[0])


def ellipticity(curvature_difference):
    """Ellipticity kappa = a/b >= 1 of the contact ellipse (Harris Eq. 6.26).

    Solves F(rho) = ((kappa^2 + 1) E(m) - 2 K(m)) / ((kappa^2 - 1) E(m)), m = 1 - 1/kappa^2,
    to float64 precision (F = 0 gives kappa = 1, a circle). Derivatives by the implicit
    function theorem. Args: curvature_difference F(rho) in [0, 1). Returns kappa [-].
    """
    f = _checks.as_float(curvature_difference, "curvature_difference", "-")
    _checks.check(_curvature_difference_rules, f)
    return _checks.evaluate(_ellipticity, f)


def _dimensionless_deflection(xp, f):
    return shape(xp, f)[1]


def dimensionless_deflection(curvature_difference):
    """Dimensionless contact deflection delta* (Harris Eq. 6.41; paper Eq. 10).

    delta* = (2 K(m) / pi) * (pi / (2 kappa^2 E(m)))^(1/3), kappa = ellipticity(F),
    m = 1 - 1/kappa^2; delta* = 1 for a circular contact (F = 0). Args: curvature_difference
    F(rho) in [0, 1). Dimensionless.
    """
    f = _checks.as_float(curvature_difference, "curvature_difference", "-")
    _checks.check(_curvature_difference_rules, f)
    return _checks.evaluate(_dimensionless_deflection, f)


# --------------------------------------------------------------------------------------------
# Stiffness constants
# --------------------------------------------------------------------------------------------


def _race_stiffness(xp, rho, f, e, nu):
    e_prime = e / (1.0 - nu * nu)
    delta_star = shape(xp, f)[1]
    return 2.0 * xp.sqrt(2.0) * e_prime / (3.0 * xp.sqrt(rho)) * delta_star**-1.5


def race_stiffness(sum_rho, curvature_difference, youngs_modulus, poisson_ratio):
    """Hertz constant of one ball–raceway contact (paper Eq. 10), balls and ring of one material.

    K = 2 sqrt(2) E' / (3 sqrt(sum_rho)) * delta*^(-3/2),  E' = E / (1 - nu^2).

    Args: sum_rho [1/m] (> 0), curvature_difference F(rho) in [0, 1), youngs_modulus E [Pa],
    poisson_ratio nu in (0, 0.5). Returns K [N/m^1.5] (load Q = K delta^1.5).
    """
    rho, f, e, nu = (
        _checks.as_float(sum_rho, "sum_rho", "1/m"),
        _checks.as_float(curvature_difference, "curvature_difference", "-"),
        _checks.as_float(youngs_modulus, "youngs_modulus", "Pa"),
        _checks.as_float(poisson_ratio, "poisson_ratio", "-"),
    )
    _checks.check(
        lambda xp, rho, f, e, nu: [_checks.positive(xp, "sum_rho", rho, "1/m")]
        + _curvature_difference_rules(xp, f)
        + rules.material(xp, e, nu),
        rho, f, e, nu,
    )
    return _checks.evaluate(_race_stiffness, rho, f, e, nu)


def _ball_stiffness(xp, ki, ko):
    return (ki ** (-2.0 / 3.0) + ko ** (-2.0 / 3.0)) ** -1.5


def ball_stiffness(k_inner, k_outer):
    """Stiffness of a ball between two raceways, the contacts in series (paper Eq. 11).

    K_b = (1 / ((1/K_i)^(2/3) + (1/K_o)^(2/3)))^(3/2). Args and result in N/m^1.5.
    """
    ki = _checks.as_float(k_inner, "k_inner", "N/m^1.5")
    ko = _checks.as_float(k_outer, "k_outer", "N/m^1.5")
    _checks.check(
        lambda xp, ki, ko: [
            _checks.positive(xp, "k_inner", ki, "N/m^1.5"), _checks.positive(xp, "k_outer", ko, "N/m^1.5")
        ],
        ki, ko,
    )
    return _checks.evaluate(_ball_stiffness, ki, ko)


def _bearing_stiffness(xp, d, dm, fi, fo, e, nu, alpha):
    rho_i, f_i, rho_o, f_o = _curvature_sums(xp, d, dm, fi, fo, alpha)
    # Both contacts in one (stacked) solve: half the program to compile.
    k_io = _race_stiffness(
        xp, xp.stack([rho_i, rho_o]), xp.stack([f_i, f_o]), e[None, ...], nu[None, ...]
    )
    k_i, k_o = k_io[0], k_io[1]
    return k_i, k_o, _ball_stiffness(xp, k_i, k_o)


def bearing_stiffness(
    ball_diameter,
    pitch_diameter,
    groove_inner,
    groove_outer,
    youngs_modulus,
    poisson_ratio,
    contact_angle=0.0,
):
    """Hertz constants (K_i, K_o, K_b) of a ball bearing from its geometry (Eqs. 10–11, Harris).

    Args:
        ball_diameter: D [m] (> 0). pitch_diameter: d_m [m] (> D).
        groove_inner, groove_outer: raceway groove curvature ratios f = r/D (> 0.5).
        youngs_modulus: E [Pa] (> 0). poisson_ratio: nu in (0, 0.5). Balls and rings share them.
        contact_angle: alpha [rad] in [0, pi/2), 0 for a deep-groove bearing under radial load.

    Returns:
        (K_i, K_o, K_b) [N/m^1.5]: inner contact, outer contact, and one ball (both in series).

    Example: SKF 98205 (D = 8.7 mm, d_m = 37.9 mm, steel) with f_i = 0.5219, f_o = 0.5194 gives
    K_i = 2.569e10, K_o = 2.861e10, K_b = 9.576e9 N/m^1.5 (paper: 2.57e10, 2.86e10, 9.57e9).
    """
    d, dm, fi, fo, e, nu, alpha = _checks.as_floats(
        (ball_diameter, "ball_diameter", "m"),
        (pitch_diameter, "pitch_diameter", "m"),
        (groove_inner, "groove_inner", "-"),
        (groove_outer, "groove_outer", "-"),
        (youngs_modulus, "youngs_modulus", "Pa"),
        (poisson_ratio, "poisson_ratio", "-"),
        (contact_angle, "contact_angle", "rad"),
    )
    _checks.check(
        lambda xp, d, dm, fi, fo, e, nu, alpha: _geometry_rules(xp, d, dm, fi, fo, alpha)
        + rules.material(xp, e, nu),
        d, dm, fi, fo, e, nu, alpha,
    )
    return _checks.evaluate(_bearing_stiffness, d, dm, fi, fo, e, nu, alpha)


def _impact_stiffness(xp, rj, rk, ej, nj, ek, nk):
    h_j = (1.0 - nj * nj) / (xp.pi * ej)
    h_k = (1.0 - nk * nk) / (xp.pi * ek)
    return 4.0 / (3.0 * xp.pi * (h_j + h_k)) * xp.sqrt(rj * rk / (rj + rk))


def impact_stiffness(radius_j, radius_k, youngs_j, poisson_j, youngs_k=None, poisson_k=None):
    """Hertz constant of two spheres in contact (paper Eqs. 24–25).

    K_d = 4 / (3 pi (h_j + h_k)) * sqrt(R_j R_k / (R_j + R_k)),  h_u = (1 - nu_u^2) / (pi E_u).

    Args: radius_j, radius_k: R [m] (> 0); youngs_j, youngs_k: E [Pa] (> 0); poisson_j,
    poisson_k: nu in (0, 0.5). Body k defaults to body j's material. Returns K_d [N/m^1.5]
    (1.07e10 for two steel spheres of R = 0.01 m, the paper's impact).
    """
    youngs_k = youngs_j if youngs_k is None else youngs_k
    poisson_k = poisson_j if poisson_k is None else poisson_k
    rj, rk, ej, nj, ek, nk = _checks.as_floats(
        (radius_j, "radius_j", "m"),
        (radius_k, "radius_k", "m"),
        (youngs_j, "youngs_j", "Pa"),
        (poisson_j, "poisson_j", "-"),
        (youngs_k, "youngs_k", "Pa"),
        (poisson_k, "poisson_k", "-"),
    )
    _checks.check(
        lambda xp, rj, rk, ej, nj, ek, nk: [
            _checks.positive(xp, "radius_j", rj, "m"), _checks.positive(xp, "radius_k", rk, "m")
        ]
        + rules.material(xp, ej, nj, "youngs_j", "poisson_j")
        + rules.material(xp, ek, nk, "youngs_k", "poisson_k"),
        rj, rk, ej, nj, ek, nk,
    )
    return _checks.evaluate(_impact_stiffness, rj, rk, ej, nj, ek, nk)


# --------------------------------------------------------------------------------------------
# Rollers: line contact
# --------------------------------------------------------------------------------------------


def _roller_stiffness(xp, length):
    l_mm = 1e3 * length
    k_mm = (2.0 * PALMGREN_LINE) ** (-10.0 / 9.0) * l_mm ** (8.0 / 9.0)  # [N/mm^(10/9)]
    return k_mm * 1e3 ** (10.0 / 9.0)


def roller_stiffness(roller_length):
    """Load–deflection constant K_r [N/m^(10/9)] of a cylindrical roller between two steel
    raceways (Q = K_r delta^(10/9), delta the roller's total compression): Palmgren's empirical
    line-contact deflection delta = 3.84e-5 Q^0.9 / l^0.8 (mm, N) for each raceway contact,
    the two contacts in series (module docstring). Valid for bearing steel only.

    Args: roller_length: effective contact length l = L_we [m] (> 0): the roller's length
    less its end chamfers or crown run-outs.

    Example: l = 9.6 mm (Harris & Kotzalas' 209 cylindrical roller bearing) gives
    K_r = 6.00e8 N/m^(10/9).
    """
    length = _checks.as_float(roller_length, "roller_length", "m")
    _checks.check(lambda xp, length: [_checks.positive(xp, "roller_length", length, "m")], length)
    return _checks.evaluate(_roller_stiffness, length)


def _roller_curvature_sums(xp, d, dm):
    gamma = d / dm
    return 2.0 / (d * (1.0 - gamma)), 2.0 / (d * (1.0 + gamma))


def roller_curvature_sums(roller_diameter, pitch_diameter):
    """Curvature sums (sum_rho_i, sum_rho_o) [1/m] of a cylindrical roller's inner and outer
    raceway contacts (radial bearing, gamma = D / d_m): sum_rho_i = 2 / (D (1 - gamma)),
    sum_rho_o = 2 / (D (1 + gamma)) (roller radius D/2 against the raceway radii
    (d_m -+ D)/2, the outer one concave). Args: roller_diameter D [m] (> 0), pitch_diameter
    d_m [m] (> D)."""
    d, dm = _checks.as_floats(
        (roller_diameter, "roller_diameter", "m"), (pitch_diameter, "pitch_diameter", "m")
    )
    _checks.check(
        lambda xp, d, dm: [
            _checks.positive(xp, "roller_diameter", d, "m"), rules.pitch_exceeds_ball(xp, dm, d)
        ],
        d, dm,
    )
    return _checks.evaluate(_roller_curvature_sums, d, dm)


# --------------------------------------------------------------------------------------------
# Contact stress
# --------------------------------------------------------------------------------------------


def _point_contact_stress(xp, q, rho, f, e, nu):
    e_prime = e / (1.0 - nu * nu)
    log_kappa = shape(xp, f)[0]
    kappa = xp.exp(log_kappa)
    _, e_m = elliptic(xp, -xp.expm1(-2.0 * log_kappa))
    ab_star = xp.cbrt(4.0 * kappa * e_m * e_m / (xp.pi * xp.pi))  # a* b*
    ab = ab_star * xp.cbrt(3.0 * q / (e_prime * rho)) ** 2
    return 3.0 * q / (2.0 * xp.pi * ab)


def point_contact_stress(load, sum_rho, curvature_difference, youngs_modulus, poisson_ratio):
    """Largest pressure p_max [Pa] of a Hertzian point contact under the load Q [N]:
    p_max = 3 Q / (2 pi a b) (module docstring; Harris & Kotzalas, ch. 6), bodies of one
    material.

    Args: load Q [N] (>= 0); sum_rho [1/m] (> 0) and curvature_difference F(rho) in [0, 1)
    (`curvature_sums`); youngs_modulus E [Pa]; poisson_ratio nu in (0, 0.5).
    """
    q, rho, f, e, nu = _checks.as_floats(
        (load, "load", "N"),
        (sum_rho, "sum_rho", "1/m"),
        (curvature_difference, "curvature_difference", "-"),
        (youngs_modulus, "youngs_modulus", "Pa"),
        (poisson_ratio, "poisson_ratio", "-"),
    )
    _checks.check(
        lambda xp, q, rho, f, e, nu: [
            _checks.non_negative(xp, "load", q, "N"), _checks.positive(xp, "sum_rho", rho, "1/m")
        ]
        + _curvature_difference_rules(xp, f)
        + rules.material(xp, e, nu),
        q, rho, f, e, nu,
    )
    return _checks.evaluate(_point_contact_stress, q, rho, f, e, nu)


def _line_contact_stress(xp, q, length, rho, e, nu):
    return xp.sqrt(q * e / (1.0 - nu * nu) * rho / (2.0 * xp.pi * length))


def line_contact_stress(load, length, sum_rho, youngs_modulus, poisson_ratio):
    """Largest pressure p_max = sqrt(Q E' sum_rho / (2 pi l)) [Pa] of a Hertzian line contact
    of length l under the load Q, E' = E / (1 - nu^2), bodies of one material (module
    docstring; Harris & Kotzalas, ch. 6). It ignores the rise at the ends of a roller that is
    not crowned.

    Args: load Q [N] (>= 0); length l [m] (> 0); sum_rho [1/m] (> 0,
    `roller_curvature_sums`); youngs_modulus E [Pa]; poisson_ratio nu in (0, 0.5).
    """
    q, length, rho, e, nu = _checks.as_floats(
        (load, "load", "N"),
        (length, "length", "m"),
        (sum_rho, "sum_rho", "1/m"),
        (youngs_modulus, "youngs_modulus", "Pa"),
        (poisson_ratio, "poisson_ratio", "-"),
    )
    _checks.check(
        lambda xp, q, length, rho, e, nu: [
            _checks.non_negative(xp, "load", q, "N"),
            _checks.positive(xp, "length", length, "m"),
            _checks.positive(xp, "sum_rho", rho, "1/m"),
        ]
        + rules.material(xp, e, nu),
        q, length, rho, e, nu,
    )
    return _checks.evaluate(_line_contact_stress, q, length, rho, e, nu)

"""Plain (journal) bearing laws: the dry contact stiffness of a journal in its hole, and the
hydrodynamic force of a short (Ocvirk) bearing with the half-Sommerfeld condition
(docs/plain_bearings.md).

**Dry contact stiffness.** A journal of radius R_j in a hole of radius R_i = R_j + c touches
it, internally, along a line; the law this literature uses for it (Flores, Ambrósio, Claro and
Lankarani, *Kinematics and Dynamics of Multibody Systems with Imperfect Joints*, Springer
2008) is Hertz's for a sphere in a spherical seat of the same radii,

    K = 4 / (3 (sigma_i + sigma_j)) * sqrt(R_i R_j / (R_i - R_j)),   sigma_k = (1 - nu_k^2) / E_k,

that is Hertz's F = (4/3) E* sqrt(R*) delta^(3/2) with 1/E* = sigma_i + sigma_j and the
conforming radius 1/R* = 1/R_j - 1/R_i (Johnson, *Contact Mechanics*, 1985, ch. 4, a concave
surface counting its radius negative). The Lankarani–Nikravesh force
(`impact.lankarani_nikravesh`) reads it as its K_d. A cylinder's line contact has no such
power law; the sphere form is the literature's stand-in, and like every Hertz law it assumes
the contact's size sqrt(R* delta) small against the radii, which a conforming pair (R* = R_j
(R_j + c) / c, metres for a clearance of micrometres) reaches at small loads.

**Short-bearing film force.** The journal's centre is off the hole's by e = epsilon c along n
(from the hole's centre to the journal's), the line of centres turns at phi_dot, the journal
and the hole turn at omega_j and omega_i [rad/s]. The film thickness is h = c (1 + epsilon cos
theta), theta measured from the widest gap (along -n) in the positive sense. For a bearing
short against its diameter (L/D small; Ocvirk's approximation drops the circumferential
pressure flow, Frêne, Nicolas, Degueurce, Berthe and Godet, *Hydrodynamic Lubrication*,
Elsevier 1997, ch. 5; Hamrock, *Fundamentals of Fluid Film Lubrication*, 1994, ch. 10), the
Reynolds equation with pressure 0 at the ends z = +-L/2 gives

    p(theta, z) = 3 mu (L^2/4 - z^2) / (c^2 (1 + epsilon cos theta)^3)
                  * (w sin theta - 2 epsilon_dot cos theta),

with mu the viscosity [Pa s], w = epsilon (omega_j + omega_i - 2 phi_dot) the wedge term and
epsilon_dot the squeeze term [1/s]. The half-Sommerfeld condition keeps the positive
pressures only: where w sin theta - 2 epsilon_dot cos theta > 0, the half turn theta in
(alpha, alpha + pi) with alpha = atan2(2 epsilon_dot, w) (the cavitation boundaries move with
the squeeze, as Daniel, Machado and Cavalca, Mech. Mach. Theory 99 (2016) 19–36, integrate
them). Integrated over the journal's surface, the force on the journal along n and t (n
turned +90 deg) is

    F_n = K_f (w S_sc - 2 epsilon_dot S_cc),   F_t = K_f (w S_ss - 2 epsilon_dot S_sc),
    K_f = mu R L^3 / (2 c^2),

S_xy the integrals over (alpha, alpha + pi) of x(theta) y(theta) / (1 + epsilon cos theta)^3
(s: sin, c: cos). With Sommerfeld's substitution 1 + epsilon cos theta = (1 - epsilon^2) /
(1 - epsilon cos gamma) they are, in closed form,

    S_cc = [(1/2 + epsilon^2) gamma + sin(2 gamma)/4 - 2 epsilon sin gamma] / (1 - epsilon^2)^(5/2),
    S_ss = [gamma/2 - sin(2 gamma)/4] / (1 - epsilon^2)^(3/2),
    S_sc = [sin(gamma)^2 / 2 + epsilon cos gamma] / (1 - epsilon^2)^2,

each [.] taken between gamma(alpha) and gamma(alpha + pi), gamma(theta) = theta - 2
atan(beta sin theta / (1 + beta cos theta)), beta = epsilon / (1 + sqrt(1 - epsilon^2)) (the
continuous branch, increasing with theta). Where the squeeze vanishes (alpha = 0) they are the
classical
-2 epsilon / (1 - epsilon^2)^2, pi / (2 (1 - epsilon^2)^(3/2)) and pi (1 + 2 epsilon^2) /
(2 (1 - epsilon^2)^(5/2)): the forces of Flores, Ambrósio, Claro, Lankarani and Koshy (Nonlinear
Dyn. 56 (2009) 277–295), and in steady running the load capacity
W = mu omega R L^3 epsilon sqrt(16 epsilon^2 + pi^2 (1 - epsilon^2)) / (4 c^2 (1 - epsilon^2)^2)
at the attitude angle tan psi = pi sqrt(1 - epsilon^2) / (4 epsilon) (Hamrock, ch. 10).

Where the form holds: Ocvirk's approximation is good for L/D up to about 1/2 (Hamrock
recommends it below 1/2; Frêne et al. compare it with the finite bearing), isothermal,
incompressible, rigid surfaces, a film flooded at the ends; the force grows without bound as
epsilon -> 1, where the film is thinner than the surfaces' roughness and the theory fails
(`JournalBearing.film_limit` holds it there). The shear torque of the film is not modelled.

Every function is pure, float64, and safe under `jax.jit`, `jax.vmap` and `jax.grad` (finite
derivatives at epsilon = 0 and where the film is at rest); `contact_stiffness` of concrete
inputs is checked and evaluated in NumPy (`_checks.evaluate`).
"""

from __future__ import annotations

import jax.numpy as jnp

from .. import _checks
from . import rules


def _contact_stiffness(xp, radius, clearance, e_j, nu_j, e_i, nu_i):
    sigma = (1.0 - nu_j * nu_j) / e_j + (1.0 - nu_i * nu_i) / e_i
    hole = radius + clearance
    return 4.0 / (3.0 * sigma) * xp.sqrt(hole * radius / clearance)


def contact_stiffness(
    journal_radius, clearance, youngs_modulus, poisson_ratio, youngs_hole=None, poisson_hole=None
):
    """K [N/m^1.5] of a journal of radius R_j in a hole of radius R_j + c: Hertz's sphere in a
    spherical seat (module docstring),

        K = 4 / (3 (sigma_i + sigma_j)) sqrt((R_j + c) R_j / c),   sigma = (1 - nu^2) / E.

    Args: journal_radius R_j [m] (> 0); clearance c [m] (> 0), radial; youngs_modulus E [Pa]
    (> 0) and poisson_ratio nu (in (0, 0.5)) of the journal; youngs_hole, poisson_hole: the
    hole's (default: the journal's material)."""
    youngs_hole = youngs_modulus if youngs_hole is None else youngs_hole
    poisson_hole = poisson_ratio if poisson_hole is None else poisson_hole
    values = _checks.as_floats(
        (journal_radius, "radius", "m"),
        (clearance, "clearance", "m"),
        (youngs_modulus, "youngs_modulus", "Pa"),
        (poisson_ratio, "poisson_ratio", "-"),
        (youngs_hole, "youngs_hole", "Pa"),
        (poisson_hole, "poisson_hole", "-"),
    )
    _checks.check(
        lambda xp, r, c, ej, nj, ei, ni: [
            _checks.positive(xp, "radius", r, "m"), _checks.positive(xp, "clearance", c, "m")
        ]
        + rules.material(xp, ej, nj)
        + rules.material(xp, ei, ni, "youngs_hole", "poisson_hole"),
        *values,
    )
    return _checks.evaluate(_contact_stiffness, *values)


def _ends(cos_theta, sin_theta, epsilon, root):
    """cos gamma, sin gamma at an end of the positive half turn: Sommerfeld's substitution
    read backwards, cos gamma = (epsilon + cos theta) / (1 + epsilon cos theta), sin gamma =
    sqrt(1 - epsilon^2) sin theta / (1 + epsilon cos theta)."""
    inverse = 1.0 / (1.0 + epsilon * cos_theta)
    return (epsilon + cos_theta) * inverse, root * sin_theta * inverse


def film_force(eccentricity_ratio, squeeze_rate, wedge_rate, viscosity, radius, length, clearance):
    """The short-bearing film force on the journal [N] with the half-Sommerfeld condition:
    (F_n, F_t) along n (from the hole's centre to the journal's) and t (n turned +90 deg)
    (module docstring).

    The half turn's ends theta = alpha, alpha + pi enter through cos alpha = w / A, sin alpha =
    2 epsilon_dot / A (A = sqrt(w^2 + 4 epsilon_dot^2)), the gammas' sines and cosines through
    the substitution (`_ends`), and the span gamma(alpha + pi) - gamma(alpha) = pi + 2
    atan(epsilon sin alpha / sqrt(1 - epsilon^2)) (the two arctangents of the substitution
    summed): no trigonometric function but that one arctangent.

    Args:
        eccentricity_ratio: epsilon = |e| / c, in [0, 1).
        squeeze_rate: epsilon_dot [1/s].
        wedge_rate: w = epsilon (omega_journal + omega_hole - 2 phi_dot) [1/s], phi the angle of
            the line of centres (finite as epsilon -> 0: epsilon phi_dot = (n x e_dot) / c).
        viscosity: mu [Pa s]. radius: R, the journal's [m]. length: L [m]. clearance: c [m].
    """
    epsilon = eccentricity_ratio
    squeeze = 2.0 * squeeze_rate
    size_sq = wedge_rate * wedge_rate + squeeze * squeeze
    still = size_sq == 0.0  # no pressure: any half turn, with finite derivatives
    size = jnp.sqrt(jnp.where(still, 1.0, size_sq))
    cos_alpha = jnp.where(still, 1.0, wedge_rate / size)
    sin_alpha = jnp.where(still, 0.0, squeeze / size)
    ones = 1.0 - epsilon * epsilon
    root = jnp.sqrt(ones)
    cos_1, sin_1 = _ends(cos_alpha, sin_alpha, epsilon, root)
    cos_2, sin_2 = _ends(-cos_alpha, -sin_alpha, epsilon, root)
    span = jnp.pi + 2.0 * jnp.arctan(epsilon * sin_alpha / root)
    twice = 0.5 * (sin_2 * cos_2 - sin_1 * cos_1)  # [sin(2 gamma) / 4] between the ends
    cc = (0.5 + epsilon * epsilon) * span + twice - 2.0 * epsilon * (sin_2 - sin_1)
    ss = 0.5 * span - twice
    sc = 0.5 * (sin_2 * sin_2 - sin_1 * sin_1) + epsilon * (cos_2 - cos_1)
    s_cc, s_ss, s_sc = cc / (ones * ones * root), ss / (ones * root), sc / (ones * ones)
    scale = viscosity * radius * length**3 / (2.0 * clearance * clearance)
    return (
        scale * (wedge_rate * s_sc - squeeze * s_cc),
        scale * (wedge_rate * s_ss - squeeze * s_sc),
    )

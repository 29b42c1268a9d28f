"""The contact ellipse of Hertz's point contact: complete elliptic integrals K(m), E(m) by the
arithmetic–geometric mean, and the ellipticity kappa and dimensionless deflection delta* as
implicit functions of the curvature difference F(rho) (paper Eqs. 10, 11), each with an exact
derivative (custom JVPs). `hertz` turns them into stiffnesses.

Each function takes the array module ``xp`` first: `jax.numpy` (traced, jitted and
differentiated through the custom JVPs `elliptic_pair` and `contact_shape`) or NumPy (concrete
values, nothing compiled), with the same steps."""

from __future__ import annotations

import math

import jax
import jax.numpy as jnp
import numpy as np

_AGM_STEPS = 10
_NEWTON_STEPS = 12
# Upper end of the bracket for log(kappa): kappa = 1e4 (F ~ 1 - 2e-7), far beyond any bearing.
_LOG_KAPPA_MAX = math.log(1.0e4)


def _fori_loop(xp, lower, upper, body, carry):
    """`jax.lax.fori_loop` in ``xp``: a Python loop in NumPy."""
    if xp is np:
        for i in range(lower, upper):
            carry = body(i, carry)
        return carry
    return jax.lax.fori_loop(lower, upper, body, carry)


# --------------------------------------------------------------------------------------------
# Complete elliptic integrals
# --------------------------------------------------------------------------------------------


def _agm(xp, m, m1):
    """AGM for parameter m with complementary parameter m1 = 1 - m (both given, for accuracy).

    Returns (K, T) with K = K(m) and T = sum_{n>=1} 2^(n-1) (c_n/m)^2, where c_n is the AGM
    sequence c_{n+1} = (a_n - b_n)/2 = c_n^2/(4 a_{n+1}), c_0^2 = m. Then (Abramowitz & Stegun
    17.6) E(m) = K(m) (1 - m/2 - m^2 T). Writing g_n = c_n/m (g_1 = 1/(4 a_1),
    g_{n+1} = m g_n^2 / (4 a_{n+1})) avoids every subtraction, so T is exact as m -> 0.
    A `fori_loop` (not unrolled) keeps compilation cheap.
    """
    a0 = xp.ones_like(m)
    b0 = xp.sqrt(m1)
    a = 0.5 * (a0 + b0)
    b = xp.sqrt(a0 * b0)
    g = 1.0 / (4.0 * a)
    t = g * g

    def step(_, state):
        a, b, g, t, weight = state
        a_next = 0.5 * (a + b)
        g = m * g * g / (4.0 * a_next)
        return a_next, xp.sqrt(a * b), g, t + weight * g * g, 2.0 * weight

    a, _, _, t, _ = _fori_loop(xp, 1, _AGM_STEPS, step, (a, b, g, t, xp.full_like(m, 2.0)))
    return xp.pi / (2.0 * a), t


def _elliptic(xp, m):
    k, t = _agm(xp, m, 1.0 - m)
    return k, k * (1.0 - 0.5 * m - m * m * t)


def elliptic(xp, m):
    """(K(m), E(m)) in ``xp``; in `jax.numpy` `elliptic_pair`."""
    return elliptic_pair(m) if xp is jnp else _elliptic(xp, m)


@jax.custom_jvp
def elliptic_pair(m):
    """(K(m), E(m)) in `jax.numpy`, with their derivatives in closed form."""
    return _elliptic(jnp, m)


@elliptic_pair.defjvp
def _elliptic_pair_jvp(primals, tangents):
    # dK/dm = (E - (1-m) K) / (2 m (1-m)) = K (1/2 - m T) / (2 (1-m)),
    # dE/dm = (E - K) / (2 m) = -K (1/2 + m T) / 2   (DLMF 19.4.1, no 0/0 at m = 0).
    (m,), (dm,) = primals, tangents
    k, t = _agm(jnp, m, 1.0 - m)
    e = k * (1.0 - 0.5 * m - m * m * t)
    dk = k * (0.5 - m * t) / (2.0 * (1.0 - m))
    de = -0.5 * k * (0.5 + m * t)
    return (k, e), (dk * dm, de * dm)


def _ellipse(xp, log_kappa):
    """Elliptic integrals and Harris' curvature difference of an ellipse, u = log(kappa) >= 0.

    Returns (K, E, T, F, dF/du) with m = 1 - 1/kappa^2 (formed without cancellation) and

        F = ((2 - m) E - 2 (1 - m) K) / (m E) = m K P / E,   P = 1/2 - (2 - m) T,
        dF/dm = K (3 E (1/2 + m T) - P (3 E - K)) / (2 E^2),   dm/du = 2 (1 - m),

    (T from `_agm`), free of 0/0 in the sphere limit u -> 0, where F ~ 3u/4.
    """
    m1 = xp.exp(-2.0 * log_kappa)  # 1/kappa^2
    m = -xp.expm1(-2.0 * log_kappa)  # 1 - 1/kappa^2
    k, t = _agm(xp, m, m1)
    e = k * (1.0 - 0.5 * m - m * m * t)
    p = 0.5 - (1.0 + m1) * t
    f = m * k * p / e
    dfdm = k * (3.0 * e * (0.5 + m * t) - p * (3.0 * e - k)) / (2.0 * e * e)
    return k, e, t, f, 2.0 * m1 * dfdm




def _solve_log_kappa(xp, f_target):
    """Safeguarded Newton for u = log(kappa): F(u) = f_target, u in [0, log 1e4].

    F is increasing in u with F(0) = 0 (convex near 0, concave beyond); the bracket [lo, hi]
    is updated from the sign of the residual and a Newton step that leaves it is replaced by
    bisection. Start: Hamrock & Brewe (1983), kappa ~ 1.0339 (R_y/R_x)^0.636 with
    R_y/R_x = (1 + F)/(1 - F); in the sphere limit F ~ 3u/4 instead. Five steps reach 1e-10
    for 0 <= F <= 0.9999; the twelve used leave only rounding (kappa is conditioned like
    eps/(1 - F)). For F >= 1 - 2e-7 kappa saturates at 1e4; F < 0 gives kappa = 1.
    """
    f_safe = xp.clip(f_target, 0.0, 1.0 - 1e-12)
    ratio = (1.0 + f_safe) / (1.0 - f_safe)
    lo = xp.zeros_like(f_target)
    hi = xp.full_like(f_target, _LOG_KAPPA_MAX)
    u_hb = xp.log(1.0339) + 0.636 * xp.log(ratio)
    u0 = xp.clip(xp.where(f_safe < 0.05, 4.0 * f_safe / 3.0, u_hb), lo, hi)

    def step(_, state):
        u, lo, hi = state
        _, _, _, f, dfdu = _ellipse(xp, u)
        r = f - f_target
        lo = xp.where(r <= 0.0, u, lo)
        hi = xp.where(r >= 0.0, u, hi)
        u_newton = u - r / dfdu
        inside = (u_newton >= lo) & (u_newton <= hi)
        u_next = xp.where(inside, u_newton, 0.5 * (lo + hi))
        u_next = xp.where(r == 0.0, u, u_next)
        return u_next, lo, hi

    u, _, _ = _fori_loop(xp, 0, _NEWTON_STEPS, step, (u0, lo, hi))
    return u


def _deflection_of(xp, log_kappa, k, e):
    # delta* = (2K/pi) (pi / (2 kappa^2 E))^(1/3), with 1/kappa^2 = exp(-2u).
    return (2.0 * k / xp.pi) * xp.cbrt(xp.pi * xp.exp(-2.0 * log_kappa) / (2.0 * e))


def _shape(xp, f):
    u = _solve_log_kappa(xp, f)
    k, e, _, _, _ = _ellipse(xp, u)
    return u, _deflection_of(xp, u, k, e)


def shape(xp, f):
    """(log kappa, delta*) of the contact ellipse for the curvature difference f, in ``xp``;
    in `jax.numpy` `contact_shape`."""
    return contact_shape(f) if xp is jnp else _shape(xp, f)


@jax.custom_jvp
def contact_shape(f):
    """(log kappa, delta*) of the contact ellipse for the curvature difference f, in
    `jax.numpy`, differentiated implicitly."""
    return _shape(jnp, f)


@contact_shape.defjvp
def _contact_shape_jvp(primals, tangents):
    # Implicit function theorem on F(u) = f: du/df = 1 / (dF/du). Then, with
    # dK/du = K (1/2 - m T) and dE/du = -(1 - m) K (1/2 + m T) (chain rule through m(u)),
    # dlog(delta*)/du = dlog(K)/du - 2/3 - dlog(E)/du / 3, which vanishes at u = 0.
    (f,), (df,) = primals, tangents
    u, delta = contact_shape(f)
    k, e, t, _, dfdu = _ellipse(jnp, u)
    m1 = jnp.exp(-2.0 * u)
    m = -jnp.expm1(-2.0 * u)
    du = df / dfdu
    dlog_delta = (0.5 - m * t) - 2.0 / 3.0 + m1 * k * (0.5 + m * t) / (3.0 * e)
    return (u, delta), (du, delta * dlog_delta * du)

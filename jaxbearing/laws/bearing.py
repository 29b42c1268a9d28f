"""Per-ball force law of a radial rolling bearing (paper Sect. 2.1, Eqs. 9, 12–15, 28).

The outer race belongs to body i (bush), the inner race to body j (journal). With the
eccentricity e = r_j^P - r_i^P of the race centres (Eq. 4) and its rate v (Eq. 5), ball r at
global angle phi_r (Eq. 14) is compressed by

    delta_r = e . u_r - P_d/2,   u_r = [cos phi_r, sin phi_r]          (Eq. 12)

and pushes with

    F_r = K_b delta_r^n + C_b (v . u_r)   if delta_r > 0, else 0        (Eq. 9)

clamped at F_r >= 0 (a ball never pulls). The resultant F = sum_r F_r u_r (Eq. 28) acts on the
outer-race body, -F on the inner-race body.

Two variants of Eq. 9 (``BallBearing.ball_force``):
- ``"paper"``: as printed; the damping term jumps on at first touch.
- ``"smooth"``: the damping term is multiplied by a C1 ramp s(delta/delta_ramp),
  s(x) = 3x^2 - 2x^3 on [0, 1], so the force is continuous at first touch. Use it for
  gradients through the simulation (the jump makes derivatives over rattling unreliable).
"""

from __future__ import annotations

import jax
import jax.numpy as jnp

from ..params import BallBearing


def ball_angles(cage_angle, n_balls: int) -> jax.Array:
    """Global angles phi_r = 2 pi (r-1)/N_b + phi_c of the balls [rad] (Eq. 14), ball 1 first."""
    return 2.0 * jnp.pi * jnp.arange(n_balls) / n_balls + cage_angle


def cage_speed(inner_speed, outer_speed, bearing: BallBearing) -> jax.Array:
    """Cage angular speed omega_m = (omega_i d_i + omega_o d_o)/(d_i + d_o) [rad/s] (Eq. 15)."""
    d_i, d_o = bearing.inner_race_diameter, bearing.outer_race_diameter
    return (inner_speed * d_i + outer_speed * d_o) / (d_i + d_o)


def smooth_ramp(x) -> jax.Array:
    """C1 ramp 3x^2 - 2x^3 on [0, 1], 0 below and 1 above."""
    x = jnp.clip(x, 0.0, 1.0)
    return x * x * (3.0 - 2.0 * x)


def ball_deflections(eccentricity, cage_angle, bearing: BallBearing) -> jax.Array:
    """delta_r = e_x cos phi_r + e_y sin phi_r - P_d/2 [m] (Eq. 12); negative inside the clearance."""
    phi = ball_angles(cage_angle, bearing.n_balls)
    return eccentricity[0] * jnp.cos(phi) + eccentricity[1] * jnp.sin(phi) - 0.5 * bearing.clearance


def ball_loads(eccentricity, eccentricity_rate, cage_angle, bearing: BallBearing) -> jax.Array:
    """Contact force of each ball [N], shape (N_b,), ball 1 first (Eqs. 9, 12–14).

    Args:
        eccentricity: e = r_j^P - r_i^P, inner-race centre relative to outer-race centre [m], (2,).
        eccentricity_rate: v = de/dt [m/s], (2,).
        cage_angle: phi_c [rad]; ball r sits at 2 pi (r-1)/N_b + phi_c.
        bearing: the `BallBearing` parameters (variant chosen by ``bearing.ball_force``).
    """
    phi = ball_angles(cage_angle, bearing.n_balls)
    cos, sin = jnp.cos(phi), jnp.sin(phi)
    delta = eccentricity[0] * cos + eccentricity[1] * sin - 0.5 * bearing.clearance
    rate = eccentricity_rate[0] * cos + eccentricity_rate[1] * sin
    touching = delta > 0.0
    depth = jnp.where(touching, delta, 0.0)  # keeps the gradient of depth**n finite
    damping = bearing.damping * rate
    if bearing.ball_force == "smooth":
        damping = damping * smooth_ramp(depth / bearing.damping_ramp)
    force = bearing.stiffness * depth**bearing.exponent + damping
    return jnp.where(touching, jnp.maximum(force, 0.0), 0.0)


def resultant(loads, cage_angle) -> jax.Array:
    """F = sum_r F_r [cos phi_r, sin phi_r] [N], the force on the outer-race body (Eq. 28)."""
    phi = ball_angles(cage_angle, loads.shape[-1])
    return jnp.stack([jnp.sum(loads * jnp.cos(phi), -1), jnp.sum(loads * jnp.sin(phi), -1)], -1)

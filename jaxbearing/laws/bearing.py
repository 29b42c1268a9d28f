"""Per-ball force law of a radial rolling bearing (paper Sect. 2.1, Eqs. 9, 12–15, 28).

The outer race belongs to body i (bush), the inner race to body j (journal). With the
eccentricity e = r_j^P - r_i^P of the race centres (Eq. 4) and its rate v (Eq. 5), ball r at
global angle phi_r (Eq. 14) is compressed by

    delta_r = e . u_r - P_d/2,   u_r = [cos phi_r, sin phi_r]          (Eq. 12)

and pushes with

    F_r = K_b delta_r^n + C_b (v . u_r)   if delta_r > 0, else 0        (Eq. 9)

clamped at F_r >= 0 (a ball never pulls). The resultant F = sum_r F_r u_r (Eq. 28) acts on the
outer-race body, -F on the inner-race body.

Two variants of Eq. 9 (``AbstractBearing.ball_force``):
- ``"paper"``: as printed; the damping term jumps on at first touch. Which balls touch is a
  discrete state (``engaged``) that `jaxbearing.simulate` switches at events (a ball engages when
  delta_r crosses 0 upwards and is released when delta_r falls below -`BALL_RELEASE`), so the
  force is smooth within each solver segment and derivatives include the jump of every switch.
- ``"smooth"``: the damping term is multiplied by a C1 ramp s(delta/delta_ramp),
  s(x) = 3x^2 - 2x^3 on [0, 1], so the force is continuous at first touch and needs no events.
"""

from __future__ import annotations

from typing import Protocol

import jax
import jax.numpy as jnp
import numpy as np

from .._forms import power

BALL_RELEASE = 1e-12  # [m] an engaged ball of the paper force is released at delta_r = -1 pm


class BearingParameters(Protocol):
    """What the laws read of a bearing (`jaxbearing.params.AbstractBearing`, so `BallBearing` and
    `RollerBearing`, has it; the laws do not
    import the parameters, which import the laws)."""

    clearance: jax.Array  # P_d, diametral [m]
    stiffness: jax.Array  # K_b [N/m^exponent]
    exponent: float  # n of Eq. 9 [-]
    damping: jax.Array  # C_b [N s/m]
    damping_ramp: jax.Array  # [m], deflection over which the smooth force ramps its damping in
    inner_race_diameter: jax.Array  # d_i [m]
    outer_race_diameter: jax.Array  # d_o [m]
    n_balls: int  # N_b
    ball_force: str  # "paper" or "smooth"


def _pitch_angles(n_balls: int) -> np.ndarray:
    """2 pi (r-1)/N_b [rad], the balls' places in the cage, ball 1 first."""
    return 2.0 * np.pi * np.arange(n_balls) / n_balls


def ball_angles(cage_angle, n_balls: int) -> jax.Array:
    """Global angles phi_r = 2 pi (r-1)/N_b + phi_c of the balls [rad] (Eq. 14), ball 1 first."""
    return _pitch_angles(n_balls) + jnp.asarray(cage_angle)


def ball_directions(cage_angle, n_balls: int) -> tuple[jax.Array, jax.Array]:
    """cos phi_r and sin phi_r of the ball angles (Eq. 14), each (N_b,).

    By angle addition from the fixed pitch angles 2 pi (r-1)/N_b: two transcendentals per call
    instead of 2 N_b (they dominate the cost of a batched force evaluation).
    """
    pitch = _pitch_angles(n_balls)
    c, s = jnp.cos(cage_angle), jnp.sin(cage_angle)
    return np.cos(pitch) * c - np.sin(pitch) * s, np.sin(pitch) * c + np.cos(pitch) * s


def cage_speed(inner_speed, outer_speed, bearing: BearingParameters) -> jax.Array:
    """Cage angular speed omega_m = (omega_i d_i + omega_o d_o)/(d_i + d_o) [rad/s] (Eq. 15)."""
    d_i, d_o = bearing.inner_race_diameter, bearing.outer_race_diameter
    return (inner_speed * d_i + outer_speed * d_o) / (d_i + d_o)


def smooth_ramp(x) -> jax.Array:
    """C1 ramp 3x^2 - 2x^3 on [0, 1], 0 below and 1 above."""
    x = jnp.clip(x, 0.0, 1.0)
    return x * x * (3.0 - 2.0 * x)


def ball_deflections(eccentricity, cage_angle, bearing: BearingParameters) -> jax.Array:
    """delta_r = e_x cos phi_r + e_y sin phi_r - P_d/2 [m] (Eq. 12); negative inside the clearance."""
    cos, sin = ball_directions(cage_angle, bearing.n_balls)
    return eccentricity[0] * cos + eccentricity[1] * sin - 0.5 * bearing.clearance


def ball_loads(
    eccentricity, eccentricity_rate, cage_angle, bearing: BearingParameters, engaged=None
) -> jax.Array:
    """Contact force of each ball [N], shape (N_b,), ball 1 first (Eqs. 9, 12–14).

    Args:
        eccentricity: e = r_j^P - r_i^P, inner-race centre relative to outer-race centre [m], (2,).
        eccentricity_rate: v = de/dt [m/s], (2,).
        cage_angle: phi_c [rad]; ball r sits at 2 pi (r-1)/N_b + phi_c.
        bearing: the bearing's parameters (variant chosen by ``bearing.ball_force``).
        engaged: (N_b,) bool, the balls that touch, for the paper force as switched by
            `jaxbearing.simulate` (module docstring); None: the balls with delta_r > 0.
            The smooth force ignores it.
    """
    cos, sin = ball_directions(cage_angle, bearing.n_balls)
    return _loads(cos, sin, eccentricity, eccentricity_rate, bearing, engaged)


def ring_point_loads(
    eccentricity, eccentricity_rate, ring_angle, n_points: int, bearing: BearingParameters
) -> jax.Array:
    """Load [N] that a ball carries when it passes each of ``n_points`` points fixed in a ring,
    shape (n_points,): point k sits at the global angle 2 pi k / n_points + ``ring_angle``
    [rad], and its load is that of `ball_loads` (engaged=None) for a ball placed there."""
    # e and v in the ring's frame, as reductions: XLA:CPU then computes them once, not again in
    # every point's element (it fuses scalar producers, cos and sin included, into their
    # consumers and repeats them there)
    axis = jnp.stack([jnp.cos(ring_angle), jnp.sin(ring_angle)])
    normal = jnp.stack([-axis[1], axis[0]])
    local = [jnp.sum(x * a) for x in (eccentricity, eccentricity_rate) for a in (axis, normal)]
    pitch = _pitch_angles(n_points)
    return _loads(np.cos(pitch), np.sin(pitch), local[:2], local[2:], bearing, None)


def _loads(cos, sin, eccentricity, eccentricity_rate, bearing, engaged):
    """Eqs. 9, 12–13 for balls in the directions (cos, sin) [N]."""
    delta = eccentricity[0] * cos + eccentricity[1] * sin - 0.5 * bearing.clearance
    rate = eccentricity_rate[0] * cos + eccentricity_rate[1] * sin
    positive = delta > 0.0
    touching = positive if engaged is None or bearing.ball_force == "smooth" else engaged
    depth = jnp.where(positive, delta, 0.0)  # keeps the gradient of depth**n finite
    damping = bearing.damping * rate
    if bearing.ball_force == "smooth":
        damping = damping * smooth_ramp(depth / bearing.damping_ramp)
    force = bearing.stiffness * power(depth, bearing.exponent) + damping
    return jnp.where(touching, jnp.maximum(force, 0.0), 0.0)


def resultant(loads, cage_angle) -> jax.Array:
    """``F = sum_r F_r (cos phi_r, sin phi_r)`` [N], the force on the outer-race body (Eq. 28)."""
    cos, sin = ball_directions(cage_angle, loads.shape[-1])
    return jnp.stack([jnp.sum(loads * cos, -1), jnp.sum(loads * sin, -1)], -1)

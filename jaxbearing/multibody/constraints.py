"""Kinematic constraints Phi(q, t) = 0 (paper Sect. 2.4).

Each joint returns its equations; `Mechanism` stacks them and differentiates them with JAX
(Phi_q, Phi_t and gamma of Eq. 35 come from forward-mode derivatives, so a new joint only needs
its position-level equations).
"""

from __future__ import annotations

import equinox as eqx
import jax
import jax.numpy as jnp

from .. import _checks
from .bodies import GROUND, point_position, pose


class Revolute(eqx.Module):
    """Ideal pin: point s_i of body i coincides with point s_j of body j (2 equations).

    Either body may be `GROUND`, whose point is then a global position [m].
    """

    body_i: int = eqx.field(static=True)
    body_j: int = eqx.field(static=True)
    point_i: jax.Array
    point_j: jax.Array

    def __init__(self, body_i: int, point_i, body_j: int, point_j):
        self.body_i, self.body_j = body_i, body_j
        self.point_i = _checks.as_float(point_i)
        self.point_j = _checks.as_float(point_j)

    n_equations = 2

    def __call__(self, q, t):
        return point_position(q, self.body_i, self.point_i) - point_position(
            q, self.body_j, self.point_j
        )


class Translational(eqx.Module):
    """Body slides along a fixed ground line without turning (2 equations).

    The body's centroid stays on the line through ``origin`` [m] at angle ``line_angle`` [rad],
    and its orientation stays at ``body_angle`` [rad].
    """

    body: int = eqx.field(static=True)
    origin: jax.Array
    line_angle: jax.Array
    body_angle: jax.Array

    def __init__(self, body: int, origin=(0.0, 0.0), line_angle=0.0, body_angle=0.0):
        if body == GROUND:
            raise ValueError("Translational joint needs a moving body, not GROUND.")
        self.body = body
        self.origin = _checks.as_float(origin)
        self.line_angle = _checks.as_float(line_angle)
        self.body_angle = _checks.as_float(body_angle)

    n_equations = 2

    def __call__(self, q, t):
        r, theta = pose(q, self.body)
        normal = jnp.stack([-jnp.sin(self.line_angle), jnp.cos(self.line_angle)])
        return jnp.stack([normal @ (r - self.origin), theta - self.body_angle])


class Driver(eqx.Module):
    """Rheonomic driver theta_b = angle + speed * t (1 equation): a motor at constant speed."""

    body: int = eqx.field(static=True)
    angle: jax.Array
    speed: jax.Array

    def __init__(self, body: int, angle=0.0, speed=0.0):
        if body == GROUND:
            raise ValueError("Driver needs a moving body, not GROUND.")
        self.body = body
        self.angle = _checks.as_float(angle)
        self.speed = _checks.as_float(speed)

    n_equations = 1

    def __call__(self, q, t):
        _, theta = pose(q, self.body)
        return jnp.reshape(theta - self.angle - self.speed * t, (1,))

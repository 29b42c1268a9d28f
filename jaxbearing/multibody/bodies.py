"""Rigid bodies in the plane and the kinematics of their points (paper Eqs. 1–3, 16–17).

Body b has generalised coordinates q_b = [x, y, theta] of its centroid frame, stored at
q[3b : 3b + 3]. A point with body-frame position s sits at r = r_b + A(theta) s and moves with
r_dot + A'(theta) s theta_dot. Index `GROUND` (-1) denotes the fixed frame; its "body-frame"
points are global points.
"""

from __future__ import annotations

import equinox as eqx
import jax
import jax.numpy as jnp

from .. import _checks

GROUND = -1


class Body(eqx.Module):
    """A rigid body: mass [kg] and centroidal moment of inertia [kg m^2] about the plane normal."""

    mass: jax.Array
    inertia: jax.Array

    def __init__(self, mass, inertia):
        self.mass = _checks.as_float(mass, "mass", "kg")
        self.inertia = _checks.as_float(inertia, "inertia", "kg m^2")

    def violations(self, xp, named=_checks.keyword):
        """Its rules (`jaxbearing._checks`) in the array module ``xp``, each field named by
        ``named``."""
        _checks.require_scalars(self, ("mass", "inertia"), named)
        return [
            _checks.positive(xp, named("mass"), self.mass, "kg"),
            _checks.positive(xp, named("inertia"), self.inertia, "kg m^2"),
        ]

    def __check_init__(self):
        _checks.check_init(self)


def rotate(theta, s) -> jax.Array:
    """A(theta) s: a plane vector s rotated by theta [rad] (Eq. 2), written out so that XLA
    fuses it with its neighbours (a 2x2 matmul is a kernel call of its own)."""
    c, sn = jnp.cos(theta), jnp.sin(theta)
    return jnp.stack([c * s[0] - sn * s[1], sn * s[0] + c * s[1]])


def rotate_back(theta, v) -> jax.Array:
    """A(theta)^T v = A(-theta) v: a global vector v in the frame of a body at angle theta [rad],
    from the cos and sin of theta itself (`rotate`)."""
    c, sn = jnp.cos(theta), jnp.sin(theta)
    return jnp.stack([c * v[0] + sn * v[1], c * v[1] - sn * v[0]])


def pose(q, body: int):
    """(r, theta) of a body's frame; the ground frame is the origin."""
    if body == GROUND:
        return jnp.zeros(2, q.dtype), jnp.zeros((), q.dtype)
    return q[3 * body : 3 * body + 2], q[3 * body + 2]


def point_position(q, body: int, point) -> jax.Array:
    """Global position r_b + A s of a body-frame point s [m] (Eqs. 2, 16)."""
    r, theta = pose(q, body)
    return r + rotate(theta, point)


def point_velocity(q, qd, body: int, point) -> jax.Array:
    """Velocity r_dot + A' s theta_dot of a body-frame point [m/s] (Eqs. 3, 17)."""
    if body == GROUND:
        return jnp.zeros(2, q.dtype)
    _, theta = pose(q, body)
    arm = rotate(theta, point)
    omega = qd[3 * body + 2]
    return qd[3 * body : 3 * body + 2] + omega * jnp.array([-arm[1], arm[0]])


def point_force(q, body: int, point, force) -> jax.Array:
    """Generalised force [Fx, Fy, torque] of a force [N] applied at a body-frame point, as a full
    vector the size of q. Torque about the centroid: (A s) x F (Eqs. 29–34)."""
    out = jnp.zeros_like(q)
    if body == GROUND:
        return out
    _, theta = pose(q, body)
    arm = rotate(theta, point)
    torque = arm[0] * force[1] - arm[1] * force[0]
    return out.at[3 * body : 3 * body + 3].set(jnp.stack([force[0], force[1], torque]))

"""Kinematic constraints Phi(q, t) = 0 (paper Sect. 2.4, Eqs. 35–36).

Each joint gives its position equations Phi, and in closed form their Jacobian Phi_q, their
explicit time derivative Phi_t and the acceleration right-hand side
gamma = -(Phi_q q_dot)_q q_dot - 2 Phi_qt q_dot - Phi_tt. (Closed forms are several times faster
inside the solver loop than forward-mode derivatives of Phi; the tests check them against those
derivatives.)

Phi_q is given by its rows' nonzero entries (`JacobianRows`): which columns a row touches is
fixed by the joint's type and bodies, so `Mechanism` can eliminate Eq. 36 entry by entry on that
static sparsity (`Mechanism.accelerations(sparse=True)`); `jacobian` is the dense matrix.
"""

from __future__ import annotations

import abc
from typing import ClassVar, final

import equinox as eqx
import jax
import jax.numpy as jnp

from .. import _checks
from .bodies import GROUND, point_position, pose, rotate

JacobianRows = tuple[dict, ...]
"""Phi_q of a joint, one dict per equation: column of q -> the entry there (a scalar array or
a Python float); columns not in a dict are zero whatever q and t."""


def _point_rows(q, body: int, point, sign: float) -> JacobianRows:
    """Entries of d(sign * (r_b + A s))/dq: [I, B s] at the body's columns, B = dA/dtheta."""
    if body == GROUND:
        return {}, {}
    _, theta = pose(q, body)
    arm = rotate(theta, point)
    x, y, angle = 3 * body, 3 * body + 1, 3 * body + 2
    if sign > 0:
        return {x: 1.0, angle: -arm[1]}, {y: 1.0, angle: arm[0]}
    return {x: -1.0, angle: arm[1]}, {y: -1.0, angle: -arm[0]}


def _sum_rows(a: JacobianRows, b: JacobianRows) -> JacobianRows:
    """Entry-wise sum of two joints' rows with the same number of equations."""
    out = []
    for row_a, row_b in zip(a, b, strict=True):
        row = dict(row_a)
        for column, value in row_b.items():
            row[column] = row[column] + value if column in row else value
        out.append(row)
    return tuple(out)


def _point_gamma(q, qd, body: int, point) -> jax.Array:
    """-(d^2/dt^2 of A s at zero angular acceleration) = A s theta_dot^2."""
    if body == GROUND:
        return jnp.zeros(2, q.dtype)
    _, theta = pose(q, body)
    return rotate(theta, point) * qd[3 * body + 2] ** 2


def _dense(rows: JacobianRows, n_coordinates: int, dtype) -> jax.Array:
    """The rows as a dense (len(rows), n_coordinates) matrix."""
    zero = jnp.zeros((), dtype)
    return jnp.stack(
        [jnp.stack([jnp.asarray(row.get(c, zero), dtype) for c in range(n_coordinates)]) for row in rows]
    )


class AbstractJoint(eqx.Module):
    """A kinematic constraint Phi(q, t) = 0 of ``n_equations`` equations with its closed-form
    derivatives (Eqs. 35–36); every concrete joint is final."""

    n_equations: eqx.AbstractClassVar[int]

    @abc.abstractmethod
    def __call__(self, q, t) -> jax.Array:
        """Phi, (n_equations,) [m or rad]."""

    @abc.abstractmethod
    def jacobian_rows(self, q, t) -> JacobianRows:
        """Phi_q by its nonzero entries, one dict per equation (`JacobianRows`)."""

    def jacobian(self, q, t) -> jax.Array:
        """Phi_q, (n_equations, n_coordinates)."""
        return _dense(self.jacobian_rows(q, t), q.shape[0], q.dtype)

    @abc.abstractmethod
    def time_derivative(self, q, t) -> jax.Array:
        """Phi_t, (n_equations,)."""

    @abc.abstractmethod
    def gamma(self, q, qd, t) -> jax.Array:
        """gamma = -(Phi_q q_dot)_q q_dot - 2 Phi_qt q_dot - Phi_tt, (n_equations,)."""


@final
class Revolute(AbstractJoint):
    """Ideal pin: point s_i of body i coincides with point s_j of body j (2 equations).

    Either body may be `GROUND`, whose point is then a global position [m].
    """

    body_i: int = eqx.field(static=True)
    body_j: int = eqx.field(static=True)
    point_i: jax.Array
    point_j: jax.Array

    n_equations: ClassVar[int] = 2

    def __init__(self, body_i: int, point_i, body_j: int, point_j):
        if body_i == body_j:
            raise ValueError("Revolute joint needs two different bodies.")
        self.body_i, self.body_j = body_i, body_j
        self.point_i = _checks.as_float(point_i, "point_i", "m")
        self.point_j = _checks.as_float(point_j, "point_j", "m")

    def __call__(self, q, t):
        return point_position(q, self.body_i, self.point_i) - point_position(
            q, self.body_j, self.point_j
        )

    def jacobian_rows(self, q, t):
        return _sum_rows(
            _point_rows(q, self.body_i, self.point_i, 1.0),
            _point_rows(q, self.body_j, self.point_j, -1.0),
        )

    def time_derivative(self, q, t):
        return jnp.zeros(2, q.dtype)

    def gamma(self, q, qd, t):
        return _point_gamma(q, qd, self.body_i, self.point_i) - _point_gamma(
            q, qd, self.body_j, self.point_j
        )


@final
class Translational(AbstractJoint):
    """Body slides along a fixed ground line without turning (2 equations).

    The body's centroid stays on the line through ``origin`` [m] at angle ``line_angle`` [rad],
    and its orientation stays at ``body_angle`` [rad].
    """

    body: int = eqx.field(static=True)
    origin: jax.Array
    line_angle: jax.Array
    body_angle: jax.Array

    n_equations: ClassVar[int] = 2

    def __init__(self, body: int, origin=(0.0, 0.0), line_angle=0.0, body_angle=0.0):
        if body == GROUND:
            raise ValueError("Translational joint needs a moving body, not GROUND.")
        self.body = body
        self.origin = _checks.as_float(origin, "origin", "m")
        self.line_angle = _checks.as_float(line_angle, "line_angle", "rad")
        self.body_angle = _checks.as_float(body_angle, "body_angle", "rad")

    def _normal(self):
        return jnp.stack([-jnp.sin(self.line_angle), jnp.cos(self.line_angle)])

    def __call__(self, q, t):
        r, theta = pose(q, self.body)
        return jnp.stack([jnp.sum(self._normal() * (r - self.origin)), theta - self.body_angle])

    def jacobian_rows(self, q, t):
        normal, x = self._normal(), 3 * self.body
        return {x: normal[0], x + 1: normal[1]}, {x + 2: 1.0}

    def time_derivative(self, q, t):
        return jnp.zeros(2, q.dtype)

    def gamma(self, q, qd, t):
        return jnp.zeros(2, q.dtype)


@final
class Driver(AbstractJoint):
    """Rheonomic driver theta_b = angle + speed * t (1 equation): a motor at constant speed."""

    body: int = eqx.field(static=True)
    angle: jax.Array
    speed: jax.Array

    n_equations: ClassVar[int] = 1

    def __init__(self, body: int, angle=0.0, speed=0.0):
        if body == GROUND:
            raise ValueError("Driver needs a moving body, not GROUND.")
        self.body = body
        self.angle = _checks.as_float(angle, "angle", "rad")
        self.speed = _checks.as_float(speed, "speed", "rad/s")

    def __call__(self, q, t):
        _, theta = pose(q, self.body)
        return jnp.reshape(theta - self.angle - self.speed * t, (1,))

    def jacobian_rows(self, q, t):
        return ({3 * self.body + 2: 1.0},)

    def time_derivative(self, q, t):
        return jnp.reshape(-self.speed, (1,)).astype(q.dtype)

    def gamma(self, q, qd, t):
        return jnp.zeros(1, q.dtype)

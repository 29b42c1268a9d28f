"""Force elements: they enter the equations of motion through Q_A only (paper Sect. 2.3).

Every element is an `AbstractForceElement` with one signature, ``generalized_force(t, q, qd,
inputs)``: it maps the state to a generalised force vector the size of q, reading from
`ForceInputs` what it needs beyond the state. The bearing joint (Eqs. 4–5, 9–14, 28–30) reads
the initial state (its cage) and which of its balls are engaged; an impact contact (Eqs. 16–27,
31–34) reads the approach speed of its current contact, which `jaxbearing.simulate` captures at
each onset; gravity reads the body masses; the spring-damper reads nothing more.
"""

from __future__ import annotations

import abc
from typing import NamedTuple, final

import equinox as eqx
import jax
import jax.numpy as jnp

from .. import _checks
from ..laws import bearing as bearing_law
from ..laws import impact as impact_law
from ..params import AbstractBearing, Impact
from .bodies import GROUND, point_force, point_position, point_velocity, pose, rotate_back


class ForceInputs(NamedTuple):
    """What a force element may read beside (t, q, qd); `Mechanism` gives each element its own."""

    q0: jax.Array  # (n_coordinates,) initial coordinates [m, rad]
    qd0: jax.Array  # (n_coordinates,) initial velocities [m/s, rad/s]
    masses: jax.Array  # (n_bodies,) [kg]
    engaged: jax.Array | None = None  # a paper-force bearing's (N_b,) engaged balls; None: delta_r > 0
    approach_speed: jax.Array | None = None  # a contact's approach speed at onset [m/s]


class AbstractForceElement(eqx.Module):
    """A force element of a `Mechanism`; every concrete element is final."""

    @abc.abstractmethod
    def generalized_force(self, t, q, qd, inputs: ForceInputs) -> jax.Array:
        """Q of this element, (n_coordinates,) [N, N m]."""

    @abc.abstractmethod
    def bodies(self) -> tuple[int, ...]:
        """The bodies it acts on (`GROUND` = -1 allowed)."""

    @abc.abstractmethod
    def violations(self, xp, named=_checks.keyword) -> list:
        """Its parameter rules (`jaxbearing._checks`) in the array module ``xp``, those of its
        parameter Modules included, each field named by ``named`` of its dotted path in the
        element (``"bearing.clearance"``)."""

    @abc.abstractmethod
    def n_switched_balls(self) -> int:
        """Balls whose contact `simulate` switches at events (a paper-force bearing's N_b), else 0."""


def _safe_norm(x):
    """|x| with a finite gradient at x = 0."""
    sq = jnp.sum(x * x)
    safe = jnp.where(sq > 0.0, sq, 1.0)
    return jnp.where(sq > 0.0, jnp.sqrt(safe), 0.0)


def _angle_and_speed(q, qd, body: int):
    if body == GROUND:
        return jnp.zeros((), q.dtype), jnp.zeros((), q.dtype)
    return pose(q, body)[1], qd[3 * body + 2]


@final
class BearingJoint(AbstractForceElement):
    """A rolling bearing (`BallBearing` or `RollerBearing`) between an outer-race body (bush)
    and an inner-race body (journal).

    The race centres are body-frame points ``outer_point`` and ``inner_point`` [m] (Eq. 2).
    The resultant acts at the race centres: frictionless balls push along lines through the
    centres, so this is exact for the model; the paper's Eqs. 29–30 use points on the bush and
    journal surfaces, which adds a small spurious moment of size (R_i - R_j) x F.
    """

    outer_body: int = eqx.field(static=True)
    inner_body: int = eqx.field(static=True)
    outer_point: jax.Array
    inner_point: jax.Array
    bearing: AbstractBearing

    def __init__(self, outer_body: int, outer_point, inner_body: int, inner_point, bearing):
        if outer_body == inner_body:
            raise ValueError("BearingJoint needs two different bodies for its races.")
        self.outer_body, self.inner_body = outer_body, inner_body
        self.outer_point = _checks.as_float(outer_point, "outer_point", "m")
        self.inner_point = _checks.as_float(inner_point, "inner_point", "m")
        self.bearing = bearing

    def offset(self, q):
        """e = r_j^P - r_i^P [m], the eccentricity of the inner race (Eq. 4)."""
        return point_position(q, self.inner_body, self.inner_point) - point_position(
            q, self.outer_body, self.outer_point
        )

    def eccentricity(self, q, qd):
        """e = r_j^P - r_i^P [m] and its rate v [m/s] (Eqs. 4–5)."""
        e = self.offset(q)
        v = point_velocity(q, qd, self.inner_body, self.inner_point) - point_velocity(
            q, qd, self.outer_body, self.outer_point
        )
        return e, v

    def cage_angle(self, t, q, q0, qd0):
        """phi_c [rad]: kinematic (from the ring rotations since t = 0) or constant speed (Eq. 15
        at the initial ring speeds), see `AbstractBearing.cage`."""
        if self.bearing.cage == "kinematic":
            # `pose` gives the ground's angle as 0
            inner = pose(q, self.inner_body)[1] - pose(q0, self.inner_body)[1]
            outer = pose(q, self.outer_body)[1] - pose(q0, self.outer_body)[1]
            return bearing_law.cage_speed(inner, outer, self.bearing)
        omega_inner = _angle_and_speed(q0, qd0, self.inner_body)[1]
        omega_outer = _angle_and_speed(q0, qd0, self.outer_body)[1]
        return bearing_law.cage_speed(omega_inner, omega_outer, self.bearing) * t

    @property
    def switched(self) -> bool:
        """True for the paper force, whose balls engage and release at events (`simulate`)."""
        return self.bearing.ball_force == "paper"

    def ball_deflections(self, t, q, q0, qd0):
        """(N_b,) ball deflections delta_r [m] (Eq. 12), ball 1 first."""
        return bearing_law.ball_deflections(self.offset(q), self.cage_angle(t, q, q0, qd0), self.bearing)

    def ball_loads(self, t, q, qd, q0, qd0, engaged=None):
        """(N_b,) ball forces [N] and the cage angle [rad]; ``engaged`` as in
        `laws.bearing.ball_loads`."""
        e, v = self.eccentricity(q, qd)
        cage = self.cage_angle(t, q, q0, qd0)
        return bearing_law.ball_loads(e, v, cage, self.bearing, engaged), cage

    def relative_speed(self, q, qd):
        """omega_inner - omega_outer [rad/s]: the rings turn relative to each other at it, and
        fatigue counts the revolutions it turns."""
        inner = _angle_and_speed(q, qd, self.inner_body)[1]
        return inner - _angle_and_speed(q, qd, self.outer_body)[1]

    def ring_point_loads(self, q, qd, n_points: int):
        """(2, n_points) loads [N] at points fixed in the inner ring (row 0) and the outer ring
        (row 1): point k at 2 pi k / n_points in its ring body's frame, loaded as a ball placed
        there would be (`laws.bearing.ring_point_loads`)."""
        e, v = self.eccentricity(q, qd)
        rows = [
            bearing_law.ring_point_loads(
                e, v, _angle_and_speed(q, qd, body)[0], n_points, self.bearing
            )
            for body in (self.inner_body, self.outer_body)
        ]
        # joined end to end, not stacked: vmapped over a step's points, a stack puts the rings'
        # axis before the points' and XLA:CPU transposes the loads in every step's fatigue
        # integrands (`jaxbearing.recorder`; docs/performance.md)
        return jnp.concatenate(rows).reshape(2, n_points)

    def force(self, t, q, qd, q0, qd0, engaged=None):
        """Resultant on the outer-race body [N] (Eq. 28)."""
        loads, cage = self.ball_loads(t, q, qd, q0, qd0, engaged)
        return bearing_law.resultant(loads, cage)

    def generalized_force(self, t, q, qd, inputs: ForceInputs):
        f = self.force(t, q, qd, inputs.q0, inputs.qd0, inputs.engaged)
        return point_force(q, self.outer_body, self.outer_point, f) + point_force(
            q, self.inner_body, self.inner_point, -f
        )

    def bodies(self):
        return (self.outer_body, self.inner_body)

    def violations(self, xp, named=_checks.keyword):
        return self.bearing.violations(xp, lambda field: named("bearing." + field))

    def n_switched_balls(self):
        return self.bearing.n_balls if self.switched else 0


@final
class CircleContact(AbstractForceElement):
    """Impact between two circular surfaces: radius R_j centred at body-frame point c_j of body j
    and radius R_k at c_k of body k (paper Eqs. 16–27, 31–34; docs/model.md, 'Impact contact'
    and 'Contact circles and switch-on time').

    Penetration delta = R_j + R_k - |c_k - c_j|, normal n from c_j to c_k, tangent t = n rotated
    +90 deg. The normal force pushes k along +n and j along -n, applied at the surface points
    c_j + R_j n and c_k - R_k n. The contact is switched off before ``active_from`` [s] (the paper
    switches it on after half a crank turn because the circles overlap at t = 0); it must be
    separated at that time.
    """

    body_j: int = eqx.field(static=True)
    body_k: int = eqx.field(static=True)
    centre_j: jax.Array
    centre_k: jax.Array
    radius_j: jax.Array
    radius_k: jax.Array
    impact: Impact
    active_from: jax.Array

    def __init__(
        self, body_j: int, centre_j, radius_j, body_k: int, centre_k, radius_k, impact, active_from=0.0
    ):
        if body_j == body_k:
            raise ValueError("CircleContact needs two different bodies.")
        self.body_j, self.body_k = body_j, body_k
        self.centre_j = _checks.as_float(centre_j, "centre_j", "m")
        self.centre_k = _checks.as_float(centre_k, "centre_k", "m")
        self.radius_j = _checks.as_float(radius_j, "radius_j", "m")
        self.radius_k = _checks.as_float(radius_k, "radius_k", "m")
        self.impact = impact
        self.active_from = _checks.as_float(active_from, "active_from", "s")

    def violations(self, xp, named=_checks.keyword):
        return [
            _checks.positive(xp, named("radius_j"), self.radius_j, "m"),
            _checks.positive(xp, named("radius_k"), self.radius_k, "m"),
        ] + self.impact.violations(xp, lambda field: named("impact." + field))

    def bodies(self):
        return (self.body_j, self.body_k)

    def n_switched_balls(self):
        return 0

    def __check_init__(self):
        _checks.check_init(self)

    def gap(self, q, qd):
        """Penetration [m], its rate [m/s] (> 0 approaching), normal n, tangent t and the
        tangential slip speed [m/s] (Eqs. 18–22)."""
        c_j = point_position(q, self.body_j, self.centre_j)
        c_k = point_position(q, self.body_k, self.centre_k)
        r_d = c_k - c_j
        distance = _safe_norm(r_d)
        n = r_d / jnp.where(distance > 0.0, distance, 1.0)
        t = jnp.stack([-n[1], n[0]])
        penetration = self.radius_j + self.radius_k - distance
        v_j = point_velocity(q, qd, self.body_j, self.centre_j)
        v_k = point_velocity(q, qd, self.body_k, self.centre_k)
        rate = -jnp.sum((v_k - v_j) * n)
        # slip of the surface points: centre velocities plus rotation times the radius arm
        omega_j = _angle_and_speed(q, qd, self.body_j)[1]
        omega_k = _angle_and_speed(q, qd, self.body_k)[1]
        slip = jnp.sum((v_k - v_j) * t) - omega_k * self.radius_k - omega_j * self.radius_j
        return penetration, rate, n, t, slip

    def active(self, t):
        return t >= self.active_from

    def forces(self, t, q, qd, approach_speed):
        """Normal force [N] (Eq. 23) and signed tangential force along t [N] (Eq. 26)."""
        penetration, rate, _, _, slip = self.gap(q, qd)
        imp = self.impact
        normal = impact_law.lankarani_nikravesh(
            penetration, rate, approach_speed, imp.stiffness, imp.restitution
        )
        normal = jnp.where(self.active(t), normal, 0.0)
        tangential = impact_law.ambrosio_friction(
            normal, slip, imp.friction, imp.friction_v0, imp.friction_v1
        )
        return normal, tangential

    def generalized_force(self, t, q, qd, inputs: ForceInputs):
        normal, tangential = self.forces(t, q, qd, inputs.approach_speed)
        _, _, n, tan, _ = self.gap(q, qd)
        on_k = normal * n + tangential * tan
        _, theta_j = pose(q, self.body_j)
        _, theta_k = pose(q, self.body_k)
        # surface points in body frames: c + A^T (R n)
        g_j = self.centre_j + rotate_back(theta_j, self.radius_j * n)
        g_k = self.centre_k - rotate_back(theta_k, self.radius_k * n)
        return point_force(q, self.body_k, g_k, on_k) + point_force(q, self.body_j, g_j, -on_k)


@final
class SpringDamper(AbstractForceElement):
    """Linear spring-damper between point s_i of body i and s_j of body j (either may be
    `GROUND`): tension k (l - l0) + c dl/dt [N] along the line between the points."""

    body_i: int = eqx.field(static=True)
    body_j: int = eqx.field(static=True)
    point_i: jax.Array
    point_j: jax.Array
    stiffness: jax.Array
    damping: jax.Array
    free_length: jax.Array

    def __init__(self, body_i: int, point_i, body_j: int, point_j, stiffness, damping, free_length):
        self.body_i, self.body_j = body_i, body_j
        self.point_i = _checks.as_float(point_i, "point_i", "m")
        self.point_j = _checks.as_float(point_j, "point_j", "m")
        self.stiffness = _checks.as_float(stiffness, "stiffness", "N/m")
        self.damping = _checks.as_float(damping, "damping", "N s/m")
        self.free_length = _checks.as_float(free_length, "free_length", "m")

    def violations(self, xp, named=_checks.keyword):
        return [
            _checks.non_negative(xp, named("stiffness"), self.stiffness, "N/m"),
            _checks.non_negative(xp, named("damping"), self.damping, "N s/m"),
            _checks.positive(xp, named("free_length"), self.free_length, "m"),
        ]

    def __check_init__(self):
        _checks.check_init(self)

    def bodies(self):
        return (self.body_i, self.body_j)

    def n_switched_balls(self):
        return 0

    def generalized_force(self, t, q, qd, inputs: ForceInputs):
        d = point_position(q, self.body_j, self.point_j) - point_position(q, self.body_i, self.point_i)
        length = _safe_norm(d)
        u = d / jnp.where(length > 0.0, length, 1.0)
        relative_velocity = point_velocity(q, qd, self.body_j, self.point_j) - point_velocity(
            q, qd, self.body_i, self.point_i
        )
        rate = jnp.sum(relative_velocity * u)
        tension = impact_law.spring_damper(length - self.free_length, rate, self.stiffness, self.damping)
        return point_force(q, self.body_i, self.point_i, tension * u) + point_force(
            q, self.body_j, self.point_j, -tension * u
        )


@final
class Gravity(AbstractForceElement):
    """Uniform gravity g [m/s^2] on every body (off in the paper's case)."""

    acceleration: jax.Array

    def __init__(self, acceleration=(0.0, -9.80665)):
        self.acceleration = _checks.as_float(acceleration, "acceleration", "m/s^2")

    def generalized_force(self, t, q, qd, inputs: ForceInputs):
        """[m g_x, m g_y, 0] per body, for the body masses ``inputs.masses`` (n_bodies,) [kg]."""
        masses = inputs.masses
        per_body = jnp.concatenate(
            [masses[:, None] * self.acceleration[None, :], jnp.zeros((masses.shape[0], 1), q.dtype)], 1
        )
        return per_body.reshape(-1)

    def bodies(self):
        return ()

    def violations(self, xp, named=_checks.keyword):
        return []

    def n_switched_balls(self):
        return 0

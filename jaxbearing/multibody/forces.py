"""Force elements: they enter the equations of motion through Q_A only (paper Sect. 2.3).

Every element is an `AbstractForceElement`, the one protocol through which the mechanism and
the solve meet it (nothing else is read of an element). An element declares

- its **generalised force** Q (n_coordinates,) [N, N m] from (t, q, qd), its own discrete
  ``state`` and the mechanism's `ForceInputs` (initial state, masses);
- its **discrete state**, a pytree of arrays: its value at the start of a solve
  (`initial_state`), its **events** (`event_values`, each negative until it happens; the solve
  locates the time each crosses zero to 1e-13 s) and what each event does to the state
  (`on_events`). A paper-force bearing's state is which balls are engaged (engage at delta_r =
  0, release at -`BALL_RELEASE`); a contact's the approach speed of its current contact and
  whether it touches (onset at penetration 0, separation at -`SEPARATION_OFFSET`); gravity's
  nothing;
- **episodes**, where its state says it is "in" one (a contact's contacts): the solve logs each
  episode's start, end, the value `episode_value` at its start (a contact's approach speed) and
  the largest value of its `episode_peak` record over it (`solution.Contacts`);
- what it **records**: `observe` names the quantities it holds at one instant (a bearing's
  ``force`` (2,) and ``element_loads`` (Z,), a contact's ``normal_force`` and ``penetration``),
  which the solve evaluates at the output times; `peak_records` names the scalars among them
  whose exact maxima (with their times, and an array carried as it was at the peak) the solve
  records from every accepted step; `integrands` and `integral_records` the quantities it
  integrates over time (power integrals, whose power means the metrics take);
- its **parameter rules** (`violations`, `start_violations`) and the bodies it acts on;
- for a joint with play (a bearing, a journal in its hole: `clearance.ClearanceJoint`), the
  play its forces act over (`play`) and the two points that coincide where it is centred
  (`centred`), which the assembly puts together.

A new kind of element is one class implementing this protocol (docs/elements.md writes one;
`clearance.py` holds the plain bearing, an element of its own file).
"""

from __future__ import annotations

import abc
from typing import ClassVar, NamedTuple, final

import equinox as eqx
import jax
import jax.numpy as jnp

from .. import _checks
from ..laws import bearing as bearing_law
from ..laws import impact as impact_law
from ..params import AbstractBearing, Impact
from .bodies import GROUND, point_force, point_position, point_velocity, pose, rotate_back

SEPARATION_OFFSET = 1e-9  # [m] a contact separates at penetration = -1 nm: restarts never stall
BALL_RELEASE = bearing_law.BALL_RELEASE  # [m] a paper-force ball is released at delta_r = -1 pm
FORCE_SCALE = 1e3  # [N] forces are divided by it before a power p: no overflow below 1e22 N
POWER = 16  # order p of the power integrals the smooth metrics read
RING_POINTS_PER_BALL = 8  # points of each ring per ball spacing a bearing's fatigue follows
# the entries of a bearing joint's ``fatigue`` integral record (`BearingJoint.integrands`)
(FAT_TIME, FAT_REVOLUTIONS, FAT_FORCE_POWER, FAT_ELEMENT_POWER, FAT_ELEMENT_SLOPE_POWER) = range(5)


class ForceInputs(NamedTuple):
    """What every force element may read beside (t, q, qd) and its own state: the mechanism's
    initial state and masses (`Mechanism.inputs`)."""

    q0: jax.Array  # (n_coordinates,) initial coordinates [m, rad]
    qd0: jax.Array  # (n_coordinates,) initial velocities [m/s, rad/s]
    masses: jax.Array  # (n_bodies,) [kg]


class PeakRecord(NamedTuple):
    """A scalar quantity of `AbstractForceElement.observe` whose exact maximum over each
    interval between the solve's stops is recorded, with the time that attains it; ``carried``
    names an array of `observe` recorded as it was at that time (None: none)."""

    name: str
    carried: str | None = None


class IntegralRecord(NamedTuple):
    """A quantity of `AbstractForceElement.integrands` integrated over each interval between
    the solve's stops. Where it is a power integral, the integrand is the mean over its entries
    of (x / ``scale``)^``power`` of a quantity x, so that scale (integral / duration)^(1/power)
    is its power mean (`metrics.PowerMean`; ``power`` None: not a power integral). ``fatigue``:
    integrated only where the solve records what the lives read (`SolveOptions.fatigue`)."""

    name: str
    power: float | None = None
    scale: float = 1.0
    fatigue: bool = False


class AbstractForceElement(eqx.Module):
    """A force element of a `Mechanism` (module docstring). The abstract methods are required;
    the others have the defaults of an element without state, events or records. Every
    concrete element is final.

    Class attributes:
        peak_records: the `PeakRecord` of each exact peak it records.
        integral_records: the `IntegralRecord` of each integral it records.
        episode_peak: the name of the peak record whose maximum over each episode the solve
            logs, for an element with episodes (`in_episode`); None: no episodes.
    """

    peak_records: ClassVar[tuple[PeakRecord, ...]] = ()
    integral_records: ClassVar[tuple[IntegralRecord, ...]] = ()
    episode_peak: ClassVar[str | None] = None

    @abc.abstractmethod
    def generalized_force(self, t, q, qd, state, inputs: ForceInputs) -> jax.Array:
        """Q of this element, (n_coordinates,) [N, N m], with its discrete ``state``."""

    @abc.abstractmethod
    def bodies(self) -> tuple[int, ...]:
        """The bodies it acts on (`GROUND` = -1 allowed)."""

    @abc.abstractmethod
    def violations(self, xp, named=_checks.keyword) -> list:
        """Its parameter rules (`jaxbearing._checks`) in the array module ``xp``, those of its
        parameter Modules included, each field named by ``named`` of its dotted path in the
        element (``"bearing.clearance"``)."""

    def start_violations(self, t0, q0, qd0, inputs: ForceInputs) -> list:
        """Rules on the state a solve starts from (`jax.numpy`), e.g. a contact switched on
        while its surfaces overlap; none by default."""
        return []

    def initial_state(self, t0, q0, qd0, inputs: ForceInputs):
        """Its discrete state at the start t0 [s] of a solve, a pytree of arrays (None: none;
        not an empty tuple, which the solve's loops cannot carry as a buffer)."""
        return None

    def event_values(self, t, q, qd, state, inputs: ForceInputs) -> jax.Array:
        """One value per event, (E,), each negative until it happens (a zero crossing); the
        count E is fixed (static). None by default."""
        return jnp.zeros((0,), q.dtype)

    def on_events(self, t, q, qd, state, crossed, inputs: ForceInputs):
        """The state after the events ``crossed`` (E,) bool at (t, q, qd)."""
        return state

    def in_episode(self, state) -> jax.Array:
        """Whether ``state`` is in an episode (elements with an ``episode_peak``)."""
        raise NotImplementedError(f"{type(self).__name__} has no episodes.")

    def episode_value(self, state) -> jax.Array:
        """The value logged at the start of an episode (elements with an ``episode_peak``)."""
        raise NotImplementedError(f"{type(self).__name__} has no episodes.")

    def observe(self, t, q, qd, state, inputs: ForceInputs) -> dict:
        """The quantities it holds at one instant, name -> array (SI units); none by default."""
        return {}

    def integrands(self, t, q, qd, state, observed: dict, inputs: ForceInputs, fatigue: bool) -> dict:
        """The integrand of each of its `integral_records` at one instant, name -> array, from
        ``observed`` (its `observe` there); ``fatigue`` (static): those marked ``fatigue``
        too."""
        return {}

    def play(self) -> jax.Array | None:
        """The free play its forces act over [m] (a bearing's diametral clearance; negative: a
        preload, whose compression its forces act over), which sets how much constraint drift
        a run may have (`Mechanism.drift_bound`); None: none."""
        return None

    def centred(self) -> tuple[tuple[int, jax.Array], tuple[int, jax.Array]] | None:
        """For a joint with play (a bearing, a journal in its hole): the two (body, body-frame
        point [m]) pairs that coincide where it is centred, which `Mechanism.assemble` puts
        together and beside which no ideal pin may join the same bodies; None (the default):
        none."""
        return None


def _safe_norm(x):
    """|x| with a finite gradient at x = 0."""
    sq = jnp.sum(x * x)
    safe = jnp.where(sq > 0.0, sq, 1.0)
    return jnp.where(sq > 0.0, jnp.sqrt(safe), 0.0)


def _angle_and_speed(q, qd, body: int):
    if body == GROUND:
        return jnp.zeros((), q.dtype), jnp.zeros((), q.dtype)
    return pose(q, body)[1], qd[3 * body + 2]


def _magnitude(force) -> jax.Array:
    """|F| [N] of a force (2,), smooth at 0."""
    return jnp.sqrt(jnp.sum(force * force) + 1e-30)


@final
class BearingJoint(AbstractForceElement):
    """A rolling bearing (`BallBearing` or `RollerBearing`) between an outer-race body (bush)
    and an inner-race body (journal).

    The race centres are body-frame points ``outer_point`` and ``inner_point`` [m] (Eq. 2).
    The resultant acts at the race centres: frictionless balls push along lines through the
    centres, so this is exact for the model; the paper's Eqs. 29–30 use points on the bush and
    journal surfaces, which adds a small spurious moment of size (R_i - R_j) x F.

    State: with the paper's ball force, which balls are engaged ((N_b,) bool; events at
    delta_r = 0 and -`BALL_RELEASE`); none with the smooth force. Records: ``element_loads``
    (N_b,) [N] (ball 1 first; "element" is a ball or a roller), ``force`` (2,) [N] on the
    outer-race body (Eq. 28), ``cage_angle`` [rad]; exact peaks of ``max_element_load`` (with
    ``element_loads`` at the peak) and ``force_magnitude``; integrals of |F|^2, of the element
    loads' and |F|'s power `POWER`, and, for the lives, the relative revolutions and the load
    powers they weigh (`integrands`).
    """

    outer_body: int = eqx.field(static=True)
    inner_body: int = eqx.field(static=True)
    outer_point: jax.Array
    inner_point: jax.Array
    bearing: AbstractBearing

    peak_records = (PeakRecord("max_element_load", "element_loads"), PeakRecord("force_magnitude"))
    integral_records = (
        IntegralRecord("force_squared", 2.0),
        IntegralRecord("element_load_power", POWER, FORCE_SCALE),
        IntegralRecord("force_power", POWER, FORCE_SCALE),
        IntegralRecord("fatigue", fatigue=True),
        IntegralRecord("inner_ring_power", fatigue=True),
        IntegralRecord("outer_ring_power", fatigue=True),
    )

    def __init__(self, outer_body: int, outer_point, inner_body: int, inner_point, bearing):
        if outer_body == inner_body:
            raise ValueError("BearingJoint needs two different bodies for its races.")
        if not isinstance(bearing, AbstractBearing):
            raise TypeError(
                f"BearingJoint's bearing must be a jaxbearing.BallBearing or RollerBearing; got "
                f"{type(bearing).__name__}."
            )
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
        """True for the paper force, whose balls engage and release at events."""
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
        # integrands (docs/performance.md)
        return jnp.concatenate(rows).reshape(2, n_points)

    def force(self, t, q, qd, q0, qd0, engaged=None):
        """Resultant on the outer-race body [N] (Eq. 28)."""
        loads, cage = self.ball_loads(t, q, qd, q0, qd0, engaged)
        return bearing_law.resultant(loads, cage)

    def _engaged(self, state):
        """The engaged balls of ``state`` (paper force), None for the smooth force."""
        return state if self.switched else None

    def generalized_force(self, t, q, qd, state, inputs: ForceInputs):
        f = self.force(t, q, qd, inputs.q0, inputs.qd0, self._engaged(state))
        return point_force(q, self.outer_body, self.outer_point, f) + point_force(
            q, self.inner_body, self.inner_point, -f
        )

    def initial_state(self, t0, q0, qd0, inputs: ForceInputs):
        """The paper force's engaged balls at t0 (those with delta_r > 0); None for the smooth."""
        if not self.switched:
            return None
        return self.ball_deflections(t0, q0, inputs.q0, inputs.qd0) > 0.0

    def event_values(self, t, q, qd, state, inputs: ForceInputs):
        """Paper force, per ball: delta_r while free (engages at 0), -(delta_r +
        `BALL_RELEASE`) while engaged; none for the smooth force."""
        if not self.switched:
            return jnp.zeros((0,), q.dtype)
        delta = self.ball_deflections(t, q, inputs.q0, inputs.qd0)
        return jnp.where(state, -(delta + BALL_RELEASE), delta)

    def on_events(self, t, q, qd, state, crossed, inputs: ForceInputs):
        """Each ball whose event ``crossed`` engages or is released."""
        if not self.switched:
            return state
        return jnp.where(crossed, ~state, state)

    def observe(self, t, q, qd, state, inputs: ForceInputs) -> dict:
        loads, cage = self.ball_loads(t, q, qd, inputs.q0, inputs.qd0, self._engaged(state))
        force = bearing_law.resultant(loads, cage)
        return {
            "element_loads": loads,
            "force": force,
            "cage_angle": cage,
            "max_element_load": jnp.max(loads),
            "force_magnitude": _magnitude(force),
        }

    def integrands(self, t, q, qd, state, observed, inputs: ForceInputs, fatigue: bool) -> dict:
        """|F|^2 [N^2]; the mean over elements of (Q_r / `FORCE_SCALE`)^`POWER` and (|F| /
        `FORCE_SCALE`)^`POWER`; where ``fatigue``, what the lives read (`solution.FatigueStats`),
        weighted by the relative revolutions w = |omega_inner - omega_outer| / (2 pi) [rev/s]:
        ``fatigue`` (5,) = (1, w, w (|F| / FORCE_SCALE)^p (p the bearing's ``life_exponent``),
        the means over elements of w (Q_r / FORCE_SCALE)^m and of w (Q_r / FORCE_SCALE)^(m e))
        (entries ``FAT_*``; m the bearing's ``raceway_exponent``, 3 for balls, 4 for rollers, e
        its ``weibull_slope``), and w (Q_k / FORCE_SCALE)^m at M = `RING_POINTS_PER_BALL` N_b
        points fixed in each ring (``inner_ring_power``, ``outer_ring_power``, (M,) each)."""
        force, loads = observed["force"], observed["element_loads"]
        scaled = loads / FORCE_SCALE
        out = {
            "force_squared": jnp.sum(force * force),
            "element_load_power": jnp.mean(scaled**POWER),
            "force_power": (observed["force_magnitude"] / FORCE_SCALE) ** POWER,
        }
        if fatigue:
            w = jnp.abs(self.relative_speed(q, qd)) / (2.0 * jnp.pi)
            scaled_force = force / FORCE_SCALE
            points = self.ring_point_loads(q, qd, RING_POINTS_PER_BALL * self.bearing.n_balls)
            m = self.bearing.raceway_exponent  # an integer: 3 (balls) or 4 (rollers)
            rings = w * (points / FORCE_SCALE) ** m
            out.update(
                fatigue=jnp.stack(
                    [
                        jnp.ones_like(w),
                        w,
                        w * jnp.sum(scaled_force * scaled_force) ** (0.5 * self.bearing.life_exponent),
                        w * jnp.mean(scaled**m),
                        w * jnp.mean(scaled ** (m * self.bearing.weibull_slope)),
                    ]
                ),
                inner_ring_power=rings[0],
                outer_ring_power=rings[1],
            )
        return out

    def bodies(self):
        return (self.outer_body, self.inner_body)

    def violations(self, xp, named=_checks.keyword):
        return self.bearing.violations(xp, lambda field: named("bearing." + field))

    def play(self):
        """The diametral clearance P_d [m] (negative: a preload)."""
        return self.bearing.clearance

    def centred(self):
        """The race centres: ``(outer_body, outer_point)``, ``(inner_body, inner_point)``."""
        return (self.outer_body, self.outer_point), (self.inner_body, self.inner_point)


class ContactState(NamedTuple):
    """An impact contact's discrete state: the approach speed of its current contact [m/s]
    (delta_dot^(-) of Eq. 23, captured at the onset) and whether it touches; with its event
    and its switch, which every contact of this law shares (`CircleContact`, the plain
    bearing's `ClearanceJoint`)."""

    approach_speed: jax.Array
    in_contact: jax.Array

    def event_value(self, penetration) -> jax.Array:
        """The penetration [m] while apart (an onset at 0), -(penetration +
        `SEPARATION_OFFSET`) while touching (a separation at -1 nm)."""
        return jnp.where(self.in_contact, -(penetration + SEPARATION_OFFSET), penetration)

    def switched(self, crossed, rate) -> ContactState:
        """The state after its event ``crossed`` (bool) where the penetration rate is ``rate``
        [m/s]: an onset captures the approach speed, a separation ends the contact."""
        onset = crossed & ~self.in_contact
        return ContactState(
            jnp.where(onset, rate, self.approach_speed),
            jnp.where(crossed, ~self.in_contact, self.in_contact),
        )


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

    State: `ContactState`; events at penetration 0 (onset: the approach speed is captured) and
    -`SEPARATION_OFFSET` (separation); each contact is an episode. Records: ``normal_force``
    [N], ``friction_force`` [N] (along t), ``penetration`` [m] (negative when apart),
    ``approach_speed`` [m/s]; the exact peak of ``normal_force`` and the integral of its power
    `POWER`.
    """

    body_j: int = eqx.field(static=True)
    body_k: int = eqx.field(static=True)
    centre_j: jax.Array
    centre_k: jax.Array
    radius_j: jax.Array
    radius_k: jax.Array
    impact: Impact
    active_from: jax.Array

    peak_records = (PeakRecord("normal_force"),)
    integral_records = (IntegralRecord("normal_force_power", POWER, FORCE_SCALE),)
    episode_peak = "normal_force"

    def __init__(
        self, body_j: int, centre_j, radius_j, body_k: int, centre_k, radius_k, impact, active_from=0.0
    ):
        if body_j == body_k:
            raise ValueError("CircleContact needs two different bodies.")
        if not isinstance(impact, Impact):
            raise TypeError(f"CircleContact's impact must be a jaxbearing.Impact; got {type(impact).__name__}.")
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

    def start_violations(self, t0, q0, qd0, inputs: ForceInputs):
        overlap = self.gap(q0, qd0)[0]
        return [
            (
                self.active(t0) & (overlap > 0.0),
                "is switched on at t0 while its surfaces overlap (penetration [m]): start it "
                "apart, or switch it on later (active_from) when they are apart",
                overlap,
            )
        ]

    def bodies(self):
        return (self.body_j, self.body_k)

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

    def generalized_force(self, t, q, qd, state, inputs: ForceInputs):
        normal, tangential = self.forces(t, q, qd, state.approach_speed)
        _, _, n, tan, _ = self.gap(q, qd)
        on_k = normal * n + tangential * tan
        _, theta_j = pose(q, self.body_j)
        _, theta_k = pose(q, self.body_k)
        # surface points in body frames: c + A^T (R n)
        g_j = self.centre_j + rotate_back(theta_j, self.radius_j * n)
        g_k = self.centre_k - rotate_back(theta_k, self.radius_k * n)
        return point_force(q, self.body_k, g_k, on_k) + point_force(q, self.body_j, g_j, -on_k)

    def initial_state(self, t0, q0, qd0, inputs: ForceInputs):
        """Apart (a start in contact is refused: `start_violations`)."""
        zero = jnp.zeros((), q0.dtype)
        return ContactState(zero, jnp.zeros((), bool))

    def event_values(self, t, q, qd, state, inputs: ForceInputs):
        """The penetration while apart (onset at 0), -(penetration + `SEPARATION_OFFSET`)
        while touching, -1 while switched off (``active_from``)."""
        value = state.event_value(self.gap(q, qd)[0])
        return jnp.where(self.active(t), value, -1.0)[None]

    def on_events(self, t, q, qd, state, crossed, inputs: ForceInputs):
        """An onset captures the approach speed (the penetration rate there); a separation
        ends the contact (`ContactState.switched`)."""
        return state.switched(crossed[0], self.gap(q, qd)[1])

    def in_episode(self, state):
        return state.in_contact

    def episode_value(self, state):
        return state.approach_speed

    def observe(self, t, q, qd, state, inputs: ForceInputs) -> dict:
        normal, tangential = self.forces(t, q, qd, state.approach_speed)
        return {
            "normal_force": normal,
            "friction_force": tangential,
            "penetration": self.gap(q, qd)[0],
            "approach_speed": state.approach_speed,
        }

    def integrands(self, t, q, qd, state, observed, inputs: ForceInputs, fatigue: bool) -> dict:
        """(normal force / `FORCE_SCALE`)^`POWER`."""
        return {"normal_force_power": (observed["normal_force"] / FORCE_SCALE) ** POWER}


@final
class SpringDamper(AbstractForceElement):
    """Linear spring-damper between point s_i of body i and s_j of body j (either may be
    `GROUND`): tension k (l - l0) + c dl/dt [N] along the line between the points. Records
    ``tension`` [N] and ``length`` [m]."""

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

    def _line(self, q, qd):
        """The unit vector u from point i to point j, the length [m], and the tension [N]."""
        d = point_position(q, self.body_j, self.point_j) - point_position(q, self.body_i, self.point_i)
        length = _safe_norm(d)
        u = d / jnp.where(length > 0.0, length, 1.0)
        relative_velocity = point_velocity(q, qd, self.body_j, self.point_j) - point_velocity(
            q, qd, self.body_i, self.point_i
        )
        rate = jnp.sum(relative_velocity * u)
        tension = impact_law.spring_damper(length - self.free_length, rate, self.stiffness, self.damping)
        return u, length, tension

    def generalized_force(self, t, q, qd, state, inputs: ForceInputs):
        u, _, tension = self._line(q, qd)
        return point_force(q, self.body_i, self.point_i, tension * u) + point_force(
            q, self.body_j, self.point_j, -tension * u
        )

    def observe(self, t, q, qd, state, inputs: ForceInputs) -> dict:
        _, length, tension = self._line(q, qd)
        return {"tension": tension, "length": length}


@final
class Gravity(AbstractForceElement):
    """Uniform gravity g [m/s^2] on every body (off in the paper's case)."""

    acceleration: jax.Array

    def __init__(self, acceleration=(0.0, -9.80665)):
        self.acceleration = _checks.as_float(acceleration, "acceleration", "m/s^2")

    def generalized_force(self, t, q, qd, state, inputs: ForceInputs):
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

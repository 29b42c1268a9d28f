"""The plain bearing: a revolute joint with clearance, dry or lubricated (docs/plain_bearings.md).

A journal of radius R on body j turns in a hole of radius R + c on body i (c the radial
clearance). Where their centres are apart by less than c the journal flies free; the
eccentricity e = r_j - r_i (the journal's centre from the hole's, each a body-frame point)
sets everything else:

- **dry contact** (Flores, Ambrósio, Claro and Lankarani, *Kinematics and Dynamics of
  Multibody Systems with Imperfect Joints*, Springer 2008): where the penetration
  delta = |e| - c is positive, the Lankarani–Nikravesh normal force (`laws.impact.
  lankarani_nikravesh`, paper Eq. 23, with the approach speed captured at the contact's onset,
  an event located as an impact contact's is) pushes the journal back along n = e / |e|, and
  Ambrósio's friction (`laws.impact.ambrosio_friction`, Eqs. 26–27) acts along t (n turned
  +90 deg) at the contact point, opposing the slip v_T = e_dot . t + omega_j R - omega_i (R +
  c); its moment about each centre follows from the point. Free flight, impacts and
  continuous contact (a contact that lasts while the journal slides round the hole) are
  one law;
- **lubricated** (``viscosity`` > 0; Flores, Ambrósio, Claro, Lankarani and Koshy, Nonlinear
  Dyn. 56 (2009) 277–295): the short-bearing (Ocvirk) film force with the half-Sommerfeld
  condition, its squeeze and wedge terms (`laws.journal.film_force`), acts through both
  centres at every eccentricity ratio epsilon = |e| / c. It grows without bound as epsilon -> 1;
  above ``film_limit`` it is held at its value there (the film thinner than the surfaces'
  roughness carries no more), and the dry contact takes over where the journal reaches the
  hole (epsilon >= 1). The film's shear torque is not modelled.

`JournalBearing` holds the parameters; `ClearanceJoint` is the force element
(`AbstractForceElement`). Its metrics are those of any element, e.g. for the element named
"pin":

- peak joint force: ``metrics.ElementPeak("force_magnitude", element="pin")``;
- RMS joint force: ``metrics.PowerMean("force_squared", element="pin")``;
- largest penetration: ``metrics.ElementPeak("penetration", element="pin")``;
- largest eccentricity ratio: ``metrics.ElementPeak("eccentricity_ratio", element="pin")``;
- peak contact force: ``metrics.ElementPeak("normal_force", element="pin")``.
"""

from __future__ import annotations

from typing import NamedTuple, final

import equinox as eqx
import jax
import jax.numpy as jnp

from .. import _checks
from ..laws import impact as impact_law
from ..laws import journal as journal_law
from .bodies import GROUND, point_force, point_position, point_velocity
from .forces import (
    FORCE_SCALE,
    POWER,
    SEPARATION_OFFSET,
    AbstractForceElement,
    ContactState,
    ForceInputs,
    IntegralRecord,
    PeakRecord,
    _angle_and_speed,
    _magnitude,
    _safe_norm,
)

FILM_LIMIT = 0.95  # default `JournalBearing.film_limit`: h_min = c / 20 (1 um at c = 20 um)


class JournalBearing(eqx.Module):
    """A plain (journal) bearing's parameters, SI units (module docstring).

    Fields:
        clearance: c = R_hole - R_journal, the radial clearance [m] (above 1 nm, the penetration
            at which a contact ends: `forces.SEPARATION_OFFSET`).
        radius: R, the journal's radius [m] (> 0).
        length: L, the bearing's length [m] (> 0): the film force's (short-bearing theory
            holds for L / (2 R) up to about 1/2: `laws.journal`).
        stiffness: K, the contact's Hertz constant [N/m^1.5] (> 0): `from_geometry` computes it.
        restitution: e_c of the Lankarani–Nikravesh contact, in (0, 1].
        friction: mu, Coulomb friction coefficient of the dry contact (>= 0).
        friction_v0, friction_v1: slip speeds between which friction ramps in [m/s] (Ambrósio,
            Eq. 27), 0 <= v0 < v1.
        viscosity: the lubricant's dynamic viscosity [Pa s] (>= 0; 0: dry).
        film_limit: the eccentricity ratio above which the film force is held at its value
            there (in (0, 1); the film is then c (1 - film_limit) thick).
    """

    clearance: jax.Array
    radius: jax.Array
    length: jax.Array
    stiffness: jax.Array
    restitution: jax.Array
    friction: jax.Array
    friction_v0: jax.Array
    friction_v1: jax.Array
    viscosity: jax.Array
    film_limit: jax.Array

    def __init__(
        self,
        clearance,
        radius,
        length,
        stiffness,
        restitution,
        friction=0.0,
        friction_v0=1e-4,
        friction_v1=1e-3,
        viscosity=0.0,
        film_limit=FILM_LIMIT,
    ):
        self.clearance = _checks.as_float(clearance, "clearance", "m")
        self.radius = _checks.as_float(radius, "radius", "m")
        self.length = _checks.as_float(length, "length", "m")
        self.stiffness = _checks.as_float(stiffness, "stiffness", "N/m^1.5")
        self.restitution = _checks.as_float(restitution, "restitution", "-")
        self.friction = _checks.as_float(friction, "friction", "-")
        self.friction_v0 = _checks.as_float(friction_v0, "friction_v0", "m/s")
        self.friction_v1 = _checks.as_float(friction_v1, "friction_v1", "m/s")
        self.viscosity = _checks.as_float(viscosity, "viscosity", "Pa s")
        self.film_limit = _checks.as_float(film_limit, "film_limit", "-")

    @classmethod
    def from_geometry(
        cls,
        *,
        radius,
        clearance,
        length,
        restitution,
        youngs_modulus=207e9,
        poisson_ratio=0.3,
        **kwargs,
    ) -> JournalBearing:
        """The stiffness of a journal of radius R [m] in a hole of radius R + c (clearance c
        [m]), both of one material (Young's modulus E [Pa] > 0, Poisson's ratio nu in (0,
        0.5)): Hertz's sphere in a spherical seat, the law of Flores et al.
        (`laws.journal.contact_stiffness`). It is computed here and does not follow later
        changes of the radius or the clearance. Other keyword arguments go to the constructor
        (friction, viscosity, ...)."""
        k = journal_law.contact_stiffness(radius, clearance, youngs_modulus, poisson_ratio)
        return cls(clearance, radius, length, k, restitution, **kwargs)

    @property
    def hole_radius(self) -> jax.Array:
        """R + c [m]."""
        return _checks.evaluate(lambda xp, r, c: r + c, self.radius, self.clearance)

    def violations(self, xp, named=_checks.keyword):
        """Its rules (`jaxbearing._checks`) in the array module ``xp``, each field named by
        ``named``."""
        fields = (
            "clearance", "radius", "length", "stiffness", "restitution", "friction", "friction_v0",
            "friction_v1", "viscosity", "film_limit",
        )  # fmt: skip
        _checks.require_scalars(self, fields, named)
        v0, v1 = xp.asarray(self.friction_v0), xp.asarray(self.friction_v1)
        return [
            _checks.positive(xp, named("clearance"), self.clearance, "m"),
            (
                xp.asarray(self.clearance) <= SEPARATION_OFFSET,
                f"{named('clearance')} must exceed {SEPARATION_OFFSET:g} m, the penetration at "
                "which a contact ends (forces.SEPARATION_OFFSET) [m]",
                self.clearance,
            ),
            _checks.positive(xp, named("radius"), self.radius, "m"),
            _checks.positive(xp, named("length"), self.length, "m"),
            _checks.positive(xp, named("stiffness"), self.stiffness, "N/m^1.5"),
            _checks.in_half_open_interval(xp, named("restitution"), self.restitution, 0.0, 1.0),
            _checks.non_negative(xp, named("friction"), self.friction, "-"),
            _checks.non_negative(xp, named("friction_v0"), v0, "m/s"),
            (v1 <= v0, f"{named('friction_v1')} must exceed {named('friction_v0')} [m/s]", v1),
            _checks.non_negative(xp, named("viscosity"), self.viscosity, "Pa s"),
            _checks.in_open_interval(xp, named("film_limit"), self.film_limit, 0.0, 1.0),
        ]

    def __check_init__(self):
        _checks.check_init(self)


class _Gap(NamedTuple):
    """The journal against its hole at one instant: e [m] and its rate [m/s], |e| [m], n, t,
    the penetration |e| - c [m] and its rate [m/s] (> 0 approaching), the slip speed at the
    contact [m/s], and the film's squeeze and wedge rates [1/s] (`laws.journal.film_force`)
    at the eccentricity ratio it is evaluated at (|e| / c, at most ``film_limit``)."""

    e: jax.Array
    rate: jax.Array
    distance: jax.Array
    n: jax.Array
    t: jax.Array
    penetration: jax.Array
    approach: jax.Array
    slip: jax.Array
    film_ratio: jax.Array
    squeeze: jax.Array
    wedge: jax.Array


@final
class ClearanceJoint(AbstractForceElement):
    """A revolute joint with clearance: the hole (centre ``point_i`` [m] in body i's frame) and
    the journal (centre ``point_j`` in body j's), with the parameters ``journal`` (a
    `JournalBearing`); dry, or lubricated where its viscosity is positive (module docstring).

    State: `ContactState` (the approach speed of the current contact, whether the journal
    touches); events at penetration 0 (onset: the approach speed is captured) and
    -`SEPARATION_OFFSET` (separation); each contact is an episode. A journal that starts
    touching starts a contact at its penetration rate then.

    Records (`observe`; forces on the hole's body i, the journal's is opposite):
    ``normal_force`` [N] and ``friction_force`` [N] (along t) of the dry contact,
    ``penetration`` |e| - c [m] (negative when apart), ``eccentricity`` e (2,) [m] (the
    journal's orbit), ``eccentricity_ratio`` |e| / c, ``film_force`` (2,) [N], the
    hydrodynamic force, ``force`` (2,) [N], the whole joint force, ``force_magnitude`` [N],
    ``approach_speed`` [m/s]; exact peaks of ``normal_force``, ``penetration``,
    ``eccentricity_ratio`` and ``force_magnitude``; integrals of |F|^2 (``force_squared``, the
    RMS) and of (|F| / `FORCE_SCALE`)^`POWER` (``force_power``, a smooth peak).
    """

    body_i: int = eqx.field(static=True)
    body_j: int = eqx.field(static=True)
    point_i: jax.Array
    point_j: jax.Array
    journal: JournalBearing

    peak_records = (
        PeakRecord("normal_force"),
        PeakRecord("penetration"),
        PeakRecord("eccentricity_ratio"),
        PeakRecord("force_magnitude"),
    )
    integral_records = (
        IntegralRecord("force_squared", 2.0),
        IntegralRecord("force_power", POWER, FORCE_SCALE),
    )
    episode_peak = "normal_force"

    def __init__(self, body_i: int, point_i, body_j: int, point_j, journal):
        if body_i == body_j:
            raise ValueError(
                "ClearanceJoint needs two different bodies: the hole's and the journal's."
            )
        if not isinstance(journal, JournalBearing):
            raise TypeError(
                "ClearanceJoint's journal must be a jaxbearing.JournalBearing; got "
                f"{type(journal).__name__}."
            )
        self.body_i, self.body_j = body_i, body_j
        self.point_i = _checks.as_float(point_i, "point_i", "m")
        self.point_j = _checks.as_float(point_j, "point_j", "m")
        self.journal = journal

    def bodies(self):
        return (self.body_i, self.body_j)

    def violations(self, xp, named=_checks.keyword):
        return self.journal.violations(xp, lambda field: named("journal." + field))

    def play(self):
        """The diametral clearance 2 c [m]."""
        return _checks.evaluate(lambda xp, c: 2.0 * c, self.journal.clearance)

    def centred(self):
        """The hole's and the journal's centres."""
        return (self.body_i, self.point_i), (self.body_j, self.point_j)

    def eccentricity(self, q, qd):
        """e = r_j - r_i [m], the journal's centre from the hole's, and its rate [m/s]."""
        journal, hole = (self.body_j, self.point_j), (self.body_i, self.point_i)
        e = point_position(q, *journal) - point_position(q, *hole)
        return e, point_velocity(q, qd, *journal) - point_velocity(q, qd, *hole)

    def gap(self, q, qd) -> _Gap:
        """The journal against its hole at (q, qd) (`_Gap`)."""
        p = self.journal
        e, rate = self.eccentricity(q, qd)
        distance = _safe_norm(e)
        apart = distance > 0.0
        n = jnp.where(apart, e / jnp.where(apart, distance, 1.0), jnp.array([1.0, 0.0]))
        t = jnp.stack([-n[1], n[0]])
        omega_i = _angle_and_speed(q, qd, self.body_i)[1]
        omega_j = _angle_and_speed(q, qd, self.body_j)[1]
        along, across = jnp.sum(rate * n), jnp.sum(rate * t)
        # the film: epsilon, held at film_limit; w = epsilon (omega_j + omega_i) - 2 epsilon
        # phi_dot with epsilon phi_dot = (n x e_dot) / c (finite at e = 0), scaled with epsilon
        ratio = distance / p.clearance
        held = ratio > p.film_limit
        film_ratio = jnp.where(held, p.film_limit, ratio)
        scale = jnp.where(held, p.film_limit / jnp.where(held, ratio, 1.0), 1.0)
        wedge = film_ratio * (omega_j + omega_i) - 2.0 * scale * across / p.clearance
        return _Gap(
            e, rate, distance, n, t, distance - p.clearance, along,
            across + omega_j * p.radius - omega_i * (p.radius + p.clearance),
            film_ratio, along / p.clearance, wedge,
        )  # fmt: skip

    def forces(self, q, qd, approach_speed):
        """The dry contact's normal force [N] (>= 0, pushing the journal along -n) and its
        friction [N] (on the journal, along t), the film force on the journal along n and t
        [N], and the `_Gap`."""
        p = self.journal
        g = self.gap(q, qd)
        normal = impact_law.lankarani_nikravesh(
            g.penetration, g.approach, approach_speed, p.stiffness, p.restitution
        )
        friction = impact_law.ambrosio_friction(
            normal, g.slip, p.friction, p.friction_v0, p.friction_v1
        )
        film = journal_law.film_force(
            g.film_ratio, g.squeeze, g.wedge, p.viscosity, p.radius, p.length, p.clearance
        )
        return normal, friction, film, g

    def _on_journal(self, q, qd, approach_speed):
        """The whole force on the journal (2,) [N], the film's (2,) [N], the friction [N], the
        normal force [N] and the `_Gap`."""
        normal, friction, (film_n, film_t), g = self.forces(q, qd, approach_speed)
        film = film_n * g.n + film_t * g.t
        return film - normal * g.n + friction * g.t, film, friction, normal, g

    def generalized_force(self, t, q, qd, state, inputs: ForceInputs):
        """The joint force through both centres, and the friction's moments about them: R F_T
        on the journal, -(R + c) F_T on the hole (the contact point is R n from the journal's
        centre and (R + c) n from the hole's)."""
        force, _, friction, _, _ = self._on_journal(q, qd, state.approach_speed)
        p = self.journal
        out = point_force(q, self.body_j, self.point_j, force)
        out = out + point_force(q, self.body_i, self.point_i, -force)
        for body, arm in ((self.body_j, p.radius), (self.body_i, -(p.radius + p.clearance))):
            if body != GROUND:
                out = out.at[3 * body + 2].add(arm * friction)
        return out

    def initial_state(self, t0, q0, qd0, inputs: ForceInputs):
        """Touching where the penetration is positive at t0, its approach speed the
        penetration rate there."""
        g = self.gap(q0, qd0)
        touching = g.penetration > 0.0
        return ContactState(jnp.where(touching, g.approach, 0.0), touching)

    def event_values(self, t, q, qd, state, inputs: ForceInputs):
        """The penetration while apart (onset at 0), -(penetration + `SEPARATION_OFFSET`)
        while touching."""
        return state.event_value(self.gap(q, qd).penetration)[None]

    def on_events(self, t, q, qd, state, crossed, inputs: ForceInputs):
        """An onset captures the approach speed (the penetration rate there); a separation
        ends the contact (`ContactState.switched`)."""
        return state.switched(crossed[0], self.gap(q, qd).approach)

    def in_episode(self, state):
        return state.in_contact

    def episode_value(self, state):
        return state.approach_speed

    def observe(self, t, q, qd, state, inputs: ForceInputs) -> dict:
        force, film, friction, normal, g = self._on_journal(q, qd, state.approach_speed)
        return {
            "normal_force": normal,
            "friction_force": friction,
            "penetration": g.penetration,
            "eccentricity": g.e,
            "eccentricity_ratio": g.distance / self.journal.clearance,
            "film_force": -film,
            "force": -force,
            "force_magnitude": _magnitude(force),
            "approach_speed": state.approach_speed,
        }

    def integrands(self, t, q, qd, state, observed, inputs: ForceInputs, fatigue: bool) -> dict:
        """|F|^2 [N^2] and (|F| / `FORCE_SCALE`)^`POWER` of the joint force F."""
        force = observed["force"]
        return {
            "force_squared": jnp.sum(force * force),
            "force_power": (observed["force_magnitude"] / FORCE_SCALE) ** POWER,
        }

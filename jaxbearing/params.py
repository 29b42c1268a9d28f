"""Parameter Modules of the force laws, in SI units.

Numbers are float64 array leaves, so `eqx.tree_at`, `jax.vmap` and `jax.grad` see them; choices
of model (cage mode, force variant, exponent) are static fields. Rules on the values live in each
Module's ``violations(xp, named)`` (`jaxbearing._checks`) and are checked at construction and
again inside `jaxbearing.simulate`.
"""

from __future__ import annotations

import math
import numbers
from typing import ClassVar, Literal

import equinox as eqx
import jax

from . import _checks
from .laws import hertz, rules

CageMode = Literal["kinematic", "constant"]
BallForce = Literal["paper", "smooth"]

MAX_CLEARANCE_FRACTION = 0.1  # largest diametral clearance, as a fraction of the element diameter
# largest preload (a negative diametral clearance), as a fraction of the element diameter: the
# preload alone compresses each element by |P_d|/2 and, for steel elements, reaches ISO 76's
# permissible contact stress (4 200 MPa balls, 4 000 MPa rollers) at 1.4-1.5 % (balls of
# conformity 0.52) and 1.65-1.7 % (rollers) of the element diameter, nearly whatever the size
# (Hertz: the approach at a given stress scales with the element). At 1 % the preload alone
# stays below 84 % of it (docs/model.md, 'Clearance and preload').
MAX_PRELOAD_FRACTION = 0.01
# Catalogue bearings: the internal geometry from_geometry needs (pitch and ball diameter [m],
# balls, groove curvature ratios f = r/D). SKF 98205: paper Table 2; the groove ratios
# reproduce the paper's K_i, K_o (docs/model.md, 'Groove curvature ratios').
CATALOGUE = {
    "98205": dict(pitch_diameter=37.9e-3, ball_diameter=8.7e-3, n_balls=8, groove_inner=0.5219, groove_outer=0.5194),
}
# Cylindrical roller bearings (pitch and roller diameter, effective roller length L_we [m],
# rollers), docs/model.md, 'Roller bearings': "209", Harris & Kotzalas' 209 cylindrical roller
# bearing (raceways 54.991 and 75.032 mm, 14 rollers of 10 mm, effective length 9.6 mm);
# "NU206", an NU 206: raceways F = 37.5 mm and E = 55.5 mm from SKF's General Catalogue
# (NU 206 ECP, N 206 ECP; C_r 44 kN, C_0r 36.5 kN), 13 rollers of 9 x 10 mm from the NU 206
# of the tribology package's P3CAN input template (Ploss et al., doi:10.5281/zenodo.1117727);
# 10 mm is the rollers' length, an upper bound of L_we (docs/life.md, 'A catalogue roller
# bearing of published internals');
# "NU205-estimated", internals estimated for an NU 205 (the SKF 98205's envelope) from the
# catalogue's inner raceway diameter F = 31.5 mm and ratings C_r 28.6 kN, C_0r 27.0 kN.
ROLLER_CATALOGUE = {
    "209": dict(pitch_diameter=65.0115e-3, roller_diameter=10e-3, roller_length=9.6e-3, n_rollers=14),
    "NU206": dict(pitch_diameter=46.5e-3, roller_diameter=9e-3, roller_length=10e-3, n_rollers=13),
    "NU205-estimated": dict(
        pitch_diameter=38.9e-3, roller_diameter=7.4e-3, roller_length=7.9e-3, n_rollers=13
    ),
}
BALL_EXPONENT = 1.5
ROLLER_EXPONENT = 10.0 / 9.0


def _check_choices(n_elements, name, cage, ball_force):
    """The static choices of a bearing: an integer count of at least 3 (``name``: n_balls or
    n_rollers), the cage mode and the force variant."""
    if (
        isinstance(n_elements, (bool, str))
        or not isinstance(n_elements, numbers.Real)
        or not math.isfinite(n_elements)
        or int(n_elements) != n_elements
        or n_elements < 3
    ):
        raise ValueError(f"{name} must be an integer of at least 3; got {n_elements!r}.")
    if cage not in ("kinematic", "constant"):
        raise ValueError(f"cage must be 'kinematic' or 'constant'; got {cage!r}.")
    if ball_force not in ("paper", "smooth"):
        raise ValueError(f"ball_force must be 'paper' or 'smooth'; got {ball_force!r}.")


class AbstractBearing(eqx.Module):
    """A radial rolling bearing seen by the planar model (paper Sect. 2.1): what the force laws
    (`jaxbearing.laws.bearing`), the bearing joint and the records read, for every kind of
    rolling element. `BallBearing` and `RollerBearing` are its final kinds; "ball" in field
    and array names (``n_balls``, ``ball_force``, ``ball_loads``) means "rolling element".

    Fields:
        clearance: P_d, diametral operating clearance [m] (Eq. 12 subtracts P_d/2 on each side);
            at most `MAX_CLEARANCE_FRACTION` of the element diameter (catalogue clearances are
            below 1 %); negative for a preload (an interference fit), down to
            -`MAX_PRELOAD_FRACTION` of the element diameter (docs/model.md, 'Clearance and
            preload').
        stiffness: K_b, element load–deflection constant, inner and outer contact in series
            [N/m^exponent] (Eq. 11 for balls; Palmgren's line contact for rollers).
        damping: C_b, per-element damping coefficient [N s/m] (Eq. 9).
        inner_race_diameter: d_i, inner raceway diameter [m] (cage speed, Eq. 15).
        outer_race_diameter: d_o, outer raceway diameter [m] (cage speed, Eq. 15).
        damping_ramp: deflection over which the smooth variant ramps the damping in [m].
        n_balls: N_b, number of rolling elements (static).
        exponent: n of Eq. 9: 3/2 for balls (the constructor's default), 10/9 for rollers
            (static).
        cage: ``"kinematic"`` (cage angle from the ring angles, the default) or ``"constant"``
            (cage speed of Eq. 15 at the initial ring speeds), see docs/model.md, 'Cage angle'
            (static).
        ball_force: ``"paper"`` (Eq. 9, damping on at first touch) or ``"smooth"`` (damping
            ramped in over ``damping_ramp``, for gradients) (static).

    Class constants: ``life_exponent``, p of the load–life law L10 = (C/P)^p (ISO 281: 3 for
    ball bearings, 10/3 for roller bearings); ``raceway_exponent``, the load–life exponent of one
    raceway contact, L = (Q_c/Q_e)^m (Lundberg–Palmgren: 3 for point contact, 4 for line
    contact); ``weibull_slope``, e of the raceways' survival, with which their lives combine
    (10/9 for balls, 9/8 for rollers; `jaxbearing.life.reference_life`).
    """

    clearance: jax.Array
    stiffness: jax.Array
    damping: jax.Array
    inner_race_diameter: jax.Array
    outer_race_diameter: jax.Array
    damping_ramp: jax.Array
    n_balls: int = eqx.field(static=True)
    exponent: float = eqx.field(static=True)
    cage: CageMode = eqx.field(static=True)
    ball_force: BallForce = eqx.field(static=True)
    life_exponent: eqx.AbstractClassVar[float]
    raceway_exponent: eqx.AbstractClassVar[int]
    weibull_slope: eqx.AbstractClassVar[float]

    def __init__(
        self,
        clearance,
        stiffness,
        damping,
        inner_race_diameter,
        outer_race_diameter,
        n_balls: int,
        *,
        exponent: float = BALL_EXPONENT,
        cage: CageMode = "kinematic",
        ball_force: BallForce = "paper",
        damping_ramp=1e-6,
    ):
        _check_choices(n_balls, "n_balls", cage, ball_force)
        if (
            isinstance(exponent, (bool, str))
            or not isinstance(exponent, numbers.Real)
            or not (math.isfinite(exponent) and exponent > 1.0)
        ):
            raise ValueError(
                f"exponent must be a finite number above 1 (3/2 balls, 10/9 rollers); got {exponent!r}."
            )
        self.clearance = _checks.as_float(clearance, "clearance", "m")
        self.stiffness = _checks.as_float(stiffness, "stiffness", "N/m^n")
        self.damping = _checks.as_float(damping, "damping", "N s/m")
        self.inner_race_diameter = _checks.as_float(inner_race_diameter, "inner_race_diameter", "m")
        self.outer_race_diameter = _checks.as_float(outer_race_diameter, "outer_race_diameter", "m")
        self.damping_ramp = _checks.as_float(damping_ramp, "damping_ramp", "m")
        self.n_balls = int(n_balls)
        self.exponent = float(exponent)
        self.cage = cage
        self.ball_force = ball_force

    @property
    def ball_diameter(self) -> jax.Array:
        """D = (d_o - d_i) / 2 [m], the rolling element's diameter."""
        return _checks.evaluate(
            lambda xp, inner, outer: 0.5 * (outer - inner), self.inner_race_diameter, self.outer_race_diameter
        )

    @property
    def pitch_diameter(self) -> jax.Array:
        """d_m = (d_i + d_o) / 2 [m]."""
        return _checks.evaluate(
            lambda xp, inner, outer: 0.5 * (outer + inner), self.inner_race_diameter, self.outer_race_diameter
        )

    def violations(self, xp, named=_checks.keyword):
        """Its rules (`jaxbearing._checks`) in the array module ``xp``, each field named by
        ``named``."""
        _checks.require_scalars(
            self, ("clearance", "stiffness", "damping", "inner_race_diameter", "outer_race_diameter", "damping_ramp"),
            named,
        )
        clearance, inner, outer = (xp.asarray(v) for v in (self.clearance, self.inner_race_diameter, self.outer_race_diameter))
        return [
            _checks.positive(xp, named("stiffness"), self.stiffness, "N/m^n"),
            _checks.non_negative(xp, named("damping"), self.damping, "N s/m"),
            _checks.positive(xp, named("inner_race_diameter"), inner, "m"),
            (
                outer <= inner,
                f"{named('outer_race_diameter')} must exceed {named('inner_race_diameter')} [m]",
                outer,
            ),
            _checks.positive(xp, named("damping_ramp"), self.damping_ramp, "m"),
            (
                clearance > MAX_CLEARANCE_FRACTION * xp.asarray(self.ball_diameter),
                f"{named('clearance')} must be at most {MAX_CLEARANCE_FRACTION} of the ball diameter "
                "(d_o - d_i) / 2, far above any catalogue clearance [m]",
                clearance,
            ),
            (
                clearance < -MAX_PRELOAD_FRACTION * xp.asarray(self.ball_diameter),
                f"{named('clearance')} must be at least -{MAX_PRELOAD_FRACTION} of the ball "
                "diameter (d_o - d_i) / 2: a negative clearance is a preload, and a deeper one "
                "alone loads the elements near ISO 76's permissible contact stress [m]",
                clearance,
            ),
        ]

    def __check_init__(self):
        _checks.check_init(self)


def _race_diameters(pitch_diameter, element_diameter):
    """(d_i, d_o) = (d_m - D, d_m + D) [m]."""
    return _checks.evaluate(lambda xp, dm, d: (dm - d, dm + d), pitch_diameter, element_diameter)


def _designation(catalogue, designation):
    if designation not in catalogue:
        raise ValueError(f"designation must be one of {sorted(catalogue)}; got {designation!r}.")
    return catalogue[designation]


class BallBearing(AbstractBearing):
    """A radial ball bearing (paper Sect. 2.1): the fields of `AbstractBearing`, built from its
    geometry by `from_geometry` (Eqs. 10–11) or by `from_catalogue`.

    ``exponent`` may be set (default 3/2): with 10/9 a `BallBearing` is the paper's stand-in for
    a roller bearing of the given stiffness; `RollerBearing` is the roller bearing itself.
    """

    life_exponent: ClassVar[float] = 3.0
    raceway_exponent: ClassVar[int] = 3
    weibull_slope: ClassVar[float] = 10.0 / 9.0

    @classmethod
    def from_geometry(
        cls,
        *,
        pitch_diameter,
        ball_diameter,
        n_balls: int,
        groove_inner,
        groove_outer,
        clearance,
        damping,
        youngs_modulus=207e9,
        poisson_ratio=0.3,
        **kwargs,
    ) -> BallBearing:
        """Build from the bearing's internal geometry (Eqs. 10–11, Harris).

        Args:
            pitch_diameter: d_m [m]. ball_diameter: D [m].
            groove_inner, groove_outer: raceway groove curvature ratios f = r/D (> 0.5).
            clearance: P_d, diametral [m]. damping: C_b [N s/m].
            youngs_modulus [Pa], poisson_ratio: of balls and rings.

        Besides the rules of `BallBearing` and of `hertz.bearing_stiffness` (D > 0, d_m > D,
        f > 0.5, E > 0, nu in (0, 0.5)), the n_balls balls must fit around the pitch circle:
        D < d_m sin(pi / n_balls).
        """
        _, _, k_ball = hertz.bearing_stiffness(
            ball_diameter, pitch_diameter, groove_inner, groove_outer, youngs_modulus, poisson_ratio
        )
        _checks.check(
            lambda xp, z, d, dm: [rules.ball_count(xp, z), rules.balls_fit(xp, z, d, dm)],
            n_balls, ball_diameter, pitch_diameter,
        )
        d_i, d_o = _race_diameters(pitch_diameter, ball_diameter)
        return cls(
            clearance=clearance,
            stiffness=k_ball,
            damping=damping,
            inner_race_diameter=d_i,
            outer_race_diameter=d_o,
            n_balls=n_balls,
            **kwargs,
        )

    @classmethod
    def from_catalogue(cls, designation: str, *, clearance=0.04e-3, damping=300.0, **kwargs) -> BallBearing:
        """A catalogue bearing by its designation (the keys of `CATALOGUE`: "98205", the paper's
        SKF 98205) with the given diametral clearance P_d [m] and per-ball damping C_b [N s/m]
        (defaults: the paper's 40 um and 300 N s/m); other keyword arguments go to
        `from_geometry` (E, nu, cage, ball_force, ...)."""
        geometry = _designation(CATALOGUE, designation)
        return cls.from_geometry(**geometry, clearance=clearance, damping=damping, **kwargs)


class RollerBearing(AbstractBearing):
    """A radial cylindrical roller bearing (NU, N, NJ types under radial load) seen by the
    planar model: the fields of `AbstractBearing` (``n_balls``: its number of rollers,
    ``exponent`` 10/9), plus the rollers' effective length, built from its geometry by
    `from_geometry` (Palmgren's line contact, steel only) or by `from_catalogue`.

    Fields (besides `AbstractBearing`'s):
        roller_length: L_we, effective contact length of a roller [m] (its length less the end
            chamfers or crown run-outs), which the load ratings and the contact stress read.
            The stiffness is built from it by `from_geometry` and does not follow later changes.
    """

    roller_length: jax.Array
    life_exponent: ClassVar[float] = 10.0 / 3.0
    raceway_exponent: ClassVar[int] = 4
    weibull_slope: ClassVar[float] = 9.0 / 8.0

    def __init__(
        self,
        clearance,
        stiffness,
        damping,
        inner_race_diameter,
        outer_race_diameter,
        n_rollers: int,
        roller_length,
        *,
        cage: CageMode = "kinematic",
        ball_force: BallForce = "paper",
        damping_ramp=1e-6,
    ):
        _check_choices(n_rollers, "n_rollers", cage, ball_force)
        super().__init__(
            clearance, stiffness, damping, inner_race_diameter, outer_race_diameter, n_rollers,
            exponent=ROLLER_EXPONENT, cage=cage, ball_force=ball_force, damping_ramp=damping_ramp,
        )  # fmt: skip
        self.roller_length = _checks.as_float(roller_length, "roller_length", "m")

    @classmethod
    def from_geometry(
        cls,
        *,
        pitch_diameter,
        roller_diameter,
        roller_length,
        n_rollers: int,
        clearance,
        damping,
        **kwargs,
    ) -> RollerBearing:
        """Build from the bearing's internal geometry: the roller stiffness of Palmgren's
        line-contact deflection, inner and outer raceway in series
        (`laws.hertz.roller_stiffness`; docs/model.md, 'Roller bearings'). Palmgren's law is
        empirical, for rollers and rings of bearing steel: there is no material argument.

        Args:
            pitch_diameter: d_m [m]. roller_diameter: D_we [m] (> 0, below d_m).
            roller_length: L_we, effective contact length [m] (> 0).
            n_rollers: Z (an integer of at least 3); the rollers must fit around the pitch
                circle: D_we < d_m sin(pi / Z).
            clearance: P_d, diametral [m]. damping: C_b, per roller [N s/m].
            **kwargs: cage, ball_force, damping_ramp (see `AbstractBearing`).
        """
        for forbidden in ("youngs_modulus", "poisson_ratio"):
            if forbidden in kwargs:
                raise TypeError(
                    f"RollerBearing.from_geometry takes no {forbidden}: the roller stiffness is "
                    "Palmgren's empirical line-contact law for bearing steel only."
                )
        d, dm, length = _checks.as_floats(
            (roller_diameter, "roller_diameter", "m"),
            (pitch_diameter, "pitch_diameter", "m"),
            (roller_length, "roller_length", "m"),
        )
        _checks.check(
            lambda xp, z, d, dm, length: [
                rules.ball_count(xp, z, "n_rollers"),
                _checks.positive(xp, "roller_diameter", d, "m"),
                rules.pitch_exceeds_ball(xp, dm, d),
                _checks.positive(xp, "roller_length", length, "m"),
                rules.balls_fit(xp, z, d, dm, element="roller"),
            ],
            n_rollers, d, dm, length,
        )
        d_i, d_o = _race_diameters(pitch_diameter, roller_diameter)
        return cls(
            clearance=clearance,
            stiffness=hertz.roller_stiffness(length),
            damping=damping,
            inner_race_diameter=d_i,
            outer_race_diameter=d_o,
            n_rollers=n_rollers,
            roller_length=length,
            **kwargs,
        )

    @classmethod
    def from_catalogue(
        cls, designation: str, *, clearance=0.04e-3, damping=300.0, **kwargs
    ) -> RollerBearing:
        """A cylindrical roller bearing by its designation (the keys of `ROLLER_CATALOGUE`:
        "209", Harris & Kotzalas' 209 cylindrical roller bearing; "NU206", an NU 206 of
        published internals; "NU205-estimated", internals estimated for the NU 205;
        docs/model.md, 'Roller bearings') with the given diametral clearance P_d [m] and
        per-roller damping C_b [N s/m] (defaults: the paper's 40 um and 300 N s/m); other
        keyword arguments go to `from_geometry` (cage, ball_force, ...)."""
        geometry = _designation(ROLLER_CATALOGUE, designation)
        return cls.from_geometry(**geometry, clearance=clearance, damping=damping, **kwargs)

    @property
    def roller_diameter(self) -> jax.Array:
        """D_we = (d_o - d_i) / 2 [m]."""
        return self.ball_diameter

    def violations(self, xp, named=_checks.keyword):
        """Its rules: `AbstractBearing`'s and L_we > 0."""
        _checks.require_scalars(self, ("roller_length",), named)
        return super().violations(xp, named) + [
            _checks.positive(xp, named("roller_length"), self.roller_length, "m")
        ]


class Impact(eqx.Module):
    """Lankarani–Nikravesh contact with Ambrosio friction (paper Eqs. 23, 26–27).

    Fields:
        stiffness: K_d, Hertz constant of the pair [N/m^1.5] (Eqs. 24–25).
        restitution: e_c, coefficient of restitution, in (0, 1].
        friction: mu, Coulomb friction coefficient (>= 0).
        friction_v0, friction_v1: tangential speeds between which friction ramps in [m/s]
            (Eq. 27), 0 <= v0 < v1.
    """

    stiffness: jax.Array
    restitution: jax.Array
    friction: jax.Array
    friction_v0: jax.Array
    friction_v1: jax.Array

    def __init__(self, stiffness, restitution, friction=0.0, friction_v0=1e-4, friction_v1=1e-3):
        self.stiffness = _checks.as_float(stiffness, "stiffness", "N/m^1.5")
        self.restitution = _checks.as_float(restitution, "restitution", "-")
        self.friction = _checks.as_float(friction, "friction", "-")
        self.friction_v0 = _checks.as_float(friction_v0, "friction_v0", "m/s")
        self.friction_v1 = _checks.as_float(friction_v1, "friction_v1", "m/s")

    @classmethod
    def from_geometry(
        cls, *, radius_j, radius_k, restitution, youngs_modulus=207e9, poisson_ratio=0.3, **kwargs
    ) -> Impact:
        """Stiffness of two spheres (or circular arcs) of radii R_j, R_k [m] of one material:
        Young's modulus E [Pa] (> 0) and Poisson's ratio nu (in (0, 0.5))."""
        _checks.check(rules.material, youngs_modulus, poisson_ratio)
        k = hertz.impact_stiffness(radius_j, radius_k, youngs_modulus, poisson_ratio)
        return cls(stiffness=k, restitution=restitution, **kwargs)

    def violations(self, xp, named=_checks.keyword):
        """Its rules (`jaxbearing._checks`) in the array module ``xp``, each field named by
        ``named``."""
        _checks.require_scalars(self, ("stiffness", "restitution", "friction", "friction_v0", "friction_v1"), named)
        v0, v1 = xp.asarray(self.friction_v0), xp.asarray(self.friction_v1)
        return [
            _checks.positive(xp, named("stiffness"), self.stiffness, "N/m^1.5"),
            _checks.in_half_open_interval(xp, named("restitution"), self.restitution, 0.0, 1.0),
            _checks.non_negative(xp, named("friction"), self.friction, "-"),
            _checks.non_negative(xp, named("friction_v0"), v0, "m/s"),
            (v1 <= v0, f"{named('friction_v1')} must exceed {named('friction_v0')} [m/s]", v1),
        ]

    def __check_init__(self):
        _checks.check_init(self)

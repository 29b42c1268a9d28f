"""ISO/TS 16281's basic reference rating life L10r of a radial bearing from its rolling
elements' loads: the raceway ratings from the basic dynamic load rating C_r and the geometry,
the equivalent element loads of the rotating and the stationary ring, and the ring lives
combined with the raceways' Weibull slope (docs/life.md, 'The reference rating life').

Notation: Z elements, m the raceway load–life exponent (3 point contact, 4 line contact), e the
Weibull slope (10/9, 9/8), n the load–deflection exponent (3/2, 10/9): the bearing's
``raceway_exponent``, ``weibull_slope`` and ``exponent``.
"""

from __future__ import annotations

import math
from typing import Literal

import equinox as eqx
import jax

from .. import _checks
from ..params import AbstractBearing, RollerBearing
from ._distribution import LoadDistribution, _power, load_distribution
from ._formulas import reliability_factor
from ._ratings import dynamic_rating

ISO_CONFORMITY = 0.52  # raceway conformities r/D that ISO 281's ball ratings assume (both rings)


class ReferenceLife(eqx.Module):
    """ISO/TS 16281's basic reference rating life (`reference_life`).

    Fields: rating_inner, rating_outer: the raceway ratings Q_ci, Q_ce [N];
    load_inner, load_outer: the equivalent element loads Q_ei, Q_ee of each ring [N];
    life_inner, life_outer: ring lives (Q_c/Q_e)^m [millions of relative revolutions];
    l10: L10r, the bearing's [millions of relative revolutions]; speed: the mean relative
    speed n [rpm]; l10_hours [h]; a1, lnm = a1 L10r, lnm_hours: as `RatingLife`'s. The static
    form has speed and the hours only where given a ``speed_rpm`` (else None).
    """

    rating_inner: jax.Array
    rating_outer: jax.Array
    load_inner: jax.Array
    load_outer: jax.Array
    life_inner: jax.Array
    life_outer: jax.Array
    l10: jax.Array
    speed: jax.Array | None
    l10_hours: jax.Array | None
    a1: jax.Array
    lnm: jax.Array
    lnm_hours: jax.Array | None


def _cos_power_mean(a: float) -> float:
    """(1/pi) int_0^(pi/2) cos^a(psi) dpsi: the mean of (cos psi)_+^a over a revolution."""
    return math.gamma((a + 1.0) / 2.0) / (2.0 * math.sqrt(math.pi) * math.gamma(a / 2.0 + 1.0))


def load_zone_integrals(exponent: float, raceway_exponent: float, weibull_slope: float):
    """Harris' load-zone integrals at zero clearance (epsilon = 1/2), where an element at angle
    psi from the load line carries Q_max cos(psi)^n over half the bearing:

        J_r = F_r / (Z Q_max) = mean of (cos psi)_+^(n+1)
        J_1 = Q_e / Q_max of a ring rotating relative to the load, (mean of (cos psi)_+^(n m))^(1/m)
        J_2 = Q_e / Q_max of a ring stationary relative to it, (mean of (cos psi)_+^(n m e))^(1/(m e))

    (means over a revolution; Harris & Kotzalas, *Essential Concepts*, ch. 7 and 11). Balls
    (n 3/2, m 3, e 10/9): 0.2288, 0.5625, 0.5874, so Stribeck's Q_max = 4.37 F_r / Z; rollers
    (n 10/9, m 4, e 9/8): 0.2448, 0.6504, 0.6743, Q_max = 4.08 F_r / Z.

    Args: exponent n, raceway_exponent m, weibull_slope e (numbers). Returns (J_r, J_1, J_2).
    """
    n, m, e = float(exponent), float(raceway_exponent), float(weibull_slope)
    return (
        _cos_power_mean(n + 1.0),
        _cos_power_mean(n * m) ** (1.0 / m),
        _cos_power_mean(n * m * e) ** (1.0 / (m * e)),
    )


def _rating_ratio(xp, gamma, fi, fo, roller: bool):
    """kappa = Q_ci / Q_ce of the geometry (Lundberg–Palmgren; ISO/TR 1281-1): balls
    ((1-g)/(1+g))^1.72 (f_i (2 f_e - 1) / (f_e (2 f_i - 1)))^0.41, rollers ((1-g)/(1+g))^(143/108)."""
    base = (1.0 - gamma) / (1.0 + gamma)
    if roller:
        return base ** (143.0 / 108.0)
    return base**1.72 * (fi * (2.0 * fo - 1.0) / (fo * (2.0 * fi - 1.0))) ** 0.41


def _ratings_kernel(xp, c, z, d, dm, fi, fo, roller, integrals, m, e):
    j_r, j_1, j_2 = integrals
    kappa = _rating_ratio(xp, d / dm, fi, fo, roller)
    q_ci = c * j_1 / (z * j_r) * (1.0 + (kappa * j_2 / j_1) ** (m * e)) ** (1.0 / (m * e))
    return q_ci, q_ci / kappa


def _conformities(bearing, groove_inner, groove_outer):
    """(f_i, f_o) of a ball bearing (None: `ISO_CONFORMITY`), checked; a roller's are unused
    and refused where given."""
    if isinstance(bearing, RollerBearing):
        if groove_inner is not None or groove_outer is not None:
            raise ValueError(
                "groove_inner and groove_outer are ball raceway conformities; a RollerBearing's "
                "line contacts have none (leave them None)."
            )
        return _checks.as_float(0.0, "groove_inner", "-"), _checks.as_float(0.0, "groove_outer", "-")
    fi, fo = _checks.as_floats(
        (ISO_CONFORMITY if groove_inner is None else groove_inner, "groove_inner", "-"),
        (ISO_CONFORMITY if groove_outer is None else groove_outer, "groove_outer", "-"),
    )
    _checks.check(
        lambda xp, fi, fo: [
            _checks.finite(xp, "groove_inner", fi),
            _checks.finite(xp, "groove_outer", fo),
            (fi <= 0.5, "groove_inner (inner raceway conformity f_i = r_i/D) must exceed 0.5", fi),
            (fo <= 0.5, "groove_outer (outer raceway conformity f_o = r_o/D) must exceed 0.5", fo),
        ],
        fi, fo,
    )  # fmt: skip
    return fi, fo


def reference_ratings(bearing: AbstractBearing, *, load_rating=None, groove_inner=None, groove_outer=None):
    """The raceway ratings (Q_ci, Q_ce) [N] of ISO/TS 16281: the element load under which 90 %
    of the inner (outer) raceways survive 1e6 relative revolutions, from the bearing's basic
    dynamic load rating and geometry, such that at zero clearance under a pure radial load the
    reference rating life is ISO 281's (C_r / F_r)^p with Harris' load-zone integrals
    (`load_zone_integrals`):

        Q_ci = C_r J_1 / (Z J_r) (1 + (kappa J_2 / J_1)^(m e))^(1/(m e)),   Q_ce = Q_ci / kappa

    kappa = Q_ci / Q_ce of Lundberg–Palmgren's geometry: ((1-g)/(1+g))^1.72 (f_i (2 f_e - 1) /
    (f_e (2 f_i - 1)))^0.41 for balls, ((1-g)/(1+g))^(143/108) for rollers (g = D / d_m; ISO/TR
    1281-1). For balls J_r/J_1 = 0.407 and J_2/J_1 = 1.044 are the constants of ISO 281's f_c
    (39.9 = 0.407 x 98.1), so with the conformities 0.52 these are Lundberg–Palmgren's ratings
    times b_m and the standard's reduction (`ball_race_load_ratings`, within 0.3 %).

    Args:
        bearing: a `BallBearing` or `RollerBearing`.
        load_rating: C_r [N] (> 0); None: ISO 281's from the geometry (`dynamic_rating`). A
            maker's catalogue rating may be given.
        groove_inner, groove_outer: a ball bearing's raceway conformities f = r/D (> 0.5;
            None: 0.52, what ISO 281's ratings assume; `cases.xu2014`: `cases.GROOVE_INNER`,
            `GROOVE_OUTER`); a roller bearing has none.
    """
    if not isinstance(bearing, AbstractBearing):
        raise TypeError(f"bearing must be a jaxbearing BallBearing or RollerBearing; got {type(bearing).__name__}.")
    fi, fo = _conformities(bearing, groove_inner, groove_outer)
    if load_rating is None:
        c = dynamic_rating(bearing)
    else:
        c = _checks.as_float(load_rating, "load_rating", "N")
        _checks.check(
            lambda xp, c: [_checks.finite(xp, "load_rating", c), _checks.positive(xp, "load_rating", c, "N")], c
        )
    b = bearing
    integrals = load_zone_integrals(b.exponent, b.raceway_exponent, b.weibull_slope)
    roller = isinstance(b, RollerBearing)
    return _checks.evaluate(
        lambda xp, c, d, dm, fi, fo: _ratings_kernel(
            xp, c, b.n_balls, d, dm, fi, fo, roller, integrals, b.raceway_exponent, b.weibull_slope
        ),
        c, b.ball_diameter, b.pitch_diameter, fi, fo,
    )  # fmt: skip


def _static_kernel(xp, loads, q_ci, q_ce, a1, m, e, inner_rotating):
    """(Q_ei, Q_ee, L_i, L_e, L10r, L_nm) of the element loads at one cage position."""
    rotating = _power(xp, xp.mean(_power(xp, loads, m)), 1.0 / m)
    stationary = _power(xp, xp.mean(_power(xp, loads, m * e)), 1.0 / (m * e))
    q_ei, q_ee = (rotating, stationary) if inner_rotating else (stationary, rotating)
    lives = _lives(xp, q_ei, q_ee, q_ci, q_ce, m, e)
    return (q_ei, q_ee, *lives, a1 * lives[-1])


def _lives(xp, q_ei, q_ee, q_ci, q_ce, m, e):
    """(L_i, L_e, L10r) [millions of revolutions]: L = (Q_c / Q_e)^m, +inf for an unloaded
    ring, combined as (L_i^-e + L_e^-e)^(-1/e) (the rings fail independently, Weibull slope e)."""
    inv_i = _power(xp, q_ei / q_ci, m * e)  # L_i^-e
    inv_e = _power(xp, q_ee / q_ce, m * e)
    total = inv_i + inv_e
    inf = float("inf")

    def life(inv):
        safe = xp.where(inv > 0.0, inv, 1.0)
        return xp.where(inv > 0.0, safe ** (-1.0 / e), inf)

    return life(inv_i), life(inv_e), life(total)


def static_reference_life(
    bearing: AbstractBearing,
    load,
    *,
    cage=None,
    rotating: Literal["inner", "outer"] | None = None,
    load_rating=None,
    groove_inner=None,
    groove_outer=None,
    reliability=0.9,
    speed_rpm=None,
) -> tuple[ReferenceLife, LoadDistribution]:
    """`reference_life`'s static form, with the load distribution it rates."""
    if rotating not in (None, "inner", "outer"):
        raise ValueError(f"rotating must be None, 'inner' or 'outer'; got {rotating!r}.")
    q_ci, q_ce = reference_ratings(
        bearing, load_rating=load_rating, groove_inner=groove_inner, groove_outer=groove_outer
    )
    a1 = reliability_factor(reliability)
    distribution = load_distribution(bearing, load, cage)
    m, e = bearing.raceway_exponent, bearing.weibull_slope
    inner = rotating in (None, "inner")
    q_ei, q_ee, l_i, l_e, l10, lnm = _checks.evaluate(
        lambda xp, q, ci, ce, a1: _static_kernel(xp, q, ci, ce, a1, m, e, inner),
        distribution.element_loads, q_ci, q_ce, a1,
    )  # fmt: skip
    speed = hours = lnm_hours = None
    if speed_rpm is not None:
        speed = _checks.as_float(speed_rpm, "speed_rpm", "rpm")
        _checks.check(
            lambda xp, n: [_checks.finite(xp, "speed_rpm", n), _checks.positive(xp, "speed_rpm", n, "rpm")], speed
        )
        hours, lnm_hours = (1e6 * x / (60.0 * speed) for x in (l10, lnm))
    life = ReferenceLife(q_ci, q_ce, q_ei, q_ee, l_i, l_e, l10, speed, hours, a1, lnm, lnm_hours)
    return life, distribution

"""Load ratings from a bearing's geometry: ISO 281:2007's basic dynamic load rating C_r of
radial ball and roller bearings, the Lundberg–Palmgren ball–raceway ratings Q_ci, Q_co (Harris
& Kotzalas, ch. 8) and ISO 76:2006's basic static load rating C_0r of radial ball and roller
bearings."""

from __future__ import annotations

import jax
import numpy as np

from .. import _checks
from ..laws import rules
from ..params import RollerBearing

B_M = 1.3  # ISO 281:2007 rating factor b_m for contemporary hardened bearing steel (Table 1)
LP_CONSTANT = 98.1  # [N / mm^1.8] Lundberg–Palmgren constant of Q_c (Harris & Kotzalas)
LARGE_BALL = 25.4  # [mm] above this ball diameter D^1.8 becomes 3.647 D^1.4 (ISO 281:2007)

# ISO 281:2007, Table 2, first column ("single-row radial contact groove ball bearings and
# single- and double-row angular contact groove ball bearings"): f_c against
# D_w cos(alpha) / D_pw = 0.01, 0.02, ..., 0.40. The standard interpolates linearly.
FC_RATIO = np.round(np.arange(1, 41) * 0.01, 2)
FC_TABLE = np.array(
    [
        29.1, 35.8, 40.3, 43.8, 46.7, 49.1, 51.1, 52.8, 54.3, 55.5,
        56.6, 57.5, 58.2, 58.8, 59.3, 59.6, 59.8, 59.9, 60.0, 59.9,
        59.8, 59.6, 59.3, 59.0, 58.6, 58.2, 57.7, 57.1, 56.6, 56.0,
        55.3, 54.6, 53.9, 53.2, 52.4, 51.7, 50.9, 50.0, 49.2, 48.4,
    ]
)  # fmt: skip

# ISO 281:2007 b_m of radial cylindrical roller bearings (Table 1). With it the standard's formula
# rates the "NU206" internals 3.5 % below SKF's catalogue C_r of the NU 206 ECP, 44 kN (tested in
# tests/test_rollers.py); the ball bearings' 1.3 would put it 14 % above (docs/life.md).
B_M_ROLLER = 1.1
# ISO 281:2007, Table 7 (radial roller bearings): f_c against D_we cos(alpha) / D_pw = 0.01,
# 0.02, ..., 0.30, interpolated linearly. Each entry is 0.83 (the standard's reduction) times
# the closed form of ISO/TR 1281-1, 207.9 g^(2/9) (1-g)^(29/27) (1+g)^(-1/4) [1 + (1.04
# ((1-g)/(1+g))^(143/108))^(9/2)]^(-2/9), to the table's rounding (tests/test_rollers.py).
FC_ROLLER_RATIO = np.round(np.arange(1, 31) * 0.01, 2)
FC_ROLLER_TABLE = np.array(
    [
        52.1, 60.8, 66.5, 70.7, 74.1, 76.9, 79.2, 81.2, 82.8, 84.2,
        85.4, 86.4, 87.1, 87.7, 88.2, 88.5, 88.7, 88.8, 88.8, 88.7,
        88.5, 88.2, 87.9, 87.5, 87.0, 86.4, 85.8, 85.2, 84.5, 83.8,
    ]
)  # fmt: skip

# ISO 76:2006, Table 1 (radial deep groove and angular contact ball bearings): f_0 against
# D_w cos(alpha) / D_pw = 0.00, 0.01, ..., 0.40, interpolated linearly. The standard derives it
# from a contact stress of 4 200 MPa at the centre of the most loaded contact, groove
# conformities 0.52 (inner) and 0.53 (outer) and Q_max = 5 F_r / Z (ISO/TR 10657); the test
# recomputes every entry from Hertz to the table's rounding (tests/test_rollers.py).
F0_RATIO = np.round(np.arange(0, 41) * 0.01, 2)
F0_TABLE = np.array(
    [
        14.7, 14.9, 15.1, 15.3, 15.5, 15.7, 15.9, 16.1, 16.3, 16.5,
        16.4, 16.1, 15.9, 15.6, 15.4, 15.2, 14.9, 14.7, 14.4, 14.2,
        14.0, 13.7, 13.5, 13.2, 13.0, 12.8, 12.5, 12.3, 12.1, 11.8,
        11.6, 11.4, 11.2, 10.9, 10.7, 10.5, 10.3, 10.0, 9.8, 9.6, 9.4,
    ]
)  # fmt: skip
# [N/mm^2] of ISO 76's C_0r = 44 (1 - D_we cos a / D_pw) i Z L_we D_we cos a (roller bearings):
# pi p0^2 / (10 E*) = 44.19, the load whose most loaded roller (Q_max = 5 F_r / Z) makes
# p0 = 4 000 MPa at its inner line contact, steel E* = 207 GPa / (2 (1 - 0.3^2)) (the test
# recomputes it; the 4 000 MPa of ISO 76 as SKF's General Catalogue quotes it, p. 52).
ROLLER_STATIC_FACTOR = 44.0

# Table 2 (first column) is this fraction of the Lundberg–Palmgren closed form of f_c
# (Harris & Kotzalas, ch. 8: 39.9 [1 + (1.04 ((1-g)/(1+g))^1.72 (f_i (2f_e-1)/(f_e (2f_i-1)))^0.41)
# ^(10/3)]^-0.3 g^0.3 (1-g)^1.39/(1+g)^(1/3) (2f_i/(2f_i-1))^0.41) at the conformities
# f_i = f_e = 0.52 the standard assumes: 0.9574 at every entry, to +-0.12 % (tests/test_life.py).
# It is the reduction the standard's derivation (ISO/TR 1281-1) applies to the theoretical
# rating; applying it to the ball-race ratings Q_c makes the per-ball life agree with the
# catalogue rating (C_r / F_r)^3 at zero clearance.
ISO_REDUCTION = 0.957


def _finite(xp, **values):
    """`_checks.finite` of each named value."""
    return [_checks.finite(xp, name, v) for name, v in values.items()]


def _geometry_rules(xp, n_balls, ball_diameter, pitch_diameter, contact_angle, element="ball"):
    """Rules of a bearing's geometry, named as the arguments (``element``: "ball" or
    "roller")."""
    return [
        rules.ball_count(xp, n_balls, f"n_{element}s"),
        _checks.positive(xp, f"{element}_diameter", ball_diameter, "m"),
        rules.pitch_exceeds_ball(xp, pitch_diameter, ball_diameter),
        rules.balls_fit(xp, n_balls, ball_diameter, pitch_diameter, element),
        rules.contact_angle_rule(xp, contact_angle),
    ]


def _table_rule(r, table_ratio, what, element):
    """The rule that the ratio ``r`` lies in the range of a standard's table (``what``: the
    table's name, ``element``: "ball" or "roller", for the message)."""
    return (
        (r < table_ratio[0] - 1e-12) | (r > table_ratio[-1] + 1e-12),
        (
            f"{element}_diameter * cos(contact_angle) / pitch_diameter must lie in "
            f"[{table_ratio[0]:g}, {table_ratio[-1]:g}] ({what})"
        ),
        r,
    )


def _table_factor(ratio, table_ratio, table, what, element):
    """A factor of a standard's table, linearly interpolated, refusing a concrete ratio outside
    the table's range (`_table_rule`)."""
    r = _checks.as_float(ratio, "ratio", "-")
    _checks.check(lambda xp, r: _finite(xp, ratio=r) + [_table_rule(r, table_ratio, what, element)], r)
    return _checks.evaluate(lambda xp, r: xp.interp(r, xp.asarray(table_ratio), xp.asarray(table)), r)


# --------------------------------------------------------------------------------------------
# ISO 281: basic dynamic load rating
# --------------------------------------------------------------------------------------------


def load_rating_factor(ratio):
    """f_c of ISO 281:2007 Table 2 (first column: single-row radial deep groove ball bearings
    and single- and double-row angular contact ball bearings), linearly interpolated.

    Args:
        ratio: D_w cos(alpha) / D_pw [-], in [0.01, 0.40] (the table's range).

    Returns:
        f_c [N / mm^1.8 in C_r = b_m f_c (i cos alpha)^0.7 Z^(2/3) D_w^1.8].
    """
    return _table_factor(ratio, FC_RATIO, FC_TABLE, "ISO 281 Table 2", "ball")


def _ball_size_term(xp, d_mm):
    """D^1.8, or 3.647 D^1.4 for D > 25.4 mm (ISO 281:2007; continuous at 25.4 mm to 0.03 %)."""
    safe_small = xp.minimum(d_mm, LARGE_BALL)
    safe_large = xp.maximum(d_mm, LARGE_BALL)
    return xp.where(d_mm <= LARGE_BALL, safe_small**1.8, 3.647 * safe_large**1.4)


def _dynamic_load_rating(xp, z, d, dm, alpha, b_m):
    ratio = d * xp.cos(alpha) / dm
    fc = xp.interp(ratio, xp.asarray(FC_RATIO), xp.asarray(FC_TABLE))
    return b_m * fc * xp.cos(alpha) ** 0.7 * z ** (2.0 / 3.0) * _ball_size_term(xp, 1e3 * d)


def dynamic_load_rating(n_balls, ball_diameter, pitch_diameter, contact_angle=0.0, *, b_m=B_M):
    """Basic dynamic radial load rating C_r [N] of a single-row radial ball bearing, ISO 281:2007
    (radial ball bearings):

        C_r = b_m f_c (cos alpha)^0.7 Z^(2/3) D_w^1.8                 (D_w <= 25.4 mm)
        C_r = 3.647 b_m f_c (cos alpha)^0.7 Z^(2/3) D_w^1.4           (D_w >  25.4 mm)

    in N with D_w in mm (one row, i = 1), f_c from Table 2 (`load_rating_factor`) at
    D_w cos(alpha) / D_pw, b_m = 1.3 (Table 1, radial deep groove ball bearings). It is the
    constant radial load under which 90 % of a population reach 1e6 revolutions.

    Args:
        n_balls: Z, number of balls (an integer >= 3).
        ball_diameter: D_w [m] (> 0).
        pitch_diameter: D_pw [m] (> D_w, and D_w < D_pw sin(pi/Z): the balls fit around the
            pitch circle); D_w cos(alpha) / D_pw must lie in [0.01, 0.4].
        contact_angle: alpha [rad] in [0, pi/2), 0 for a deep groove bearing.
        b_m: rating factor (1.3, the standard's value for contemporary bearing steel).

    Example: a 6205 (Z = 9, D_w = 7.938 mm, D_pw = 39.04 mm) gives 14.0 kN, the catalogue
    value; the paper's SKF 98205 (8 balls of 8.7 mm on 37.9 mm) 15.14 kN.
    """
    z, d, dm, alpha, bm = _checks.as_floats(
        (n_balls, "n_balls", "-"),
        (ball_diameter, "ball_diameter", "m"),
        (pitch_diameter, "pitch_diameter", "m"),
        (contact_angle, "contact_angle", "rad"),
        (b_m, "b_m", "-"),
    )
    _checks.check(
        lambda xp, z, d, dm, alpha, bm: _finite(
            xp, n_balls=z, ball_diameter=d, pitch_diameter=dm, contact_angle=alpha, b_m=bm
        )
        + _geometry_rules(xp, z, d, dm, alpha)
        + [_checks.positive(xp, "b_m", bm, "-")]
        + _ratio_rules(xp, d, dm, alpha, FC_RATIO, "ISO 281 Table 2", "ball"),
        z, d, dm, alpha, bm,
    )
    return _checks.evaluate(_dynamic_load_rating, z, d, dm, alpha, bm)


def _ratio_rules(xp, d, dm, alpha, table_ratio, what, element):
    """The rules of the ratio D cos(alpha) / d_m of a table (`_table_factor`'s)."""
    r = d * xp.cos(alpha) / xp.where(dm != 0.0, dm, xp.nan)  # dm = 0 is refused before
    return _finite(xp, ratio=r) + [_table_rule(r, table_ratio, what, element)]


def roller_load_rating_factor(ratio):
    """f_c of ISO 281:2007 Table 7 (radial roller bearings), linearly interpolated.

    Args:
        ratio: D_we cos(alpha) / D_pw [-], in [0.01, 0.30] (the table's range).

    Returns:
        f_c [in C_r = b_m f_c (i L_we cos alpha)^(7/9) Z^(3/4) D_we^(29/27), N and mm].
    """
    return _table_factor(ratio, FC_ROLLER_RATIO, FC_ROLLER_TABLE, "ISO 281 Table 7", "roller")


def _roller_rules(xp, n_rollers, roller_diameter, pitch_diameter, roller_length, contact_angle):
    return _finite(
        xp, n_rollers=n_rollers, roller_diameter=roller_diameter, pitch_diameter=pitch_diameter,
        roller_length=roller_length, contact_angle=contact_angle,
    ) + _geometry_rules(xp, n_rollers, roller_diameter, pitch_diameter, contact_angle, "roller") + [
        _checks.positive(xp, "roller_length", roller_length, "m")
    ]  # fmt: skip


def _roller_dynamic_load_rating(xp, z, d, dm, length, alpha, b_m):
    ratio = d * xp.cos(alpha) / dm
    fc = xp.interp(ratio, xp.asarray(FC_ROLLER_RATIO), xp.asarray(FC_ROLLER_TABLE))
    contact = 1e3 * length * xp.cos(alpha)
    return b_m * fc * contact ** (7.0 / 9.0) * z**0.75 * (1e3 * d) ** (29.0 / 27.0)


def roller_dynamic_load_rating(
    n_rollers, roller_diameter, pitch_diameter, roller_length, contact_angle=0.0, *, b_m=B_M_ROLLER
):
    """Basic dynamic radial load rating C_r [N] of a single-row radial roller bearing, ISO
    281:2007 (radial roller bearings):

        C_r = b_m f_c (i L_we cos alpha)^(7/9) Z^(3/4) D_we^(29/27)

    in N with L_we, D_we in mm (one row, i = 1), f_c from Table 7 (`roller_load_rating_factor`)
    at D_we cos(alpha) / D_pw, b_m = 1.1 (Table 1, cylindrical roller bearings). The load
    under which 90 % of a population reach 1e6 revolutions, with L10 = (C_r / P)^(10/3).

    Args:
        n_rollers: Z (an integer >= 3).
        roller_diameter: D_we [m] (> 0).
        pitch_diameter: D_pw [m] (the rollers must fit around it: D_we < D_pw sin(pi/Z));
            D_we cos(alpha) / D_pw must lie in [0.01, 0.30].
        roller_length: L_we, effective contact length [m] (> 0).
        contact_angle: alpha [rad] in [0, pi/2), 0 for a cylindrical roller bearing.
        b_m: rating factor (1.1).

    Example: Harris & Kotzalas' 209 cylindrical roller bearing (14 rollers of 10 mm, L_we
    9.6 mm, D_pw 65.01 mm) gives 48.4 kN.
    """
    z, d, dm, length, alpha, bm = _checks.as_floats(
        (n_rollers, "n_rollers", "-"),
        (roller_diameter, "roller_diameter", "m"),
        (pitch_diameter, "pitch_diameter", "m"),
        (roller_length, "roller_length", "m"),
        (contact_angle, "contact_angle", "rad"),
        (b_m, "b_m", "-"),
    )
    _checks.check(
        lambda xp, z, d, dm, length, alpha, bm: _roller_rules(xp, z, d, dm, length, alpha)
        + _finite(xp, b_m=bm)
        + [_checks.positive(xp, "b_m", bm, "-")]
        + _ratio_rules(xp, d, dm, alpha, FC_ROLLER_RATIO, "ISO 281 Table 7", "roller"),
        z, d, dm, length, alpha, bm,
    )
    return _checks.evaluate(_roller_dynamic_load_rating, z, d, dm, length, alpha, bm)


# --------------------------------------------------------------------------------------------
# ISO 76: basic static load rating
# --------------------------------------------------------------------------------------------


def static_load_factor(ratio):
    """f_0 of ISO 76:2006 Table 1 (radial deep groove and angular contact ball bearings),
    linearly interpolated. Args: ratio D_w cos(alpha) / D_pw [-] in [0, 0.40]. Returns f_0
    [N/mm^2 in C_0r = f_0 i Z D_w^2 cos alpha]."""
    return _table_factor(ratio, F0_RATIO, F0_TABLE, "ISO 76 Table 1", "ball")


def _static_load_rating(xp, z, d, dm, alpha):
    f0 = xp.interp(d * xp.cos(alpha) / dm, xp.asarray(F0_RATIO), xp.asarray(F0_TABLE))
    return f0 * z * (1e3 * d) ** 2 * xp.cos(alpha)


def static_load_rating(n_balls, ball_diameter, pitch_diameter, contact_angle=0.0):
    """Basic static radial load rating C_0r [N] of a single-row radial ball bearing, ISO
    76:2006: C_0r = f_0 i Z D_w^2 cos(alpha) (N, mm; i = 1), f_0 from Table 1
    (`static_load_factor`). The radial load that makes the contact stress at the centre of the
    most loaded contact 4 200 MPa.

    Args: n_balls Z (an integer >= 3); ball_diameter D_w [m]; pitch_diameter D_pw [m] (the
    balls must fit around it; D_w cos(alpha) / D_pw in [0, 0.40]); contact_angle alpha [rad].

    Example: a 6205 (Z = 9, D_w = 7.938 mm, D_pw = 39.04 mm) gives 7.88 kN (catalogue 7.8 kN).
    """
    z, d, dm, alpha = _checks.as_floats(
        (n_balls, "n_balls", "-"),
        (ball_diameter, "ball_diameter", "m"),
        (pitch_diameter, "pitch_diameter", "m"),
        (contact_angle, "contact_angle", "rad"),
    )
    _checks.check(
        lambda xp, z, d, dm, alpha: _finite(
            xp, n_balls=z, ball_diameter=d, pitch_diameter=dm, contact_angle=alpha
        )
        + _geometry_rules(xp, z, d, dm, alpha)
        + _ratio_rules(xp, d, dm, alpha, F0_RATIO, "ISO 76 Table 1", "ball"),
        z, d, dm, alpha,
    )
    return _checks.evaluate(_static_load_rating, z, d, dm, alpha)


def _roller_static_load_rating(xp, z, d, dm, length, alpha):
    ratio = d * xp.cos(alpha) / dm
    return ROLLER_STATIC_FACTOR * (1.0 - ratio) * z * (1e3 * length) * (1e3 * d) * xp.cos(alpha)


def roller_static_load_rating(
    n_rollers, roller_diameter, pitch_diameter, roller_length, contact_angle=0.0
):
    """Basic static radial load rating C_0r [N] of a single-row radial roller bearing, ISO
    76:2006: C_0r = 44 (1 - D_we cos(alpha) / D_pw) i Z L_we D_we cos(alpha) (N, mm; i = 1).
    The radial load that makes the contact stress at the centre of the most loaded contact
    4 000 MPa.

    Args: as `roller_dynamic_load_rating` (no table range: any ratio below 1).

    Example: Harris & Kotzalas' 209 cylindrical roller bearing gives 50.0 kN.
    """
    z, d, dm, length, alpha = _checks.as_floats(
        (n_rollers, "n_rollers", "-"),
        (roller_diameter, "roller_diameter", "m"),
        (pitch_diameter, "pitch_diameter", "m"),
        (roller_length, "roller_length", "m"),
        (contact_angle, "contact_angle", "rad"),
    )
    _checks.check(_roller_rules, z, d, dm, length, alpha)
    return _checks.evaluate(_roller_static_load_rating, z, d, dm, length, alpha)


# --------------------------------------------------------------------------------------------
# Lundberg–Palmgren: ball–raceway ratings, equivalent ball loads, ring and bearing lives
# --------------------------------------------------------------------------------------------


def _race_ratings(xp, z, d, dm, fi, fo, alpha, b_m, reduction):
    factor = b_m * reduction
    gamma = d * xp.cos(alpha) / dm
    base = (
        LP_CONSTANT
        * factor
        * (gamma / xp.cos(alpha)) ** 0.3
        * _ball_size_term(xp, 1e3 * d)
        * z ** (-1.0 / 3.0)
    )
    q_ci = (
        base
        * (2.0 * fi / (2.0 * fi - 1.0)) ** 0.41
        * (1.0 - gamma) ** 1.39
        / (1.0 + gamma) ** (1.0 / 3.0)
    )
    q_co = (
        base
        * (2.0 * fo / (2.0 * fo - 1.0)) ** 0.41
        * (1.0 + gamma) ** 1.39
        / (1.0 - gamma) ** (1.0 / 3.0)
    )
    return q_ci, q_co


def ball_race_load_ratings(
    n_balls,
    ball_diameter,
    pitch_diameter,
    groove_inner,
    groove_outer,
    contact_angle=0.0,
    *,
    b_m=B_M,
    reduction=ISO_REDUCTION,
):
    """Basic dynamic load ratings (Q_ci, Q_co) [N] of the ball–inner-race and ball–outer-race
    contacts (Lundberg & Palmgren 1947; Harris & Kotzalas, *Advanced Concepts*, ch. 8):

        Q_c = k 98.1 (2f/(2f - 1))^0.41 (1 -+ gamma)^1.39 / (1 +- gamma)^(1/3)
              (gamma / cos alpha)^0.3 D^1.8 Z^(-1/3)          [N, D in mm]

    upper signs for the inner race (f = f_i), lower for the outer race (f = f_o), with
    gamma = D cos(alpha) / d_m and k = b_m * reduction. Q_c is the ball load under which 90 %
    of the raceways survive 1e6 revolutions of one ring relative to the other (its stress
    cycles per revolution, Z (1 +- gamma)/2, are built in). D^1.8 becomes 3.647 D^1.4 above
    25.4 mm, as in ISO 281.

    Args:
        n_balls: Z (an integer >= 3). ball_diameter: D [m]. pitch_diameter: d_m [m] (the
            balls must fit around it: D < d_m sin(pi/Z)).
        groove_inner, groove_outer: raceway conformities f = r/D (> 0.5).
        contact_angle: alpha [rad] in [0, pi/2).
        b_m: ISO 281 material factor (1.3; 1 for the original Lundberg–Palmgren constant).
        reduction: the standard's reduction of the theoretical rating (`ISO_REDUCTION`, 0.957;
            1 for plain Lundberg–Palmgren). With both defaults and f_i = f_o = 0.52 the ring
            lives combine to the catalogue rating of `dynamic_load_rating`.
    """
    z, d, dm, fi, fo, alpha, bm, red = _checks.as_floats(
        (n_balls, "n_balls", "-"),
        (ball_diameter, "ball_diameter", "m"),
        (pitch_diameter, "pitch_diameter", "m"),
        (groove_inner, "groove_inner", "-"),
        (groove_outer, "groove_outer", "-"),
        (contact_angle, "contact_angle", "rad"),
        (b_m, "b_m", "-"),
        (reduction, "reduction", "-"),
    )
    _checks.check(
        lambda xp, z, d, dm, fi, fo, alpha, bm, red: _finite(
            xp, n_balls=z, ball_diameter=d, pitch_diameter=dm, groove_inner=fi, groove_outer=fo,
            contact_angle=alpha, b_m=bm, reduction=red,
        )
        + _geometry_rules(xp, z, d, dm, alpha)
        + [
            (fi <= 0.5, "groove_inner (inner raceway conformity f_i = r_i/D) must exceed 0.5", fi),
            (fo <= 0.5, "groove_outer (outer raceway conformity f_o = r_o/D) must exceed 0.5", fo),
            _checks.positive(xp, "b_m", bm, "-"),
            _checks.positive(xp, "reduction", red, "-"),
        ],
        z, d, dm, fi, fo, alpha, bm, red,
    )
    return _checks.evaluate(_race_ratings, z, d, dm, fi, fo, alpha, bm, red)


def dynamic_rating(b) -> jax.Array:
    """ISO 281's basic dynamic radial load rating C_r [N] of a bearing's parameters, by its
    kind: `dynamic_load_rating` of a `BallBearing`, `roller_dynamic_load_rating` of a
    `RollerBearing` (Z, D and d_m from the raceway diameters d_i = d_m - D, d_o = d_m + D)."""
    if isinstance(b, RollerBearing):
        return roller_dynamic_load_rating(
            b.n_balls, b.ball_diameter, b.pitch_diameter, b.roller_length
        )
    return dynamic_load_rating(b.n_balls, b.ball_diameter, b.pitch_diameter)

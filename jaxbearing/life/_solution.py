"""Fatigue life of a simulated bearing: the formulas of `_formulas` applied to the integrals a
`Solution` records (`FatigueStats`: quadratures of the solution itself, so a life does not
depend on the output times) and to its model (the bearing's geometry), and the L10 life as a
sweep metric."""

from __future__ import annotations

import functools
import inspect
import numbers
from typing import ClassVar, Literal

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from .._checks import is_concrete
from ..metrics import (
    AbstractMetric,
    bearing_index,
    element_index,
    finite_numbers,
    intervals_inside,
    reached,
    window_edges,
    window_start,
)
from ..multibody.mechanism import Mechanism
from ..params import AbstractBearing, BallBearing
from ..solution import (
    FAT_ELEMENT_POWER,
    FAT_ELEMENT_SLOPE_POWER,
    FAT_FORCE_POWER,
    FAT_REVOLUTIONS,
    FAT_TIME,
    FORCE_SCALE,
    RING_POINTS_PER_BALL,
    FatigueStats,
    Solution,
)
from ._formulas import (
    _combine,
    _safe_power,
    _safe_ratio,
    life_hours,
    rating_life,
    reliability_factor,
    ring_cube_mean,
)
from ._ratings import B_M, ISO_REDUCTION, ball_race_load_ratings, dynamic_rating
from ._reference import ReferenceLife, _lives, reference_ratings, static_reference_life


class RatingLife(eqx.Module):
    """ISO 281 basic rating life of a simulated bearing (`iso_life`).

    Fields: load_rating C_r [N]; equivalent_load P [N] (revolution-weighted mean of |F|^p,
    p = 3 for balls, 10/3 for rollers); l10 = (C_r/P)^p [millions of relative revolutions];
    speed n [rpm] (mean relative speed); l10_hours [h]; revolutions: relative revolutions in
    the window; a1: ISO 281's life modification factor for the reliability asked for;
    lnm = a1 l10 [millions of relative revolutions] and lnm_hours [h].
    """

    load_rating: jax.Array
    equivalent_load: jax.Array
    l10: jax.Array
    speed: jax.Array
    l10_hours: jax.Array
    revolutions: jax.Array
    a1: jax.Array
    lnm: jax.Array
    lnm_hours: jax.Array


class LPLife(eqx.Module):
    """Lundberg–Palmgren life of a simulated bearing (`lp_life`).

    Fields: rating_inner, rating_outer: Q_ci, Q_co [N]; load_inner, load_outer: equivalent
    ball loads Q_e of each ring [N]; life_inner, life_outer: ring lives (Q_c/Q_e)^3 [millions of
    relative revolutions]; l10: bearing life [millions of relative revolutions]; speed n [rpm];
    l10_hours [h]; a1, lnm = a1 l10, lnm_hours: as `RatingLife`'s.
    """

    rating_inner: jax.Array
    rating_outer: jax.Array
    load_inner: jax.Array
    load_outer: jax.Array
    life_inner: jax.Array
    life_outer: jax.Array
    l10: jax.Array
    speed: jax.Array
    l10_hours: jax.Array
    a1: jax.Array
    lnm: jax.Array
    lnm_hours: jax.Array


def _joint(model: Mechanism, bearing):
    """The bearing joint ``bearing`` of ``model`` (None: the only one)."""
    if not isinstance(model, Mechanism):
        raise TypeError(f"model must be a jaxbearing Mechanism, got {type(model).__name__}.")
    if not model.bearings:
        raise ValueError("This model has no bearing joint.")
    return model.bearings[element_index("bearing", bearing, len(model.bearings), "bearing joint")]


def relative_speed(sol: Solution, model: Mechanism, bearing=None) -> jax.Array:
    """omega_inner - omega_outer [rad/s] at the output times, (T,): the inner-race body's
    angular speed minus the outer-race body's (`cases.xu2014`: rod qd[:, 5] minus crank
    qd[:, 2])."""
    return _relative_speed(_joint(model, bearing), sol.q, sol.qd)


@eqx.filter_jit
def _relative_speed(joint, q, qd):
    return jax.vmap(joint.relative_speed)(q, qd)


def _reliability(a1, l10, n):
    """(a1, L_nm = a1 L10, L_nm in hours at n [rpm]) of ISO 281's factor a1."""
    return a1, a1 * l10, life_hours(a1 * l10, n)


def _solved_joint(sol: Solution, model: Mechanism, bearing):
    """The bearing joint ``bearing`` (None: the only one) of ``model``, checked to be the model
    that produced ``sol``."""
    if not isinstance(sol, Solution):
        raise TypeError(f"sol must be a jaxbearing Solution, got {type(sol).__name__}.")
    joint = _joint(model, bearing)
    if sol.n_bearings != len(model.bearings):
        raise ValueError(
            f"sol has {sol.n_bearings} bearing joints and model {len(model.bearings)}: pass the "
            "model that produced the solution."
        )
    return joint


def _fatigue(sol: Solution, model: Mechanism, bearing) -> FatigueStats:
    """The `FatigueStats` of bearing joint ``bearing`` (None: the only one) of ``sol``, a
    solution of ``model``."""
    _solved_joint(sol, model, bearing)
    stats = sol.bearings[bearing_index(sol, bearing)].fatigue
    if stats is None:
        raise ValueError(
            "This solution carries no fatigue integrals (its bearings' fatigue is None): the "
            "life needs a solution made by jaxbearing.simulate with "
            "options=SolveOptions(fatigue=True) (its default records them too)."
        )
    return stats


def iso_life(
    sol: Solution,
    model: Mechanism,
    *,
    t_min="model",
    t_max=None,
    bearing=None,
    reliability=0.9,
) -> RatingLife:
    """ISO 281 basic rating life of the simulated bearing: C_r from the bearing's geometry
    (`dynamic_load_rating`, b_m = 1.3, for a `BallBearing`; `roller_dynamic_load_rating`,
    b_m = 1.1, for a `RollerBearing`), P the revolution-weighted mean of |F|^p of the bearing
    force over the window (`equivalent_load`'s rule; p = 3 for balls, 10/3 for rollers),
    L10 = (C_r/P)^p, L10h at the mean relative speed, and L_nm = a1 L10 at ``reliability``
    (`reliability_factor`, ISO 281 Table 12).

    The means are integrals of the solution (``sol.fatigue``: Gauss–Legendre quadrature of each
    accepted step's interpolant), not of the output times.

    Args: sol, model: a `simulate` result and the model that produced it; window t_min, t_max
    [s] ("model": the model's ``window_start``; None: unbounded), whose edges must be ends of
    the solve's stop intervals (t0, the model's ``window_start``, ``SolveOptions.window_edges``,
    t1); bearing: index of the bearing joint in ``model.bearings`` (None: the only one);
    reliability: S in [0.9, 0.9995].
    """
    index, edges = _window(sol, model, bearing, t_min, t_max)
    b = _joint(model, bearing).bearing
    c, a1 = dynamic_rating(b), reliability_factor(reliability)  # NumPy where known in Python
    return _iso_life(sol, index, *edges, c, a1, b.life_exponent)


def _window(sol: Solution, model: Mechanism, bearing, t_min, t_max):
    """(index of the bearing joint, the window's edges [s]) of a life of ``sol`` after its
    checks (`_window_integrals`; in NumPy where known in Python)."""
    _window_integrals(sol, _fatigue(sol, model, bearing), t_min, t_max)  # its checks only
    return bearing_index(sol, bearing), window_edges(sol, t_min, t_max)


@functools.partial(jax.jit, static_argnums=(1, 6))
def _iso_life(sol: Solution, index, lo, hi, c, a1, exponent) -> RatingLife:
    """`iso_life` of bearing joint ``index`` over [lo, hi] [s], C_r = ``c`` [N]."""
    integrals, _, _ = _window_integrals(sol, sol.bearings[index].fatigue, lo, hi)
    revolutions = integrals[FAT_REVOLUTIONS]
    p = FORCE_SCALE * _safe_power(_mean(integrals[FAT_FORCE_POWER], revolutions), 1.0 / exponent)
    n = 60.0 * revolutions / integrals[FAT_TIME]
    l10 = rating_life(c, p, exponent)
    return RatingLife(c, p, l10, n, life_hours(l10, n), revolutions, *_reliability(a1, l10, n))


def _window_integrals(sol: Solution, stats: FatigueStats, t_min, t_max):
    """``stats``' integrals summed over the window: (integrals (5,), inner (M,), outer (M,));
    NaN when the window's edges are not ends of the stop intervals or the run stopped before
    its end (`metrics.reached`) (traced). Raises when, concretely, the rings do not turn
    relative to each other in the window."""
    ok = reached(sol, t_max)  # first: a run that stopped short explains the rest
    inside, on_stops = intervals_inside(stats, window_start(sol, t_min), t_max, "stop intervals")
    ok = ok & on_stops
    concrete = is_concrete(ok, inside, stats.integrals, stats.inner, stats.outer)
    xp = np if concrete else jnp  # the checks of a concrete window in NumPy: compile nothing

    def total(x):
        return xp.where(ok, xp.sum(xp.where(inside[:, None], xp.asarray(x), 0.0), axis=0), xp.nan)

    integrals = total(stats.integrals)
    revolutions = integrals[FAT_REVOLUTIONS]
    if concrete and float(revolutions) == 0.0:
        raise ValueError(
            "the rings must turn relative to each other inside the window (relative_speed is 0 "
            "throughout): fatigue life is counted in relative revolutions."
        )
    return integrals, total(stats.inner), total(stats.outer)


def _mean(integral, revolutions):
    """A revolution-weighted mean: integral / revolutions, NaN where no revolution counts."""
    return integral / jnp.where(revolutions > 0.0, revolutions, jnp.nan)


def ring_point_loads(
    sol: Solution,
    model: Mechanism,
    ring: Literal["inner", "outer"],
    points_per_ball: int = 8,
    bearing=None,
) -> jax.Array:
    """Load history of material points fixed in one ring, (T, Z * points_per_ball) [N].

    Point k sits at angle 2 pi k / M (M = Z * points_per_ball) in the frame of the ring's body;
    its load at time t is what the bearing law (Eqs. 9, 12; `laws.bearing.ring_point_loads`,
    same variant, clearance and damping) gives for a ball at that point's global angle
    2 pi k / M + theta_body(t), from the simulated eccentricity and its rate. At the balls'
    own positions it equals that bearing's ``ball_loads``; in between it is the load the next ball to
    pass will carry. Balls and both raceways carry the same load (frictionless balls). A
    history at the output times, for plots; `lp_life` integrates the same loads over the
    solution itself (``sol.fatigue``).
    """
    if ring not in ("inner", "outer"):
        raise ValueError(f"ring must be 'inner' or 'outer'; got {ring!r}.")
    if int(points_per_ball) != points_per_ball or points_per_ball < 1:
        raise ValueError(f"points_per_ball must be a positive integer; got {points_per_ball}.")
    joint = _joint(model, bearing)
    body = joint.inner_body if ring == "inner" else joint.outer_body
    return _ring_point_loads(joint, body, sol.q, sol.qd, int(points_per_ball))


@eqx.filter_jit
def _ring_point_loads(joint, body, q, qd, k):
    row = 0 if body == joint.inner_body else 1
    m = joint.bearing.n_balls * k
    return jax.vmap(lambda q_, qd_: joint.ring_point_loads(q_, qd_, m)[row])(q, qd)


def lp_life(
    sol: Solution,
    model: Mechanism,
    *,
    groove_inner=0.52,
    groove_outer=0.52,
    t_min="model",
    t_max=None,
    rotating: Literal["inner", "outer"] | None = None,
    points_per_ball: int | None = None,
    b_m=B_M,
    reduction=ISO_REDUCTION,
    bearing=None,
    reliability=0.9,
) -> LPLife:
    """Lundberg–Palmgren life of the simulated bearing from its ball loads (Harris & Kotzalas).

    Ring ratings Q_ci, Q_co from the geometry (`ball_race_load_ratings`); equivalent ball
    loads of each ring; ring lives L = (Q_c/Q_e)^3; bearing L10 = (L_i^-10/9 + L_o^-10/9)^-9/10
    in millions of relative revolutions, and in hours at the mean relative speed.

    Which ring turns relative to the load? In a mechanism the load direction turns too, so the
    default (``rotating=None``) assumes nothing: it follows the material points of each ring
    (`ring_point_loads`) through the simulated load field and applies `ring_equivalent_load`'s
    rule,
    which reduces to Harris' exponent-3 mean for a ring that rotates uniformly relative to a
    steady load and to the exponent-10/3 mean for one that does not, and also covers what lies
    between. In `cases.xu2014` without impact the bearing force is dominated by the
    centripetal force of the rod's big end, so it stays within about 110 degrees of one
    direction in the crank (outer ring) frame, and turns once per revolution relative to the
    rod (inner ring). The inner ring nevertheless meets the load peaks at the same points every
    revolution (the rod swings periodically with the crank, and sweeps past the load at a speed
    that varies by a factor 2.4), so its equivalent load lies between Harris' rotating and
    stationary values. ``rotating="inner"`` or ``"outer"`` instead applies Harris' textbook
    rule to the ball loads: the named ring rotates relative to the load (p = 3 over balls
    and time), the other is stationary (p = 10/3), see `ball_equivalent_load`; for
    `cases.xu2014` the kinematically apt choice is ``"inner"``.

    Every mean is an integral of the solution (``sol.fatigue``: Gauss–Legendre quadrature of
    each accepted step's interpolant), not of the output times.

    Args:
        sol, model: a `simulate` result and its model.
        groove_inner, groove_outer: raceway conformities f = r/D (`BallBearing` does not store
            them; 0.52, 0.52 are those ISO 281's Table 2 assumes; `cases.xu2014` uses
            0.5219, 0.5194, docs/model.md, 'Groove curvature ratios').
        t_min, t_max: window [s] ("model": the model's ``window_start``; None: unbounded);
            its edges must be ends of the solve's stop intervals (t0, the model's
            ``window_start``, ``SolveOptions.window_edges``, t1).
        rotating: None (follow ring points), "inner" or "outer" (Harris' rule on ball loads).
        points_per_ball: ring points per ball spacing for ``rotating=None``: the solve follows
            `solution.RING_POINTS_PER_BALL`; None or that number.
        b_m, reduction: factors of the ratings, see `ball_race_load_ratings`.
        bearing: index of the bearing joint in ``model.bearings`` (None: the only one).
        reliability: S in [0.9, 0.9995] of L_nm = a1 L10 (`reliability_factor`).

    Ball bearings only: a `RollerBearing` is refused (its line contacts need the ring ratings
    of Harris & Kotzalas with the load–life exponent 4); `reference_life` rates it from its
    roller loads (ISO/TS 16281), `iso_life` from its resultant.
    """
    if rotating not in (None, "inner", "outer"):
        raise ValueError(f"rotating must be None, 'inner' or 'outer'; got {rotating!r}.")
    _fatigue(sol, model, bearing)  # the solution's checks first
    if points_per_ball is not None and points_per_ball != RING_POINTS_PER_BALL:
        raise ValueError(
            f"points_per_ball: the solution follows {RING_POINTS_PER_BALL} points of each ring "
            f"per ball (solution.RING_POINTS_PER_BALL); got {points_per_ball}."
        )
    b = _joint(model, bearing).bearing
    if not isinstance(b, BallBearing):
        raise ValueError(
            f"lp_life rates ball bearings; this bearing is a {type(b).__name__}. The life of "
            "line contacts from the roller loads (load–life exponent 4) is ISO/TS 16281's "
            "reference rating life: use reference_life (or iso_life, ISO 281 from the "
            "resultant)."
        )
    z, d, dm = b.n_balls, b.ball_diameter, b.pitch_diameter
    q_ci, q_co = ball_race_load_ratings(
        z, d, dm, groove_inner, groove_outer, b_m=b_m, reduction=reduction
    )  # NumPy where known in Python, as the factor a1
    index, edges = _window(sol, model, bearing, t_min, t_max)
    a1 = reliability_factor(reliability)
    return _lp_life(sol, index, *edges, q_ci, q_co, a1, rotating)


@functools.partial(jax.jit, static_argnums=(1, 7))
def _lp_life(sol: Solution, index, lo, hi, q_ci, q_co, a1, rotating) -> LPLife:
    """`lp_life` of bearing joint ``index`` over [lo, hi] [s] with the ring ratings Q_ci,
    Q_co [N]."""
    integrals, inner, outer = _window_integrals(sol, sol.bearings[index].fatigue, lo, hi)
    revolutions = integrals[FAT_REVOLUTIONS]
    if rotating is None:
        q_ei = FORCE_SCALE * _safe_power(ring_cube_mean(_mean(inner, revolutions)), 1.0 / 3.0)
        q_eo = FORCE_SCALE * _safe_power(ring_cube_mean(_mean(outer, revolutions)), 1.0 / 3.0)
    else:
        cubed = FORCE_SCALE * _safe_power(_mean(integrals[FAT_ELEMENT_POWER], revolutions), 1 / 3)
        power = _mean(integrals[FAT_ELEMENT_SLOPE_POWER], revolutions)
        ten_thirds = FORCE_SCALE * _safe_power(power, 0.3)
        q_ei, q_eo = (cubed, ten_thirds) if rotating == "inner" else (ten_thirds, cubed)
    inv_i = _safe_power(q_ei / q_ci, 3.0)
    inv_o = _safe_power(q_eo / q_co, 3.0)
    l10 = _combine(inv_i, inv_o)
    n = 60.0 * revolutions / integrals[FAT_TIME]
    return LPLife(
        q_ci, q_co, q_ei, q_eo, _safe_ratio(1.0, inv_i), _safe_ratio(1.0, inv_o), l10, n,
        1e6 * l10 / (60.0 * n), *_reliability(a1, l10, n),
    )  # fmt: skip


_STATIC_ONLY = ("cage", "speed_rpm")  # keywords of reference_life's static form alone


def reference_life(
    sol,
    model,
    bearing=None,
    *,
    t_min="model",
    t_max=None,
    rotating: Literal["inner", "outer"] | None = None,
    cage=None,
    speed_rpm=None,
    load_rating=None,
    groove_inner=None,
    groove_outer=None,
    reliability=0.9,
) -> ReferenceLife:
    """ISO/TS 16281's basic reference rating life L10r, from the rolling elements' loads (so it
    sees the clearance, a preload and the load zone, which ISO 281's L10 from the resultant
    does not): raceway ratings Q_ci, Q_ce from C_r and the geometry (`reference_ratings`),
    each ring's equivalent element load, ring lives L = (Q_c/Q_e)^m and

        L10r = ((Q_ci/Q_ei)^(-m e) + (Q_ce/Q_ee)^(-m e))^(-1/e)

    (balls m = 3, e = 10/9: exponents -10/3 and -9/10; rollers m = 4, e = 9/8: -9/2 and -8/9)
    in millions of relative revolutions, and L_nm = a1 L10r (`reliability_factor`). In the
    planar model the rings stay aligned, so the load is uniform along each roller and the
    standard's laminae reduce to the whole roller (docs/life.md, 'The reference rating life').

    Two forms:

    - ``reference_life(sol, model, bearing=None, ...)``: of a simulated bearing joint
      (``bearing``: its index in ``model.bearings``; None: the only one) over the window
      ``[t_min, t_max]`` ("model": the model's ``window_start``; edges must be stops of the
      solve), from the integrals the solve records for every accepted step
      (``sol.bearings[i].fatigue``: exact from the solution, not its samples), each instant
      weighted by the relative revolutions turned in it (the load spectrum of the standard).
      ``rotating=None`` (default) follows points fixed in each ring through the simulated
      load: each point's Miner mean of Q^m over the window, the ring's (mean of its points'
      Q_k^(m e))^(1/(m e)), which is the standard's cube mean over the elements for a ring that
      rotates relative to the load and its 10/3 mean for one that stands in it, and what
      lies between in a mechanism where both rings turn (`ring_equivalent_load`).
      ``rotating="inner"`` or ``"outer"`` instead names the ring that rotates relative to the
      load and applies the standard's two means to the element loads over the window.
      Differentiable, and a metric of sweeps and tuning: ``life.metric("reference")``.
    - ``reference_life(bearing, load, ...)``: static, a `BallBearing` or `RollerBearing`
      under the radial load (F_x, F_y) [N] on the inner ring, outer ring fixed
      (`load_distribution`; ``cage``: element 1's angle [rad], None: on the load line), the
      standard's means over the elements at that cage position, ``rotating`` the ring that
      turns relative to the load (None: the inner ring); ``speed_rpm`` gives the hours (else
      the hours are None). Concrete inputs run in NumPy, traced ones differentiably.

    Args (both forms): ``load_rating``, C_r [N] (None: ISO 281's from the geometry, a
    catalogue's may be given); ``groove_inner``, ``groove_outer``: a ball bearing's raceway
    conformities (None: 0.52, ISO 281's; none for rollers); ``reliability``: S in
    [0.9, 0.9995].
    """
    if rotating not in (None, "inner", "outer"):
        raise ValueError(f"rotating must be None, 'inner' or 'outer'; got {rotating!r}.")
    ratings = dict(load_rating=load_rating, groove_inner=groove_inner, groove_outer=groove_outer)
    if isinstance(sol, AbstractBearing):
        if bearing is not None or (t_min, t_max) != ("model", None):
            raise TypeError(
                "reference_life(bearing, load, ...) is the static form: it takes no bearing "
                "index, t_min or t_max (those of a Solution's form)."
            )
        return static_reference_life(
            sol, model, cage=cage, rotating=rotating, reliability=reliability,
            speed_rpm=speed_rpm, **ratings,
        )[0]  # fmt: skip
    if cage is not None or speed_rpm is not None:
        raise TypeError(
            "reference_life(sol, model, ...) takes no cage or speed_rpm (those of the static "
            "form, reference_life(bearing, load, ...)): a solution has its cage and speeds."
        )
    _fatigue(sol, model, bearing)  # the solution's checks first
    b = _joint(model, bearing).bearing
    q_ci, q_ce = reference_ratings(b, **ratings)  # NumPy where known in Python
    index, edges = _window(sol, model, bearing, t_min, t_max)
    a1 = reliability_factor(reliability)
    m, e = b.raceway_exponent, b.weibull_slope
    return _reference_life(sol, index, *edges, q_ci, q_ce, a1, rotating, m, e)


@functools.partial(jax.jit, static_argnums=(1, 7, 8, 9))
def _reference_life(sol: Solution, index, lo, hi, q_ci, q_ce, a1, rotating, m, e) -> ReferenceLife:
    """`reference_life` of bearing joint ``index`` over [lo, hi] [s] with the raceway ratings
    Q_ci, Q_ce [N], raceway exponent m and Weibull slope e."""
    integrals, inner, outer = _window_integrals(sol, sol.bearings[index].fatigue, lo, hi)
    revolutions = integrals[FAT_REVOLUTIONS]
    if rotating is None:  # each ring point's Miner mean, then the points' slope-e mean

        def ring(points):
            per_point = _safe_power(_mean(points, revolutions), e)
            return FORCE_SCALE * _safe_power(jnp.mean(per_point), 1.0 / (m * e))

        q_ei, q_ee = ring(inner), ring(outer)
    else:
        mean = lambda column, p: FORCE_SCALE * _safe_power(_mean(integrals[column], revolutions), 1.0 / p)  # noqa: E731
        turning, standing = mean(FAT_ELEMENT_POWER, m), mean(FAT_ELEMENT_SLOPE_POWER, m * e)
        q_ei, q_ee = (turning, standing) if rotating == "inner" else (standing, turning)
    life_i, life_e, l10 = _lives(jnp, q_ei, q_ee, q_ci, q_ce, m, e)
    n = 60.0 * revolutions / integrals[FAT_TIME]
    return ReferenceLife(
        q_ci, q_ce, q_ei, q_ee, life_i, life_e, l10, n, 1e6 * l10 / (60.0 * n),
        *_reliability(a1, l10, n),
    )  # fmt: skip


def l10_hours(
    sol: Solution, model: Mechanism, method: Literal["iso", "lp", "reference"] = "iso", **kwargs
) -> jax.Array:
    """L10 life in hours at the simulated mean relative speed: ``method="iso"`` the ISO 281
    rating (C_r/P)^3 (`iso_life`), ``"lp"`` Lundberg–Palmgren from the ball loads (`lp_life`;
    pass ``groove_inner``, ``groove_outer``), ``"reference"`` ISO/TS 16281's L10r from the
    element loads (`reference_life`). Keyword arguments go to that function."""
    return _life_function(method)(sol, model, **kwargs).l10_hours


def _life_function(method):
    """`iso_life`, `lp_life` or `reference_life` by name."""
    functions = {"iso": iso_life, "lp": lp_life, "reference": reference_life}
    if method not in functions:
        raise ValueError(f"method must be 'iso', 'lp' or 'reference'; got {method!r}.")
    return functions[method]


_L10_UNITS = ("hours", "mrev")


class LifeMetric(AbstractMetric):
    """The L10 life as a metric (`metric` makes it): of a solution and its model (the bearing's
    geometry and ring speeds, so a swept or differentiated clearance or stiffness enters the
    life), from the solve's fatigue records (no output samples).

    Fields: method ("iso", "lp" or "reference"), unit ("hours" or "mrev"), options: ((keyword,
    value), ...) of `iso_life` / `lp_life` / `reference_life`."""

    method: str = eqx.field(static=True)
    unit: str = eqx.field(static=True)
    options: tuple = eqx.field(static=True)
    reads_samples: ClassVar[bool] = False
    reads_fatigue: ClassVar[bool] = True

    def value(self, sol: Solution, model: Mechanism) -> jax.Array:
        """L10 [h] or [millions of relative revolutions] of ``sol``, a solution of ``model``."""
        result = _life_function(self.method)(sol, model, **dict(self.options))
        return result.l10_hours if self.unit == "hours" else result.l10

    def __call__(self, sol: Solution, model: Mechanism) -> jax.Array:
        """`value` (called as the life functions are, on a solution and its model)."""
        return self.value(sol, model)

    def edges(self) -> tuple[float, ...]:
        """``t_min`` and ``t_max`` [s] where given as numbers."""
        options = dict(self.options)
        return finite_numbers(options.get("t_min"), options.get("t_max"))

    @property
    def label(self) -> str:
        """The call of `metric` that makes it, e.g. ``life.metric('lp', groove_inner=0.5219)``."""
        unit = [] if self.unit == "hours" else [f"unit={self.unit!r}"]
        options = [f"{k}={v!r}" for k, v in self.options]
        return f"life.metric({', '.join([repr(self.method), *unit, *options])})"


def metric(
    method: Literal["iso", "lp", "reference"] = "iso",
    unit: Literal["hours", "mrev"] = "hours",
    **kwargs,
) -> LifeMetric:
    """The L10 life as a metric of `jaxbearing.sweep`, `jaxbearing.sensitivity` and
    `metrics.converged` (a `LifeMetric`: each member's own model enters, so a swept clearance
    or stiffness enters the life):

        metrics = {"l10_hours": life.metric("lp", groove_inner=0.5219, groove_outer=0.5194)}

    Args:
        method: ``"iso"`` ISO 281 rating life (`iso_life`), ``"lp"`` Lundberg–Palmgren
            (`lp_life`) or ``"reference"`` ISO/TS 16281's reference rating life L10r
            (`reference_life` of a solution).
        unit: ``"hours"`` L10h [h] at the mean relative speed, or ``"mrev"`` L10 [millions of
            relative revolutions].
        **kwargs: keyword arguments of that function (t_min, t_max; groove_inner,
            groove_outer, rotating, ... for ``"lp"`` and ``"reference"``; not the static
            form's ``cage`` and ``speed_rpm``), checked here; numbers and strings (the
            metric is static, compared by value). A ``t_min`` or ``t_max`` given as a number
            becomes a stop of the solves that compute the metric.

    ``metric(...).value(sol, model)`` equals ``iso_life(sol, model, **kwargs).l10_hours`` (or
    ``.l10``; ``lp_life`` likewise) on a single run. It costs little beside the simulation
    (Lundberg–Palmgren follows ``points_per_ball`` points of each ring per ball;
    benchmarks/results.json has the figures).
    """
    function = _life_function(method)
    if unit not in _L10_UNITS:
        raise ValueError(f"unit must be 'hours' or 'mrev'; got {unit!r}.")
    try:
        inspect.signature(function).bind(None, None, **kwargs)
    except TypeError as err:
        raise TypeError(f"life.metric({method!r}): {err}") from None
    static = sorted(set(kwargs) & set(_STATIC_ONLY)) if method == "reference" else []
    if static:
        raise TypeError(
            f"life.metric('reference'): {', '.join(static)} belong to reference_life's static "
            "form; a metric rates a solution."
        )
    for name, value in kwargs.items():
        if not (value is None or isinstance(value, (str, numbers.Real))):
            raise TypeError(
                f"life.metric: {name} must be a number, a string or None; got "
                f"{type(value).__name__}."
            )
    return LifeMetric(method, unit, tuple((k, _plain(v)) for k, v in kwargs.items()))


def _plain(value):
    """A NumPy scalar as a Python one (the metric's fields are compared and hashed)."""
    return value.item() if isinstance(value, np.generic) else value

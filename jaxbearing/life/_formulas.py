"""Fatigue-life formulas on load histories (ISO 281:2007, ISO/TR 1281-1, Lundberg–Palmgren
after Harris & Kotzalas): revolution weights, equivalent loads and lives, testable on
synthetic histories; conventions in `jaxbearing.life`."""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np

from .. import _checks
from .._checks import is_concrete
from ..metrics import check_window, window_weights


def _bounds(t_min, t_max):
    """The window as two floats (None: unbounded), so jitted kernels never retrace on it."""
    lo = -jnp.inf if t_min is None else t_min
    hi = jnp.inf if t_max is None else t_max
    return _checks.as_float(lo, "t_min", "s"), _checks.as_float(hi, "t_max", "s")


def _times(ts):
    return _checks.as_float(ts, "ts", "s")


def _relative_speed(relative_speed):
    return _checks.as_float(relative_speed, "relative_speed", "rad/s")


def _validate_history(
    ts, rel, t_min, t_max, series=None, name="", trailing=(), nonneg=False, rotation=True
):
    """Shapes always; values (NumPy, cheap) when concrete: ts finite and increasing, series and
    relative_speed finite, loads >= 0, a window of at least two samples (traced: a run-time
    warning, and the results are NaN), relative rotation."""
    if ts.ndim != 1 or ts.shape[0] < 2:
        raise ValueError(
            f"ts must be a 1-D array of at least 2 output times; got shape {ts.shape}."
        )
    for arr, label, tail in ((rel, "relative_speed", ()), (series, name, trailing)):
        if arr is None:
            continue
        if (
            arr.shape[0] != ts.shape[0]
            or arr.ndim != 1 + len(tail)
            or any(want is not None and got != want for got, want in zip(arr.shape[1:], tail))
        ):
            want = ", ".join([str(ts.shape[0])] + ["N" if w is None else str(w) for w in tail])
            raise ValueError(
                f"{label} must have shape ({want}) (one row per output time); got {arr.shape}."
            )
    if not is_concrete(ts, rel, series, t_min, t_max):
        check_window(ts, window_weights(ts, *_bounds(t_min, t_max)), t_min, t_max, need="two")
        return
    t, r = np.asarray(ts), np.asarray(rel)
    rules = [
        (~np.isfinite(t), "ts must be finite [s]", t),
        (np.diff(t) <= 0.0, "ts must be strictly increasing [s]", t),
        (~np.isfinite(r), "relative_speed must be finite [rad/s]", r),
    ]
    if series is not None:
        x = np.asarray(series)
        rules.append((~np.isfinite(x), f"{name} must be finite [N]", x))
        if nonneg:
            rules.append((x < 0.0, f"{name} must be zero or positive [N]", x))
    _checks.raise_first(rules)
    lo, hi = (float(b) for b in _bounds(t_min, t_max))
    inside = (t >= lo) & (t <= hi)
    pairs = inside[:-1] & inside[1:]
    check_window(ts, window_weights(ts, lo, hi), t_min, t_max, need="two")
    if rotation and not np.any(pairs & ((r[:-1] != 0.0) | (r[1:] != 0.0))):
        raise ValueError(
            "the rings must turn relative to each other inside the window (relative_speed is 0 "
            "throughout): fatigue life is counted in relative revolutions."
        )


def _safe_power(x, p):
    """x^p for x >= 0 with a finite gradient also at x = 0 (p > 0); inf where x = inf, NaN
    where x is NaN (the mean over an empty window)."""
    safe = jnp.where(x > 0.0, x, 1.0)
    return jnp.where(x > 0.0, safe**p, jnp.where(jnp.isnan(x), jnp.nan, 0.0))


def _safe_ratio(num, den):
    """num / den, +inf where den = 0, NaN where den is NaN, finite gradients."""
    safe = jnp.where(den > 0.0, den, 1.0)
    return jnp.where(den > 0.0, num / safe, jnp.where(jnp.isnan(den), jnp.nan, jnp.inf))


# --------------------------------------------------------------------------------------------
# Revolution-weighted means (the standard's mean load for variable loads)
# --------------------------------------------------------------------------------------------


@jax.jit
def _weights(ts, relative_speed, lo, hi):
    """(trapezoid weights [s], revolution weights [rev]) of the output times."""
    trap = window_weights(ts, lo, hi)
    return trap, trap * jnp.abs(relative_speed) / (2.0 * jnp.pi)


def revolution_weights(ts, relative_speed, t_min=None, t_max=None):
    """Weight of each output time in relative revolutions: trapezoid weight times
    |omega_rel| / (2 pi), zero outside ``[t_min, t_max]`` (None: unbounded). Sums to the relative
    revolutions turned in the window.

    Args: ts (T,) [s], increasing; relative_speed (T,) omega_inner - omega_outer [rad/s].
    Returns: (T,) [revolutions].
    """
    ts, rel = _times(ts), _relative_speed(relative_speed)
    _validate_history(ts, rel, t_min, t_max, rotation=False)
    return _weights(ts, rel, *_bounds(t_min, t_max))[1]


def _weighted_mean(values, weights):
    """sum_t w_t values_t / sum_t w_t over the first axis."""
    w = weights.reshape((-1,) + (1,) * (values.ndim - 1))
    total = jnp.sum(weights)
    return jnp.sum(w * values, axis=0) / jnp.where(total > 0.0, total, jnp.nan)


def _force_power(force, p):
    """|F|^p of (T, 2) vectors (or (T,) magnitudes), with finite gradients at F = 0."""
    if force.ndim == 2:
        return _safe_power(jnp.sum(force * force, axis=-1), 0.5 * p)
    return _safe_power(jnp.abs(force), p)


@jax.jit
def _equivalent_load(ts, force, rel, lo, hi, p):
    w = _weights(ts, rel, lo, hi)[1]
    return _safe_power(_weighted_mean(_force_power(force, p), w), 1.0 / p)


def equivalent_load(ts, force, relative_speed, t_min=None, t_max=None, exponent=3.0):
    """Equivalent dynamic load P [N] of a varying load, weighted by relative revolutions
    (ISO/TR 1281-1; Harris & Kotzalas):

        P = ( sum_t w_t |F_t|^p / sum_t w_t )^(1/p),   w_t = revolution weight, p = 3 (balls).

    A constant load gives P = |F|; P0 + P1 sin(omega t) over whole periods at constant speed
    gives (P0^3 + 1.5 P0 P1^2)^(1/3).

    Args:
        ts: (T,) output times [s], increasing.
        force: (T, 2) bearing force vectors or (T,) magnitudes [N] (a radial bearing: the
            radial load is the magnitude).
        relative_speed: (T,) omega_inner - omega_outer [rad/s].
        t_min, t_max: window [s] (None: unbounded).
        exponent: p (3 for ball bearings, 10/3 for roller bearings).
    """
    ts, f, rel = _times(ts), _checks.as_float(force, "force", "N"), _relative_speed(relative_speed)
    _validate_history(ts, rel, t_min, t_max, f, "force", (2,) if f.ndim == 2 else ())
    p = _checks.as_float(exponent, "exponent", "-")
    return _equivalent_load(ts, f, rel, *_bounds(t_min, t_max), p)


def rating_life(load_rating, equivalent, exponent=3.0):
    """Basic rating life L10 = (C / P)^p [millions of revolutions] (ISO 281:2007; p = 3 for
    ball bearings). +inf where P = 0. Args: load_rating C [N] (> 0), equivalent P [N] (>= 0)."""
    c = _checks.as_float(load_rating, "load_rating", "N")
    p = _checks.as_float(equivalent, "equivalent", "N")
    _checks.check(
        lambda xp, c, p: [_checks.positive(xp, "load_rating", c, "N"), _checks.non_negative(xp, "equivalent", p, "N")],
        c, p,
    )
    return _safe_ratio(c**exponent, _safe_power(p, exponent))


# ISO 281:2007, Table 12: life modification factor for reliability a1 (L_nm = a1 L10) at the
# reliabilities 90 ... 99.95 %. Each entry is the standard's formula 0.95 (ln(1/R) /
# ln(1/0.9))^(2/3) + 0.05 (a Weibull slope 1.5 and a life that never falls below 0.05 L10) to
# the table's rounding (tests/test_rollers.py). The 1990 edition's a1, without the 0.05 floor
# (0.62, 0.53, 0.44, 0.33, 0.21 at 95 ... 99 %, as SKF's General Catalogue prints them, p. 53),
# give these through 0.95 a1 + 0.05; the test checks that too.
A1_RELIABILITY = np.array(
    [0.90, 0.95, 0.96, 0.97, 0.98, 0.99, 0.992, 0.994, 0.996, 0.998, 0.999, 0.9992, 0.9994, 0.9995]
)
A1_TABLE = np.array(
    [1.0, 0.64, 0.55, 0.47, 0.37, 0.25, 0.22, 0.19, 0.16, 0.12, 0.093, 0.087, 0.080, 0.077]
)


def reliability_factor(reliability):
    """Life modification factor for reliability a1 of ISO 281:2007 (Table 12), so that
    L_nm = a1 L10 is the life that the fraction ``reliability`` of a population reaches (with
    a_ISO = 1): 1 at 0.9, 0.25 at 0.99, 0.077 at 0.9995; linearly interpolated between the
    table's entries.

    Args: reliability: S in [0.9, 0.9995] (a fraction, not a percentage).
    """
    s = _checks.as_float(reliability, "reliability", "-")
    _checks.check(
        lambda xp, s: [
            (
                ~((s >= A1_RELIABILITY[0]) & (s <= A1_RELIABILITY[-1])),
                "reliability must lie in [0.9, 0.9995] (ISO 281 Table 12; a fraction: 0.99 for "
                "99 %)",
                s,
            )
        ],
        s,
    )
    return _checks.evaluate(
        lambda xp, s: xp.interp(s, xp.asarray(A1_RELIABILITY), xp.asarray(A1_TABLE)), s
    )


def mean_speed_rpm(ts, relative_speed, t_min=None, t_max=None):
    """Mean relative speed n = <|omega_inner - omega_outer|> 60 / (2 pi) [rpm] over the window
    (time average, trapezoid rule)."""
    ts, rel = _times(ts), _relative_speed(relative_speed)
    _validate_history(ts, rel, t_min, t_max, rotation=False)
    return _mean_speed_rpm(ts, rel, *_bounds(t_min, t_max))


@jax.jit
def _mean_speed_rpm(ts, rel, lo, hi):
    trap, w = _weights(ts, rel, lo, hi)
    return 60.0 * jnp.sum(w) / jnp.sum(trap)


def life_hours(l10, speed_rpm):
    """L10h = 1e6 L10 / (60 n) [h] from L10 [millions of revolutions] and n [rpm] (> 0)."""
    l10 = _checks.as_float(l10, "l10", "1e6 rev")
    n = _checks.as_float(speed_rpm, "speed_rpm", "rpm")
    _checks.check(
        lambda xp, l10, n: [_checks.non_negative(xp, "l10", l10, "1e6 rev"), _checks.positive(xp, "speed_rpm", n, "rpm")],
        l10, n,
    )
    return 1e6 * l10 / (60.0 * n)


# --------------------------------------------------------------------------------------------
# Lundberg–Palmgren: ball–raceway ratings, equivalent ball loads, ring and bearing lives
# --------------------------------------------------------------------------------------------


def ball_equivalent_load(ts, ball_loads, relative_speed, exponent, t_min=None, t_max=None):
    """Equivalent ball load over all balls and time, weighted by relative revolutions (Harris
    & Kotzalas, ch. 8):

        Q_e = ( sum_t w_t (1/Z) sum_j Q_j(t)^p / sum_t w_t )^(1/p)

    with p = 3 for a ring that rotates relative to the load (each of its points meets every
    ball load) and p = 10/3 for a ring that is stationary relative to the load (its most loaded
    points decide; 10/3 = 3 e with the Weibull slope e = 10/9). See `ring_equivalent_load` for
    the general case, where the load turns relative to both rings.

    Args: ts (T,) [s]; ball_loads (T, Z) [N] (>= 0); relative_speed (T,) [rad/s]; exponent p;
    window t_min, t_max [s]. Returns Q_e [N].
    """
    ts, rel = _times(ts), _relative_speed(relative_speed)
    q = _checks.as_float(ball_loads, "ball_loads", "N")
    _validate_history(ts, rel, t_min, t_max, q, "ball_loads", (None,), nonneg=True)
    return _ball_equivalent_load(
        ts, q, rel, *_bounds(t_min, t_max), _checks.as_float(exponent, "exponent", "-")
    )


@jax.jit
def _ball_equivalent_load(ts, q, rel, lo, hi, p):
    w = _weights(ts, rel, lo, hi)[1]
    per_time = jnp.mean(_safe_power(q, p), axis=-1)
    return _safe_power(_weighted_mean(per_time, w), 1.0 / p)


@jax.jit
def _ring_damage(ts, q, rel, lo, hi):
    """Q_e^3 of a ring from its point loads q (T, M)."""
    w = _weights(ts, rel, lo, hi)[1]
    return ring_cube_mean(_weighted_mean(_safe_power(q, 3.0), w))


def ring_cube_mean(cubic):
    """Q_e^3 of a ring from the cube-mean loads Q_k^3 of its M points (M,): the points fail
    independently with Weibull slope e = 10/9, Q_e^3 = ((1/M) sum_k (Q_k^3)^(10/9))^(9/10)."""
    return _safe_power(jnp.mean(_safe_power(cubic, 10.0 / 9.0)), 0.9)


def ring_equivalent_load(ts, ring_loads, relative_speed, t_min=None, t_max=None):
    """Equivalent ball load of a ring [N] from the load history of its own material points.

    ``ring_loads[t, k]`` is the load a ball exerts when it passes point k of M equally spaced
    points fixed in the ring. Each point collects stress cycles at a rate proportional to the
    relative speed; by Miner's rule (Lundberg–Palmgren load–life exponent 3) it sees the
    cube-mean load Q_k = (sum_t w_t Q_tk^3 / sum_t w_t)^(1/3). The points fail independently
    with Weibull slope e = 10/9, so the ring's survival is the product over points:

        Q_e = ( (1/M) sum_k Q_k^(10/3) )^(3/10).

    This needs no assumption on which ring turns relative to the load: a load turning
    uniformly through the points gives Harris' rotating-ring load (1/Z sum_j Q_j^3)^(1/3), a
    load fixed to the ring his stationary-ring load (1/Z sum_j Q_j^(10/3))^(3/10), and any
    mechanism lies in between.

    Args: ts (T,) [s]; ring_loads (T, M) [N] (>= 0); relative_speed (T,) [rad/s]; window [s].
    Returns: Q_e [N]; the ring life is (Q_c / Q_e)^3 (`ring_life`).
    """
    ts, rel = _times(ts), _relative_speed(relative_speed)
    q = _checks.as_float(ring_loads, "ring_loads", "N")
    _validate_history(ts, rel, t_min, t_max, q, "ring_loads", (None,), nonneg=True)
    return _safe_power(_ring_damage(ts, q, rel, *_bounds(t_min, t_max)), 1.0 / 3.0)


def ring_life(load_rating, equivalent):
    """Ring life L = (Q_c / Q_e)^3 [millions of relative revolutions], +inf at Q_e = 0."""
    return rating_life(load_rating, equivalent, 3.0)


def bearing_life(inner_life, outer_life):
    """Bearing L10 from its ring lives, the rings failing independently with Weibull slope
    e = 10/9: L10 = (L_i^(-10/9) + L_o^(-10/9))^(-9/10) [same unit as the inputs]."""
    li = _checks.as_float(inner_life, "inner_life", "1e6 rev")
    lo = _checks.as_float(outer_life, "outer_life", "1e6 rev")
    _checks.check(
        lambda xp, li, lo: [
            _checks.positive(xp, "inner_life", li, "1e6 rev"),
            _checks.positive(xp, "outer_life", lo, "1e6 rev"),
        ],
        li, lo,
    )
    return _combine(_safe_ratio(1.0, li), _safe_ratio(1.0, lo))


def _combine(inv_i, inv_o):
    """L10 from the inverse ring lives 1/L_i, 1/L_o (zero for an unloaded ring)."""
    s = _safe_power(inv_i, 10.0 / 9.0) + _safe_power(inv_o, 10.0 / 9.0)
    return _safe_ratio(1.0, _safe_power(s, 0.9))

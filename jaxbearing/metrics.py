"""Scalar metrics of a `Solution`, over a time window (default t >= 0.04 s, after the start-up
transient in which the rod falls onto the race and rings).

All are pure functions of the solution arrays, so they run under `jax.jit`, `jax.vmap` and the
differentiation transforms:

- the exact peaks (``peak_*``, ``max_*``) are differentiable almost everywhere: their derivative
  is that of the sample that attains the maximum, which jumps when another sample takes over;
  fine for sensitivities at one design point, poor for optimisation;
- the smooth versions (``smooth_*``) replace the maximum by a power mean
  (sum w x^p / sum w)^(1/p), which lies below the maximum, approaches it as p grows, and is
  differentiable everywhere: use them as objectives for `jax.grad` and optax. The RMS bearing
  force is smooth already.

Samples are weighted by the trapezoid rule on ``sol.ts``, so the means do not depend on how the
output times are spaced. Forces in N, displacements in m.

A window that holds no output time (e.g. a run to t1 < 0.04 s with the default t_min) has no
value: with concrete ``sol.ts`` and window the metric raises a `ValueError` naming ``t_min`` and
the span; traced (under jit or vmap, in sweeps) it is NaN and a warning says so at run time.

A metric that needs the model as well (bearing life: the bearing's geometry and the ring speeds)
is a function ``fn(sol, model)`` wrapped in `WithModel`, which tells `jaxbearing.sweep` to pass
each member's model; `jaxbearing.life.metric` makes one.
"""

from __future__ import annotations

import dataclasses
import functools
import warnings
from collections.abc import Callable

import equinox.internal as eqxi
import jax
import jax.numpy as jnp
import numpy as np

from .simulate import Solution

T_MIN = 0.04  # [s] start of the default window
TARGET_X = 9  # coordinate of the target's x in `cases.xu2014` (body 3)


@dataclasses.dataclass(frozen=True)
class WithModel:
    """A metric of the solution and the model: ``fn(sol, model) -> scalar``.

    `jaxbearing.sweep` calls a plain metric as ``fn(sol)`` and a WithModel as ``fn(sol, model)``
    with the member's own model (its swept parameters set). Calling a WithModel calls ``fn``.
    """

    fn: Callable

    def __call__(self, sol: Solution, model) -> jax.Array:
        return self.fn(sol, model)


def window(ts, t_min=T_MIN, t_max=None) -> jax.Array:
    """Trapezoid weights [s] of the output times inside [t_min, t_max], zero outside; checked
    by `check_window` (a window without output times)."""
    inside = ts >= t_min
    if t_max is not None:
        inside = inside & (ts <= t_max)
    dt = jnp.diff(ts)
    w = jnp.zeros_like(ts).at[:-1].add(0.5 * dt).at[1:].add(0.5 * dt)
    w = jnp.where(inside, w, 0.0)
    check_window(ts, w, t_min, t_max)
    return w


def check_window(ts, weights, t_min, t_max, need="one"):
    """A window whose weights [s] are all zero holds fewer than ``need`` output times: raise a
    `ValueError` when ``ts`` and the window [t_min, t_max] [s] are concrete; traced, warn at
    run time (the metrics of that window are NaN)."""
    if all(not isinstance(x, jax.core.Tracer) for x in (ts, weights, t_min, t_max)):
        if not np.any(np.asarray(weights) > 0):
            raise ValueError(_empty_window(t_min, t_max, ts[0], ts[-1], need) + ".")
        return
    empty = eqxi.unvmap_any(~jnp.any(weights > 0))
    lo = -jnp.inf if t_min is None else t_min
    bounds = (lo, jnp.inf if t_max is None else t_max, ts[0], ts[-1])
    warn = functools.partial(_warn_empty_window, need=need)
    jax.lax.cond(
        eqxi.nonbatchable(empty), lambda: jax.debug.callback(warn, *bounds), lambda: None
    )


def _empty_window(t_min, t_max, first, last, need):
    t_min = -np.inf if t_min is None else float(t_min)
    t_max = np.inf if t_max is None else float(t_max)
    return (
        f"the window t_min = {t_min:.6g} s to t_max = {t_max:.6g} s must hold at least "
        f"{need} of the output times, which span [{float(first):.6g}, {float(last):.6g}] s: "
        f"lower t_min (default {T_MIN} s, after the start-up transient) or simulate longer"
    )


def _warn_empty_window(t_min, t_max, first, last, *, need):
    warnings.warn(f"{_empty_window(t_min, t_max, first, last, need)}; the metric is NaN.")


def _peak(values, weights):
    """Max of values (T, ...) over samples with positive weight; NaN if there are none."""
    weighted = weights.reshape((-1,) + (1,) * (values.ndim - 1)) > 0
    peak = jnp.max(jnp.where(weighted, values, -jnp.inf))
    return jnp.where(jnp.any(weighted), peak, jnp.nan)


def _power_mean(values, weights, p):
    """(sum w x^p / sum w)^(1/p) of non-negative values (T, ...), scaled for overflow safety."""
    values = values.reshape(values.shape[0], -1)
    scale = jax.lax.stop_gradient(jnp.maximum(_peak(values, weights), 1e-300))
    x = values / scale
    w = weights[:, None] * jnp.ones_like(x)
    return scale * (jnp.sum(w * x**p) / jnp.sum(w)) ** (1.0 / p)


def _bearing_magnitude(sol: Solution):
    if sol.bearing_force is None:
        raise ValueError("This solution has no bearing joint.")
    f = sol.bearing_force
    return jnp.sqrt(jnp.sum(f * f, axis=-1) + 1e-30)


def peak_ball_load(sol: Solution, t_min=T_MIN, t_max=None) -> jax.Array:
    """Largest load on any ball [N] in the window."""
    if sol.ball_loads is None:
        raise ValueError("This solution has no bearing joint.")
    return _peak(sol.ball_loads, window(sol.ts, t_min, t_max))


def peak_bearing_force(sol: Solution, t_min=T_MIN, t_max=None) -> jax.Array:
    """Largest magnitude |F| of the bearing resultant (Eq. 28) [N] in the window."""
    return _peak(_bearing_magnitude(sol), window(sol.ts, t_min, t_max))


def rms_bearing_force(sol: Solution, t_min=T_MIN, t_max=None) -> jax.Array:
    """Root-mean-square of |F| over the window (time-weighted) [N]. Smooth."""
    w = window(sol.ts, t_min, t_max)
    f = sol.bearing_force
    return jnp.sqrt(jnp.sum(w * jnp.sum(f * f, axis=-1)) / jnp.sum(w))


def peak_impact_force(sol: Solution, t_min=T_MIN, t_max=None) -> jax.Array:
    """Largest normal impact force [N] in the window (sample it finely: impacts last ~100 µs)."""
    return _peak(sol.contact_force, window(sol.ts, t_min, t_max))


def max_target_displacement(sol: Solution, t_min=T_MIN, t_max=None, coordinate=TARGET_X) -> jax.Array:
    """Largest |q_c(t) - q_c(0)| [m] of one coordinate in the window (default: the xu2014 target's x)."""
    return _peak(jnp.abs(sol.q[:, coordinate] - sol.q[0, coordinate]), window(sol.ts, t_min, t_max))


def smooth_peak_ball_load(sol: Solution, t_min=T_MIN, t_max=None, p=16.0) -> jax.Array:
    """Power mean of order p of all ball loads over the window [N]: a differentiable stand-in
    for `peak_ball_load` (below it; closer as p grows)."""
    return _power_mean(sol.ball_loads, window(sol.ts, t_min, t_max), p)


def smooth_peak_bearing_force(sol: Solution, t_min=T_MIN, t_max=None, p=16.0) -> jax.Array:
    """Power mean of order p of |F| over the window [N]: differentiable stand-in for the peak."""
    return _power_mean(_bearing_magnitude(sol), window(sol.ts, t_min, t_max), p)


def smooth_peak_impact_force(sol: Solution, t_min=T_MIN, t_max=None, p=16.0) -> jax.Array:
    """Power mean of order p of the impact force over the window [N]."""
    return _power_mean(sol.contact_force, window(sol.ts, t_min, t_max), p)


STANDARD = {
    "peak_ball_load": peak_ball_load,
    "peak_bearing_force": peak_bearing_force,
    "rms_bearing_force": rms_bearing_force,
    "peak_impact_force": peak_impact_force,
    "max_target_displacement": max_target_displacement,
}
"""The standard metrics (name -> function of a Solution), used by default in sweeps."""

SMOOTH = {
    "smooth_peak_ball_load": smooth_peak_ball_load,
    "smooth_peak_bearing_force": smooth_peak_bearing_force,
    "rms_bearing_force": rms_bearing_force,
    "smooth_peak_impact_force": smooth_peak_impact_force,
}
"""Differentiable metrics, for gradients and optimisation."""

"""The arguments of a solve, checked: a `TypeError` or `ValueError` that names the argument,
its value and what is allowed (the span, the step-size controller and its tolerances, the
solver, the first step, the output times, the counts, the window edges), for any system the
engine integrates (`jaxbearing.simulate`, `simulate_one_loop` and `sweep` call them)."""

from __future__ import annotations

import numbers

import diffrax
import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from .._checks import is_concrete, to_float64


def check_count(name: str, value, optional: bool = False) -> None:
    """A `ValueError` unless ``value`` (the argument ``name``: ``max_steps``, a `SolveOptions`
    field) is an integer of at least 1, or None where ``optional``."""
    if optional and value is None:
        return
    if isinstance(value, bool) or not isinstance(value, numbers.Integral) or value < 1:
        allowed = "None or an integer" if optional else "an integer"
        raise ValueError(f"{name} must be {allowed} of at least 1; got {value!r}.")


def checked_span(t0, t1):
    """t0 and t1 [s] as float64 arrays: a `ValueError` now if they are concrete and not finite
    or t1 <= t0, an error at run time if traced and not finite (the solve checks t1 > t0:
    `start_rules`)."""
    for name, t in (("t0", t0), ("t1", t1)):
        if isinstance(t, (str, bytes, bool)):
            raise ValueError(f"{name} must be a number [s]; got {t!r}.")
    if is_concrete(t0, t1):  # known in Python (a number stays known even under a caller's trace)
        for name, t in (("t0", t0), ("t1", t1)):
            value = np.asarray(t, np.float64)
            if value.ndim or not np.isfinite(value):
                raise ValueError(f"{name} must be a finite number [s]; got {name} = {value}.")
        if not np.asarray(t1, np.float64) > np.asarray(t0, np.float64):
            raise ValueError(f"t1 must be greater than t0 = {float(t0)} s; got t1 = {float(t1)} s.")
        return to_float64(t0), to_float64(t1)
    t0, t1 = jnp.asarray(t0, jnp.float64), jnp.asarray(t1, jnp.float64)
    finite = jnp.isfinite(t0) & jnp.isfinite(t1)
    return t0, eqx.error_if(t1, ~finite, "t0 and t1 must be finite [s]")


def checked_tolerances(rtol, atol):
    """rtol and atol as float64 arrays (so that other tolerances reuse the compiled solve); a
    `ValueError` now if they are not numbers, or concrete and not finite, negative, or both
    zero."""
    for name, value in (("rtol", rtol), ("atol", atol)):
        if value is None or isinstance(value, (str, bytes, bool)):
            raise ValueError(f"{name} must be a finite number >= 0; got {name} = {value!r}.")
    rtol, atol = to_float64(rtol), to_float64(atol)
    if is_concrete(rtol, atol):
        values = {"rtol": np.asarray(rtol), "atol": np.asarray(atol)}
        for name, x in values.items():
            if x.ndim or not (np.isfinite(x) and x >= 0):
                raise ValueError(f"{name} must be a finite number >= 0; got {name} = {x}.")
        if not values["rtol"] < 1:
            raise ValueError(f"rtol must be below 1 (a relative error); got rtol = {values['rtol']}.")
        if not values["rtol"] + values["atol"] > 0:
            raise ValueError("rtol and atol must not both be zero: the step control needs one.")
    return rtol, atol


def checked_controller(controller):
    """``controller`` (a diffrax step-size controller; a `TypeError` for anything else) with its
    rtol and atol, where it has them, checked and made float64 arrays, so that other tolerances
    reuse the compiled solve."""
    if not isinstance(controller, diffrax.AbstractStepSizeController):
        raise TypeError(
            "stepsize_controller must be a diffrax step-size controller (e.g. "
            f"jaxbearing.default_controller(rtol, atol)); got {type(controller).__name__}."
        )
    if isinstance(controller, diffrax.StepTo):
        raise ValueError(
            "stepsize_controller=diffrax.StepTo is not supported: its grid of step ends cannot "
            "survive the restarts of the solve at its events (contact onsets and separations, ball "
            "engagements). simulate supports diffrax.PIDController (e.g. "
            "jaxbearing.default_controller(rtol, atol)) and diffrax.ConstantStepSize() with its "
            "step in jaxbearing.SolveOptions(dt0=...); outputs at chosen times come from ts."
        )
    if isinstance(controller, diffrax.AbstractAdaptiveStepSizeController):
        tolerances = checked_tolerances(controller.rtol, controller.atol)
        controller = eqx.tree_at(lambda c: (c.rtol, c.atol), controller, tolerances)
    return controller


def checked_solver(solver):
    """``solver``, a diffrax ODE solver with an error estimate; a `TypeError` for anything that
    is not a diffrax solver (a name, a class), a `ValueError` naming the solver where it
    integrates other terms than one ODE (SDE, IMEX and split solvers) or gives no error
    estimate (``diffrax.Euler``): the step control reads it, and under a constant step it is how
    a step whose result is not finite fails the run."""
    suggestion = "e.g. diffrax.Tsit5() (the default), diffrax.Dopri5() or jaxbearing.kvaerno5()"
    if isinstance(solver, type) and issubclass(solver, diffrax.AbstractSolver):
        raise TypeError(
            f"solver must be a diffrax solver instance, {suggestion}; got the class "
            f"{solver.__name__} (call it: {solver.__name__}())."
        )
    if not isinstance(solver, diffrax.AbstractSolver):
        raise TypeError(f"solver must be a diffrax solver, {suggestion}; got {solver!r}.")
    name = type(solver).__name__
    structure = solver.term_structure
    if not (structure is diffrax.AbstractTerm or structure is diffrax.ODETerm):
        raise ValueError(
            f"solver=diffrax.{name}() integrates other terms than one ODE (its term structure: "
            f"{structure}); simulate solves the equations of motion as one ODE: use an ODE "
            f"solver, {suggestion}."
        )
    if not isinstance(solver, diffrax.AbstractAdaptiveSolver):
        raise ValueError(
            f"solver=diffrax.{name}() gives no error estimate, which simulate needs with any "
            "step-size controller (the adaptive control reads it; under "
            "diffrax.ConstantStepSize() it is how a step whose result is not finite fails the "
            f"run): use a solver with an embedded error estimate, {suggestion}."
        )
    return solver


def checked_dt0(dt0, controller, t0, t1):
    """The first step [s] (``SolveOptions.dt0``) as a float64 array, or None; a `ValueError` now
    where it is None under a `diffrax.ConstantStepSize`, not a number, or concrete and not
    finite, not positive or not below t1 - t0 (traced: an error at run time)."""
    if dt0 is None:
        if isinstance(controller, diffrax.ConstantStepSize):
            raise ValueError(
                "stepsize_controller=diffrax.ConstantStepSize() needs its step: set it in "
                "jaxbearing.SolveOptions(dt0=...) [s], e.g. simulate(..., "
                "options=jaxbearing.SolveOptions(dt0=1e-6))."
            )
        return None
    if isinstance(dt0, (str, bytes, bool)) or np.ndim(dt0) != 0:
        raise ValueError(f"dt0 must be one number, a step [s]; got {dt0!r}.")
    dt0 = to_float64(dt0)
    if not is_concrete(dt0, t0, t1):
        wrong = ~(jnp.isfinite(dt0) & (dt0 > 0) & (dt0 < t1 - t0))
        return eqx.error_if(dt0, wrong, "dt0 must be finite, > 0 and below t1 - t0 [s]")
    span = float(t1) - float(t0)
    if not (np.isfinite(dt0) and 0 < float(dt0) < span):
        raise ValueError(
            f"dt0 must be a finite step [s] above 0 and below t1 - t0 = {span:.6g} s; got "
            f"dt0 = {float(dt0)!r}."
        )
    return dt0


def checked_ts(ts, t0, t1):
    """The output times as a float64 array; a `ValueError` now if they are not 1-D, or, when
    concrete, not finite, decreasing somewhere or outside [t0, t1] (traced: `start_rules`)."""
    single = getattr(ts, "dtype", None) == np.float32
    if not isinstance(ts, jax.Array) and np.asarray(ts).dtype.kind not in "iuf":
        raise ValueError(f"ts must be an array of numbers [s]; got {ts!r}.")
    ts = jnp.asarray(ts, jnp.float64)
    if ts.ndim != 1 or ts.shape[0] == 0:
        raise ValueError(f"ts must be a 1-D array of at least one output time [s]; got shape {ts.shape}.")
    if not is_concrete(ts, t0, t1):
        return ts
    t = np.asarray(ts)
    bad = np.flatnonzero(~np.isfinite(t))
    if bad.size:
        raise ValueError(f"ts must be finite [s]; got ts[{bad[0]}] = {t[bad[0]]}.")
    back = np.flatnonzero(t[1:] < t[:-1])
    if back.size:
        i = back[0]
        raise ValueError(
            f"ts must be increasing (equal neighbours allowed) [s]; got ts[{i + 1}] = {t[i + 1]:.6g} "
            f"after ts[{i}] = {t[i]:.6g}."
        )
    out = np.flatnonzero((t < float(t0)) | (t > float(t1)))
    if out.size:
        i = out[0]
        hint = " (float32 times round off t0 and t1: give ts in float64)" if single else ""
        raise ValueError(
            f"ts must lie within [t0, t1] = [{float(t0)!r}, {float(t1)!r}] s; got ts[{i}] = "
            f"{float(t[i])!r}{hint}."
        )
    return ts


def window_stops(window_edges, window_start=None, more=()) -> jax.Array:
    """The stops a solve adds to t1: the model's ``window_start`` (unless None), the
    ``window_edges`` [s] and ``more`` (the records' window edges); a `ValueError` unless
    ``window_edges`` is a tuple (or list) of finite numbers."""
    wrong = ValueError(
        f"window_edges must be a tuple of finite times [s] (e.g. (0.09,)); got {window_edges!r}."
    )
    if not isinstance(window_edges, (tuple, list)) or any(isinstance(e, (bool, str)) for e in window_edges):
        raise wrong
    start = () if window_start is None else (window_start,)
    try:
        stops = to_float64(start + tuple(window_edges) + tuple(more))
    except (TypeError, ValueError):
        raise wrong from None
    if stops.ndim != 1 or (is_concrete(stops) and not np.all(np.isfinite(stops))):
        raise wrong
    return stops

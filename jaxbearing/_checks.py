"""Validation of physical parameters, in one place for construction and for `simulate`.

Every rule is written once, as ``(is_wrong, message, value)``: ``message`` names the parameter and
what is allowed, ``value`` is what the error shows. Rules are made by functions that take the
array module ``xp`` as their first argument (the builders below, each parameter Module's
``violations(xp, named)``, `finite_leaves` for every floating leaf), and are checked twice:

- at construction (``__check_init__``, `check_init`), with ``xp`` NumPy on the concrete values,
  so that checking compiles nothing: the first broken rule raises a `ValueError` naming the
  parameter by the constructor's keyword (``clearance``), its value and what is allowed
  (`raise_first`). A Module built from traced values (inside a `jax.jit` or `jax.vmap`) is
  checked by the solve;
- by `jaxbearing.simulate`, because parameters also change after construction (`eqx.tree_at`,
  sweeps, optimisers): inside the compiled solve, with ``xp`` `jax.numpy`, the rules of the
  run (`start_rules`, parameters named by their path in the model, ``bearing.clearance``)
  give the index of the first broken rule and its value (`first_broken`), which the solve
  returns beside its result code (`RESULTS.invalid_input`; no host callback, so the compiled
  solve can be cached). After the call it raises that rule's message on the host
  (`raise_broken`), nothing evaluated again; under your own `jax.jit` or `jax.vmap` one
  `eqx.branched_error_if` raises it (`enforce`) when ``throw=True``.

The arguments of a solve (span, controller and tolerances, output times, counts, window edges)
are checked here as well (at the end: `check_count`, `checked_span` and what follows), with the
rules a run must meet (`start_rules`), for `simulate`, `simulate_one_loop` and `sweep` alike.
"""
from __future__ import annotations

import numbers
from collections.abc import Iterable
from typing import NamedTuple

import diffrax
import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

Rule = tuple[object, str, object]  # (is_wrong, message, value)


def keyword(field: str) -> str:
    """How a rule names a Module's field at construction: by the constructor's keyword, the
    field's own name (``named`` of ``violations``; a solve names it by its path in the model)."""
    return field


def require_x64() -> None:
    """Raise if JAX runs in float32: deflections of micrometres against stiffnesses of 1e10
    need float64."""
    if not jax.config.read("jax_enable_x64"):
        raise RuntimeError(
            "jaxbearing computes in float64, but JAX is in float32 mode. Call "
            "`jax.config.update('jax_enable_x64', True)` before building models "
            "(or set the environment variable JAX_ENABLE_X64=1)."
        )


def as_float(value, name: str, unit: str) -> jax.Array:
    """A float64 array leaf (parameters stay visible to `jax.vmap` and `jax.grad`) of the
    parameter ``name`` [unit]; anything but a number or an array of numbers (a string such as
    "40 um", a boolean, None) raises a `ValueError` naming the parameter and its unit."""
    require_x64()
    if not isinstance(value, (str, bytes, bool, np.bool_)):  # None: `to_float64` refuses it
        try:
            return to_float64(value)
        except (TypeError, ValueError):
            pass
    raise ValueError(
        f"{name} must be a number in SI units [{unit}] (a float or an array of floats); "
        f"got {value!r}."
    )


def require_scalars(module, fields, named=keyword) -> None:
    """A `ValueError` now for the first of ``fields`` (names of ``module``'s parameters, named
    in the message by ``named``) that is not one number: a value set after construction
    (`eqx.tree_at`) is not converted, and shapes are known at trace time, so this holds under
    jit and vmap as well."""
    for field in fields:
        value = getattr(module, field)
        if isinstance(value, (str, bytes, bool, np.bool_)) or value is None or np.ndim(value) != 0:
            shape = f"shape {np.shape(value)}" if hasattr(value, "shape") else repr(value)
            raise ValueError(f"{named(field)} must be one number; got {shape}.")


def as_floats(*specs) -> tuple[jax.Array, ...]:
    """`as_float` of each ``(value, name, unit)``."""
    return tuple(as_float(value, name, unit) for value, name, unit in specs)


def float_leaves(tree):
    """``tree`` with every number leaf (a Python or NumPy number or array, or a JAX array, as
    `eqx.tree_at` or a user may put in a model) as a float64 JAX array that is not weakly typed
    (``jnp.asarray(float("nan"))`` is), so that a jitted solve sees it as a value, not as part
    of its compiled program: another value compiles nothing. Booleans stay as they are."""

    def convert(x):
        if isinstance(x, (bool, np.bool_)) or not isinstance(x, (int, float, np.number, np.ndarray, jax.Array)):
            return x
        if isinstance(x, (np.ndarray, jax.Array)) and x.dtype.kind not in "iuf":
            return x
        if isinstance(x, jax.Array) and x.dtype == jnp.float64 and not x.weak_type:
            return x
        return to_float64(x)

    return jax.tree_util.tree_map(convert, tree)


def is_concrete(*xs) -> bool:
    """Whether every one of ``xs`` is a concrete value (known in Python), not a JAX tracer."""
    return not any(isinstance(x, jax.core.Tracer) for x in xs)


def _describe(value) -> str:
    arr = np.asarray(value)
    return f"{arr.item():.6g}" if arr.size == 1 else np.array2string(arr, precision=6)


def raise_first(rules: Iterable[Rule]) -> None:
    """Raise a `ValueError` for the first broken rule of ``rules``, evaluated in NumPy."""
    for is_wrong, message, value in rules:
        if np.any(is_wrong):
            raise ValueError(f"{message}; got {_describe(value)}.")


def check(rules_of, *values) -> None:
    """`raise_first` of ``rules_of(np, *values)`` where every one of ``values`` is concrete (in
    NumPy: compiles nothing); nothing where one is traced (then the caller's program runs on)."""
    if is_concrete(*jax.tree_util.tree_leaves(values)):
        raise_first(rules_of(np, *(np.asarray(v) for v in values)))


def first_broken(rules: Iterable[Rule]) -> tuple[jax.Array, jax.Array]:
    """In `jax.numpy`, under jit: the index of the first broken rule of ``rules`` (-1 where
    none is) and one number of its value: the first element that breaks the rule, or the
    value's first element where the rule is one condition on all of them (the output times)."""
    rules = list(rules)
    if not rules:
        return jnp.asarray(-1, jnp.int32), jnp.asarray(jnp.nan)
    wrong = jnp.stack([jnp.any(jnp.asarray(is_wrong)) for is_wrong, _, _ in rules])
    index = jnp.where(jnp.any(wrong), jnp.argmax(wrong), -1).astype(jnp.int32)
    values = jnp.stack([_culprit(is_wrong, value) for is_wrong, _, value in rules])
    return index, values[jnp.maximum(index, 0)]


def _culprit(is_wrong, value) -> jax.Array:
    value = jnp.ravel(jnp.asarray(value, jnp.float64))
    wrong = jnp.ravel(jnp.asarray(is_wrong))
    return value[jnp.argmax(wrong)] if wrong.shape == value.shape else value[0]


def messages(rules: Iterable[Rule]) -> tuple[str, ...]:
    """The messages of ``rules``, in order: what `first_broken`'s index points into."""
    return tuple(message for _, message, _ in rules)


class Broken(NamedTuple):
    """What a compiled solve returns of its rules (`start_rules`): the index of the first
    broken one (-1: none) and its value (`first_broken`), and every rule's message (static)."""

    index: jax.Array
    value: jax.Array
    messages: tuple[str, ...]


def broken(rules: Iterable[Rule]) -> Broken:
    """`Broken` of ``rules``, evaluated in `jax.numpy` (inside the compiled solve)."""
    rules = list(rules)
    return Broken(*first_broken(rules), messages(rules))


def raise_broken(b: Broken) -> None:
    """On the host, after a solve: the `ValueError` of the broken rule of ``b``, with its value;
    nothing where no rule is broken."""
    if int(b.index) >= 0:
        raise ValueError(f"{b.messages[int(b.index)]}; got {_describe(b.value)}.")


def enforce(x, b: Broken):
    """``x`` with the broken rule of ``b`` (traced) raised at run time: one
    `eqx.branched_error_if` for all rules (one `eqx.error_if` per rule would be traced once
    per rule)."""
    if not b.messages:
        return x
    return eqx.branched_error_if(x, b.index >= 0, jnp.maximum(b.index, 0), b.messages)


def to_float64(value) -> jax.Array:
    """``value`` as a float64 JAX array. A value known in Python is converted by NumPy and put on
    the device, which compiles nothing (``jnp.asarray`` of a number or a NumPy array compiles a
    small program per shape, once per process); a JAX array or tracer goes through
    ``jnp.asarray``. None is refused (NumPy would make it NaN)."""
    if value is None:
        raise TypeError("expected a number or an array of numbers; got None")
    if isinstance(value, jax.Array) or not is_concrete(*jax.tree_util.tree_leaves(value)):
        return jnp.asarray(value, jnp.float64)
    return jax.device_put(np.asarray(value, np.float64))


def evaluate(kernel, *args):
    """``kernel(xp, *args)``: in NumPy where every argument is known in Python (compiles
    nothing; the results as float64 JAX arrays), else in `jax.numpy` inside the caller's
    program (traced: differentiable)."""
    if is_concrete(*jax.tree_util.tree_leaves(args)):
        out = kernel(np, *(np.asarray(a, np.float64) for a in args))
        return jax.tree_util.tree_map(to_float64, out)
    return kernel(jnp, *args)


def on_host(tree):
    """``tree`` with every concrete JAX array as a NumPy array (traced leaves stay), so that
    its rules (``violations(np)``) evaluate in NumPy and compile nothing."""
    def convert(x):
        return np.asarray(x) if isinstance(x, jax.Array) and is_concrete(x) else x

    return jax.tree_util.tree_map(convert, tree)


def finite_leaves(xp, module, named=keyword) -> list:
    """One rule per floating array leaf of ``module``: it must be finite. Each is named by
    ``named`` of its dotted path in ``module`` (``"bearing.stiffness"``, as `jaxbearing.paths`
    reads it). A NaN passes every comparison rule, and a NaN or infinite parameter (an
    optimiser's step, `eqx.tree_at`) would have the solver shrink its step until ``max_steps``."""
    rules = []
    for path, leaf in jax.tree_util.tree_leaves_with_path(module):
        if eqx.is_inexact_array(leaf) or isinstance(leaf, (float, np.floating)):  # tree_at may set floats
            name = named(jax.tree_util.keystr(path, simple=True, separator="."))
            rules.append(finite(xp, name, leaf))
    return rules


def check_init(module) -> None:
    """The construction check of a parameter Module whose values are concrete, in NumPy: every
    floating leaf finite, then the Module's own ``violations(np)``, named by the constructor's
    keywords. A Module built from traced values is checked by the solve (`start_rules`)."""
    if is_concrete(*jax.tree_util.tree_leaves(module)):
        host = on_host(module)
        raise_first(finite_leaves(np, host) + host.violations(np))


def finite(xp, name: str, value):
    """The rule that ``value`` is finite (a NaN passes every comparison rule)."""
    return (~xp.isfinite(value), f"{name} must be finite (not NaN or infinite)", value)


def positive(xp, name: str, value, unit: str):
    return (xp.asarray(value) <= 0, f"{name} must be positive [{unit}]", value)


def non_negative(xp, name: str, value, unit: str):
    return (xp.asarray(value) < 0, f"{name} must be zero or positive [{unit}]", value)


def in_open_interval(xp, name: str, value, low: float, high: float):
    v = xp.asarray(value)
    return ((v <= low) | (v >= high), f"{name} must lie in ({low}, {high})", value)


def in_half_open_interval(xp, name: str, value, low: float, high: float):
    v = xp.asarray(value)
    return ((v <= low) | (v > high), f"{name} must lie in ({low}, {high}]", value)


def material(xp, youngs_modulus, poisson_ratio, youngs_name="youngs_modulus", poisson_name="poisson_ratio"):
    """Rules of an elastic material: E > 0 [Pa], nu in (0, 0.5), named as given."""
    return [
        positive(xp, youngs_name, youngs_modulus, "Pa"),
        in_open_interval(xp, poisson_name, poisson_ratio, 0.0, 0.5),
    ]


def ball_count(xp, n_balls, name="n_balls"):
    """A bearing has an integer number of rolling elements, at least 3 (``name``: the argument
    as the user types it, ``n_balls`` or ``n_rollers``)."""
    z = xp.asarray(n_balls)
    return ((z < 3) | (z != xp.round(z)), f"{name} must be an integer of at least 3", n_balls)


def balls_fit(xp, n_balls, ball_diameter, pitch_diameter, element="ball"):
    """The rolling elements fit around the pitch circle without overlapping: neighbours'
    centres lie d_m sin(pi/Z) apart, so D < d_m sin(pi/Z). ``element``: "ball" or "roller",
    as the arguments are named (``ball_diameter``, ``n_balls`` or ``roller_diameter``,
    ``n_rollers``)."""
    z, d, dm = (xp.asarray(v) for v in (n_balls, ball_diameter, pitch_diameter))
    return (
        d >= dm * xp.sin(xp.pi / xp.maximum(z, 1.0)),
        (
            f"{element}_diameter must be below pitch_diameter * sin(pi / n_{element}s), or the "
            f"{element}s overlap on the pitch circle [m]"
        ),
        ball_diameter,
    )


def pitch_exceeds_ball(xp, pitch_diameter, ball_diameter):
    """The pitch circle is wider than a ball: d_m > D [m]."""
    return (
        xp.asarray(pitch_diameter) <= xp.asarray(ball_diameter),
        "pitch_diameter must exceed ball_diameter [m]",
        pitch_diameter,
    )


def contact_angle_rule(xp, contact_angle):
    """A bearing's contact angle alpha lies in [0, pi/2) [rad]."""
    alpha = xp.asarray(contact_angle)
    return ((alpha < 0.0) | (alpha >= 0.5 * xp.pi), "contact_angle must lie in [0, pi/2) [rad]", contact_angle)


# the arguments of a solve (`jaxbearing.simulate`, `simulate_one_loop`, `sweep`)


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


def start_rules(model, t0, t1, ts=None) -> list:
    """Every rule a run must meet, in `jax.numpy` (inside the compiled solve: `first_broken`):
    the model's at ``t0`` (named by their paths in the model), t1 > t0, and the output times
    ``ts`` finite, increasing and within [t0, t1]."""
    rules = model.violations(jnp, t0)
    rules.append((t1 <= t0, "t1 must be greater than t0 [s]", t1))
    if ts is not None:
        rules.append(
            ((ts[0] < t0) | (ts[-1] > t1) | jnp.any(ts[1:] < ts[:-1]) | jnp.any(~jnp.isfinite(ts)),
             "ts must be finite, increasing and lie within [t0, t1]", ts)
        )
    return rules

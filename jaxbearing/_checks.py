"""Validation of physical parameters, in one place for construction and for `simulate`.

Every parameter Module lists its rules once, as ``(condition_that_is_wrong, message)`` pairs
returned by a ``violations()`` method; on top of them every floating leaf must be finite
(`finite_leaves`). The rules are enforced twice:

- at construction (``__check_init__``), as a `ValueError` that names the parameter, the value
  and what is allowed, whenever the values are concrete (known values are checked in NumPy,
  `namespace` and `on_host`: a check compiles no program);
- by `jaxbearing.simulate`, because parameters also change after construction (`eqx.tree_at`,
  sweeps, optimisers): inside the compiled solve as a result code (`RESULTS.invalid_input`, no
  host callback, so the compiled solve can be cached), raised on the host after the call with
  the rule's message (`raise_if_concrete`); a run given traced values (your own `jax.jit`,
  `jax.vmap`) raises it with `eqx.error_if` around the solve when ``throw=True``.

The arguments of a solve (span, controller and tolerances, output times, counts, window edges)
are checked here as well (at the end: `check_count`, `checked_span` and what follows), with the
rules a run must meet (`start_rules`), for `simulate`, `simulate_one_loop` and `sweep` alike.
"""

from __future__ import annotations

import numbers
from collections.abc import Iterable

import diffrax
import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

Violation = tuple[jax.Array, str]


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


def require_scalars(module, fields) -> None:
    """A `ValueError` now for the first of ``fields`` (names of ``module``'s parameters) that is
    not one number: a value set after construction (`eqx.tree_at`) is not converted, and shapes
    are known at trace time, so this holds under jit and vmap as well."""
    for field in fields:
        value = getattr(module, field)
        if isinstance(value, (str, bytes, bool, np.bool_)) or value is None or np.ndim(value) != 0:
            shape = f"shape {np.shape(value)}" if hasattr(value, "shape") else repr(value)
            raise ValueError(f"{type(module).__name__}.{field} must be one number; got {shape}.")


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


def raise_if_concrete(violations: Iterable[tuple[object, str, object]]) -> None:
    """Raise a `ValueError` for the first violated rule whose inputs are concrete.

    ``violations`` holds ``(is_wrong, message, value)``; traced entries are skipped here and
    enforced later by `enforce`.
    """
    for is_wrong, message, value in violations:
        if is_concrete(is_wrong, value) and bool(np.any(np.asarray(is_wrong))):
            raise ValueError(f"{message}; got {_describe(value)}.")


def any_violated(violations: Iterable[tuple[object, str, object]]) -> jax.Array:
    """Whether any rule of ``violations`` is violated: a boolean scalar, computed under jit
    without a host callback (`simulate` turns it into a result code)."""
    wrong = [jnp.any(jnp.asarray(is_wrong)) for is_wrong, _, _ in violations]
    return jnp.any(jnp.stack(wrong)) if wrong else jnp.zeros((), bool)


def enforce(x, violations: Iterable[tuple[object, str, object]]):
    """Attach every rule to ``x`` (usable under jit, vmap and grad): the first violated rule
    raises its message. One `eqx.branched_error_if` for all rules: one `eqx.error_if` per rule
    would be traced once per rule."""
    violations = list(violations)
    if not violations:
        return x
    wrong = jnp.stack([jnp.any(jnp.asarray(is_wrong)) for is_wrong, _, _ in violations])
    messages = [message for _, message, _ in violations]
    return eqx.branched_error_if(x, jnp.any(wrong), jnp.argmax(wrong), messages)


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


def namespace(*xs):
    """The array namespace for rules on ``xs``: NumPy when every one is concrete (a check of
    known values then compiles nothing), `jax.numpy` when any is traced (the check runs in the
    caller's program)."""
    return np if is_concrete(*xs) else jnp


def on_host(tree):
    """``tree`` with every concrete JAX array as a NumPy array (traced leaves stay), so that
    its rules (``violations()``) evaluate in NumPy: see `namespace`."""
    def convert(x):
        return np.asarray(x) if isinstance(x, jax.Array) and is_concrete(x) else x

    return jax.tree_util.tree_map(convert, tree)


def finite_leaves(module, prefix: str = "") -> list:
    """One rule per floating array leaf of ``module``: it must be finite. Each is named by its
    dotted path (``"forces.0.bearing.stiffness"``, as in `jaxbearing.paths`) after ``prefix``.
    A NaN passes every comparison rule, and a NaN or infinite parameter (an optimiser's step,
    `eqx.tree_at`) would have the solver shrink its step until ``max_steps``."""
    rules = []
    for path, leaf in jax.tree_util.tree_leaves_with_path(module):
        if eqx.is_inexact_array(leaf) or isinstance(leaf, (float, np.floating)):  # tree_at may set floats
            name = prefix + jax.tree_util.keystr(path, simple=True, separator=".")
            rules.append(finite(name, leaf))
    return rules


def check_init(module) -> None:
    """The construction check of a parameter Module: every floating leaf finite (named
    ``Class.field``), then the Module's own ``violations()``."""
    host = on_host(module)
    raise_if_concrete(finite_leaves(host, f"{type(module).__name__}.") + host.violations())


def finite(name: str, value):
    """The rule that ``value`` is finite (a NaN passes every comparison rule)."""
    return (~namespace(value).isfinite(value), f"{name} must be finite (not NaN or infinite)", value)


def positive(name: str, value, unit: str):
    return (namespace(value).asarray(value) <= 0, f"{name} must be positive [{unit}]", value)


def non_negative(name: str, value, unit: str):
    return (namespace(value).asarray(value) < 0, f"{name} must be zero or positive [{unit}]", value)


def in_open_interval(name: str, value, low: float, high: float):
    v = namespace(value).asarray(value)
    return ((v <= low) | (v >= high), f"{name} must lie in ({low}, {high})", value)


def in_half_open_interval(name: str, value, low: float, high: float):
    v = namespace(value).asarray(value)
    return ((v <= low) | (v > high), f"{name} must lie in ({low}, {high}]", value)


def material(youngs_modulus, poisson_ratio, youngs_name="youngs_modulus", poisson_name="poisson_ratio"):
    """Rules of an elastic material: E > 0 [Pa], nu in (0, 0.5), named as given."""
    return [
        positive(youngs_name, youngs_modulus, "Pa"),
        in_open_interval(poisson_name, poisson_ratio, 0.0, 0.5),
    ]


def ball_count(n_balls, name="n_balls"):
    """A bearing has an integer number of rolling elements, at least 3 (``name``: the argument
    as the user types it, ``n_balls`` or ``n_rollers``)."""
    xp = namespace(n_balls)
    z = xp.asarray(n_balls)
    return ((z < 3) | (z != xp.round(z)), f"{name} must be an integer of at least 3", n_balls)


def balls_fit(n_balls, ball_diameter, pitch_diameter, element="ball"):
    """The rolling elements fit around the pitch circle without overlapping: neighbours'
    centres lie d_m sin(pi/Z) apart, so D < d_m sin(pi/Z). ``element``: "ball" or "roller",
    as the arguments are named (``ball_diameter``, ``n_balls`` or ``roller_diameter``,
    ``n_rollers``)."""
    xp = namespace(n_balls, ball_diameter, pitch_diameter)
    z, d, dm = (xp.asarray(v) for v in (n_balls, ball_diameter, pitch_diameter))
    return (
        d >= dm * xp.sin(xp.pi / xp.maximum(z, 1.0)),
        (
            f"{element}_diameter must be below pitch_diameter * sin(pi / n_{element}s), or the "
            f"{element}s overlap on the pitch circle [m]"
        ),
        ball_diameter,
    )


def pitch_exceeds_ball(pitch_diameter, ball_diameter):
    """The pitch circle is wider than a ball: d_m > D [m]."""
    xp = namespace(pitch_diameter, ball_diameter)
    return (
        xp.asarray(pitch_diameter) <= xp.asarray(ball_diameter),
        "pitch_diameter must exceed ball_diameter [m]",
        pitch_diameter,
    )


def contact_angle_rule(contact_angle):
    """A bearing's contact angle alpha lies in [0, pi/2) [rad]."""
    xp = namespace(contact_angle)
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
    if isinstance(controller, diffrax.AbstractAdaptiveStepSizeController):
        tolerances = checked_tolerances(controller.rtol, controller.atol)
        controller = eqx.tree_at(lambda c: (c.rtol, c.atol), controller, tolerances)
    return controller


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


def window_stops(window_edges, window_start=None) -> jax.Array:
    """The stops a solve adds to t1: the model's ``window_start`` (unless None) and the
    ``window_edges`` [s]; a `ValueError` unless those are a tuple (or list) of finite numbers."""
    wrong = ValueError(
        f"window_edges must be a tuple of finite times [s] (e.g. (0.09,)); got {window_edges!r}."
    )
    if not isinstance(window_edges, (tuple, list)) or any(isinstance(e, (bool, str)) for e in window_edges):
        raise wrong
    start = () if window_start is None else (window_start,)
    try:
        stops = to_float64(start + tuple(window_edges))
    except (TypeError, ValueError):
        raise wrong from None
    if stops.ndim != 1 or (is_concrete(stops) and not np.all(np.isfinite(stops))):
        raise wrong
    return stops


def start_rules(model, t0, t1, ts=None) -> list:
    """Every rule a run must meet (as `any_violated` and `enforce` take them): the model's at
    ``t0``, t1 > t0, and the output times ``ts`` finite, increasing and within [t0, t1]."""
    rules = model.violations(t0)
    rules.append((t1 <= t0, "t1 must be greater than t0 [s]", t1))
    if ts is not None:
        rules.append(
            ((ts[0] < t0) | (ts[-1] > t1) | jnp.any(ts[1:] < ts[:-1]) | jnp.any(~jnp.isfinite(ts)),
             "ts must be finite, increasing and lie within [t0, t1]", ts)
        )
    return rules

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

This module holds the machinery and the generic rules (positive, finite, in an interval);
each parameter's own rules live with it (the bearing geometry's and materials' in
`jaxbearing.laws.rules`), the solve's arguments' in `jaxbearing.solve._arguments`, the rules a
run of a mechanism must meet in `jaxbearing.simulation`.
"""
from __future__ import annotations

from collections.abc import Iterable
from typing import NamedTuple

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
    value's first element where the rule is one condition on all of them (the output times).
    The value carries no derivative: under `jax.grad` or `jax.jacfwd` it comes back a plain
    number that the error message can show (`raise_broken`)."""
    rules = list(rules)
    if not rules:
        return jnp.asarray(-1, jnp.int32), jnp.asarray(jnp.nan)
    wrong = jnp.stack([jnp.any(jnp.asarray(is_wrong)) for is_wrong, _, _ in rules])
    index = jnp.where(jnp.any(wrong), jnp.argmax(wrong), -1).astype(jnp.int32)
    values = jnp.stack([_culprit(is_wrong, value) for is_wrong, _, value in rules])
    return index, jax.lax.stop_gradient(values[jnp.maximum(index, 0)])


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

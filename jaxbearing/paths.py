"""Parameters named by dotted paths, e.g. ``"bearing.clearance"`` or ``"impact.restitution"``.

A path is read with attribute access from the model (``model.bearing.clearance``); numeric parts
index tuples (``"contacts.0.impact.restitution"``). `replace` returns a new model through
`eqx.tree_at`, so values may be traced (vmap, grad) and the original model is unchanged.

Each bearing joint's parameters are ``"bearings.i.bearing.<field>"`` (i: its index in
``model.bearings``, model order) and each contact's ``"contacts.j.impact.<field>"``; on a model
with one of them, ``"bearing.<field>"`` and ``"impact.<field>"`` name the same leaves.
`parameter_paths` lists every path of a model.
"""

from __future__ import annotations

from collections.abc import Mapping

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np


def _step(node, part: str):
    if part.isdigit():
        return node[int(part)]
    return getattr(node, part)


def get(model, path: str):
    """The value at ``path`` in ``model``; a ValueError listing the model's paths where it has
    none there."""
    node = model
    for part in path.split("."):
        try:
            node = _step(node, part)
        except (AttributeError, IndexError, TypeError) as err:
            known = parameter_paths(model) if isinstance(model, eqx.Module) else []
            listed = f" Its parameters: {', '.join(known)}." if known else ""
            raise ValueError(
                f"Parameter path {path!r} does not exist in the model ({err}).{listed}"
            ) from None
    return node


def _key(entry) -> str:
    """One part of a dotted path from a `jax.tree_util` key."""
    for attribute in ("name", "idx", "key"):
        if hasattr(entry, attribute):
            return str(getattr(entry, attribute))
    return str(entry)


def parameter_paths(model) -> list[str]:
    """Every path of ``model``'s numeric parameters (its array leaves), in model order, as a
    user types it (`typed`)."""
    return [
        typed(model, ".".join(_key(k) for k in keys))
        for keys, leaf in jax.tree_util.tree_flatten_with_path(model)[0]
        if eqx.is_array(leaf)
    ]


def typed(model, path: str) -> str:
    """The path a user types for the parameter at ``path``, a model's tree path
    (``"forces.0.bearing.clearance"``): the model's bearing joints through ``bearings``
    (``"bearings.1.bearing.clearance"``), the parameters of its only bearing through
    ``bearing`` (``"bearing.clearance"``) and of its only contact through ``impact``
    (``"impact.restitution"``); any other path as it is. Each reads the same leaf with `get`."""
    parts = path.split(".")
    if len(parts) > 2 and parts[0] == "forces":
        i, bearings = int(parts[1]), model.bearings
        is_bearing = [any(f is joint for joint in bearings) for f in model.forces]
        if is_bearing[i]:
            if len(bearings) == 1 and parts[2] == "bearing":
                return ".".join(parts[2:])
            return ".".join(["bearings", str(sum(is_bearing[:i]))] + parts[2:])
    if len(parts) > 2 and parts[0] == "contacts" and len(model.contacts) == 1 and parts[2] == "impact":
        return ".".join(parts[2:])
    return path


def replace(model, values: Mapping[str, object]):
    """A copy of ``model`` with each ``path -> value`` of ``values`` set."""
    if not values:
        return model
    names = list(values)
    for name in names:
        get(model, name)  # clear error for a bad path
    check_distinct(model, names)
    where = lambda m: tuple(get(m, name) for name in names)  # noqa: E731
    return eqx.tree_at(where, model, tuple(_as_leaf(values[name]) for name in names))


def scalar_leaf(model, path: str, purpose: str):
    """The value at ``path``, which must be a scalar array leaf of ``model`` (a `ValueError`
    otherwise, saying it is needed ``purpose``, e.g. ``"to be swept"``)."""
    leaf = get(model, path)
    if not eqx.is_array(leaf) or jnp.shape(leaf) != ():
        raise ValueError(
            f"Parameter {path!r} must be a scalar array leaf of the model {purpose}; got "
            f"{type(leaf).__name__} {getattr(leaf, 'shape', '')}."
        )
    return leaf


class _Tag:
    """Stands in for a leaf, to tell which leaf a path reaches."""


def check_distinct(model, names):
    """A `ValueError` if two paths reach the same leaf (e.g. ``"bearing.clearance"`` and
    ``"forces.0.bearing.clearance"`` of `cases.xu2014`): which value wins would be arbitrary."""
    leaves, treedef = jax.tree_util.tree_flatten(model)
    tagged = jax.tree_util.tree_unflatten(treedef, [_Tag() for _ in leaves])
    seen = {}
    for name in names:
        reached = get(tagged, name)
        for tag in jax.tree_util.tree_leaves(reached, is_leaf=lambda x: isinstance(x, _Tag)):
            if id(tag) in seen:
                raise ValueError(
                    f"Parameter paths {seen[id(tag)]!r} and {name!r} name the same parameter; "
                    "give it once."
                )
            seen[id(tag)] = name


def _as_leaf(value):
    """Numbers become float64 arrays: a Python float would be a static leaf, and every new value
    would recompile `simulate`."""
    if isinstance(value, (int, float, np.number, np.ndarray)) and not isinstance(value, bool):
        return jnp.asarray(value, dtype=jnp.float64)
    return value

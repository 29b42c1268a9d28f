"""Parameters named by dotted paths, e.g. ``"bearing.clearance"`` or ``"impact.restitution"``.

A path is read with attribute access from the model (``model.bearing.clearance``); numeric parts
index tuples (``"contacts.0.impact.restitution"``). `replace` returns a new model through
`eqx.tree_at`, so values may be traced (vmap, grad) and the original model is unchanged.

Every force element is in ``model.forces`` (``"forces.2.impact.restitution"``); the views name
them too: each bearing joint's parameters are ``"bearings.i.bearing.<field>"`` (i: its index
in ``model.bearings``, model order), each contact's ``"contacts.j.<field>"``, gravity's
``"gravity.acceleration"``; on a model with one bearing joint or one contact,
``"bearing.<field>"`` and ``"impact.<field>"`` name the same leaves, and a named force element
(``Mechanism(forces={"rope": ...})``) is named by its name too (``"rope.stiffness"``).
`parameter_paths` lists every path of a model, in both forms where there are two (`general`,
`typed`); a path the model lacks is a `ValueError` that lists them.
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
    names = getattr(node, "force_names", ())  # a Mechanism's named force elements
    if part in names and not hasattr(node, part):
        return node.forces[names.index(part)]
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
    """Every path of ``model``'s numeric parameters (its array leaves), in model order: each
    leaf by its general path (`general`: ``"bearings.1.bearing.clearance"``,
    ``"contacts.0.impact.restitution"``, ``"bodies.2.mass"``), followed, where the model has one
    bearing joint or one contact, by the short path that reads the same leaf (`typed`:
    ``"bearing.clearance"``, ``"impact.restitution"``), and where its element is named by the
    path through the name (`named`: ``"stop.impact.restitution"``)."""
    found = []
    for keys, leaf in jax.tree_util.tree_flatten_with_path(model)[0]:
        if eqx.is_array(leaf):
            path = ".".join(_key(k) for k in keys)
            found += dict.fromkeys((general(model, path), typed(model, path), named(model, path)))
    return found


def general(model, path: str) -> str:
    """The path that names the parameter at ``path``, a model's tree path
    (``"forces.0.bearing.clearance"``), whatever the model's counts: a bearing joint's and an
    impact contact's through their views and their index there
    (``"bearings.0.bearing.clearance"``, ``"contacts.0.impact.restitution"``), gravity's through
    ``gravity``, any other path as it is. `get` reads the same leaf."""
    parts = path.split(".")
    if len(parts) < 3 or parts[0] != "forces" or not parts[1].isdigit():
        return path
    i, rest = int(parts[1]), parts[2:]
    element = model.forces[i]
    for view in ("bearings", "contacts"):
        place = [k for k, other in enumerate(getattr(model, view)) if other is element]
        if place:
            return ".".join([view, str(place[0])] + rest)
    if element is _gravity(model):
        return ".".join(["gravity"] + rest)
    return path


def typed(model, path: str) -> str:
    """The shortest path that names the parameter at ``path``, a model's tree path, as messages
    name it: the parameters of the model's only bearing through ``bearing``
    (``"bearing.clearance"``) and of its only contact through ``impact``
    (``"impact.restitution"``); a named force element's through its name (``"rope.stiffness"``,
    where the name is no attribute of the model); any other as `general` names it
    (``"bearings.1.bearing.clearance"``). `get` reads the same leaf."""
    parts = general(model, path).split(".")
    only = {"bearings": ("bearing", len(model.bearings)), "contacts": ("impact", len(model.contacts))}
    if len(parts) > 2 and only.get(parts[0]) == (parts[2], 1):
        return ".".join(parts[2:])
    return named(model, path)


def named(model, path: str) -> str:
    """The path through the element's name of the parameter at ``path``, a model's tree path,
    where its force element is named (``"stop.impact.restitution"``); else `general`'s."""
    tree = path.split(".")
    if len(tree) > 2 and tree[0] == "forces" and tree[1].isdigit():
        name = model.force_names[int(tree[1])]
        if name is not None and _nameable(model, name):
            return ".".join([name] + tree[2:])
    return general(model, path)


def _nameable(model, name: str) -> bool:
    """Whether a force element's ``name`` can start a path: no dot, not a number, not an
    attribute of the model."""
    return "." not in name and not name.isdigit() and not hasattr(model, name)


def _gravity(model):
    """The model's only `Gravity` element, or None."""
    try:
        return model.gravity
    except AttributeError:  # several
        return None


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
    for name in names:
        get(model, name)  # a path the model lacks: the error lists those it has
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

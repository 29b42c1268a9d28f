"""What produced a result: package versions and the model's full parameter set.

Result files record both (`jaxbearing xu2014`'s ``summary.json``, a sweep's ``manifest.json`` and
``results.nc``), so that a result can be traced and re-run:

- `versions`: python, jaxbearing, jax, jaxlib, diffrax, equinox, numpy;
- `parameters`: every field of the model, array leaves and static fields alike, under its
  dotted path (`jaxbearing.paths`: ``"forces.0.bearing.clearance"``, ``"bodies.2.mass"``), with
  arrays as (nested) lists of floats in SI units. The array entries can be set back onto a model
  of the same structure with ``paths.replace(model, {path: value, ...})``.
"""

from __future__ import annotations

import dataclasses
import platform
from importlib import metadata

import equinox as eqx
import numpy as np

PACKAGES = ("jaxbearing", "jax", "jaxlib", "diffrax", "equinox", "numpy")


def versions() -> dict[str, str]:
    """Versions of python and of `PACKAGES` (``"not installed"`` where one is missing)."""
    found = {"python": platform.python_version()}
    for name in PACKAGES:
        try:
            found[name] = metadata.version(name)
        except metadata.PackageNotFoundError:
            found[name] = "not installed"
    return found


def parameters(model) -> dict[str, object]:
    """Every field of ``model`` (an `eqx.Module`, e.g. a `Mechanism`) by dotted path, depth first.

    Arrays become floats (scalars) or nested lists; static fields keep their value (int, float,
    str, bool, None; tuples as lists); anything else is recorded by its ``repr``. Every path can
    be read back with `jaxbearing.paths.get`.
    """
    record: dict[str, object] = {}
    _collect(model, "", record)
    return record


def _collect(node, path, record):
    if isinstance(node, eqx.Module):
        for field in dataclasses.fields(node):
            _collect(getattr(node, field.name), _join(path, field.name), record)
    elif isinstance(node, (tuple, list)) and any(isinstance(x, eqx.Module) for x in node):
        for i, child in enumerate(node):
            _collect(child, _join(path, str(i)), record)
    else:
        record[path] = _plain(node)


def _join(path, part):
    return f"{path}.{part}" if path else part


def _plain(value):
    if value is None or isinstance(value, (bool, int, float, str)):
        return value
    if isinstance(value, (tuple, list)):
        return [_plain(v) for v in value]
    if eqx.is_array(value) or isinstance(value, np.generic):
        return np.asarray(value).tolist()
    return repr(value)

"""Solves stored across processes: a solve's traced and lowered program, kept on disk.

JAX's persistent compilation cache (`jaxbearing._process`) spares a process the compiling of a
solve met before on this machine, but not the tracing and lowering that come first and make the
program's key (docs/performance.md gives their share of a run). Here
`call` keeps the lowered program itself (`jax.export`: StableHLO, serialized) in `folder`,
under a key of everything the program was built from, and a later process calls it from there:
it lowers a small wrapper around the stored program, and the compile is served by JAX's cache.

The key (`key`) is a SHA-256 of
- the code: the source of jaxbearing, diffrax, equinox, lineax and optimistix, and the versions
  of jax, jaxlib, numpy and Python;
- JAX's configuration (every value of ``jax.config.values``) and the default backend's platform
  and device kind;
- the call: the types and static values of every node of the arguments' pytrees (the model, the
  solver, the controller, the sizes) and the shape and dtype of each array in them.

A value the key cannot describe for certain (a class, function or object from outside those
libraries, e.g. a force element a user wrote, or a function that closes over a value) leaves the
solve out of the store: it is traced in each process as before, with the same results. A stored
program and a traced one are the same program, so where the store serves changes no result.

The store is a folder inside that of JAX's cache (`folder`): on where that cache is on (also
in a folder the user chose), off with its opt-out (``JAXBEARING_NO_COMPILATION_CACHE``). A file
is written whole (a temporary file renamed), so that an interrupted or concurrent writer
(pytest-xdist workers) leaves either no file or a whole one; a file that cannot be read is
written again. Its files are trusted as JAX's cache files are: both hold what a process runs.
"""

from __future__ import annotations

import enum
import functools
import hashlib
import importlib.metadata
import importlib.util
import os
import pickle
import sys
import tempfile
import types
import warnings
from pathlib import Path

import jax
import numpy as np
from jax import export


FORMAT = 1  # of the stored files; another value makes every key new
TRACED_CODE = ("jaxbearing", "diffrax", "equinox", "lineax", "optimistix")  # sources in the key
VERSIONED = ("jax", "jaxlib", "numpy")  # versions in the key
KNOWN_MODULES = TRACED_CODE + ("jax", "jaxlib", "numpy", "builtins", "math", "operator")


class _Unknown(Exception):
    """A value `_describe` cannot describe for certain."""


class _NotExported(Exception):
    """`jax.export` refused a solve."""


def folder() -> Path | None:
    """Where the stored solves are: ``jaxbearing-solves`` in the folder of JAX's persistent
    compilation cache (`jaxbearing._process`), so that the store is on exactly where that cache
    is, and deleting that folder deletes both; None where the cache is off (the opt-out
    ``JAXBEARING_NO_COMPILATION_CACHE``) or remote, or ``jax_disable_jit`` is set."""
    cache = jax.config.jax_compilation_cache_dir
    if not cache or "://" in str(cache) or not jax.config.jax_enable_compilation_cache:
        return None
    if jax.config.jax_disable_jit:
        return None
    return Path(cache) / "jaxbearing-solves"


@functools.cache
def _code_digest() -> str | None:
    """The code's part of every key; None where a source cannot be read (e.g. from a zip)."""
    h = hashlib.sha256(f"format {FORMAT}; python {sys.version}".encode())
    try:
        for name in VERSIONED:
            h.update(f"; {name} {importlib.metadata.version(name)}".encode())
        for name in TRACED_CODE:
            root = Path(importlib.util.find_spec(name).origin).parent
            sources = sorted(root.rglob("*.py"))
            if not sources:
                return None
            for path in sources:
                h.update(f"\n{name}/{path.relative_to(root).as_posix()}\n".encode())
                h.update(path.read_bytes())
    except (OSError, TypeError, importlib.metadata.PackageNotFoundError):
        return None
    return h.hexdigest()


def _known(obj) -> bool:
    module = getattr(obj, "__module__", None) or ""
    return module.split(".")[0] in KNOWN_MODULES


def _describe(value) -> str:
    """A text that stands for ``value`` in a key: equal texts, equal values (else `_Unknown`)."""
    if value is None or isinstance(value, (bool, int, float, complex, str, bytes)):
        return f"{type(value).__name__}:{value!r}"
    if isinstance(value, (tuple, list)):
        return f"{type(value).__name__}({','.join(map(_describe, value))})"
    if isinstance(value, dict):
        items = sorted((_describe(k), _describe(v)) for k, v in value.items())
        return f"dict({','.join(f'{k}:{v}' for k, v in items)})"
    if isinstance(value, (np.ndarray, np.generic)):
        digest = hashlib.sha256(np.ascontiguousarray(value).tobytes()).hexdigest()
        return f"ndarray({value.dtype},{value.shape},{digest})"
    if isinstance(value, enum.Enum) and _known(type(value)):
        return f"enum:{_name(type(value))}.{value.name}"
    if isinstance(value, type):
        if not _known(value):
            raise _Unknown(value)
        return f"type:{_name(value)}"
    if isinstance(value, functools.partial):
        return f"partial({_describe(value.func)},{_describe(value.args)},{_describe(value.keywords)})"
    if isinstance(value, types.MethodType):
        return f"method({_describe(value.__self__)},{_describe(value.__func__)})"
    if isinstance(value, (types.FunctionType, types.BuiltinFunctionType)):
        if not _known(value):
            raise _Unknown(value)
        name = f"function:{value.__module__}.{value.__qualname__}"
        if "<" not in value.__qualname__:
            return name  # defined at import, by the source in the key
        # made at run time (a closure, a lambda): its values are not in its name
        cells = [cell.cell_contents for cell in value.__closure__ or ()]
        return f"{name}({_describe((value.__defaults__, value.__kwdefaults__, cells))})"
    if _known(type(value)) and _stateless(value):
        return f"object:{_name(type(value))}"  # a marker, e.g. equinox's field sentinel
    raise _Unknown(value)


def _stateless(value) -> bool:
    """An instance of a Python class with no attribute of its own (an object with state kept
    elsewhere, e.g. in C, has no ``__dict__``)."""
    slots = any("__slots__" in vars(cls) for cls in type(value).__mro__[:-1])
    return not slots and hasattr(value, "__dict__") and not vars(value)


def _name(cls) -> str:
    return f"{cls.__module__}.{cls.__qualname__}"


def _describe_tree(treedef) -> str:
    node = treedef.node_data()
    children = ",".join(_describe_tree(child) for child in treedef.children())
    if node is None:
        return "*"  # a leaf
    kind, data = node
    if not _known(kind):
        raise _Unknown(kind)
    return f"{_name(kind)}[{_describe(data)}]({children})"


def _is_array(x) -> bool:
    return isinstance(x, (jax.Array, np.ndarray, np.generic))


def key(name: str, args) -> str | None:
    """The key of a call of the solve ``name`` with the arguments ``args`` (see the module doc),
    or None where it cannot be made for certain (then `call` traces the solve as before)."""
    code = _code_digest()
    if code is None:
        return None
    leaves, treedef = jax.tree_util.tree_flatten(args)
    try:
        parts = [name, _describe_tree(treedef)]
        for leaf in leaves:
            if _is_array(leaf):  # an input of the program (as strongly typed: `_store`)
                parts.append(f"array({leaf.dtype},{np.shape(leaf)})")
            else:
                parts.append(_describe(leaf))
    except (_Unknown, ValueError, RecursionError):  # ValueError: a closure's empty cell
        return None
    backend = jax.devices()[0]
    config = sorted((option, repr(value)) for option, value in jax.config.values.items())
    h = hashlib.sha256(code.encode())
    h.update(repr((backend.platform, backend.device_kind, config, parts)).encode())
    return h.hexdigest()


class _Array:
    """Marks an array of a stored program's outputs in its output skeleton."""

    __slots__ = ("index",)

    def __init__(self, index):
        self.index = index


def _named(fn, name):
    """``fn`` under ``name``: JAX's logs, events and cache files name the stored program after the
    solve it stores (e.g. ``jit(_simulate)``)."""

    def named(*args):
        return fn(*args)

    named.__name__ = named.__qualname__ = name
    return named


class _Entry:
    """A stored solve in this process: the program, jitted, and its output skeleton."""

    def __init__(self, exported, skeleton, name):
        self.call = jax.jit(_named(exported.call, name))
        self.skeleton = skeleton

    def __call__(self, arrays):
        outputs = self.call(*arrays)
        fill = lambda s: outputs[s.index] if isinstance(s, _Array) else s  # noqa: E731
        return jax.tree_util.tree_map(fill, self.skeleton, is_leaf=lambda s: isinstance(s, _Array))


_ENTRIES: dict[str, _Entry | None] = {}  # key -> this process's entry; None: not storable


def call(fn, *args):
    """``fn(*args)`` (a solve, jitted, from the sources in the key), through the store where it
    can serve: arguments that are concrete (not traced) and describable (`key`). The arrays of ``args`` are its inputs,
    everything else is part of the program, as in `eqx.filter_jit`."""
    where = folder()
    traced = any(isinstance(x, jax.core.Tracer) for x in jax.tree_util.tree_leaves(args))
    if where is None or traced or not _known(fn):
        return fn(*args)
    name = getattr(fn, "__name__", "solve")
    k = key(f"{getattr(fn, '__module__', '')}.{name}", args)
    if k is None:
        return fn(*args)
    if k not in _ENTRIES:
        path = where / f"{k}.solve"
        try:
            _ENTRIES[k] = _load(path, k, name) or _store(fn, args, path, k, name)
        except _NotExported as err:
            _ENTRIES[k] = None
            result = fn(*args)  # an error of the solve itself raises here, as without the store
            warnings.warn(
                f"jaxbearing: this solve cannot be stored for later processes ({err}); it is "
                "traced again in each process, with the same results.",
                RuntimeWarning,
                stacklevel=4,
            )
            return result
    entry = _ENTRIES[k]
    if entry is None:
        return fn(*args)
    return entry([x for x in jax.tree_util.tree_leaves(args) if _is_array(x)])


def _load(path: Path, k: str, name: str) -> _Entry | None:
    """The entry stored in ``path``; None where there is none, or none that can be read."""
    try:
        data = path.read_bytes()
    except OSError:
        return None
    try:
        stored_key, serialized, skeleton = pickle.loads(data)
        if stored_key != k:
            return None
        return _Entry(export.deserialize(bytearray(serialized)), skeleton, name)
    except Exception:  # a file cut short or from elsewhere: written again by _store
        return None


def _store(fn, args, path: Path, k: str, name: str) -> _Entry:
    """Export ``fn(*args)`` (`_NotExported` where that fails), write it to ``path`` and return
    its entry."""
    leaves, treedef = jax.tree_util.tree_flatten(args)
    where = [i for i, x in enumerate(leaves) if _is_array(x)]
    out_tree = []

    def program(*arrays):
        merged = list(leaves)
        for i, x in zip(where, arrays):
            merged[i] = x
        out_leaves, tree = jax.tree_util.tree_flatten(fn(*jax.tree_util.tree_unflatten(treedef, merged)))
        out_tree.append((tree, [None if _is_array(x) else x for x in out_leaves]))
        return [x for x in out_leaves if _is_array(x)]

    avals = [jax.ShapeDtypeStruct(np.shape(leaves[i]), leaves[i].dtype) for i in where]
    try:
        exported = export.export(jax.jit(_named(program, name)))(*avals)
    except Exception as err:  # an operation jax.export refuses, or an error of the solve
        raise _NotExported(f"{type(err).__name__}: {err}") from err
    tree, statics = out_tree[-1]
    count = iter(range(len(statics)))
    skeleton = jax.tree_util.tree_unflatten(
        tree, [_Array(next(count)) if s is None else s for s in statics]
    )
    entry = _Entry(exported, skeleton, name)
    try:
        data = pickle.dumps((k, exported.serialize(), skeleton))
    except Exception:  # an output that cannot be pickled: this process still uses the entry
        return entry
    _write(path, data)
    return entry


def _write(path: Path, data: bytes) -> None:
    """Write ``data`` whole or not at all (a temporary file in the folder, then renamed)."""
    tmp = None
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=".", suffix=".tmp")
        with os.fdopen(fd, "wb") as f:
            f.write(data)
        os.replace(tmp, path)
    except OSError as err:
        if tmp is not None:
            Path(tmp).unlink(missing_ok=True)
        warnings.warn(
            f"jaxbearing: cannot write to {path.parent} ({err.strerror}); solves are traced again "
            "in each process.",
            RuntimeWarning,
            stacklevel=5,
        )

"""What a metric computes, as a digest that a sweep's manifest records beside the metric's label
(`store.manifest`): two metrics of one label that compute different things, such as two
``metrics.Peak(lambda model, x: ...)`` (both ``Peak(<lambda>)``) or one function redefined
between a sweep and its resume, have different digests, so that a folder never hands one
function's values to another.

`code_digest` reads what the metric's own code is made of, the same in every process (no
address, no hash-seeded order, no line number):

- a function of the user's: its code object (bytecode, constants, the names it reads, its
  arguments; nested functions' code alike), its defaults, the values it closes over, and the
  values of the module globals its code loads (functions of the same module by their code,
  others by their qualified names);
- a metric object: its class and its fields (``dataclasses.fields``, static ones too), with the
  methods of a class of the user's by their code; `functools.partial`: its function, arguments
  and keywords; a wrapper (``jax.jit``'s functions, `functools.wraps`): what it wraps;
- numbers, strings, containers by value, arrays by dtype, shape and bytes, modules, classes and
  builtins by their qualified names, anything else by its ``repr`` without addresses.

jaxbearing's own functions and classes are named, not read (their label identifies them, and
the package versions are recorded, not compared: `store`), so a metric of jaxbearing's alone
has no digest and its manifest entry is its label, as before. Another Python version compiles
the same source to other bytecode: its digest differs, and a folder started under one is then
refused by the other, never mixed.
"""

from __future__ import annotations

import dataclasses
import dis
import functools
import hashlib
import re
import types

import jax
import numpy as np

PACKAGE = "jaxbearing"
DIGITS = 16  # hex digits of the sha256 that the manifest shows (64 bits)


def labelled(metric) -> str:
    """The manifest's entry of ``metric``: its label, and the digest of its own code where it
    holds some, e.g. ``Peak(<lambda>) [code 3f2a...]``."""
    label = without_address(metric.label)
    digest = code_digest(metric)
    return label if digest is None else f"{label} [code {digest[:DIGITS]}]"


def code_digest(metric) -> str | None:
    """sha256 (hex) of what ``metric`` computes, or None where it holds no code but
    jaxbearing's (see the module doc)."""
    reader = _Reader()
    text = reader.read(metric)
    return hashlib.sha256(text.encode()).hexdigest() if reader.user_code else None


def without_address(text: str) -> str:
    """``text`` without the memory addresses of default reprs (`` at 0x7f...``)."""
    return re.sub(r" at 0x[0-9a-fA-F]+", "", text)


def _ours(thing) -> bool:
    """Whether a function or class is jaxbearing's own."""
    module = getattr(thing, "__module__", None) or ""
    return module == PACKAGE or module.startswith(PACKAGE + ".")


def _name(thing) -> str:
    return f"{getattr(thing, '__module__', None)}.{getattr(thing, '__qualname__', repr(thing))}"


class _Reader:
    """Turns a value into text that identifies what it computes (`code_digest`); notes whether
    it read code of the user's."""

    def __init__(self):
        self.user_code = False
        self._open: set[int] = set()  # ids of the functions and objects being read (cycles)

    def read(self, x, module: str | None = None) -> str:
        """Text of ``x``; ``module``: the module of the function that refers to ``x`` through
        its globals (a function of another module is then named, not read)."""
        if x is None or isinstance(x, (bool, int, float, complex, str, bytes)):
            return f"{type(x).__name__}:{x!r}"
        if isinstance(x, (tuple, list)):
            return f"{type(x).__name__}[{', '.join(self.read(v, module) for v in x)}]"
        if isinstance(x, dict):
            items = sorted(f"{self.read(k, module)}: {self.read(v, module)}" for k, v in x.items())
            return f"dict{{{', '.join(items)}}}"
        if isinstance(x, (set, frozenset)):
            return f"{type(x).__name__}{{{', '.join(sorted(self.read(v, module) for v in x))}}}"
        if isinstance(x, (np.ndarray, np.generic, jax.Array)):
            a = np.ascontiguousarray(np.asarray(x))
            return f"array({a.dtype.str}, {a.shape}, {hashlib.sha256(a.tobytes()).hexdigest()})"
        if isinstance(x, types.ModuleType):
            return f"module:{x.__name__}"
        if isinstance(x, types.CodeType):
            return self._code(x, module)
        if isinstance(x, types.FunctionType):
            return self._function(x, module)
        if isinstance(x, types.MethodType):
            return f"method({self.read(x.__func__, module)}, {self.read(x.__self__, module)})"
        if isinstance(x, functools.partial):
            return (f"partial({self.read(x.func, module)}, {self.read(x.args, module)}, "
                    f"{self.read(x.keywords, module)})")  # fmt: skip
        if isinstance(x, type):
            return f"class:{_name(x)}"
        if dataclasses.is_dataclass(x):  # metrics and other equinox modules
            return self._fields(x, module)
        wrapped = getattr(x, "__wrapped__", None)
        if callable(wrapped):  # jax.jit's functions, functools.wraps: what they wrap
            return f"wraps({_name(x)}, {self.read(wrapped, module)})"
        if callable(x) and hasattr(x, "__name__"):  # builtins, NumPy's ufuncs
            return f"callable:{_name(x)}"
        try:
            shown = without_address(repr(x))
        except Exception:  # noqa: BLE001  (a repr that fails names nothing more than its type)
            shown = "?"
        return f"{_name(type(x))}:{shown}"

    def _guarded(self, x, read):
        """``read()``, or a mark where ``x`` is already being read (a cycle)."""
        if id(x) in self._open:
            return f"cycle:{_name(x)}"
        self._open.add(id(x))
        try:
            return read()
        finally:
            self._open.discard(id(x))

    def _function(self, fn, module):
        if _ours(fn) or (module is not None and fn.__module__ != module):
            return f"function:{_name(fn)}"
        self.user_code = True

        def read():
            own = fn.__module__
            cells = [c.cell_contents if _filled(c) else "<empty>" for c in fn.__closure__ or ()]
            names = [n for n in dict.fromkeys(_global_names(fn.__code__)) if n in fn.__globals__]
            globals_ = [f"{n}={self.read(fn.__globals__[n], own)}" for n in names]
            return (f"function({fn.__qualname__}, {self._code(fn.__code__, own)}, "
                    f"defaults={self.read(fn.__defaults__, own)}, "
                    f"kwdefaults={self.read(fn.__kwdefaults__, own)}, "
                    f"closure={self.read(cells, own)}, globals=[{', '.join(globals_)}])")  # fmt: skip

        return self._guarded(fn, read)

    def _code(self, code, module):
        consts = [self.read(c, module) for c in code.co_consts]
        return (f"code({code.co_name}, {code.co_argcount}, {code.co_posonlyargcount}, "
                f"{code.co_kwonlyargcount}, {code.co_flags}, {code.co_code.hex()}, "
                f"names={code.co_names}, varnames={code.co_varnames}, "
                f"freevars={code.co_freevars}, cellvars={code.co_cellvars}, "
                f"consts=[{', '.join(consts)}])")  # fmt: skip

    def _fields(self, x, module):
        cls = type(x)

        def read():
            fields = [f"{f.name}={self.read(getattr(x, f.name, None), module)}"
                      for f in dataclasses.fields(x)]  # fmt: skip
            return f"{self._class(cls)}({', '.join(fields)})"

        return self._guarded(x, read)

    def _class(self, cls) -> str:
        """A class by name; a class of the user's with the code of the methods it and its
        bases define, down to the first class of jaxbearing's or equinox's."""
        methods = []
        for c in cls.__mro__:
            if _ours(c) or c.__module__.startswith("equinox") or c is object:
                break
            for name, member in sorted(vars(c).items()):
                member = getattr(member, "fget", member)  # a property: its getter
                member = getattr(member, "__func__", member)  # static and class methods
                if isinstance(member, types.FunctionType):
                    methods.append(f"{name}={self._function(member, None)}")
        return f"{_name(cls)}<{', '.join(methods)}>" if methods else _name(cls)


def _filled(cell) -> bool:
    try:
        cell.cell_contents
    except ValueError:  # a cell not assigned yet
        return False
    return True


_GLOBAL_LOADS = ("LOAD_GLOBAL", "LOAD_NAME")


def _global_names(code) -> list[str]:
    """The global names that ``code`` and the code objects nested in it load, in order."""
    names = [i.argval for i in dis.get_instructions(code) if i.opname in _GLOBAL_LOADS]
    for const in code.co_consts:
        if isinstance(const, types.CodeType):
            names += _global_names(const)
    return names

"""Solves stored across processes (`jaxbearing._stored`): a second process runs a stored
solve without tracing it, with the results of the first; a damaged file is written again; a
refused export warns and runs; and the key changes with everything the program depends on, and
is not made for code from outside the libraries it hashes (the opt-out: tests/test_compile.py)."""

import functools
import json
import subprocess
import sys
import warnings

import diffrax
import jax
import jax.numpy as jnp
import numpy as np
import pytest

import jaxbearing as jb
from jaxbearing import _stored

_RUN = """
import json
import jax
jax.config.update("jax_enable_x64", True)
import jaxbearing as jb
from jaxbearing import _stored
from jaxbearing.solve import _simulate
traced = []
core_start = _simulate.core_start
def counted(*args):
    traced.append(1)  # the solve's Python runs: it is being traced
    return core_start(*args)
_simulate.core_start = counted
sol = jb.simulate(jb.cases.rotor(jb.cases.skf98205()), 0.01, jax.numpy.linspace(0.0, 0.01, 5))
folder = _stored.folder()
files = sorted(p.name for p in folder.iterdir()) if folder.is_dir() else []
cached = sorted(p.name.split("-")[0] for p in folder.parent.iterdir())  # JAX's own cache
print(json.dumps({"traced": len(traced), "q": sol.q.tolist(), "files": files, "cached": cached}))
"""


def _run(env):
    done = subprocess.run([sys.executable, "-c", _RUN], env=env, capture_output=True, text=True)
    assert done.returncode == 0, done.stderr[-3000:]
    return json.loads(done.stdout.strip().splitlines()[-1])


def test_a_second_process_runs_the_stored_solve_without_tracing_it(tmp_path, own_cache_env):
    """The first process traces the rotor's solve and stores it, and JAX's persistent cache
    writes its compiled form (the compiled solve holds no host callback: checks and failures
    come back as result codes, and the cache refuses any program with a callback); the next
    process runs it from the store without tracing it, with the same positions (one program,
    the same inputs)."""
    env = own_cache_env(XDG_CACHE_HOME=str(tmp_path))
    first = _run(env)
    assert first["traced"] >= 1 and len(first["files"]) == 1, first
    assert "jit__simulate" in first["cached"], first["cached"]
    second = _run(env)
    assert second["traced"] == 0 and second["files"] == first["files"], second
    np.testing.assert_allclose(second["q"], first["q"], rtol=1e-13, atol=0)



def test_a_damaged_or_refused_solve_runs_and_says_so(monkeypatch, tmp_path):
    """A program is stored and served again (one file); a damaged file (an interrupted copy, a
    full disk) is stored again whole; one that `jax.export` refuses runs as it is, with a
    warning that it is traced in each process; an error of the solve itself is raised as
    without the store, with no warning."""
    monkeypatch.setattr(_stored, "folder", lambda: tmp_path)
    monkeypatch.setattr(_stored, "_ENTRIES", {})
    x = jnp.linspace(0.0, 1.0, 3)
    np.testing.assert_allclose(_stored.call(jnp.sin, x), np.sin(x), rtol=1e-15)
    np.testing.assert_allclose(_stored.call(jnp.sin, 2 * x), np.sin(2 * x), rtol=1e-15)
    (stored,) = tmp_path.glob("*.solve")
    whole = stored.read_bytes()
    stored.write_bytes(whole[: len(whole) // 2])
    _stored._ENTRIES.clear()  # as in a new process
    np.testing.assert_allclose(_stored.call(jnp.sin, x), np.sin(x), rtol=1e-15)
    assert _stored._load(stored, stored.stem, "sin") is not None  # whole again
    with pytest.raises(TypeError), warnings.catch_warnings():
        warnings.simplefilter("error")
        _stored.call(jnp.reshape, x, (2,))  # 3 values cannot take the shape (2,)

    def refuse(*args, **kwargs):
        raise ValueError("refused")

    monkeypatch.setattr(_stored.export, "export", refuse)
    with pytest.warns(RuntimeWarning, match="cannot be stored for later processes .*refused"):
        np.testing.assert_allclose(_stored.call(jnp.cos, x), np.cos(x), rtol=1e-15)
    assert len(list(tmp_path.glob("*.solve"))) == 1


@pytest.fixture(scope="module")
def call_args():
    """The arguments `simulate` hands to the store for a short run of the paper's case: the
    (name, args) of `_stored.key`, without running anything."""

    class Captured(Exception):
        pass

    def capture(*args, **kwargs):
        raise Captured(args)

    def args_of(model, t1=0.01, ts=None, **kwargs):
        original = _stored.call
        _stored.call = capture
        try:
            jb.simulate(model, t1, ts, **kwargs)
        except Captured as captured:
            fn, *args = captured.args[0]
            return f"{fn.__module__}.{fn.__name__}", tuple(args)
        finally:
            _stored.call = original
        raise AssertionError("simulate did not call the store")

    return args_of


def test_the_key_changes_with_what_the_program_depends_on(call_args):
    """Equal calls, equal keys; parameter values and tolerances (inputs of the program) keep the
    key; a static setting of the model, the solver, the number of output times and JAX's
    configuration each change it."""
    model = jb.cases.xu2014(impact=False)
    base = _stored.key(*call_args(model))
    assert isinstance(base, str) and base == _stored.key(*call_args(jb.cases.xu2014(impact=False)))
    same = [
        call_args(jb.paths.replace(model, {"bearing.clearance": 60e-6})),
        call_args(model, stepsize_controller=jb.default_controller(rtol=1e-9)),
    ]
    assert all(_stored.key(*args) == base for args in same)
    other = [
        call_args(jb.cases.xu2014(impact=False, cage="constant")),
        call_args(jb.cases.xu2014(impact=True)),
        call_args(model, solver=jb.kvaerno5()),
        call_args(model, ts=jnp.linspace(0.0, 0.01, 4097)),
    ]
    keys = {_stored.key(*args) for args in other}
    assert None not in keys and base not in keys and len(keys) == len(other)
    with jax.numpy_rank_promotion("raise"):
        assert _stored.key(*call_args(model)) != base


def test_code_from_outside_the_hashed_libraries_is_not_stored(call_args):
    """A solver class written here (its source is in no key) makes no key: such a solve is traced
    in each process. Values held by a function are part of its description."""

    class OwnTsit5(diffrax.Tsit5):
        pass

    model = jb.cases.rotor(jb.cases.skf98205())
    assert _stored.key(*call_args(model, solver=OwnTsit5())) is None
    assert _stored.key(*call_args(model)) is not None
    one, two = (functools.partial(jnp.where, x) for x in (True, False))
    assert _stored._describe(one) != _stored._describe(two)
    with pytest.raises(_stored._Unknown):
        _stored._describe(lambda x: x)  # defined in this module, outside the key's sources


"""How the solve compiles: once per structure (values, tolerances, step limits and up to 2048
output times compile nothing new, nor does a Python float put into a model), model checks of
known values in NumPy (building a model compiles nothing), XLA:CPU's loops
compiled whole by default (`jaxbearing._process`, with its opt-out), the persistent compilation
cache on by default (a second process compiles no solve met before), and no private or
compiler-steering code in the package."""

import dataclasses
import json
import os
import pathlib
import re
import subprocess
import sys

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import pytest

import jaxbearing as jb
from jaxbearing import _process

PACKAGE = pathlib.Path(jb.__file__).parent
# [s] the paper's case over this span (its contact is switched on at 0.05 s: no impact yet), up
# to 2048 output times, is the compiled solve that tests/test_validation.py and
# tests/test_windows.py run too: one worker compiles it once for all of them (tests/conftest.py)
SPAN = 0.005


@pytest.mark.slow  # 17 s: the solve compiled inside another program
def test_simulate_inside_a_user_jit_equals_the_top_level_call():
    model = jb.cases.xu2014(impact=False)
    ts = jnp.linspace(0.0, 0.002, 3)
    top = jb.simulate(model, 0.002, ts)
    nested = jax.jit(lambda m: jb.simulate(m, 0.002, ts))(model)
    # other XLA options round differently, and the solver amplifies that up to its accuracy
    # (the benchmark finds positions within 1e-8 m of a 1000x tighter reference; measured
    # 7e-9 here, in the rod's angle while it falls onto the race)
    np.testing.assert_allclose(nested.q, top.q, rtol=0, atol=2e-8)


def test_tolerances_and_step_limit_compile_nothing_new(compiled_functions):
    """rtol, atol and max_steps are values of the compiled solve: another value runs the solve
    of `SPAN` without compiling it again, and tighter tolerances take more steps."""
    model = jb.cases.xu2014()
    ts = jnp.linspace(0.0, SPAN, 3)
    loose = jb.simulate(model, SPAN, ts)
    with compiled_functions() as compiles:
        tight = jb.simulate(model, SPAN, ts, stepsize_controller=jb.default_controller(rtol=1e-10, atol=1e-12), max_steps=7_000)
    assert "jit(_simulate)" not in compiles
    assert int(tight.num_steps) > int(loose.num_steps)
    np.testing.assert_allclose(tight.q, loose.q, rtol=0, atol=2e-8)


def test_fewer_output_times_compile_nothing_new(compiled_functions):
    """Called at the top level, up to 2048 output times share one compiled solve, that of the
    tests above: outputs at the times two runs share are the same to the last bit, and every
    per-time field has one row per output time asked for."""
    model = jb.cases.xu2014()
    ts = jnp.linspace(0.0, SPAN, 21)
    few = jb.simulate(model, SPAN, ts[::10])
    with compiled_functions() as compiles:
        many = jb.simulate(model, SPAN, ts)
    assert "jit(_simulate)" not in compiles
    arrays = lambda x: {  # noqa: E731
        f.name for f in dataclasses.fields(x)
        if isinstance(getattr(x, f.name), jax.Array) and getattr(x, f.name).ndim >= 1
    }  # fmt: skip
    per_time = {"q", "qd", "drift"}
    assert arrays(many) == {"ts"} and arrays(many.samples) == per_time  # the samples apart
    # the accelerations, evaluated when read by a program of their own for each count of
    # output times: equal within rounding (1e-13 of the largest)
    scale = float(np.max(np.abs(np.asarray(many.qdd))))
    np.testing.assert_allclose(np.asarray(few.qdd), np.asarray(many.qdd)[::10], rtol=0, atol=1e-13 * scale)
    assert few.qdd.shape == (3, model.n_coordinates) and many.qdd.shape == (21, model.n_coordinates)
    read = {name: (lambda s, n=name: getattr(s.samples, n)) for name in per_time}
    read["ts"] = lambda s: s.ts
    for i, element in enumerate(many.samples.elements):  # each element's quantities too
        for name in element:
            read[f"{i}.{name}"] = lambda s, i=i, n=name: s.samples.elements[i][n]
    for name in ("ball_loads", "force", "cage_angle"):
        read[name] = lambda s, n=name: getattr(s.bearings[0], n)
    for name, get in read.items():
        assert get(many).shape[0] == 21, name
        np.testing.assert_array_equal(get(few), get(many)[::10], err_msg=name)


def test_a_python_float_put_into_the_model_compiles_nothing_new(compiled_functions):
    """`eqx.tree_at` with a Python float (the documented pattern) or a weakly typed JAX array
    reuses the compiled solve of the tests above, and the value takes effect: both runs are equal
    (one compiled program, the same inputs)."""
    model = jb.cases.xu2014()
    ts = jnp.linspace(0.0, SPAN, 3)
    jb.simulate(model, SPAN, ts)
    wider = eqx.tree_at(lambda m: m.bearing.clearance, model, 60e-6)
    assert isinstance(wider.bearing.clearance, float)
    as_array = eqx.tree_at(lambda m: m.bearing.clearance, model, jnp.asarray(60e-6))
    assert as_array.bearing.clearance.weak_type  # a weakly typed array is another program to JAX
    with compiled_functions() as compiles:
        sol = jb.simulate(wider, SPAN, ts)
        from_array = jb.simulate(as_array, SPAN, ts)
    assert "jit(_simulate)" not in compiles
    np.testing.assert_array_equal(sol.q, from_array.q)


_FRESH = """
import json, os, sys
import jax
jax.config.update("jax_enable_x64", True)
if sys.argv[1] == "off":
    os.environ["JAXBEARING_KEEP_XLA_FLAGS"] = "1"
import jaxbearing as jb
from jaxbearing import _process
model = jb.cases.rotor(jb.cases.skf98205())
sol = jb.simulate(model, 0.01, jax.numpy.linspace(0.0, 0.01, 5))
print(json.dumps({"flags": os.environ.get("XLA_FLAGS", ""), "q": sol.q.tolist()}))
"""


def _fresh(mode, **env):
    env = {**{k: v for k, v in os.environ.items() if k not in ("XLA_FLAGS", _process.OPT_OUT)}, **env}
    done = subprocess.run([sys.executable, "-c", _FRESH, mode], env=env, capture_output=True, text=True)
    assert done.returncode == 0, done.stderr[-3000:]
    return json.loads(done.stdout.strip().splitlines()[-1])


@pytest.mark.slow  # 27 s: two fresh processes, each compiling under other XLA flags
def test_loops_compile_whole_by_default_with_an_opt_out():
    """Importing jaxbearing sets its one XLA flag; ``JAXBEARING_KEEP_XLA_FLAGS=1`` keeps XLA's
    defaults, and a user's own ``xla_backend_extra_options`` is left alone. Both settings agree
    to the solver's accuracy (other kernels round differently; the rotor's positions are
    millimetres, rtol 1e-8)."""
    on, off = _fresh("on"), _fresh("off")
    assert _process.LOOP_KERNELS_FLAG in on["flags"].split()
    assert _process.LOOP_KERNELS_FLAG not in off["flags"]
    np.testing.assert_allclose(on["q"], off["q"], rtol=0, atol=1e-9)
    own = "--xla_backend_extra_options=xla_cpu_small_while_loop_byte_threshold=2048"
    assert _fresh("on", XLA_FLAGS=own)["flags"] == own


_IMPORT = """
import json, os, sys
import jax
jax.config.update("jax_enable_x64", True)
import numpy as np
if sys.argv[1] == "late":
    jax.device_put(np.ones(2)) + 1.0  # the process's first computation: JAX starts its backends
import jaxbearing
from jaxbearing import _process
print(json.dumps([_process.backends_started(), os.environ.get("XLA_FLAGS", "")]))
"""


def test_the_loop_flag_is_added_only_before_the_first_computation():
    """XLA reads XLA_FLAGS when JAX starts its backends: imported before the process's first
    computation, jaxbearing adds its loop flag (and importing it starts no backend); imported
    after it, the flag could change nothing and is not added (a process started from this one
    would inherit it). `backends_started` tells the two apart and leaves its probe as it was."""
    env = {k: v for k, v in os.environ.items() if k not in ("XLA_FLAGS", _process.OPT_OUT)}

    def run(when):
        done = subprocess.run([sys.executable, "-c", _IMPORT, when], env=env, capture_output=True, text=True)
        assert done.returncode == 0, done.stderr[-3000:]
        return json.loads(done.stdout.strip().splitlines()[-1])

    assert run("early") == [False, _process.LOOP_KERNELS_FLAG]
    assert run("late") == [True, ""]
    probe = getattr(jax.config, _process._PROBE)
    jnp.ones(2) + 1.0  # this process has computed
    assert _process.backends_started()
    assert getattr(jax.config, _process._PROBE) == probe  # left as it was


# a child process that counts the programs it compiles and those it loads from the cache
_COUNTING = """
import json
import jax
jax.config.update("jax_enable_x64", True)
import jaxbearing as jb
counts = {"compiles": 0, "cache_hits": 0}
def count(event, duration=None, **kwargs):
    if event == "/jax/core/compile/backend_compile_duration":  # every program compiled or loaded
        counts["compiles"] += 1
    if event == "/jax/compilation_cache/cache_hits":
        counts["cache_hits"] += 1
jax.monitoring.register_event_duration_secs_listener(count)
jax.monitoring.register_event_listener(count)
"""

_SECOND_PROCESS = _COUNTING + """
import equinox as eqx
model = jb.cases.rotor(jb.cases.skf98205(ball_force="smooth"), speed=100.0)
def loss(clearance):
    changed = eqx.tree_at(lambda m: m.bearing.clearance, model, clearance)
    return jb.metrics.rms_bearing_force(jb.simulate(changed, 0.005))
gradient = float(jax.grad(loss)(40e-6))
value, tangent = jb.sensitivity(model, jb.metrics.rms_bearing_force, ["bearing.clearance"], 0.005)
try:
    jb.sensitivity(model, jb.metrics.rms_bearing_force, ["bearing.clearance"], 0.005, max_steps=5)
    counts["raised"] = None
except jb.SimulationError as err:
    counts["raised"] = str(err)
counts["gradients"] = [gradient, float(tangent["bearing.clearance"])]
print(json.dumps(counts))
"""


@pytest.mark.slow  # 50 s: reverse and forward mode compiled in a fresh process, then loaded in another
def test_a_second_process_compiles_nothing_for_the_same_derivatives(tmp_path, own_cache_env):
    """A user's `jax.grad` through `simulate` and `jb.sensitivity`'s derivative hold no host
    callback (a failure comes back as the solve's result code, raised after the call): with
    the cache jaxbearing turns on, a second process running the same code loads every program
    it needs, the derivatives and the small programs around them, and compiles none; a failure
    still raises the simulation's own error."""
    env = own_cache_env(XDG_CACHE_HOME=str(tmp_path))

    def run():
        done = subprocess.run([sys.executable, "-c", _SECOND_PROCESS], env=env, capture_output=True, text=True)
        assert done.returncode == 0, done.stderr[-3000:]
        return json.loads(done.stdout.strip().splitlines()[-1])

    first, second = run(), run()
    assert first["compiles"] > first["cache_hits"], first
    assert second["compiles"] == second["cache_hits"] > 0, second  # every program from the cache
    assert second["gradients"] == first["gradients"]  # one compiled program, the same inputs
    assert second["raised"].startswith("The simulation stopped at t = "), second


_SOLVE_TWICE = _COUNTING + """
sol = jb.simulate(jb.cases.rotor(jb.cases.skf98205()), 0.01, jax.numpy.linspace(0.0, 0.01, 5))
cached = sorted(p.name.split("-")[0] for p in __import__("pathlib").Path(jax.config.jax_compilation_cache_dir).iterdir())
print(json.dumps({**counts, "q": sol.q.tolist(), "cached": cached}))
"""


@pytest.mark.slow  # 11 s: two fresh processes (issue 75: the suite's time)
def test_a_second_process_compiles_nothing_for_the_same_solve(tmp_path, own_cache_env):
    """The compiled solve holds no host callback (checks and failures come back as result
    codes; JAX's cache refuses a program with a callback): the first process writes it to the
    cache that importing jaxbearing turns on, and the next process, tracing it again, loads it
    and every small program around it, and compiles none. One compiled program with the same
    inputs: the positions agree to rounding (loaded, not recompiled)."""
    env = own_cache_env(XDG_CACHE_HOME=str(tmp_path))

    def run():
        done = subprocess.run([sys.executable, "-c", _SOLVE_TWICE], env=env, capture_output=True, text=True)
        assert done.returncode == 0, done.stderr[-3000:]
        return json.loads(done.stdout.strip().splitlines()[-1])

    first = run()
    assert first["compiles"] > first["cache_hits"] and "jit__simulate" in first["cached"], first
    second = run()
    assert second["compiles"] == second["cache_hits"] > 0, second  # every program from the cache
    np.testing.assert_allclose(second["q"], first["q"], rtol=1e-13, atol=0)


_BUILT = """
import json
import jax
jax.config.update("jax_enable_x64", True)
import jaxbearing as jb
names = []
jax.monitoring.register_event_duration_secs_listener(lambda e, d, **kw: names.append(kw.get("fun_name")))
model = jb.cases.xu2014()
body = jb.multibody.Body(mass=2.0, inertia=0.01)
bearing = jb.BallBearing(clearance=40e-6, stiffness=9.6e9, damping=300.0, inner_race_diameter=0.0292, outer_race_diameter=0.0466, n_balls=8)
print(json.dumps(sorted({n for n in names if n})))
"""


def test_building_and_checking_a_model_compiles_nothing():
    """A model's rules are checked, and its stiffnesses computed (`hertz.bearing_stiffness`,
    `hertz.impact_stiffness`), where its values are known, in NumPy: in a fresh process,
    building the paper's case, a body and a bearing traces and compiles nothing, no program per
    comparison of a check nor per Hertz law."""
    done = subprocess.run([sys.executable, "-c", _BUILT], capture_output=True, text=True)
    assert done.returncode == 0, done.stderr[-3000:]
    names = json.loads(done.stdout.strip().splitlines()[-1])  # traced "f", compiled "jit(f)"
    assert names == [], names


_NOTEBOOK = """
import json
import jax
jax.config.update("jax_enable_x64", True)
import numpy as np
import jaxbearing as jb
programs, steps = [], {}
def count(event, duration, **kwargs):
    if event == "/jax/core/compile/backend_compile_duration":  # one program compiled
        programs.append(kwargs.get("fun_name"))
jax.monitoring.register_event_duration_secs_listener(count)
def step(label, f):
    start = len(programs)
    value = f()
    steps[label] = programs[start:]
    return value
step("xu2014", jb.cases.xu2014)
step("four_bar", jb.cases.four_bar)
rotor = step("rotor", lambda: jb.cases.rotor(jb.cases.skf98205(), speed=100.0))
ts = np.linspace(0.0, 0.002, 5)
for label in ("simulate", "simulate again"):
    step(label, lambda: jb.simulate(rotor, 0.002, ts).q.block_until_ready())
sol = jb.simulate(rotor, 0.002, ts)
results = {
    "peak_ball_load": lambda: jb.metrics.peak_ball_load(sol),
    "rms_bearing_force": lambda: jb.metrics.rms_bearing_force(sol),
    "smooth_peak_ball_load": lambda: jb.metrics.smooth_peak_ball_load(sol),
    "peak_time": lambda: jb.metrics.peak_time(sol, jb.metrics.peak_ball_load),
    "loads_at_peak": lambda: jb.metrics.loads_at_peak(sol),
    "peak_ball": lambda: jb.metrics.peak_ball(sol),
    "l10_hours": lambda: jb.life.l10_hours(sol, rotor),
    "lp_life": lambda: jb.life.lp_life(sol, rotor),
    "static_safety": lambda: jb.life.static_safety(sol, rotor),
    "ratings": lambda: (jb.life.dynamic_rating(rotor.bearing), jb.life.static_rating(rotor.bearing)),
    "reference_life": lambda: jb.life.reference_life(sol, rotor),
    "static_reference_life": lambda: jb.life.reference_life(rotor.bearing, [300.0, -400.0]),
}
for label, result in results.items():
    for again in ("", " again"):
        step(label + again, lambda: jax.block_until_ready(result()))
print(json.dumps(steps))
"""
# the one program each metric or life of `_NOTEBOOK` compiles on its first call (its window's
# checks run in NumPy; the ratings of a concrete bearing are NumPy, no program)
_RESULT_PROGRAMS = {
    "peak_ball_load": ["_peak_of"],
    "rms_bearing_force": ["_power_mean_of"],
    "smooth_peak_ball_load": ["_power_mean_of"],
    "peak_time": ["_peak_time_of"],
    "loads_at_peak": ["_at_peak_of"],
    "peak_ball": ["_peak_index_of"],
    "l10_hours": ["_iso_life"],
    "lp_life": ["_lp_life"],
    "static_safety": ["_static_safety"],
    "ratings": [],
    "reference_life": ["_reference_life"],
    "static_reference_life": [],  # the load distribution and the life of a known bearing: NumPy
}
# the one-operation programs a first `simulate` still compiles, outside jaxbearing's solve: diffrax's
# Runge-Kutta step compares its constant result code while the solve's first state is traced
# (`_core.initial_state`'s `eqx.filter_eval_shape` of the step), and `solution.raise_on_failure`
# compares the run's result code
_FIRST_RUN_EAGER = {"convert_element_type", "bitwise_or", "not_equal", "equal"}


@pytest.mark.slow  # 9 s: a notebook kernel compiling the paper's case (issue 75: the suite's time)
def test_a_notebook_compiles_one_program_per_result_and_nothing_twice():
    """The path a notebook walks, in a fresh process: building the paper's case compiles nothing
    (its stiffness laws are NumPy), the four-bar its assembly's constraints and Jacobians (one
    small program without loops: the assembly's steps are NumPy), the rotor nothing, none of
    them an eager operation on a known value (NumPy checks and conversions); the rotor's first
    `simulate` compiles the solve, the program that cuts its outputs to the times asked for, and
    at most the 4 one-operation programs of `_FIRST_RUN_EAGER` (none of `simulate`'s argument
    checks); the same call again compiles nothing. Then each metric and life of the run
    compiles its one program (`_RESULT_PROGRAMS`: the window's checks in NumPy, the value in one
    jitted call), and nothing the second time."""
    env = {**os.environ, "JAXBEARING_NO_COMPILATION_CACHE": "1"}
    done = subprocess.run([sys.executable, "-c", _NOTEBOOK], env=env, capture_output=True, text=True)
    assert done.returncode == 0, done.stderr[-3000:]
    steps = json.loads(done.stdout.strip().splitlines()[-1])
    names = {k: [n.removeprefix("jit(").removesuffix(")") for n in v] for k, v in steps.items()}
    assert names["xu2014"] == [], steps
    assert names["four_bar"] == ["linearized"], steps
    assert names["rotor"] == [], steps
    first = set(names["simulate"])
    assert len(names["simulate"]) == len(first) <= 6, steps  # each program once
    assert {"_simulate", "first_rows"} <= first <= {"_simulate", "first_rows"} | _FIRST_RUN_EAGER, steps
    assert names["simulate again"] == [], steps
    for label, programs in _RESULT_PROGRAMS.items():
        assert names[label] == programs, (label, steps)
        assert names[label + " again"] == [], (label, steps)


def test_no_private_apis_or_compiler_tricks_in_the_package():
    """Plain, public JAX: no `jax._src`, no private diffrax names, no ctypes, no platform-dependent
    branches or library calls that steer XLA's passes."""
    banned = re.compile(r"jax\._src|diffrax\._|ctypes|platform_dependent|cholesky|mallopt")
    found = [
        f"{path.relative_to(PACKAGE)}:{i}: {line.strip()}"
        for path in PACKAGE.rglob("*.py")
        for i, line in enumerate(path.read_text().splitlines(), 1)
        if banned.search(line)
    ]
    assert not found, found


_CACHE_DIR = """
import json, sys
from pathlib import Path
import jax
jax.config.update("jax_enable_x64", True)
if "own-threshold" in sys.argv:
    jax.config.update("jax_persistent_cache_min_compile_time_secs", 5.0)
import jaxbearing
if "build" in sys.argv:
    jaxbearing.cases.four_bar()  # compiles its assembly's constraints, in well under a second
if "more" in sys.argv:
    jax.jit(lambda x: 3.0 * x + 1.0)(1.0)  # a program no other call compiles
folder = jax.config.jax_compilation_cache_dir
stored = sorted(p.name.split("-")[0] for p in Path(folder).iterdir()) if folder and Path(folder).is_dir() else []
config = jax.config
print(json.dumps([folder, config.jax_persistent_cache_min_compile_time_secs, stored, config.jax_compilation_cache_max_size]))
"""


@pytest.mark.slow  # 13 s: seven fresh processes (issue 75: the suite's time)
def test_the_persistent_cache_is_on_by_default_with_an_opt_out(tmp_path, own_cache_env):
    """Importing jaxbearing turns JAX's persistent compilation cache on under XDG_CACHE_HOME,
    keeping every program however quickly it compiled (the four-bar's assembly constraints,
    compiled in a fraction of a second, are stored), bounded in size (JAX then needs
    `filelock`, else it stores nothing), unless the process chose a folder, a threshold or a
    size itself or opts out."""

    def cache(*args, **env):
        done = subprocess.run(
            [sys.executable, "-c", _CACHE_DIR, *args], env=own_cache_env(**env), capture_output=True, text=True
        )
        assert done.returncode == 0, done.stderr[-3000:]
        assert "Error writing persistent compilation cache" not in done.stderr, done.stderr[-3000:]
        return json.loads(done.stdout.strip().splitlines()[-1])

    folder, threshold, stored, size = cache("build", XDG_CACHE_HOME=str(tmp_path))
    assert (folder, threshold, size) == (str(tmp_path / "jaxbearing" / "jax-lru"), 0.0, _process.CACHE_MAX_SIZE)
    assert "jit_linearized" in stored, stored
    assert cache(XDG_CACHE_HOME=str(tmp_path), JAX_PERSISTENT_CACHE_MIN_COMPILE_TIME_SECS="2")[1] == 2.0
    assert cache("own-threshold", XDG_CACHE_HOME=str(tmp_path))[1] == 5.0  # set before the import
    elsewhere = cache(XDG_CACHE_HOME=str(tmp_path), JAX_COMPILATION_CACHE_DIR="/elsewhere")
    assert elsewhere == ["/elsewhere", 1.0, [], -1]
    # an unbounded cache writes entries without an access time, which would fail every write of
    # a bounded cache in that folder (jax-ml/jax#39880): its own folder
    fresh = tmp_path / "fresh"
    unbounded = cache("build", XDG_CACHE_HOME=str(fresh), JAX_COMPILATION_CACHE_MAX_SIZE="-1")
    assert (unbounded[0], unbounded[3]) == (str(fresh / "jaxbearing" / "jax-unbounded"), -1)
    assert "jit_linearized" in unbounded[2], unbounded[2]
    assert "jit__lambda" in cache("build", "more", XDG_CACHE_HOME=str(fresh))[2]  # bounded: writes
    assert cache(XDG_CACHE_HOME=str(tmp_path), JAX_COMPILATION_CACHE_MAX_SIZE="1000000")[3] == 1_000_000
    assert cache(XDG_CACHE_HOME=str(tmp_path), **{_process.CACHE_OPT_OUT: "1"}) == [None, 1.0, [], -1]

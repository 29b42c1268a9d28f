"""`jaxbearing.jit`: compiler options at the top level, plain compilation when nested, CPU
options for the CPU only.

JAX refuses compiler options on a jit inside another transformation ("can only be passed to
top-level jax.jit"), and GPU builds refuse XLA:CPU's options ("No such compile option");
`simulate` must keep working inside a user's jit, vmap and grad, and on every backend.
"""

import dataclasses
import json
import os
import subprocess
import sys

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import pytest

import jaxbearing as jb
from jaxbearing import compile as jbcompile


@jb.jit
def _energy(x, scale):
    return scale * jnp.sum(jnp.sin(x) ** 2)


def test_jit_works_at_top_level_and_inside_transformations():
    x = jnp.linspace(0.0, 1.0, 5)
    expected = 2.0 * np.sum(np.sin(np.asarray(x)) ** 2)
    np.testing.assert_allclose(_energy(x, 2.0), expected, rtol=1e-14)
    np.testing.assert_allclose(jax.jit(_energy)(x, 2.0), expected, rtol=1e-14)
    np.testing.assert_allclose(jax.vmap(_energy, (0, None))(jnp.stack([x, x]), 2.0), [expected] * 2, rtol=1e-14)
    np.testing.assert_allclose(jax.grad(_energy)(x, 2.0), 2.0 * np.sin(2.0 * np.asarray(x)), rtol=1e-13)


def test_simulate_inside_a_user_jit_equals_the_top_level_call():
    model = jb.cases.xu2014(impact=False)
    ts = jnp.linspace(0.0, 0.002, 3)
    top = jb.simulate(model, 0.002, ts, time_cells=1)
    nested = jax.jit(lambda m: jb.simulate(m, 0.002, ts, time_cells=1))(model)
    # other XLA options round differently, and the solver amplifies that up to its accuracy
    # (the benchmark finds positions within 1e-8 m of a 1000x tighter reference; measured
    # 7e-9 here, in the rod's angle while it falls onto the race)
    np.testing.assert_allclose(nested.q, top.q, rtol=0, atol=2e-8)


def test_tolerances_and_step_limit_compile_nothing_new(compiled_functions):
    """rtol, atol and max_steps are values of the compiled solve: another value runs the solve
    of the test above (the same module's worker, tests/conftest.py) without compiling it again,
    and tighter tolerances take more steps."""
    model = jb.cases.xu2014(impact=False)
    ts = jnp.linspace(0.0, 0.002, 3)
    loose = jb.simulate(model, 0.002, ts, time_cells=1)
    with compiled_functions() as compiles:
        tight = jb.simulate(model, 0.002, ts, time_cells=1, rtol=1e-10, atol=1e-12, max_steps=7_000)
    assert "jit(_simulate)" not in compiles
    assert int(tight.num_steps) > int(loose.num_steps)
    np.testing.assert_allclose(tight.q, loose.q, rtol=0, atol=2e-8)


def test_fewer_output_times_compile_nothing_new(compiled_functions):
    """Called at the top level, up to 2048 output times share one compiled solve, that of the
    tests above: outputs at the times two runs share are the same to the last bit, and every
    per-time field has one row per output time asked for."""
    model = jb.cases.xu2014(impact=False)
    ts = jnp.linspace(0.0, 0.002, 21)
    few = jb.simulate(model, 0.002, ts[::10], time_cells=1)
    with compiled_functions() as compiles:
        many = jb.simulate(model, 0.002, ts, time_cells=1)
    assert "jit(_simulate)" not in compiles
    per_time = [
        f.name for f in dataclasses.fields(many)
        if isinstance(getattr(many, f.name), jax.Array) and getattr(many, f.name).ndim >= 1
    ]
    assert {"ts", "q", "qdd", "ball_loads", "contact_force", "drift"} <= set(per_time)
    for name in per_time:
        assert getattr(many, name).shape[0] == 21, name
        np.testing.assert_array_equal(getattr(few, name), getattr(many, name)[::10], err_msg=name)


def test_cpu_options_go_to_the_cpu_only():
    assert jbcompile.compiler_options("cpu") == jbcompile.accepted_cpu_options()
    assert jbcompile.compiler_options("cpu")  # this jaxlib's XLA:CPU accepts at least one
    for platform in ("gpu", "cuda", "rocm", "tpu", "METAL"):
        assert jbcompile.compiler_options(platform) == {}


def test_the_ynnpack_option_keeps_small_reductions_out_of_ynnpack():
    """XLA:CPU of jax 0.10 hands a small reduction to a YNNPACK fusion by default; with
    `compiler_options` the compiled program holds none."""
    if "xla_cpu_experimental_ynn_fusion_type" not in jbcompile.accepted_cpu_options():
        pytest.skip("this XLA:CPU has no YNNPACK fusion option")
    x = jnp.ones((2048, 2))
    reduce = lambda x: jnp.sum(x * x, axis=1)
    plain = jax.jit(reduce).lower(x).compile().as_text()
    if "__ynn_fusion" not in plain:
        pytest.skip("this XLA:CPU does not hand the reduction to YNNPACK by default")
    ours = jax.jit(reduce, compiler_options=jbcompile.compiler_options("cpu")).lower(x).compile().as_text()
    assert "__ynn_fusion" not in ours


def test_cpu_options_are_dropped_where_the_cpu_compiler_refuses_them(monkeypatch):
    """jax 0.11's XLA:CPU no longer knows the fusion-emitter switch and refuses it: the probe
    must drop that option (here faked with one no XLA knows), keep the others, and `jit` must
    then still run."""
    jbcompile.accepted_cpu_options.cache_clear()
    unknown = {"xla_no_such_option_anywhere": True}
    monkeypatch.setattr(jbcompile, "CPU_COMPILER_OPTIONS", {**unknown, "xla_cpu_use_fusion_emitters": False})
    try:
        assert jbcompile.compiler_options("cpu") == {"xla_cpu_use_fusion_emitters": False}
        monkeypatch.setattr(jbcompile, "CPU_COMPILER_OPTIONS", unknown)
        jbcompile.accepted_cpu_options.cache_clear()
        assert jbcompile.compiler_options("cpu") == {}
        f = jb.jit(lambda x: 2.0 * x)
        np.testing.assert_allclose(f(jnp.ones(2)), 2.0)
    finally:
        jbcompile.accepted_cpu_options.cache_clear()


@pytest.mark.skipif(jax.default_backend() != "cpu", reason="reads the CPU as the default backend")
def test_target_platform_follows_committed_inputs_then_default_device_then_backend():
    x = jnp.ones(3)
    assert jbcompile.target_platform((x,)) == jax.default_backend() == "cpu"
    with jax.default_device("gpu"):  # only read, never used: this machine has no GPU
        assert jbcompile.target_platform((x,)) == "gpu"
        committed = jax.device_put(x, jax.devices("cpu")[0])
        assert jbcompile.target_platform(({"a": x, "b": committed},)) == "cpu"
    with jax.default_device(jax.devices("cpu")[0]):
        assert jbcompile.target_platform((x,)) == "cpu"


def test_jit_compiles_for_a_gpu_target_without_cpu_options(monkeypatch):
    """With a GPU as target, `jit` hands no compiler options to XLA (measured on the CPU, the
    only backend here: the platform is faked, the compile is real)."""
    passed = []
    filter_jit = eqx.filter_jit

    def spy(fun, **kwargs):
        passed.append(kwargs.get("compiler_options"))
        return filter_jit(fun, **kwargs)

    monkeypatch.setattr(jbcompile.eqx, "filter_jit", spy)
    monkeypatch.setattr(jbcompile, "target_platform", lambda args: "gpu")
    f = jb.jit(lambda x: jnp.sum(jnp.sin(x)))
    np.testing.assert_allclose(f(jnp.ones(2)), 2 * np.sin(1.0), rtol=1e-15)
    assert passed == [None, None]  # the nested and the top-level (gpu) compilation
    monkeypatch.setattr(jbcompile, "target_platform", lambda args: "cpu")
    f(jnp.ones(2))
    assert passed[-1] == (jbcompile.accepted_cpu_options() or None)


def test_loop_kernels_are_refused_once_the_backends_run(monkeypatch):
    """XLA reads XLA_FLAGS when JAX starts its backends (here they run): too late to add the flag,
    so nothing changes; a flag set before is reported in effect."""
    monkeypatch.setenv("XLA_FLAGS", "--xla_force_host_platform_device_count=1")
    assert not jb.enable_loop_kernels()
    assert os.environ["XLA_FLAGS"] == "--xla_force_host_platform_device_count=1"
    monkeypatch.setenv("XLA_FLAGS", jbcompile.LOOP_KERNELS_FLAG)
    assert jb.enable_loop_kernels()


def test_entry_elimination_follows_the_last_instruction_set_limit(monkeypatch):
    """`entry_elimination` (FMA off) follows the instruction-set limit that XLA reads: the last
    ``--xla_cpu_max_isa`` counts, and only sets without FMA turn it on; too late to set, like
    the loop kernels."""
    assert jbcompile.fma_off(jbcompile.NO_FMA_FLAG)
    assert jbcompile.fma_off("--xla_cpu_max_isa=sse4_2 --xla_force_host_platform_device_count=2")
    assert not jbcompile.fma_off("")
    assert not jbcompile.fma_off("--xla_cpu_max_isa=AVX2")
    assert not jbcompile.fma_off("--xla_cpu_max_isa=AVX --xla_cpu_max_isa=AVX512")
    monkeypatch.setenv("XLA_FLAGS", "--xla_force_host_platform_device_count=1")
    assert not jb.enable_entry_elimination()
    assert os.environ["XLA_FLAGS"] == "--xla_force_host_platform_device_count=1"
    assert not jbcompile.entry_elimination()  # this process: the suite runs with FMA


_FRESH = """
import json, sys
import jax, numpy as np
import jaxbearing as jb
enabled = jb.enable_loop_kernels() if sys.argv[1] == "on" else False
jax.config.update("jax_enable_x64", True)
loop = jax.jit(lambda x: jax.lax.fori_loop(0, 3, lambda i, v: jax.numpy.sin(v)[::-1], x))
whole = "xla_cpu_small_call" in loop.lower(jax.numpy.ones(300)).compile().as_text()
by_kernel = lambda i, v: jax.numpy.roll(jax.numpy.sin(v), jb.compile.kernel_by_kernel(i) + 1)
apart = jax.jit(lambda x: jax.lax.fori_loop(0, 3, by_kernel, x))
apart_whole = "xla_cpu_small_call" in apart.lower(jax.numpy.ones(300)).compile().as_text()
rolled = np.asarray(apart(jax.numpy.linspace(0.0, 1.0, 300))).tolist()
sol = jb.simulate(jb.cases.xu2014(impact=False), 0.002, np.linspace(0.0, 0.002, 3), time_cells=1)
print(json.dumps(dict(enabled=enabled, whole=whole, apart_whole=apart_whole, rolled=rolled,
                     q=np.asarray(sol.q).tolist())))
"""


def _fresh(mode):
    env = {k: v for k, v in os.environ.items() if k != "XLA_FLAGS"}
    done = subprocess.run([sys.executable, "-c", _FRESH, mode], env=env, capture_output=True, text=True)
    assert done.returncode == 0, done.stderr[-3000:]
    return json.loads(done.stdout.strip().splitlines()[-1])


def test_loop_kernels_compile_loops_whole_in_a_fresh_process():
    """Before the first computation the flag takes effect: XLA:CPU compiles the loop into one
    call (``xla_cpu_small_call``), but not one whose index passes through `kernel_by_kernel`;
    the simulation agrees with the plain one to the solver's accuracy (other kernels round
    differently, as in test_simulate_inside_a_user_jit_equals_the_top_level_call).
    """
    on, off = _fresh("on"), _fresh("off")
    assert on["enabled"] and on["whole"]
    assert not off["whole"]
    # a loop whose index passes through `kernel_by_kernel` runs kernel by kernel, unchanged
    assert not on["apart_whole"] and not off["apart_whole"]
    x = np.linspace(0.0, 1.0, 300)
    for i in range(3):
        x = np.roll(np.sin(x), i + 1)
    np.testing.assert_allclose(on["rolled"], x, rtol=1e-14)  # a few ulps of three sines
    assert on["rolled"] == off["rolled"]
    np.testing.assert_allclose(on["q"], off["q"], rtol=0, atol=2e-8)


_PAGES = """
import json, resource, sys
import jax
import numpy as np
import jaxbearing as jb
jax.config.update("jax_enable_x64", True)
on = jb.enable_memory_reuse() if sys.argv[1] == "on" else False
model, ts = jb.cases.xu2014(impact=False), np.linspace(0.0, 0.01, 100_001)
faults = []
for _ in range(6):  # each call's outputs (about 60 MB) freed before the next call
    before = resource.getrusage(resource.RUSAGE_SELF).ru_minflt
    jax.block_until_ready(jb.simulate(model, 0.01, ts))
    faults.append(resource.getrusage(resource.RUSAGE_SELF).ru_minflt - before)
print(json.dumps({"on": on, "faults": faults}))
"""


@pytest.mark.slow
def test_memory_reuse_keeps_freed_memory_for_the_next_call():
    """`enable_memory_reuse` on glibc (this machine's C library): a simulation with 100 001
    output times, called again and again, takes its buffers from the memory the previous call
    freed, without page faults from the third call on (measured: at most 27); without it the
    calls fault on their fresh buffers (measured: 12 600 to 15 500 faults a call), though not
    every one: glibc raises its mmap threshold as it frees mapped blocks, and one run of the
    suite saw one of the four later calls reuse its heap (1 fault). So the control asks most of
    them to fault."""
    runs = {}
    for mode in ("on", "off"):
        done = subprocess.run([sys.executable, "-c", _PAGES, mode], capture_output=True, text=True)
        assert done.returncode == 0, done.stderr[-3000:]
        runs[mode] = json.loads(done.stdout.strip().splitlines()[-1])
    assert runs["on"]["on"]
    assert max(runs["on"]["faults"][2:]) < 500
    assert sorted(runs["off"]["faults"][2:])[1] > 5_000  # three of the four

"""How jaxbearing compiles: `jit`, `eqx.filter_jit` with the XLA options measured best here.

Two XLA:CPU options, each measured on the paper's case (README and benchmarks/results.json give
the figures; benchmarks/run.py measures them):
- ``xla_cpu_use_fusion_emitters`` off: XLA:CPU's newer fusion emitters (on by default in jax
  0.10) compile the paper's case markedly slower and run it no faster;
- ``xla_cpu_experimental_ynn_fusion_type`` empty: no YNNPACK fusions. XLA:CPU hands small
  reductions and matrix products (sums over 2 to 9 numbers, the 9 x 12 products of the
  constraint solve) to YNNPACK, whose fixed cost per call exceeds their arithmetic many times;
  without them a run and the batched evaluation of its outputs are faster.
Both exist on XLA:CPU only, and only in some releases: GPU builds of JAX refuse them ("No such
compile option"), and the CPU compiler of jax 0.11 refuses the first. `jit` passes them only
when it compiles for the CPU (`compiler_options`, `target_platform`), and of those only the
ones that CPU compiler accepts (`accepted_cpu_options`, each asked once a process); none
elsewhere.

`sweep` keeps XLA's defaults: with them a vmapped member's solution equals, to the last bit,
that of the same point run alone under `jax.jit` (tests/test_pauses.py); without the fusion emitters batched and
single kernels round differently (README), and batches ran no faster.

One more setting makes a simulation much cheaper on the CPU (README, *Performance and solvers*),
and `jit` cannot pass it: XLA:CPU runs a program as a sequence of kernel calls, each with a fixed
cost, except the while loops that its small-while-loop pass compiles whole, into one function;
by default only loops that touch less than about a kilobyte (by XLA's cost analysis) qualify.
`enable_loop_kernels` raises that limit (`LOOP_KERNELS_FLAG`), so that the solver's loops run as
single functions. It is an entry of XLA's ``xla_backend_extra_options``, a map that compile
options cannot carry, so it goes through the ``XLA_FLAGS`` environment variable, which XLA reads
once, when JAX starts its backends: call it before the first computation (the ``jaxbearing``
command, the studies and the benchmark do). Other backends ignore it (XLA hands no ``xla_``
entry of that map to LLVM). Loops that call library routines (the LU factorisation of
Kvaerno5's Newton iteration) stay as they are, and so does the loop that evaluates the output
times after the solve (`kernel_by_kernel`): its kernels are large (a batch of output times each),
and run kernel by kernel XLA:CPU splits each over the cores, which a loop compiled whole does not.

A second setting of that kind, `enable_entry_elimination`, limits XLA:CPU to the AVX
instruction set (`NO_FMA_FLAG`), which has no fused multiply–add: a product is then rounded
before it is added wherever XLA computes it. It no longer makes a run faster (README gives the
figures: slower, since the solver evaluates each cos and sin once with FMA on as well, with
loops compiled whole, `jaxbearing._forms`); it is kept for a process that wants XLA:CPU
without FMA, e.g. to compare results between CPUs with and without it. It is named for what it
first switched on as well: the elimination of Eq. 36 entry by entry, which the solver uses in
every process, and later the cheaper cos and sin. It too goes through ``XLA_FLAGS`` and affects
every XLA:CPU computation of the process; other backends ignore the flag.

A third setting of the process concerns its memory, not XLA: XLA:CPU allocates the buffers of
each call afresh, and glibc's malloc hands blocks above its mmap threshold (at most 32 MB) to
the system when they are freed, so a simulation with many output times (whose buffers exceed
that threshold) takes a page fault for every page of them on every call (README gives the sizes
and the cost).
`enable_memory_reuse` raises glibc's thresholds (``mallopt``), so that freed memory stays in the
process for the next call; its resident memory then stays at its largest so far. It can be
called at any time (it applies to the allocations after it), and does nothing where the C
library is not glibc.

JAX accepts compiler options on the outermost jit only. `jit` therefore applies them when called
outside any transformation (`simulate`, `sensitivity`, `tune` and life's ring loads called from
Python) and compiles plainly when called inside one (your own `jax.jit`, `jax.vmap`,
`jax.grad`): wrap your own functions around `simulate` in `jaxbearing.jit` to keep the options.
"""

from __future__ import annotations

import ctypes
import ctypes.util
import functools
import os

import equinox as eqx
import jax
import jax.numpy as jnp

try:  # True outside every transformation; private, so without it the options are not applied
    from jax._src.core import trace_state_clean
except ImportError:  # pragma: no cover
    def trace_state_clean() -> bool:
        return False

try:  # whether JAX has started its backends (and XLA read XLA_FLAGS); private
    from jax._src.xla_bridge import backends_are_initialized
except ImportError:  # pragma: no cover
    def backends_are_initialized() -> bool:
        return True

LOOP_KERNELS_FLAG = "--xla_backend_extra_options=xla_cpu_small_while_loop_byte_threshold=1000000000"
NO_FMA_FLAG = "--xla_cpu_max_isa=AVX"
NO_FMA_ISAS = ("SSE4_2", "AVX")  # values of xla_cpu_max_isa whose instruction sets lack FMA

MALLOC_KEEP = 1 << 30  # [bytes] glibc's mmap and trim thresholds under `enable_memory_reuse`
_M_TRIM_THRESHOLD, _M_MMAP_THRESHOLD = -1, -3  # mallopt's parameters (glibc's malloc.h)

CPU_COMPILER_OPTIONS = {
    "xla_cpu_use_fusion_emitters": False,
    "xla_cpu_experimental_ynn_fusion_type": "",
}


def compiler_options(platform: str) -> dict:
    """The XLA options for a platform (``"cpu"``, ``"gpu"``, ``"cuda"``, ``"tpu"``, ...): those
    of `CPU_COMPILER_OPTIONS` that this CPU compiler accepts on a CPU, none elsewhere."""
    return dict(accepted_cpu_options()) if platform == "cpu" else {}


@functools.cache
def accepted_cpu_options() -> dict:
    """The options of `CPU_COMPILER_OPTIONS` that this jaxlib's XLA:CPU accepts (one tiny
    compile per option, once a process)."""
    x = jax.device_put(0.0, jax.devices("cpu")[0])
    accepted = {}
    for name, value in CPU_COMPILER_OPTIONS.items():
        try:
            jax.jit(lambda v: v + 1, compiler_options={name: value})(x)
        except jax.errors.JaxRuntimeError as error:
            if "No such compile option" in str(error):
                continue
            raise
        accepted[name] = value
    return accepted


def enable_loop_kernels() -> bool:
    """Let XLA:CPU compile each while loop that touches less than 1 GB into one function
    (module docstring): appends `LOOP_KERNELS_FLAG` to ``XLA_FLAGS``. Returns whether the
    setting is in effect: True when ``XLA_FLAGS`` already held it or JAX has not started its
    backends yet; False, changing nothing, once they run without it (then set ``XLA_FLAGS``
    before starting Python). Results agree with and without it to the solver's tolerance, not
    to the last bit."""
    return _append_flag(LOOP_KERNELS_FLAG)


def enable_entry_elimination() -> bool:
    """Turn XLA:CPU's fused multiply–adds off for the process (`NO_FMA_FLAG`; module docstring:
    no longer faster). Returns whether the setting is in effect, like `enable_loop_kernels`;
    call it before the first computation. Results agree with and without it to the solver's
    tolerance, not to the last bit."""
    return _append_flag(NO_FMA_FLAG) and entry_elimination()


def enable_memory_reuse() -> bool:
    """Let glibc's malloc keep freed memory for the next allocation instead of returning it to
    the system (module docstring): its mmap and trim thresholds set to `MALLOC_KEEP`. Returns
    whether the setting is in effect: False, changing nothing, where the C library is not glibc.
    Results do not change."""
    libc = _glibc()
    if libc is None:
        return False
    return bool(libc.mallopt(_M_MMAP_THRESHOLD, MALLOC_KEEP)) and bool(
        libc.mallopt(_M_TRIM_THRESHOLD, MALLOC_KEEP)
    )


def _glibc():
    """The C library through ctypes where it is glibc (it has ``mallopt`` and
    ``gnu_get_libc_version``), else None."""
    name = ctypes.util.find_library("c")
    try:
        libc = ctypes.CDLL(name)
    except OSError:  # pragma: no cover
        return None
    if not (hasattr(libc, "mallopt") and hasattr(libc, "gnu_get_libc_version")):
        return None
    libc.mallopt.argtypes = (ctypes.c_int, ctypes.c_int)
    return libc


def kernel_by_kernel(index):
    """The integer loop index ``index`` unchanged, through a library call (the Cholesky factor
    of a 1 x 1 matrix, exactly 1), so that XLA:CPU does not compile the loop that uses it into
    one function under `enable_loop_kernels` (its pass leaves loops with library calls as they
    are). The loop's body then runs kernel by kernel, and XLA:CPU splits each large kernel over
    the cores: for loops over large batches (the outputs' evaluation), not for the solver's
    loops, whose many small kernels are what that pass saves. Costs one library call a
    trip."""
    matrix = jnp.ones((1, 1)) + 0.0 * index  # depends on the trip, so it stays in the loop
    one = jax.lax.linalg.cholesky(matrix, symmetrize_input=False)[0, 0]
    return index + (one - 1.0).astype(jnp.asarray(index).dtype)


@functools.cache
def loop_kernels() -> bool:
    """Whether ``XLA_FLAGS`` holds `LOOP_KERNELS_FLAG` (`enable_loop_kernels`), read once a
    process, at the first call (after JAX has read ``XLA_FLAGS``)."""
    return LOOP_KERNELS_FLAG in os.environ.get("XLA_FLAGS", "").split()


@functools.cache
def entry_elimination() -> bool:
    """Whether `enable_entry_elimination` is in effect: whether ``XLA_FLAGS`` limits XLA:CPU to
    an instruction set without FMA (`NO_FMA_ISAS`), read once a process, at the first call
    (after JAX has read ``XLA_FLAGS``)."""
    return fma_off(os.environ.get("XLA_FLAGS", ""))


def fma_off(flags: str) -> bool:
    """Whether the XLA flags ``flags`` limit XLA:CPU to an instruction set without FMA (the
    last ``--xla_cpu_max_isa`` counts, as in XLA)."""
    isa = [f.split("=", 1)[1] for f in flags.split() if f.startswith("--xla_cpu_max_isa=")]
    return bool(isa) and isa[-1].upper() in NO_FMA_ISAS


def _append_flag(flag: str) -> bool:
    """Append ``flag`` to ``XLA_FLAGS`` unless there; False where JAX's backends already run
    without it (XLA has read the variable), True otherwise."""
    flags = os.environ.get("XLA_FLAGS", "")
    if flag in flags.split():
        return True
    if backends_are_initialized():
        return False
    os.environ["XLA_FLAGS"] = f"{flags} {flag}".strip()
    return True


def target_platform(args) -> str:
    """The platform a call with inputs ``args`` (a pytree) compiles for: that of its first
    input committed to a device (`jax.device_put`), else that of `jax.default_device`, else
    JAX's default backend."""
    for leaf in jax.tree_util.tree_leaves(args):
        if isinstance(leaf, jax.Array) and not isinstance(leaf, jax.core.Tracer) and leaf.committed:
            return next(iter(leaf.devices())).platform
    default = jax.config.jax_default_device
    if default is not None:
        return default if isinstance(default, str) else default.platform
    return jax.default_backend()


def jit(fun=None, **jitkwargs):
    """`eqx.filter_jit` with `compiler_options` of the target platform at the top level (usable
    as ``@jit`` or ``jit(f, donate=...)``)."""
    if fun is None:
        return lambda f: jit(f, **jitkwargs)
    compiled = {}  # platform -> filter_jit with that platform's options
    nested = eqx.filter_jit(fun, **jitkwargs)

    @functools.wraps(fun)
    def call(*args, **kwargs):
        if not trace_state_clean():
            return nested(*args, **kwargs)
        platform = target_platform((args, kwargs))
        if platform not in compiled:
            compiled[platform] = eqx.filter_jit(
                fun, compiler_options=compiler_options(platform) or None, **jitkwargs
            )
        return compiled[platform](*args, **kwargs)

    return call

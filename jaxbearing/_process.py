"""The two process-wide settings jaxbearing makes on import, each with its opt-out.

1. XLA:CPU compiles the solver's loops whole. XLA:CPU runs a program as a sequence of kernel
   calls, each with a fixed cost, except the while loops that its small-while-loop pass compiles
   into one function; by default only loops that touch less than about a kilobyte qualify. The
   solver's step loop, thousands of iterations of a few hundred scalar operations, is far above
   that limit, and run kernel by kernel it spends most of its time calling kernels. Importing
   jaxbearing raises the limit (`LOOP_KERNELS_FLAG`), which makes the paper's case several times
   faster on a CPU (docs/performance.md gives the figure and the command that measures it);
   results agree with and without it to the solver's tolerance. The limit is an entry of XLA's
   ``xla_backend_extra_options``, which XLA reads from the ``XLA_FLAGS`` environment variable
   once, when JAX starts its backends (at the first computation): it is added when jaxbearing
   is imported before the process's first JAX computation (``import jax;
   jax.config.update(...)`` before it is fine: that starts no backend), and not at all when
   imported later, where it could change nothing (`backends_started`); results are the same,
   only slower. Being in the environment, it is inherited by the processes this one starts.
   Other backends ignore it. A ``XLA_FLAGS`` that already sets ``xla_backend_extra_options``
   is left as it is. Opt-out: ``JAXBEARING_KEEP_XLA_FLAGS=1``.

2. JAX's persistent compilation cache, in `cache_dir` (``$XDG_CACHE_HOME/jaxbearing/jax-lru``,
   by default ``~/.cache/jaxbearing/jax-lru``): a process that meets a solve compiled before on this
   machine loads it instead of compiling it again (the compiled solve holds no host callback,
   which the cache would refuse). The cache keeps every program, however quickly it compiled
   (``jax_persistent_cache_min_compile_time_secs`` 0 unless the process set a threshold itself:
   by ``JAX_PERSISTENT_CACHE_MIN_COMPILE_TIME_SECS``, or by ``jax.config.update`` before the
   import to a value other than JAX's default, `JAX_MIN_COMPILE_TIME`, which keeps only the
   programs that took a second or more): the main job's summaries and the other small
   programs a run meets would otherwise compile again in every process, a good part of a
   second run's time. The cache is bounded (``jax_compilation_cache_max_size`` `CACHE_MAX_SIZE`, unless the
   process set a size itself, by ``jax.config.update`` or ``JAX_COMPILATION_CACHE_MAX_SIZE``):
   beyond it JAX deletes the least recently used programs, which needs the ``filelock``
   package (a dependency of jaxbearing; without it JAX warns and caches nothing). Only where
   the process has not chosen a cache folder itself (``jax_compilation_cache_dir``,
   ``JAX_COMPILATION_CACHE_DIR``): a cache of the user's keeps the user's settings. Opt-out:
   ``JAXBEARING_NO_COMPILATION_CACHE=1``; an unbounded cache: ``JAX_COMPILATION_CACHE_MAX_SIZE=-1``,
   which writes into a folder of its own (`cache_dir`): an entry written unbounded has no access
   time, and a bounded cache that meets one fails every later write (jax-ml/jax#39880).
"""

from __future__ import annotations

import os
from pathlib import Path

import jax

LOOP_KERNELS_FLAG = "--xla_backend_extra_options=xla_cpu_small_while_loop_byte_threshold=1000000000"
OPT_OUT = "JAXBEARING_KEEP_XLA_FLAGS"
CACHE_OPT_OUT = "JAXBEARING_NO_COMPILATION_CACHE"
CACHE_MAX_SIZE = 2 * 1024**3  # [bytes] the cache's bound (the paper's solve takes about 0.6 MB)
JAX_MIN_COMPILE_TIME = 1.0  # [s] JAX's default jax_persistent_cache_min_compile_time_secs
# a public option JAX refuses to change once its backends run (`backends_started`)
_PROBE = "jax_cpu_get_local_topology_timeout_minutes"


def _true(name: str) -> bool:
    return os.environ.get(name, "").strip().lower() in ("1", "true", "yes", "on")


def apply_loop_kernels() -> bool:
    """Append `LOOP_KERNELS_FLAG` to ``XLA_FLAGS`` (setting 1 of the module docstring); whether
    it is there now."""
    flags = os.environ.get("XLA_FLAGS", "")
    if LOOP_KERNELS_FLAG in flags.split():
        return True
    if _true(OPT_OUT) or "--xla_backend_extra_options=" in flags or backends_started():
        return False
    os.environ["XLA_FLAGS"] = f"{flags} {LOOP_KERNELS_FLAG}".strip()
    return True


def backends_started() -> bool:
    """Whether JAX has started its backends (the process's first computation), after which
    ``XLA_FLAGS`` is read no more. JAX has no function that says so (jax-ml/jax#23320), but it
    refuses to change `_PROBE` (a timeout of multi-process CPU runs) once they run: the probe sets
    it to another value and back."""
    value = getattr(jax.config, _PROBE)
    try:
        jax.config.update(_PROBE, value + 1)
    except RuntimeError:
        return True
    jax.config.update(_PROBE, value)
    return False


def cache_dir(bounded: bool = True) -> Path:
    """The folder of jaxbearing's persistent compilation cache: ``$XDG_CACHE_HOME/jaxbearing/jax-lru``
    (``~/.cache/jaxbearing/jax-lru`` where XDG_CACHE_HOME is unset); ``jax-unbounded`` beside it
    for an unbounded cache (``bounded=False``). The two are never one folder, nor the ``jax``
    folder, which jaxbearing's unbounded cache wrote before: a bounded cache reads each entry's
    access time at every write, and an entry written unbounded has none, which fails every
    write (jax-ml/jax#39880)."""
    base = os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache"
    return Path(base) / "jaxbearing" / ("jax-lru" if bounded else "jax-unbounded")


def apply_compilation_cache() -> Path | None:
    """Turn JAX's persistent compilation cache on in `cache_dir` (setting 2 of the module
    docstring); the folder in use, or None where the opt-out is set."""
    if _true(CACHE_OPT_OUT):
        return None
    chosen = jax.config.jax_compilation_cache_dir or os.environ.get("JAX_COMPILATION_CACHE_DIR")
    if chosen:
        return Path(chosen)
    threshold = jax.config.jax_persistent_cache_min_compile_time_secs
    if threshold == JAX_MIN_COMPILE_TIME and "JAX_PERSISTENT_CACHE_MIN_COMPILE_TIME_SECS" not in os.environ:
        jax.config.update("jax_persistent_cache_min_compile_time_secs", 0.0)
    unbounded = jax.config.jax_compilation_cache_max_size == -1  # JAX's default
    if unbounded and "JAX_COMPILATION_CACHE_MAX_SIZE" not in os.environ:
        jax.config.update("jax_compilation_cache_max_size", CACHE_MAX_SIZE)
    folder = cache_dir(bounded=jax.config.jax_compilation_cache_max_size != -1)
    jax.config.update("jax_compilation_cache_dir", str(folder))
    return folder

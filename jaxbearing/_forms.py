"""Two forms of cos and sin, each computed once per angle and evaluation: one for the solver, one
for the batched evaluation of the outputs and the one loop; and d^1.5.

XLA:CPU fuses an elementwise producer into every kernel that consumes it unless that would read
more memory, so cos and sin of each body angle, read by many kernels of a right-hand side, would
be computed again in each (`docs/performance.md` counts them). Two ways keep them to one
evaluation per angle:

- within `output_forms`, `cos_sin` passes its values through an exact reduction, (x + x) / 2 as
  a sum over two copies (a reduction is never repeated). `simulate` evaluates its output times
  so, and `simulate_one_loop` its right-hand side. With XLA:CPU's fused multiply–adds on, the
  kernels that XLA builds around the reduction round in the last bit differently in a single
  run and in a batch, so the solver, whose sweep members must equal their single runs bit for
  bit (tests/test_sweep.py), does not use it;
- otherwise (the solver's evaluations, the steps' records, the events), on a CPU with its loops
  compiled whole (`jaxbearing.compile.enable_loop_kernels`; not under `held_forms(False)`, which
  `simulate` sets for an implicit solver, whose loops call LAPACK and stay kernel by kernel),
  `cos_sin` returns them through a
  `jax.lax.cond` whose predicate (any of the angles finite, across a vmapped batch) holds
  wherever cos and sin are numbers: their readers read the conditional's results, so XLA
  computes cos and sin once, for the conditional, and cannot repeat them in the readers'
  kernels, which otherwise stay as they were; the results are those of the plain form to the
  last bit, and single runs and batches round alike. Elsewhere they are plain: with loops run
  kernel by kernel each conditional is a call of its own, which cost more than it saved, and on
  other platforms (`jax.lax.platform_dependent`) a conditional waits for the host.

`power` writes d^1.5 (the Hertzian exponent of Eqs. 9 and 23) as d sqrt(d) everywhere: XLA
evaluates a general power as an exponential and a logarithm.
"""

from __future__ import annotations

import contextlib
import contextvars

import equinox.internal as eqxi
import jax
import jax.numpy as jnp

from .compile import loop_kernels

_OUTPUTS = contextvars.ContextVar("jaxbearing_output_forms", default=False)
_HELD = contextvars.ContextVar("jaxbearing_held_forms", default=True)


@contextlib.contextmanager
def output_forms():
    """Trace `cos_sin` in its form for the outputs (module docstring)."""
    token = _OUTPUTS.set(True)
    try:
        yield
    finally:
        _OUTPUTS.reset(token)


@contextlib.contextmanager
def held_forms(allowed: bool):
    """Trace `cos_sin` outside `output_forms` through the conditional where ``allowed`` and
    `compile.loop_kernels`, else plainly (module docstring)."""
    token = _HELD.set(bool(allowed))
    try:
        yield
    finally:
        _HELD.reset(token)


def cos_sin(angle) -> tuple[jax.Array, jax.Array]:
    """(cos, sin) of ``angle`` [rad], computed once per evaluation (module docstring)."""
    if not _OUTPUTS.get():
        if not (_HELD.get() and loop_kernels()):
            return _cos_sin(angle)
        return jax.lax.platform_dependent(angle, cpu=_cos_sin_held, default=_cos_sin)
    c, s = _cos_sin(angle)
    pair = jnp.stack([c, s], axis=-1)
    pair = jnp.sum(jnp.stack([pair, pair], axis=-1), axis=-1) * 0.5
    return pair[..., 0], pair[..., 1]


def _cos_sin(angle):
    return jnp.cos(angle), jnp.sin(angle)


def _cos_sin_held(angle):
    """`_cos_sin` returned from a conditional (module docstring). Its other branch, taken where
    every angle of a batch is infinite or NaN, returns them swapped: both are NaN there, so the
    values are the same, and branches that differ keep XLA from removing the conditional (a
    branch of constant NaN instead changed how XLA fuses the readers)."""
    c, s = _cos_sin(angle)
    return jax.lax.cond(eqxi.unvmap_any(jnp.isfinite(angle)), lambda: (c, s), lambda: (s, c))


def power(depth, exponent: float) -> jax.Array:
    """depth^exponent [-] for depth >= 0 and a static exponent, with finite gradients at 0; 3/2
    as depth sqrt(depth)."""
    if exponent != 1.5:
        return depth**exponent
    safe = jnp.where(depth > 0.0, depth, 1.0)
    return jnp.where(depth > 0.0, safe * jnp.sqrt(safe), 0.0)

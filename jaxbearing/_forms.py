"""Two forms of cos and sin: the one the solver evaluates by default, and a faster one for the
batched evaluation of the outputs, the one loop, and the solver with FMA off; and d^1.5.

XLA:CPU fuses an elementwise producer into every kernel that consumes it unless that would read
more memory, so in a batched evaluation of the forces cos and sin of each body angle were
computed again in dozens of kernels. Within `output_forms`, `cos_sin` passes its values through
an exact reduction, (x + x) / 2 as a sum over two copies (a reduction is never repeated).
`simulate` evaluates its output times so. The solver's own evaluations keep the plain form by
default: with XLA:CPU's fused multiply–adds on, the kernels XLA builds around it round in the last
bit differently in a single run and in a batch, and a sweep member must equal its single run bit
for bit (tests/test_sweep.py). With them off (`jaxbearing.compile.enable_entry_elimination`)
they round alike, and the solver's accelerations use this form.

`power` writes d^1.5 (the Hertzian exponent of Eqs. 9 and 23) as d sqrt(d) everywhere: XLA
evaluates a general power as an exponential and a logarithm.
"""

from __future__ import annotations

import contextlib
import contextvars

import jax
import jax.numpy as jnp

_OUTPUTS = contextvars.ContextVar("jaxbearing_output_forms", default=False)


@contextlib.contextmanager
def output_forms():
    """Trace `cos_sin` in its form for the outputs (module docstring)."""
    token = _OUTPUTS.set(True)
    try:
        yield
    finally:
        _OUTPUTS.reset(token)


def cos_sin(angle) -> tuple[jax.Array, jax.Array]:
    """(cos, sin) of ``angle`` [rad]; within `output_forms`, computed once per evaluation."""
    c, s = jnp.cos(angle), jnp.sin(angle)
    if not _OUTPUTS.get():
        return c, s
    pair = jnp.stack([c, s], axis=-1)
    pair = jnp.sum(jnp.stack([pair, pair], axis=-1), axis=-1) * 0.5
    return pair[..., 0], pair[..., 1]


def power(depth, exponent: float) -> jax.Array:
    """depth^exponent [-] for depth >= 0 and a static exponent, with finite gradients at 0; 3/2
    as depth sqrt(depth)."""
    if exponent != 1.5:
        return depth**exponent
    safe = jnp.where(depth > 0.0, depth, 1.0)
    return jnp.where(depth > 0.0, safe * jnp.sqrt(safe), 0.0)

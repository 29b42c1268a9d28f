"""d^1.5, the Hertzian power of Eqs. 9 and 23, with a finite gradient at 0.

Written as d sqrt(d): XLA evaluates a general power as an exponential and a logarithm.
"""

from __future__ import annotations

import jax
import jax.numpy as jnp


def power(depth, exponent: float) -> jax.Array:
    """depth^exponent [-] for depth >= 0 and a static exponent, with finite gradients at 0; 3/2
    as depth sqrt(depth)."""
    if exponent != 1.5:
        return depth**exponent
    safe = jnp.where(depth > 0.0, depth, 1.0)
    return jnp.where(depth > 0.0, safe * jnp.sqrt(safe), 0.0)

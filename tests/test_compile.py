"""`jaxbearing.jit`: compiler options at the top level, plain compilation when nested.

JAX refuses compiler options on a jit inside another transformation ("can only be passed to
top-level jax.jit"); `simulate` must keep working inside a user's jit, vmap and grad.
"""

import jax
import jax.numpy as jnp
import numpy as np

import jaxbearing as jb


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
    # other XLA options may round differently: equal within the solver's tolerance
    np.testing.assert_allclose(nested.q, top.q, rtol=0, atol=1e-9)

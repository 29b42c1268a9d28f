"""The forms of `jaxbearing._forms` against libm (NumPy, itself within half an ulp of the true
values): `polynomial_cos_sin` at the quadrant edges, near zero and far out, and its derivatives
exactly (-sin, cos); d^1.5 as d sqrt(d)."""

import jax
import jax.numpy as jnp
import numpy as np

from jaxbearing._forms import output_forms, polynomial_cos_sin, power


def _ulps(value, reference):
    """|value - reference| in units of the last place of the larger of the two (near a power of
    two, the coarser one's)."""
    return np.abs(value - reference) / np.spacing(np.maximum(np.abs(value), np.abs(reference)))


def _check(angles, ulps):
    c, s = (np.asarray(x) for x in jax.jit(polynomial_cos_sin)(angles))
    for value, reference in ((c, np.cos(angles)), (s, np.sin(angles))):
        # away from the zeros (where libm's own value is a rounding residue of the argument)
        kept = np.abs(reference) > 1e-12
        assert np.max(_ulps(value[kept], reference[kept])) <= ulps
        assert np.max(np.abs(value - reference)) <= 2.3e-16
    return c, s


def test_polynomial_cos_sin_against_libm():
    """Within 1 ulp over a few revolutions of the crank and the cage (the reduced angle is one
    rounding, the kernels add less than one more), 2 ulp up to 1e6 rad (there the reduction's
    second part rounds too)."""
    rng = np.random.default_rng(0)
    near = np.concatenate(
        [
            rng.uniform(-50.0, 50.0, 100_000),
            np.arange(-64, 65) * np.pi / 4,  # quadrant edges and the kernels' ends
            np.geomspace(1e-300, 1e-3, 200),  # near zero: sin x = x
            -np.geomspace(1e-300, 1e-3, 200),
        ]
    )
    c, s = _check(near, 1.0)
    tiny = np.abs(near) < 1e-8
    assert np.all(s[tiny] == near[tiny]) and np.all(c[tiny] == 1.0)
    _check(rng.uniform(-1e6, 1e6, 10_000), 2.0)
    c, s = polynomial_cos_sin(0.0)
    assert float(c) == 1.0 and float(s) == 0.0


def test_polynomial_cos_sin_derivatives():
    angles = jnp.linspace(-20.0, 20.0, 101)
    dc, ds = jax.vmap(jax.jacfwd(polynomial_cos_sin))(angles)
    c, s = polynomial_cos_sin(angles)
    np.testing.assert_array_equal(dc, -s)
    np.testing.assert_array_equal(ds, c)
    grad = jax.grad(lambda x: polynomial_cos_sin(x)[1])(0.3)
    assert grad == polynomial_cos_sin(0.3)[0]


def test_power_one_and_a_half():
    depth = jnp.asarray([0.0, 1e-12, 2.5e-6, 4.0])
    plain = power(depth, 1.5)
    with output_forms():
        cheap = power(depth, 1.5)
    np.testing.assert_allclose(cheap, plain, rtol=4e-16, atol=0.0)
    assert float(jax.grad(lambda d: power(d, 1.5, cheap=True))(0.0)) == 0.0

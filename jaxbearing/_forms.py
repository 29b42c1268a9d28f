"""Two forms of a few formulas: the ones the solver evaluates by default, and faster ones for the
batched evaluation of the outputs and for the solver with the entry elimination.

XLA:CPU calls libm's cos and sin one number at a time, also in a batch, where its own arithmetic
runs on vectors; it fuses an elementwise producer into every kernel that consumes it unless that
would read more memory, so in a batched evaluation of the forces cos and sin of each body angle
were computed again in dozens of kernels; and it evaluates d^1.5 as a general power (an
exponential and a logarithm). Within `output_forms`, `cos_sin` computes cos and sin with
arithmetic XLA vectorises (`polynomial_cos_sin`: fdlibm's reduction and kernels, within 1 ulp of
libm's over a few revolutions) and passes them through an exact reduction, (x + x) / 2 as a sum over two copies (a
reduction is never repeated), and `power` writes d^1.5 as d sqrt(d). `simulate` evaluates its
output times so. The solver's own evaluations keep the plain
forms by default: with XLA:CPU's fused multiply–adds on, the kernels XLA builds from the others
round in the last bit differently in a single run and in a batch, and a sweep member must equal
its single run bit for bit (tests/test_sweep.py). With them off
(`jaxbearing.compile.enable_entry_elimination`) they round alike, and the solver's accelerations
use these forms with the entry-by-entry elimination.
"""

from __future__ import annotations

import contextlib
import contextvars

import jax
import jax.numpy as jnp

_OUTPUTS = contextvars.ContextVar("jaxbearing_output_forms", default=False)


@contextlib.contextmanager
def output_forms():
    """Trace `cos_sin` and `power` in their forms for the outputs (module docstring)."""
    token = _OUTPUTS.set(True)
    try:
        yield
    finally:
        _OUTPUTS.reset(token)


def cos_sin(angle) -> tuple[jax.Array, jax.Array]:
    """(cos, sin) of ``angle`` [rad]; within `output_forms`, by `polynomial_cos_sin` and computed
    once per evaluation."""
    if not _OUTPUTS.get():
        return jnp.cos(angle), jnp.sin(angle)
    c, s = polynomial_cos_sin(angle)
    pair = jnp.stack([c, s], axis=-1)
    pair = jnp.sum(jnp.stack([pair, pair], axis=-1), axis=-1) * 0.5
    return pair[..., 0], pair[..., 1]


def power(depth, exponent: float, cheap: bool = False) -> jax.Array:
    """depth^exponent [-] for depth >= 0 and a static exponent, with finite gradients at 0;
    3/2 as depth sqrt(depth) within `output_forms`, or where ``cheap``."""
    if exponent != 1.5 or not (cheap or _OUTPUTS.get()):
        return depth**exponent
    safe = jnp.where(depth > 0.0, depth, 1.0)
    return jnp.where(depth > 0.0, safe * jnp.sqrt(safe), 0.0)


# pi/2 in three parts (fdlibm's pio2_1, pio2_2, pio2_3: 33 + 33 + 33 bits), so that k pio2_1 is
# exact for |k| < 2^20 and the reduced angle is good to about 1e-30 rad there
_PIO2 = (1.57079632673412561417e00, 6.07710050630396597660e-11, 2.02226624871116645580e-21)
# fdlibm's minimax kernels on [-pi/4, pi/4]: sin x = x + x^3 S(x^2), cos x = 1 - x^2/2 + x^4 C(x^2)
_SIN = (-1.66666666666666324348e-01, 8.33333333332248946124e-03, -1.98412698298579493134e-04,
        2.75573137070700676789e-06, -2.50507602534068634195e-08, 1.58969099521155010221e-10)
_COS = (4.16666666666666019037e-02, -1.38888888888741095749e-03, 2.48015872894767294178e-05,
        -2.75573143513906633035e-07, 2.08757232129817482790e-09, -1.13596475577881948265e-11)


def _horner(z, coefficients):
    result = coefficients[-1]
    for c in reversed(coefficients[:-1]):
        result = c + z * result
    return result


@jax.custom_jvp
def polynomial_cos_sin(angle) -> tuple[jax.Array, jax.Array]:
    """(cos, sin) of ``angle`` [rad] by arithmetic alone (no library call), which XLA
    vectorises: the angle less the nearest multiple k pi/2 (Cody and Waite's reduction, exact
    for |angle| < 1.6e6 rad; beyond, good to about the angle's own rounding), fdlibm's kernels
    there, and the quadrant k mod 4. Within 1 ulp of libm's values for |angle| <= 50 rad and 2
    ulp up to 1e6 rad (tests/test_forms.py); the derivatives are (-sin, cos) exactly."""
    k = jnp.round(angle * (2.0 / jnp.pi))
    r = ((angle - k * _PIO2[0]) - k * _PIO2[1]) - k * _PIO2[2]
    z = r * r
    sin = r + r * z * _horner(z, _SIN)
    half = 0.5 * z
    one_less = 1.0 - half  # fdlibm's compensated 1 - z/2 + z^2 C(z)
    cos = one_less + (((1.0 - one_less) - half) + z * z * _horner(z, _COS))
    quadrant = k - 4.0 * jnp.floor(0.25 * k)
    odd = (quadrant == 1.0) | (quadrant == 3.0)
    c, s = jnp.where(odd, sin, cos), jnp.where(odd, cos, sin)
    return jnp.where((quadrant == 1.0) | (quadrant == 2.0), -c, c), jnp.where(quadrant >= 2.0, -s, s)


@polynomial_cos_sin.defjvp
def _polynomial_cos_sin_jvp(primals, tangents):
    (angle,), (d_angle,) = primals, tangents
    c, s = polynomial_cos_sin(angle)
    return (c, s), (-s * d_angle, c * d_angle)

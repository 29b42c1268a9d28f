"""Static load distribution of a radial bearing (Harris & Kotzalas, *Essential Concepts*, ch. 7):
the inner ring's displacement under a radial load, each rolling element's load, and the load
zone, for any operating clearance (a preload too) and cage position.

The elements follow the bearing law the dynamics use (Eqs. 9, 12, static: no damping): element
r at phi_r = phi_c + 2 pi (r-1)/Z carries Q_r = K (e . u_r - P_d/2)_+^n, u_r = (cos phi_r,
sin phi_r), e the inner ring's displacement from the outer ring's centre. The balance
sum_r Q_r u_r = F is the gradient of the convex potential

    V(e) = sum_r K/(n+1) (e . u_r - P_d/2)_+^(n+1) - F . e,

so it is solved by Newton's method on V with a backtracking line search (each step lowers V or
the residual), a Levenberg–Marquardt shift of 1e-9 of the Hessian's trace where fewer than two
elements carry (the Hessian is then singular), from a start where the element nearest the load
line carries about |F|. Concrete inputs are solved in NumPy (nothing compiled); traced ones in
`jax.numpy` inside the caller's program, the root held constant, then one Newton step from it
that carries the derivative of the implicit function theorem, de/dp = -H^-1 dg/dp, as
`multibody.assembly` does.
"""

from __future__ import annotations

import functools

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from .. import _checks
from ..params import AbstractBearing

NEWTON_STEPS = 100  # most Newton steps; 12 suffice from the start below (tests/test_reference_life.py)
LINE_SEARCH_STEPS = 60  # most halvings of a Newton step
TOLERANCE = 1e-10  # |residual| at the root, relative to |F| + Z K (max(-P_d, 0)/2)^n [N]
SHIFT = 1e-9  # Levenberg–Marquardt shift, relative to the Hessian's trace
LOADED_FRACTION = 1e-9  # an element carries when its load exceeds this fraction of the largest


class LoadDistribution(eqx.Module):
    """The static load distribution of a bearing (`load_distribution`).

    Fields:
        displacement: e (2,), the inner ring's centre from the outer ring's [m], along the load
            for a symmetric element set.
        element_loads: Q_r (Z,), each rolling element's load [N], element 1 first.
        element_angles: phi_r (Z,), where each element sits [rad], phi_c + 2 pi (r-1)/Z.
        n_loaded: how many elements carry load: above 1e-9 of the largest (an element 90 degrees
            from the load line at zero clearance carries round-off only).
        zone_half_angle: psi_l, the half-angle of the load zone about the displacement [rad]
            (Harris): cos psi_l = P_d / (2 |e|), pi where every position is loaded, 0 where none
            is.
        load_zone_factor: epsilon = (1 - P_d / (2 |e|)) / 2 (Harris), the load zone's
            projection on the diameter over the diameter: 0.5 at zero clearance, below under a
            clearance, above under a preload (1 and more: every position loaded); 0 where no
            element carries.
    """

    displacement: jax.Array
    element_loads: jax.Array
    element_angles: jax.Array
    n_loaded: jax.Array
    zone_half_angle: jax.Array
    load_zone_factor: jax.Array


def _power(xp, x, p):
    """x^p for x >= 0 with finite derivatives at 0 (p > 1)."""
    safe = xp.where(x > 0.0, x, 1.0)
    return xp.where(x > 0.0, safe**p, 0.0)


def _field(xp, e, k, n, c, load, cos, sin):
    """(V, its gradient g (2,), its Hessian H (2, 2)) at e: the module docstring's potential."""
    depth = xp.maximum(e[0] * cos + e[1] * sin - 0.5 * c, 0.0)
    q = k * _power(xp, depth, n)
    potential = xp.sum(q * depth) / (n + 1.0) - (load[0] * e[0] + load[1] * e[1])
    g = xp.stack([xp.sum(q * cos) - load[0], xp.sum(q * sin) - load[1]])
    h = n * k * _power(xp, depth, n - 1.0)
    hxy = xp.sum(h * cos * sin)
    hess = xp.stack([xp.stack([xp.sum(h * cos * cos), hxy]), xp.stack([hxy, xp.sum(h * sin * sin)])])
    return potential, g, hess


def _newton_direction(xp, g, hess):
    """-(H + lambda I)^-1 g, lambda = `SHIFT` tr(H) (2 x 2, written out)."""
    shift = SHIFT * (hess[0, 0] + hess[1, 1])
    a, b, d = hess[0, 0] + shift, hess[0, 1], hess[1, 1] + shift
    det = a * d - b * b
    det = xp.where(det > 0.0, det, 1.0)  # H = 0 is excluded by the start; the guard keeps NaN out
    return -xp.stack([d * g[0] - b * g[1], a * g[1] - b * g[0]]) / det


def _start(xp, k, n, c, load, cos, sin):
    """e0 along the load where the element nearest the load line carries about |F|."""
    size = xp.sqrt(load[0] ** 2 + load[1] ** 2)
    unit = load / xp.where(size > 0.0, size, 1.0)
    nearest = xp.max(unit[0] * cos + unit[1] * sin)  # >= cos(pi / Z) >= 0.5
    return unit * (0.5 * xp.maximum(c, 0.0) + (size / k) ** (1.0 / n)) / nearest


def _solve(xp, while_loop, k, n, c, load, cos, sin):
    """(e, |g| at e, the tolerance, steps): Newton with line search (module docstring) in the
    array module ``xp`` with the loop ``while_loop`` (`jax.lax`'s signature)."""
    z = cos.shape[0]
    scale = xp.sqrt(load[0] ** 2 + load[1] ** 2) + z * k * _power(xp, 0.5 * xp.maximum(-c, 0.0), n)
    tol = TOLERANCE * scale

    def fields(e):
        return _field(xp, e, k, n, c, load, cos, sin)

    def going(carry):
        _, norm, i = carry
        return (norm > tol) & (i < NEWTON_STEPS)

    def step(carry):
        e, _, i = carry
        v0, g, hess = fields(e)
        s = _newton_direction(xp, g, hess)
        slope, norm0 = g[0] * s[0] + g[1] * s[1], xp.sqrt(g[0] ** 2 + g[1] ** 2)

        def shorter(inner):
            t, _, j = inner
            v, g1, _ = fields(e + t * s)
            ok = (v <= v0 + 1e-4 * t * slope) | (xp.sqrt(g1[0] ** 2 + g1[1] ** 2) < norm0)
            return t, ok, j + 1

        def halving(inner):
            t, ok, j = inner
            return ~ok & (j < LINE_SEARCH_STEPS)

        def halve(inner):
            t, _, j = inner
            return shorter((0.5 * t, False, j))

        t = while_loop(halving, halve, shorter((1.0, False, 0)))[0]
        e = e + t * s
        g = fields(e)[1]
        return e, xp.sqrt(g[0] ** 2 + g[1] ** 2), i + 1

    e0 = _start(xp, k, n, c, load, cos, sin)
    g0 = fields(e0)[1]
    e, norm, steps = while_loop(going, step, (e0, xp.sqrt(g0[0] ** 2 + g0[1] ** 2), 0))
    return e, norm, tol, steps


def _host_while(going, step, carry):
    """`jax.lax.while_loop` on the host."""
    while going(carry):
        carry = step(carry)
    return carry


def _angles(xp, cage, z):
    return cage + 2.0 * np.pi * xp.arange(z) / z


def _outputs(xp, e, k, n, c, cos, sin, angles) -> LoadDistribution:
    depth = xp.maximum(e[0] * cos + e[1] * sin - 0.5 * c, 0.0)
    loads = k * _power(xp, depth, n)
    size = xp.sqrt(e[0] ** 2 + e[1] ** 2)
    safe = xp.where(size > 0.0, size, 1.0)
    # c / (2 |e|), +-inf at e = 0 (no load zone under a clearance, all of it under a preload)
    ratio = xp.where(size > 0.0, c / (2.0 * safe), xp.where(c > 0.0, xp.inf, xp.where(c < 0.0, -xp.inf, 0.0)))
    half = xp.arccos(xp.clip(ratio, -1.0, 1.0))
    epsilon = xp.maximum(0.5 * (1.0 - ratio), 0.0)
    counted = xp.sum(loads > LOADED_FRACTION * xp.max(loads))
    return LoadDistribution(e, loads, angles, counted, half, epsilon)


def load_distribution(bearing: AbstractBearing, load, cage=None) -> LoadDistribution:
    """The static load distribution of ``bearing`` under a radial load (module docstring).

    Args:
        bearing: a `BallBearing` or `RollerBearing` (its clearance, stiffness K, exponent n
            and element count Z; any operating clearance its rules accept, negative for a
            preload). The damping does not enter.
        load: (F_x, F_y), the radial load the inner ring carries [N] (a shaft load; the outer
            ring is fixed and takes it through the elements). Zero gives the centred rings
            (under a preload the elements carry the preload alone).
        cage: phi_c, where element 1 sits [rad] (Eq. 14's cage angle); None: on the load line.
            An element on the load line and two straddling it (phi_c = load angle + pi / Z) are
            the extremes of the element loads as the cage turns.

    Returns: `LoadDistribution`. Concrete inputs are solved in NumPy; traced ones (a clearance
    or a load under `jax.grad`, `jax.jit`, `jax.vmap`) in `jax.numpy`, differentiable (the
    implicit function theorem). A solve that does not converge in `NEWTON_STEPS` raises.
    """
    if not isinstance(bearing, AbstractBearing):
        raise TypeError(f"bearing must be a jaxbearing BallBearing or RollerBearing; got {type(bearing).__name__}.")
    _checks.check_init(bearing)  # its rules again: values may have changed since construction
    f = _checks.as_float(load, "load", "N")
    if f.shape != (2,):
        raise ValueError(f"load must be the radial load vector (F_x, F_y) [N], shape (2,); got shape {f.shape}.")
    _checks.check(lambda xp, f: [_checks.finite(xp, "load", f)], f)
    if cage is None:
        cage = _checks.evaluate(lambda xp, f: xp.arctan2(f[1], f[0]), f)
    phi = _checks.as_float(cage, "cage", "rad")
    if phi.shape != ():
        raise ValueError(f"cage must be one angle [rad]; got shape {phi.shape}.")
    _checks.check(lambda xp, phi: [_checks.finite(xp, "cage", phi)], phi)
    k, c, n, z = bearing.stiffness, bearing.clearance, bearing.exponent, bearing.n_balls
    if _checks.is_concrete(k, c, f, phi):
        return _on_host(*(np.asarray(x, np.float64) for x in (k, c, f, phi)), n, z)
    return _traced(k, c, f, phi, n, z)


def _on_host(k, c, f, phi, n, z) -> LoadDistribution:
    """`load_distribution` in NumPy."""
    angles = _angles(np, phi, z)
    cos, sin = np.cos(angles), np.sin(angles)
    if np.all(f == 0.0):
        e = np.zeros(2)
    else:
        e, norm, tol, steps = _solve(np, _host_while, k, n, c, f, cos, sin)
        if not norm <= tol:
            raise RuntimeError(
                f"load_distribution: Newton's method left a residual of {norm:.3g} N after "
                f"{steps} steps (tolerance {tol:.3g} N); the load {f.tolist()} N and clearance "
                f"{float(c):.6g} m have no balance this method finds."
            )
    # on the device as they are (float64, the count an integer): compiles nothing
    return jax.tree_util.tree_map(jax.device_put, _outputs(np, e, k, n, c, cos, sin, angles))


@functools.partial(jax.jit, static_argnums=(4, 5))
def _solved(k, c, f, phi, n, z):
    """The root e (held constant), its residual and tolerance, in `jax.numpy`."""
    angles = _angles(jnp, phi, z)
    e, norm, tol, _ = _solve(jnp, jax.lax.while_loop, k, n, c, f, jnp.cos(angles), jnp.sin(angles))
    zero = jnp.all(f == 0.0)
    return jnp.where(zero, 0.0, e), jnp.where(zero, 0.0, norm), tol


def _traced(k, c, f, phi, n, z) -> LoadDistribution:
    """`load_distribution` inside the caller's program: the root of the stopped inputs, then one
    Newton step from it with the inputs themselves (their derivatives: the implicit function
    theorem's)."""
    e, norm, tol = _solved(*jax.lax.stop_gradient((k, c, f, phi)), n, z)
    e = eqx.error_if(
        e, norm > tol, "load_distribution: Newton's method did not converge (traced inputs)."
    )
    angles = _angles(jnp, phi, z)
    cos, sin = jnp.cos(angles), jnp.sin(angles)
    _, g, hess = _field(jnp, e, k, n, c, f, cos, sin)
    step = _newton_direction(jnp, g, jax.lax.stop_gradient(hess))
    e = e + jnp.where(jnp.all(f == 0.0), 0.0, step)
    return _outputs(jnp, e, k, n, c, cos, sin, angles)

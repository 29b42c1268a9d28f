"""Assembly: initial coordinates and velocities that satisfy a mechanism's joints and drivers.

The assembly constraints are the joints' Phi(q, t0) = 0 (drivers held at their angle at t0)
and, for every `BearingJoint`, its race centres coinciding (the bearing centred, as in the
paper's case). Positions: q0 is the point of that constraint manifold nearest the guess,
min ||q - q_guess||^2 subject to Phi(q, t0) = 0, found by Gauss–Newton steps onto the manifold
(minimum-norm corrections, robust from a rough guess) and then Newton's method on the
projection's optimality conditions,

    q - q_guess + Phi_q^T lambda = 0,    Phi(q, t0) = 0,

a square system in (q, lambda). Its solution is differentiated by the implicit function
theorem: where the model or the guess is traced, a last Newton step from the solution (held
constant) carries dq0/dp = -K^-1 dF/dp (K the system's Jacobian), so that a parameter that moves
a joint point moves q0 accordingly. Velocities: qd0 is the velocity guess projected onto
Phi_q qd + Phi_t = 0 (minimum-norm correction), which is linear and differentiable as it stands.
All of it is one compiled program (`_assembled`: two small loops), which the checks read on the
host: assembling a small mechanism compiles once instead of running many one-operation programs.

A constraint set whose Jacobian is rank-deficient at the assembly (redundant joints, e.g. an
ideal `Revolute` beside a bearing at its points) is refused, naming the joints involved; so is
a guess from which the joints cannot be closed, naming the joint left open.
"""

from __future__ import annotations

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from .._checks import is_concrete, to_float64
from .forces import BearingJoint

TOLERANCE = 1e-12  # [m or rad] residual of every assembly constraint at q0
GAUSS_NEWTON_STEPS = 50  # Gauss–Newton steps onto the manifold before the projection's Newton
PROJECTION_STEPS = 200  # most Gauss–Newton steps on the projection's optimality conditions
RANK_TOLERANCE = 1e-9  # smallest / largest singular value of Phi_q below which it is rank-deficient


def assemble(model, q_guess=None, qd_guess=None, t0=0.0):
    """``model`` with ``q0``, ``qd0`` that satisfy its joints and drivers at ``t0`` [s], each
    bearing centred, nearest ``q_guess`` and ``qd_guess`` (defaults: the model's own ``q0``,
    ``qd0``). See the module docstring; `Mechanism.assemble` calls it."""
    n = model.n_coordinates
    q_guess = model.q0 if q_guess is None else to_float64(q_guess)
    qd_guess = model.qd0 if qd_guess is None else to_float64(qd_guess)
    for name, x in (("q_guess", q_guess), ("qd_guess", qd_guess)):
        if x.shape != (n,):
            raise ValueError(f"{name} must have shape ({n},) (x, y, theta per body); got {x.shape}.")
    if not model.joints and not model.bearings:
        return _with_state(model, q_guess, qd_guess)
    traced = not is_concrete(*jax.tree_util.tree_leaves((model, q_guess, qd_guess, t0)))
    found = _assembled(model, q_guess, qd_guess, to_float64(t0), traced)
    _check_closed(model, found.start_residual, "Gauss–Newton steps")
    _check_rank(model, found.start_jacobian)
    _check_closed(model, found.residual, "Newton steps on the projection")
    return _with_state(model, found.q, found.qd)


def _with_state(model, q, qd):
    return eqx.tree_at(lambda m: (m.q0, m.qd0), model, (q, qd))


def constraints(model, q, t) -> jax.Array:
    """The assembly constraints: the joints' Phi(q, t), then the race-centre offsets of every
    bearing (2 each) [m or rad]."""
    parts = [joint(q, t) for joint in model.joints] + [b.offset(q) for b in model.bearings]
    return jnp.concatenate(parts)


def linearized(model, q, t):
    """`constraints` at (q, t) [m or rad] with their derivatives d/dq (n_equations,
    n_coordinates) and d/dt (the joints' Phi_t; 0 for the bearings), in one forward-mode pass."""
    (jac, rate), phi = jax.jacfwd(lambda q, t: (constraints(model, q, t),) * 2, argnums=(0, 1), has_aux=True)(q, t)
    return phi, jac, rate


def labels(model) -> list[str]:
    """The assembly constraint each equation belongs to, in `constraints`' order, e.g.
    ``"joint 2 (Revolute, rod–slider)"``."""
    out = []
    for i, joint in enumerate(model.joints):
        out += [model.joint_label(i)] * joint.n_equations
    for i, force in enumerate(model.forces):
        if isinstance(force, BearingJoint):
            out += [f"force {i} (BearingJoint, {model.bodies_label(force.outer_body, force.inner_body)})"] * 2
    return out


class _Assembly(eqx.Module):
    """What `_assembled` finds: the start on the manifold with its residual and Phi_q (for the
    checks), the assembled q with its residual, and qd."""

    start_residual: jax.Array
    start_jacobian: jax.Array
    q: jax.Array
    residual: jax.Array
    qd: jax.Array


@eqx.filter_jit
def _assembled(model, q_guess, qd_guess, t0, differentiable: bool) -> _Assembly:
    """The assembly as one compiled program (a few small loops, compiled once, instead of many
    one-operation programs): Gauss–Newton steps onto the manifold, Newton's method on the
    projection, the velocities' projection. The checks read its result on the host.
    ``differentiable`` (static; where any input is traced): the projection's last step carries
    its derivative (`_projection`)."""
    start = jax.lax.stop_gradient(_onto_manifold(model, q_guess, t0))
    start_residual, jac, _ = linearized(model, start, t0)
    q = _projection(model, q_guess, t0, start, jac, differentiable)
    residual, jac_q, phi_t = linearized(model, q, t0)
    qd = qd_guess - jac_q.T @ jnp.linalg.solve(jac_q @ jac_q.T, jac_q @ qd_guess + phi_t)
    return _Assembly(start_residual, jac, q, residual, qd)


def _onto_manifold(model, q, t0):
    """Gauss–Newton steps with minimum-norm corrections, dq = -Phi_q^T (Phi_q Phi_q^T)^-1 Phi,
    until a step starts where the residual is below `TOLERANCE`, or `GAUSS_NEWTON_STEPS` are
    taken."""

    def step(carry):
        q, _, i = carry
        phi, jac, _ = linearized(model, q, t0)
        return q - jac.T @ jnp.linalg.lstsq(jac @ jac.T, phi)[0], jnp.max(jnp.abs(phi)), i + 1

    def going(carry):
        _, residual, i = carry
        return (residual > TOLERANCE) & (i < GAUSS_NEWTON_STEPS)

    return jax.lax.while_loop(going, step, (q, jnp.inf, 0))[0]


def _projection(model, q_guess, t0, start, jac, differentiable: bool):
    """The point of the manifold nearest ``q_guess``: from ``start`` (on the manifold) and its
    multipliers' least-squares estimate, Gauss–Newton steps on the optimality conditions
    F(q, lambda) = 0 (module docstring: `_newton_step` without the constraints' curvature, which
    converges linearly to the same point and compiles much smaller), until a step starts where
    they hold within `TOLERANCE`, or `PROJECTION_STEPS` are taken. If ``differentiable``, then
    one Newton step from the point found, held constant, which carries the derivative in the
    model and the guess: that of the implicit function theorem, -K^-1 dF/dp."""
    n = model.n_coordinates

    def step(carry):
        y, _, i = carry
        dy, f = _newton_step(model, q_guess, t0, y, curvature=False)
        return y + dy, jnp.max(jnp.abs(f)), i + 1

    def going(carry):
        _, residual, i = carry
        return (residual > TOLERANCE) & (i < PROJECTION_STEPS)

    lam = -jnp.linalg.solve(jac @ jac.T, jac @ (start - q_guess))
    y0 = jax.lax.stop_gradient(jnp.concatenate([start, lam]))
    found = jax.lax.stop_gradient(jax.lax.while_loop(going, step, (y0, jnp.inf, 0))[0])
    if not differentiable:
        return found[:n]
    return (found + _newton_step(model, q_guess, t0, found, curvature=True)[0])[:n]


def _newton_step(model, q_guess, t0, y, curvature: bool):
    """The step -K^-1 F at y = (q, lambda) on the projection's optimality conditions F, K held
    constant: K = [[I + sum_i lambda_i Phi_i,qq, Phi_q^T], [Phi_q, 0]] (Newton's method), without
    the sum unless ``curvature`` (Gauss–Newton); and F."""
    n = model.n_coordinates
    q, lam = y[:n], y[n:]
    phi, jac, _ = linearized(model, q, t0)
    upper = jnp.eye(n)
    if curvature:
        upper = upper + jax.hessian(lambda q: lam @ constraints(model, q, t0))(q)
    k = jnp.block([[upper, jac.T], [jac, jnp.zeros((lam.size, lam.size))]])
    f = jnp.concatenate([q - q_guess + jac.T @ lam, phi])
    return -jnp.linalg.solve(jax.lax.stop_gradient(k), f), f


def _check_closed(model, residual, method: str) -> None:
    """A `ValueError` naming the assembly constraint with the largest ``residual`` (`constraints`
    at the point found), unless all are below 1e3 `TOLERANCE` (checked where it is concrete)."""
    if not is_concrete(residual):
        return
    residual = np.abs(np.asarray(residual))
    worst = int(np.argmax(residual))
    if not residual[worst] <= 1e3 * TOLERANCE:  # also NaN
        raise ValueError(
            f"assembly could not close {labels(model)[worst]}: its residual is "
            f"{residual[worst]:.3g} (m or rad) after {method}. Start q_guess nearer an "
            "assembled position, or check the joints' points and the links' lengths (they "
            "may not close at all)."
        )


def _check_rank(model, jac) -> None:
    """A `ValueError` naming the redundant constraints when Phi_q is rank-deficient (checked
    where it is concrete)."""
    if not is_concrete(jac):
        return
    u, s, _ = np.linalg.svd(np.asarray(jac))
    rank = int(np.sum(s > RANK_TOLERANCE * s[0])) if s.size else 0
    if rank == u.shape[0]:
        return
    combination = u[:, rank]  # a combination of the equations whose Phi_q rows cancel
    involved = np.flatnonzero(np.abs(combination) > 1e-6 * np.abs(combination).max())
    names = list(dict.fromkeys(labels(model)[i] for i in involved))
    bearing = any("BearingJoint" in name for name in names)
    hint = " (a BearingJoint already joins its two bodies: no ideal joint may)" if bearing else ""
    raise ValueError(
        "redundant constraints: " + ", ".join(names) + " constrain the same motion (Phi_q is "
        f"rank-deficient at the assembly). Remove one of them{hint}."
    )

"""Assembly: initial coordinates and velocities that satisfy a mechanism's joints and drivers.

The assembly constraints are the joints' Phi(q, t0) = 0 (drivers held at their angle at t0)
and, for every `BearingJoint`, its race centres coinciding (the bearing centred, as in the
paper's case). Positions: q0 is the point of that constraint manifold nearest the guess,
min ||q - q_guess||^2 subject to Phi(q, t0) = 0, found by Gauss–Newton steps onto the manifold
(minimum-norm corrections, robust from a rough guess) and then Newton's method on the
projection's optimality conditions,

    q - q_guess + Phi_q^T lambda = 0,    Phi(q, t0) = 0,

a square system that `optimistix.root_find` solves and differentiates by the implicit
function theorem: a parameter that moves a joint point moves q0 accordingly. Velocities:
qd0 is the velocity guess projected onto Phi_q qd + Phi_t = 0 (minimum-norm correction),
which is linear and differentiable as it stands.

A constraint set whose Jacobian is rank-deficient at the assembly (redundant joints, e.g. an
ideal `Revolute` beside a bearing at its points) is refused, naming the joints involved; so is
a guess from which the joints cannot be closed, naming the joint left open.
"""

from __future__ import annotations

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import optimistix as optx

from .._checks import is_concrete
from .forces import BearingJoint

TOLERANCE = 1e-12  # [m or rad] residual of every assembly constraint at q0
GAUSS_NEWTON_STEPS = 50  # Gauss–Newton steps onto the manifold before the projection's Newton
RANK_TOLERANCE = 1e-9  # smallest / largest singular value of Phi_q below which it is rank-deficient


def assemble(model, q_guess=None, qd_guess=None, t0=0.0):
    """``model`` with ``q0``, ``qd0`` that satisfy its joints and drivers at ``t0`` [s], each
    bearing centred, nearest ``q_guess`` and ``qd_guess`` (defaults: the model's own ``q0``,
    ``qd0``). See the module docstring; `Mechanism.assemble` calls it."""
    n = model.n_coordinates
    q_guess = model.q0 if q_guess is None else jnp.asarray(q_guess, jnp.float64)
    qd_guess = model.qd0 if qd_guess is None else jnp.asarray(qd_guess, jnp.float64)
    for name, x in (("q_guess", q_guess), ("qd_guess", qd_guess)):
        if x.shape != (n,):
            raise ValueError(f"{name} must have shape ({n},) (x, y, theta per body); got {x.shape}.")
    t0 = jnp.asarray(t0, jnp.float64)
    if not model.joints and not model.bearings:
        return _with_state(model, q_guess, qd_guess)
    start = jax.lax.stop_gradient(_onto_manifold(model, q_guess, t0))
    _check_closed(model, start, t0, "Gauss–Newton steps")
    jac = constraint_jacobian(model, start, t0)
    _check_rank(model, jac)
    q = _projection(model, q_guess, t0, start, jac)
    _check_closed(model, q, t0, "Newton steps on the projection")
    jac = constraint_jacobian(model, q, t0)
    rate = jac @ qd_guess + _time_derivatives(model, q, t0)
    qd = qd_guess - jac.T @ jnp.linalg.solve(jac @ jac.T, rate)
    return _with_state(model, q, qd)


def _with_state(model, q, qd):
    return eqx.tree_at(lambda m: (m.q0, m.qd0), model, (q, qd))


def constraints(model, q, t) -> jax.Array:
    """The assembly constraints: the joints' Phi(q, t), then the race-centre offsets of every
    bearing (2 each) [m or rad]."""
    parts = [joint(q, t) for joint in model.joints] + [b.offset(q) for b in model.bearings]
    return jnp.concatenate(parts)


def constraint_jacobian(model, q, t) -> jax.Array:
    """d(`constraints`)/dq, (n_equations, n_coordinates)."""
    return jax.jacfwd(constraints, argnums=1)(model, q, t)


def _time_derivatives(model, q, t) -> jax.Array:
    """d(`constraints`)/dt: the joints' Phi_t; 0 for the bearings."""
    return jax.jacfwd(constraints, argnums=2)(model, q, t)


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


@eqx.filter_jit
def _onto_manifold(model, q, t0):
    """Gauss–Newton steps with minimum-norm corrections, dq = -Phi_q^T (Phi_q Phi_q^T)^-1 Phi,
    until the residual is below `TOLERANCE` or `GAUSS_NEWTON_STEPS` are taken."""

    def step(carry):
        q, i = carry
        jac = constraint_jacobian(model, q, t0)
        phi = constraints(model, q, t0)
        dq = jac.T @ jnp.linalg.lstsq(jac @ jac.T, phi)[0]
        return q - dq, i + 1

    def going(carry):
        q, i = carry
        return (jnp.max(jnp.abs(constraints(model, q, t0))) > TOLERANCE) & (i < GAUSS_NEWTON_STEPS)

    return jax.lax.while_loop(going, step, (q, 0))[0]


@eqx.filter_jit
def _projection(model, q_guess, t0, start, jac):
    """The point of the manifold nearest ``q_guess``: Newton's method on the optimality
    conditions from ``start`` (on the manifold) and its multipliers' least-squares estimate;
    differentiable in the model and the guess by the implicit function theorem."""
    n = model.n_coordinates

    def conditions(y, args):
        model, q_guess = args
        q, lam = y[:n], y[n:]
        jac = constraint_jacobian(model, q, t0)
        return jnp.concatenate([q - q_guess + jac.T @ lam, constraints(model, q, t0)])

    lam = -jnp.linalg.solve(jac @ jac.T, jac @ (start - q_guess))
    solver = optx.Newton(rtol=1e-14, atol=TOLERANCE)
    y0 = jnp.concatenate([start, jax.lax.stop_gradient(lam)])
    found = optx.root_find(conditions, solver, y0, (model, q_guess), max_steps=50, throw=False)
    return found.value[:n]


def _check_closed(model, q, t0, method: str) -> None:
    """A `ValueError` naming the assembly constraint with the largest residual, unless all are
    below 1e3 `TOLERANCE` (checked where ``q`` is concrete)."""
    residual = jnp.abs(constraints(model, q, t0))
    if not is_concrete(residual):
        return
    residual = np.asarray(residual)
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

"""Assembly: initial coordinates and velocities that satisfy a mechanism's joints and drivers.

The assembly constraints are the joints' Phi(q, t0) = 0 (drivers held at their angle at t0)
and, for every force element with play (`AbstractForceElement.centred`: a `BearingJoint`'s race
centres, a `ClearanceJoint`'s journal and hole centres), its two points coinciding (centred, as
the bearing of the paper's case). Positions: q0 is the point of that constraint manifold
nearest the guess, min ||q - q_guess||^2 subject to Phi(q, t0) = 0, found by Gauss–Newton steps onto the manifold
(minimum-norm corrections, robust from a rough guess) and then Gauss–Newton steps (the
constraints' curvature left out: linear convergence to the same point) on the projection's
optimality conditions,

    q - q_guess + Phi_q^T lambda = 0,    Phi(q, t0) = 0,

a square system in (q, lambda). Its solution is differentiated by the implicit function
theorem: where the model or the guess is traced, a last Newton step from the solution (held
constant) carries dq0/dp = -K^-1 dF/dp (K the system's Jacobian), so that a parameter that moves
a joint point moves q0 accordingly. Velocities: qd0 is the velocity guess projected onto
Phi_q qd + Phi_t = 0 (minimum-norm correction), which is linear and differentiable as it stands.
A concrete model is assembled on the host: NumPy's linear algebra and loops around one small
compiled function (the constraints and their Jacobians, no loops), so that assembling a small
mechanism compiles in a fraction of a second instead of compiling the loops; a traced one (under
`jax.jit`, `jax.grad`, `jax.vmap`) runs the same steps (`_search`) in `jax.numpy` and
`jax.lax.while_loop` inside the caller's program.

A constraint set whose Jacobian is rank-deficient at the assembly (redundant joints, e.g. an
ideal `Revolute` beside a bearing or a journal at its points) is refused, naming the joints involved; so is
a guess from which the joints cannot be closed, naming the joint left open.
"""

from __future__ import annotations

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from .._checks import is_concrete, to_float64
from .bodies import point_position

TOLERANCE = 1e-12  # [m or rad] residual of every assembly constraint at q0
GAUSS_NEWTON_STEPS = 50  # Gauss–Newton steps onto the manifold before the projection's Newton
PROJECTION_STEPS = 200  # most Gauss–Newton steps on the projection's optimality conditions
RANK_TOLERANCE = 1e-9  # smallest / largest singular value of Phi_q below which it is rank-deficient


def assemble(model, q_guess=None, qd_guess=None, t0=0.0):
    """``model`` with ``q0``, ``qd0`` that satisfy its joints and drivers at ``t0`` [s], each
    element with play centred, nearest ``q_guess`` and ``qd_guess`` (defaults: the model's own ``q0``,
    ``qd0``). See the module docstring; `Mechanism.assemble` calls it."""
    n = model.n_coordinates
    q_guess = model.q0 if q_guess is None else to_float64(q_guess)
    qd_guess = model.qd0 if qd_guess is None else to_float64(qd_guess)
    for name, x in (("q_guess", q_guess), ("qd_guess", qd_guess)):
        if x.shape != (n,):
            raise ValueError(f"{name} must have shape ({n},) (x, y, theta per body); got {x.shape}.")
    if not model.joints and not _centred(model):
        return _with_state(model, q_guess, qd_guess)
    if not is_concrete(*jax.tree_util.tree_leaves((model, q_guess, qd_guess, t0))):
        return _with_state(model, *_traced(model, q_guess, qd_guess, to_float64(t0)))
    linearize = _on_host(model, t0)
    q_guess, qd_guess = np.asarray(q_guess), np.asarray(qd_guess)
    start, residual, jac = _onto_manifold(linearize, q_guess, np, _host_while)
    _check_closed(model, residual, "Gauss–Newton steps")
    _check_rank(model, jac)
    y, (residual, jac, rate) = _projection(linearize, q_guess, start, jac, np, _host_while)
    _check_closed(model, residual, "Newton steps on the projection")
    q, qd = y[: q_guess.size], _velocities(np, jac, rate, qd_guess)
    return _with_state(model, to_float64(q), to_float64(qd))


def _with_state(model, q, qd):
    return eqx.tree_at(lambda m: (m.q0, m.qd0), model, (q, qd))


def _centred(model) -> list[tuple[int, tuple]]:
    """(index in ``model.forces``, its `AbstractForceElement.centred` pairs) of each element
    with play."""
    return [(i, pairs) for i, f in enumerate(model.forces) if (pairs := f.centred()) is not None]


def constraints(model, q, t) -> jax.Array:
    """The assembly constraints: the joints' Phi(q, t), then for every element with play the
    offset of its second point from its first (2 each) [m or rad]."""
    parts = [joint(q, t) for joint in model.joints]
    for _, ((body_a, point_a), (body_b, point_b)) in _centred(model):
        parts.append(point_position(q, body_b, point_b) - point_position(q, body_a, point_a))
    return jnp.concatenate(parts)


def linearized(model, q, t):
    """`constraints` at (q, t) [m or rad] with their derivatives d/dq (n_equations,
    n_coordinates) and d/dt (the joints' Phi_t; 0 for the centred elements), in one
    forward-mode pass."""
    (jac, rate), phi = jax.jacfwd(lambda q, t: (constraints(model, q, t),) * 2, argnums=(0, 1), has_aux=True)(q, t)
    return phi, jac, rate


def labels(model) -> list[str]:
    """The assembly constraint each equation belongs to, in `constraints`' order, e.g.
    ``"joint 2 (Revolute, rod–slider)"``."""
    out = []
    for i, joint in enumerate(model.joints):
        out += [model.joint_label(i)] * joint.n_equations
    for i, ((body_a, _), (body_b, _)) in _centred(model):
        kind = type(model.forces[i]).__name__
        out += [f"force {i} ({kind}, {model.bodies_label(body_a, body_b)})"] * 2
    return out


def _on_host(model, t0):
    """q -> `linearized` at ``t0`` in NumPy, by one small jitted function without loops: a
    concrete model's assembly runs its steps on the host around it."""
    t0 = np.asarray(t0, np.float64)
    return lambda q: tuple(np.asarray(x) for x in _linearized_jit(model, q, t0))


_linearized_jit = eqx.filter_jit(linearized)


def _host_while(going, step, carry):
    """`jax.lax.while_loop` on the host."""
    while going(carry):
        carry = step(carry)
    return carry


@eqx.filter_jit
def _traced(model, q_guess, qd_guess, t0):
    """(q0, qd0) of a traced model, inside the caller's program: the steps of a concrete one in
    `jax.numpy`, the projection's point held constant, then one Newton step from it that
    carries the derivative in the model and the guess, that of the implicit function theorem,
    -K^-1 dF/dp (module docstring)."""
    frozen, guess, time = jax.lax.stop_gradient((model, q_guess, t0))

    def linearize(q):
        return linearized(frozen, q, time)

    start, _, jac = _onto_manifold(linearize, guess, jnp, jax.lax.while_loop)
    y, _ = _projection(linearize, guess, start, jac, jnp, jax.lax.while_loop)
    q = (y + _newton_step(model, q_guess, t0, y))[: model.n_coordinates]
    _, jac_q, phi_t = linearized(model, q, t0)
    return q, _velocities(jnp, jac_q, phi_t, qd_guess)


def _going(limit):
    """A loop's condition: its last residual above `TOLERANCE` and fewer than ``limit`` steps."""
    return lambda carry: (carry[1] > TOLERANCE) & (carry[2] < limit)


def _onto_manifold(linearize, q, xp, while_loop):
    """Gauss–Newton steps with minimum-norm corrections, dq = -Phi_q^T (Phi_q Phi_q^T)^-1 Phi,
    until a step starts where the residual is below `TOLERANCE`, or `GAUSS_NEWTON_STEPS` are
    taken; the point reached with its residual and Phi_q. In the array module ``xp`` with the
    loop ``while_loop`` (`jax.lax`'s signature); ``linearize``: q -> `linearized` at t0."""

    def step(carry):
        q, _, i = carry
        phi, jac, _ = linearize(q)
        return q - jac.T @ xp.linalg.lstsq(jac @ jac.T, phi)[0], xp.max(xp.abs(phi)), i + 1

    q = while_loop(_going(GAUSS_NEWTON_STEPS), step, (q, xp.inf, 0))[0]
    phi, jac, _ = linearize(q)
    return q, phi, jac


def _projection(linearize, q_guess, start, jac, xp, while_loop):
    """The point y = (q, lambda) of the manifold nearest ``q_guess``, from ``start`` (on the
    manifold, Phi_q there ``jac``) and its multipliers' least-squares estimate: Gauss–Newton
    steps on the optimality conditions F(q, lambda) = 0 (`_optimality` without the constraints'
    curvature, which converges linearly to the same point and compiles much smaller), until a
    step starts where they hold within `TOLERANCE`, or `PROJECTION_STEPS` are taken; and
    `linearized` at its q. ``xp``, ``while_loop``, ``linearize``: as `_onto_manifold`'s."""
    n = q_guess.shape[0]

    def step(carry):
        y, _, i = carry
        phi, jac, _ = linearize(y[:n])
        k, f = _optimality(xp, y, q_guess, phi, jac, xp.eye(n))
        return y - xp.linalg.solve(k, f), xp.max(xp.abs(f)), i + 1

    lam = -xp.linalg.solve(jac @ jac.T, jac @ (start - q_guess))
    y = while_loop(_going(PROJECTION_STEPS), step, (xp.concatenate([start, lam]), xp.inf, 0))[0]
    return y, linearize(y[:n])


def _velocities(xp, jac_q, phi_t, qd_guess):
    """The velocity guess projected onto Phi_q qd + Phi_t = 0 (minimum-norm correction)."""
    return qd_guess - jac_q.T @ xp.linalg.solve(jac_q @ jac_q.T, jac_q @ qd_guess + phi_t)


def _optimality(xp, y, q_guess, phi, jac, upper):
    """The projection's optimality conditions F at y = (q, lambda) (module docstring) and their
    Jacobian K = [[upper, Phi_q^T], [Phi_q, 0]]: upper = I + sum_i lambda_i Phi_i,qq for Newton's
    method, I for Gauss–Newton."""
    n, m = q_guess.shape[0], phi.shape[0]
    k = xp.block([[upper, jac.T], [jac, xp.zeros((m, m))]])
    return k, xp.concatenate([y[:n] - q_guess + jac.T @ y[n:], phi])


def _newton_step(model, q_guess, t0, y):
    """Newton's step -K^-1 F on the projection's optimality conditions at y = (q, lambda), K
    held constant (`_optimality`)."""
    n = model.n_coordinates
    q, lam = y[:n], y[n:]
    phi, jac, _ = linearized(model, q, t0)
    upper = jnp.eye(n) + jax.hessian(lambda q: lam @ constraints(model, q, t0))(q)
    k, f = _optimality(jnp, y, q_guess, phi, jac, upper)
    return -jnp.linalg.solve(jax.lax.stop_gradient(k), f)


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
    centred = [type(model.forces[i]).__name__ for i, _ in _centred(model)]
    kinds = [kind for kind in dict.fromkeys(centred) if any(f"({kind}," in name for name in names)]
    hint = f" (a {kinds[0]} already joins its two bodies: no ideal joint may)" if kinds else ""
    raise ValueError(
        "redundant constraints: " + ", ".join(names) + " constrain the same motion (Phi_q is "
        f"rank-deficient at the assembly). Remove one of them{hint}."
    )

"""Assembly of bodies, joints and force elements into the equations of motion (paper Eq. 36).

    [M  Phi_q^T] [q_ddot]   [Q_A                                ]
    [Phi_q  0  ] [lambda] = [gamma - 2 alpha Phi_dot - beta^2 Phi]

M = diag(m, m, J) per body is diagonal, so the system is solved by its Schur complement
S = Phi_q M^-1 Phi_q^T (a small SPD matrix), never as the full augmented matrix. Each joint
supplies Phi, Phi_t, gamma = -(Phi_q q_dot)_q q_dot - 2 Phi_qt q_dot - Phi_tt and the nonzero
entries of Phi_q in closed form.

Two eliminations give the same q_ddot to rounding (tests/test_multibody.py):
- dense (`solve_spd`, the default of `accelerations`): matrix products and an unrolled
  Gauss–Jordan elimination, a reference that needs no sparsity.
- sparse (`solve_spd_entries`, ``accelerations(..., sparse=True)``): S, its LDL^T factors and
  Phi_q^T lambda written out entry by entry on the sparsity of Phi_q, which the joints' types and
  bodies fix. For the paper's slider–crank it is a few hundred scalar operations, much cheaper
  than the dense form; the solver and the outputs use it.
"""

from __future__ import annotations

import functools
from collections.abc import Mapping

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from .. import _checks, paths
from ..params import AbstractBearing, Impact
from .bodies import GROUND, Body
from .constraints import AbstractJoint, JacobianRows, Revolute
from .forces import AbstractForceElement, BearingJoint, CircleContact, ForceInputs, Gravity

DRIFT_FRACTION = 0.01  # of the smallest nonzero |play| of the force elements: `drift_bound`
DRIFT_SIZE_FRACTION = 1e-4  # of the mechanism's size, where no element has a play
POSITION_TOLERANCE = 1e-8  # [m or rad] allowed violation of Phi(q0, 0) = 0
VELOCITY_TOLERANCE = 1e-6  # [m/s or rad/s] allowed violation of Phi_dot(q0, qd0, 0) = 0


class Mechanism(eqx.Module):
    """A planar multibody system: the model that `jaxbearing.simulate` integrates.

    Fields:
        bodies: the moving bodies; body b owns q[3b:3b+3] = [x, y, theta].
        joints: kinematic constraints (`Revolute`, `Translational`, `Driver`).
        forces: every force element, in one list (`AbstractForceElement`: `BearingJoint`,
            `CircleContact`, `SpringDamper`, `Gravity`, and your own); given as a mapping
            name -> element, the elements are also named (``force_names``). ``bearings``,
            ``contacts`` and ``gravity`` are views of it.
        q0, qd0: initial coordinates [m, rad] and velocities [m/s, rad/s], (3 n_bodies,)
            (qd0 default: at rest). A solve needs them to satisfy the joints and drivers at its
            t0; `assemble` finds such a state from a rough guess.
        baumgarte_alpha, baumgarte_beta: Baumgarte stabilisation parameters [1/s] (Eq. 36).
        body_names: labels of the bodies, in order (static).
        force_names: the name of each force element, or None where it has none (static).
        window_start: where the default window of `jaxbearing.metrics` and `jaxbearing.life`
            starts [s], e.g. after a start-up transient; the solve stops there. None (the
            default): the whole solved span.
    """

    bodies: tuple[Body, ...]
    joints: tuple[AbstractJoint, ...]
    forces: tuple[AbstractForceElement, ...]
    q0: jax.Array
    qd0: jax.Array
    baumgarte_alpha: jax.Array
    baumgarte_beta: jax.Array
    body_names: tuple[str, ...] = eqx.field(static=True)
    force_names: tuple[str | None, ...] = eqx.field(static=True)
    window_start: jax.Array | None

    def __init__(
        self,
        bodies,
        joints,
        q0,
        qd0=None,
        *,
        forces=(),
        baumgarte_alpha=5.0,
        baumgarte_beta=5.0,
        body_names=None,
        window_start=None,
    ):
        self.bodies = tuple(bodies)
        self.joints = tuple(joints)
        self.forces, self.force_names = _elements(forces)
        for i, joint in enumerate(self.joints):
            if not isinstance(joint, AbstractJoint):
                fix = (
                    ": a force element belongs in forces=" if isinstance(joint, AbstractForceElement)
                    else ""
                )
                raise TypeError(
                    f"joints[{i}] must be a joint (jaxbearing.multibody.AbstractJoint: Revolute, "
                    f"Translational, Driver); got {type(joint).__name__}{fix}."
                )
        self.q0 = _checks.as_float(q0, "q0", "m, rad")
        if qd0 is None:
            qd0 = np.zeros(self.q0.shape)  # NumPy: jnp.zeros_like compiles a program
        self.qd0 = _checks.as_float(qd0, "qd0", "m/s, rad/s")
        self.baumgarte_alpha = _checks.as_float(baumgarte_alpha, "baumgarte_alpha", "1/s")
        self.baumgarte_beta = _checks.as_float(baumgarte_beta, "baumgarte_beta", "1/s")
        n = 3 * len(self.bodies)
        if not self.bodies:
            raise ValueError("A Mechanism needs at least one moving body.")
        if self.q0.shape != (n,) or self.qd0.shape != (n,):
            raise ValueError(
                f"q0 and qd0 must have shape ({n},) (x, y, theta per body); got "
                f"{self.q0.shape} and {self.qd0.shape}."
            )
        names = tuple(body_names) if body_names is not None else tuple(
            f"body{b}" for b in range(len(self.bodies))
        )
        if len(names) != len(self.bodies):
            raise ValueError(f"body_names has {len(names)} entries for {len(self.bodies)} bodies.")
        self.body_names = names
        if window_start is not None:
            window_start = _checks.as_float(window_start, "window_start", "s")
            if window_start.ndim:
                raise ValueError(f"window_start must be one time [s] or None; got shape {window_start.shape}.")
        self.window_start = window_start
        for i, element in enumerate(self.forces):
            for body in element.bodies():
                if body >= len(self.bodies) or body < -1:
                    name = "" if self.force_names[i] is None else f" {self.force_names[i]!r}"
                    raise ValueError(
                        f"force {i}{name} ({type(element).__name__}) refers to body {body}, which "
                        f"does not exist (bodies 0 to {len(self.bodies) - 1}, or GROUND = -1)."
                    )
        if self.n_constraints > n:
            raise ValueError(
                f"{self.n_constraints} constraint equations over-determine {n} coordinates."
            )
        _refuse_pins_at_centred(self)

    # -- structure -------------------------------------------------------------------------
    @property
    def n_coordinates(self) -> int:
        return 3 * len(self.bodies)

    @property
    def n_constraints(self) -> int:
        return sum(j.n_equations for j in self.joints)

    @property
    def masses(self) -> jax.Array:
        return jnp.stack([b.mass for b in self.bodies])

    @property
    def inverse_mass(self) -> jax.Array:
        """Diagonal of M^-1, (n_coordinates,)."""
        per_body = [jnp.stack([1.0 / b.mass, 1.0 / b.mass, 1.0 / b.inertia]) for b in self.bodies]
        return jnp.concatenate(per_body)

    @property
    def inputs(self) -> ForceInputs:
        """What every force element reads beside its state: q0, qd0 and the masses."""
        return ForceInputs(self.q0, self.qd0, self.masses)

    def indices(self, kind: type) -> tuple[int, ...]:
        """The indices in ``forces`` of the elements of class ``kind``."""
        return tuple(i for i, f in enumerate(self.forces) if isinstance(f, kind))

    @property
    def bearings(self) -> tuple[BearingJoint, ...]:
        """The `BearingJoint` elements of ``forces``, in order (a view)."""
        return tuple(self.forces[i] for i in self.indices(BearingJoint))

    @property
    def contacts(self) -> tuple[CircleContact, ...]:
        """The `CircleContact` elements of ``forces``, in order (a view)."""
        return tuple(self.forces[i] for i in self.indices(CircleContact))

    @property
    def gravity(self) -> Gravity | None:
        """The `Gravity` element of ``forces`` (None without one; a ValueError with several)."""
        found = self.indices(Gravity)
        if len(found) > 1:
            raise AttributeError(f"model.gravity: this model has {len(found)} Gravity elements.")
        return self.forces[found[0]] if found else None

    @property
    def bearing(self) -> AbstractBearing:
        """Parameters of the model's only bearing joint (``model.bearing.clearance`` etc.)."""
        bearings = self.bearings
        if len(bearings) != 1:
            raise AttributeError(
                f"model.bearing needs exactly one BearingJoint, this model has {len(bearings)}; "
                "use model.bearings[i].bearing."
            )
        return bearings[0].bearing

    @property
    def impact(self) -> Impact:
        """Parameters of the model's only impact contact (``model.impact.restitution`` etc.)."""
        if len(self.contacts) != 1:
            raise AttributeError(
                f"model.impact needs exactly one contact, this model has {len(self.contacts)}; "
                "use model.contacts[i].impact."
            )
        return self.contacts[0].impact

    def element(self, key: int | str) -> AbstractForceElement:
        """The force element of index ``key`` in ``forces``, or of that name."""
        return self.forces[self.element_index(key)]

    def element_index(self, key: int | str) -> int:
        """The index in ``forces`` of the element ``key`` (an index or a name); a
        ValueError naming what exists otherwise."""
        if isinstance(key, str):
            if key not in self.force_names:
                named = [n for n in self.force_names if n is not None]
                raise ValueError(
                    f"No force element named {key!r}; the named ones: {named or 'none'} (name "
                    "them by passing forces as a mapping, name -> element)."
                )
            return self.force_names.index(key)
        if isinstance(key, bool) or not isinstance(key, int) or not 0 <= key < len(self.forces):
            raise ValueError(
                f"A force element is an index from 0 to {len(self.forces) - 1} or a name; got {key!r}."
            )
        return key

    def force_label(self, i: int) -> str:
        """``"force i (Type, bodies)"``, with the element's name where it has one."""
        element = self.forces[i]
        bodies = self.bodies_label(*element.bodies()) if element.bodies() else "every body"
        name = self.force_names[i]
        return f"force {i}{'' if name is None else f' {name!r}'} ({type(element).__name__}, {bodies})"

    # -- constraints (Eqs. 35–36) ------------------------------------------------------------
    def constraints(self, q, t) -> jax.Array:
        """Phi(q, t), (n_constraints,)."""
        return jnp.concatenate([joint(q, t) for joint in self.joints])

    def constraint_jacobian(self, q, t) -> jax.Array:
        """Phi_q, (n_constraints, n_coordinates)."""
        return jnp.concatenate([joint.jacobian(q, t) for joint in self.joints])

    def constraint_velocity(self, q, qd, t, jacobian=None) -> jax.Array:
        """Phi_dot = Phi_q q_dot + Phi_t (``jacobian``: Phi_q if already at hand)."""
        jac = self.constraint_jacobian(q, t) if jacobian is None else jacobian
        return jac @ qd + self._time_derivatives(q, t)

    def _time_derivatives(self, q, t) -> jax.Array:
        """Phi_t, (n_constraints,)."""
        return jnp.concatenate([joint.time_derivative(q, t) for joint in self.joints])

    def constraint_rows(self, q, t) -> JacobianRows:
        """Phi_q by its nonzero entries, one dict per constraint equation (`JacobianRows`)."""
        return tuple(row for joint in self.joints for row in joint.jacobian_rows(q, t))

    def constraint_rhs(self, q, qd, t):
        """Phi_q and the right-hand side gamma - 2 alpha Phi_dot - beta^2 Phi of Eq. 36."""
        jac = self.constraint_jacobian(q, t)
        return jac, self._stabilised_rhs(q, qd, t, self.constraint_velocity(q, qd, t, jac))

    def _stabilised_rhs(self, q, qd, t, phi_dot) -> jax.Array:
        """gamma - 2 alpha Phi_dot - beta^2 Phi (Eq. 36) for the given Phi_dot."""
        phi = self.constraints(q, t)
        gamma = jnp.concatenate([joint.gamma(q, qd, t) for joint in self.joints])
        return gamma - 2.0 * self.baumgarte_alpha * phi_dot - self.baumgarte_beta**2 * phi

    # -- force elements and their discrete states ------------------------------------------
    def initial_states(self, t0, q0=None, qd0=None) -> tuple:
        """Each force element's discrete state at t0 [s] from (q0, qd0) (default: the model's),
        in ``forces`` order (`AbstractForceElement.initial_state`)."""
        q0 = self.q0 if q0 is None else q0
        qd0 = self.qd0 if qd0 is None else qd0
        inputs = self.inputs
        return tuple(f.initial_state(t0, q0, qd0, inputs) for f in self.forces)

    def generalized_forces(self, t, q, qd, states) -> jax.Array:
        """Q_A: the sum of every force element's generalised force with its discrete state
        (``states``, `initial_states`' structure), (n_coordinates,) [N, N m]."""
        inputs = self.inputs
        total = jnp.zeros_like(q)
        for element, state in zip(self.forces, states, strict=True):
            total = total + element.generalized_force(t, q, qd, state, inputs)
        return total

    def event_values(self, t, q, qd, states) -> jax.Array:
        """Every element's event values, joined in ``forces`` order, (n_events,)."""
        inputs = self.inputs
        parts = [f.event_values(t, q, qd, s, inputs) for f, s in zip(self.forces, states, strict=True)]
        return jnp.concatenate(parts) if parts else jnp.zeros((0,), q.dtype)

    def event_counts(self) -> tuple[int, ...]:
        """How many event values each element has (static)."""
        t = jax.ShapeDtypeStruct((), self.q0.dtype)
        q = jax.ShapeDtypeStruct(self.q0.shape, self.q0.dtype)
        states = jax.eval_shape(self.initial_states, t, q, q)
        inputs = self.inputs
        return tuple(
            jax.eval_shape(lambda t, q, s, f=f: f.event_values(t, q, q, s, inputs), t, q, state).shape[0]
            for f, state in zip(self.forces, states)
        )

    def on_events(self, t, q, qd, states, crossed) -> tuple:
        """The states after the events ``crossed`` ((n_events,) bool, `event_values`' order):
        each element's `AbstractForceElement.on_events` with its own."""
        inputs, out, start = self.inputs, [], 0
        for element, state, count in zip(self.forces, states, self.event_counts(), strict=True):
            mine = crossed[start : start + count]
            out.append(element.on_events(t, q, qd, state, mine, inputs) if count else state)
            start += count
        return tuple(out)

    @property
    def episodic(self) -> tuple[int, ...]:
        """The indices in ``forces`` of the elements with episodes (an ``episode_peak``)."""
        return tuple(i for i, f in enumerate(self.forces) if f.episode_peak is not None)

    def episodes(self, states):
        """(in episode, logged value), each (n_episodic,), of the elements with episodes."""
        chosen = [(self.forces[i], states[i]) for i in self.episodic]
        if not chosen:
            return jnp.zeros((0,), bool), jnp.zeros((0,), self.q0.dtype)
        return (
            jnp.stack([f.in_episode(s) for f, s in chosen]),
            jnp.stack([jnp.asarray(f.episode_value(s), self.q0.dtype) for f, s in chosen]),
        )

    # -- accelerations -------------------------------------------------------------------------
    def accelerations(self, t, q, qd, states, *, sparse=False) -> jax.Array:
        """q_ddot from Eq. 36 by the Schur complement of the diagonal mass matrix:
        S lambda = Phi_q M^-1 Q_A - rhs, q_ddot = M^-1 (Q_A - Phi_q^T lambda), with the force
        elements' discrete ``states``. ``sparse`` (static): the entry-by-entry elimination
        instead of the dense one (module docstring)."""
        forces = self.generalized_forces(t, q, qd, states)
        m_inv = self.inverse_mass
        if not self.joints:
            return m_inv * forces
        if sparse:
            return self._sparse_accelerations(t, q, qd, forces, m_inv)
        jac, rhs = self.constraint_rhs(q, qd, t)
        jm = jac * m_inv[None, :]
        lam = solve_spd(jm @ jac.T, jm @ forces - rhs)
        return m_inv * (forces - jac.T @ lam)

    def _sparse_accelerations(self, t, q, qd, forces, inverse_mass) -> jax.Array:
        """`accelerations` on the sparsity of Phi_q, for the generalised forces ``forces`` and
        the diagonal of M^-1 ``inverse_mass``."""
        n = self.n_coordinates
        m_inv = [inverse_mass[c] for c in range(n)]
        f = [forces[c] for c in range(n)]
        rows = self.constraint_rows(q, t)
        phi_dot = jnp.stack([_row_dot(row, qd) for row in rows]) + self._time_derivatives(q, t)
        rhs = self._stabilised_rhs(q, qd, t, phi_dot)
        schur = [[_weighted_dot(rows[i], rows[j], m_inv) for j in range(i + 1)] for i in range(len(rows))]
        accelerations_free = [m * x for m, x in zip(m_inv, f)]  # M^-1 Q_A
        b = [_row_dot(row, accelerations_free) - rhs[i] for i, row in enumerate(rows)]
        lam = solve_spd_entries(schur, b)
        for row, lam_i in zip(rows, lam):
            for c, value in row.items():
                f[c] = f[c] - value * lam_i
        return jnp.stack([m * x for m, x in zip(m_inv, f)])

    # -- assembly and validation ----------------------------------------------------------------
    def assemble(self, q_guess=None, qd_guess=None, t0=0.0) -> Mechanism:
        """This mechanism with ``q0``, ``qd0`` that satisfy its joints and drivers at ``t0`` [s],
        each bearing and journal centred (`AbstractForceElement.centred`), nearest ``q_guess`` [m, rad] and ``qd_guess`` [m/s, rad/s]
        (defaults: its own ``q0``, ``qd0``). Newton's method; differentiable in the parameters
        (a joint point that moves moves the state) by the implicit function theorem. A
        `ValueError` names a joint it cannot close, or redundant joints
        (`jaxbearing.multibody.assembly`)."""
        from .assembly import assemble

        return assemble(self, q_guess, qd_guess, t0)

    def parameter_violations(self, xp):
        """Every rule on every parameter of the model, in the array module ``xp``; first that
        every floating leaf is finite. Each parameter is named by the path a user types for it
        (`jaxbearing.paths.typed`: ``bearing.clearance``, ``bodies.1.mass``)."""
        named = functools.partial(paths.typed, self)
        rules = _checks.finite_leaves(xp, self, named)
        parts = [(f"bodies.{i}.", b) for i, b in enumerate(self.bodies)]
        parts += [(f"forces.{i}.", f) for i, f in enumerate(self.forces)]
        for prefix, part in parts:
            rules.extend(part.violations(xp, lambda field, prefix=prefix: named(prefix + field)))
        rules.append(_checks.positive(xp, "baumgarte_alpha", self.baumgarte_alpha, "1/s"))
        rules.append(_checks.positive(xp, "baumgarte_beta", self.baumgarte_beta, "1/s"))
        return rules

    def violations(self, xp, t0=0.0):
        """`parameter_violations` and the consistency of the initial state at ``t0`` [s]: every
        joint and driver satisfied (each joint named), no contact switched on while its surfaces
        overlap. The joints and contacts are JAX functions: with ``xp`` NumPy, those rules are
        eager JAX operations (the solve evaluates all of them inside its program). Each force
        element's rules on the initial state (`AbstractForceElement.start_violations`) are
        named by its label."""
        rules = self.parameter_violations(xp)
        t0 = jnp.asarray(t0, self.q0.dtype)
        for i, joint in enumerate(self.joints):
            pos = jnp.max(jnp.abs(joint(self.q0, t0)))
            rate = jnp.max(jnp.abs(joint.jacobian(self.q0, t0) @ self.qd0 + joint.time_derivative(self.q0, t0)))
            label = self.joint_label(i)
            fix = "; model.assemble(q_guess, qd_guess, t0) finds a consistent state"
            rules.append(
                (pos > POSITION_TOLERANCE,
                 f"initial positions q0 violate {label} at t0 by more than {POSITION_TOLERANCE} "
                 f"(m or rad){fix}", pos)
            )
            rules.append(
                (rate > VELOCITY_TOLERANCE,
                 f"initial velocities qd0 violate {label} at t0 by more than {VELOCITY_TOLERANCE} "
                 f"(m/s or rad/s){fix}", rate)
            )
        inputs = self.inputs
        for i, element in enumerate(self.forces):
            for broken, message, value in element.start_violations(t0, self.q0, self.qd0, inputs):
                rules.append((broken, f"{self.force_label(i)} {message}", value))
        return rules

    def joint_label(self, i: int) -> str:
        """``"joint i (Type, body–body)"`` by the bodies' names."""
        joint = self.joints[i]
        bodies = (joint.body_i, joint.body_j) if isinstance(joint, Revolute) else (joint.body,)
        return f"joint {i} ({type(joint).__name__}, {self.bodies_label(*bodies)})"

    def bodies_label(self, *bodies: int) -> str:
        """The bodies' names joined by dashes, ``GROUND`` as "ground"."""
        return "–".join("ground" if b == GROUND else self.body_names[b] for b in bodies)

    def drift_bound(self) -> float:
        """The constraint drift [m] above which a run is not trusted: `DRIFT_FRACTION` of the
        smallest nonzero |play| of its force elements (`AbstractForceElement.play`: a
        bearing's diametral clearance or preload; the joints then move by a visible fraction of
        the play, or of the preload's compression, the element forces act over), else `DRIFT_SIZE_FRACTION` of the mechanism's size (the
        largest distance between two bodies' initial positions, at least 1 m where all start at
        one point). Needs concrete values."""
        plays = [abs(float(np.asarray(p))) for f in self.forces if (p := f.play()) is not None]
        nonzero = [p for p in plays if p > 0.0]
        if nonzero:
            return DRIFT_FRACTION * min(nonzero)
        xy = np.asarray(self.q0).reshape(-1, 3)[:, :2]
        size = float(np.max(np.linalg.norm(xy[:, None] - xy[None], axis=-1))) if len(xy) else 0.0
        return DRIFT_SIZE_FRACTION * (size if size > 0.0 else 1.0)

    def __check_init__(self):
        if _checks.is_concrete(*jax.tree_util.tree_leaves(self)):
            _checks.raise_first(_checks.on_host(self).parameter_violations(np))


def _elements(forces) -> tuple[tuple, tuple]:
    """(elements, names) of the ``forces`` given: a sequence of elements (no names) or a
    mapping name -> element; a TypeError for anything but force elements."""
    if isinstance(forces, Mapping):
        names = tuple(forces)
        for name in names:
            if not isinstance(name, str) or not name:
                raise TypeError(f"forces: each name must be a non-empty string; got {name!r}.")
        elements = tuple(forces.values())
    else:
        elements = tuple(forces)
        names = (None,) * len(elements)
    for i, element in enumerate(elements):
        if not isinstance(element, AbstractForceElement):
            fix = ": a joint belongs in joints" if isinstance(element, AbstractJoint) else ""
            raise TypeError(
                f"forces[{i}] must be a force element (jaxbearing.multibody.AbstractForceElement: "
                f"BearingJoint, CircleContact, SpringDamper, Gravity or your own); got "
                f"{type(element).__name__}{fix}."
            )
    return elements, names


def _refuse_pins_at_centred(model) -> None:
    """A `ValueError` for an ideal `Revolute` that joins the two bodies of an element with play
    (`AbstractForceElement.centred`: a `BearingJoint`'s race centres, a journal's and its
    hole's centres) at those points: it would carry the load and the element none (checked
    where the points are concrete; `Mechanism.assemble` refuses any redundant set)."""
    for f, force in enumerate(model.forces):
        pairs = force.centred()
        if pairs is None:
            continue
        points = dict(pairs)
        kind = type(force).__name__
        for i, joint in enumerate(model.joints):
            if not isinstance(joint, Revolute) or {joint.body_i, joint.body_j} != set(points):
                continue
            given = (joint.point_i, points[joint.body_i], joint.point_j, points[joint.body_j])
            if not _checks.is_concrete(*given):
                continue
            if np.allclose(given[0], given[1], atol=1e-9) and np.allclose(given[2], given[3], atol=1e-9):
                raise ValueError(
                    f"{model.joint_label(i)} joins the two bodies of force {f} ({kind}) at the "
                    f"points it centres: the ideal pin would carry the load and the {kind} none. "
                    f"Remove the Revolute: the {kind} is the joint."
                )


def solve_spd(a, b) -> jax.Array:
    """x with a x = b for a small symmetric positive definite ``a`` (n, n), by Gauss–Jordan
    elimination unrolled over the n pivots.

    Without pivoting this is stable for SPD matrices (the pivots are those of a Cholesky
    factorisation). Unrolled, XLA fuses it into a few kernels, cheaper for these small matrices than
    LAPACK's Cholesky factor and solve (benchmarks/results.json).
    """
    m = jnp.concatenate([a, b[:, None]], axis=1)
    for j in range(a.shape[0]):
        row = m[j] / m[j, j]
        m = (m - m[:, j : j + 1] * row[None, :]).at[j].set(row)
    return m[:, -1]


def _row_dot(row: dict, x) -> jax.Array:
    """sum_c row[c] x[c] over the row's entries."""
    terms = [value * x[c] for c, value in row.items()]
    return sum(terms[1:], terms[0])


def _weighted_dot(row_i: dict, row_j: dict, weights: list):
    """sum_c row_i[c] weights[c] row_j[c] over the columns both rows touch; None if none."""
    terms = [weights[c] * (row_i[c] * row_j[c]) for c in sorted(row_i.keys() & row_j.keys())]
    return sum(terms[1:], terms[0]) if terms else None


def solve_spd_entries(a: list, b: list) -> list:
    """x with a x = b for a small symmetric positive definite ``a`` given by its lower triangle,
    entry by entry: ``a[i][j]`` (j <= i) a scalar, or None where a is zero by structure; ``b``
    a list of scalars. Returns x as a list of scalars.

    LDL^T factorisation without pivoting (stable for SPD matrices), unrolled at trace time and
    skipping every product with a structural zero (fill-in included), then the two triangular
    solves. Divisions are written as products with reciprocals, as a vmapped program would
    compute a division by a number its batch shares.
    """
    n = len(b)
    lower = [[None] * n for _ in range(n)]  # L below its unit diagonal; None: zero
    diagonal = []
    for j in range(n):
        d = a[j][j]
        for k in range(j):
            if lower[j][k] is not None:
                d = d - lower[j][k] * lower[j][k] * diagonal[k]
        diagonal.append(d)
        for i in range(j + 1, n):
            s = a[i][j]
            for k in range(j):
                if lower[i][k] is not None and lower[j][k] is not None:
                    term = lower[i][k] * lower[j][k] * diagonal[k]
                    s = -term if s is None else s - term
            lower[i][j] = None if s is None else s * (1.0 / d)
    y = list(b)
    for i in range(n):
        for k in range(i):
            if lower[i][k] is not None:
                y[i] = y[i] - lower[i][k] * y[k]
    x = [y[i] * (1.0 / diagonal[i]) for i in range(n)]
    for i in reversed(range(n)):
        for k in range(i + 1, n):
            if lower[k][i] is not None:
                x[i] = x[i] - lower[k][i] * x[k]
    return x


__all__ = ["Mechanism"]

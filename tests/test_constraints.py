"""The joints' closed-form Phi_q, Phi_t and gamma equal forward-mode derivatives of Phi."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from jaxbearing.multibody import GROUND, Driver, Revolute, Translational

N = 9  # three bodies
Q = jnp.array([0.1, -0.2, 0.7, 0.4, 0.3, -1.1, -0.5, 0.2, 2.0])
QD = jnp.array([0.3, 1.2, -2.0, -0.7, 0.4, 3.0, 1.5, -0.2, 0.9])
T = jnp.asarray(0.37)

JOINTS = [
    Revolute(0, (0.2, -0.1), 1, (-0.3, 0.05)),
    Revolute(GROUND, (0.5, 0.1), 2, (0.1, 0.2)),
    Revolute(1, (0.0, 0.0), GROUND, (0.0, 0.0)),
    Translational(2, origin=(0.1, 0.3), line_angle=0.4, body_angle=0.2),
    Driver(1, angle=0.3, speed=62.8),
]


@jax.jit
def closed_and_derived(joint, q, qd, t):
    """(closed forms, forward-mode derivatives) of Phi_q, Phi_t and -gamma at (q, qd, t): one
    compiled program a joint, not one per operation."""

    def phi_dot(q, t):
        return jax.jvp(joint, (q, t), (qd, jnp.ones_like(t)))[1]

    # d/dt Phi_dot at zero acceleration = -gamma
    second = jax.jvp(phi_dot, (q, t), (qd, jnp.ones_like(t)))[1]
    derived = (jax.jacfwd(joint, argnums=0)(q, t), jax.jacfwd(joint, argnums=1)(q, t), second)
    closed = (joint.jacobian(q, t), joint.time_derivative(q, t), -joint.gamma(q, qd, t))
    return closed, derived


@pytest.mark.parametrize("joint", JOINTS, ids=lambda j: type(j).__name__)
def test_closed_forms_match_autodiff(joint):
    closed, derived = closed_and_derived(joint, Q, QD, T)
    for name, c, d, atol in zip(("Phi_q", "Phi_t", "gamma"), closed, derived, (1e-14, 1e-14, 1e-12)):
        np.testing.assert_allclose(c, d, atol=atol, err_msg=name)

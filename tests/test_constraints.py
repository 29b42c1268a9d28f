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


@pytest.mark.parametrize("joint", JOINTS, ids=lambda j: type(j).__name__)
def test_closed_forms_match_autodiff(joint):
    jac = jax.jacfwd(joint, argnums=0)(Q, T)
    phi_t = jax.jacfwd(joint, argnums=1)(Q, T)
    np.testing.assert_allclose(joint.jacobian(Q, T), jac, atol=1e-14)
    np.testing.assert_allclose(joint.time_derivative(Q, T), phi_t, atol=1e-14)

    def phi_dot(q, t):
        return jax.jvp(joint, (q, t), (QD, jnp.ones_like(t)))[1]

    # d/dt Phi_dot at zero acceleration = -gamma
    second = jax.jvp(phi_dot, (Q, T), (QD, jnp.ones_like(T)))[1]
    np.testing.assert_allclose(joint.gamma(Q, QD, T), -second, atol=1e-12)

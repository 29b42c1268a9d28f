"""Impact laws between two bodies (paper Sect. 2.2, Eqs. 23, 26–27) and a linear spring-damper.

Lankarani–Nikravesh normal force (Eq. 23):

    F_N = K_d delta^1.5 (1 + 3 (1 - e_c^2)/4 * delta_dot / delta_dot^(-))

with delta the penetration, delta_dot its rate and delta_dot^(-) the approach speed at the onset
of the current contact (captured per contact by `jaxbearing.simulate`). The hysteresis term is
derived for e_c near 1: at lower restitution the model dissipates less than asked, so the
effective restitution exceeds e_c (a known property, tested).

Ambrosio friction (Eqs. 26–27): F_T = -mu c_d F_N sign(v_T), with c_d ramping from 0 at
|v_T| = v0 to 1 at |v_T| = v1.
"""

from __future__ import annotations

import jax
import jax.numpy as jnp

from .._forms import power


def hertz(penetration, stiffness) -> jax.Array:
    """Elastic Hertz force K delta^1.5 [N] for delta > 0, else 0."""
    depth = jnp.where(penetration > 0.0, penetration, 0.0)
    return stiffness * power(depth, 1.5)


def lankarani_nikravesh(
    penetration, penetration_rate, approach_speed, stiffness, restitution
) -> jax.Array:
    """Normal contact force [N] (Eq. 23), zero when separated and clamped at >= 0.

    Args:
        penetration: delta [m] (> 0 in contact).
        penetration_rate: d delta/dt [m/s] (> 0 while approaching).
        approach_speed: delta_dot^(-) [m/s], the rate at the onset of this contact. A
            non-positive value (a contact that starts at rest) gives the elastic Hertz force.
        stiffness: K_d [N/m^1.5]. restitution: e_c in (0, 1].
    """
    safe_speed = jnp.where(approach_speed > 0.0, approach_speed, 1.0)
    hysteresis = jnp.where(
        approach_speed > 0.0,
        0.75 * (1.0 - restitution**2) * penetration_rate / safe_speed,
        0.0,
    )
    force = hertz(penetration, stiffness) * (1.0 + hysteresis)
    return jnp.where(penetration > 0.0, jnp.maximum(force, 0.0), 0.0)


def ambrosio_friction(normal_force, tangential_speed, friction, v0, v1) -> jax.Array:
    """Tangential friction force along the tangent t [N] (Eqs. 26–27), opposing v_T."""
    speed = jnp.abs(tangential_speed)
    c_d = jnp.clip((speed - v0) / (v1 - v0), 0.0, 1.0)
    return -friction * c_d * normal_force * jnp.sign(tangential_speed)


def spring_damper(extension, extension_rate, stiffness, damping) -> jax.Array:
    """Linear spring-damper tension k (l - l0) + c dl/dt [N] (positive pulls the ends together)."""
    return stiffness * extension + damping * extension_rate

"""Static capacity of a simulated bearing (ISO 76:2006): the basic static load rating C_0r of
its kind, the largest equivalent static load P_0r over a window (impacts included), the static
safety factor s_0 = C_0r / P_0r, and the largest Hertz contact stress of the most loaded rolling
element beside the standard's permissible one."""

from __future__ import annotations

import functools

import equinox as eqx
import jax
import jax.numpy as jnp

from .. import _checks, metrics
from ..laws import hertz
from ..multibody.mechanism import Mechanism
from ..params import RollerBearing
from ..solution import Solution
from ._ratings import roller_static_load_rating, static_load_rating
from ._solution import _solved_joint

# ISO 76:2006, 3.1: the contact stress at the centre of the most loaded contact under C_0r (SKF's
# General Catalogue quotes the same: 4 600 MPa self-aligning ball, 4 200 MPa other ball and
# 4 000 MPa all roller bearings, p. 52)
PERMISSIBLE_BALL = 4200e6  # [Pa] radial ball bearings (self-aligning ones excepted)
PERMISSIBLE_ROLLER = 4000e6  # [Pa] radial roller bearings
# bearing steel as ISO 76 (ISO/TR 10657) takes it for the contact stress
STEEL_MODULUS = 207e9  # [Pa]
STEEL_POISSON = 0.3
# groove conformities ISO 76's f_0 assumes (ISO/TR 10657)
ISO76_GROOVE_INNER, ISO76_GROOVE_OUTER = 0.52, 0.53


class StaticSafety(eqx.Module):
    """ISO 76 static capacity of a simulated bearing (`static_safety`).

    Fields:
        c0: basic static radial load rating C_0r [N].
        p0: largest equivalent static radial load P_0r over the window [N]: under a purely
            radial load, the peak bearing force |F| (impacts included).
        s0: static safety factor C_0r / P_0r [-].
        peak_element_load: Q_max, the largest rolling-element load over the window [N].
        contact_stress: the largest contact pressure of the element carrying Q_max [Pa] (Hertz:
            the more loaded of its inner and outer raceway contacts, the inner one for
            rollers).
        permissible_stress: ISO 76's contact stress under C_0r [Pa]: 4 200 MPa for ball
            bearings, 4 000 MPa for roller bearings.
    """

    c0: jax.Array
    p0: jax.Array
    s0: jax.Array
    peak_element_load: jax.Array
    contact_stress: jax.Array
    permissible_stress: jax.Array


def static_rating(b) -> jax.Array:
    """ISO 76's basic static radial load rating C_0r [N] of a bearing's parameters, by its kind:
    `static_load_rating` of a `BallBearing`, `roller_static_load_rating` of a `RollerBearing`."""
    if isinstance(b, RollerBearing):
        return roller_static_load_rating(
            b.n_balls, b.ball_diameter, b.pitch_diameter, b.roller_length
        )
    return static_load_rating(b.n_balls, b.ball_diameter, b.pitch_diameter)


def element_contact_stress(
    b, load, groove_inner=ISO76_GROOVE_INNER, groove_outer=ISO76_GROOVE_OUTER
) -> jax.Array:
    """Largest Hertz contact pressure [Pa] of one rolling element of the bearing ``b`` under the
    load Q [N], over its inner and outer raceway contacts, rings and elements of steel (E
    207 GPa, nu 0.3). A ball: point contacts (`hertz.point_contact_stress`) with the raceway
    conformities ``groove_inner``, ``groove_outer`` (f = r/D > 0.5; a `BallBearing` does not
    store them, the defaults are those ISO 76 assumes). A roller: line contacts of its length
    L_we (`hertz.line_contact_stress`); the conformities are not used."""
    if isinstance(b, RollerBearing):
        rho_i, rho_o = hertz.roller_curvature_sums(b.ball_diameter, b.pitch_diameter)
        rho = jnp.maximum(rho_i, rho_o)
        return hertz.line_contact_stress(load, b.roller_length, rho, STEEL_MODULUS, STEEL_POISSON)
    rho_i, f_i, rho_o, f_o = hertz.curvature_sums(
        b.ball_diameter, b.pitch_diameter, groove_inner, groove_outer
    )
    inner = hertz.point_contact_stress(load, rho_i, f_i, STEEL_MODULUS, STEEL_POISSON)
    outer = hertz.point_contact_stress(load, rho_o, f_o, STEEL_MODULUS, STEEL_POISSON)
    return jnp.maximum(inner, outer)


def static_safety(
    sol: Solution,
    model: Mechanism,
    bearing: int | None = None,
    *,
    t_min="model",
    t_max=None,
    groove_inner=ISO76_GROOVE_INNER,
    groove_outer=ISO76_GROOVE_OUTER,
) -> StaticSafety:
    """ISO 76 static capacity of the simulated bearing over a window: C_0r from its geometry
    (`static_rating`), P_0r = the peak bearing force |F| (a radial bearing under radial load;
    every solver step's interpolant, so impacts count at their peak), s_0 = C_0r / P_0r, and
    the contact stress of the most loaded element (`element_contact_stress` at the peak element
    load) beside the permissible 4 200 MPa (balls) or 4 000 MPa (rollers).

    Args:
        sol, model: a `simulate` result and the model that produced it.
        bearing: index of the bearing joint in ``model.bearings`` (None: the only one).
        t_min, t_max: window [s] ("model": the model's ``window_start``; None: unbounded), as
            for the metrics: its edges must be stops of the solve.
        groove_inner, groove_outer: raceway conformities f = r/D of a ball bearing (ISO 76's
            0.52 and 0.53 by default; `cases.xu2014`: `cases.GROOVE_INNER`, `GROOVE_OUTER`).

    s_0 >= 1 keeps the permanent deformation of the most loaded contact below about 1e-4 of the
    element diameter (ISO 76); impacts and shocks usually call for s_0 of 1.5–2 or more.
    """
    b = _solved_joint(sol, model, bearing).bearing
    metrics.bearing_index(sol, bearing)  # checked before the window, as the metrics do
    edges = metrics.checked_window(sol, t_min, t_max)
    grooves = _checks.as_floats((groove_inner, "groove_inner", "-"), (groove_outer, "groove_outer", "-"))
    if not isinstance(b, RollerBearing):  # a roller's line contacts have no conformity
        _checks.check(hertz.groove_rules, *grooves)
    return _static_safety(sol, b, bearing, *edges, static_rating(b), *grooves)


@functools.partial(jax.jit, static_argnums=2)
def _static_safety(sol, b, bearing, lo, hi, c0, groove_inner, groove_outer) -> StaticSafety:
    """`static_safety` over [lo, hi] [s] with C_0r = ``c0`` [N]."""
    p0 = metrics.peak_bearing_force(sol, lo, hi, bearing=bearing)
    q_max = metrics.peak_ball_load(sol, lo, hi, bearing=bearing)
    stress = element_contact_stress(b, q_max, groove_inner, groove_outer)
    permissible = PERMISSIBLE_ROLLER if isinstance(b, RollerBearing) else PERMISSIBLE_BALL
    return StaticSafety(c0, p0, c0 / p0, q_max, stress, jnp.asarray(permissible, jnp.float64))

"""The rules on an elastic material's and a rolling bearing's numbers (E, nu; the element
count, their fit on the pitch circle, the contact angle) that the laws (`hertz`), the bearing
parameters (`jaxbearing.params`) and the load ratings (`jaxbearing.life`) share, each a
``(is_wrong, message, value)`` of `jaxbearing._checks` in the array module ``xp``. They live
with the laws, the lowest stage that reads them, so that no stage imports a later one."""

from __future__ import annotations

from .._checks import in_open_interval, positive


def material(xp, youngs_modulus, poisson_ratio, youngs_name="youngs_modulus", poisson_name="poisson_ratio"):
    """Rules of an elastic material: E > 0 [Pa], nu in (0, 0.5), named as given."""
    return [
        positive(xp, youngs_name, youngs_modulus, "Pa"),
        in_open_interval(xp, poisson_name, poisson_ratio, 0.0, 0.5),
    ]


def ball_count(xp, n_balls, name="n_balls"):
    """A bearing has an integer number of rolling elements, at least 3 (``name``: the argument
    as the user types it, ``n_balls`` or ``n_rollers``)."""
    z = xp.asarray(n_balls)
    return ((z < 3) | (z != xp.round(z)), f"{name} must be an integer of at least 3", n_balls)


def balls_fit(xp, n_balls, ball_diameter, pitch_diameter, element="ball"):
    """The rolling elements fit around the pitch circle without overlapping: neighbours'
    centres lie d_m sin(pi/Z) apart, so D < d_m sin(pi/Z). ``element``: "ball" or "roller",
    as the arguments are named (``ball_diameter``, ``n_balls`` or ``roller_diameter``,
    ``n_rollers``)."""
    z, d, dm = (xp.asarray(v) for v in (n_balls, ball_diameter, pitch_diameter))
    return (
        d >= dm * xp.sin(xp.pi / xp.maximum(z, 1.0)),
        (
            f"{element}_diameter must be below pitch_diameter * sin(pi / n_{element}s), or the "
            f"{element}s overlap on the pitch circle [m]"
        ),
        ball_diameter,
    )


def pitch_exceeds_ball(xp, pitch_diameter, ball_diameter):
    """The pitch circle is wider than a ball: d_m > D [m]."""
    return (
        xp.asarray(pitch_diameter) <= xp.asarray(ball_diameter),
        "pitch_diameter must exceed ball_diameter [m]",
        pitch_diameter,
    )


def contact_angle_rule(xp, contact_angle):
    """A bearing's contact angle alpha lies in [0, pi/2) [rad]."""
    alpha = xp.asarray(contact_angle)
    return ((alpha < 0.0) | (alpha >= 0.5 * xp.pi), "contact_angle must lie in [0, pi/2) [rad]", contact_angle)

"""Pure force laws: bearing balls (Eqs. 9–15, 28), impact (Eqs. 23–27), Hertz stiffness (Eqs. 10–11, 24–25),
plain bearings (`journal`: a journal's contact stiffness, the short-bearing film force)."""

from . import hertz, journal
from .bearing import (
    ball_angles,
    ball_deflections,
    ball_directions,
    ball_loads,
    cage_speed,
    resultant,
    ring_point_loads,
    smooth_ramp,
)
from .impact import ambrosio_friction, hertz as hertz_force, lankarani_nikravesh, spring_damper

__all__ = [
    "ambrosio_friction",
    "ball_angles",
    "ball_deflections",
    "ball_directions",
    "ball_loads",
    "cage_speed",
    "hertz",
    "hertz_force",
    "journal",
    "lankarani_nikravesh",
    "resultant",
    "ring_point_loads",
    "smooth_ramp",
    "spring_damper",
]

"""A second mechanism from the same pieces: a rigid rotor hung in a rolling bearing (a
`BallBearing` or a `RollerBearing`).

A disc (body 0) is held only by its bearing, whose outer race is fixed to ground at the origin
and whose inner race is the disc's centre. A driver spins it at a constant speed, gravity pulls
it onto the lower balls, and an unbalance (the centroid offset from the bearing axis) whirls it.
"""

from __future__ import annotations

from ..multibody import GROUND, BearingJoint, Body, Driver, Gravity, Mechanism
from ..params import AbstractBearing


def rotor(
    bearing: AbstractBearing,
    *,
    mass=2.0,
    inertia=2e-3,
    speed=0.0,
    eccentricity=0.0,
    initial_offset=(0.0, 0.0),
    initial_velocity=(0.0, 0.0),
    gravity=(0.0, -9.80665),
    driven=True,
    window_start=None,
) -> Mechanism:
    """A disc of ``mass`` [kg] and ``inertia`` [kg m^2] in ``bearing``.

    Args:
        speed: spin [rad/s] (held by a driver if ``driven``, else the initial spin).
        eccentricity: unbalance, distance of the centroid from the bearing axis [m].
        initial_offset, initial_velocity: of the bearing axis from the outer-race centre [m],
            [m/s] at t = 0 (the disc starts with its centroid at +x of the axis).
        gravity: [m/s^2], or None.
        window_start: where the metrics' default window starts [s]; None: the whole span.
    """
    centre = (-eccentricity, 0.0)  # bearing axis in the disc frame
    q0 = [initial_offset[0] + eccentricity, initial_offset[1], 0.0]
    qd0 = [initial_velocity[0], initial_velocity[1] + speed * eccentricity, speed]
    joints = (Driver(0, angle=0.0, speed=speed),) if driven else ()
    return Mechanism(
        (Body(mass, inertia),),
        joints,
        q0,
        qd0,
        forces=(BearingJoint(GROUND, (0.0, 0.0), 0, centre, bearing),)
        + (() if gravity is None else (Gravity(gravity),)),
        body_names=("rotor",),
        window_start=window_start,
    )

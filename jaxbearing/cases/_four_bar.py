"""A crank–rocker four-bar with a ball bearing at the coupler–rocker joint, built from the public
pieces and assembled from a rough guess (`Mechanism.assemble`).

Bodies, in order: 0 crank, 1 coupler, 2 rocker, each a uniform slender link (centroid at its
middle, inertia m L^2 / 12). The crank turns about the origin, driven at constant speed; the
rocker turns about the ground pivot at (ground, 0); the bearing's outer race is in the rocker's
end, its inner race on the coupler's end. Gravity acts along -y.
"""

from __future__ import annotations

import numpy as np

from ..multibody import GROUND, BearingJoint, Body, Driver, Gravity, Mechanism, Revolute
from ..params import AbstractBearing
from ._xu2014 import skf98205

LENGTHS = (0.30, 0.10, 0.28, 0.25)  # [m] ground, crank, coupler, rocker (a crank–rocker: Grashof)
MASSES = (0.5, 1.0, 0.8)  # [kg] crank, coupler, rocker


def four_bar(
    bearing: AbstractBearing | None = None,
    *,
    lengths=LENGTHS,
    masses=MASSES,
    crank_speed=1000.0 * 2.0 * np.pi / 60.0,
    gravity=(0.0, -9.80665),
    window_start=None,
) -> Mechanism:
    """The four-bar at crank angle 0 (crank along +x), assembled with the bearing centred.

    Args:
        bearing: at the coupler–rocker joint (default `skf98205()`, the paper's bearing).
        lengths: ground, crank, coupler, rocker [m]: pivots at the origin and (ground, 0).
        masses: crank, coupler, rocker [kg], uniform slender links.
        crank_speed: [rad/s] (1000 rpm), held by a driver.
        gravity: [m/s^2], or None.
        window_start: where the metrics' default window starts [s]; None: the whole span.
    """
    ground, crank, coupler, rocker = (float(x) for x in lengths)
    bearing = skf98205() if bearing is None else bearing
    bodies = tuple(Body(m, m * length**2 / 12.0) for m, length in zip(masses, (crank, coupler, rocker)))
    joints = (
        Revolute(GROUND, (0.0, 0.0), 0, (-crank / 2, 0.0)),
        Driver(0, angle=0.0, speed=crank_speed),
        Revolute(0, (crank / 2, 0.0), 1, (-coupler / 2, 0.0)),
        Revolute(GROUND, (ground, 0.0), 2, (-rocker / 2, 0.0)),
    )
    forces = (BearingJoint(2, (rocker / 2, 0.0), 1, (coupler / 2, 0.0), bearing),)
    if gravity is not None:
        forces += (Gravity(gravity),)
    # a rough guess: the coupler level above the crank pin, the rocker upright; the assembly
    # moves it onto the joints (elbow up)
    guess = [crank / 2, 0.0, 0.0, crank + coupler / 2, rocker / 2, 0.0, ground, rocker / 2, np.pi / 2]
    model = Mechanism(
        bodies,
        joints,
        guess,
        forces=forces,
        body_names=("crank", "coupler", "rocker"),
        window_start=window_start,
    )
    return model.assemble()

"""Planar multibody core: bodies, joints, force elements and the equations of motion (Eq. 36)."""

from .bodies import GROUND, Body, point_force, point_position, point_velocity, rotate
from .constraints import Driver, Revolute, Translational
from .forces import BearingJoint, CircleContact, Gravity, SpringDamper
from .mechanism import Mechanism

__all__ = [
    "GROUND",
    "BearingJoint",
    "Body",
    "CircleContact",
    "Driver",
    "Gravity",
    "Mechanism",
    "Revolute",
    "SpringDamper",
    "Translational",
    "point_force",
    "point_position",
    "point_velocity",
    "rotate",
]

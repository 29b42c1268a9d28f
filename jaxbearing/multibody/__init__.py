"""Planar multibody core: bodies, joints, force elements and the equations of motion (Eq. 36)."""

from .bodies import GROUND, Body, point_force, point_position, point_velocity, rotate
from .constraints import AbstractJoint, Driver, JacobianRows, Revolute, Translational
from .forces import AbstractForceElement, BearingJoint, CircleContact, ForceInputs, Gravity, SpringDamper
from .mechanism import Mechanism

__all__ = [
    "GROUND",
    "AbstractForceElement",
    "AbstractJoint",
    "BearingJoint",
    "Body",
    "CircleContact",
    "Driver",
    "ForceInputs",
    "Gravity",
    "JacobianRows",
    "Mechanism",
    "Revolute",
    "SpringDamper",
    "Translational",
    "point_force",
    "point_position",
    "point_velocity",
    "rotate",
]

"""Planar multibody core: bodies, joints, force elements (one protocol, `AbstractForceElement`;
the plain bearing, `ClearanceJoint` with its `JournalBearing`, in `clearance`) and the equations
of motion (Eq. 36)."""

from .bodies import GROUND, Body, point_force, point_position, point_velocity, rotate
from .clearance import ClearanceJoint, JournalBearing
from .constraints import AbstractJoint, Driver, JacobianRows, Revolute, Translational
from .forces import (
    AbstractForceElement,
    BearingJoint,
    CircleContact,
    ContactState,
    ForceInputs,
    Gravity,
    IntegralRecord,
    PeakRecord,
    SpringDamper,
)
from .mechanism import Mechanism

__all__ = [
    "GROUND",
    "AbstractForceElement",
    "AbstractJoint",
    "BearingJoint",
    "Body",
    "CircleContact",
    "ClearanceJoint",
    "ContactState",
    "Driver",
    "ForceInputs",
    "Gravity",
    "IntegralRecord",
    "JacobianRows",
    "JournalBearing",
    "Mechanism",
    "PeakRecord",
    "Revolute",
    "SpringDamper",
    "Translational",
    "point_force",
    "point_position",
    "point_velocity",
    "rotate",
]

"""The paper's impact slider–crank with an SKF 98205 bearing (Xu 2014, Sect. 3;
docs/model.md, 'The paper's case').

Bodies, in order: 0 crank, 1 connecting rod, 2 slider, 3 target (the paper's bodies 2–5).
The crank turns about the origin at 600 rpm; the bearing joins the crank's far end (outer race)
to the rod's near end (inner race); the slider and target slide along the x axis; the target
hangs on a spring-damper to ground and is struck by the slider through a Lankarani–Nikravesh
contact of two 10 mm circles, switched on after half a crank turn (t >= 0.05 s). The model's
metrics window starts at `WINDOW_START`, after the start-up transient (docs/model.md).
"""

from __future__ import annotations

import numpy as np

from ..multibody import (
    GROUND,
    BearingJoint,
    Body,
    CircleContact,
    ClearanceJoint,
    Driver,
    JournalBearing,
    Mechanism,
    Revolute,
    SpringDamper,
    Translational,
)
from ..params import (
    CATALOGUE,
    ROLLER_CATALOGUE,
    AbstractBearing,
    BallBearing,
    Impact,
    RollerBearing,
)

CRANK_LENGTH = 0.050  # [m]
ROD_LENGTH = 0.120  # [m]
SPRING_FREE_LENGTH = 0.1  # [m], any positive value: the spring is unstressed at the start
# raceway groove curvature ratios f = r/D that reproduce the paper's K_i, K_o
GROOVE_INNER, GROOVE_OUTER = CATALOGUE["98205"]["groove_inner"], CATALOGUE["98205"]["groove_outer"]
SLIDER = 2  # body index of the slider
TARGET = 3  # body index of the target
WINDOW_START = 0.04  # [s] the metrics' default window starts after the rod fell onto the race and rang
FIGURE_WINDOW = (WINDOW_START, 0.14)  # [s] one crank revolution, the window of the paper's Figs. 12–15

# Paper Table 5: ball loads [N] without impact, kinematic cage; rows ball 1..8, columns TABLE5_TIMES.
TABLE5_TIMES = np.array([0.04, 0.06, 0.08, 0.10, 0.12])
TABLE5 = np.array(
    [
        [0.0, 0.0, 0.0, 0.0, 0.0],
        [42.9, 92.2, 0.0, 0.0, 0.0],
        [109.7, 64.8, 53.1, 24.9, 0.0],
        [0.0, 0.0, 0.0, 193.8, 0.0],
        [0.0, 0.0, 0.0, 45.1, 40.7],
        [0.0, 0.0, 0.0, 0.0, 0.0],
        [0.0, 0.0, 0.0, 0.0, 0.0],
        [0.0, 0.0, 0.0, 0.0, 0.0],
    ]
)


def skf98205(
    cage="kinematic", ball_force="paper", clearance=0.04e-3, damping=300.0
) -> BallBearing:
    """SKF 98205 (paper Table 2): d_m 37.9 mm, D 8.7 mm, 8 balls, E 207 GPa, nu 0.3, and the
    groove curvature ratios f_i = 0.5219, f_o = 0.5194 that reproduce the paper's K_i, K_o
    (docs/model.md, 'Groove curvature ratios'): `BallBearing.from_catalogue("98205")`."""
    return BallBearing.from_catalogue(
        "98205", clearance=clearance, damping=damping, cage=cage, ball_force=ball_force
    )


def _catalogue_bearing(designation: str, **kwargs) -> AbstractBearing:
    """The catalogue bearing ``designation``: `BallBearing.from_catalogue` for the keys of
    `params.CATALOGUE`, `RollerBearing.from_catalogue` for those of `params.ROLLER_CATALOGUE`;
    keyword arguments go to it (clearance, damping, cage, ball_force)."""
    if designation in ROLLER_CATALOGUE:
        return RollerBearing.from_catalogue(designation, **kwargs)
    if designation in CATALOGUE:
        return BallBearing.from_catalogue(designation, **kwargs)
    raise ValueError(
        f"bearing must be a BallBearing, a RollerBearing or one of the designations "
        f"{sorted(CATALOGUE) + sorted(ROLLER_CATALOGUE)}; got {designation!r}."
    )


def xu2014(
    impact: bool = True,
    cage="kinematic",
    ball_force="paper",
    *,
    clearance=0.04e-3,
    bearing_damping=300.0,
    restitution=0.9,
    friction=0.0,
    crank_speed=20.0 * np.pi,
    contact_on=0.05,
    window_start=WINDOW_START,
    bearing: str | AbstractBearing | JournalBearing | None = "98205",
) -> Mechanism:
    """The paper's impact slider–crank (Tables 1–4), SI units.

    Args:
        impact: include the slider–target contact (False: the paper's case without impact).
        cage, ball_force: see `BallBearing`.
        clearance: P_d, diametral [m]. bearing_damping: C_b [N s/m].
        restitution: e_c. friction: mu of the slider–target contact.
        crank_speed: [rad/s] (600 rpm). contact_on: time the contact is switched on [s].
        window_start: where the metrics' default window starts [s] (`WINDOW_START`, after the
            start-up transient); None: the whole span.
        bearing: the crank–rod bearing: a catalogue designation (`params.CATALOGUE`: "98205",
            the paper's SKF 98205; `params.ROLLER_CATALOGUE`: "NU205-estimated", a cylindrical
            roller bearing of the same envelope, "NU206" or "209"), built with ``cage``,
            ``ball_force``, ``clearance`` and ``bearing_damping``; or a `BallBearing` or
            `RollerBearing` itself; or a plain bearing, a `JournalBearing` (a `ClearanceJoint`,
            its hole on the crank, its journal on the rod); or None, an ideal pin (a
            `Revolute`). Where it is not a designation, those four must keep their defaults.
    """
    if isinstance(bearing, str):
        bearing = _catalogue_bearing(
            bearing, clearance=clearance, damping=bearing_damping, cage=cage, ball_force=ball_force
        )
    elif (cage, ball_force, clearance, bearing_damping) != ("kinematic", "paper", 0.04e-3, 300.0):
        raise ValueError(
            "xu2014: give cage, ball_force, clearance and bearing_damping to the bearing passed "
            "as bearing=, not to xu2014."
        )
    l2, l3 = CRANK_LENGTH, ROD_LENGTH
    bodies = (
        Body(0.75, 5.2e-4),  # crank
        Body(0.67, 1.2e-3),  # connecting rod
        Body(0.30, 1e-4),  # slider: cannot rotate, any positive inertia
        Body(0.10, 1e-4),  # target: likewise
    )
    joints = (
        Revolute(GROUND, (0.0, 0.0), 0, (-l2 / 2, 0.0)),
        Driver(0, angle=0.0, speed=crank_speed),
        Revolute(1, (l3 / 2, 0.0), 2, (0.0, 0.0)),
        Translational(2),
        Translational(3),
    )
    x_target = l2 + l3 + 0.010
    if bearing is None:  # the crank pin is an ideal joint
        joints += (Revolute(0, (l2 / 2, 0.0), 1, (-l3 / 2, 0.0)),)
        forces = ()
    else:
        joint = ClearanceJoint if isinstance(bearing, JournalBearing) else BearingJoint
        forces = (joint(0, (l2 / 2, 0.0), 1, (-l3 / 2, 0.0), bearing),)
    forces += (
        SpringDamper(
            GROUND, (x_target + SPRING_FREE_LENGTH, 0.0), 3, (0.0, 0.0), 100e3, 120.0, SPRING_FREE_LENGTH
        ),
    )
    if impact:
        contact = Impact.from_geometry(
            radius_j=0.01, radius_k=0.01, restitution=restitution, friction=friction
        )
        forces += (CircleContact(2, (0.0, 0.0), 0.01, 3, (0.0, 0.0), 0.01, contact, contact_on),)
    w = crank_speed
    q0 = [l2 / 2, 0.0, 0.0, l2 + l3 / 2, 0.0, 0.0, l2 + l3, 0.0, 0.0, x_target, 0.0, 0.0]
    qd0 = [0.0, w * l2 / 2, w, 0.0, w * l2 / 2, -w * l2 / l3, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0]
    return Mechanism(
        bodies,
        joints,
        q0,
        qd0,
        forces=forces,
        body_names=("crank", "rod", "slider", "target"),
        window_start=window_start,
    )

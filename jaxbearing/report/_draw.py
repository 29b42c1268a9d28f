"""A picture of any planar machine (`draw`) and the scene that `animate` moves, in matplotlib's
object API (no pyplot, no global backend switch) and NumPy on concrete values.

What is drawn, at any coordinates q (SI units, equal axes):

- each body as a link through the points its joints and elements hold (a line through two or
  more points in a row, the convex outline of more), its centroid marked and its name written
  there (``model.body_names``);
- revolute joints as pins at both bodies' points, translational joints as a block on a rail,
  drivers as an arrow round the driven body, ground points as hatched marks;
- force elements by kind (`ELEMENTS`, a dict from the element's class to its `Kind`): a
  bearing's outer and inner raceways and its rolling elements at their cage angle (Eq. 14),
  the radial clearance and the eccentricity drawn enlarged by a stated factor; a plain
  bearing's (`ClearanceJoint`'s) hole and journal, its clearance and eccentricity enlarged by
  the same factor; a contact's two circles; a spring's zigzag; gravity as an arrow. A kind not
  in `ELEMENTS` is drawn as a dotted line between the centroids of the bodies it acts on,
  labelled by its class name.
  Elements are labelled by their index: ``bearing i`` into ``model.bearings``, ``contact i``
  into ``model.contacts``, ``force k`` into ``model.forces``.

Artists carry a gid (``"joint 2"``, ``"bearing 0 outer"``, ``"body 1"``) by which a test or a
user finds them. The ``"joint k"`` artist of a revolute joint holds its two bodies' points, that
of a translational joint the body's centroid and its foot on the rail: they coincide where the
joint holds.
"""

from __future__ import annotations

import math
import sys
from collections.abc import Callable
from typing import NamedTuple

import numpy as np

from .. import _checks
from ..laws import bearing as bearing_law
from ..multibody import (
    GROUND,
    BearingJoint,
    CircleContact,
    ClearanceJoint,
    Driver,
    Gravity,
    Revolute,
    SpringDamper,
    Translational,
)

CLEARANCE_SHOWN = 0.3  # the automatic factor draws a radial clearance P_d/2 as at most this
# fraction of the rolling element's diameter, and a journal's radial clearance as at most this
# fraction of its radius
SYMBOL = 0.04  # size of pins, blocks, ground marks and driver arrows, a fraction of the machine's
GROUND_COLOUR = "0.35"
LABEL = {"fontsize": 7, "color": "0.25", "textcoords": "offset points"}


class Frame(NamedTuple):
    """What a picture shows at one instant: coordinates ``q`` (n_coordinates,) [m, rad], each
    bearing's cage angle [rad] (``model.bearings`` order) and, for load bars, each bearing's
    rolling-element loads (N_b,) [N] (None: no bars)."""

    q: np.ndarray
    cages: tuple
    loads: tuple | None = None


class Entry(NamedTuple):
    """A force element to draw: its ``label`` (``"bearing 0"``), the ``element`` and its index
    into ``model.bearings`` (None for any other kind)."""

    label: str
    element: object
    bearing: int | None = None


class Kind(NamedTuple):
    """How a kind of force element is drawn: ``points(element)`` the (body, body-frame point)
    pairs it holds, which the bodies' links pass through; ``draw(scene, entry)`` adds its
    artists and returns the function that moves them to a `Frame`."""

    points: Callable
    draw: Callable


def place(q, body: int, point) -> np.ndarray:
    """Global position [m] of body-frame point(s) ``point`` (..., 2) of ``body`` at ``q``
    (n_coordinates,) or (T, n_coordinates) (Eq. 2; `multibody.point_position` in NumPy)."""
    point = np.asarray(point, dtype=float)
    if body == GROUND:
        return np.broadcast_to(point, np.shape(q)[:-1] + point.shape).copy()
    x, y, theta = (np.asarray(q, dtype=float)[..., 3 * body + i] for i in range(3))
    c, s = np.cos(theta), np.sin(theta)
    if point.ndim > 1:
        x, y, c, s = x[..., None], y[..., None], c[..., None], s[..., None]
    return np.stack(
        [x + c * point[..., 0] - s * point[..., 1], y + s * point[..., 0] + c * point[..., 1]], -1
    )


def colour(body: int) -> str:
    """A body's colour (matplotlib's cycle); ground's grey."""
    return GROUND_COLOUR if body == GROUND else f"C{body % 10}"


def nice_floor(x: float) -> float:
    """The largest 1, 2 or 5 x 10^n not above ``x`` > 0."""
    decade = 10.0 ** math.floor(math.log10(x))
    return max(m * decade for m in (1.0, 2.0, 5.0) if m * decade <= x * (1 + 1e-12))


def default_clearance_scale(model) -> float:
    """The factor by which `draw` and `animate` enlarge the clearances and eccentricities of
    the bearings and the plain bearings: the largest 1, 2 or 5 x 10^n at which every bearing's
    radial clearance P_d/2 appears at most `CLEARANCE_SHOWN` of its rolling element's
    diameter, and every journal's clearance c at most `CLEARANCE_SHOWN` of its radius, and at
    least 1 (1 where none has a clearance)."""
    factors = [
        CLEARANCE_SHOWN * float(b.bearing.ball_diameter) / (0.5 * float(b.bearing.clearance))
        for b in model.bearings
        if float(b.bearing.clearance) > 0.0
    ]
    factors += [
        CLEARANCE_SHOWN * float(j.journal.radius) / float(j.journal.clearance)
        for j in journals(model)
    ]
    return max(nice_floor(min(factors)), 1.0) if factors else 1.0


def journals(model) -> list:
    """The plain bearings (`ClearanceJoint`) of ``model``, ``model.forces`` order."""
    return [f for f in model.forces if isinstance(f, ClearanceJoint)]


def has_play(model) -> bool:
    """Whether ``model`` has a bearing or a plain bearing, whose clearance a picture enlarges."""
    return bool(model.bearings) or bool(journals(model))


def elements(model) -> list[Entry]:
    """Every force element of ``model``, each once: its bearings and its contacts labelled by
    their index in those views, gravity as such, the others by their index in
    ``model.forces``."""
    entries = [Entry(f"bearing {i}", b, i) for i, b in enumerate(model.bearings)]
    entries += [Entry(f"contact {i}", c) for i, c in enumerate(model.contacts)]
    for k, f in enumerate(model.forces):
        if not isinstance(f, (BearingJoint, CircleContact)):
            entries.append(Entry("gravity" if isinstance(f, Gravity) else f"force {k}", f))
    return entries


def cage_angles(model, q, t) -> tuple:
    """Each bearing's cage angle [rad] at (t, q) (`BearingJoint.cage_angle`)."""
    return tuple(float(b.cage_angle(t, q, model.q0, model.qd0)) for b in model.bearings)


def _joint_points(joint) -> list[tuple[int, np.ndarray]]:
    if isinstance(joint, Revolute):
        return [(joint.body_i, joint.point_i), (joint.body_j, joint.point_j)]
    if isinstance(joint, Translational):
        return [(joint.body, np.zeros(2))]
    return []


def _outline(points: np.ndarray) -> np.ndarray:
    """A link through body-frame points (m, 2): the segment between the extremes of points in a
    row (to the centroid for one point), else their convex outline, closed."""
    points = np.unique(np.round(np.asarray(points, dtype=float).reshape(-1, 2), 15), axis=0)
    if len(points) == 0:
        return np.zeros((1, 2))
    if len(points) == 1:
        return np.vstack([points, np.zeros((1, 2))])
    centred = points - points.mean(0)
    _, singular, axes = np.linalg.svd(centred)
    if singular[1] <= 1e-9 * singular[0]:
        along = centred @ axes[0]
        return points[[np.argmin(along), np.argmax(along)]]
    return _hull(points)


def _hull(points: np.ndarray) -> np.ndarray:
    """The convex hull of points (m, 2), closed (Andrew's monotone chain)."""
    order = sorted(map(tuple, points))

    def turns_left(o, a, b) -> bool:
        return (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0]) > 0

    def half(seq):
        chain = []
        for p in seq:
            while len(chain) >= 2 and not turns_left(chain[-2], chain[-1], p):
                chain.pop()
            chain.append(p)
        return chain[:-1]

    ring = half(order) + half(order[::-1])
    return np.array(ring + ring[:1])


def _zigzag(a, b, width: float, coils: int = 6) -> np.ndarray:
    """A spring's zigzag from a to b [m], straight ends of a sixth of its length."""
    d = b - a
    length = math.hypot(*d)
    if length == 0.0:
        return np.array([a, b])
    normal = np.array([-d[1], d[0]]) / length
    s = np.linspace(1 / 6, 5 / 6, 2 * coils + 1)
    side = width * np.where(np.arange(s.size) % 2, 1.0, -1.0)
    side[[0, -1]] = 0.0
    zig = a + s[:, None] * d + side[:, None] * normal
    return np.vstack([a, zig, b])


class Scene:
    """The artists of one machine on one Axes and how to move them to a `Frame`.

    Args:
        ax: the matplotlib Axes.
        model: a `Mechanism` with concrete values (NumPy leaves: `_checks.on_host`).
        frame: the first `Frame`.
        clearance_scale: the factor bearings' clearances and eccentricities are drawn by.
        load_scale: [m/N] the length of a rolling element's load bar per newton; None: no bars.
        labels: write the bodies' names and the elements' labels.
    """

    def __init__(
        self, ax, model, frame: Frame, clearance_scale: float, load_scale=None, labels=True
    ):
        self.ax, self.model = ax, model
        self.clearance_scale, self.load_scale, self.labels = clearance_scale, load_scale, labels
        self.entries = elements(model)
        self.size = self._size(frame.q)
        self.updates: list[Callable] = []
        for b in range(len(model.bodies)):
            self._body(b)
        for k, joint in enumerate(model.joints):
            self._joint(k, joint)
        for entry in self.entries:
            self.updates.append(ELEMENTS.get(type(entry.element), UNKNOWN).draw(self, entry))
        self.update(frame)

    def update(self, frame: Frame) -> None:
        """Move every artist to ``frame``."""
        for update in self.updates:
            if update is not None:
                update(frame)

    # -- helpers ------------------------------------------------------------------------------
    def _size(self, q) -> float:
        """The machine's size [m]: the larger side of the box round its points and circles."""
        points = [np.zeros((1, 2))] + [
            place(q, body, np.asarray(point).reshape(-1, 2)) for body, point in self.body_points()
        ]
        points += [place(q, b, np.zeros((1, 2))) for b in range(len(self.model.bodies))]
        points = np.vstack(points)
        size = float(np.max(np.ptp(points, axis=0)))
        for entry in self.entries:
            if isinstance(entry.element, BearingJoint):
                size = max(size, float(entry.element.bearing.outer_race_diameter))
            elif isinstance(entry.element, CircleContact):
                size = max(
                    size, 2 * float(entry.element.radius_j), 2 * float(entry.element.radius_k)
                )
            elif isinstance(entry.element, ClearanceJoint):
                size = max(size, 2 * float(entry.element.journal.hole_radius))
        return size if size > 0.0 else 0.1

    def body_points(self) -> list[tuple[int, np.ndarray]]:
        """Every (body, body-frame point) that a joint or an element holds."""
        pairs = [pair for joint in self.model.joints for pair in _joint_points(joint)]
        for entry in self.entries:
            pairs += ELEMENTS.get(type(entry.element), UNKNOWN).points(entry.element)
        return pairs

    def line(self, *, gid: str, zorder: float = 2.0, **style):
        (artist,) = self.ax.plot([], [], gid=gid, zorder=zorder, **style)
        return artist

    def label(self, text: str, offset=(4, 4)):
        """A movable label (its ``xy`` is set by the caller), or None without labels."""
        if not self.labels:
            return None
        return self.ax.annotate(text, (0.0, 0.0), xytext=offset, zorder=5, **LABEL)

    def ground_mark(self, point, gid: str) -> None:
        """A fixed hatched mark under a ground point [m]."""
        h = SYMBOL * self.size
        x, y = point
        self.ax.plot(
            [x, x - h / 2, x + h / 2, x],
            [y, y - h, y - h, y],
            color=GROUND_COLOUR,
            lw=1.0,
            gid=gid,
            zorder=1.5,
        )
        hatch_x = np.linspace(x - h / 2, x + h / 2, 5)
        segments = [[(u, y - h), (u - h / 3, y - 1.35 * h)] for u in hatch_x]
        xs = [p for seg in segments for p in (seg[0][0], seg[1][0], np.nan)]
        ys = [p for seg in segments for p in (seg[0][1], seg[1][1], np.nan)]
        self.ax.plot(xs, ys, color=GROUND_COLOUR, lw=0.8, gid=gid, zorder=1.5)

    # -- bodies and joints ----------------------------------------------------------------------
    def _body(self, b: int) -> None:
        mine = [np.asarray(point) for body, point in self.body_points() if body == b]
        outline = _outline(np.array(mine) if mine else np.zeros((0, 2)))
        link = self.line(
            gid=f"body {b}", color=colour(b), lw=5.0, alpha=0.45, solid_capstyle="round", zorder=1.0
        )
        centroid = self.line(
            gid=f"body {b} centroid",
            color=colour(b),
            marker="o",
            ms=4.5,
            mfc="white",
            ls="none",
            zorder=3.5,
        )
        name = self.label(self.model.body_names[b], (5, -11))

        def update(frame):
            link.set_data(*place(frame.q, b, outline).T)
            centre = place(frame.q, b, np.zeros(2))
            centroid.set_data([centre[0]], [centre[1]])
            if name is not None:
                name.xy = centre

        self.updates.append(update)

    def _joint(self, k: int, joint) -> None:
        gid = f"joint {k}"
        if isinstance(joint, Revolute):
            for body, point in _joint_points(joint):
                if body == GROUND:
                    self.ground_mark(np.asarray(point, dtype=float), f"{gid} ground")
            pins = self.line(
                gid=gid, marker="o", ms=6, mfc="white", mec="k", mew=1.0, ls="none", zorder=4.0
            )

            def update(frame):
                xy = np.array([place(frame.q, body, point) for body, point in _joint_points(joint)])
                pins.set_data(*xy.T)

        elif isinstance(joint, Translational):
            origin = np.asarray(joint.origin, dtype=float)
            along = np.array([math.cos(float(joint.line_angle)), math.sin(float(joint.line_angle))])
            self.ax.axline(
                origin,
                origin + along,
                color=GROUND_COLOUR,
                lw=0.8,
                ls=(0, (6, 3)),
                gid=f"{gid} rail",
                zorder=0.5,
            )
            w, h = 1.6 * SYMBOL * self.size, SYMBOL * self.size
            box = np.array([[-w, -h], [w, -h], [w, h], [-w, h], [-w, -h]]) / 2
            box = box @ np.array([along, [-along[1], along[0]]])  # block aligned with the rail
            block = self.line(gid=f"{gid} block", color=colour(joint.body), lw=1.2, zorder=2.5)
            marks = self.line(gid=gid, marker=".", ms=3, color="k", ls="none", zorder=4.0)

            def update(frame):
                centre = place(frame.q, joint.body, np.zeros(2))
                foot = origin + along * float(np.dot(centre - origin, along))
                block.set_data(*(centre + box).T)
                marks.set_data([centre[0], foot[0]], [centre[1], foot[1]])

        elif isinstance(joint, Driver):
            radius = 1.5 * SYMBOL * self.size
            turn = math.copysign(1.0, float(joint.speed)) if float(joint.speed) else 1.0
            sweep = turn * np.linspace(-1.0, 1.0, 24)
            arc = self.line(gid=gid, color="k", lw=1.0, zorder=4.0)
            head = self.line(
                gid=f"{gid} head", color="k", marker=(3, 0, 0), ms=5, ls="none", zorder=4.0
            )

            def update(frame):
                centre = place(frame.q, joint.body, np.zeros(2))
                angles = float(frame.q[3 * joint.body + 2]) + sweep
                arc.set_data(
                    centre[0] + radius * np.cos(angles), centre[1] + radius * np.sin(angles)
                )
                tip = angles[-1]
                head.set_data(
                    [centre[0] + radius * math.cos(tip)], [centre[1] + radius * math.sin(tip)]
                )
                head.set_marker((3, 0, math.degrees(tip) + (0.0 if turn > 0 else 180.0)))

        else:  # a joint of another kind: its name at the centroids of its bodies
            bodies = [
                getattr(joint, name)
                for name in ("body", "body_i", "body_j")
                if hasattr(joint, name)
            ]
            marks = self.line(gid=gid, marker="x", ms=5, color="k", ls=":", lw=0.8, zorder=4.0)
            text = self.label(type(joint).__name__)

            def update(frame):
                xy = np.array(
                    [place(frame.q, b, np.zeros(2)) for b in bodies if b != GROUND]
                ).reshape(-1, 2)
                marks.set_data(*xy.T)
                if text is not None and len(xy):
                    text.xy = xy.mean(0)

        self.updates.append(update)


# -- force elements, by kind -----------------------------------------------------------------------
def _bearing_points(b: BearingJoint):
    return [(b.outer_body, b.outer_point), (b.inner_body, b.inner_point)]


def _draw_bearing(scene: Scene, entry: Entry):
    """Outer and inner raceways (d_o, d_i) with the clearance and the eccentricity enlarged by
    the scene's factor k, and the rolling elements (diameter D) at their angles (Eq. 14), ball 1
    dark; each element sits on its line through the outer race's centre, halfway between the
    raceways, so that it touches both where its deflection (Eq. 12) is zero. Load bars stand
    radially outside the outer raceway."""
    from matplotlib.patches import Circle

    b, i = entry.element, entry.bearing
    p = b.bearing
    d_i, d_o, diameter = (
        float(p.inner_race_diameter),
        float(p.outer_race_diameter),
        float(p.ball_diameter),
    )
    k = scene.clearance_scale
    gap = k * float(p.clearance) / 4.0  # drawn radial gap each side of a centred element
    r_outer, r_inner = d_o / 2 + gap, max(d_i / 2 - gap, 0.0)
    outer = scene.ax.add_patch(
        Circle(
            (0, 0),
            r_outer,
            fill=False,
            ec=colour(b.outer_body),
            lw=1.3,
            gid=f"{entry.label} outer",
            zorder=2.0,
        )
    )
    inner = scene.ax.add_patch(
        Circle(
            (0, 0),
            r_inner,
            fill=False,
            ec=colour(b.inner_body),
            lw=1.3,
            gid=f"{entry.label} inner",
            zorder=2.0,
        )
    )
    balls = [
        scene.ax.add_patch(
            Circle(
                (0, 0),
                diameter / 2,
                fc="0.35" if r == 0 else "0.88",
                ec="0.3",
                lw=0.5,
                gid=f"{entry.label} ball {r + 1}",
                zorder=2.2,
            )
        )
        for r in range(p.n_balls)
    ]
    bars = scene.line(
        gid=f"{entry.label} loads", color="C3", lw=2.5, solid_capstyle="butt", zorder=2.4
    )
    name = scene.label(entry.label, (3, 3))
    if b.outer_body == GROUND:
        scene.ground_mark(
            np.asarray(b.outer_point, dtype=float) - [0.0, r_outer], f"{entry.label} ground"
        )

    def update(frame):
        c_o = place(frame.q, b.outer_body, b.outer_point)
        e = place(frame.q, b.inner_body, b.inner_point) - c_o
        outer.center, inner.center = c_o, c_o + k * e
        angles = np.asarray(bearing_law.ball_angles(frame.cages[i], p.n_balls))
        u = np.stack([np.cos(angles), np.sin(angles)], -1)
        rho = (d_i + d_o) / 4 + 0.5 * k * (u @ e)
        for ball, centre in zip(balls, c_o + rho[:, None] * u):
            ball.center = centre
        if frame.loads is not None and scene.load_scale is not None:
            start = c_o + r_outer * u
            end = (
                start
                + (scene.load_scale * np.nan_to_num(np.asarray(frame.loads[i], dtype=float)))[
                    :, None
                ]
                * u
            )
            gaps = np.full((p.n_balls, 1), np.nan)
            bars.set_data(
                np.hstack([start[:, :1], end[:, :1], gaps]).ravel(),
                np.hstack([start[:, 1:], end[:, 1:], gaps]).ravel(),
            )
        if name is not None:
            name.xy = c_o + r_outer * np.array([math.sqrt(0.5), math.sqrt(0.5)])

    return update


def _contact_points(c: CircleContact):
    return [(c.body_j, c.centre_j), (c.body_k, c.centre_k)]


def _draw_contact(scene: Scene, entry: Entry):
    """The contact's two circles (radii R_j, R_k at their centres), dashed."""
    from matplotlib.patches import Circle

    c = entry.element
    circles = [
        scene.ax.add_patch(
            Circle(
                (0, 0),
                float(radius),
                fill=False,
                ec=colour(body),
                lw=1.0,
                ls="--",
                gid=f"{entry.label} {side}",
                zorder=2.0,
            )
        )
        for side, body, radius in (("j", c.body_j, c.radius_j), ("k", c.body_k, c.radius_k))
    ]
    name = scene.label(entry.label, (0, 6))

    def update(frame):
        centres = [place(frame.q, body, point) for body, point in _contact_points(c)]
        for circle, centre in zip(circles, centres):
            circle.center = centre
        if name is not None:
            name.xy = 0.5 * (centres[0] + centres[1]) + [
                0.0,
                max(float(c.radius_j), float(c.radius_k)),
            ]

    return update


def _journal_points(j: ClearanceJoint):
    return [(j.body_i, j.point_i), (j.body_j, j.point_j)]


def _draw_journal(scene: Scene, entry: Entry):
    """A plain bearing's hole (radius R + k c) and journal (radius R), the journal's centre
    k e from the hole's: the clearance c and the eccentricity e enlarged by the scene's factor
    k, so that the journal touches the hole where the contact does."""
    from matplotlib.patches import Circle

    j = entry.element
    radius, clearance = float(j.journal.radius), float(j.journal.clearance)
    k = scene.clearance_scale
    hole = radius + k * clearance  # drawn
    circles = [
        scene.ax.add_patch(
            Circle(
                (0, 0), r, fill=False, ec=colour(body), lw=1.3, gid=f"{entry.label} {side}",
                zorder=2.0,
            )
        )
        for side, body, r in (("hole", j.body_i, hole), ("journal", j.body_j, radius))
    ]
    name = scene.label(entry.label, (3, 3))
    if j.body_i == GROUND:
        scene.ground_mark(np.asarray(j.point_i, dtype=float) - [0.0, hole], f"{entry.label} ground")

    def update(frame):
        centre = place(frame.q, j.body_i, j.point_i)
        e = place(frame.q, j.body_j, j.point_j) - centre
        circles[0].center, circles[1].center = centre, centre + k * e
        if name is not None:
            name.xy = centre + hole * np.array([math.sqrt(0.5), math.sqrt(0.5)])

    return update


def _spring_points(s: SpringDamper):
    return [(s.body_i, s.point_i), (s.body_j, s.point_j)]


def _draw_spring(scene: Scene, entry: Entry):
    """A zigzag between the spring's two points, ground ends marked."""
    s = entry.element
    coil = scene.line(gid=entry.label, color="0.2", lw=0.9, zorder=1.8)
    name = scene.label(f"{entry.label}: spring", (0, 8))
    for body, point in _spring_points(s):
        if body == GROUND:
            scene.ground_mark(np.asarray(point, dtype=float), f"{entry.label} ground")

    def update(frame):
        a, b = (place(frame.q, body, point) for body, point in _spring_points(s))
        coil.set_data(*_zigzag(a, b, 0.6 * SYMBOL * scene.size).T)
        if name is not None:
            name.xy = 0.5 * (a + b)

    return update


def _draw_gravity(scene: Scene, entry: Entry):
    """An arrow along g in the Axes' upper left corner (fixed: nothing to move)."""
    g = np.asarray(entry.element.acceleration, dtype=float)
    norm = float(np.hypot(*g))
    if norm > 0.0:
        tail = np.array([0.06, 0.9])
        scene.ax.annotate(
            f"g {norm:.3g} m/s²",
            xy=tail + 0.1 * g / norm,
            xytext=tail,
            xycoords="axes fraction",
            arrowprops={"arrowstyle": "->", "color": "0.2"},
            fontsize=7,
            color="0.25",
            gid=entry.label,
            ha="center",
            va="bottom",
        )


def _draw_unknown(scene: Scene, entry: Entry):
    """A kind without a drawer: a dotted line between the centroids of the bodies it acts on,
    labelled by its class name."""
    try:
        bodies = [b for b in entry.element.bodies() if b != GROUND]
    except (AttributeError, TypeError):
        bodies = []
    marks = scene.line(gid=entry.label, color="0.3", ls=":", lw=1.0, marker="x", ms=5, zorder=1.8)
    name = scene.label(f"{entry.label}: {type(entry.element).__name__}", (4, -12))

    def update(frame):
        xy = np.array([place(frame.q, b, np.zeros(2)) for b in bodies]).reshape(-1, 2)
        marks.set_data(*xy.T)
        if name is not None and len(xy):
            name.xy = xy.mean(0)

    return update


ELEMENTS: dict[type, Kind] = {
    BearingJoint: Kind(_bearing_points, _draw_bearing),
    CircleContact: Kind(_contact_points, _draw_contact),
    ClearanceJoint: Kind(_journal_points, _draw_journal),
    SpringDamper: Kind(_spring_points, _draw_spring),
    Gravity: Kind(lambda element: [], _draw_gravity),
}
UNKNOWN = Kind(lambda element: [], _draw_unknown)


def shown_in_notebooks() -> None:
    """In IPython (a notebook), show a Figure that is a cell's value as a PNG, as matplotlib's
    inline backend does once pyplot is imported (`IPython.core.pylabtools.select_figure_formats`);
    nothing outside IPython or where a display of Figures is registered already."""
    ipython = sys.modules.get("IPython")
    shell = ipython.get_ipython() if ipython is not None else None
    if shell is None:
        return
    from IPython.core.pylabtools import select_figure_formats
    from matplotlib.figure import Figure

    if not any(Figure in f.type_printers for f in shell.display_formatter.formatters.values()):
        select_figure_formats(shell, {"png"})


def new_figure(figsize=(6.4, 4.8)):
    """A new Figure (object API, constrained layout; shown as a notebook cell's value)."""
    from matplotlib.figure import Figure

    shown_in_notebooks()
    return Figure(figsize=figsize, layout="constrained")


def finish(ax, scale: float, bearings: bool, adjustable: str = "datalim") -> None:
    """Equal axes in metres (``adjustable``: what gives way, matplotlib's ``set_aspect``), and
    the clearance's factor stated where ``bearings`` (or plain bearings: `has_play`) are
    drawn."""
    ax.set_aspect("equal", adjustable=adjustable)
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.grid(True, linewidth=0.3, alpha=0.4)
    if bearings:
        ax.text(
            0.01,
            0.01,
            f"bearings' clearance and eccentricity ×{scale:g}",
            transform=ax.transAxes,
            fontsize=7,
            color="0.25",
            va="bottom",
            gid="clearance scale",
        )


def checked_scale(model, clearance_scale) -> float:
    """``clearance_scale`` (None: `default_clearance_scale` of the model), a ValueError unless
    positive and finite."""
    if clearance_scale is None:
        return default_clearance_scale(model)
    scale = float(clearance_scale)
    if not (math.isfinite(scale) and scale > 0.0):
        raise ValueError(
            f"clearance_scale must be a positive number (1: true size); got {clearance_scale!r}."
        )
    return scale


def checked_q(model, q) -> np.ndarray:
    """``q`` (None: ``model.q0``) as float64 (n_coordinates,), finite; a ValueError otherwise."""
    q = np.asarray(model.q0 if q is None else q, dtype=float)
    if q.shape != (model.n_coordinates,) or not np.all(np.isfinite(q)):
        raise ValueError(
            f"q must be {model.n_coordinates} finite coordinates (x, y, theta per body, [m, rad]); "
            f"got shape {q.shape}."
        )
    return q


def draw(model, q=None, ax=None, *, t=0.0, clearance_scale=None, labels=True):
    """A picture of the planar machine ``model`` at coordinates ``q`` (module docstring).

    Args:
        model: a `Mechanism` (any machine: several bearings, contacts, springs).
        q: (n_coordinates,) [m, rad]; None: ``model.q0``, its initial state.
        ax: a matplotlib Axes to draw into; None: a new Figure (object API, no pyplot).
        t: the time [s] of ``q``, for a cage turning at constant speed (``cage="constant"``);
            the kinematic cage follows the rings' angles in ``q``.
        clearance_scale: the factor by which each bearing's and plain bearing's clearance and
            eccentricity are drawn (1: true size); None: `default_clearance_scale` of the model. It
            is written in the Axes' lower left corner.
        labels: write the bodies' names and the elements' labels.

    Returns:
        The matplotlib Figure (shown by a notebook when it is a cell's value).
    """
    model = _checks.on_host(model)
    q = checked_q(model, q)
    scale = checked_scale(model, clearance_scale)
    ax = new_figure().add_subplot() if ax is None else ax
    Scene(ax, model, Frame(q, cage_angles(model, q, t)), scale, labels=labels)
    finish(ax, scale, has_play(model))
    ax.relim()
    ax.autoscale_view()
    return ax.figure

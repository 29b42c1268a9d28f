"""Pictures of machines (`jb.report.draw`, `animate` and the element plots), read back from the
artists' data: joint points coincide where the joints hold and part by a known displacement
where they do not; rolling elements sit at the cage angle of Eq. 15 and touch both drawn
raceways where their deflection (Eq. 12) is zero; load bars, plotted curves and orbits equal
the solution's samples and the library's JAX kinematics. The machine with several bearings and
contacts is the docs' two-bearing slider-crank with a sprung target it strikes and a stop
behind the target."""

import io
import itertools
import logging
import math
import warnings
from typing import final

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from matplotlib.animation import FFMpegWriter, FuncAnimation
from matplotlib.figure import Figure
from PIL import Image

import jaxbearing as jb
from jaxbearing.multibody import (
    GROUND,
    AbstractForceElement,
    BearingJoint,
    Body,
    CircleContact,
    Driver,
    Gravity,
    Mechanism,
    Revolute,
    SpringDamper,
    Translational,
)
from jaxbearing.report import _animate

W, CRANK, ROD = 20 * np.pi, 0.05, 0.12  # [rad/s], [m]
T1 = 0.004  # [s] the short run: the slider strikes the target at about 0.5 ms
SAMPLES = 21


def slider_crank(target=True):
    """The docs' slider-crank with an SKF 98205 in the frame and one on the crank pin
    (docs/mechanisms.md, 'Several bearings'); with ``target``, a sprung target 0.5 mm beyond the
    slider's circle, moving onto it at 1 m/s, and a stop on the ground 10 mm behind it."""
    bearing = jb.BallBearing.from_catalogue("98205", ball_force="smooth", damping=3000.0)
    bodies = [Body(0.75, 5.2e-4), Body(0.67, 1.2e-3), Body(0.30, 1e-4)]
    joints = [
        Driver(0, angle=0.0, speed=W),
        Revolute(1, (ROD / 2, 0.0), 2, (0.0, 0.0)),
        Translational(2),
    ]
    forces = [
        BearingJoint(GROUND, (0.0, 0.0), 0, (-CRANK / 2, 0.0), bearing),
        BearingJoint(0, (CRANK / 2, 0.0), 1, (-ROD / 2, 0.0), bearing),
    ]
    guess = [CRANK / 2, 0, 0, CRANK + ROD / 2, 0, 0, CRANK + ROD, 0, 0]
    names = ["crank", "rod", "slider"]
    contacts, velocities = [], [0.0] * 9
    if target:
        x = CRANK + ROD + 0.0205
        bodies.append(Body(0.1, 1e-4))
        joints.append(Translational(3))
        forces.append(SpringDamper(GROUND, (x + 0.05, 0.0), 3, (0.0, 0.0), 1e4, 10.0, 0.05))
        impact = jb.Impact.from_geometry(radius_j=0.01, radius_k=0.01, restitution=0.8)
        contacts.append(CircleContact(2, (0.0, 0.0), 0.01, 3, (0.0, 0.0), 0.01, impact))
        contacts.append(CircleContact(3, (0.0, 0.0), 0.01, GROUND, (x + 0.03, 0.0), 0.01, impact))
        guess += [x, 0, 0]
        velocities += [-1.0, 0.0, 0.0]
        names.append("target")
    model = Mechanism(bodies, joints, guess, forces=forces + contacts, body_names=names)
    return model.assemble(qd_guess=velocities)


@final
class Tether(AbstractForceElement):
    """A force element of a kind the drawing does not know (it pulls nothing)."""

    body_i: int
    body_j: int

    def generalized_force(self, t, q, qd, state, inputs):
        return jnp.zeros_like(q)

    def bodies(self):
        return (self.body_i, self.body_j)

    def violations(self, xp, named=None):
        return []


def plate():
    """The four-bar with a spring from the ground to a point above its coupler's line: the
    coupler is a plate of three points."""
    model = jb.cases.four_bar()
    spring = SpringDamper(GROUND, (0.15, 0.35), 1, (0.0, 0.04), 1e3, 1.0, 0.1)
    return Mechanism(
        model.bodies,
        model.joints,
        model.q0,
        model.qd0,
        forces=(*model.forces, spring),
        body_names=model.body_names,
    )


def with_tether(model):
    return Mechanism(
        model.bodies,
        model.joints,
        model.q0,
        model.qd0,
        forces=(*model.forces, Gravity(), Tether(0, 1)),
        body_names=model.body_names,
    )


MODELS = {
    "xu2014": lambda: jb.cases.xu2014(),
    "xu2014 without impact": lambda: jb.cases.xu2014(impact=False, bearing="NU206"),
    "rotor": lambda: jb.cases.rotor(jb.cases.skf98205(), speed=100.0, eccentricity=1e-3),
    "four_bar": lambda: jb.cases.four_bar(),
    "docs' two-bearing slider-crank": lambda: slider_crank(target=False),
    "two bearings, a spring and a contact": slider_crank,
    "a plate of three points": plate,
}


def artists(fig, gid):
    """The artists of ``fig`` with this gid."""
    return [a for a in fig.findobj() if a.get_gid() == gid]


def one(fig, gid):
    (artist,) = artists(fig, gid)
    return artist


def xy(fig, gid) -> np.ndarray:
    return np.asarray(one(fig, gid).get_xydata(), dtype=float)


def on_polyline(point, line) -> float:
    """Distance [m] from a point to a polyline (m, 2)."""
    best = math.inf
    for a, b in itertools.pairwise(line):
        d = b - a
        s = np.clip(np.dot(point - a, d) / max(np.dot(d, d), 1e-300), 0.0, 1.0)
        best = min(best, float(np.hypot(*(a + s * d - point))))
    return best if len(line) > 1 else float(np.hypot(*(line[0] - point)))


@pytest.fixture(scope="module")
def models():
    return {name: build() for name, build in MODELS.items()}


@pytest.mark.parametrize("name", MODELS)
def test_every_machine_draws_without_warnings(models, name, caplog):
    """Every ready-made case and the docs' machines: a Figure with a link and a centroid per
    body, an artist per joint, each bearing's raceways and rolling elements, each contact's
    circles and the bodies' names, rendered without a warning (Python's or matplotlib's log)."""
    model = models[name]
    with warnings.catch_warnings(), caplog.at_level(logging.WARNING, logger="matplotlib"):
        warnings.simplefilter("error")
        fig = jb.report.draw(model)
        fig.savefig(io.BytesIO(), format="png")
    assert not caplog.records, [r.getMessage() for r in caplog.records]
    assert isinstance(fig, Figure)
    for b in range(len(model.bodies)):
        assert artists(fig, f"body {b}") and artists(fig, f"body {b} centroid")
    for k in range(len(model.joints)):
        assert artists(fig, f"joint {k}")
    for i, bearing in enumerate(model.bearings):
        assert artists(fig, f"bearing {i} outer") and artists(fig, f"bearing {i} inner")
        assert all(
            artists(fig, f"bearing {i} ball {r + 1}") for r in range(bearing.bearing.n_balls)
        )
    for i in range(len(model.contacts)):
        assert artists(fig, f"contact {i} j") and artists(fig, f"contact {i} k")
    texts = {t.get_text() for t in fig.findobj(lambda a: hasattr(a, "get_text"))}
    assert set(model.body_names) <= texts


@pytest.mark.parametrize(
    "name",
    ["xu2014", "four_bar", "two bearings, a spring and a contact", "a plate of three points"],
)
def test_joint_points_coincide_on_an_assembled_machine(models, name):
    """Each revolute joint's two drawn points, each translational joint's centroid and its foot
    on the rail, and each bearing's race centres coincide (to 1e-9 m) at an assembled state; each
    joint point lies on its body's link. Body 1 moved 1 mm along x parts the points of the
    joints it is in by exactly that, and its bearing's drawn race centres by the stated factor
    times it."""
    model = models[name]
    fig = jb.report.draw(model)
    for k, joint in enumerate(model.joints):
        if isinstance(joint, Driver):
            continue
        points = xy(fig, f"joint {k}")
        assert points.shape == (2, 2)
        assert np.hypot(*(points[0] - points[1])) < 1e-9, model.joint_label(k)
        if isinstance(joint, Revolute):
            for body, point in zip((joint.body_i, joint.body_j), points):
                if body != GROUND:
                    assert on_polyline(point, xy(fig, f"body {body}")) < 1e-12
    for i in range(len(model.bearings)):
        outer, inner = one(fig, f"bearing {i} outer"), one(fig, f"bearing {i} inner")
        assert np.hypot(*np.subtract(outer.center, inner.center)) < 1e-9
    if name == "a plate of three points":  # the coupler: a closed triangle through its points
        link = xy(fig, "body 1")
        corners = [
            jb.multibody.point_position(model.q0, 1, p) for p in ([-0.14, 0], [0.14, 0], [0, 0.04])
        ]
        assert len(link) == 4 and np.allclose(link[0], link[-1])
        for corner in corners:
            assert np.min(np.hypot(*(link - np.asarray(corner)).T)) < 1e-12

    shift = 1e-3
    q = np.array(model.q0)
    q[3] += shift  # body 1's x
    moved = jb.report.draw(model, q)
    scale = jb.report._draw.default_clearance_scale(model)
    assert any(
        f"×{scale:g}" in t.get_text() for t in moved.findobj(lambda a: hasattr(a, "get_text"))
    )
    for k, joint in enumerate(model.joints):
        if isinstance(joint, Revolute) and 1 in (joint.body_i, joint.body_j):
            gap = xy(moved, f"joint {k}")
            np.testing.assert_allclose(abs(gap[0, 0] - gap[1, 0]), shift, rtol=0, atol=1e-12)
            np.testing.assert_allclose(gap[0, 1] - gap[1, 1], 0.0, atol=1e-12)
    for i, b in enumerate(model.bearings):
        if 1 in (b.outer_body, b.inner_body):
            sign = 1.0 if b.inner_body == 1 else -1.0
            outer, inner = one(moved, f"bearing {i} outer"), one(moved, f"bearing {i} inner")
            drawn = np.subtract(inner.center, outer.center)
            np.testing.assert_allclose(drawn, [sign * scale * shift, 0.0], atol=1e-12)


@pytest.mark.parametrize("cage", ["kinematic", "constant"])
def test_rolling_elements_sit_at_the_cage_angle_and_touch_at_zero_deflection(cage):
    """A rotor in the SKF 98205 (outer race on ground), turned by 0.7 rad at t = 0.01 s with its
    axis at e = P_d/2 along ball 1: each element's centre is at 2 pi (r-1)/N_b + phi_c about the
    outer race's centre, phi_c = theta d_i/(d_i + d_o) (kinematic) or omega d_i/(d_i + d_o) t
    (constant, Eq. 15), and ball 1, at zero deflection (Eq. 12), touches both drawn raceways."""
    bearing = jb.cases.skf98205(cage=cage)
    speed, t, theta = 300.0, 0.01, 0.7
    model = jb.cases.rotor(bearing, speed=speed)
    d_i, d_o = float(bearing.inner_race_diameter), float(bearing.outer_race_diameter)
    diameter, n = float(bearing.ball_diameter), bearing.n_balls
    phi = (theta if cage == "kinematic" else speed * t) * d_i / (d_i + d_o)
    e = 0.5 * float(bearing.clearance) * np.array([np.cos(phi), np.sin(phi)])
    fig = jb.report.draw(model, [e[0], e[1], theta], t=t)
    outer, inner = one(fig, "bearing 0 outer"), one(fig, "bearing 0 inner")
    np.testing.assert_allclose(outer.center, [0.0, 0.0], atol=1e-15)
    for r in range(n):
        ball = one(fig, f"bearing 0 ball {r + 1}")
        angle = math.atan2(ball.center[1], ball.center[0])
        expected = phi + 2 * np.pi * r / n
        assert abs(math.remainder(angle - expected, 2 * np.pi)) < 1e-12
        assert ball.radius == pytest.approx(diameter / 2, rel=1e-15)
    ball = one(fig, "bearing 0 ball 1")
    to_outer = np.hypot(*np.subtract(ball.center, outer.center)) + ball.radius
    to_inner = np.hypot(*np.subtract(ball.center, inner.center)) - ball.radius
    assert to_outer == pytest.approx(outer.radius, rel=1e-12)
    assert to_inner == pytest.approx(inner.radius, rel=1e-12)


def test_the_clearance_factor_is_stated_and_can_be_given():
    """The SKF 98205 (P_d 40 um, D 8.7 mm): 0.3 D / (P_d/2) = 130.5, drawn x100; at
    clearance_scale=1 the raceways are the true d_i and d_o."""
    model = jb.cases.four_bar()
    bearing = model.bearing
    assert jb.report._draw.default_clearance_scale(model) == 100.0
    fig = jb.report.draw(model, clearance_scale=1)
    assert one(fig, "bearing 0 outer").radius == pytest.approx(
        float(bearing.outer_race_diameter) / 2 + float(bearing.clearance) / 4, rel=1e-15
    )
    assert one(fig, "bearing 0 inner").radius == pytest.approx(
        float(bearing.inner_race_diameter) / 2 - float(bearing.clearance) / 4, rel=1e-15
    )
    assert "×1" in one(fig, "clearance scale").get_text()
    with pytest.raises(ValueError, match="clearance_scale must be a positive number"):
        jb.report.draw(model, clearance_scale=0.0)
    with pytest.raises(ValueError, match="q must be 9 finite coordinates"):
        jb.report.draw(model, q=np.zeros(3))


def test_an_element_of_an_unknown_kind_is_drawn_by_its_bodies(models):
    """A force element without a drawer: a dotted line between the centroids of the bodies it
    acts on, labelled by its class name; gravity an arrow; into a given Axes."""
    model = with_tether(models["two bearings, a spring and a contact"])
    fig = Figure()
    ax = fig.add_subplot()
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert jb.report.draw(model, ax=ax) is fig
    k = len(model.forces) - 1
    q = np.asarray(model.q0)
    np.testing.assert_allclose(xy(fig, f"force {k}"), [q[0:2], q[3:5]], atol=1e-15)
    texts = [t.get_text() for t in fig.findobj(lambda a: hasattr(a, "get_text"))]
    assert f"force {k}: Tether" in texts
    assert any(t.startswith("g 9.81") for t in texts)


@pytest.fixture(scope="module")
def run(models):
    model = models["two bearings, a spring and a contact"]
    return jb.simulate(model, T1, np.linspace(0.0, T1, SAMPLES)), model


def frames_of(path) -> int:
    with Image.open(path) as image:
        return image.n_frames


def test_animate_writes_a_frame_per_chosen_sample(run, tmp_path):
    """A GIF of ``frames`` frames (every sample where fewer, those of the window), the load bars
    of the last frame as long as its loads at the stated scale, the panel's time marker there."""
    sol, model = run
    panel = {"contact 0 [N]": sol.contact_forces[:, 0]}
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        anim = jb.report.animate(
            sol, model, frames=8, path=tmp_path / "a.gif", panel=panel, ylabel="N"
        )
    assert isinstance(anim, FuncAnimation)
    assert frames_of(tmp_path / "a.gif") == 8
    fig = anim._fig
    title = [
        t for t in fig.findobj(lambda a: hasattr(a, "get_text")) if t.get_text().startswith("t = ")
    ]
    assert title[0].get_text() == f"t = {T1:.6g} s"  # the last frame drawn
    radius = max(float(b.bearing.outer_race_diameter) / 2 for b in model.bearings)
    loads = [np.asarray(b.ball_loads)[-1] for b in sol.bearings]
    largest = max(
        float(np.max(np.asarray(b.ball_loads)[_animate.frame_indices(sol.ts, sol.q, None, 8)]))
        for b in sol.bearings
    )
    for i, load in enumerate(loads):
        bars = xy(fig, f"bearing {i} loads").reshape(-1, 3, 2)[:, :2]
        lengths = np.hypot(*(bars[:, 1] - bars[:, 0]).T)
        np.testing.assert_allclose(
            lengths, _animate.LOAD_BAR * radius * load / largest, rtol=1e-12, atol=1e-15
        )

    jb.report.animate(sol, model, frames=100, path=tmp_path / "all.gif")
    assert frames_of(tmp_path / "all.gif") == SAMPLES
    ts = np.asarray(sol.ts)
    window = (0.001, 0.002)
    jb.report.animate(sol, model, window=window, path=tmp_path / "window.gif")
    assert frames_of(tmp_path / "window.gif") == np.count_nonzero(
        (ts >= window[0]) & (ts <= window[1])
    )
    if not FFMpegWriter.isAvailable():
        with pytest.raises(ValueError, match="needs ffmpeg"):
            jb.report.animate(sol, model, frames=2, path=tmp_path / "a.mp4")
        assert not (tmp_path / "a.mp4").exists()
    with pytest.raises(ValueError, match="panel series"):
        jb.report.animate(sol, model, panel=np.zeros(3))


def lines(fig) -> list:
    return [line for ax in fig.axes for line in ax.get_lines()]


def test_element_plots_hold_the_solution_s_samples(run):
    """Each plot's curves are the samples: every element's load, the bearing force's
    components and magnitude, the contact force with the recorded peaks, and the orbit equal
    to 1e6 |e| from `BearingJoint.offset` (the library's JAX kinematics)."""
    sol, model = run
    ts = np.asarray(sol.ts)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        figures = [
            jb.report.plot_ball_loads(sol, bearing=1),
            jb.report.plot_bearing_force(sol, bearing=0),
            jb.report.plot_contact_force(sol, contact=0),
            jb.report.plot_orbit(sol, model, bearing=1),
        ]
        for fig in figures:
            fig.savefig(io.BytesIO(), format="png")
    balls, force, contact, orbit = figures
    loads = np.asarray(sol.bearings[1].ball_loads)
    assert len(lines(balls)) == loads.shape[1]
    for r, line in enumerate(lines(balls)):
        np.testing.assert_array_equal(line.get_xdata(), ts)
        np.testing.assert_array_equal(line.get_ydata(), loads[:, r])
    f = np.asarray(sol.bearings[0].force)
    for line, expected in zip(lines(force), (f[:, 0], f[:, 1], np.hypot(f[:, 0], f[:, 1]))):
        np.testing.assert_array_equal(line.get_ydata(), expected)
    curve, peaks = lines(contact)
    np.testing.assert_array_equal(curve.get_ydata(), np.asarray(sol.contact_forces[:, 0]))
    recorded = jb.report.contacts(sol, 0)
    assert recorded and np.max(peaks.get_ydata()) >= np.max(curve.get_ydata())
    np.testing.assert_array_equal(peaks.get_ydata(), [c.peak_force for c in recorded])
    e = jax.vmap(model.bearings[1].offset)(sol.q)
    np.testing.assert_allclose(
        one(orbit, "orbit 0").get_xydata(), 1e6 * np.asarray(e), rtol=0, atol=1e-9
    )


def test_element_plots_overlay_runs_and_choose_their_window(run):
    """A mapping of runs draws one labelled curve each; a window keeps its samples; a machine
    with two bearings needs one named."""
    sol, model = run
    fig = jb.report.plot_bearing_force({"a": sol, "b": sol}, bearing=1, window=(0.001, 0.002))
    first = fig.axes[0]
    assert [line.get_label() for line in first.get_lines()] == ["a", "b"]
    assert [t.get_text() for t in first.get_legend().get_texts()] == ["a", "b"]
    x = first.get_lines()[0].get_xdata()
    ts = np.asarray(sol.ts)
    np.testing.assert_array_equal(x, ts[(ts >= 0.001) & (ts <= 0.002)])
    with pytest.raises(ValueError, match="bearing"):
        jb.report.plot_ball_loads(sol)
    with pytest.raises(ValueError, match="contact"):
        jb.report.plot_contact_force(sol)
    with pytest.raises(ValueError, match="index"):
        jb.report.plot_orbit(sol, model, bearing=2)

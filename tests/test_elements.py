"""A force element of a new kind, defined here only, through the public protocol
(`jaxbearing.multibody.AbstractForceElement`): a rope that pulls only while taut, its taut and
slack events located by the solve, each taut spell an episode. A 1 kg bob falls 0.2 m on it
from rest straight below the anchor, so the rope snaps taut at the free-fall time sqrt(2 h / g)
and speed sqrt(2 g h), and (elastic, undamped) the first tension peak is k delta with
1/2 m v^2 + m g delta = 1/2 k delta^2: closed forms for its events, its records, the metrics
of it, and the derivative of its peak in the rope's stiffness. The built-in elements are
elements like it (named, read by index and name)."""

from __future__ import annotations

from typing import NamedTuple, final

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import pytest

import jaxbearing as jb
from jaxbearing import _checks
from jaxbearing.multibody import (
    GROUND,
    AbstractForceElement,
    Body,
    Gravity,
    IntegralRecord,
    PeakRecord,
    point_force,
    point_position,
    point_velocity,
)

M, G, K, DROP, LENGTH = 1.0, 9.80665, 2e4, 0.2, 0.5  # [kg], [m/s^2], [N/m], [m], [m]
T1 = 0.7  # [s] two bounces (each 26 ms, 0.40 s of free flight between them)
TIGHT = jb.default_controller(rtol=1e-10, atol=1e-12)
SLACK_OFFSET = 1e-9  # [m]


class RopeState(NamedTuple):
    taut: jax.Array
    snap_speed: jax.Array  # [m/s] the stretch rate when it last went taut


@final
class Rope(AbstractForceElement):
    """Tension k (l - l0) + c dl/dt, never negative, while taut; none while slack."""

    body_i: int = eqx.field(static=True)
    body_j: int = eqx.field(static=True)
    point_i: jax.Array
    point_j: jax.Array
    stiffness: jax.Array
    damping: jax.Array
    length: jax.Array

    peak_records = (PeakRecord("tension"),)
    integral_records = (IntegralRecord("tension_squared", power=2.0),)
    episode_peak = "tension"

    def __init__(self, body_i, point_i, body_j, point_j, stiffness, damping, length):
        self.body_i, self.body_j = body_i, body_j
        self.point_i = _checks.as_float(point_i, "point_i", "m")
        self.point_j = _checks.as_float(point_j, "point_j", "m")
        self.stiffness = _checks.as_float(stiffness, "stiffness", "N/m")
        self.damping = _checks.as_float(damping, "damping", "N s/m")
        self.length = _checks.as_float(length, "length", "m")

    def bodies(self):
        return (self.body_i, self.body_j)

    def violations(self, xp, named=_checks.keyword):
        return [
            _checks.positive(xp, named("stiffness"), self.stiffness, "N/m"),
            _checks.non_negative(xp, named("damping"), self.damping, "N s/m"),
            _checks.positive(xp, named("length"), self.length, "m"),
        ]

    def _line(self, q, qd):
        d = point_position(q, self.body_j, self.point_j) - point_position(q, self.body_i, self.point_i)
        v = point_velocity(q, qd, self.body_j, self.point_j) - point_velocity(q, qd, self.body_i, self.point_i)
        distance = jnp.sqrt(jnp.sum(d * d))
        u = d / distance
        return u, distance - self.length, jnp.sum(v * u)

    def _tension(self, q, qd, state):
        _, stretch, rate = self._line(q, qd)
        return jnp.where(state.taut, jnp.maximum(self.stiffness * stretch + self.damping * rate, 0.0), 0.0)

    def generalized_force(self, t, q, qd, state, inputs):
        f = self._tension(q, qd, state) * self._line(q, qd)[0]
        return point_force(q, self.body_i, self.point_i, f) + point_force(q, self.body_j, self.point_j, -f)

    def initial_state(self, t0, q0, qd0, inputs):
        _, stretch, rate = self._line(q0, qd0)
        return RopeState(stretch > 0.0, jnp.where(stretch > 0.0, rate, 0.0))

    def event_values(self, t, q, qd, state, inputs):
        stretch = self._line(q, qd)[1]
        return jnp.where(state.taut, -(stretch + SLACK_OFFSET), stretch)[None]

    def on_events(self, t, q, qd, state, crossed, inputs):
        snaps = crossed[0] & ~state.taut
        return RopeState(state.taut ^ crossed[0], jnp.where(snaps, self._line(q, qd)[2], state.snap_speed))

    def in_episode(self, state):
        return state.taut

    def episode_value(self, state):
        return state.snap_speed

    def observe(self, t, q, qd, state, inputs):
        _, stretch, _ = self._line(q, qd)
        return {"tension": self._tension(q, qd, state), "stretch": stretch, "taut": state.taut}

    def integrands(self, t, q, qd, state, observed, inputs, fatigue):
        return {"tension_squared": observed["tension"] ** 2}


def bob(stiffness=K):
    rope = Rope(GROUND, (0.0, 0.0), 0, (0.0, 0.0), stiffness, 0.0, LENGTH)
    return jb.Mechanism(
        [Body(M, 1e-3)], [], [0.0, -(LENGTH - DROP), 0.0], forces={"rope": rope, "gravity": Gravity()}
    )


def first_peak(k):
    """k delta [N] of the first bounce: 1/2 m v^2 + m g delta = 1/2 k delta^2, v^2 = 2 g h."""
    return M * G + np.sqrt((M * G) ** 2 + k * M * 2 * G * DROP)


PEAK = jb.metrics.ElementPeak("tension", element="rope")
# a metric of your own that reads the element by name: the share of the time the rope is slack
SLACK = jb.metrics.Mean(lambda model, x: 1.0 - x.element("rope")["taut"].astype(float))


@pytest.fixture(scope="module")
def run():
    model = bob()
    options = jb.SolveOptions(records={"slack": SLACK})
    return model, jb.simulate(model, T1, jnp.linspace(0.0, T1, 2001), stepsize_controller=TIGHT, options=options)


def test_the_rope_snaps_taut_at_the_free_fall_time_and_speed(run):
    _, sol = run
    episodes = sol.episodes
    valid = np.asarray(episodes.valid)
    assert valid.sum() == 2  # two bounces, each a taut spell
    assert np.all(np.asarray(episodes.element)[valid] == 0)  # the rope, forces[0]
    fall = np.sqrt(2 * DROP / G)
    assert float(episodes.time[0]) == pytest.approx(fall, abs=1e-9)
    assert float(episodes.value[0]) == pytest.approx(np.sqrt(2 * G * DROP), rel=1e-7)
    # elastic: it leaves at the speed it arrived (the stretch rate reversed), by symmetry of
    # the bounce about its peak
    end = float(episodes.end[0])
    assert float(episodes.peak_time[0]) == pytest.approx(0.5 * (fall + end), abs=1e-7)
    assert sol.contacts.count == 0  # not an impact contact: the contacts' view is empty


def test_its_records_and_metrics_meet_the_closed_form(run):
    _, sol = run
    rope = sol.elements["rope"]
    assert rope is not None and sol.elements[0].kind == "Rope" and sol.elements[0].name == "rope"
    assert set(rope.samples) == {"tension", "stretch", "taut"}
    exact = float(PEAK(sol))
    assert exact == pytest.approx(first_peak(K), rel=1e-7)
    valid = np.asarray(sol.episodes.valid)
    assert np.max(np.asarray(sol.episodes.peak)[valid]) == exact  # the largest of the bounces'
    assert float(sol.episodes.peak[0]) == pytest.approx(exact, rel=1e-7)
    assert exact >= float(np.max(rope.samples["tension"]))  # every step, not the samples
    rms = float(jb.metrics.PowerMean("tension_squared", element="rope")(sol))
    tension = np.asarray(rope.samples["tension"])
    sampled = np.sqrt(np.trapezoid(tension**2, np.asarray(sol.ts)) / T1)
    assert rms == pytest.approx(sampled, rel=2e-3)  # 2001 samples of a 26 ms bounce
    # by index too, and gravity is an element without records
    assert float(jb.metrics.ElementPeak("tension", element=0)(sol)) == exact
    assert sol.elements["gravity"].samples == {} and sol.elements[1].records.peaks == {}


def test_energy_is_conserved_through_the_bounces(run):
    """Undamped: kinetic + gravity + rope energy constant within the solver's tolerance."""
    _, sol = run
    q, qd = np.asarray(sol.q), np.asarray(sol.qd)
    stretch = np.asarray(sol.elements["rope"].samples["stretch"])
    taut = np.asarray(sol.elements["rope"].samples["taut"])
    energy = 0.5 * M * (qd[:, 0] ** 2 + qd[:, 1] ** 2) + M * G * q[:, 1] + 0.5 * K * np.where(taut, stretch, 0.0) ** 2
    assert np.ptp(energy) < 1e-6 * M * G * DROP


def test_a_metric_of_your_own_reads_the_element_by_name(run):
    _, sol = run
    spells = np.asarray(sol.episodes.end - sol.episodes.time)[np.asarray(sol.episodes.valid)]
    assert float(sol.records["slack"]) == pytest.approx(1.0 - spells.sum() / T1, rel=1e-6)


@pytest.mark.slow  # 40 s: a sweep's and a forward-mode derivative's compiles
def test_sweep_and_derivative_by_the_element_s_path():
    model = bob()
    first = PEAK.replace(t_max=0.3)  # the first bounce: a window edge the solves stop at
    ks = jnp.array([1e4, 4e4])
    ds = jb.sweep(model, {"rope.stiffness": ks}, t1=T1, metrics={"peak": first}, stepsize_controller=TIGHT)
    np.testing.assert_allclose(ds["peak"].values, first_peak(np.asarray(ks)), rtol=1e-6)
    _, grad = jb.sensitivity(model, first, ["rope.stiffness"], t1=T1, stepsize_controller=TIGHT)
    closed = M * 2 * G * DROP / (2 * np.sqrt((M * G) ** 2 + K * M * 2 * G * DROP))
    assert float(grad["rope.stiffness"]) == pytest.approx(closed, rel=1e-5)


@final
class Misdeclared(AbstractForceElement):
    """Declares a peak record its observations lack."""

    peak_records = (PeakRecord("pull"),)

    def generalized_force(self, t, q, qd, state, inputs):
        return jnp.zeros_like(q)

    def bodies(self):
        return ()

    def violations(self, xp, named=_checks.keyword):
        return []

    def observe(self, t, q, qd, state, inputs):
        return {"tension": jnp.zeros((), q.dtype)}


def test_a_declaration_that_does_not_match_its_observations_is_refused():
    model = jb.Mechanism([Body(M, 1e-3)], [], [0.0, -0.3, 0.0], forces=[Misdeclared(), Gravity()])
    with pytest.raises(ValueError, match=r"Misdeclared declares the peak record 'pull', which must name a scalar of its observe\(\) \(it gives \['tension'\]\)"):
        jb.simulate(model, 0.01)


def test_only_force_elements_go_in_forces_and_only_joints_in_joints():
    rope = Rope(GROUND, (0.0, 0.0), 0, (0.0, 0.0), K, 0.0, LENGTH)
    with pytest.raises(TypeError, match=r"forces\[0\] must be a force element .* got Revolute: a joint belongs in joints"):
        jb.Mechanism([Body(M, 1e-3)], [], [0.0, -0.3, 0.0], forces=[jb.multibody.Revolute(GROUND, (0, 0), 0, (0, 0))])
    with pytest.raises(TypeError, match=r"joints\[0\] must be a joint .* got Rope: a force element belongs in forces="):
        jb.Mechanism([Body(M, 1e-3)], [rope], [0.0, -0.3, 0.0])
    with pytest.raises(ValueError, match=r"force 0 'rope' \(Rope\) refers to body 3, which does not exist"):
        jb.Mechanism([Body(M, 1e-3)], [], [0.0, -0.3, 0.0],
                     forces={"rope": Rope(GROUND, (0.0, 0.0), 3, (0.0, 0.0), K, 0.0, LENGTH)})


def test_the_built_in_elements_are_elements_like_any_other():
    """The paper's case, its elements named: each is read by index and by name; the views
    (``model.bearings``, ``model.contacts``, ``sol.bearings``, ``sol.contacts``) are views."""
    paper = jb.cases.xu2014(impact=True)
    named = jb.Mechanism(
        paper.bodies, paper.joints, paper.q0, paper.qd0,
        forces=dict(zip(("crank bearing", "target spring", "stop"), paper.forces)),
        window_start=paper.window_start,
    )  # fmt: skip
    assert named.bearings == (named.element("crank bearing"),) and named.contacts == (named.forces[2],)
    assert jb.paths.get(named, "stop.impact.restitution") is named.forces[2].impact.restitution
    assert "stop.impact.restitution" in jb.paths.parameter_paths(named)
    sol = jb.simulate(named, 0.005)  # the compiled solve of the paper's case (values, not structure)
    assert sol.elements["crank bearing"].records.peaks.keys() == {"max_element_load", "force_magnitude"}
    np.testing.assert_array_equal(sol.bearings[0].ball_loads, sol.elements[0].samples["element_loads"])
    assert float(jb.metrics.ElementPeak("max_element_load", element="crank bearing")(sol, t_min=None)) == float(
        jb.metrics.peak_ball_load(sol, t_min=None)
    )
    with pytest.raises(ValueError, match=r"No force element named 'crank'"):
        sol.elements["crank"]

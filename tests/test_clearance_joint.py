"""The plain bearing (`ClearanceJoint` with a `JournalBearing`), dry and lubricated, against
independent truths:

- its laws: the journal's contact stiffness against Hertz's closed form for a sphere in a
  spherical seat, and the film force against the short-bearing pressure integrated by SciPy
  (positive part only) and against the classical closed forms without squeeze;
- the rigid-pin limit: the paper's slider–crank with a dry journal of shrinking clearance and
  growing stiffness at the crank pin converges to the pin force of the Newton–Euler solution
  in NumPy (`helpers.slider_crank_pin_force`);
- the same crank with a realistic dry journal against an independent SciPy solve in minimal
  coordinates with the contacts as events (`helpers.clearance_slider_crank`): orbit, onsets,
  approach speeds, each contact's peak;
- a lubricated journal under a static load settles where the short-bearing load capacity
  and attitude angle say; under a load above the film's at its limit, the dry contact carries
  the rest as statics says;
- a pendulum hanging on a dry, frictionless, elastic journal keeps its energy over ~100
  impacts and its continuous contact;
- the derivative of the peak joint force in the clearance against central differences;
- records, metrics, paths, rules and the drawing.
"""

import equinox as eqx
import jax.numpy as jnp
import numpy as np
import pytest
from scipy.integrate import quad
from scipy.optimize import brentq

import helpers as ref
import jaxbearing as jb
from jaxbearing.cases._xu2014 import CRANK_LENGTH, ROD_LENGTH
from jaxbearing.laws import journal as journal_law
from jaxbearing.multibody import (
    GROUND,
    Body,
    ClearanceJoint,
    Driver,
    Gravity,
    JournalBearing,
    Revolute,
)

W = 20.0 * np.pi  # [rad/s] the paper's crank speed
MASSES = dict(m_rod=0.67, j_rod=1.2e-3, m_slider=0.30)  # paper Table 1
RADIUS, LENGTH, CLEARANCE = 12.5e-3, 12e-3, 20e-6  # [m] a plain bearing in the SKF 98205's place
START, TURN = 0.05, 0.1  # [s] the window of the rigid-pin limit: a crank turn after the start-up
PIN = jb.metrics.ElementPeak("force_magnitude", element="pin")
RMS = jb.metrics.PowerMean("force_squared", element="pin")
TIGHT = jb.default_controller(rtol=1e-12, atol=1e-14)


def dry(**kwargs):
    """The plain bearing of the comparison, dry: steel on steel (Flores' law), e_c 0.9, mu 0.1."""
    values = dict(radius=RADIUS, clearance=CLEARANCE, length=LENGTH, restitution=0.9, friction=0.1)
    return JournalBearing.from_geometry(**{**values, **kwargs})


def crank(journal, window_start=START):
    """The paper's slider–crank without impact, its crank pin the plain bearing ``journal`` (the
    hole on the crank, the journal on the rod), the element named "pin"."""
    paper = jb.cases.xu2014(impact=False, bearing=journal, window_start=window_start)
    forces = dict(zip(("pin", "target spring"), paper.forces))
    return jb.Mechanism(paper.bodies, paper.joints, paper.q0, paper.qd0, forces=forces,
                        body_names=paper.body_names, window_start=window_start)  # fmt: skip


# -- the laws ------------------------------------------------------------------------------------


def test_contact_stiffness_is_hertz_s_sphere_in_its_seat():
    """K = (4/3) E* sqrt(R*), 1/E* = (1 - nu_j^2)/E_j + (1 - nu_i^2)/E_i, 1/R* = 1/R - 1/(R + c)
    (Johnson, Contact Mechanics, ch. 4): steel in steel and a steel journal in a bronze hole;
    `JournalBearing.from_geometry` reads the same."""
    for (e_j, nu_j, e_i, nu_i) in ((207e9, 0.3, 207e9, 0.3), (207e9, 0.3, 110e9, 0.34)):
        e_star = 1.0 / ((1 - nu_j**2) / e_j + (1 - nu_i**2) / e_i)
        r_star = 1.0 / (1.0 / RADIUS - 1.0 / (RADIUS + CLEARANCE))
        k = journal_law.contact_stiffness(RADIUS, CLEARANCE, e_j, nu_j, e_i, nu_i)
        assert float(k) == pytest.approx(4.0 / 3.0 * e_star * np.sqrt(r_star), rel=1e-13)
    built = dry()
    assert float(built.stiffness) == pytest.approx(float(journal_law.contact_stiffness(RADIUS, CLEARANCE, 207e9, 0.3)), rel=1e-15)
    assert float(built.hole_radius) == RADIUS + CLEARANCE
    with pytest.raises(ValueError, match=r"^clearance must be positive \[m\]; got -1e-05\."):
        journal_law.contact_stiffness(RADIUS, -1e-5, 207e9, 0.3)


def short_bearing_force(eps, eps_dot, wedge, mu=0.06):
    """The film force on the journal along n and t [N]: the short-bearing pressure
    p = 3 mu (L^2/4 - z^2) (w sin th - 2 eps_dot cos th) / (c^2 (1 + eps cos th)^3), its
    positive part integrated over the surface by SciPy (z in closed form: L^3/6); the pressure
    at angle th (from the widest gap, along -n) pushes the journal along -(cos th, sin th) in
    the frame (-n, -t)."""
    def p(th):
        return max(3 * mu * (LENGTH**3 / 6) * (wedge * np.sin(th) - 2 * eps_dot * np.cos(th))
                   / (CLEARANCE**2 * (1 + eps * np.cos(th)) ** 3), 0.0)  # fmt: skip

    kinks = np.sort(np.mod(np.arctan2(2 * eps_dot, wedge) + np.array([0.0, np.pi]), 2 * np.pi))
    edges = [0.0, *kinks, 2 * np.pi]  # the positive part is smooth between them
    along = [
        sum(quad(lambda th: p(th) * f(th), a, b, epsabs=1e-5, epsrel=1e-11, limit=200)[0] for a, b in zip(edges, edges[1:]))
        for f in (np.cos, np.sin)
    ]
    return RADIUS * along[0], RADIUS * along[1]  # -R int p (cos, sin) along (-n, -t)


@pytest.mark.parametrize("eps", [0.0, 0.3, 0.7, 0.93])
def test_film_force_is_the_short_bearing_pressure_with_half_sommerfeld(eps):
    """Closed forms against the quadrature (to 1e-11) for wedge and squeeze of both signs (the
    positive pressure's half turn moving with them), to 1e-10 of the force's size."""
    rng = np.random.default_rng(int(100 * eps))
    for eps_dot, wedge in [(0.0, 50.0), (0.0, -50.0), (20.0, 0.0), (-20.0, 0.0), *rng.normal(0, 40, (6, 2))]:
        got = np.array(journal_law.film_force(eps, eps_dot, wedge, 0.06, RADIUS, LENGTH, CLEARANCE))
        want = np.array(short_bearing_force(eps, eps_dot, wedge))
        np.testing.assert_allclose(got, want, rtol=0, atol=1e-10 * np.abs(want).max())


def test_film_force_in_steady_running_is_the_classical_load_capacity():
    """Without squeeze (w = eps omega): F_n = -mu omega R L^3 eps^2 / (c^2 (1 - eps^2)^2) and
    F_t = pi mu omega R L^3 eps / (4 c^2 (1 - eps^2)^(3/2)) (Flores et al. 2009; Hamrock ch.
    10), so |F| is the load capacity and tan psi = -F_t / F_n = pi sqrt(1 - eps^2) / (4 eps);
    a journal pressed in (eps_dot > 0) meets a squeeze force along -n, and with omega = 0 the
    film carries nothing."""
    mu, omega = 0.06, 300.0
    for eps in (0.1, 0.5, 0.9):
        f_n, f_t = (float(x) for x in journal_law.film_force(eps, 0.0, eps * omega, mu, RADIUS, LENGTH, CLEARANCE))
        base = mu * omega * RADIUS * LENGTH**3 / CLEARANCE**2
        assert f_n == pytest.approx(-base * eps**2 / (1 - eps**2) ** 2, rel=1e-12)
        assert f_t == pytest.approx(np.pi * base * eps / (4 * (1 - eps**2) ** 1.5), rel=1e-12)
        capacity = base / 4 * eps * np.sqrt(16 * eps**2 + np.pi**2 * (1 - eps**2)) / (1 - eps**2) ** 2
        assert np.hypot(f_n, f_t) == pytest.approx(capacity, rel=1e-12)
        squeeze = float(journal_law.film_force(eps, 5.0, 0.0, mu, RADIUS, LENGTH, CLEARANCE)[0])
        assert squeeze < 0.0
        assert np.all(np.array(journal_law.film_force(eps, 0.0, 0.0, mu, RADIUS, LENGTH, CLEARANCE)) == 0.0)


# -- the rigid-pin limit ---------------------------------------------------------------------------


def test_a_stiff_tight_journal_converges_to_the_rigid_pin():
    """Clearance 1 um -> 10 nm, stiffness 1e11 -> 1e13 N/m^1.5 (e_c 0.5, no friction): the
    peak and RMS |F| of the joint over a crank turn after the start-up approach the rigid pin's
    (the Newton–Euler solution in NumPy), the error falling at each step and below 1e-5 at the
    stiffest (measured: 2.7e-5, 5.9e-6, 1.4e-6 in the peak; 7.5e-5, 1.3e-5, 2.4e-6 in the RMS);
    the force follows the pin's within 0.1 % of its peak at every output time."""
    fine = np.linspace(START, START + TURN, 20001)
    pin = ref.slider_crank_pin_force(fine, W, CRANK_LENGTH, ROD_LENGTH, MASSES["m_rod"], MASSES["j_rod"], MASSES["m_slider"])
    magnitude = np.linalg.norm(pin, axis=1)
    rms = np.sqrt(np.trapezoid(magnitude**2, fine) / TURN)
    errors = []
    for clearance, stiffness in ((1e-6, 1e11), (1e-7, 1e12), (1e-8, 1e13)):
        model = crank(JournalBearing(clearance, RADIUS, LENGTH, stiffness, 0.5))
        sol = jb.simulate(model, START + TURN, np.linspace(0.0, START + TURN, 301))
        errors.append((float(PIN(sol)) / magnitude.max() - 1, float(RMS(sol)) / rms - 1))
    errors = np.abs(np.array(errors))
    assert np.all(np.diff(errors, axis=0) < 0), errors
    assert errors[-1].max() < 1e-5, errors
    after = np.asarray(sol.ts) >= START
    sampled = ref.slider_crank_pin_force(np.asarray(sol.ts)[after], W, CRANK_LENGTH, ROD_LENGTH, **MASSES)
    simulated = np.asarray(sol.elements["pin"].samples["force"])[after]  # on the crank (the hole's body)
    assert np.abs(simulated - sampled).max() < 1e-3 * magnitude.max()


# -- an independent solve with events ------------------------------------------------------------


def journal_state(model):
    """The journal's centre [m] and its velocity [m/s] at t0: the rod's point (-l3/2, 0)."""
    q, qd = np.asarray(model.q0), np.asarray(model.qd0)
    x, y, theta = q[3:6]
    arm = -ROD_LENGTH / 2 * np.array([np.cos(theta), np.sin(theta)])
    return np.array([x, y]) + arm, qd[3:5] + qd[5] * np.array([-arm[1], arm[0]])


def test_a_rattling_journal_agrees_with_an_independent_solve():
    """The paper's crank with the dry plain bearing (c 20 um, e_c 0.9, mu 0.1) over 0–0.02 s:
    the journal rattles in its hole, 11 contacts. Both solves at rtol 1e-12 (jaxbearing: the
    DAE with Baumgarte terms, events located to 1e-13 s; the reference: minimal coordinates,
    SciPy DOP853 with terminal events), each within about 1e-11 m of the exact solution
    (measured: orbits 2.1e-11 m, onsets 2.6e-10 s, contacts' peaks 7e-4 N apart; both
    rattles drift apart as a chaotic motion does, 100x more at rtol 1e-10). Bounds 10x above."""
    t1, ts = 0.02, np.linspace(0.0, 0.02, 401)
    journal = dry()
    model = crank(journal, window_start=None)
    sol = jb.simulate(model, t1, ts, stepsize_controller=TIGHT)
    x0, xd0 = journal_state(model)
    run = ref.clearance_slider_crank(
        t1, ts, omega=W, l2=CRANK_LENGTH, l3=ROD_LENGTH, **MASSES, clearance=CLEARANCE, radius=RADIUS,
        stiffness=float(journal.stiffness), restitution=0.9, friction=0.1, v0=1e-4, v1=1e-3,
        x0=x0, xd0=xd0, rtol=1e-12, atol=1e-16,
    )  # fmt: skip
    orbit = np.asarray(sol.elements["pin"].samples["eccentricity"])
    assert np.abs(orbit - run["e"]).max() < 3e-10
    assert np.abs(orbit).max() > CLEARANCE  # it touched
    episodes = sol.episodes
    valid = np.asarray(episodes.valid)
    assert valid.sum() == run["onsets"].size == 11
    np.testing.assert_allclose(np.asarray(episodes.time)[valid], run["onsets"], rtol=0, atol=3e-9)
    np.testing.assert_allclose(np.asarray(episodes.end)[valid][:10], run["ends"], rtol=0, atol=3e-9)
    # approach speeds: the onsets' bound times the journal's acceleration (~ omega^2 l2, 200 m/s^2)
    np.testing.assert_allclose(np.asarray(episodes.value)[valid], run["approach"], rtol=0, atol=1e-6)
    np.testing.assert_allclose(np.asarray(episodes.peak)[valid], run["peaks"], rtol=1e-5)
    assert float(jb.metrics.ElementPeak("normal_force", element="pin", t_min=None)(sol)) == pytest.approx(run["peaks"].max(), rel=1e-5)


# -- lubricated: the static equilibrium ------------------------------------------------------------

SPEED, VISCOSITY, LOADED_MASS = 1000.0, 0.01, 315.0  # [rad/s], [Pa s], [kg]: eps near 0.8
LOADED = jb.default_controller(rtol=1e-10, atol=1e-12)  # both loaded journals: one compiled solve


def load_capacity(eps):
    """W = mu omega R L^3 eps sqrt(16 eps^2 + pi^2 (1 - eps^2)) / (4 c^2 (1 - eps^2)^2) [N]
    (short bearing, half-Sommerfeld, steady; Hamrock ch. 10)."""
    base = VISCOSITY * SPEED * RADIUS * LENGTH**3 / (4 * CLEARANCE**2)
    return base * eps * np.sqrt(16 * eps**2 + np.pi**2 * (1 - eps**2)) / (1 - eps**2) ** 2


def test_a_lubricated_journal_settles_where_the_load_capacity_says():
    """A journal of 315 kg turning at 1000 rad/s (driven) in a fixed hole, under its weight,
    released centred: it settles at the eccentricity ratio whose short-bearing load capacity
    is its weight (eps = 0.7998, stable: above the short bearing's whirl threshold), below
    the hole's centre by the attitude angle tan psi = pi sqrt(1 - eps^2) / (4 eps) in the
    sense of rotation, within 1e-3 after 0.2 s (measured after 0.1 s: 7e-5 and 1.8e-4; the
    squeeze film damps the approach with a time constant of about 10 ms)."""
    weight = LOADED_MASS * ref.G0
    eps = brentq(lambda x: load_capacity(x) - weight, 1e-9, 1 - 1e-9, xtol=1e-15)
    psi = np.arctan(np.pi * np.sqrt(1 - eps**2) / (4 * eps))
    journal = JournalBearing(CLEARANCE, RADIUS, LENGTH, 1e12, 0.9, viscosity=VISCOSITY)
    model = jb.Mechanism(
        [Body(LOADED_MASS, 0.5 * LOADED_MASS * RADIUS**2)], [Driver(0, 0.0, SPEED)], [0.0, 0.0, 0.0],
        [0.0, 0.0, SPEED], forces={"pin": ClearanceJoint(GROUND, (0.0, 0.0), 0, (0.0, 0.0), journal), "gravity": Gravity()},
    )  # fmt: skip
    sol = jb.simulate(model, 0.2, np.linspace(0.0, 0.2, 11), stepsize_controller=LOADED)
    e = np.asarray(sol.elements["pin"].samples["eccentricity"])[-1]
    assert np.hypot(*e) / CLEARANCE == pytest.approx(eps, rel=1e-3)
    assert np.arctan2(e[0], -e[1]) == pytest.approx(psi, rel=1e-3)
    assert np.abs(np.asarray(sol.qd)[-1, :2]).max() < 1e-3 * eps * CLEARANCE * SPEED  # at rest
    film = np.asarray(sol.elements["pin"].samples["film_force"])[-1]  # on the hole: the weight
    np.testing.assert_allclose(film, [0.0, -weight], atol=1e-3 * weight)
    assert float(jb.metrics.ElementPeak("normal_force", element="pin")(sol)) == 0.0  # never touched
    assert int(sol.episodes.valid.sum()) == 0


def test_where_the_film_cannot_carry_the_load_the_contact_takes_the_rest():
    """The same journal under 6 000 kg, more than the film carries at its limit (W(0.95) =
    52.9 kN against 58.8 kN): the film force is held at its value at eps = `film_limit`, the
    journal presses into the hole, and at rest (after 0.2 s, within 1e-3; measured 3e-6) the
    film force is the load capacity at the limit, the contact's normal force what the weight
    leaves along n: with the film's components F_n, F_t at the limit (frictionless contact),
    sin phi = F_t / (m g) and F_N = m g cos phi + F_n, and the penetration Hertz's
    (F_N / K)^(2/3) (the hysteresis vanishes at rest)."""
    mass, limit, stiffness = 6000.0, 0.95, 1e12
    weight = mass * ref.G0
    base = VISCOSITY * SPEED * RADIUS * LENGTH**3 / CLEARANCE**2
    f_n = -base * limit**2 / (1 - limit**2) ** 2
    f_t = np.pi * base * limit / (4 * (1 - limit**2) ** 1.5)
    assert np.hypot(f_n, f_t) == pytest.approx(load_capacity(limit), rel=1e-12) and load_capacity(limit) < weight
    normal = weight * np.sqrt(1 - (f_t / weight) ** 2) + f_n
    journal = JournalBearing(CLEARANCE, RADIUS, LENGTH, stiffness, 0.9, viscosity=VISCOSITY, film_limit=limit)
    model = jb.Mechanism(
        [Body(mass, 0.5 * mass * RADIUS**2)], [Driver(0, 0.0, SPEED)], [0.0, 0.0, 0.0],
        [0.0, 0.0, SPEED], forces={"pin": ClearanceJoint(GROUND, (0.0, 0.0), 0, (0.0, 0.0), journal), "gravity": Gravity()},
    )  # fmt: skip
    sol = jb.simulate(model, 0.2, np.linspace(0.0, 0.2, 11), stepsize_controller=LOADED)
    pin = {name: np.asarray(x)[-1] for name, x in sol.elements["pin"].samples.items()}
    assert np.hypot(*pin["film_force"]) == pytest.approx(load_capacity(limit), rel=1e-3)
    assert float(pin["normal_force"]) == pytest.approx(normal, rel=1e-3)
    assert float(pin["penetration"]) == pytest.approx((normal / stiffness) ** (2 / 3), rel=1e-3)
    np.testing.assert_allclose(pin["force"], [0.0, -weight], atol=1e-3 * weight)
    assert int(sol.episodes.valid.sum()) == 1 and np.isnan(float(sol.episodes.end[0]))  # one lasting contact


# -- energy ------------------------------------------------------------------------------------

ROD, GAP, PIN_RADIUS = 0.2, 0.1e-3, 5e-3  # [m]


def test_an_elastic_frictionless_journal_keeps_the_energy():
    """A 0.2 m rod (1 kg) hanging from a dry journal (c 0.1 mm, e_c 1, no friction, no oil),
    released level: it falls and swings, the journal bouncing in its hole (elastic: the
    bounces never die out). Kinetic + gravity + contact energy (2/5) K delta^(5/2) is constant
    within 1e-7 of m g l/2 at rtol 1e-10 over 0.3 s (99 contacts; measured 1.8e-8)."""
    mass, inertia = 1.0, ROD**2 / 12
    journal = JournalBearing.from_geometry(radius=PIN_RADIUS, clearance=GAP, length=5e-3, restitution=1.0)
    model = jb.Mechanism(
        [Body(mass, inertia)], [], [ROD / 2, 0.0, 0.0],
        forces={"pin": ClearanceJoint(GROUND, (0.0, 0.0), 0, (-ROD / 2, 0.0), journal), "gravity": Gravity()},
    )  # fmt: skip
    sol = jb.simulate(model, 0.3, np.linspace(0.0, 0.3, 3001), stepsize_controller=jb.default_controller(rtol=1e-10, atol=1e-12))
    q, qd = np.asarray(sol.q), np.asarray(sol.qd)
    depth = np.maximum(np.asarray(sol.elements["pin"].samples["penetration"]), 0.0)
    energy = (0.5 * mass * (qd[:, 0] ** 2 + qd[:, 1] ** 2) + 0.5 * inertia * qd[:, 2] ** 2
              + mass * ref.G0 * q[:, 1] + 0.4 * float(journal.stiffness) * depth**2.5)  # fmt: skip
    assert np.ptp(energy) < 1e-7 * mass * ref.G0 * ROD / 2
    assert int(sol.episodes.valid.sum()) > 50 and q[:, 2].min() < -np.pi / 2  # bounced, swung


# -- records, metrics, paths, rules -----------------------------------------------------------------


@pytest.fixture(scope="module")
def rattle():
    model = crank(dry(), window_start=None)
    return model, jb.simulate(model, 0.02, np.linspace(0.0, 0.02, 401))


def test_records_are_exact_and_the_samples_consistent(rattle):
    """The exact peaks bound the samples; the samples' eccentricity is the journal's centre
    from the hole's in q; the force is the contact's normal and friction forces along n and t
    (dry: no film); the RMS is the samples' within their resolution."""
    model, sol = rattle
    pin = sol.elements["pin"]
    assert pin.kind == "ClearanceJoint" and sol.contacts.count == 0  # not an impact contact
    assert set(pin.records.peaks) == {"normal_force", "penetration", "eccentricity_ratio", "force_magnitude"}
    for name in ("normal_force", "penetration", "eccentricity_ratio", "force_magnitude"):
        exact = float(jb.metrics.ElementPeak(name, element="pin", t_min=None)(sol))
        assert exact >= np.max(np.asarray(pin.samples[name])) - 1e-12 * abs(exact)
    assert float(jb.metrics.ElementPeak("penetration", element="pin", t_min=None)(sol)) == pytest.approx(
        CLEARANCE * (float(jb.metrics.ElementPeak("eccentricity_ratio", element="pin", t_min=None)(sol)) - 1), rel=1e-9)
    orbit = jb.report.orbit(sol, model, element="pin")
    np.testing.assert_allclose(np.asarray(pin.samples["eccentricity"]), orbit, rtol=0, atol=1e-15)
    e = np.asarray(pin.samples["eccentricity"])[1:]  # centred at t0: no direction
    n = e / np.linalg.norm(e, axis=1)[:, None]
    t = np.stack([-n[:, 1], n[:, 0]], 1)
    normal, friction = (np.asarray(pin.samples[name])[1:] for name in ("normal_force", "friction_force"))
    on_hole = normal[:, None] * n - friction[:, None] * t  # the journal's forces, reversed
    np.testing.assert_allclose(np.asarray(pin.samples["force"])[1:], on_hole, rtol=0, atol=1e-9)
    assert np.all(np.asarray(pin.samples["film_force"]) == 0.0)
    ratio = np.abs(friction[normal > 0] / normal[normal > 0])
    assert np.all(ratio <= 0.1 + 1e-12) and ratio.max() == pytest.approx(0.1)  # sliding: full friction


def test_paths_name_every_parameter_and_a_sweep_reads_them(rattle):
    model, _ = rattle
    listed = jb.paths.parameter_paths(model)
    for field in ("clearance", "radius", "length", "stiffness", "restitution", "friction", "friction_v0",
                  "friction_v1", "viscosity", "film_limit"):  # fmt: skip
        assert f"pin.journal.{field}" in listed and f"forces.0.journal.{field}" in listed
    assert jb.paths.get(model, "pin.journal.clearance") is model.forces[0].journal.clearance
    wider = jb.paths.replace(model, {"pin.journal.clearance": 2 * CLEARANCE})
    assert float(wider.forces[0].journal.clearance) == 2 * CLEARANCE
    assert float(wider.forces[0].play()) == 4 * CLEARANCE  # diametral


def test_bad_parameters_are_refused_by_name():
    with pytest.raises(ValueError, match=r"^clearance must be positive \[m\]; got 0\."):
        JournalBearing(0.0, RADIUS, LENGTH, 1e11, 0.9)
    with pytest.raises(ValueError, match=r"^clearance must exceed 1e-09 m, the penetration at which a contact ends"):
        JournalBearing(5e-10, RADIUS, LENGTH, 1e11, 0.9)
    with pytest.raises(ValueError, match=r"^restitution must lie in \(0\.0, 1\.0\]; got 1\.2\."):
        JournalBearing(CLEARANCE, RADIUS, LENGTH, 1e11, 1.2)
    with pytest.raises(ValueError, match=r"^friction_v1 must exceed friction_v0 \[m/s\]; got 0\.0001\."):
        JournalBearing(CLEARANCE, RADIUS, LENGTH, 1e11, 0.9, friction_v1=1e-4)
    with pytest.raises(ValueError, match=r"^viscosity must be zero or positive \[Pa s\]; got -0\.1\."):
        JournalBearing(CLEARANCE, RADIUS, LENGTH, 1e11, 0.9, viscosity=-0.1)
    with pytest.raises(ValueError, match=r"^film_limit must lie in \(0\.0, 1\.0\); got 1\."):
        JournalBearing(CLEARANCE, RADIUS, LENGTH, 1e11, 0.9, film_limit=1.0)
    with pytest.raises(ValueError, match=r"^clearance must be one number; got shape \(2,\)\."):
        JournalBearing([1e-5, 2e-5], RADIUS, LENGTH, 1e11, 0.9)
    with pytest.raises(TypeError, match=r"ClearanceJoint's journal must be a jaxbearing\.JournalBearing; got Impact\."):
        ClearanceJoint(0, (0.0, 0.0), 1, (0.0, 0.0), jb.Impact(1e10, 0.9))
    with pytest.raises(ValueError, match=r"two different bodies"):
        ClearanceJoint(0, (0.0, 0.0), 0, (0.0, 0.0), dry())
    paper = crank(dry())
    with pytest.raises(ValueError, match=r"joint 5 \(Revolute, crank–rod\) joins the two bodies of force 0 \(ClearanceJoint\) at the points it centres"):
        jb.Mechanism(paper.bodies, paper.joints + (Revolute(0, (CRANK_LENGTH / 2, 0.0), 1, (-ROD_LENGTH / 2, 0.0)),),
                     paper.q0, paper.qd0, forces=paper.forces, body_names=paper.body_names)  # fmt: skip


def test_a_value_set_later_is_checked_by_the_solve_and_named_by_its_path(rattle):
    model, _ = rattle
    broken = eqx.tree_at(lambda m: m.forces[0].journal.clearance, model, jnp.asarray(-1e-6))
    with pytest.raises(ValueError, match=r"^pin\.journal\.clearance must be positive \[m\]; got -1e-06\."):
        jb.simulate(broken, 0.02, np.linspace(0.0, 0.02, 401))


def test_assembly_centres_the_journal():
    """A guess with the journal 5 um off its hole's centre and the slider off its rail is
    assembled with the journal centred (`AbstractForceElement.centred`), as a bearing is."""
    model = crank(dry())
    guess = np.asarray(model.q0) + np.array([0, 0, 0, 5e-6, -3e-6, 0, 2e-6, 1e-6, 0, 0, 0, 0])
    assembled = model.assemble(guess)
    q = np.asarray(assembled.q0)
    centre = jb.report._draw.place(q, 0, (CRANK_LENGTH / 2, 0.0))
    journal = jb.report._draw.place(q, 1, (-ROD_LENGTH / 2, 0.0))
    assert np.abs(journal - centre).max() < 1e-12


def test_the_drawing_shows_the_hole_and_the_journal_at_its_eccentricity(rattle):
    """The hole is drawn with its clearance, the journal at the eccentricity, both enlarged by
    the stated factor (0.3 R / c = 187.5 -> 100), so that the circles touch where the journal
    touches the hole; the orbit's plot holds the samples within the circle of radius c."""
    model, sol = rattle
    assert jb.report._draw.default_clearance_scale(model) == 100.0
    k = np.argmax(np.asarray(sol.elements["pin"].samples["penetration"]))
    q = np.asarray(sol.q)[k]
    fig = jb.report.draw(model, q)
    patches = {p.get_gid(): p for p in fig.axes[0].patches}
    hole, journal = patches["force 0 hole"], patches["force 0 journal"]
    assert hole.get_radius() == pytest.approx(RADIUS + 100 * CLEARANCE, rel=1e-12)
    assert journal.get_radius() == pytest.approx(RADIUS, rel=1e-12)
    e = np.asarray(sol.elements["pin"].samples["eccentricity"])[k]
    np.testing.assert_allclose(np.subtract(journal.center, hole.center), 100 * e, rtol=1e-12)
    gap = hole.get_radius() - journal.get_radius() - np.hypot(*np.subtract(journal.center, hole.center))
    assert gap == pytest.approx(-100 * float(sol.elements["pin"].samples["penetration"][k]), rel=1e-9)
    assert "×100" in next(t.get_text() for t in fig.axes[0].texts if t.get_gid() == "clearance scale")
    plot = jb.report.plot_orbit(sol, model, element="pin", window=(0.0, 0.02))
    line = next(x for x in plot.axes[0].lines if x.get_gid() == "orbit 0")
    np.testing.assert_allclose(np.c_[line.get_xdata(), line.get_ydata()], 1e6 * np.asarray(sol.elements["pin"].samples["eccentricity"]))
    assert plot.axes[0].patches[0].get_radius() == pytest.approx(1e6 * CLEARANCE)
    with pytest.raises(ValueError, match=r"force 1 'target spring' \(SpringDamper, ground–target\) has no orbit"):
        jb.report.plot_orbit(sol, model, element="target spring")


@pytest.mark.slow  # a forward-mode derivative's compile and two solves at derivative tolerances
def test_the_peak_joint_force_s_derivative_in_the_clearance():
    """d(peak |F|)/dc over the first impact (0–0.8 ms) by forward mode at `jb.DERIVATIVE_RTOL`
    against central differences of solves at the same tolerances: within 2 % (measured 1e-5,
    d peak / dc = 9.15e7 N/m: a wider clearance, a faster impact)."""
    model = crank(dry(), window_start=None)
    _, grad = jb.sensitivity(model, PIN, ["pin.journal.clearance"], t1=0.0008)
    controller = jb.derivative_controller()

    def at(c):
        changed = jb.paths.replace(model, {"pin.journal.clearance": c})
        return float(PIN(jb.simulate(changed, 0.0008, stepsize_controller=controller)))

    h = 1e-9
    difference = (at(CLEARANCE + h) - at(CLEARANCE - h)) / (2 * h)
    assert float(grad["pin.journal.clearance"]) == pytest.approx(difference, rel=0.02)
    assert difference > 0.0

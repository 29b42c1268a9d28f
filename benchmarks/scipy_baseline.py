"""The SciPy baseline: the paper's impact slider–crank in plain NumPy, integrated by `solve_ivp`.

    python benchmarks/scipy_baseline.py [--t1 0.2] [--methods LSODA,BDF,Radau,RK45,DOP853]
                                        [--rtols 1e-8,1e-7] [--max-wall 120] [--json out.json]

The equations are those of `jaxbearing.cases.xu2014` (docs/model.md), written again here without
JAX: Eq. 36 with Baumgarte stabilisation, solved as one dense augmented system per right-hand
side call; the per-ball force of Eq. 9 with the kinematic cage; the Lankarani–Nikravesh contact
(Eq. 23, frictionless as in the paper) switched on at t >= 0.05 s; the target's spring-damper.
Only the numbers (masses, stiffnesses, initial state, ...) are read from a jaxbearing model, once,
by `Params.from_model`.

Contact onsets and separations are located by `solve_ivp`'s terminal events, as
`jaxbearing.simulate` does: the penetration crossing 0 upwards while apart (onset; its rate there
is the approach speed of Eq. 23) and falling below -`SEPARATION_OFFSET` while touching
(separation); the integration restarts at each event.

The command line runs each method at each rtol (atol = rtol/100), compares it with jaxbearing
at tolerances 1000x tighter than the tightest (positions [m] at every output time, ball loads [N]
at the Table-5 times, the contact onsets), prints a table, the fastest run that stays accurate
and its ratio to a compiled jaxbearing run at its defaults. A run that exceeds --max-wall seconds
is stopped and reported as such.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import math
import time

import numpy as np
from scipy.integrate import solve_ivp

SEPARATION_OFFSET = 1e-9  # [m], as jaxbearing.simulate: separation at penetration = -1 nm
N_COORDS = 12  # crank, rod, slider, target; [x, y, theta] each
N_CONSTRAINTS = 9  # ground pin 2, driver 1, rod–slider pin 2, two translational joints 2 + 2
POSITIONS = [0, 1, 3, 4, 6, 7, 9, 10]  # x, y of every body [m]: what "position error" compares
POSITION_TOLERANCE = 1e-7  # [m] accuracy check of a run against a reference (issue 5)
LOAD_TOLERANCE = 0.5  # [N] likewise, ball loads at the Table-5 times


class BaselineTimeout(RuntimeError):
    """The integration exceeded its wall-time cap; ``t`` is the simulated time reached [s]."""

    def __init__(self, method, max_wall, t):
        super().__init__(f"{method} stopped after {max_wall:g} s of wall time at t = {t:.6g} s")
        self.t = t


@dataclasses.dataclass(frozen=True)
class Params:
    """Numbers of the paper's case (SI units): Python floats, the initial state as arrays.

    Bodies in jaxbearing's order: 0 crank, 1 rod, 2 slider, 3 target.
    """

    masses: tuple  # [kg], per body
    inertias: tuple  # [kg m^2], per body
    q0: np.ndarray  # (12,) [m, rad]
    qd0: np.ndarray  # (12,) [m/s, rad/s]
    crank_length: float  # L2 [m]: ground pin at crank point (-L2/2, 0), outer race at (+L2/2, 0)
    rod_length: float  # L3 [m]: inner race at rod point (-L3/2, 0), slider pin at (+L3/2, 0)
    crank_angle: float  # driver, theta_crank = angle + omega t: angle [rad]
    crank_speed: float  # and omega [rad/s]
    clearance: float  # P_d [m]
    ball_stiffness: float  # K_b [N/m^n]
    ball_exponent: float  # n of Eq. 9
    ball_damping: float  # C_b [N s/m]
    inner_race_diameter: float  # d_i [m]
    outer_race_diameter: float  # d_o [m]
    n_balls: int
    spring_anchor: tuple  # ground point of the target's spring [m]
    spring_stiffness: float  # [N/m]
    spring_damping: float  # [N s/m]
    spring_free_length: float  # [m]
    contact: bool  # slider–target impact present
    contact_radii: float  # R_slider + R_target [m]
    contact_stiffness: float  # K_d [N/m^1.5]
    restitution: float  # e_c
    contact_on: float  # the contact acts for t >= contact_on [s]
    baumgarte_alpha: float  # [1/s]
    baumgarte_beta: float  # [1/s]

    @classmethod
    def from_model(cls, model) -> Params:
        """Read the numbers of a `jaxbearing.cases.xu2014(...)` mechanism (kinematic cage, paper
        ball force, frictionless contact). Only the numbers are taken: the layout of bodies,
        joints and forces is the one this module writes out."""
        from jaxbearing.multibody import BearingJoint, CircleContact, Driver, Revolute, SpringDamper

        ground_pin, driver, rod_pin = model.joints[:3]
        bearing_joint, spring, *contacts = model.forces
        if not (
            isinstance(ground_pin, Revolute)
            and isinstance(driver, Driver)
            and isinstance(rod_pin, Revolute)
            and isinstance(bearing_joint, BearingJoint)
            and isinstance(spring, SpringDamper)
        ):
            raise ValueError("Params.from_model needs a jaxbearing.cases.xu2014 mechanism.")
        b = bearing_joint.bearing
        if b.cage != "kinematic" or b.ball_force != "paper":
            raise ValueError("The baseline has the kinematic cage and the paper's ball force only.")
        contact = bool(contacts)
        if contact:
            (c,) = contacts
            if not isinstance(c, CircleContact) or float(c.impact.friction) != 0.0:
                raise ValueError("The baseline implements the paper's frictionless circle contact.")
        f = float
        return cls(
            masses=tuple(f(body.mass) for body in model.bodies),
            inertias=tuple(f(body.inertia) for body in model.bodies),
            q0=np.asarray(model.q0, float),
            qd0=np.asarray(model.qd0, float),
            crank_length=-2.0 * f(ground_pin.point_j[0]),
            rod_length=2.0 * f(rod_pin.point_i[0]),
            crank_angle=f(driver.angle),
            crank_speed=f(driver.speed),
            clearance=f(b.clearance),
            ball_stiffness=f(b.stiffness),
            ball_exponent=f(b.exponent),
            ball_damping=f(b.damping),
            inner_race_diameter=f(b.inner_race_diameter),
            outer_race_diameter=f(b.outer_race_diameter),
            n_balls=b.n_balls,
            spring_anchor=(f(spring.point_i[0]), f(spring.point_i[1])),
            spring_stiffness=f(spring.stiffness),
            spring_damping=f(spring.damping),
            spring_free_length=f(spring.free_length),
            contact=contact,
            contact_radii=f(c.radius_j + c.radius_k) if contact else 0.0,
            contact_stiffness=f(c.impact.stiffness) if contact else 0.0,
            restitution=f(c.impact.restitution) if contact else 1.0,
            contact_on=f(c.active_from) if contact else math.inf,
            baumgarte_alpha=f(model.baumgarte_alpha),
            baumgarte_beta=f(model.baumgarte_beta),
        )


class SliderCrank:
    """Equations of motion of the paper's case in NumPy (Eqs. 9, 12–14, 23, 28–30, 36).

    State y = [q, q_dot], q = [x, y, theta] of crank, rod, slider, target [m, rad].
    """

    def __init__(self, p: Params):
        self.p = p
        self.ball_base = 2.0 * np.pi * np.arange(p.n_balls) / p.n_balls  # phi_r - phi_c [rad]
        # Constant part of [M Phi_q^T; Phi_q 0]; the entries that depend on the crank and rod
        # angles (the pinned points' arms) are written per call in `accelerations`.
        a = np.zeros((N_COORDS + N_CONSTRAINTS,) * 2)
        for b in range(4):
            a[3 * b, 3 * b] = a[3 * b + 1, 3 * b + 1] = p.masses[b]
            a[3 * b + 2, 3 * b + 2] = p.inertias[b]
        jac = a[N_COORDS:, :N_COORDS]
        jac[0, 0] = jac[1, 1] = -1.0  # ground pin: 0 - (r_crank + A s)
        jac[2, 2] = 1.0  # driver: theta_crank - omega t
        jac[3, 3] = jac[4, 4] = 1.0  # rod pin: r_rod + A s - r_slider
        jac[3, 6] = jac[4, 7] = -1.0
        jac[5, 7] = jac[6, 8] = 1.0  # slider: y = 0, theta = 0
        jac[7, 10] = jac[8, 11] = 1.0  # target: y = 0, theta = 0
        a[:N_COORDS, N_COORDS:] = jac.T
        self.augmented = a

    # -- kinematics of the bearing and the contact -----------------------------------------
    def arms(self, q):
        """Global arms A s [m] of the crank's ground pin (s = (-L2/2, 0)), the outer race
        (s = (+L2/2, 0)), the inner race (s = (-L3/2, 0)) and the rod's slider pin (+L3/2, 0)."""
        h2, h3 = 0.5 * self.p.crank_length, 0.5 * self.p.rod_length
        c2, s2 = math.cos(q[2]), math.sin(q[2])
        c3, s3 = math.cos(q[5]), math.sin(q[5])
        return (-h2 * c2, -h2 * s2), (h2 * c2, h2 * s2), (-h3 * c3, -h3 * s3), (h3 * c3, h3 * s3)

    def balls(self, q, qd):
        """Ball forces [N] (N_b,), ball 1 first, and the cosines and sines of the ball angles
        phi_r (Eqs. 9, 12–14)."""
        p = self.p
        _, outer, inner, _ = self.arms(q)
        # eccentricity e = inner-race centre - outer-race centre (Eq. 4) and its rate (Eq. 5)
        ex = q[3] + inner[0] - q[0] - outer[0]
        ey = q[4] + inner[1] - q[1] - outer[1]
        vx = qd[3] - qd[5] * inner[1] - qd[0] + qd[2] * outer[1]
        vy = qd[4] + qd[5] * inner[0] - qd[1] - qd[2] * outer[0]
        # kinematic cage: ring rotations since t = 0 weighted by the raceway diameters
        d_i, d_o = p.inner_race_diameter, p.outer_race_diameter
        cage = (d_i * (q[5] - p.q0[5]) + d_o * (q[2] - p.q0[2])) / (d_i + d_o)
        phi = self.ball_base + cage
        cos, sin = np.cos(phi), np.sin(phi)
        delta = ex * cos + ey * sin - 0.5 * p.clearance
        touching = delta > 0.0
        depth = np.where(touching, delta, 0.0)
        force = p.ball_stiffness * depth**p.ball_exponent + p.ball_damping * (vx * cos + vy * sin)
        return np.where(touching, np.maximum(force, 0.0), 0.0), cos, sin

    def bearing_force(self, q, qd):
        """Resultant (Fx, Fy) [N] of the balls on the crank, the outer race (Eq. 28)."""
        loads, cos, sin = self.balls(q, qd)
        return float(loads @ cos), float(loads @ sin)

    def gap(self, q, qd):
        """Slider–target penetration [m], its rate [m/s] (> 0 approaching) and the unit normal
        from slider to target (Eqs. 18–21)."""
        dx, dy = q[9] - q[6], q[10] - q[7]
        distance = math.hypot(dx, dy)
        nx, ny = dx / distance, dy / distance
        rate = -((qd[9] - qd[6]) * nx + (qd[10] - qd[7]) * ny)
        return self.p.contact_radii - distance, rate, nx, ny

    def contact_force(self, t, q, qd, approach_speed):
        """Lankarani–Nikravesh normal force [N] (Eq. 23), zero before ``contact_on``, when apart
        and never pulling; ``approach_speed`` [m/s] is the rate at the current contact's onset
        (a non-positive value gives the elastic Hertz force)."""
        p = self.p
        penetration, rate, _, _ = self.gap(q, qd)
        if not p.contact or t < p.contact_on or penetration <= 0.0:
            return 0.0
        hysteresis = 0.0  # a contact that starts at rest: elastic Hertz
        if approach_speed > 0.0:
            hysteresis = 0.75 * (1.0 - p.restitution**2) * rate / approach_speed
        hertz = p.contact_stiffness * penetration * math.sqrt(penetration)
        return max(hertz * (1.0 + hysteresis), 0.0)

    # -- equations of motion (Eq. 36) ------------------------------------------------------
    def generalized_forces(self, t, q, qd, approach_speed):
        """Q_A [N, N m], (12,): bearing (Eqs. 28–30, at the race centres), spring-damper on the
        target, contact (Eqs. 31–34; the normal passes through both centroids: no moments)."""
        p = self.p
        out = np.zeros(N_COORDS)
        _, outer, inner, _ = self.arms(q)
        fx, fy = self.bearing_force(q, qd)
        out[0:3] = fx, fy, outer[0] * fy - outer[1] * fx
        out[3:6] = -fx, -fy, -(inner[0] * fy - inner[1] * fx)
        # spring-damper from its ground anchor to the target centroid: tension k (l - l0) + c l'
        dx, dy = q[9] - p.spring_anchor[0], q[10] - p.spring_anchor[1]
        length = math.hypot(dx, dy)
        ux, uy = dx / length, dy / length
        tension = p.spring_stiffness * (length - p.spring_free_length) + p.spring_damping * (
            qd[9] * ux + qd[10] * uy
        )
        out[9] -= tension * ux
        out[10] -= tension * uy
        if p.contact:
            normal = self.contact_force(t, q, qd, approach_speed)
            _, _, nx, ny = self.gap(q, qd)
            out[6] -= normal * nx
            out[7] -= normal * ny
            out[9] += normal * nx
            out[10] += normal * ny
        return out

    def accelerations(self, t, q, qd, approach_speed):
        """q_ddot [m/s^2, rad/s^2] from the dense augmented system of Eq. 36:
        [M Phi_q^T; Phi_q 0][q_ddot; lambda] = [Q_A; gamma - 2 alpha Phi_dot - beta^2 Phi].
        ``q``, ``qd``: 12 floats each (lists: scalar arithmetic on Python floats is cheaper than
        on NumPy scalars)."""
        p = self.p
        pin, _, _, rod_pin = self.arms(q)
        a = self.augmented.copy()
        # Phi_q columns of the angles: -d(A s)/dtheta for the ground pin, +d(A s)/dtheta for
        # the rod pin; d(A s)/dtheta = (-arm_y, arm_x)
        jac_crank = (pin[1], -pin[0])
        jac_rod = (-rod_pin[1], rod_pin[0])
        a[N_COORDS, 2], a[N_COORDS + 1, 2] = jac_crank
        a[N_COORDS + 3, 5], a[N_COORDS + 4, 5] = jac_rod
        a[2, N_COORDS], a[2, N_COORDS + 1] = jac_crank
        a[5, N_COORDS + 3], a[5, N_COORDS + 4] = jac_rod
        phi = np.array(
            [
                -(q[0] + pin[0]),
                -(q[1] + pin[1]),
                q[2] - p.crank_angle - p.crank_speed * t,
                q[3] + rod_pin[0] - q[6],
                q[4] + rod_pin[1] - q[7],
                q[7],
                q[8],
                q[10],
                q[11],
            ]
        )
        phi_dot = a[N_COORDS:, :N_COORDS] @ np.asarray(qd)
        phi_dot[2] -= p.crank_speed  # Phi_t of the driver
        # gamma = -(Phi_q q_dot)_q q_dot: the centripetal terms A s theta_dot^2 of the pins
        gamma = np.zeros(N_CONSTRAINTS)
        # (products, not **: a Python float overflows to inf there, where ** raises, and the
        # solver must see inf to reject a wild trial step)
        w2, w3 = qd[2] * qd[2], qd[5] * qd[5]
        gamma[0:2] = -w2 * pin[0], -w2 * pin[1]
        gamma[3:5] = w3 * rod_pin[0], w3 * rod_pin[1]
        rhs = np.concatenate(
            [
                self.generalized_forces(t, q, qd, approach_speed),
                gamma - 2.0 * p.baumgarte_alpha * phi_dot - p.baumgarte_beta**2 * phi,
            ]
        )
        return np.linalg.solve(a, rhs)[:N_COORDS]


def _xu2014(impact: bool):
    """`jaxbearing.cases.xu2014(impact=impact)`, with JAX switched to float64 first."""
    import jax

    jax.config.update("jax_enable_x64", True)
    import jaxbearing as jb

    return jb.cases.xu2014(impact=impact)


def simulate(
    t1: float,
    ts=None,
    *,
    impact: bool = True,
    method: str = "LSODA",
    rtol: float = 1e-8,
    atol: float = 1e-10,
    max_wall: float | None = None,
    params: Params | None = None,
) -> dict:
    """Integrate the paper's case from 0 to ``t1`` [s] with `scipy.integrate.solve_ivp`.

    Args:
        t1: final time [s].
        ts: output times [s], increasing, within [0, t1] (default 1001 points).
        impact: with the slider–target contact (`jaxbearing.cases.xu2014(impact=...)`).
        method: a `solve_ivp` method: "LSODA", "BDF", "Radau", "RK45", "DOP853", "RK23".
        rtol, atol: `solve_ivp`'s tolerances (state in m, rad, m/s, rad/s).
        max_wall: wall-time cap [s]; past it the run stops with `BaselineTimeout`.
        params: the numbers of the case (default: `Params.from_model(xu2014(impact=impact))`).

    Returns a dict:
        ts (T,) [s]; q, qd (T, 12) [m, rad], [m/s, rad/s]; ball_loads (T, 8) [N], ball 1 first;
        bearing_force (T, 2) [N] on the crank; contact_force (T,) [N];
        onset_times, approach_speeds: contact onsets [s] and penetration rates there [m/s];
        end_times: separations [s] (penetration -SEPARATION_OFFSET);
        steps (accepted, over all segments), rhs_calls (right-hand side evaluations, Jacobian
        columns included), segments, wall_s (integration and outputs) [s], method, rtol, atol.

    Raises `BaselineTimeout` past ``max_wall`` and `RuntimeError` if `solve_ivp` fails.
    """
    if params is None:
        params = Params.from_model(_xu2014(impact))
    model = SliderCrank(params)
    ts = np.linspace(0.0, t1, 1001) if ts is None else np.asarray(ts, float)
    n = N_COORDS
    start = time.perf_counter()
    deadline = math.inf if max_wall is None else start + max_wall
    calls = 0
    state = {"approach": 0.0, "in_contact": False}

    def rhs(t, y):
        nonlocal calls
        calls += 1
        if time.perf_counter() > deadline:
            raise BaselineTimeout(method, max_wall, t)
        qdd = model.accelerations(t, y[:n].tolist(), y[n:].tolist(), state["approach"])
        return np.concatenate([y[n:], qdd])

    def event(t, y):
        """Negative until the next event: the penetration while apart, -(penetration +
        SEPARATION_OFFSET) while touching, -1 while the contact is switched off."""
        if t < params.contact_on:
            return -1.0
        penetration = model.gap(y[:n], y[n:])[0]
        return -(penetration + SEPARATION_OFFSET) if state["in_contact"] else penetration

    event.terminal, event.direction = True, 1.0
    events = event if params.contact else None

    y = np.concatenate([params.q0, params.qd0])
    t = 0.0
    out = np.full((ts.size, 2 * n), np.nan)
    approach_out = np.zeros(ts.size)
    onsets, speeds, ends = [], [], []
    steps = segments = 0
    while True:
        sol = solve_ivp(
            rhs, (t, t1), y, method=method, rtol=rtol, atol=atol, events=events, dense_output=True
        )
        if sol.status < 0:
            raise RuntimeError(f"solve_ivp {method} failed at t = {sol.t[-1]:.6g} s: {sol.message}")
        segments += 1
        steps += sol.t.size - 1
        t_end = sol.t[-1]
        mine = (ts >= t) & (ts <= t_end)
        if mine.any():  # segments between close events may hold no output time
            out[mine] = sol.sol(ts[mine]).T
            approach_out[mine] = state["approach"]
        if sol.status == 0:
            break
        t, y = sol.t_events[0][0], sol.y_events[0][0]
        if not state["in_contact"]:
            state["approach"] = model.gap(y[:n], y[n:])[1]
            onsets.append(t)
            speeds.append(state["approach"])
        else:
            ends.append(t)
        state["in_contact"] = not state["in_contact"]
    q, qd = out[:, :n], out[:, n:]
    loads = np.array([model.balls(q[i], qd[i])[0] for i in range(ts.size)])
    bearing = np.array([model.bearing_force(q[i], qd[i]) for i in range(ts.size)])
    contact = np.array(
        [model.contact_force(ts[i], q[i], qd[i], approach_out[i]) for i in range(ts.size)]
    )
    return dict(
        ts=ts,
        q=q,
        qd=qd,
        ball_loads=loads,
        bearing_force=bearing,
        contact_force=contact,
        onset_times=np.array(onsets),
        approach_speeds=np.array(speeds),
        end_times=np.array(ends),
        steps=steps,
        rhs_calls=calls,
        segments=segments,
        wall_s=time.perf_counter() - start,
        method=method,
        rtol=rtol,
        atol=atol,
    )


def compare(run: dict, reference, table5_index) -> dict:
    """Errors of a baseline ``run`` against a jaxbearing `Solution` at the same output times:
    positions (x, y of every body) [m] at all times, ball loads [N] at ``table5_index``, the
    contact onsets (count, and the largest time difference [s] when the counts agree), and
    ``accurate``: within POSITION_TOLERANCE and LOAD_TOLERANCE with every onset found."""
    ref_onsets = np.asarray(reference.contacts.time)[np.asarray(reference.contacts.valid)]
    same_count = run["onset_times"].size == ref_onsets.size
    ref_q, ref_loads = np.asarray(reference.q), np.asarray(reference.ball_loads)
    position = np.max(np.abs(run["q"][:, POSITIONS] - ref_q[:, POSITIONS]))
    load = np.max(np.abs(run["ball_loads"][table5_index] - ref_loads[table5_index]))
    onset_dt = math.nan
    if same_count:
        onset_dt = np.max(np.abs(run["onset_times"] - ref_onsets), initial=0.0)
    return dict(
        position_error_m=float(position),
        ball_load_error_N=float(load),
        onsets=int(run["onset_times"].size),
        reference_onsets=int(ref_onsets.size),
        onset_time_error_s=float(onset_dt),
        accurate=bool(position <= POSITION_TOLERANCE and load <= LOAD_TOLERANCE and same_count),
    )


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--t1", type=float, default=0.2, help="final time [s]")
    parser.add_argument("--methods", default="LSODA,BDF,Radau,RK45,DOP853")
    parser.add_argument("--rtols", default="1e-8", help="rtol values to try; atol = rtol / 100")
    parser.add_argument("--max-wall", type=float, default=120.0, help="cap per run [s]")
    parser.add_argument("--no-impact", action="store_true", help="the case without impact")
    parser.add_argument("--json", default=None, help="also write the rows here")
    args = parser.parse_args(argv)

    impact = not args.no_impact
    model = _xu2014(impact)
    import jax
    import jaxbearing as jb

    ts = np.linspace(0.0, args.t1, int(round(args.t1 / 1e-4)) + 1)  # every 1e-4 s
    times = jb.cases.TABLE5_TIMES[jb.cases.TABLE5_TIMES <= args.t1]
    table5 = np.searchsorted(ts, times - 1e-12)
    rtols = [float(r) for r in args.rtols.split(",")]
    ref_rtol = min(rtols) * 1e-3
    tight = jb.default_controller(rtol=ref_rtol, atol=ref_rtol / 100)
    reference = jb.simulate(model, args.t1, ts, stepsize_controller=tight, max_steps=2_000_000)
    print(f"reference: jaxbearing Tsit5 at rtol {ref_rtol:g}, atol {ref_rtol / 100:g}, "
          f"{int(reference.num_steps)} steps, {int(reference.contacts.count)} onsets")

    def jaxbearing_run():
        return jax.block_until_ready(jb.simulate(model, args.t1, ts))

    jaxbearing_run()  # compile
    walls = []
    for _ in range(3):
        start = time.perf_counter()
        jaxbearing_run()
        walls.append(time.perf_counter() - start)
    jb_wall = float(np.median(walls))
    print(f"jaxbearing default (Tsit5, rtol 1e-8, atol 1e-10), compiled: {jb_wall:.3f} s, "
          "median of 3")

    params = Params.from_model(model)
    rows = []
    print(f"{'method':7s} {'rtol':>6s} {'wall s':>8s} {'steps':>7s} {'rhs calls':>9s} "
          f"{'pos err m':>9s} {'load err N':>10s} {'onsets':>7s} {'onset dt s':>10s}")
    for rtol in rtols:
        for method in args.methods.split(","):
            try:
                run = simulate(args.t1, ts, method=method, rtol=rtol, atol=rtol / 100,
                               max_wall=args.max_wall, params=params)
            except BaselineTimeout as stop:
                rows.append(
                    dict(method=method, rtol=rtol, timeout_s=args.max_wall, t_reached=stop.t)
                )
                print(f"{method:7s} {rtol:6.0e} stopped at the {args.max_wall:g} s cap at "
                      f"t = {stop.t:.4f} s", flush=True)
                continue
            e = compare(run, reference, table5)
            rows.append(dict(method=method, rtol=rtol, wall_s=run["wall_s"], steps=run["steps"],
                             rhs_calls=run["rhs_calls"], **e))
            print(f"{method:7s} {rtol:6.0e} {run['wall_s']:8.2f} {run['steps']:7d} "
                  f"{run['rhs_calls']:9d} {e['position_error_m']:9.1e} "
                  f"{e['ball_load_error_N']:10.3f} "
                  f"{e['onsets']:3d}/{e['reference_onsets']:<3d} {e['onset_time_error_s']:10.1e}"
                  f"{'' if e['accurate'] else '  inaccurate'}", flush=True)
    accurate = [r for r in rows if r.get("accurate")]
    best = min(accurate, key=lambda r: r["wall_s"]) if accurate else None
    if best:
        print(f"best accurate: {best['method']} at rtol {best['rtol']:g}, {best['wall_s']:.2f} s "
              f"(positions within {POSITION_TOLERANCE:g} m, ball loads within "
              f"{LOAD_TOLERANCE:g} N, every onset): jaxbearing is "
              f"{best['wall_s'] / jb_wall:.1f}x faster")
    else:
        print("no run met the accuracy checks")
    if args.json:
        with open(args.json, "w") as f:
            summary = dict(t1=args.t1, impact=impact, reference_rtol=ref_rtol,
                           jaxbearing_wall_s=jb_wall, best=best, rows=rows)
            json.dump(summary, f, indent=2)


if __name__ == "__main__":
    main()

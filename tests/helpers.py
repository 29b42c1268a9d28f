"""Independent plain-NumPy/SciPy references shared by the tests.

Nothing here imports jaxbearing: these are re-derivations from the paper's equations (Xu 2014,
Eqs. 9, 12–14, 23) and from textbook mechanics, written separately so that a test compares the
library against code that cannot share its bugs.
"""

from __future__ import annotations

import numpy as np
import scipy.special as sps
from scipy.optimize import brentq

G0 = 9.80665  # standard gravity [m/s^2], the library's Gravity default


# ------------------------------------------------------------------------------ bearing law


def ball_unit_vectors(cage_angle, n_balls):
    """(N_b, 2) unit vectors u_r = [cos phi_r, sin phi_r], phi_r = 2 pi (r-1)/N_b + phi_c."""
    phi = cage_angle + 2.0 * np.pi * np.arange(n_balls) / n_balls
    return np.stack([np.cos(phi), np.sin(phi)], axis=1)


def ball_loads_ref(e, v, cage_angle, *, clearance, stiffness, damping, n_balls, exponent=1.5,
                   smooth=False, ramp=1e-6):
    """Eq. 9 with Eqs. 12–13, a ball never pulls; ``smooth`` scales the damping by 3x^2-2x^3."""
    u = ball_unit_vectors(cage_angle, n_balls)
    delta = u @ np.asarray(e, float) - 0.5 * clearance
    rate = u @ np.asarray(v, float)
    depth = np.where(delta > 0, delta, 0.0)
    damp = damping * rate
    if smooth:
        x = np.clip(depth / ramp, 0.0, 1.0)
        damp = damp * x * x * (3.0 - 2.0 * x)
    force = stiffness * depth**exponent + damp
    return np.where(delta > 0, np.maximum(force, 0.0), 0.0)


def resultant_ref(loads, cage_angle):
    """sum_r F_r u_r [N] (Eq. 28)."""
    return loads @ ball_unit_vectors(cage_angle, loads.shape[-1])


def static_eccentricity(load, direction_angle, *, clearance, stiffness, n_balls, exponent=1.5,
                        cage_angle=0.0):
    """|e| [m] along ``direction_angle`` at which the (damping-free) resultant's component
    along that direction equals ``load`` [N]. SciPy brentq on the NumPy law above; the bracket
    runs from the clearance circle (zero force) to a deflection that surely carries the load."""
    d = np.array([np.cos(direction_angle), np.sin(direction_angle)])

    def excess(s):
        loads = ball_loads_ref(s * d, (0.0, 0.0), cage_angle, clearance=clearance,
                               stiffness=stiffness, damping=0.0, n_balls=n_balls,
                               exponent=exponent)
        return resultant_ref(loads, cage_angle) @ d - load

    lo = 0.5 * clearance
    hi = lo + 2.0 * (load / stiffness) ** (1.0 / exponent) + 1e-12
    while excess(hi) < 0:
        hi = lo + 2.0 * (hi - lo)
    return brentq(excess, lo, hi, xtol=1e-22, rtol=4 * np.finfo(float).eps, maxiter=500)


def stribeck_limit(exponent=1.5):
    """Z Q_max / F_r for zero clearance and Z -> infinity: 1 / J_r(0.5) with
    J_r(0.5) = (1/2pi) int_{-pi/2}^{pi/2} cos^(n+1) psi dpsi = B(1/2, (n+2)/2) / (2 pi)."""
    integral = sps.beta(0.5, 0.5 * (exponent + 2.0))
    return 2.0 * np.pi / integral


# ------------------------------------------------------------------------------ impacts


def hertz_contact_constant():
    """2 int_0^1 dx / sqrt(1 - x^(5/2)) = (4/5) B(2/5, 1/2): t_contact = const * delta_max / v
    for a Hertz (exponent 3/2) impact, 2.94328..."""
    return 0.8 * sps.beta(0.4, 0.5)


def ln_exit_ratio(restitution, stiffness, reduced_mass, approach_speed, rtol=1e-12):
    """Exit/entry speed ratio of the 1-DOF Lankarani–Nikravesh impact
    m* x'' = -K x^1.5 (1 + 3 (1 - e^2)/4 x'/v0), x(0) = 0, x'(0) = v0, integrated by SciPy
    DOP853 until x returns to 0 (terminal event)."""
    from scipy.integrate import solve_ivp

    k, m, v0 = stiffness, reduced_mass, approach_speed
    hyst = 0.75 * (1.0 - restitution**2) / v0

    def rhs(t, y):
        x, xd = y
        depth = max(x, 0.0)
        force = max(k * depth**1.5 * (1.0 + hyst * xd), 0.0)
        return [xd, -force / m]

    def back_to_zero(t, y):
        return y[0]

    back_to_zero.terminal = True
    back_to_zero.direction = -1
    delta_max = (5.0 * m * v0**2 / (4.0 * k)) ** 0.4
    t_end = 10.0 * delta_max / v0
    sol = solve_ivp(rhs, (0.0, t_end), [0.0, v0], method="DOP853", rtol=rtol,
                    atol=rtol * delta_max * 1e-3, events=back_to_zero,
                    first_step=1e-3 * delta_max / v0)
    assert sol.status == 1, "reference impact did not end"
    return -sol.y_events[0][0][1] / v0


# ------------------------------------------------------------------------------ mechanisms


def compound_double_pendulum_rhs(m1, j1, l1, m2, j2, l2, g=G0):
    """Lagrange equations of two uniform links (centroids at mid-length), pinned at the origin,
    absolute angles th1, th2 from +x, gravity along -y. State [th1, th2, w1, w2]."""
    a1, a2 = 0.5 * l1, 0.5 * l2

    def rhs(t, y):
        th1, th2, w1, w2 = y
        c, s = np.cos(th1 - th2), np.sin(th1 - th2)
        mass = np.array([[j1 + m1 * a1**2 + m2 * l1**2, m2 * l1 * a2 * c],
                         [m2 * l1 * a2 * c, j2 + m2 * a2**2]])
        rhs_ = np.array([
            -m2 * l1 * a2 * s * w2**2 - g * (m1 * a1 + m2 * l1) * np.cos(th1),
            m2 * l1 * a2 * s * w1**2 - g * m2 * a2 * np.cos(th2),
        ])
        return np.concatenate([[w1, w2], np.linalg.solve(mass, rhs_)])

    return rhs


def slider_crank_kinematics(t, omega, l2, l3):
    """Exact kinematics of the ideal slider–crank: crank angle theta = omega t about the origin,
    crank pin P = l2 [cos, sin] theta, rod angle phi with l2 sin theta + l3 sin phi = 0 (the
    slider pin B on the x axis, cos phi > 0). Returns dict of arrays: theta, phi, phi_d, phi_dd,
    P, G (rod centroid), B and their accelerations a_G, a_B (analytic second derivatives)."""
    t = np.asarray(t, float)
    theta = omega * t
    lam = l2 / l3
    sphi = -lam * np.sin(theta)
    cphi = np.sqrt(1.0 - sphi**2)
    phi = np.arctan2(sphi, cphi)
    # cos(phi) phi' = -lam omega cos(theta);  differentiate once more:
    # -sin(phi) phi'^2 + cos(phi) phi'' = lam omega^2 sin(theta)
    phi_d = -lam * omega * np.cos(theta) / cphi
    phi_dd = (lam * omega**2 * np.sin(theta) + sphi * phi_d**2) / cphi
    u = np.stack([cphi, sphi], -1)
    n = np.stack([-sphi, cphi], -1)
    pin = l2 * np.stack([np.cos(theta), np.sin(theta)], -1)
    a_pin = -(omega**2) * pin
    a_rel = phi_dd[..., None] * n - (phi_d**2)[..., None] * u  # d2/dt2 of u
    return dict(
        theta=theta, phi=phi, phi_d=phi_d, phi_dd=phi_dd, u=u,
        P=pin, G=pin + 0.5 * l3 * u, B=pin + l3 * u,
        a_G=a_pin + 0.5 * l3 * a_rel, a_B=a_pin + l3 * a_rel,
    )


def slider_crank_pin_force(t, omega, l2, l3, m_rod, j_rod, m_slider):
    """Force [N] the rod exerts on the crank at the crank pin of an ideal slider–crank without
    gravity, from Newton–Euler of rod and slider (slider guided along x, frictionless).

    Unknowns: R (crank on rod, at P) and S (slider on rod, at B). Slider, x: m4 a_Bx = -S_x.
    Rod: m3 a_G = R + S; J3 phi'' = (P - G) x R + (B - G) x S with P - G = -(l3/2) u,
    B - G = +(l3/2) u. Returns -R, shape (T, 2)."""
    k = slider_crank_kinematics(t, omega, l2, l3)
    u, a_g, a_b = k["u"], k["a_G"], k["a_B"]
    s_x = -m_slider * a_b[:, 0]
    r_x = m_rod * a_g[:, 0] - s_x
    h = 0.5 * l3
    # moment: J phi'' = -h (u_x R_y - u_y R_x) + h (u_x S_y - u_y S_x), and R_y + S_y = m3 a_Gy
    out = []
    for i in range(len(u)):
        ux, uy = u[i]
        a = np.array([[-h * ux, h * ux], [1.0, 1.0]])
        b = np.array([
            j_rod * k["phi_dd"][i] - h * uy * r_x[i] + h * uy * s_x[i],
            m_rod * a_g[i, 1],
        ])
        r_y, _ = np.linalg.solve(a, b)
        out.append([-r_x[i], -r_y])
    return np.array(out)


# ------------------------------------------------------------------------------ clearance joint


def lankarani_nikravesh_ref(penetration, rate, approach_speed, stiffness, restitution):
    """F_N = K delta^1.5 (1 + 3 (1 - e^2)/4 delta_dot / delta_dot^(-)) [N], >= 0, zero apart;
    elastic where the approach speed is not positive."""
    if penetration <= 0.0:
        return 0.0
    hysteresis = 0.75 * (1.0 - restitution**2) * rate / approach_speed if approach_speed > 0.0 else 0.0
    return max(stiffness * penetration**1.5 * (1.0 + hysteresis), 0.0)


def ambrosio_friction_ref(normal, slip, friction, v0, v1):
    """-mu c_d F_N sign(v_T) [N], c_d ramping from 0 at |v_T| = v0 to 1 at v1."""
    c_d = min(max((abs(slip) - v0) / (v1 - v0), 0.0), 1.0)
    return -friction * c_d * normal * np.sign(slip)


def clearance_slider_crank(t1, ts, *, omega, l2, l3, m_rod, j_rod, m_slider, clearance, radius,
                           stiffness, restitution, friction, v0, v1, x0, xd0, rtol, atol,
                           separation=1e-9):
    """The slider–crank whose crank pin is a dry journal in a hole (the hole's centre on the
    crank at P(t) = l2 [cos, sin] omega t, the crank driven; the journal's centre J on the rod's
    end; the rod's other end pinned to a slider on the x axis), in the minimal coordinates
    x = J (2 DOF), integrated by SciPy's DOP853 with the contact's onsets and separations as
    terminal events (no Baumgarte terms, no constraints: a formulation independent of
    jaxbearing's).

    The rod's angle: sin phi = -J_y / l3 (cos phi > 0); its centre G = J + l3/2 u(phi), the
    slider at x_s = J_x + l3 cos phi. Virtual work over dx gives the 2x2 system
    [m_r J_G^T J_G + j_rod g g^T + m_s J_s^T J_s] x'' = f + g M - m_r J_G^T c_G - j_rod g h
    - m_s J_s^T c_s, with g = dphi/dx = (0, -1/(l3 cos phi)), phi'' = g . x'' + h,
    h = tan(phi) phi'^2, and f, M the joint's force and moment on the rod: the normal force
    -F_N n with n = e/|e|, e = J - P, and the friction F_T along t (n turned +90 deg) at the
    contact point J + R n (moment R F_T).

    Returns a dict: ``J`` (T, 2) and ``e`` (T, 2) [m] at ``ts``, ``onsets``, ``ends`` [s] and
    ``approach`` [m/s] of each contact, ``peaks`` [N] the largest normal force of each (the
    dense output's maximum, refined by a bounded scalar search)."""
    from scipy.integrate import solve_ivp
    from scipy.optimize import minimize_scalar

    def crank(t):
        c, s = np.cos(omega * t), np.sin(omega * t)
        return l2 * np.array([c, s]), l2 * omega * np.array([-s, c])

    def rod_cos(x):  # cos phi (a rejected step's trial stages may reach beyond the rod)
        return np.sqrt(max(1.0 - (x[1] / l3) ** 2, 1e-12))

    def gap(t, y):
        x, xd = y[:2], y[2:]
        p, pd = crank(t)
        e, ed = x - p, xd - pd
        d = np.hypot(*e)
        n = e / d if d > 0.0 else np.array([1.0, 0.0])
        tan = np.array([-n[1], n[0]])
        phi_d = -xd[1] / (l3 * rod_cos(x))
        slip = ed @ tan + phi_d * radius - omega * (radius + clearance)
        return d - clearance, ed @ n, n, tan, slip

    def normal_force(t, y, approach):
        penetration, rate, *_ = gap(t, y)
        return lankarani_nikravesh_ref(penetration, rate, approach, stiffness, restitution)

    def rhs(t, y, approach):
        x, xd = y[:2], y[2:]
        s_phi, c_phi = -x[1] / l3, rod_cos(x)
        phi_d = -xd[1] / (l3 * c_phi)
        u, nn = np.array([c_phi, s_phi]), np.array([-s_phi, c_phi])
        g = np.array([0.0, -1.0 / (l3 * c_phi)])
        h = s_phi / c_phi * phi_d**2
        jac_g = np.eye(2) + 0.5 * l3 * np.outer(nn, g)
        c_g = 0.5 * l3 * (nn * h - u * phi_d**2)
        jac_s = np.array([1.0, 0.0]) - l3 * s_phi * g
        c_s = -l3 * (c_phi * phi_d**2 + s_phi * h)
        penetration, rate, n, tan, slip = gap(t, y)
        f_n = lankarani_nikravesh_ref(penetration, rate, approach, stiffness, restitution)
        f_t = ambrosio_friction_ref(f_n, slip, friction, v0, v1)
        force, moment = -f_n * n + f_t * tan, radius * f_t
        mass = m_rod * jac_g.T @ jac_g + j_rod * np.outer(g, g) + m_slider * np.outer(jac_s, jac_s)
        rhs_ = force + g * moment - m_rod * jac_g.T @ c_g - j_rod * g * h - m_slider * jac_s * c_s
        return np.concatenate([xd, np.linalg.solve(mass, rhs_)])

    y = np.concatenate([x0, xd0]).astype(float)
    t, touching, approach = 0.0, False, 0.0
    onsets, ends, speeds, peaks, pieces = [], [], [], [], []
    while t < t1:
        if touching:
            def event(t, y):
                return gap(t, y)[0] + separation
            event.direction = -1
        else:
            def event(t, y):
                return gap(t, y)[0]
            event.direction = 1
        event.terminal = True
        with np.errstate(over="ignore", invalid="ignore"):  # a rejected step's trial stages
            run = solve_ivp(lambda t, y, a=approach: rhs(t, y, a), (t, t1), y, method="DOP853",
                            rtol=rtol, atol=atol, events=event, dense_output=True, max_step=1e-3)
        assert run.status >= 0, run.message
        pieces.append((t, run.t[-1], run.sol))
        if touching:  # the contact's peak: the dense output's largest normal force, refined
            grid = np.linspace(t, run.t[-1], 2001)
            forces = [normal_force(s, run.sol(s), approach) for s in grid]
            k = int(np.argmax(forces))
            lo, hi = grid[max(k - 1, 0)], grid[min(k + 1, grid.size - 1)]
            best = minimize_scalar(lambda s: -normal_force(s, run.sol(s), approach), bounds=(lo, hi),
                                   method="bounded", options={"xatol": 1e-14})
            peaks.append(max(forces[k], -best.fun))
        t, y = run.t[-1], run.y[:, -1]
        if run.status == 1:
            if touching:
                ends.append(t)
            else:
                approach = gap(t, y)[1]
                onsets.append(t)
                speeds.append(approach)
            touching = not touching
    out = []
    for s in np.asarray(ts, float):
        for start, end, dense in pieces:
            if start <= s <= end:
                out.append(dense(s)[:2])
                break
    joint = np.array(out)
    pins = np.array([crank(s)[0] for s in ts])
    return dict(J=joint, e=joint - pins, onsets=np.array(onsets), ends=np.array(ends),
                approach=np.array(speeds), peaks=np.array(peaks))

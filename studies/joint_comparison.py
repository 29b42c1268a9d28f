"""Which joint for the crank pin? The paper's slider–crank with its crank–rod joint as (a) an
ideal pin, (b) a dry plain bearing, (c) a lubricated plain bearing, (d) the SKF 98205 ball
bearing, (e) an NU 206 cylindrical roller bearing: the slider's acceleration, the joint force,
the journal's (or inner race's) orbit, the peak loads, and the rolling bearings' lives
(docs/plain_bearings.md).

The plain bearing takes the ball bearing's place: a 25 mm journal (R 12.5 mm, the 98205's
bore) 12 mm long (L/D 0.48: short-bearing theory holds) with the ball bearing's radial play,
c = 20 um, steel on steel (`JournalBearing.from_geometry`: Flores' contact law), restitution
0.9, dry friction 0.1; lubricated, an ISO VG 68 oil at 40 C (0.06 Pa s). The rolling bearings
have the paper's 40 um diametral clearance and 300 N s/m per element. Without impact by
default (the joint's own behaviour; ``--impact``: the paper's impact case), over t >= 0.04 s
(after the start-up transient). The ideal pin's force is its reaction, from the Newton–Euler
equations of the rod and the slider at each output time (the rod's and the slider's
accelerations of the solve, the contact's force on the slider where it strikes).

Writes ``comparison.json`` (per joint: peak and RMS joint force, peak slider acceleration,
largest eccentricity ratio and smallest film, the rolling bearings' peak element load and ISO
281 life), ``joint_comparison.png`` (slider acceleration and joint force against time) and
``joint_orbits.png`` (the four orbits, each in its clearance circle).

    python studies/joint_comparison.py [--quick] [--impact] [--out results/joint_comparison]
"""

from __future__ import annotations

import argparse
import json
import os
from pathlib import Path
from typing import NamedTuple

import jax

jax.config.update("jax_enable_x64", True)

import matplotlib  # noqa: E402

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

import jaxbearing as jb  # noqa: E402
from jaxbearing.cases import SLIDER, WINDOW_START  # noqa: E402
from jaxbearing.cases._xu2014 import ROD_LENGTH  # noqa: E402

RADIUS, LENGTH, CLEARANCE = 12.5e-3, 12e-3, 20e-6  # [m]
VISCOSITY = 0.06  # [Pa s] ISO VG 68 at 40 C
ROD = 1  # the rod's body index in cases.xu2014


def plain_bearing(viscosity=0.0) -> jb.JournalBearing:
    return jb.JournalBearing.from_geometry(
        radius=RADIUS, clearance=CLEARANCE, length=LENGTH, restitution=0.9, friction=0.1,
        viscosity=viscosity,
    )


JOINTS = {  # label: the crank pin (`cases.xu2014`'s bearing=)
    "ideal pin": None,
    "dry plain bearing": plain_bearing(),
    "lubricated plain bearing": plain_bearing(VISCOSITY),
    "ball bearing (SKF 98205)": "98205",
    "roller bearing (NU 206)": "NU206",
}


def pin_force(sol, model) -> np.ndarray:
    """(T, 2) [N]: the force on the crank at an ideal crank pin, from the Newton–Euler equations
    of the rod (centre G, pins P = G - l/2 u and B = G + l/2 u) and the slider (along x, the
    contact's normal force on it along -x): m_s a_s = -S_x - F_c, m_r a_G = R + S, J_r alpha =
    (P - G) x R + (B - G) x S, with R the crank's force on the rod, S the slider's."""
    q, qdd = np.asarray(sol.q), np.asarray(sol.qdd)
    rod, slider = model.bodies[ROD], model.bodies[SLIDER]
    m_r, j_r, m_s = float(rod.mass), float(rod.inertia), float(slider.mass)
    contact = np.asarray(sol.contact_force)  # zeros without impact
    s_x = -m_s * qdd[:, 3 * SLIDER] - contact
    a_x, a_y, alpha = qdd[:, 3 * ROD], qdd[:, 3 * ROD + 1], qdd[:, 3 * ROD + 2]
    u_x, u_y = np.cos(q[:, 3 * ROD + 2]), np.sin(q[:, 3 * ROD + 2])
    h = ROD_LENGTH / 2
    s_y = (j_r * alpha + h * m_r * (u_x * a_y - u_y * a_x) + 2 * h * u_y * s_x) / (2 * h * u_x)
    return -np.stack([m_r * a_x - s_x, m_r * a_y - s_y], axis=1)


class Series(NamedTuple):
    """A run's samples: times [s], the slider's acceleration [m/s^2], the joint force's
    magnitude [N], and for a joint with play its orbit (T, 2) [m] and clearance circle's
    radius [m] (c, or P_d/2)."""

    t: np.ndarray
    acceleration: np.ndarray
    force: np.ndarray
    orbit: np.ndarray | None = None
    radius: float | None = None


PEAK = jb.metrics.ElementPeak("force_magnitude", element=0)  # the crank pin is forces[0]
RMS = jb.metrics.PowerMean("force_squared", element=0)
RATIO = jb.metrics.ElementPeak("eccentricity_ratio", element=0)
CONTACT = jb.metrics.ElementPeak("normal_force", element=0)


def run(joint, impact: bool, t1: float, ts) -> tuple[dict, Series]:
    """One simulation: its numbers (over t >= `WINDOW_START`) and its `Series`."""
    model = jb.cases.xu2014(impact=impact, bearing=joint)
    sol = jb.simulate(model, t1, ts)
    t = np.asarray(sol.ts)
    inside = t >= WINDOW_START
    acceleration = np.asarray(sol.qdd)[:, 3 * SLIDER]
    numbers = {"peak_slider_acceleration_m_s2": float(np.abs(acceleration[inside]).max())}
    if joint is None:  # the pin's peak and RMS from its samples (smooth: no rattle)
        magnitude = np.hypot(*pin_force(sol, model).T)
        span = t[inside][-1] - t[inside][0]
        numbers["peak_joint_force_N"] = float(magnitude[inside].max())
        mean_square = np.trapezoid(magnitude[inside] ** 2, t[inside]) / span
        numbers["rms_joint_force_N"] = float(np.sqrt(mean_square))
        return numbers | {"steps": int(sol.num_steps)}, Series(t, acceleration, magnitude)
    numbers["peak_joint_force_N"] = float(PEAK(sol))
    numbers["rms_joint_force_N"] = float(RMS(sol))
    if isinstance(joint, jb.JournalBearing):
        ratio = float(RATIO(sol))
        numbers["largest_eccentricity_ratio"] = ratio
        numbers["smallest_film_um"] = 1e6 * CLEARANCE * max(1.0 - ratio, 0.0)
        numbers["peak_contact_force_N"] = float(CONTACT(sol))
        mine = np.asarray(sol.episodes.valid) & (np.asarray(sol.episodes.element) == 0)
        numbers["contacts"] = int(mine.sum())
    else:
        numbers["peak_element_load_N"] = float(jb.metrics.peak_ball_load(sol))
        numbers["l10_hours"] = float(jb.life.iso_life(sol, model).l10_hours)
    numbers["steps"] = int(sol.num_steps)
    magnitude = np.hypot(*np.asarray(sol.elements[0].samples["force"]).T)
    orbit = jb.report.orbit(sol, model, element=0)
    return numbers, Series(t, acceleration, magnitude, orbit, 0.5 * float(model.forces[0].play()))


def _save(fig, path: Path) -> None:
    tmp = path.with_suffix(".png.tmp")
    fig.savefig(tmp, dpi=110, format="png")
    os.replace(tmp, path)
    plt.close(fig)


def plot_series(series: dict, impact: bool, path: Path) -> None:
    """Each joint's slider acceleration and joint force against time, a row each, the ideal
    pin's drawn over them."""
    size = (9, 1.7 * len(series) + 0.8)
    fig, axes = plt.subplots(len(series), 2, figsize=size, sharex=True, sharey="col")
    pin = series["ideal pin"]
    for k, (row, (name, one)) in enumerate(zip(axes, series.items())):
        shown = one.t >= WINDOW_START
        pairs = ((one.acceleration, pin.acceleration), (one.force, pin.force))
        for ax, (y, reference) in zip(row, pairs):
            if name != "ideal pin":
                pin_style = dict(color="k", lw=0.5, zorder=3, label="ideal pin")
                ax.plot(one.t[shown], reference[shown], **pin_style)
            ax.plot(one.t[shown], y[shown], color=f"C{k}", lw=0.7, label=name)
            ax.grid(True, lw=0.3, alpha=0.5)
        row[0].set_title(name, fontsize=9, loc="left")
    axes[0, 0].set_title("slider acceleration [m/s²]", fontsize=9, loc="right")
    axes[0, 1].set_title("joint force |F| on the crank [N]", fontsize=9, loc="right")
    axes[1, 0].legend(fontsize=7, loc="lower right")
    for ax in axes[-1]:
        ax.set_xlabel("t [s]")
    case = "the paper's slider–crank" + (" with impact" if impact else "")
    fig.suptitle(f"{case}: the crank pin (black: the ideal pin)", fontsize=10)
    fig.tight_layout()
    _save(fig, path)


def plot_orbits(series: dict, path: Path) -> None:
    """The orbit of each joint with play in its clearance circle."""
    with_play = {name: one for name, one in series.items() if one.orbit is not None}
    fig, axes = plt.subplots(2, 2, figsize=(7.5, 7.5))
    circle = np.linspace(0.0, 2 * np.pi, 181)
    for ax, (k, (name, one)) in zip(axes.ravel(), enumerate(with_play.items(), 1)):
        shown, radius = one.t >= WINDOW_START, 1e6 * one.radius
        ax.plot(radius * np.cos(circle), radius * np.sin(circle), color="0.4", ls="--", lw=0.8)
        ax.plot(1e6 * one.orbit[shown, 0], 1e6 * one.orbit[shown, 1], color=f"C{k}", lw=0.6)
        ax.set(title=name, xlabel="e_x [µm]", ylabel="e_y [µm]", aspect="equal")
        ax.grid(True, lw=0.3, alpha=0.5)
    title = "orbits: the journal's (inner race's) centre in its hole; dashed: c (P_d/2)"
    fig.suptitle(title, fontsize=10)
    fig.tight_layout()
    _save(fig, path)


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--quick", action="store_true", help="0-0.06 s (tests)")
    parser.add_argument("--impact", action="store_true", help="the paper's case with its impact")
    parser.add_argument("--out", default="results/joint_comparison")
    args = parser.parse_args(argv)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    t1 = 0.06 if args.quick else 0.2
    ts = np.linspace(0.0, t1, round(t1 / 2e-5) + 1)
    results = {"t1_s": t1, "window_from_s": WINDOW_START, "impact": args.impact, "joints": {}}
    series = {}
    for name, joint in JOINTS.items():
        numbers, series[name] = run(joint, args.impact, t1, ts)
        results["joints"][name] = numbers
        print(f"{name:26s} " + ", ".join(f"{k} {v:.4g}" for k, v in numbers.items()), flush=True)
        tmp = out / "comparison.json.tmp"  # after each joint: an interrupted run keeps the others
        tmp.write_text(json.dumps(results, indent=2))
        os.replace(tmp, out / "comparison.json")
    plot_series(series, args.impact, out / "joint_comparison.png")
    plot_orbits(series, out / "joint_orbits.png")


if __name__ == "__main__":
    main()

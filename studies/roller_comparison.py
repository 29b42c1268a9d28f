"""The paper's slider–crank with a cylindrical roller bearing of the same envelope in place of the
SKF 98205 ball bearing: peak element load, contact stress, static safety and L10 life, with and
without impact.

Both bearings have the 25 x 52 x 15 mm envelope: the paper's SKF 98205 (8 balls of 8.7 mm)
and an NU 205 with estimated internals (`xu2014(bearing="NU205-estimated")`, 13
rollers of 7.4 x 7.9 mm; docs/model.md, 'Roller bearings'), both with the paper's 40 um
clearance and 300 N s/m per element. Over t >= 0.04 s (after the start-up transient): ISO 76
static safety (`jb.life.static_safety`) and ISO 281 life (`jb.life.iso_life`). Writes
``comparison.json`` and ``roller_comparison.png`` (the contact stress of the most loaded
element against time, beside ISO 76's permissible stresses).

    python studies/roller_comparison.py [--quick] [--out results/roller_comparison]
"""

from __future__ import annotations

import argparse
import json
import os
from pathlib import Path

import jax

jax.config.update("jax_enable_x64", True)

import jax.numpy as jnp  # noqa: E402
import matplotlib  # noqa: E402

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

import jaxbearing as jb  # noqa: E402
from jaxbearing.cases import GROOVE_INNER, GROOVE_OUTER, WINDOW_START  # noqa: E402

BEARINGS = {  # label: (designation, the contact stress's groove ratios)
    "ball (SKF 98205)": ("98205", dict(groove_inner=GROOVE_INNER, groove_outer=GROOVE_OUTER)),
    "roller (NU 205, estimated)": ("NU205-estimated", {}),
}


def run(bearing, grooves, impact: bool, t1: float, ts):
    """One simulation: its summary numbers and the most loaded element's contact stress [Pa] at
    ``ts``."""
    model = jb.cases.xu2014(impact=impact, bearing=bearing)
    sol = jb.simulate(model, t1, ts)
    static = jb.life.static_safety(sol, model, **grooves)
    iso = jb.life.iso_life(sol, model)
    largest = jnp.max(sol.ball_loads, axis=1)
    stress = jb.life.element_contact_stress(model.bearing, largest, **grooves)
    numbers = {
        "peak_element_load_N": float(static.peak_element_load),
        "peak_bearing_force_N": float(static.p0),
        "static_load_rating_N": float(static.c0),
        "static_safety": float(static.s0),
        "contact_stress_MPa": 1e-6 * float(static.contact_stress),
        "permissible_contact_stress_MPa": 1e-6 * float(static.permissible_stress),
        "dynamic_load_rating_N": float(iso.load_rating),
        "equivalent_load_N": float(iso.equivalent_load),
        "l10_hours": float(iso.l10_hours),
    }
    return numbers, np.asarray(stress), float(static.permissible_stress)


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--quick", action="store_true", help="0-0.1 s: the first impacts only (tests)")
    parser.add_argument("--out", default="results/roller_comparison")
    args = parser.parse_args(argv)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    t1 = 0.1 if args.quick else 0.2
    ts = np.linspace(0.0, t1, int(round(t1 / 1e-4)) + 1)
    shown = ts >= WINDOW_START

    rows = {"t1_s": t1, "window_from_s": WINDOW_START}
    fig, axes = plt.subplots(2, 1, figsize=(7, 5.5), sharex=True)
    for ax, impact in zip(axes, (True, False)):
        key = "with_impact" if impact else "without_impact"
        rows[key] = {}
        for (name, (bearing, grooves)), colour in zip(BEARINGS.items(), ("C0", "C3")):
            numbers, stress, permissible = run(bearing, grooves, impact, t1, ts)
            rows[key][name] = numbers
            print(f"{key:15s} {name:27s} " + ", ".join(f"{k} {v:.4g}" for k, v in numbers.items()), flush=True)
            ax.plot(ts[shown], 1e-6 * stress[shown], color=colour, lw=0.8, label=name)
            ax.axhline(1e-6 * permissible, color=colour, ls="--", lw=0.8)
        ax.set(ylabel="contact stress [MPa]", title=key.replace("_", " "))
    axes[0].legend(fontsize=8, loc="center left")
    axes[-1].set_xlabel("t [s]  (dashed: ISO 76 permissible, 4 200 MPa balls, 4 000 MPa rollers)")
    fig.suptitle("most loaded element, paper's slider-crank", fontsize=10)
    fig.tight_layout()
    tmp = out / "roller_comparison.png.tmp"
    fig.savefig(tmp, dpi=110, format="png")
    os.replace(tmp, out / "roller_comparison.png")
    tmp = out / "comparison.json.tmp"
    tmp.write_text(json.dumps(rows, indent=2))
    os.replace(tmp, out / "comparison.json")


if __name__ == "__main__":
    main()

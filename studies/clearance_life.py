"""Which operating clearance gives the longest life? ISO/TS 16281's reference rating life L10r
against the operating clearance, from a preload to a large clearance, of the SKF 98205 ball
bearing and the NU 206 cylindrical roller bearing in the paper's slider–crank with impact.

For each bearing: a scan of L10r and of ISO 281's L10 over the clearance (`jb.sweep` with
`jb.life.metric`), the L10r-optimal clearance found by gradient steps through the whole
simulation (`jb.tune`, Adam on -log L10r from zero clearance, smooth element force), and a
fine scan around the optimum that checks it. Window 0.04–0.2 s (the case's), lives in hours
at the mean relative speed.

    python studies/clearance_life.py [--quick] [--out results/clearance_life]
"""

from __future__ import annotations

import argparse
import json
import os
import time
from pathlib import Path

import jax

jax.config.update("jax_enable_x64", True)

import jax.numpy as jnp  # noqa: E402
import matplotlib  # noqa: E402

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import optax  # noqa: E402

import jaxbearing as jb  # noqa: E402
from jaxbearing.cases import GROOVE_INNER, GROOVE_OUTER  # noqa: E402

UM = 1e-6  # [m]
# bearing -> (the case with it, smooth element force; the life's options; the scan [m]; the
# tuning's bounds [m]; the half-width of the check's fine scan [m])
BEARINGS = {
    "SKF 98205 (ball)": (
        lambda: jb.cases.xu2014(impact=True, ball_force="smooth"),
        dict(groove_inner=GROOVE_INNER, groove_outer=GROOVE_OUTER),
        np.array([-40, -30, -20, -15, -10, -7, -5, -3, 0, 5, 10, 20, 30, 40, 60, 80]) * UM,
        (-40 * UM, 80 * UM),
        2 * UM,
    ),
    "NU 206 (roller)": (
        lambda: jb.cases.xu2014(impact=True, bearing=jb.RollerBearing.from_catalogue("NU206", ball_force="smooth")),
        {},
        np.array([-20, -10, -7, -5, -3, -2, -1, 0, 1, 2, 5, 10, 20, 30, 40, 60, 80]) * UM,
        (-20 * UM, 80 * UM),
        1 * UM,
    ),
}
QUICK_SCAN = np.array([-10, 0, 40]) * UM


def scan(model, clearances, options, t1):
    """L10r and ISO 281's L10 [h] at each clearance (one `jb.sweep`)."""
    metrics = {"l10r_hours": jb.life.metric("reference", **options), "l10_hours": jb.life.metric("iso")}
    ds = jb.sweep(model, {"bearing.clearance": clearances}, metrics=metrics, t1=t1, progress=False)
    if bool(ds.failed.any()):
        raise RuntimeError(f"members failed: {ds.attrs.get('failures')}")
    return ds.l10r_hours.values, ds.l10_hours.values


def optimum(model, options, t1, steps, bounds):
    """The clearance that maximises L10r, by Adam on -log L10r from zero clearance."""
    ts = jnp.array([0.0, t1])  # the life reads the solve's integrals, not samples

    def loss(m):
        sol = jb.simulate(m, t1, ts)
        return -jnp.log(jb.life.reference_life(sol, m, **options).l10)

    return jb.tune(
        loss,
        jb.paths.replace(model, {"bearing.clearance": 0.0}),
        ["bearing.clearance"],
        optax.adam(optax.cosine_decay_schedule(0.15, steps)),
        steps,
        bounds={"bearing.clearance": bounds},
        scale={"bearing.clearance": 10 * UM},  # Adam's steps in units of 10 um
        callback=lambda k, v, p: print(f"  step {k:2d}: L10r {np.exp(-v):.4g} Mrev at {p['bearing.clearance'] / UM:+.3f} um", flush=True),
    )


def write(path: Path, text: str) -> None:
    """Write ``text`` to ``path`` atomically."""
    tmp = path.with_suffix(path.suffix + ".tmp")
    tmp.write_text(text)
    os.replace(tmp, path)


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--quick", action="store_true", help="3 clearances, 0.12 s, 2 tuning steps (tests)")
    parser.add_argument("--out", default="results/clearance_life")
    args = parser.parse_args(argv)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    t1 = 0.12 if args.quick else 0.2
    steps = 2 if args.quick else 20
    start = time.perf_counter()
    summary = {"t1_s": t1, "window_start_s": 0.04, "bearings": {}}
    fig, axes = plt.subplots(1, 2, figsize=(11, 4.2))
    for ax, (name, (build, options, clearances, bounds, half)) in zip(axes, BEARINGS.items()):
        model = build()
        clearances = QUICK_SCAN if args.quick else clearances
        l10r, l10 = scan(model, clearances, options, t1)
        print(f"{name}: " + ", ".join(f"{c / UM:+.0f} um {r:.3g} h" for c, r in zip(clearances, l10r)), flush=True)
        result = optimum(model, options, t1, steps, bounds)
        best = result.values["bearing.clearance"]
        fine = best + np.linspace(-half, half, 3 if args.quick else 9)
        fine_l10r, fine_l10 = scan(model, fine, options, t1)
        at_best = float(fine_l10r[len(fine) // 2])  # the fine scan is centred on the optimum
        print(
            f"{name}: L10r-optimal clearance {best / UM:+.2f} um (jb.tune, {steps} steps); the fine scan's "
            f"best {fine[np.argmax(fine_l10r)] / UM:+.2f} um; L10r there {at_best:.4g} h; "
            f"ISO 281's L10 largest at {clearances[np.argmax(l10)] / UM:+.0f} um of the scan "
            f"({time.perf_counter() - start:.0f} s)",
            flush=True,
        )
        summary["bearings"][name] = {
            "clearance_m": clearances.tolist(),
            "l10r_hours": l10r.tolist(),
            "l10_iso_hours": l10.tolist(),
            "tuned_clearance_m": best,
            "tuning_history_clearance_m": result.history_values["bearing.clearance"].tolist(),
            "tuning_history_loss": result.history_loss.tolist(),
            "fine_clearance_m": fine.tolist(),
            "fine_l10r_hours": fine_l10r.tolist(),
            "fine_l10_iso_hours": fine_l10.tolist(),
            "fine_best_clearance_m": float(fine[np.argmax(fine_l10r)]),
        }
        ax.semilogy(clearances / UM, l10r, "o-", label="L10r, ISO/TS 16281 (element loads)")
        ax.semilogy(clearances / UM, l10, "s--", label="L10, ISO 281 (resultant)")
        ax.semilogy(fine / UM, fine_l10r, ".", color="C0")
        ax.axvline(best / UM, color="k", lw=0.8, ls=":", label=f"jb.tune optimum {best / UM:+.1f} µm")
        ax.set(xlabel="operating clearance P_d [µm] (negative: preload)", ylabel="life [h]", title=name)
        ax.legend(fontsize=7)
    fig.suptitle("Life against operating clearance, paper's slider–crank with impact", fontsize=10)
    fig.tight_layout()
    tmp = out / "clearance_life.png.tmp"
    fig.savefig(tmp, dpi=110, format="png")
    os.replace(tmp, out / "clearance_life.png")
    summary["wall_s"] = time.perf_counter() - start
    write(out / "summary.json", json.dumps(summary, indent=2))


if __name__ == "__main__":
    main()

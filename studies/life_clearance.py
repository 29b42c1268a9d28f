"""Bearing life against clearance in the paper's case, and the clearance that maximises it.

For diametral clearances over 5–80 µm, simulates 0–0.2 s with and without impact and computes
the L10 life (ISO 281 (C_r/P)^3 and Lundberg–Palmgren from the ball loads, `jaxbearing.life`,
window t >= 0.04 s); draws life against clearance; differentiates log L10 (Lundberg–Palmgren,
with impact) w.r.t. clearance through the whole simulation (forward mode) and checks it against a
central difference; and maximises it with optax (`jb.tune`, smooth ball force).

    python studies/life_clearance.py [--quick] [--out results/life_clearance]
"""

from __future__ import annotations

import argparse
import json
import os
import time
from pathlib import Path

import jax

jax.config.update("jax_enable_x64", True)

import diffrax  # noqa: E402
import jax.numpy as jnp  # noqa: E402
import matplotlib  # noqa: E402

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import optax  # noqa: E402

import jaxbearing as jb  # noqa: E402
from jaxbearing.cases import GROOVE_INNER, GROOVE_OUTER  # noqa: E402

GROOVES = dict(groove_inner=GROOVE_INNER, groove_outer=GROOVE_OUTER)


TIGHT = dict(stepsize_controller=jb.default_controller(rtol=1e-10, atol=1e-12))  # derivative checks: finite differences need tight solves


def log_life(model, t1, ts, **kw):
    """log L10 [log of millions of relative revolutions], Lundberg–Palmgren, t >= 0.04 s."""
    sol = jb.simulate(model, t1, ts, **kw)
    return jnp.log(jb.life.lp_life(sol, model, **GROOVES).l10)


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--quick", action="store_true", help="3 clearances, 0.12 s, 2 steps (tests)")
    parser.add_argument("--out", default="results/life_clearance")
    args = parser.parse_args(argv)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    t1 = 0.12 if args.quick else 0.2
    ts = jnp.array([0.0, t1])  # the life reads the solve's integrals (sol.fatigue), not samples
    clearances = np.array([10e-6, 40e-6, 70e-6]) if args.quick else np.linspace(5e-6, 80e-6, 11)
    start = time.perf_counter()

    rows = {"clearance_m": clearances.tolist()}
    for impact in (True, False):
        base = jb.cases.xu2014(impact=impact)
        iso, lp = [], []
        for c in clearances:
            model = jb.paths.replace(base, {"bearing.clearance": c})
            sol = jb.simulate(model, t1, ts)
            iso.append(float(jb.life.iso_life(sol, model).l10_hours))
            lp.append(float(jb.life.lp_life(sol, model, **GROOVES).l10_hours))
        key = "with_impact" if impact else "without_impact"
        rows[key] = {"l10_iso_hours": iso, "l10_lp_hours": lp}
        print(f"{key}: " + ", ".join(f"{c * 1e6:.0f} µm: LP {h:.3g} h" for c, h in zip(clearances, lp)), flush=True)

    smooth = jb.cases.xu2014(impact=True, ball_force="smooth")

    def forward_log_life(c):  # the life law uses the model's clearance too: pass the same model
        m = jb.paths.replace(smooth, {"bearing.clearance": c})
        sol = jb.simulate(m, t1, ts, adjoint=diffrax.ForwardMode(), **TIGHT)
        return jnp.log(jb.life.lp_life(sol, m, **GROOVES).l10)

    g = float(jax.jit(jax.jacfwd(forward_log_life))(40e-6))
    h = 1e-7
    fd = (float(log_life(jb.paths.replace(smooth, {"bearing.clearance": 40e-6 + h}), t1, ts, **TIGHT))
          - float(log_life(jb.paths.replace(smooth, {"bearing.clearance": 40e-6 - h}), t1, ts, **TIGHT))) / (2 * h)
    print(f"d log L10 / d P_d at 40 µm: {g:.4g} 1/m (forward mode), {fd:.4g} 1/m (central difference)", flush=True)

    result = jb.tune(
        lambda m: -log_life(m, t1, ts),
        smooth,
        ["bearing.clearance"],
        optax.adam(optax.cosine_decay_schedule(0.1, 2 if args.quick else 20)),
        2 if args.quick else 20,
        bounds={"bearing.clearance": (5e-6, 80e-6)},
        callback=lambda k, v, p: print(f"  step {k:2d}: log L10 {-v:.4f}  {p}", flush=True),
    )
    best = result.values["bearing.clearance"]
    best_life = float(jnp.exp(-result.loss))
    print(f"life-optimal clearance under impact: {best * 1e6:.2f} µm, L10 {best_life:.4g} Mrev "
          f"({time.perf_counter() - start:.0f} s)", flush=True)

    fig, ax = plt.subplots(figsize=(6.5, 4))
    for key, style in (("with_impact", "-"), ("without_impact", "--")):
        ax.semilogy(clearances * 1e6, rows[key]["l10_iso_hours"], "o" + style, label=f"ISO 281, {key.replace('_', ' ')}")
        ax.semilogy(clearances * 1e6, rows[key]["l10_lp_hours"], "s" + style, label=f"Lundberg–Palmgren, {key.replace('_', ' ')}")
    ax.axvline(best * 1e6, color="k", lw=0.8, ls=":", label="optax optimum (LP, impact)")
    ax.set(xlabel="diametral clearance P_d [µm]", ylabel="L10 [h]", title="bearing life, paper's case")
    ax.legend(fontsize=7)
    fig.tight_layout()
    tmp = out / "life_vs_clearance.png.tmp"
    fig.savefig(tmp, dpi=120, format="png")
    os.replace(tmp, out / "life_vs_clearance.png")
    rows.update(gradient_log_l10_per_m=g, central_difference=fd, optimum_clearance_m=best,
                optimum_l10_mrev=best_life, history_clearance_m=result.history_values["bearing.clearance"].tolist())
    tmp = out / "summary.json.tmp"
    tmp.write_text(json.dumps(rows, indent=2))
    os.replace(tmp, out / "summary.json")


if __name__ == "__main__":
    main()

"""Tuning a bearing with optax through the whole simulation (the paper's case, smooth ball force).

1. Identification: a synthetic "measured" bearing-force history at a known clearance and
   restitution; starting from perturbed values, `jb.tune` recovers both from the history.
2. Design: the diametral clearance in [5, 80] µm that minimises a smooth peak ball load
   (power mean, `metrics.smooth_peak_ball_load`) under impact over one revolution; a
   convergence plot is written.

    python studies/tune_clearance.py [--quick] [--out results/tune_clearance]
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
import optax  # noqa: E402

import jaxbearing as jb  # noqa: E402
from jaxbearing import metrics  # noqa: E402

TRUE = {"bearing.clearance": 40e-6, "impact.restitution": 0.9}
START = {"bearing.clearance": 46e-6, "impact.restitution": 0.8}  # +15 %, -11 %
WINDOW = (0.04, 0.11)  # [s]: one impact sequence (0.091–0.108 s) and the loads before it
PHASES = ((0.04, 0.09), (0.09, 0.11))  # [s] before the impacts (clearance) and during them


def low_pass(signal, dt, width=0.5e-3):
    """Moving average over ``width`` [s] of a (T, 2) signal sampled every ``dt`` [s]: the misfit
    of ringing phases at kHz would otherwise give the loss many local minima."""
    n = max(int(round(width / dt)), 1)
    kernel = jnp.ones(n) / n
    return jnp.stack([jnp.convolve(signal[:, i], kernel, mode="same") for i in range(signal.shape[1])], 1)


def identification(t1, samples, steps, lr):
    ts = jnp.linspace(0.0, t1, samples)
    base = jb.cases.xu2014(impact=True, ball_force="smooth")
    measured = jb.simulate(jb.paths.replace(base, TRUE), t1, ts).bearing_force
    # each phase's misfit relative to its own signal: the kN impact phase would otherwise drown
    # the 100 N phase before it, which pins the clearance
    weights = [metrics.window(ts, *phase) for phase in PHASES]
    norms = [jnp.sum(w * jnp.sum(measured**2, axis=1)) for w in weights]

    def loss(model):
        f = low_pass(jb.simulate(model, t1, ts).bearing_force - measured, t1 / (samples - 1))
        misfit = jnp.sum(f**2, axis=1)
        return sum(jnp.sum(w * misfit) / norm for w, norm in zip(weights, norms)) / len(PHASES)

    start = jb.paths.replace(base, START)
    return jb.tune(
        loss,
        start,
        list(TRUE),
        optax.adam(optax.cosine_decay_schedule(lr, steps)),
        steps,
        bounds={"bearing.clearance": (5e-6, 80e-6), "impact.restitution": (0.3, 1.0)},
        callback=lambda k, v, p: print(f"  identification step {k:3d}: loss {v:.3e}  {p}", flush=True),
    )


def design(t1, samples, steps, lr):
    ts = jnp.linspace(0.0, t1, samples)
    base = jb.cases.xu2014(impact=True, ball_force="smooth")

    def loss(model):
        return metrics.smooth_peak_ball_load(jb.simulate(model, t1, ts), *WINDOW)

    return jb.tune(
        loss,
        base,
        ["bearing.clearance"],
        optax.adam(lr),
        steps,
        bounds={"bearing.clearance": (5e-6, 80e-6)},
        callback=lambda k, v, p: print(f"  design step {k:3d}: smooth peak {v:.1f} N  {p}", flush=True),
    )


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--quick", action="store_true", help="few steps, coarse sampling (tests)")
    parser.add_argument("--out", default="results/tune_clearance")
    args = parser.parse_args(argv)
    t1, samples = 0.11, (1101 if args.quick else 11001)
    steps_id, steps_design = (2, 2) if args.quick else (40, 20)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)

    start = time.perf_counter()
    ident = identification(t1, samples, steps_id, 0.02)
    errors = {k: ident.values[k] / TRUE[k] - 1.0 for k in TRUE}
    print(f"identification: {ident.values}, relative errors {errors}, "
          f"{time.perf_counter() - start:.0f} s", flush=True)

    start = time.perf_counter()
    best = design(t1, samples, steps_design, 0.1)
    print(f"design: clearance {best.values['bearing.clearance'] * 1e6:.2f} µm, smooth peak ball load "
          f"{float(best.loss):.1f} N, {time.perf_counter() - start:.0f} s", flush=True)

    fig, axes = plt.subplots(1, 3, figsize=(13, 3.6))
    axes[0].semilogy(ident.history_loss)
    axes[0].set(xlabel="step", ylabel="misfit (relative)", title="identification")
    axes[1].plot(ident.history_values["bearing.clearance"] * 1e6 / 40, label="clearance / true")
    axes[1].plot(ident.history_values["impact.restitution"] / 0.9, label="restitution / true")
    axes[1].set(xlabel="step", ylabel="value / true value", title="identified parameters")
    axes[1].legend()
    ax = axes[2]
    ax.plot(best.history_values["bearing.clearance"] * 1e6, best.history_loss, "o-")
    ax.set(xlabel="clearance P_d [µm]", ylabel="smooth peak ball load [N]", title="design")
    fig.tight_layout()
    tmp = out / "convergence.png.tmp"
    fig.savefig(tmp, dpi=120, format="png")
    os.replace(tmp, out / "convergence.png")
    summary = {
        "identification": {"values": ident.values, "relative_errors": errors,
                           "loss": ident.history_loss.tolist()},
        "design": {"clearance_m": best.values["bearing.clearance"], "smooth_peak_ball_load_N": float(best.loss),
                   "history_clearance_m": best.history_values["bearing.clearance"].tolist(),
                   "history_loss": best.history_loss.tolist()},
    }
    tmp = out / "summary.json.tmp"
    tmp.write_text(json.dumps(summary, indent=2))
    os.replace(tmp, out / "summary.json")


if __name__ == "__main__":
    main()

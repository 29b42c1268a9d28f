"""Clearance x restitution map of the paper's impact slider–crank (`jaxbearing.sweep`).

For each diametral clearance P_d and coefficient of restitution e_c, simulates 0–t1 of the
paper's case with impact (Xu 2014, Sect. 3) and records the peak ball load and the peak bearing
force |F| over t >= 0.04 s (after the start-up transient), plus the other standard metrics.
Results go to ``OUT/`` through ``sweep(out=...)`` (resumable: rerun the same command after an
interruption), then ``OUT/results.nc`` and one heatmap PNG per metric. Last, whether the map's
peak ball load is converged in the solver's tolerance at the paper's point (two tolerances,
`jaxbearing.metrics.converged`; ``OUT/convergence.json``).

    python studies/clearance_sweep.py             # 8 x 4 grid, 5–80 µm x e 0.5–1.0, 0–0.2 s
    python studies/clearance_sweep.py --quick     # 2 x 2 grid, 0–0.2 s
    python studies/clearance_sweep.py --out DIR --samples 20001
    python studies/clearance_sweep.py --grid 256 256   # a dense map, on a GPU

Prints the throughput in simulations per second (with and without the first chunk, which
includes compilation). For several CPU cores as devices, run with
``XLA_FLAGS=--xla_force_host_platform_device_count=2``. ``--grid NC NE`` spaces NC clearances
and NE restitutions evenly over the same ranges. Without ``--samples`` each member runs as one
while loop (`jaxbearing.simulate_one_loop`, the faster in batches; `jaxbearing.sweep` picks it).
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

CLEARANCES_UM = [5.0, 10.0, 20.0, 30.0, 40.0, 50.0, 60.0, 80.0]  # the paper's 40 µm among them
ANNOTATED = 16  # grids up to this many values a side get their numbers printed and on the map
RESTITUTIONS = [0.5, 0.7, 0.9, 1.0]  # the paper's 0.9 among them
QUICK_CLEARANCES_UM = [20.0, 60.0]
QUICK_RESTITUTIONS = [0.7, 1.0]
PLOTTED = {
    "peak_ball_load": "peak ball load [N], t ≥ 0.04 s",
    "peak_bearing_force": "peak bearing force |F| [N], t ≥ 0.04 s",
}


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--quick", action="store_true", help="2 x 2 grid")
    parser.add_argument("--out", default=None, help="output folder (default results/clearance_sweep[_quick])")
    parser.add_argument("--t1", type=float, default=0.2, help="final time [s] (default 0.2)")
    parser.add_argument("--samples", type=int, default=None,
                        help="output times (default: the sweep's, [0, t1]: the metrics are exact without samples)")
    parser.add_argument("--chunk-size", type=int, default=None, help="points per device per chunk")
    parser.add_argument("--grid", type=int, nargs=2, metavar=("NC", "NE"), default=None,
                        help="NC clearances over 5-80 µm x NE restitutions over 0.5-1.0, evenly spaced")
    args = parser.parse_args(argv)

    import jax

    jax.config.update("jax_enable_x64", True)

    import jaxbearing as jb
    from jaxbearing import sweep

    if args.grid is not None:
        if min(args.grid) < 2:
            parser.error(f"--grid needs at least 2 values a side; got {args.grid[0]} {args.grid[1]}")
        clearances = np.linspace(CLEARANCES_UM[0], CLEARANCES_UM[-1], args.grid[0]) * 1e-6
        restitutions = np.linspace(RESTITUTIONS[0], RESTITUTIONS[-1], args.grid[1])
    else:
        clearances = np.array(QUICK_CLEARANCES_UM if args.quick else CLEARANCES_UM) * 1e-6
        restitutions = np.array(QUICK_RESTITUTIONS if args.quick else RESTITUTIONS)
    t1 = args.t1  # quick too: the paper's span, whose solve the convergence check shares with
    # the quickstart notebook and the tests (compiled once on a machine)
    ts = None if args.samples is None else np.linspace(0.0, t1, args.samples)
    out = Path(args.out or ("results/clearance_sweep_quick" if args.quick else "results/clearance_sweep"))

    model = jb.cases.xu2014(impact=True, cage="kinematic", ball_force="paper")
    n = clearances.size * restitutions.size
    print(f"{n} simulations of 0–{t1} s on {jax.device_count()} device(s) -> {out}", flush=True)
    tic = time.perf_counter()
    ds = sweep(
        model,
        {"bearing.clearance": clearances, "impact.restitution": restitutions},
        t1=t1,
        ts=ts,
        out=out,
        chunk_size=args.chunk_size,
    )
    wall = time.perf_counter() - tic
    _report_speed(ds, wall)
    _print_table(ds)
    _check_convergence(jb, model, t1, out)
    for name, label in PLOTTED.items():
        path = out / f"{name}.png"
        _heatmap(ds, name, label, path)
        print(f"wrote {path}")
    return 0


def _check_convergence(jb, model, t1, out):
    """Is the map's metric a result? The peak ball load at the paper's point (the model as
    given: 40 µm, e 0.9) at two tolerances (`jaxbearing.metrics.converged`); written to
    ``OUT/convergence.json``."""
    import json

    found = jb.metrics.converged(model, jb.metrics.peak_ball_load, t1, rtols=(1e-8, 1e-10))
    values = ", ".join(f"{v:.2f} N" for v in found.values)
    verdict = "converged" if found.converged else "NOT converged: tighten the tolerances or shorten the span"
    print(f"peak ball load at the paper's point, rtol 1e-8 and 1e-10: {values}; spread "
          f"{found.spread:.1e} ({verdict})")
    record = {"metric": "peak_ball_load", "rtols": found.rtols, "values_N": found.values,
              "spread": found.spread, "converged": found.converged}
    (out / "convergence.json").write_text(json.dumps(record, indent=2))


def _report_speed(ds, wall):
    computed = int(ds.attrs["sweep_computed_points"])
    chunks = np.atleast_1d(ds.attrs["sweep_chunk_s"])
    if computed == 0:
        print(f"all {ds.status.size} points were already in the output folder ({wall:.1f} s)")
        return
    print(f"computed {computed} simulations in {wall:.1f} s: {computed / wall:.2f} simulations/s "
          "including compilation")
    if chunks.size > 1:
        per_chunk = computed / chunks.size  # all chunks but the last are full
        later = chunks[1:].sum()
        rest = computed - per_chunk
        print(f"  after the first chunk (compilation): {rest / later:.2f} simulations/s")


def _dense(ds) -> bool:
    """Whether the grid has more than `ANNOTATED` values a side: too many to print each."""
    return max(ds["bearing.clearance"].size, ds["impact.restitution"].size) > ANNOTATED


def _print_table(ds):
    clear = ds["bearing.clearance"].values * 1e6
    if _dense(ds):
        _print_extremes(ds)
    else:
        for name in PLOTTED:
            print(f"\n{name} [N]; rows: clearance [µm], columns: restitution")
            print("        " + "".join(f"{e:>9.2f}" for e in ds["impact.restitution"].values))
            for i, c in enumerate(clear):
                row = ds[name].values[i]
                print(f"{c:7.1f} " + "".join(f"{v:9.0f}" if np.isfinite(v) else "   failed" for v in row))
    failed = int(ds.failed.sum())
    if failed:
        print(f"\n{failed} simulations failed (status codes {sorted(set(ds.status.values.ravel()) - {0})})")


def _print_extremes(ds):
    """For grids too large to print: each plotted metric's least and largest value and where."""
    for name in PLOTTED:
        values = ds[name].values
        if not np.isfinite(values).any():
            print(f"\n{name}: every simulation failed")
            continue
        for what, pick in (("least", np.nanargmin), ("largest", np.nanargmax)):
            i, j = np.unravel_index(pick(values), values.shape)
            print(f"{name}: {what} {values[i, j]:.0f} N at P_d = {ds['bearing.clearance'].values[i] * 1e6:.2f} µm, "
                  f"e = {ds['impact.restitution'].values[j]:.3f}")


def _heatmap(ds, name, label, path):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    values = ds[name].values.T  # rows: restitution, columns: clearance
    clear = ds["bearing.clearance"].values * 1e6
    rest = ds["impact.restitution"].values
    masked = np.ma.masked_invalid(values)
    if _dense(ds):  # axes in the parameters' units
        fig, ax = plt.subplots(figsize=(7.0, 5.0), layout="constrained")
        image = ax.pcolormesh(clear, rest, masked, shading="nearest", cmap="viridis")
    else:  # one labelled cell a point, its value printed on it
        fig, ax = plt.subplots(figsize=(1.0 + 0.9 * clear.size, 1.2 + 0.6 * rest.size), layout="constrained")
        image = ax.imshow(masked, origin="lower", aspect="auto", cmap="viridis")
        ax.set_xticks(range(clear.size), [f"{c:g}" for c in clear])
        ax.set_yticks(range(rest.size), [f"{e:g}" for e in rest])
        finite = values[np.isfinite(values)]
        middle = 0.5 * (finite.min() + finite.max()) if finite.size else 0.0
        for (j, i), v in np.ndenumerate(values):
            text = f"{v:.0f}" if np.isfinite(v) else "failed"
            ax.text(i, j, text, ha="center", va="center", fontsize=8,
                    color="black" if np.isfinite(v) and v > middle else "white")
    ax.set_xlabel("diametral clearance P_d [µm]")
    ax.set_ylabel("restitution e_c")
    ax.set_title(label)
    fig.colorbar(image, ax=ax, label="N")
    fig.savefig(path, dpi=120)
    plt.close(fig)


if __name__ == "__main__":
    sys.exit(main())

"""Trace short runs of the paper's case on JAX's default device (jax.profiler): one simulation,
and optionally sweeps of several batch sizes; count the device kernels and sum their times.

    python benchmarks/gpu_profile.py OUT_DIR [t1] [--sweep 1024,4096] [--stages-written] [--one-loop]

``t1`` [s] defaults to 0.05; with ``--sweep`` it must pass the paper case's
`cases.WINDOW_START` (0.04 s), where the sweeps' standard metrics start their window.

Writes the traces under ``OUT_DIR`` and prints, for each run, the wall time of a call after
compilation (untraced), then from a traced call: the device kernels (events on the GPU's stream
lines; on the CPU nothing is counted), the time they kept the device busy, and the kernels that
took the most of it. For the single run also steps and kernels a step. ``--stages-written``:
the same with `WrittenTsit5` instead of diffrax's Tsit5 (docs/performance.md, 2026-11-26).
``--one-loop``: the single run with `jaxbearing.simulate_one_loop` (sweeps without output
samples run their members so anyway; without ``--one-loop`` they are given 2 output times, so
that their members run as `simulate`).
"""

import argparse
import collections
import time
from pathlib import Path

import diffrax
import equinox.internal as eqxi
import jax
import jax.numpy as jnp
from diffrax._solver.tsit5 import _tsit5_tableau as TABLEAU

jax.config.update("jax_enable_x64", True)

import numpy as np  # noqa: E402

import jaxbearing as jb  # noqa: E402
from run import SWEEP_CLEARANCES, SWEEP_RESTITUTIONS, T1  # noqa: E402  (the benchmark's grid and span)

TOP = 12  # kernels listed by device time


class WrittenTsit5(diffrax.Tsit5):
    """diffrax's Tsit5 with the six stages of a step written out instead of run in diffrax's
    stage loop (an `eqxi.while_loop`: on a GPU a host round trip each iteration). The same
    tableau and the same sums over the stage buffer: on the CPU a single run equals diffrax's
    Tsit5 to the last bit."""

    def step(self, terms, t0, t1, y0, args, solver_state, made_jump):
        first, f0 = solver_state
        control = terms.contr(t0, t1)
        f0 = jax.lax.cond(
            eqxi.unvmap_any(first | made_jump), lambda: terms.vf(t0, y0, args), lambda: f0
        )
        ks = jnp.zeros((7,) + y0.shape, y0.dtype).at[0].set(terms.prod(f0, control))
        for i, (row, c) in enumerate(zip(TABLEAU.a_lower, TABLEAU.c)):
            weights = jnp.zeros(7, y0.dtype).at[: row.shape[0]].set(row)
            y = y0 + jnp.tensordot(weights, ks, axes=1)
            f = terms.vf(t1 if c == 1.0 else t0 + c * (t1 - t0), y, args)
            ks = ks.at[i + 1].set(terms.prod(f, control))
        error = jnp.tensordot(jnp.asarray(TABLEAU.b_error, y0.dtype), ks, axes=1)
        dense = dict(y0=y0, y1=y, k=ks)
        return y, error, dense, (jnp.asarray(False), f), diffrax.RESULTS.successful


def _device_events(trace_dir):
    """(name, duration [ns]) of every event on the device stream lines of the newest trace."""
    path = max(Path(trace_dir).rglob("*.xplane.pb"), key=lambda p: p.stat().st_mtime)
    data = jax.profiler.ProfileData.from_file(str(path))
    return [
        (event.name, event.duration_ns)
        for plane in data.planes
        if plane.name.startswith("/device:GPU")
        for line in plane.lines
        if "Stream" in line.name
        for event in line.events
    ]


def _profiled(run, trace_dir):
    """Wall time [s] of ``run()`` after a compiling call, and the device events of a traced call."""
    jax.block_until_ready(run())
    start = time.perf_counter()
    result = jax.block_until_ready(run())
    wall = time.perf_counter() - start
    with jax.profiler.trace(str(trace_dir)):
        jax.block_until_ready(run())
    return wall, result, _device_events(trace_dir)


def _summary(events, wall):
    busy = sum(d for _, d in events) * 1e-9
    print(f"  {len(events)} kernels, device busy {busy:.3f} s of {wall:.3f} s untraced wall")
    by_name = collections.defaultdict(lambda: [0, 0.0])
    for name, d in events:
        by_name[name][0] += 1
        by_name[name][1] += d * 1e-9
    for name, (count, total) in sorted(by_name.items(), key=lambda kv: -kv[1][1])[:TOP]:
        print(f"    {total:8.3f} s {count:8d} x {1e6 * total / count:9.1f} us  {name[:90]}")


def main(out, t1, sweeps, solver=None, one_loop=False):
    model = jb.cases.xu2014(impact=True)
    ts = np.array([0.0, t1])
    single = lambda: jb.simulate(model, t1, ts, solver=solver)  # noqa: E731
    if one_loop:
        single = lambda: jb.simulate_one_loop(model, t1)  # noqa: E731
    wall, sol, events = _profiled(single, Path(out) / "single")
    steps = int(sol.num_steps) + int(sol.num_rejected_steps)
    print(f"device {jax.devices()[0].device_kind}, one simulation of {t1} s: {wall:.3f} s untraced, {steps} steps "
          f"(accepted and rejected) = {1e6 * wall / steps:.0f} us a step; {len(events) / steps:.0f} kernels a step")
    _summary(events, wall)
    # the segment slots of the benchmark's full-span sweep, so that a shorter span keeps its loops
    max_segments = jb.simulation.default_max_segments(model, 0.0, T1)
    for points in sweeps:
        n = int(round(points**0.5))
        grid = {
            "bearing.clearance": np.linspace(*SWEEP_CLEARANCES, n),
            "impact.restitution": np.linspace(*SWEEP_RESTITUTIONS, n),
        }
        settings = dict(solver=solver)
        if not one_loop:  # output times make the members run as simulate
            settings.update(options=jb.SolveOptions(max_segments=max_segments), ts=ts)
        run = lambda: jb.sweep(model, grid, t1=t1, progress=False, chunk_size=n * n, **settings)  # noqa: E731
        start = time.perf_counter()
        wall, ds, events = _profiled(run, Path(out) / f"sweep{n * n}")
        print(f"sweep of {n * n} points, {t1} s: {wall:.3f} s untraced = {n * n / wall:.0f} simulations/s "
              f"({time.perf_counter() - start:.0f} s with compile and trace), {int(ds.failed.sum())} failed")
        _summary(events, wall)


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("out")
    parser.add_argument("t1", nargs="?", type=float, default=0.05)
    parser.add_argument("--sweep", default="", help="comma-separated sweep sizes (points in one chunk)")
    parser.add_argument(
        "--stages-written", action="store_true", help="WrittenTsit5 instead of diffrax's Tsit5"
    )
    parser.add_argument("--one-loop", action="store_true", help="the single run with simulate_one_loop; sweeps as the sweep picks")
    args = parser.parse_args()
    if args.sweep and args.t1 <= jb.cases.WINDOW_START:  # the sweeps' standard metrics need their window
        parser.error(f"sweeps need t1 > {jb.cases.WINDOW_START} s (cases.WINDOW_START, where the metrics' window starts)")
    solver = WrittenTsit5() if args.stages_written else None
    main(args.out, args.t1, [int(s) for s in args.sweep.split(",") if s], solver, args.one_loop)

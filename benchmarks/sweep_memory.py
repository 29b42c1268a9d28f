"""Memory of a sweep member: XLA's compiled memory analysis of the sweep's chunk kernel
(`jaxbearing._sweep.kernel.run_chunk`) for the paper's case with impact over 0–0.2 s, at 4 and 32
points per chunk on one device: the standard metrics, which read no samples and solve [t0, t1]
only, and a metric that reads 2001 output samples (the largest ball load sampled; XLA drops the
samples of a member whose metrics do not read them).

    python benchmarks/sweep_memory.py [--chunks 4 32] [--samples 2 2001]

Prints, per setting, the temporary and output buffers [MiB] and the temporary memory per member
(the difference between the two chunk sizes over the difference in members). Compiles each
setting once (no run).
"""

from __future__ import annotations

import argparse
import itertools

import equinox as eqx
import jax

jax.config.update("jax_enable_x64", True)
import numpy as np  # noqa: E402

import jaxbearing as jb  # noqa: E402
from jaxbearing._sweep import arguments, kernel  # noqa: E402

MIB = 2.0**20


def memory(chunk: int, samples: int, t1: float = 0.2):
    """XLA's memory analysis of the compiled chunk kernel (one device)."""
    model = jb.cases.xu2014(impact=True)
    params = {"bearing.clearance": np.full(chunk, 40e-6)}
    metrics = None if samples <= 2 else {"sampled_peak_ball_load": lambda sol: jax.numpy.max(sol.ball_loads)}
    request = arguments.request(model, params, metrics, False, t1, np.linspace(0.0, t1, samples), {})
    mesh = jax.make_mesh((1,), (kernel.AXIS,), axis_types=(jax.sharding.AxisType.Auto,))
    runner = kernel.ChunkRunner(model, request, mesh, chunk)
    rows = jax.device_put(request.points, runner.split)
    lowered = kernel.run_chunk.lower(
        eqx.combine(runner.dynamic, runner.static), rows, runner.ts, runner.names, runner.metric_items,
        runner.t1, runner.sim_items, runner.solve, mesh,
    )
    return lowered.compile().compiled.memory_analysis()  # equinox wraps jax's Compiled


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--chunks", type=int, nargs="+", default=[4, 32])
    parser.add_argument("--samples", type=int, nargs="+", default=[2, 2001])
    args = parser.parse_args()
    temp = {}
    for samples, chunk in itertools.product(args.samples, args.chunks):
        m = memory(chunk, samples)
        temp[samples, chunk] = m.temp_size_in_bytes
        print(
            f"samples {samples:>6}, chunk {chunk:>3}: temp {m.temp_size_in_bytes / MIB:8.2f} MiB, "
            f"output {m.output_size_in_bytes / MIB:6.3f} MiB, "
            f"arguments {m.argument_size_in_bytes / MIB:6.3f} MiB",
            flush=True,
        )
    lo, hi = min(args.chunks), max(args.chunks)
    for samples in args.samples:
        per = (temp[samples, hi] - temp[samples, lo]) / (hi - lo) / MIB
        print(f"samples {samples:>6}: {per:.3f} MiB temporary memory per member")


if __name__ == "__main__":
    main()

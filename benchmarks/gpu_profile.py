"""Trace one short simulation of the paper's case on JAX's default device (jax.profiler) and
count the device kernels it launches per solver step.

    python benchmarks/gpu_profile.py OUT_DIR [t1]

Writes the trace under ``OUT_DIR/trace`` and prints steps, kernels and kernels per step (device
lines of the trace: the GPU's streams; on the CPU nothing is counted).
"""

import sys
from pathlib import Path

import jax

jax.config.update("jax_enable_x64", True)

import numpy as np  # noqa: E402

import jaxbearing as jb  # noqa: E402


def kernel_count(trace_dir) -> int:
    """Events on the device lines (``/device:GPU:*`` planes) of the newest trace in ``trace_dir``."""
    path = max(Path(trace_dir).rglob("*.xplane.pb"), key=lambda p: p.stat().st_mtime)
    data = jax.profiler.ProfileData.from_file(str(path))
    return sum(
        1
        for plane in data.planes
        if plane.name.startswith("/device:GPU")
        for line in plane.lines
        if "Stream" in line.name
        for _ in line.events
    )


def _print_lines(trace_dir):
    """Every device plane's lines with their event counts (what the count above is made of)."""
    path = max(Path(trace_dir).rglob("*.xplane.pb"), key=lambda p: p.stat().st_mtime)
    for plane in jax.profiler.ProfileData.from_file(str(path)).planes:
        if plane.name.startswith("/device"):
            for line in plane.lines:
                print(f"  {plane.name} | {line.name}: {sum(1 for _ in line.events)} events")


def main(out, t1=0.05):
    model = jb.cases.xu2014(impact=True)
    ts = np.array([0.0, t1])
    sol = jax.block_until_ready(jb.simulate(model, t1, ts))  # compile
    trace = Path(out) / "trace"
    with jax.profiler.trace(str(trace)):
        sol = jax.block_until_ready(jb.simulate(model, t1, ts))
    steps = int(sol.num_steps) + int(sol.num_rejected_steps)
    kernels = kernel_count(trace)
    _print_lines(trace)
    print(f"device {jax.devices()[0].device_kind}: {steps} steps (accepted and rejected), {kernels} kernels, "
          f"{kernels / steps:.0f} kernels a step")


if __name__ == "__main__":
    main(sys.argv[1], *(float(a) for a in sys.argv[2:]))

"""Cost and accuracy of one 0.2 s simulation of the paper's case with impact, per solver.

    python benchmarks/solvers.py [--repeats 5] [--solvers tsit5,dopri5,kvaerno5] [--json out.json]

For each solver and ball-force variant: compile time (first call minus a compiled call), median
wall time of a compiled call over --repeats, steps taken and rejected, and the error against a
reference run of the default solver at 1000x tighter tolerances: rod and slider positions [m] at
all output times, and ball loads [N] at the Table-5 times. Prints a table and writes JSON.
"""

from __future__ import annotations

import argparse
import json
import statistics
import time

import jax

jax.config.update("jax_enable_x64", True)

import diffrax  # noqa: E402
import jax.numpy as jnp  # noqa: E402
import numpy as np  # noqa: E402

import jaxbearing as jb  # noqa: E402

SOLVERS = {
    "tsit5": diffrax.Tsit5,
    "dopri5": diffrax.Dopri5,
    "dopri8": diffrax.Dopri8,
    "kvaerno5": jb.kvaerno5,
    "kvaerno3": lambda: diffrax.Kvaerno3(root_finder=jb.kvaerno5().root_finder),
}
T1 = 0.2
TS = jnp.linspace(0.0, T1, 2001)


def timed(fn):
    start = time.perf_counter()
    out = jax.block_until_ready(fn())
    return out, time.perf_counter() - start


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--solvers", default="tsit5,dopri5,kvaerno5")
    parser.add_argument("--forces", default="paper,smooth")
    parser.add_argument("--rtol", type=float, default=1e-8)
    parser.add_argument("--atol", type=float, default=1e-10)
    parser.add_argument("--json", default="benchmarks/solvers.json")
    args = parser.parse_args(argv)
    idx = np.searchsorted(np.asarray(TS), jb.cases.TABLE5_TIMES)
    rows = []
    for force in args.forces.split(","):
        model = jb.cases.xu2014(impact=True, ball_force=force)
        ref = jb.simulate(model, T1, TS, rtol=args.rtol * 1e-3, atol=args.atol * 1e-3, max_steps=1_000_000)
        for name in args.solvers.split(","):
            solver = SOLVERS[name]()

            def run():
                return jb.simulate(model, T1, TS, solver=solver, rtol=args.rtol, atol=args.atol)

            sol, first = timed(run)
            walls = [timed(run)[1] for _ in range(args.repeats)]
            wall = statistics.median(walls)
            pos = np.max(np.abs(np.asarray(sol.q)[:, [3, 4, 6]] - np.asarray(ref.q)[:, [3, 4, 6]]))
            load = np.max(np.abs(np.asarray(sol.ball_loads)[idx] - np.asarray(ref.ball_loads)[idx]))
            row = dict(
                solver=name,
                ball_force=force,
                wall_s=wall,
                compile_s=first - wall,
                steps=int(sol.num_steps),
                rejected=int(sol.num_rejected_steps),
                contacts=int(sol.contacts.count),
                position_error_m=float(pos),
                ball_load_error_N=float(load),
            )
            rows.append(row)
            print(
                f"{name:9s} {force:6s} wall {wall:7.3f} s  compile {row['compile_s']:6.1f} s  "
                f"steps {row['steps']:6d} ({row['rejected']:5d} rejected)  contacts {row['contacts']:2d}  "
                f"pos err {pos:.1e} m  load err {load:.2f} N",
                flush=True,
            )
    with open(args.json, "w") as f:
        json.dump(dict(rtol=args.rtol, atol=args.atol, repeats=args.repeats, rows=rows), f, indent=2)


if __name__ == "__main__":
    main()

"""What tracing a solve costs, in measures the machine's load does not move (issue 65).

    python benchmarks/trace_cost.py [simulate grad jacfwd] [--hlo] [--t1 0.05]

For the paper's case with impact over 0-t1 (2 001 output times, simulate's defaults), each of
its forward run (``simulate``), `jax.grad` and `jax.jacfwd` (``diffrax.ForwardMode()``) of the
RMS bearing force in the clearance, traced in this order in one process: the primitives bound
while tracing (`jax.make_jaxpr`), the equations of the jaxpr counted into its sub-jaxprs, and
with ``--hlo`` the lines of the StableHLO (``jax.jit(f).lower(x).as_text()``). Run it with
``JAXBEARING_NO_COMPILATION_CACHE=1``; docs/performance.md gives the figures.
"""

from __future__ import annotations

import argparse
import json
import time

import diffrax
import jax

jax.config.update("jax_enable_x64", True)
import numpy as np  # noqa: E402
from jax.extend import core  # noqa: E402

import jaxbearing as jb  # noqa: E402


def equations(jaxpr) -> int:
    """Equations of ``jaxpr``, those of its sub-jaxprs (loop bodies, branches) included."""
    count = 0
    for eqn in jaxpr.eqns:
        count += 1
        for param in eqn.params.values():
            for sub in param if isinstance(param, (tuple, list)) else (param,):
                if isinstance(sub, core.ClosedJaxpr):
                    count += equations(sub.jaxpr)
                elif isinstance(sub, core.Jaxpr):
                    count += equations(sub)
    return count


class Binds:
    """Counts every primitive bound while it is open."""

    def __enter__(self):
        self.count, self._bind = 0, core.Primitive.bind

        def counted(primitive, *args, **params):
            self.count += 1
            return self._bind(primitive, *args, **params)

        core.Primitive.bind = counted
        return self

    def __exit__(self, *exc):
        core.Primitive.bind = self._bind


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("transforms", nargs="*", default=["simulate", "grad", "jacfwd"])
    parser.add_argument("--hlo", action="store_true", help="also the StableHLO's lines")
    parser.add_argument("--t1", type=float, default=0.05)
    args = parser.parse_args()
    model = jb.cases.xu2014(impact=True)
    ts = np.linspace(0.0, args.t1, 2001)
    clearance = jb.paths.get(model, "bearing.clearance")

    def run(c, adjoint=None):
        moved = jb.paths.replace(model, {"bearing.clearance": c})
        return jb.simulate(moved, args.t1, ts, adjoint=adjoint, throw=False)

    functions = {
        "simulate": run,
        "grad": jax.grad(lambda c: jb.metrics.rms_bearing_force(run(c))),
        "jacfwd": jax.jacfwd(lambda c: jb.metrics.rms_bearing_force(run(c, diffrax.ForwardMode()))),
    }
    for name in args.transforms:
        start = time.perf_counter()
        with Binds() as binds:
            jaxpr = jax.make_jaxpr(functions[name])(clearance)
        row = dict(transform=name, t1_s=args.t1, primitives_bound=binds.count,
                   equations=equations(jaxpr.jaxpr), trace_s=round(time.perf_counter() - start, 2))
        if args.hlo:
            row["hlo_lines"] = len(jax.jit(functions[name]).lower(clearance).as_text().splitlines())
        print(json.dumps(row), flush=True)


if __name__ == "__main__":
    main()

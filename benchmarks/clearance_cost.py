"""What a plain bearing costs against a ball bearing (issue 74's targets).

    python benchmarks/clearance_cost.py [--runs 10] [--processes 3] [--json benchmarks/results.json]

The paper's slider–crank without impact over 0-0.2 s (2001 output times) with its crank pin a
dry plain bearing (`JournalBearing.from_geometry`: R 12.5 mm, c 20 um, L 12 mm, e_c 0.9, mu 0.1;
a `ClearanceJoint`) against the same crank with the paper's SKF 98205 (`cases.xu2014`): in
``--processes`` pairs of fresh worker processes (`step_cost.Worker`: each a cold cache folder
of its own, started one after the other, each case first in turn), each worker's first call
(trace, compile, one run), and in the first pair ``--runs`` runs of each taken in turn, the
fastest of each: wall per step. Targets: per step within `STEP_RATIO` of the ball bearing's,
the first call within `COMPILE_RATIO` of its: the median over the pairs of each pair's ratio
(a pair meets one load of the machine), beside the ratio of the medians and that of the
first calls' median processor times (which the machine's load moves less than their wall).

The figures go to the JSON under ``"plain_bearing"`` (other keys kept), with the machine's
load average and calibrator (wall of ``sum(range(10**8))``): the machine is shared, and a
compile's time moves with its load.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import statistics
import tempfile
import time
from pathlib import Path

from step_cost import ROOT, Worker, _calibrator, _per_step

STEP_RATIO = 2.0  # wall per step of the plain bearing's crank against the ball bearing's
COMPILE_RATIO = 1.2  # first call (compile) likewise


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=10)
    parser.add_argument("--processes", type=int, default=3, help="pairs of fresh workers for the first calls")
    parser.add_argument("--json", type=Path, default=ROOT / "benchmarks" / "results.json")
    args = parser.parse_args(argv)
    results = {"date": time.strftime("%Y-%m-%d"), "machine": platform.processor() or platform.machine(),
               "cpus": os.cpu_count(), "load_average": os.getloadavg(), "calibrator_s": _calibrator(),
               "runs": args.runs, "processes": args.processes}  # fmt: skip
    firsts = {"plain_bearing": [], "one_bearing": []}
    processor = {case: [] for case in firsts}  # the first calls' processor time [s]
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        for k in range(args.processes):
            order = list(firsts) if k % 2 == 0 else list(reversed(firsts))  # each first in turn
            workers = {case: Worker(case, ROOT, tmp / f"{case}{k}") for case in order}
            for case, worker in workers.items():
                firsts[case].append(worker.first["first"])
                processor[case].append(worker.first["first_cpu"])
            print(f"pair {k + 1}: first calls {firsts['plain_bearing'][-1]:.1f} s (plain bearing), "
                  f"{firsts['one_bearing'][-1]:.1f} s (ball bearing)", flush=True)  # fmt: skip
            if k == 0:
                runs = {case: [] for case in workers}
                for _ in range(args.runs):
                    for case, worker in workers.items():
                        runs[case].append(worker.run())
            for worker in workers.values():
                worker.close()
    plain, ball = runs["plain_bearing"], runs["one_bearing"]
    step_ratio = _per_step(plain) / _per_step(ball)
    medians = {case: statistics.median(values) for case, values in firsts.items()}
    pair_ratios = [a / b for a, b in zip(firsts["plain_bearing"], firsts["one_bearing"])]
    compile_ratio = statistics.median(pair_ratios)
    cpu_ratio = statistics.median(processor["plain_bearing"]) / statistics.median(processor["one_bearing"])
    results.update(
        steps=[plain[0]["steps"], ball[0]["steps"]],
        rejected=[plain[0]["rejected"], ball[0]["rejected"]],
        per_step_us=[1e6 * _per_step(plain), 1e6 * _per_step(ball)],
        wall_s=[min(r["wall"] for r in plain), min(r["wall"] for r in ball)],
        step_ratio=step_ratio,
        step_ratio_met=step_ratio <= STEP_RATIO,
        first_call_s={case: values for case, values in firsts.items()},
        first_call_median_s=[medians["plain_bearing"], medians["one_bearing"]],
        first_call_pair_ratios=pair_ratios,
        first_call_cpu_s=processor,
        first_call_cpu_ratio=cpu_ratio,
        compile_ratio=compile_ratio,
        compile_ratio_of_medians=medians["plain_bearing"] / medians["one_bearing"],
        compile_ratio_met=compile_ratio <= COMPILE_RATIO,
        load_average_after=os.getloadavg(),
    )
    print(f"plain bearing: {plain[0]['steps']} steps ({plain[0]['rejected']} rejected), "
          f"{1e6 * _per_step(plain):.2f} us per step; ball bearing: {ball[0]['steps']} steps "
          f"({ball[0]['rejected']} rejected), {1e6 * _per_step(ball):.2f} us per step: "
          f"{step_ratio:.3f}x (target <= {STEP_RATIO}); first call (medians of {args.processes}) "
          f"{medians['plain_bearing']:.1f} s against {medians['one_bearing']:.1f} s, the pairs' "
          f"median ratio {compile_ratio:.3f}x (target <= {COMPILE_RATIO}); processor time "
          f"{cpu_ratio:.3f}x", flush=True)  # fmt: skip
    stored = json.loads(args.json.read_text()) if args.json.exists() else {}
    stored["plain_bearing"] = results
    args.json.write_text(json.dumps(stored, indent=2))


if __name__ == "__main__":
    main()

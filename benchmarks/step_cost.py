"""What a solver step costs against an earlier commit (issue 72's targets; issue 63's before).

    python benchmarks/step_cost.py [--against REV] [--tree REV] [--runs 10] [--json benchmarks/results.json]

Two comparisons, each between two worker processes that compile once and then run alternately
(interleaved), so that both meet the same machine, and the fastest of ``--runs`` runs of each:

- ``paper``: the paper's case with impact over 0-0.2 s (2001 output times) at this working tree
  (or the commit ``--tree``) and at ``--against`` (a commit, exported with ``git archive``): steps taken and rejected (equal),
  wall per step and its ratio (target <= `PAPER_RATIO`), and each worker's first call (trace,
  compile, run; cold, in a cache folder of its own: target no slower);
- ``two_bearings``: the paper's slider–crank without impact over 0-0.2 s with a second SKF 98205
  in place of the ground–crank pin (the paper's crank with its first joint replaced) against the
  paper's crank: wall per step and its ratio (target <= `TWO_BEARING_RATIO`).

The figures go to the JSON under ``"step_cost"`` (other keys kept) with the machine's calibrator
(wall of ``sum(range(10**8))``).
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import subprocess
import sys
import tarfile
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PAPER_RATIO = 1.05  # wall per step against the commit before the element protocol (issue 72)
TWO_BEARING_RATIO = 1.6  # two-bearing crank per step against the one-bearing crank (issue 63)
DEFAULT_AGAINST = "7936899"  # the last commit before the element protocol (issue 72)

WORKER = r"""
import json, sys, time
t_start = time.perf_counter()
import jax
jax.config.update("jax_enable_x64", True)
import jax.numpy as jnp
import jaxbearing as jb

case = sys.argv[1]
if case == "paper":
    model = jb.cases.xu2014(impact=True)
elif case == "one_bearing":
    model = jb.cases.xu2014(impact=False)
elif case == "plain_bearing":  # the crank pin a dry plain bearing (benchmarks/clearance_cost.py)
    journal = jb.JournalBearing.from_geometry(radius=12.5e-3, clearance=20e-6, length=12e-3,
                                              restitution=0.9, friction=0.1)
    model = jb.cases.xu2014(impact=False, bearing=journal)
else:  # the ground-crank pin (joint 0) replaced by a second bearing
    from jaxbearing.multibody import GROUND, BearingJoint
    m = jb.cases.xu2014(impact=False)
    ground = BearingJoint(GROUND, (0.0, 0.0), 0, (-0.025, 0.0), jb.cases.skf98205())  # crank 0.05 m
    model = jb.Mechanism(m.bodies, m.joints[1:], m.q0, m.qd0, forces=m.forces + (ground,),
                         body_names=m.body_names, window_start=m.window_start)
ts = jnp.linspace(0.0, 0.2, 2001)

def run():
    t, cpu = time.perf_counter(), time.process_time()
    sol = jb.simulate(model, 0.2, ts)
    sol.q.block_until_ready()
    return time.perf_counter() - t, int(sol.num_steps), int(sol.num_rejected_steps), time.process_time() - cpu

first, steps, rejected, first_cpu = run()
print(json.dumps({"first": first, "first_cpu": first_cpu, "steps": steps, "rejected": rejected,
                  "file": jb.__file__}), flush=True)
for line in sys.stdin:
    wall, steps, rejected, _ = run()
    print(json.dumps({"wall": wall, "steps": steps, "rejected": rejected}), flush=True)
"""


class Worker:
    """A process that compiles ``case`` at ``tree`` once, then runs it on each request."""

    def __init__(self, case: str, tree: Path, cache: Path):
        env = {k: v for k, v in os.environ.items() if not k.startswith(("JAX_", "XLA_", "JAXBEARING_"))}
        env.update(PYTHONPATH=str(tree), JAX_COMPILATION_CACHE_DIR=str(cache), JAX_PLATFORMS="cpu")
        self.process = subprocess.Popen(
            [sys.executable, "-c", WORKER, case], stdin=subprocess.PIPE, stdout=subprocess.PIPE,
            text=True, env=env, cwd=tempfile.gettempdir(),
        )  # fmt: skip
        self.first = self._read()
        if not self.first["file"].startswith(str(tree)):
            raise RuntimeError(f"the worker for {tree} imported {self.first['file']}")

    def _read(self) -> dict:
        line = self.process.stdout.readline()
        if not line:
            raise RuntimeError(f"worker exited with {self.process.wait()}")
        return json.loads(line)

    def run(self) -> dict:
        self.process.stdin.write("run\n")
        self.process.stdin.flush()
        return self._read()

    def close(self):
        self.process.stdin.close()
        self.process.wait()


def _export(rev: str, into: Path) -> Path:
    """The package ``jaxbearing/`` of commit ``rev``, unpacked into ``into``."""
    archive = subprocess.run(["git", "archive", rev, "jaxbearing"], cwd=ROOT, capture_output=True, check=True)
    with tarfile.open(fileobj=__import__("io").BytesIO(archive.stdout)) as tar:
        tar.extractall(into, filter="data")
    return into


def _interleaved(a: tuple, b: tuple, runs: int) -> tuple[Worker, Worker, list, list]:
    """Workers of ``a`` and ``b`` ((case, tree, cache) each), their ``runs`` runs taken in turn;
    the workers are closed after."""
    workers = Worker(*a), Worker(*b)
    out_a, out_b = [], []
    for _ in range(runs):
        out_a.append(workers[0].run())
        out_b.append(workers[1].run())
    for w in workers:
        w.close()
    return (*workers, out_a, out_b)


def _per_step(runs: list) -> float:
    return min(r["wall"] for r in runs) / runs[0]["steps"]


def _calibrator() -> float:
    t = time.perf_counter()
    sum(range(10**8))
    return time.perf_counter() - t


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--against", default=DEFAULT_AGAINST)
    parser.add_argument("--tree", default=None, help="a commit in place of the working tree")
    parser.add_argument("--runs", type=int, default=10)
    parser.add_argument("--json", type=Path, default=ROOT / "benchmarks" / "results.json")
    args = parser.parse_args(argv)
    results = {"date": time.strftime("%Y-%m-%d"), "machine": platform.processor() or platform.machine(),
               "calibrator_s": _calibrator(), "runs": args.runs}  # fmt: skip
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        parent = _export(args.against, tmp / "parent")
        tree = ROOT if args.tree is None else _export(args.tree, tmp / "tree")
        here, there, new, old = _interleaved(("paper", tree, tmp / "c1"), ("paper", parent, tmp / "c2"), args.runs)
        ratio = _per_step(new) / _per_step(old)
        results["paper"] = {
            "tree": args.tree or "working tree",
            "against": args.against,
            "steps": [new[0]["steps"], old[0]["steps"]],
            "rejected": [new[0]["rejected"], old[0]["rejected"]],
            "per_step_us": [1e6 * _per_step(new), 1e6 * _per_step(old)],
            "ratio": ratio,
            "ratio_met": ratio <= PAPER_RATIO,
            "first_call_s": [here.first["first"], there.first["first"]],
            "first_call_met": here.first["first"] <= there.first["first"],
        }
        print(f"paper: {new[0]['steps']} steps ({new[0]['rejected']} rejected) here, "
              f"{old[0]['steps']} ({old[0]['rejected']}) at {args.against}; per step "
              f"{1e6 * _per_step(new):.2f} us against {1e6 * _per_step(old):.2f} us: {ratio:.3f}x "
              f"(target <= {PAPER_RATIO}); first call {here.first['first']:.1f} s against "
              f"{there.first['first']:.1f} s", flush=True)  # fmt: skip
        two, one, runs_two, runs_one = _interleaved(
            ("two_bearings", tree, tmp / "c3"), ("one_bearing", tree, tmp / "c4"), args.runs
        )
        ratio = _per_step(runs_two) / _per_step(runs_one)
        results["two_bearings"] = {
            "steps": [runs_two[0]["steps"], runs_one[0]["steps"]],
            "per_step_us": [1e6 * _per_step(runs_two), 1e6 * _per_step(runs_one)],
            "ratio": ratio,
            "ratio_met": ratio <= TWO_BEARING_RATIO,
            "first_call_s": [two.first["first"], one.first["first"]],
        }
        print(f"two bearings: {runs_two[0]['steps']} steps, per step {1e6 * _per_step(runs_two):.2f} us "
              f"against one bearing's {1e6 * _per_step(runs_one):.2f} us ({runs_one[0]['steps']} "
              f"steps): {ratio:.3f}x (target <= {TWO_BEARING_RATIO})", flush=True)  # fmt: skip
    stored = json.loads(args.json.read_text()) if args.json.exists() else {}
    stored["step_cost"] = results
    args.json.write_text(json.dumps(stored, indent=2))  # as benchmarks/run.py writes it


if __name__ == "__main__":
    main()

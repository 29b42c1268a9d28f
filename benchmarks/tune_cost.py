"""What tuning costs against simulating (issue 75's targets).

    python benchmarks/tune_cost.py [--only GROUP ...] [--runs 3] [--json benchmarks/results.json]

Each job runs in a fresh worker process with JAX's persistent compilation cache off
(``JAXBEARING_NO_COMPILATION_CACHE=1``), one after the other, so that its first call traces and
compiles everything; later calls in the same worker are warm. Cases:

- ``paper``: the paper's case with impact (`cases.xu2014(impact=True, ball_force="smooth")`)
  over 0-0.2 s at simulate's default tolerances; the loss is the RMS bearing force, the
  parameter the clearance.
- ``roller``: a two-bearing crank: the paper's slider-crank without impact, its crank pin an
  NU 205 roller bearing (estimated internals, smooth force) and its ground pin a second SKF
  98205 (as in benchmarks/step_cost.py), over 0-0.2 s at the derivative tolerance
  (`derivative_controller()`); the loss is the roller's smooth peak element load, the
  parameter the roller's clearance (``bearings.0.bearing.clearance``).
- ``reference``: diffrax's own Tsit5 + PID solve of the Lorenz system (benchmarks/run.py),
  whose first call the first calls are measured against.

Groups (``--only``): ``tune`` (12 `jb.tune` steps on the roller crank against 12 simulations
plus one compile), ``reverse`` (warm `jax.grad` against a warm forward run, both cases, and
each process's peak resident memory), ``first`` (first calls of the paper's case against the
reference's), ``threshold`` (forward mode with 1 and 4 parameters against reverse mode, warm and
first calls, both cases: what ``mode="auto"``'s threshold rests on), ``suite`` (README's test
command, ``python -m pytest``, with this interpreter and an empty compilation cache, against the
calibrator; the issue measures it in a fresh virtual environment made from pyproject.toml). Each target is printed with its
figure and ratio; the figures go to the JSON under ``"tune_cost"``, one entry a group (each
run's entry under every group it ran; other groups and keys kept), with the machine's load
average and calibrator (wall of ``sum(range(10**8))``).
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
TUNE_STEPS = 12
TARGETS = {  # the bound on each ratio
    "tune_12_steps": 3.0,  # 12 tune steps / (12 simulations + one compile), roller crank
    "reverse_warm": 5.0,  # warm jax.grad / warm forward run (stretch 3)
    "first_simulate": 5.0,  # first simulate / reference's first call
    "first_grad": 3.0,  # first jax.grad / first simulate
    "first_tune_step": 3.0,  # first tune step / first simulate
    "suite": 180.0,  # the test command from an empty cache / the calibrator
}

WORKER = r"""
import json, resource, sys, time
import jax
jax.config.update("jax_enable_x64", True)
import jax.numpy as jnp
import optax
import jaxbearing as jb
from jaxbearing.multibody import GROUND, BearingJoint

case, job, runs = sys.argv[1], sys.argv[2], int(sys.argv[3])
if case == "paper":
    base = jb.cases.xu2014(impact=True, ball_force="smooth")
    name, kw = "bearing.clearance", {}
    metric, others = jb.metrics.rms_bearing_force, "impact.restitution"
elif case == "roller":
    roller = jb.RollerBearing.from_catalogue("NU205-estimated", ball_force="smooth")
    m = jb.cases.xu2014(impact=False, bearing=roller)
    ball = jb.cases.skf98205(ball_force="smooth")
    ground = BearingJoint(GROUND, (0.0, 0.0), 0, (-0.025, 0.0), ball)
    base = jb.Mechanism(m.bodies, m.joints[1:], m.q0, m.qd0, forces=m.forces + (ground,),
                        body_names=m.body_names, window_start=m.window_start)
    name, kw = "bearings.0.bearing.clearance", {"stepsize_controller": jb.derivative_controller()}
    metric = jb.metrics.smooth_peak_ball_load.replace(bearing=0)  # the roller
    others = "bearings.1.bearing.clearance"  # the ball bearing's
ts = jnp.linspace(0.0, 0.2, 2001)


def loss(model):  # simulate's adjoint left to its default, as a user writes it
    return metric(jb.simulate(model, 0.2, ts, **kw))


def timed(fn, *args):
    t = time.perf_counter()
    out = jax.block_until_ready(fn(*args))
    return time.perf_counter() - t, out


def at(c):
    return jb.paths.replace(base, {name: c})


c0 = float(jb.paths.get(base, name))
out = {}
if job == "reference":
    import diffrax

    def lorenz(t, y, rho):
        return jnp.stack([10.0 * (y[1] - y[0]), y[0] * (rho - y[2]) - y[1],
                          y[0] * y[1] - 8.0 / 3.0 * y[2]])

    @jax.jit
    def solve(rho):
        controller = diffrax.PIDController(rtol=1e-8, atol=1e-8)
        return diffrax.diffeqsolve(diffrax.ODETerm(lorenz), diffrax.Tsit5(), 0.0, 1.0, 0.01,
                                   jnp.ones(3), args=rho, stepsize_controller=controller).ys[-1]
    out["first"], _ = timed(solve, jnp.asarray(28.0))
elif job == "simulate":
    walls = []
    for k in range(runs):
        w, sol = timed(lambda: jb.simulate(base, 0.2, ts, **kw))
        walls.append(w)
    out.update(first=walls[0], warm=min(walls[1:]), walls=walls, steps=int(sol.num_steps))
elif job in ("grad", "forward1", "forward4"):
    if job == "grad":
        fn, x = jax.jit(jax.grad(lambda c: loss(at(c)))), jnp.asarray(c0)
    else:  # jb.sensitivity's forward mode with 1 or 4 parameters
        more = [name.replace("clearance", p) for p in ("stiffness", "damping")] + [others]
        names = [name] + (more if job == "forward4" else [])
        controller = kw.get("stepsize_controller", jb.default_controller())
        fn = lambda: jb.sensitivity(base, metric, names, 0.2, ts, mode="forward",
                                    stepsize_controller=controller)
        x = None
    walls = [timed(fn, *(() if x is None else (x,)))[0] for _ in range(runs)]
    out.update(first=walls[0], warm=min(walls[1:]), walls=walls)
elif job == "tune":
    stamps, t = [], time.perf_counter()
    result = jb.tune(loss, base, [name], optax.adam(0.05), runs,
                     bounds={name: (5e-6, 80e-6)},
                     callback=lambda *a: stamps.append(time.perf_counter()))
    total = time.perf_counter() - t
    out.update(total=total, first=stamps[0] - t, evaluations=len(stamps),
               losses=[float(v) for v in result.history_loss])
out["peak_rss_MiB"] = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
out["file"] = jb.__file__
print(json.dumps(out), flush=True)
"""


def work(case: str, job: str, runs: int = 1) -> dict:
    """``job`` on ``case`` in a fresh process with the persistent compilation cache off."""
    env = {k: v for k, v in os.environ.items() if not k.startswith(("JAX_", "XLA_", "JAXBEARING_"))}
    env.update(PYTHONPATH=str(ROOT), JAXBEARING_NO_COMPILATION_CACHE="1", JAX_PLATFORMS="cpu")
    start = time.perf_counter()
    done = subprocess.run([sys.executable, "-c", WORKER, case, job, str(runs)], env=env,
                          capture_output=True, text=True, cwd=tempfile.gettempdir())
    if done.returncode:
        raise RuntimeError(f"{case} {job} failed:\n{done.stderr[-3000:]}")
    out = json.loads(done.stdout.strip().splitlines()[-1])
    if not out["file"].startswith(str(ROOT)):
        raise RuntimeError(f"the worker imported {out['file']}, not this tree")
    out["process_s"] = time.perf_counter() - start
    shown = {k: v for k, v in out.items() if k != "file"}
    print(f"  {case} {job}: {json.dumps(shown)}", flush=True)
    return out


def target(results: dict, key: str, figure: float, base: float, what: str) -> None:
    """Print and keep one target: its figure, the denominator, the ratio and whether it is met."""
    ratio = figure / base
    bound = TARGETS[key.split(":")[0]]
    met = ratio <= bound if key.split(":")[0] != "tune_12_steps" else ratio < bound
    results["targets"][key] = dict(figure_s=figure, base_s=base, ratio=ratio, bound=bound, met=met)
    print(f"{what}: {figure:.2f} s / {base:.2f} s = {ratio:.2f}x (target {bound:g}x: "
          f"{'met' if met else 'not met'})", flush=True)


def run_suite() -> dict:
    """README's test command in this tree with this interpreter, JAX's compilation cache in an
    empty folder: its wall [s] and pytest's last line."""
    with tempfile.TemporaryDirectory() as cache:
        env = {k: v for k, v in os.environ.items() if not k.startswith(("JAXBEARING_", "JAX_"))}
        start = time.perf_counter()
        done = subprocess.run([sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider"], cwd=ROOT,
                              env={**env, "XDG_CACHE_HOME": cache}, capture_output=True, text=True)
        wall = time.perf_counter() - start
    summary = (done.stdout.strip().splitlines() or [""])[-1].strip("= ")
    if done.returncode != 0:
        raise RuntimeError(f"the test command failed ({summary}):\n{done.stdout[-3000:]}")
    print(f"  suite: {wall:.1f} s, {summary}", flush=True)
    return {"wall_s": wall, "summary": summary}


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--only", nargs="*", default=["tune", "reverse", "first", "threshold", "suite"])
    parser.add_argument("--runs", type=int, default=3, help="warm calls after the first")
    parser.add_argument("--json", type=Path, default=ROOT / "benchmarks" / "results.json")
    args = parser.parse_args(argv)
    t = time.perf_counter()
    sum(range(10**8))
    results = {"date": time.strftime("%Y-%m-%d"),
               "machine": platform.processor() or platform.machine(),
               "cpus": os.cpu_count(), "load_average": os.getloadavg(),
               "calibrator_s": time.perf_counter() - t, "targets": {}, "jobs": {}, "threshold": {}}
    jobs = results["jobs"]
    if "tune" in args.only:
        jobs["roller simulate"] = sim = work("roller", "simulate", TUNE_STEPS)
        jobs["roller tune"] = tune = work("roller", "tune", TUNE_STEPS)
        target(results, "tune_12_steps", tune["total"], sum(sim["walls"]),
               f"{TUNE_STEPS} jb.tune steps (roller clearance, auto mode) against "
               f"{TUNE_STEPS} simulations plus one compile")
    for case in ("paper", "roller") if "reverse" in args.only else ():
        sim = jobs.get(f"{case} simulate") or work(case, "simulate", args.runs + 1)
        jobs[f"{case} simulate"] = sim
        jobs[f"{case} grad"] = grad = work(case, "grad", args.runs + 1)
        target(results, f"reverse_warm:{case}", grad["warm"], sim["warm"],
               f"{case}: warm jax.grad (peak {grad['peak_rss_MiB']:.0f} MiB resident, "
               f"simulate's {sim['peak_rss_MiB']:.0f} MiB) against a warm forward run")
    if "first" in args.only:
        ref = jobs["reference"] = work("paper", "reference")
        sim = jobs.get("paper simulate") or work("paper", "simulate", args.runs + 1)
        jobs["paper simulate"] = sim
        grad = jobs.get("paper grad") or work("paper", "grad", 2)
        jobs["paper grad"] = grad
        tune = jobs["paper tune"] = work("paper", "tune", 1)
        target(results, "first_simulate", sim["first"], ref["first"],
               "paper: first simulate against the reference's first call")
        target(results, "first_grad", grad["first"], sim["first"],
               "paper: first jax.grad against its first simulate")
        target(results, "first_tune_step", tune["first"], sim["first"],
               "paper: first jb.tune step (auto: forward mode) against its first simulate")
    for case in ("paper", "roller") if "threshold" in args.only else ():
        for job in ("forward1", "forward4"):
            jobs[f"{case} {job}"] = work(case, job, args.runs + 1)
        grad = jobs.get(f"{case} grad") or work(case, "grad", args.runs + 1)
        jobs[f"{case} grad"] = grad
        one, four = jobs[f"{case} forward1"], jobs[f"{case} forward4"]
        per, per_first = (four["warm"] - one["warm"]) / 3, (four["first"] - one["first"]) / 3
        runs = 1 + (grad["warm"] - one["warm"]) / per
        firsts = 1 + (grad["first"] - one["first"]) / per_first
        results["threshold"][case] = dict(tangent_s=per, tangent_first_s=per_first,
                                          warm_crossover=runs, first_crossover=firsts)
        print(f"{case}: forward mode with 1 / 4 parameters warm {one['warm']:.3f} / "
              f"{four['warm']:.3f} s, first {one['first']:.1f} / {four['first']:.1f} s; "
              f"reverse warm "
              f"{grad['warm']:.3f} s, first {grad['first']:.1f} s: forward is the cheaper up to "
              f"{runs:.1f} parameters warm, {firsts:.1f} in its first call", flush=True)
    if "suite" in args.only:
        results["suite"] = suite = run_suite()
        target(results, "suite", suite["wall_s"], results["calibrator_s"],
               f"the test command from an empty cache ({suite['summary']}) against the calibrator")
    results["wall_s"] = time.perf_counter() - t
    stored = json.loads(args.json.read_text()) if args.json.exists() else {}
    kept = stored.get("tune_cost", {})
    stored["tune_cost"] = {**kept, **{group: results for group in args.only}}
    args.json.write_text(json.dumps(stored, indent=2) + "\n")

if __name__ == "__main__":
    main()

"""Where XLA's compile of a solve goes, piece by piece, in a measure the load does not move
(issue 65).

    JAXBEARING_NO_COMPILATION_CACHE=1 python benchmarks/compile_pieces.py [--case paper]
        [--transform simulate|grad] [--t1 0.2] [--json FILE]

Compiles one first call in this process (the paper's case with impact, the rotor or the
four-bar; the forward run with 2 001 output times, or `jax.grad` of the RMS bearing force in the
clearance), under `jax.profiler.trace`, and reports:

- the compile's phases from XLA's own profiler events (`jax.profiler.ProfileData`): the HLO
  passes, the LLVM code generation, and its largest single task. XLA:CPU compiles each loop
  that the loop flag opens (`jaxbearing._process`) into one function, so the solve's loop is
  one task, which no second core shares;
- the optimized HLO's instructions (``compiled.as_text()``) by piece of the solve, each
  instruction attributed through XLA's stack-frame table to the innermost function of
  `PIECES` it was traced in (deterministic: the same on every machine of one JAX version).
"""

from __future__ import annotations

import argparse
import collections
import glob
import json
import re
import tempfile
import time

import jax

jax.config.update("jax_enable_x64", True)
import numpy as np  # noqa: E402

import jaxbearing as jb  # noqa: E402

CASES = {
    "paper": lambda: jb.cases.xu2014(impact=True),
    "rotor": lambda: jb.cases.rotor(jb.cases.skf98205()),
    "four_bar": lambda: jb.cases.four_bar(),
}
PIECES = {  # a function of the solve -> the piece its instructions count to (innermost wins)
    "_accelerations": "right-hand side (Eq. 36)",
    "_attempt": "solver step and step-size control",
    **dict.fromkeys(("event_values", "_event_value", "_switch", "_event_time", "itp_step",
                     "itp_start", "_locate"), "events and their root finder"),
    **dict.fromkeys(("step_stats", "_spans", "_running", "_drift"), "records"),
    **dict.fromkeys(("_write_outputs", "_rows_at", "output_rows", "solution"), "outputs"),
    **dict.fromkeys(("core_start", "initial_state"), "setup and checks"),
}
PHASES = {  # XLA:CPU's profiler events (JAX 0.10, less the module's name) -> a phase
    "HLO passes through layout assignment": "HLO passes",
    "HLO passes after layout assignment": "HLO passes",
    "JitCompiler::Compile": "LLVM code generation",
}


def _function(case: str, transform: str, t1: float):
    model = CASES[case]()
    ts = np.linspace(0.0, t1, 2001)

    def run(c):
        return jb.simulate(jb.paths.replace(model, {"bearing.clearance": c}), t1, ts, throw=False)

    if transform == "grad":
        return jax.grad(lambda c: jb.metrics.rms_bearing_force(run(c))), jb.paths.get(model, "bearing.clearance")
    return run, jb.paths.get(model, "bearing.clearance")


def phases(profile_dir: str) -> dict:
    """Seconds of each of `PHASES`, and of the largest code-generation task, in the profile."""
    path = glob.glob(f"{profile_dir}/**/*.xplane.pb", recursive=True)[0]
    out = collections.Counter()
    tasks = [0.0]
    for plane in jax.profiler.ProfileData.from_file(path).planes:
        for line in plane.lines:
            for event in line.events:
                name = event.name.split(" (")[0]
                if name in PHASES:
                    out[PHASES[name]] += event.duration_ns / 1e9
                elif event.name == "TaskDispatcher::dispatch":
                    tasks.append(event.duration_ns / 1e9)
    return {**out, "largest code-generation task": max(tasks), "code-generation tasks": len(tasks) - 1}


def _tables(text: str):
    """XLA's stack-frame tables of an HLO module's text: frame id -> (function, parent id)."""
    tables, current = collections.defaultdict(dict), None
    for line in text.splitlines():
        if line in ("FileNames", "FunctionNames", "FileLocations", "StackFrames"):
            current = line
        elif current and not line.strip():
            current = None
        elif current:
            key, rest = line.split(" ", 1)
            fields = dict(re.findall(r"(\w+)=(\d+)", rest))
            tables[current][int(key)] = fields or rest.strip('"')
    locations = tables["FileLocations"]
    function = {k: tables["FunctionNames"][int(v["function_name_id"])] for k, v in locations.items()}
    return {
        k: (function[int(v["file_location_id"])].split(".")[-1], int(v["parent_frame_id"]) - 1)
        for k, v in tables["StackFrames"].items()
    }


def pieces(text: str) -> dict:
    """The optimized HLO's instructions by `PIECES` (``text``: ``compiled.as_text()``)."""
    frames = _tables(text)
    out = collections.Counter()
    for line in text.splitlines():
        if not re.match(r"\s+(ROOT )?%?[\w.\-]+ = ", line):
            continue
        frame = re.search(r"stack_frame_id=(\d+)", line)
        fid, piece = int(frame.group(1)) if frame else 0, None
        while fid > 0 and piece is None:
            name, fid = frames[fid]
            piece = PIECES.get(name)
        out[piece or ("loop state and plumbing" if frame else "no source (copies, tuples)")] += 1
    return dict(out.most_common())


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--case", choices=list(CASES), default="paper")
    parser.add_argument("--transform", choices=["simulate", "grad"], default="simulate")
    parser.add_argument("--t1", type=float, default=None, help="span [s] (default 0.2, 0.05 for grad)")
    parser.add_argument("--json", help="append the row to this file (JSON lines)")
    args = parser.parse_args()
    t1 = args.t1 or (0.05 if args.transform == "grad" else 0.2)
    fn, x = _function(args.case, args.transform, t1)
    lowered = jax.jit(fn).trace(x).lower()
    with tempfile.TemporaryDirectory() as profile_dir:
        with jax.profiler.trace(profile_dir):
            start = time.perf_counter()
            compiled = lowered.compile()
            compile_s = time.perf_counter() - start
        split = phases(profile_dir)
    by_piece = pieces(compiled.as_text())
    row = dict(case=args.case, transform=args.transform, t1_s=t1, compile_s=round(compile_s, 2),
               phases_s={k: round(v, 2) if isinstance(v, float) else v for k, v in split.items()},
               hlo_instructions=sum(by_piece.values()), by_piece=by_piece)
    print(f"{args.case} {args.transform}: XLA compile {compile_s:.2f} s; "
          + ", ".join(f"{k} {v:.2f} s" if isinstance(v, float) else f"{k} {v}" for k, v in split.items()))
    print(f"optimized HLO: {row['hlo_instructions']} instructions")
    for name, count in by_piece.items():
        print(f"  {count:6d}  {100 * count / row['hlo_instructions']:4.1f} %  {name}")
    if args.json:
        with open(args.json, "a") as f:
            f.write(json.dumps(row) + "\n")


if __name__ == "__main__":
    main()

"""The performance figures of jaxbearing and the targets of issue 44, measured in one run on this
machine.

    python benchmarks/run.py [--repeats 5] [--json benchmarks/results.json] [--quick]
                             [--only single,outputs,gradient,scipy,sweep,mainjob,compile] [--pairs 3]
                             [--processes 3]
    python benchmarks/run.py --only gpu [--gpu-parts single,gradient,sweep,variants]
                             [--gpu-batches 256,1024,4096,16384,65536] [--reference-file F]

Every CPU item runs jaxbearing as it comes: nothing is called or set beyond importing it, which
makes the library's process-wide settings (`jaxbearing._process`: its XLA flag,
`LOOP_KERNELS_FLAG`, and JAX's persistent compilation cache). Each item's process gets a cache
folder of its own, empty (``JAX_COMPILATION_CACHE_DIR``), so that its compiles start cold, as a
first run on a machine does, cache writes included. What it measures, on the paper's case with
impact (0-0.2 s, 2001 output times):

- one simulation after compilation (fastest of ``--repeats``) for each solver row of `SOLVERS`:
  the default (Tsit5), Dopri5 and Kvaerno5, with steps taken and rejected, and Kvaerno5 with
  the smooth ball force (the model for gradients); and one Tsit5 row in a process started with
  ``JAXBEARING_KEEP_XLA_FLAGS=1`` ("Tsit5, XLA defaults": XLA's defaults, without the library's
  flag), for what that process-wide flag buys. A process-level setting stays only if it makes
  the main path at least `FLAG_GAIN` times faster;
- the first call of the default row: cold (``first_call_cold_s``: trace, compile and one run in a
  fresh process, which writes its compiles to its empty cache folder as the library's cache
  settings have it), and in a second fresh process given the same folder
  (``first_call_cached_s``: served from the cache); for each, where the time goes by JAX's
  monitoring events (`jax.monitoring`: tracing, lowering to MLIR, backend compile or cache
  retrieval) and the cache's hits and writes;
- the cost of 200 001 output times against 2001;
- compile time of a forward run and of a 3-parameter forward-mode gradient (`jb.sensitivity`: one
  tangent at a time), and the cost of that gradient (clearance, restitution, ball stiffness;
  smooth peak ball load) relative to one forward run of the same model and metric, for the paper
  and the smooth ball force; and the same gradient by `jax.jacfwd` (3 tangents at once);
- the SciPy baseline (`benchmarks/scipy_baseline.py`: the same equations in NumPy, `solve_ivp`
  with exact contact events) for LSODA, BDF, Radau and RK45; the speed target compares RK45 with
  the default row;
- sweep throughput [simulations/s] of `jaxbearing.sweep` over an 8 x 8 grid of clearance and
  restitution on 1 and on 2 CPU devices, and on 2 with 2001 output samples, whose members then
  run as `simulate`, not as one loop (`SWEEP_ROWS`; the dataset's ``solve`` says which ran), with
  the sweep's default output times (the standard metrics need none but [t0, t1]);
- peak memory (maximum resident set size) of each measurement;
- the main job (group ``mainjob``, `MAIN_JOB`: README's first command, ``jaxbearing xu2014``,
  with both cases, figures and files), ``--pairs`` times run from an empty cache and then again
  from the cache it filled, each a fresh process as a user's (wall from start to exit), and the
  ratio of each pair and their median (a figure, not a target: results.json's ``main_job``).
- where compile goes (group ``compile``, issue 65): first calls in fresh processes with the
  persistent cache off (``JAXBEARING_NO_COMPILATION_CACHE=1``), the median of ``--processes``, beside a reference that moves with the machine
  the way compiles do, measured in the same run: diffrax's own Tsit5 + `diffrax.PIDController`
  solve of the Lorenz system, first call and first `jax.grad` (`_lorenz`). Per transform of
  the paper's case, the rotor in the paper's bearing and the four-bar (`COMPILE_ROWS`): the
  forward run, `jax.grad` and `jax.jacfwd` of the RMS bearing force in the clearance,
  `jaxbearing.sensitivity` and `jax.vmap`, each as ``jax.jit(f).trace(...)``, ``.lower()``,
  ``.compile()`` and the first run, timed, with the StableHLO's lines and operations; building
  and assembling `jaxbearing.cases.four_bar` (its wall and, by JAX's monitoring events, its
  tracing, lowering and compiles). Per piece of the solve, the paper's forward run with the
  piece absent (`COMPILE_VARIANTS`: no impact contacts, so no events and no root finder; the
  smooth ball force, so no ball switches; no fatigue records; two output times; all four). The
  derivatives run over `GRADIENT_SPAN`, the forward runs over ``--t1``. Each first call's ratio
  to the reference's (the first `jax.grad` for derivatives) is what compares across machines
  and loads.

The targets (`_targets`, each with its figure and whether it is met): the default path at least
30x faster than SciPy's RK45; issue 65's (`_compile_targets`): the paper's first `simulate`
within 5x the reference's first call, its first `jax.grad` within half of the ratio to the
reference's first `jax.grad` measured before that work (`TODAY_GRAD_RATIO`) and within 5x its
own first `simulate`, `jaxbearing.cases.four_bar()` within 1x the reference's first call; the second
process's first call served from the persistent cache (the solve written by the first process
and read by the second, and the first call under half the cold one); Kvaerno5 within 2.5 s; the
gradient within 5x a forward run; at least 25 sweep simulations/s on 2 CPU devices; the loop
flag worth at least `FLAG_GAIN`; on a GPU, at least 2500 sweep simulations/s; jaxbearing/solve/
within 1600 lines and `simulate` within 10 parameters (counted). A target not met carries what
stands in its way (`IN_THE_WAY`).

The group ``gpu`` (run alone, ``--only gpu``; results in ``results_gpu.json`` with the device's
name) measures on JAX's default accelerator: one simulation and the 3-parameter gradient, each
with XLA's defaults and one run with CUDA-graph loops (`COMMAND_BUFFERS`); sweep throughput of
one chunk of all points against batch size (`GPU_BATCHES`, members with the sweep's default
output times, [t0, t1]: the metrics are exact without samples) with the device memory per member;
at 4096 points the same sweep with 2001 output times and with CUDA-graph loops. Sweeps above
``--gpu-repeat-max`` points are timed on their first call (compile included), the others on a
second call. The reference runs stay on the CPU. Every row carries the same accuracy checks as on
the CPU.

Accuracy: every timed run is compared with a reference run of the default solver at
tolerances 1000x tighter (rtol 1e-11, atol 1e-13): positions (x, y of every body) within 1e-7 m at
all output times, ball loads within 0.5 N at the Table-5 times, and every contact onset found.
A sweep member's peak ball load and peak bearing force are compared with those of a reference run
at its point (within 1e-3 relative), the gradient's forward run like a single run. A row that fails
its check is marked.

Each measurement runs in a fresh Python process (``--item``) with an empty cache folder, so that
compile times start cold, peak memory is its own and the device count can differ; the parent
prints the table and writes the JSON.
``--quick`` (0.06 s, 1 repeat, a 2 x 2 sweep, RK45 only, the default and XLA-defaults rows only,
one pair of main jobs, `QUICK_COMPILE_ROWS` only, one process each unless ``--processes`` says)
checks that the command works.
"""

from __future__ import annotations

import argparse
import inspect
import json
import os
import platform
import resource
import subprocess
import sys
import tempfile
import time
import types
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
T1 = 0.2
N_TS = 2001
DENSE_TS = 200_001  # output every microsecond over 0.2 s, as `jaxbearing xu2014` does
RTOL, ATOL = 1e-8, 1e-10  # simulate's defaults
REFERENCE_FACTOR = 1e-3  # reference tolerances relative to the timed ones
POSITION_TOLERANCE = 1e-7  # [m]
LOAD_TOLERANCE = 0.5  # [N]
POSITIONS = [0, 1, 3, 4, 6, 7, 9, 10]  # x, y of every body
SOLVERS = (  # (row label, solver name, ball force, XLA's defaults: JAXBEARING_KEEP_XLA_FLAGS=1)
    ("default (Tsit5)", "default", "paper", False),
    ("Dopri5", "dopri5", "paper", False),
    ("Kvaerno5", "kvaerno5", "paper", False),
    ("Kvaerno5, smooth force", "kvaerno5", "smooth", False),
    ("Tsit5, XLA defaults", "default", "paper", True),
)
XLA_DEFAULTS_LABEL = SOLVERS[-1][0]
FLAG_GAIN = 1.5  # a process-level setting must make the main path this many times faster
CACHED_FRACTION = 0.5  # a first call served from the persistent cache: under this share of the cold one
MAIN_JOB = ("-m", "jaxbearing.cli", "xu2014")  # README's first command, `jaxbearing xu2014`
CACHED_KEYS = ("wall_s", "first_call_s", "compile_s", "first_call", "accurate", "peak_memory_MiB")
SCIPY_METHODS = ("LSODA", "BDF", "Radau", "RK45")
SCIPY_MAX_WALL = 300.0  # [s] cap per SciPy run
GRADIENT_NAMES = ("bearing.clearance", "impact.restitution", "bearing.stiffness")
GRADIENT_FORCES = ("paper", "smooth")  # both give exact derivatives (docs/model.md)
SWEEP_CLEARANCES = (20e-6, 80e-6)  # [m] range of the sweep grid
SWEEP_RESTITUTIONS = (0.5, 0.95)
SWEEP_CORNER = {"bearing.clearance": SWEEP_CLEARANCES[1], "impact.restitution": SWEEP_RESTITUTIONS[1]}
SWEEP_CHECKED = ("peak_ball_load", "peak_bearing_force")  # metrics checked at the grid's corner
SWEEP_ROWS = ((1, 0), (2, 0), (2, N_TS))  # CPU sweeps: (devices, output times; 0: the sweep's default)
GPU_BATCHES = (256, 1024, 4096, 16_384, 65_536)  # sweep points in one chunk on one GPU
GPU_SWEEP_TS = 0  # output times of a GPU sweep member: the sweep's default ([t0, t1] for exact metrics)
COMMAND_BUFFERS = "--xla_gpu_enable_command_buffer=+WHILE,+CONDITIONAL"  # CUDA graphs for loops
COMPILE_CASES = {  # the compile group's mechanisms (keyword arguments: a variant's, the paper's only)
    "paper": lambda **kw: _jb().cases.xu2014(**{"impact": True, **kw}),
    "rotor": lambda: _jb().cases.rotor(_jb().cases.skf98205()),
    "four_bar": lambda: _jb().cases.four_bar(),
}
COMPILE_VARIANTS = {  # the paper's case with a piece of the solve absent
    "": {},
    "no contacts": {"case": {"impact": False}},  # no impact events, no root finder
    "smooth balls": {"case": {"ball_force": "smooth"}},  # no ball switches
    "no fatigue": {"no_fatigue": True},  # SolveOptions(fatigue=False): fewer records
    "two outputs": {"two_outputs": True},  # output times [0, t1]: little output evaluation
    "bare": {"case": {"impact": False, "ball_force": "smooth"}, "no_fatigue": True, "two_outputs": True},
}
COMPILE_ROWS = (  # (case, transform, variant); the reference's two first, then the targets' rows
    ("lorenz", "simulate", ""), ("lorenz", "grad", ""),
    ("paper", "simulate", ""), ("four_bar", "build", ""), ("paper", "grad", ""),
    ("paper", "jacfwd", ""), ("paper", "sensitivity", ""), ("paper", "vmap", ""),
    *(("paper", "simulate", variant) for variant in list(COMPILE_VARIANTS)[1:]),
    ("paper", "grad", "bare"),
    ("rotor", "simulate", ""), ("rotor", "grad", ""), ("rotor", "jacfwd", ""),
    ("four_bar", "simulate", ""), ("four_bar", "grad", ""),
)
QUICK_COMPILE_ROWS = COMPILE_ROWS[:5] + (("paper", "simulate", "bare"),)
GRADIENT_SPAN = 0.05  # [s] the derivative rows' span (issue 65's); the forward rows run over --t1
TODAY_GRAD_RATIO = 80.7 / 3.1  # issue 65: the paper's first jax.grad / the reference's, before the work
GRAD_TARGET = f"paper's first jax.grad <= {TODAY_GRAD_RATIO / 2:.0f}x the reference's (half of issue 65's)"


# -- the child processes ----------------------------------------------------------------------


def _jax():
    import jax

    jax.config.update("jax_enable_x64", True)
    import jaxbearing as jb

    return jax, jb


def _solver(name):
    import diffrax

    _, jb = _jax()
    return {"default": None, "tsit5": diffrax.Tsit5(), "dopri5": diffrax.Dopri5(), "kvaerno5": jb.kvaerno5()}[name]


def _machine() -> dict:
    return dict(cpus=os.cpu_count(), cpu_model=_cpu_model(), load_average=os.getloadavg())


def _calibrator() -> float:
    """Wall [s] of ``sum(range(10**8))``: the machine's speed of the moment, which issue 45's
    targets name."""
    start = time.perf_counter()
    sum(range(10**8))
    return time.perf_counter() - start


def _cpu_model() -> str:
    """The CPU's model name (/proc/cpuinfo, else `platform.processor`): results that call
    LAPACK (Kvaerno5's Newton iteration) may round, and so step, differently on another CPU."""
    try:
        with open("/proc/cpuinfo") as f:
            names = [line.split(":", 1)[1].strip() for line in f if line.startswith("model name")]
    except OSError:
        names = []
    return names[0] if names else platform.processor()


def _versions() -> dict:
    """The versions the figures depend on: `jaxbearing.provenance.versions` and SciPy's (the
    baseline)."""
    from importlib import metadata

    from jaxbearing import provenance

    return dict(provenance.versions(), scipy=metadata.version("scipy"))


def _device_kind():
    jax, _ = _jax()
    return jax.devices()[0].device_kind


def _timed(fn):
    jax, _ = _jax()
    start = time.perf_counter()
    out = jax.block_until_ready(fn())
    return out, time.perf_counter() - start


def _min_wall(fn, repeats):
    """The fastest of ``repeats`` calls: on this 2-core machine some calls run at half speed
    (twice the wall of the others, as if sharing a core), which a median can land on."""
    return min(_timed(fn)[1] for _ in range(repeats))


def _ts(t1):
    return np.linspace(0.0, t1, N_TS)


def _reference(args):
    """Reference runs (paper and smooth ball force) at 1000x tighter tolerances, saved to npz."""
    _, jb = _jax()
    tight = jb.default_controller(rtol=RTOL * REFERENCE_FACTOR, atol=ATOL * REFERENCE_FACTOR)
    out = {}
    for force in ("paper", "smooth"):
        model = jb.cases.xu2014(impact=True, ball_force=force)
        sol = jb.simulate(model, args.t1, _ts(args.t1), stepsize_controller=tight, max_steps=2_000_000)
        out[f"{force}_q"] = np.asarray(sol.q)
        out[f"{force}_ball_loads"] = np.asarray(sol.ball_loads)
        out[f"{force}_onsets"] = np.asarray(sol.contacts.time)[np.asarray(sol.contacts.valid)]
        out[f"{force}_steps"] = int(sol.num_steps)
    corner = jb.simulate(
        jb.paths.replace(jb.cases.xu2014(impact=True), SWEEP_CORNER), args.t1, _ts(args.t1),
        stepsize_controller=tight, max_steps=2_000_000,
    )
    for name in SWEEP_CHECKED:
        out[f"corner_{name}"] = float(jb.metrics.STANDARD[name](corner))
    np.savez(args.reference, **out)
    return {"steps": {f: int(out[f"{f}_steps"]) for f in ("paper", "smooth")}}


def _load_reference(path, force):
    data = np.load(path)
    onsets = data[f"{force}_onsets"]
    return types.SimpleNamespace(
        q=data[f"{force}_q"],
        ball_loads=data[f"{force}_ball_loads"],
        contacts=types.SimpleNamespace(time=onsets, valid=np.ones(onsets.shape, bool)),
    )


def _table5_index(t1):
    _, jb = _jax()
    times = jb.cases.TABLE5_TIMES[jb.cases.TABLE5_TIMES <= t1]
    return np.searchsorted(_ts(t1), times)


def _accuracy(q, ball_loads, onsets, reference, t1) -> dict:
    idx = _table5_index(t1)
    ref_onsets = reference.contacts.time
    position = float(np.max(np.abs(np.asarray(q)[:, POSITIONS] - reference.q[:, POSITIONS])))
    load = float(np.max(np.abs(np.asarray(ball_loads)[idx] - reference.ball_loads[idx]), initial=0.0))
    found = len(onsets) == len(ref_onsets)
    return dict(
        position_error_m=position,
        ball_load_error_N=load,
        onsets=len(onsets),
        accurate=bool(position <= POSITION_TOLERANCE and load <= LOAD_TOLERANCE and found),
    )


def _onsets(sol):
    return np.asarray(sol.contacts.time)[np.asarray(sol.contacts.valid)]


class _FirstCall:
    """Where the time of the calls inside its ``with`` block goes, from JAX's monitoring events
    (`jax.monitoring`): tracing to jaxprs, lowering to MLIR and the backend's compile (or, on a
    persistent-cache hit, its retrieval), each the length of the union of its events' time spans
    (nested jits' spans lie within their caller's); the largest backend compile and the function
    it compiled; and the persistent compilation cache's hits, writes (JAX's ``cache_misses``
    event: an entry written) and retrieval time."""

    PHASES = {
        "trace_s": "/jax/core/compile/jaxpr_trace_duration",
        "lower_s": "/jax/core/compile/jaxpr_to_mlir_module_duration",
        "backend_compile_s": "/jax/core/compile/backend_compile_duration",
    }
    COUNTS = {
        "cache_hits": "/jax/compilation_cache/cache_hits",
        "cache_writes": "/jax/compilation_cache/cache_misses",  # recorded as an entry is written
    }
    RETRIEVAL = "/jax/compilation_cache/cache_retrieval_time_sec"

    def __enter__(self):
        import jax.monitoring as monitoring

        self.spans = {event: [] for event in self.PHASES.values()}
        self.counts = {event: 0 for event in self.COUNTS.values()}
        self.compiles, self.retrieval = [], 0.0
        monitoring.register_event_time_span_listener(self._span)
        monitoring.register_event_listener(self._event)
        monitoring.register_event_duration_secs_listener(self._duration)
        return self

    def __exit__(self, *exc):
        import jax.monitoring as monitoring

        monitoring.unregister_event_time_span_listener(self._span)
        monitoring.unregister_event_listener(self._event)
        monitoring.unregister_event_duration_listener(self._duration)

    def _span(self, event, start, end, **kwargs):
        if event in self.spans:
            self.spans[event].append((start, end))
        if event == self.PHASES["backend_compile_s"]:
            self.compiles.append((end - start, str(kwargs.get("fun_name", ""))))

    def _event(self, event, **kwargs):
        if event in self.counts:
            self.counts[event] += 1

    def _duration(self, event, duration, **kwargs):
        if event == self.RETRIEVAL:
            self.retrieval += duration

    @staticmethod
    def _union(spans):
        total, end = 0.0, -np.inf
        for a, b in sorted(spans):
            if b > end:
                total += b - max(a, end)
                end = b
        return total

    def row(self) -> dict:
        row = {name: self._union(self.spans[event]) for name, event in self.PHASES.items()}
        largest = max(self.compiles, default=(0.0, ""))
        row.update(largest_compile_s=largest[0], largest_compile=largest[1], compiles=len(self.compiles))
        row.update({name: self.counts[event] for name, event in self.COUNTS.items()})
        row["cache_retrieval_s"] = self.retrieval
        return row


def _single(args):
    """One simulation per call: the first call (trace, compile and run; where its time goes:
    `_FirstCall`), the fastest wall after it, steps, accuracy."""
    _, jb = _jax()
    model = jb.cases.xu2014(impact=True, ball_force=args.force)
    solver = _solver(args.solver)
    ts = _ts(args.t1)

    def run():
        return jb.simulate(model, args.t1, ts, solver=solver)

    with _FirstCall() as first_call:
        sol, first = _timed(run)
    wall = _min_wall(run, args.repeats)
    row = dict(
        device_kind=_device_kind(),
        wall_s=wall,
        first_call_s=first,
        compile_s=first - wall,
        first_call=first_call.row(),
        steps=int(sol.num_steps),
        rejected=int(sol.num_rejected_steps),
    )
    row.update(_accuracy(sol.q, sol.ball_loads, _onsets(sol), _load_reference(args.reference, args.force), args.t1))
    return row


def _gradient(args):
    """Compile and run times of a forward run and of its 3-parameter forward-mode gradient:
    `jaxbearing.sensitivity` (one tangent at a time), and `jax.jacfwd` (a batch of 3 tangents)."""
    import diffrax
    import equinox as eqx

    jax, jb = _jax()
    model = jb.cases.xu2014(impact=True, ball_force=args.force)
    ts = _ts(args.t1)
    names = list(GRADIENT_NAMES)
    x0 = jax.numpy.stack([jb.paths.get(model, n) for n in names])

    def metric(x, adjoint):
        sol = jb.simulate(jb.paths.replace(model, dict(zip(names, x))), args.t1, ts, adjoint=adjoint)
        return jb.metrics.smooth_peak_ball_load(sol), sol

    forward = eqx.filter_jit(lambda x: metric(x, diffrax.RecursiveCheckpointAdjoint()))
    jacfwd = eqx.filter_jit(jax.jacfwd(lambda x: metric(x, diffrax.ForwardMode())[0]))

    def gradient(x):  # at the forward run's tolerances: the ratio compares equal work per step
        m = jb.paths.replace(model, dict(zip(names, x)))
        _, grads = jb.sensitivity(m, jb.metrics.smooth_peak_ball_load, names, args.t1, ts,
                                  stepsize_controller=jb.default_controller())
        return jax.numpy.stack([grads[n] for n in names])

    (value, sol), first_f = _timed(lambda: forward(x0))
    wall_f = _min_wall(lambda: forward(x0), args.repeats)
    grad, first_g = _timed(lambda: gradient(x0))
    wall_g = _min_wall(lambda: gradient(x0), args.repeats)
    batched, first_j = _timed(lambda: jacfwd(x0))
    wall_j = _min_wall(lambda: jacfwd(x0), args.repeats)
    row = dict(
        device_kind=_device_kind(),
        forward_s=wall_f,
        gradient_s=wall_g,
        ratio=wall_g / wall_f,
        compile_forward_s=first_f - wall_f,
        compile_gradient_s=first_g - wall_g,
        jacfwd_s=wall_j,
        jacfwd_ratio=wall_j / wall_f,
        compile_jacfwd_s=first_j - wall_j,
        jacfwd_gradient={n: float(g) for n, g in zip(names, batched)},
        value_N=float(value),
        gradient={n: float(g) for n, g in zip(names, grad)},
        finite=bool(np.all(np.isfinite(np.asarray(grad)))),
    )
    row.update(_accuracy(sol.q, sol.ball_loads, _onsets(sol), _load_reference(args.reference, args.force), args.t1))
    row["accurate"] = row["accurate"] and row["finite"]
    return row


def _sweep(args):
    """Throughput of jb.sweep over an n x n grid, one chunk of ``chunk_size`` points per device:
    a first call (compile + run), then, unless ``--once``, a timed second call; the member at the
    grid's corner checked against the reference run there."""
    jax, jb = _jax()
    from jaxbearing._sweep import default_chunk_size

    model = jb.cases.xu2014(impact=True)
    grid = {
        "bearing.clearance": np.linspace(*SWEEP_CLEARANCES, args.sweep_n),
        "impact.restitution": np.linspace(*SWEEP_RESTITUTIONS, args.sweep_n),
    }
    ts = np.linspace(0.0, args.t1, args.sweep_ts) if args.sweep_ts else None  # None: the sweep's default
    kwargs = dict(t1=args.t1, ts=ts, progress=False, chunk_size=args.chunk_size or None)
    start = time.perf_counter()
    ds = jb.sweep(model, grid, **kwargs)
    first = time.perf_counter() - start
    wall = None
    if not args.once:
        start = time.perf_counter()
        ds = jb.sweep(model, grid, **kwargs)
        wall = time.perf_counter() - start
    # 1e-3 relative: at the corner the default tolerances' own error in these peaks is 2.6e-4,
    # and a batch takes other steps than a single run (3e-4 apart)
    reference = np.load(args.reference)
    errors = {
        name: abs(float(ds[name].sel(SWEEP_CORNER)) / float(reference[f"corner_{name}"]) - 1.0)
        for name in SWEEP_CHECKED
    }
    points = args.sweep_n**2
    device = jax.devices()[0]
    stats = device.memory_stats() or {}
    row = dict(
        devices=jax.device_count(),
        device_kind=device.device_kind,
        points=int(points),
        output_times=int(ds.attrs["ts"].size),
        chunk_size=args.chunk_size or default_chunk_size(solve=ds.attrs["solve"]),
        wall_s=wall,
        first_call_s=first,
        throughput=None if wall is None else points / wall,
        failed=int(ds.failed.sum()),
        solve=ds.attrs["solve"],
        relative_error=errors,
        accurate=bool(max(errors.values()) <= 1e-3 and int(ds.failed.sum()) == 0),
    )
    if "peak_bytes_in_use" in stats:
        row["device_peak_MiB"] = stats["peak_bytes_in_use"] / 2**20
        row["device_MiB_per_member"] = row["device_peak_MiB"] / points
    return row


def _outputs(args):
    """Cost of dense output: one run with N_TS and one with DENSE_TS output times, interleaved,
    the minimum of 2 ``repeats`` each (a ratio of two minima scatters more than either wall);
    the dense run's positions checked like a single run's."""
    _, jb = _jax()
    model = jb.cases.xu2014(impact=True)
    runs = {n: (lambda n=n: jb.simulate(model, args.t1, np.linspace(0.0, args.t1, n))) for n in (N_TS, DENSE_TS)}
    first = {n: _timed(run)[1] for n, run in runs.items()}
    walls = {n: [] for n in runs}
    for _ in range(2 * args.repeats):
        for n, run in runs.items():
            walls[n].append(_timed(run)[1])
    sol = runs[DENSE_TS]()
    every = (DENSE_TS - 1) // (N_TS - 1)
    row = dict(
        output_times=[N_TS, DENSE_TS],
        wall_s=[min(walls[n]) for n in runs],
        compile_s=[first[n] - min(walls[n]) for n in runs],
        ratio=min(walls[DENSE_TS]) / min(walls[N_TS]),
    )
    row.update(
        _accuracy(sol.q[::every], sol.ball_loads[::every], _onsets(sol), _load_reference(args.reference, "paper"), args.t1)
    )
    return row


def _scipy(args):
    """The SciPy baseline with one method, checked against the reference."""
    sys.path.insert(0, str(HERE))
    import scipy_baseline

    ts = _ts(args.t1)
    reference = _load_reference(args.reference, "paper")
    try:
        run = scipy_baseline.simulate(args.t1, ts, method=args.method, rtol=RTOL, atol=ATOL, max_wall=args.max_wall)
    except scipy_baseline.BaselineTimeout as error:
        return dict(method=args.method, wall_s=None, timeout=str(error), accurate=False)
    row = dict(method=args.method, wall_s=run["wall_s"], steps=run["steps"], rhs_calls=run["rhs_calls"])
    row.update(_accuracy(run["q"], run["ball_loads"], run["onset_times"], reference, args.t1))
    return row


def _compile(args):
    """One first call of ``--transform`` on ``--case`` (``--variant``: the paper's case with a
    piece of the solve absent, `COMPILE_VARIANTS`), in this fresh process with the persistent
    cache off: ``jax.jit(f).trace``, ``.lower()``, ``.compile()`` and the first run, each timed,
    the StableHLO's lines and operations; for the transforms that are not one jitted function
    (``build``: constructing the case, ``sensitivity``) the first call's wall, split by JAX's
    monitoring events (`_FirstCall`)."""
    jax, jb = _jax()
    if args.case == "lorenz":
        fn, x = _lorenz(args.transform)
    elif args.transform == "build":
        with _FirstCall() as first_call:
            start = time.perf_counter()
            jax.block_until_ready(COMPILE_CASES[args.case]().q0)
            wall = time.perf_counter() - start
        return dict(first_call_s=wall, first_call=first_call.row())
    else:
        fn, x = _compile_function(args)
    if fn is None:  # jb.sensitivity: the user's call, not one function of ours to jit
        model = COMPILE_CASES[args.case]()
        with _FirstCall() as first_call:
            start = time.perf_counter()
            jax.block_until_ready(jb.sensitivity(model, jb.metrics.rms_bearing_force, ["bearing.clearance"],
                                                 args.t1, _ts(args.t1)))
            wall = time.perf_counter() - start
        return dict(first_call_s=wall, first_call=first_call.row())
    times = {}
    start = time.perf_counter()
    traced = jax.jit(fn).trace(x)
    times["trace_s"] = time.perf_counter() - start
    lowered = traced.lower()
    times["lower_s"] = time.perf_counter() - start - times["trace_s"]
    compiled = lowered.compile()
    times["compile_s"] = time.perf_counter() - start - times["trace_s"] - times["lower_s"]
    out = jax.block_until_ready(compiled(x))
    times["first_call_s"] = time.perf_counter() - start
    times["run_s"] = times["first_call_s"] - times["trace_s"] - times["lower_s"] - times["compile_s"]
    text = lowered.as_text()
    leaves = [np.asarray(leaf) for leaf in jax.tree_util.tree_leaves(out)]
    return dict(
        times,
        hlo_lines=len(text.splitlines()),
        hlo_ops=sum(1 for line in text.splitlines() if _HLO_OP.search(line)),
        finite=bool(all(np.all(np.isfinite(leaf)) for leaf in leaves if leaf.dtype.kind == "f")),
    )


_HLO_OP = __import__("re").compile(r"\b(stablehlo|chlo|mhlo|func|sdy)\.[a-z_]+")


def _compile_function(args):
    """The function of the clearance [m] that ``--transform`` makes of ``--case``'s run over
    ``--t1`` (rtol and atol simulate's defaults, `N_TS` output times unless the variant drops
    them), and the clearance: the forward run (``simulate``), `jax.grad` and `jax.jacfwd` of the
    RMS bearing force, and `jax.vmap` of it over two clearances."""
    import diffrax

    jax, jb = _jax()
    variant = COMPILE_VARIANTS[args.variant]
    model = COMPILE_CASES[args.case](**variant.get("case", {}))
    ts = np.array([0.0, args.t1]) if variant.get("two_outputs") else _ts(args.t1)
    options = jb.SolveOptions(fatigue=False) if variant.get("no_fatigue") else None
    adjoint = diffrax.ForwardMode() if args.transform == "jacfwd" else None
    x = jb.paths.get(model, "bearing.clearance")

    def run(c):
        moved = jb.paths.replace(model, {"bearing.clearance": c})
        return jb.simulate(moved, args.t1, ts, adjoint=adjoint, throw=False, options=options)

    def rms(c):
        return jb.metrics.rms_bearing_force(run(c))

    if args.transform == "sensitivity":
        return None, x
    transforms = {"simulate": run, "grad": jax.grad(rms), "jacfwd": jax.jacfwd(rms), "vmap": jax.vmap(rms)}
    return transforms[args.transform], (jax.numpy.stack([x, 1.1 * x]) if args.transform == "vmap" else x)


def _lorenz(transform):
    """The reference of issue 65: diffrax's own Tsit5 + `diffrax.PIDController` solve of the
    Lorenz system (sigma 10, rho 28, beta 8/3, from (1, 1, 1) over 0-1, rtol = atol = 1e-8), as
    a function of rho: the final state (``simulate``), or `jax.grad` of its sum."""
    import diffrax

    jax, _ = _jax()
    jnp = jax.numpy

    def lorenz(t, y, rho):
        return jnp.stack([10.0 * (y[1] - y[0]), y[0] * (rho - y[2]) - y[1], y[0] * y[1] - 8.0 / 3.0 * y[2]])

    def solve(rho):
        sol = diffrax.diffeqsolve(
            diffrax.ODETerm(lorenz), diffrax.Tsit5(), 0.0, 1.0, 0.01, jnp.ones(3), args=rho,
            stepsize_controller=diffrax.PIDController(rtol=1e-8, atol=1e-8),
        )
        return sol.ys[-1]

    fn = solve if transform == "simulate" else jax.grad(lambda rho: jnp.sum(solve(rho)))
    return fn, jnp.asarray(28.0)


GROUPS = ("single", "outputs", "gradient", "scipy", "sweep", "mainjob", "compile", "gpu")
CPU_GROUPS = GROUPS[:-1]  # the default; "gpu" runs alone (--only gpu) into results_gpu.json
OWN_SPAN = {"mainjob", "compile"}  # groups that record their span and time in their own entry
GPU_PARTS = ("single", "gradient", "sweep", "variants")
ITEMS = {
    "reference": _reference,
    "single": _single,
    "outputs": _outputs,
    "gradient": _gradient,
    "sweep": _sweep,
    "scipy": _scipy,
    "compile": _compile,
}


# -- the parent -------------------------------------------------------------------------------


def _child(item, settings, devices=1, platform="cpu", xla_flags="", xla_defaults=False, cache_dir=None,
           no_cache=False, **options):
    """Run one item in a fresh process on ``platform`` ("cpu" with ``devices`` devices, or
    "gpu": JAX's default accelerator); its JSON result with the peak memory [MiB]. The child
    imports jaxbearing as it comes (its process-wide settings, `jaxbearing._process`), except,
    with ``xla_defaults``, ``JAXBEARING_KEEP_XLA_FLAGS=1`` (XLA's defaults). Its persistent
    compilation cache is in ``cache_dir``, else in an empty folder of its own; with ``no_cache``
    it has none (``JAXBEARING_NO_COMPILATION_CACHE=1``: neither JAX's cache nor the stored
    solves)."""
    from jaxbearing._process import CACHE_OPT_OUT, OPT_OUT

    cmd = [sys.executable, str(Path(__file__).resolve()), "--item", item]
    for key, value in {**settings, **options}.items():
        if value is True:
            cmd.append(f"--{key.replace('_', '-')}")
        elif value is not False:
            cmd += [f"--{key.replace('_', '-')}", str(value)]
    env = _fresh_env()
    if xla_defaults:
        env[OPT_OUT] = "1"
    own_cache = None if cache_dir or no_cache else tempfile.TemporaryDirectory()
    if no_cache:
        env[CACHE_OPT_OUT] = "1"
        env.pop("JAX_COMPILATION_CACHE_DIR", None)
    else:
        env["JAX_COMPILATION_CACHE_DIR"] = cache_dir or own_cache.name
    if platform == "cpu":
        xla_flags += f" --xla_force_host_platform_device_count={devices}"
        env.setdefault("JAX_PLATFORMS", "cpu")
    else:
        env.pop("JAX_PLATFORMS", None)
    env["XLA_FLAGS"] = " ".join(env["XLA_FLAGS"].split() + xla_flags.split())
    try:
        done = subprocess.run(cmd, env=env, capture_output=True, text=True)
    finally:
        if own_cache:
            own_cache.cleanup()
    if done.returncode != 0:
        raise RuntimeError(f"benchmark item {item} {options} failed:\n{done.stderr[-4000:]}")
    return json.loads(done.stdout.strip().splitlines()[-1])


def _fresh_env() -> dict:
    """This process's environment for a child that imports jaxbearing as a user's process does:
    without jaxbearing's opt-outs, and without the loop flag this process got by importing it
    (each child's import decides)."""
    from jaxbearing._process import CACHE_OPT_OUT, LOOP_KERNELS_FLAG, OPT_OUT

    env = dict(os.environ)
    env.pop(OPT_OUT, None)
    env.pop(CACHE_OPT_OUT, None)
    env["XLA_FLAGS"] = " ".join(flag for flag in env.get("XLA_FLAGS", "").split() if flag != LOOP_KERNELS_FLAG)
    return env


def _fmt(x, spec):
    return "-" if x is None else format(x, spec)


def _ok(row):
    return "ok" if row.get("accurate") else "INACCURATE"


def measure(args, results) -> dict:
    """Run the groups in ``args.only`` into ``results``; print each row as it lands."""
    settings = dict(t1=args.t1, repeats=args.repeats, reference=args.reference)
    if not results or set(args.only) >= set(CPU_GROUPS):  # a partial run keeps the whole run's
        results.update(machine=_machine(), versions=_versions())
    if set(args.only) - OWN_SPAN:  # the other groups share the span and check their runs against it
        results.update(t1_s=args.t1, output_times=N_TS, rtol=RTOL, atol=ATOL)
        print(f"reference runs (rtol {RTOL * REFERENCE_FACTOR:g}) ...", flush=True)
        results["reference"] = _reference_row(args, settings)
    if "single" in args.only:
        _singles(args, settings, results)
    if "outputs" in args.only:
        _outputs_row(settings, results)
    if "gradient" in args.only:
        _gradient_row(settings, results)
    if "scipy" in args.only:
        _scipy_rows(args, settings, results)
    if "sweep" in args.only:
        _sweep_rows(args, settings, results)
    if "mainjob" in args.only:
        _main_job_rows(args, results)
    if "compile" in args.only:
        _compile_rows(args, results)
    if "gpu" in args.only:
        _gpu_rows(args, settings, results)
    return results


def _singles(args, settings, results):
    """The rows of `SOLVERS`; the default row's process writes its persistent compilation cache
    to a folder that a second process then starts from (`_cached_first_call`)."""
    results["single"] = []
    print("\none simulation after compilation")
    with tempfile.TemporaryDirectory() as cache:
        for label, solver, force, xla_defaults in _solver_rows(args.solver_rows):
            default = label == SOLVERS[0][0]
            row = dict(label=label, **_child("single", settings, solver=solver, force=force,
                                              xla_defaults=xla_defaults, cache_dir=cache if default else None))
            results["single"].append(row)
            print(
                f"  {label:24s} {row['wall_s']:7.3f} s  compile {row['compile_s']:5.1f} s  steps {row['steps']:6d} "
                f"({row['rejected']:5d} rejected)  pos {row['position_error_m']:.1e} m  "
                f"load {row['ball_load_error_N']:.3f} N  {row['peak_memory_MiB']:.0f} MiB  {_ok(row)}",
                flush=True,
            )
            if default:
                _cached_first_call(settings, solver, force, cache, row)


def _cached_first_call(settings, solver, force, cache, row):
    """The first call of the default row, cold (its own process, which wrote ``cache``) and in
    a second fresh process that starts from that persistent compilation cache, into ``row``;
    the folder's entries."""
    cached = _child("single", settings, solver=solver, force=force, cache_dir=cache)
    row.update(
        first_call_cold_s=row["first_call_s"],
        first_call_cached_s=cached["first_call_s"],
        cache_entries=len(list(Path(cache).iterdir())),
        cached_process={k: cached[k] for k in CACHED_KEYS},
    )
    for name, r in (("cold", row), ("cached", cached)):
        c = r["first_call"]
        print(
            f"    first call, {name:6s} {r['first_call_s']:6.2f} s: trace {c['trace_s']:.2f} s, "
            f"lower {c['lower_s']:.2f} s, backend compile{' or cache read' if name == 'cached' else ''} "
            f"{c['backend_compile_s']:.2f} s (largest {c['largest_compile_s']:.2f} s, {c['largest_compile']}); "
            f"cache: {c['cache_writes']} written, {c['cache_hits']} hits  {_ok(r)}",
            flush=True,
        )


def _solver_rows(n):
    """The first ``n`` rows of `SOLVERS`, and the XLA-defaults row in any case."""
    rows = SOLVERS[:n]
    return rows if rows[-1][0] == XLA_DEFAULTS_LABEL else rows + SOLVERS[-1:]


def _outputs_row(settings, results):
    print()
    row = _child("outputs", settings)
    results["outputs"] = row
    (n, dense), (wall, dense_wall) = row["output_times"], row["wall_s"]
    print(
        f"output times: {dense} cost {dense_wall:.3f} s = {row['ratio']:.2f} x {n} ({wall:.3f} s); "
        f"{row['peak_memory_MiB']:.0f} MiB  {_ok(row)}",
        flush=True,
    )


def _gradient_row(settings, results):
    results["gradient"] = []
    print("\n3-parameter forward-mode gradient")
    for force in GRADIENT_FORCES:
        row = dict(force=force, **_child("gradient", settings, force=force))
        results["gradient"].append(row)
        print(
            f"  {force:6s} ball force: {row['gradient_s']:.3f} s = {row['ratio']:.2f} x forward "
            f"({row['forward_s']:.3f} s); compile forward {row['compile_forward_s']:.1f} s, gradient "
            f"{row['compile_gradient_s']:.1f} s; {row['peak_memory_MiB']:.0f} MiB  {_ok(row)}\n"
            f"  {'':6s} jax.jacfwd (3 tangents at once): {row['jacfwd_s']:.3f} s = {row['jacfwd_ratio']:.2f} x "
            f"forward; compile {row['compile_jacfwd_s']:.1f} s",
            flush=True,
        )


def _scipy_rows(args, settings, results):
    results["scipy"] = []
    print("\nSciPy baseline (rtol 1e-8, atol 1e-10)")
    for method in args.scipy_methods.split(","):
        row = _child("scipy", settings, method=method, max_wall=args.max_wall)
        results["scipy"].append(row)
        print(
            f"  {method:6s} {_fmt(row['wall_s'], '7.2f')} s  steps {row.get('steps', '-')}  "
            f"pos {_fmt(row.get('position_error_m'), '.1e')} m  load {_fmt(row.get('ball_load_error_N'), '.3f')} N  "
            f"{row['peak_memory_MiB']:.0f} MiB  {_ok(row)}",
            flush=True,
        )


def _reference_row(args, settings):
    """Compute the reference runs into ``args.reference``, unless ``--reference-file`` names one
    that exists (computed before with the same --t1: the GPU group reuses the CPU's)."""
    if args.reference_file and Path(args.reference_file).exists():
        return {"reused": str(args.reference_file)}
    row = _child("reference", settings)
    if args.reference_file:
        Path(args.reference_file).write_bytes(Path(args.reference).read_bytes())
    return row


def _sweep_rows(args, settings, results):
    results["sweep"] = []
    print("\nsweep throughput")
    for devices, n_ts in SWEEP_ROWS:
        row = _child("sweep", settings, devices=devices, sweep_n=args.sweep_n, chunk_size=args.chunk_size,
                     sweep_ts=n_ts)
        results["sweep"].append(row)
        kind = f", {row['output_times']} output times" if n_ts else ""
        kind += f", members as {'one loop' if row['solve'] == 'one_loop' else 'simulate'}"
        print(
            f"  {devices} device(s){kind}: {row['points']} points in {row['wall_s']:.2f} s = {row['throughput']:.2f} "
            f"simulations/s (first call {row['first_call_s']:.1f} s, {row['chunk_size']} per device per chunk)  "
            f"{row['peak_memory_MiB']:.0f} MiB  {_ok(row)}",
            flush=True,
        )


def _gpu_rows(args, settings, results):
    """The GPU group: one run and one gradient on JAX's default accelerator, with and without
    CUDA-graph loops, and sweep throughput against batch size (one chunk of all points)."""
    gpu = results.setdefault("gpu", {})
    parts = args.gpu_parts.split(",")
    flags = {"default": "", "command buffers": COMMAND_BUFFERS}
    if "single" in parts:
        gpu["single"] = []
        print("\nGPU: one simulation after compilation (Tsit5, paper ball force)")
        for label in ("default", "command buffers"):  # the one-loop labels are the sweeps' only
            row = dict(label=label, **_child("single", settings, platform="gpu", xla_flags=flags[label],
                                              solver="default", force="paper"))
            gpu["single"].append(row)
            _save(args, results)
            print(
                f"  {row['device_kind']}, {label:16s} {row['wall_s']:7.3f} s  compile {row['compile_s']:5.1f} s  "
                f"steps {row['steps']}  pos {row['position_error_m']:.1e} m  load {row['ball_load_error_N']:.3f} N  "
                f"{_ok(row)}",
                flush=True,
            )
    if "gradient" in parts:
        row = dict(force="paper", **_child("gradient", settings, platform="gpu", force="paper"))
        gpu["gradient"] = row
        _save(args, results)
        print(
            f"\nGPU: 3-parameter gradient {row['gradient_s']:.3f} s = {row['ratio']:.2f} x forward "
            f"({row['forward_s']:.3f} s); compile {row['compile_forward_s']:.1f} / {row['compile_gradient_s']:.1f} s  "
            f"{_ok(row)}",
            flush=True,
        )
    runs = []
    if "sweep" in parts:
        label = "command buffers" if args.gpu_command_buffers else "default"
        runs += [(batch, GPU_SWEEP_TS, label) for batch in map(int, args.gpu_batches.split(","))]
    if "variants" in parts:  # at 4096 points: dense outputs, and CUDA-graph loops
        runs += [(4096, N_TS, "default"), (4096, GPU_SWEEP_TS, "command buffers")]
    if runs:
        gpu.setdefault("sweep", [])
        print("\nGPU: sweep throughput (one chunk of all points)")
    for batch, n_ts, label in runs:
        n = int(round(batch**0.5))
        row = _child(
            "sweep", settings, platform="gpu", xla_flags=flags[label], sweep_n=n, chunk_size=n * n,
            sweep_ts=n_ts, once=n * n > args.gpu_repeat_max,
        )
        row["label"] = label
        gpu["sweep"].append(row)
        _save(args, results)
        timed = row["wall_s"] if row["wall_s"] is not None else row["first_call_s"]
        print(
            f"  {row['points']:6d} points, {row['output_times']} output times, {label}: {timed:.1f} s "
            f"({'second call' if row['wall_s'] is not None else 'first call, compile included'}) = "
            f"{row['points'] / timed:.0f} simulations/s; {row.get('device_MiB_per_member', 0):.3f} MiB a member "
            f"on the device  {_ok(row)}",
            flush=True,
        )


def _main_job_rows(args, results):
    """`MAIN_JOB` ``args.pairs`` times: from an empty cache folder of its own, then again from
    the cache that run filled, each in a fresh process with the environment a user's shell gives
    it (none of this process's cache settings or opt-outs); the walls and their ratio."""
    print("\nthe main job (jaxbearing xu2014), from an empty cache and then again")
    env = _fresh_env()
    for name in ("JAX_COMPILATION_CACHE_DIR", "JAX_PERSISTENT_CACHE_MIN_COMPILE_TIME_SECS"):
        env.pop(name, None)
    pairs = []
    for _ in range(args.pairs):
        with tempfile.TemporaryDirectory() as home:
            env["XDG_CACHE_HOME"] = home
            cmd = [sys.executable, *MAIN_JOB, "--out", str(Path(home) / "out")]
            if args.t1 != T1:
                cmd += ["--t1", str(args.t1)]
            cold = _wall(cmd, env)
            warm = _wall(cmd, env)
        pairs.append(dict(cold_s=cold, warm_s=warm, ratio=warm / cold))
        print(f"  {cold:6.2f} s, then {warm:6.2f} s: {100 * warm / cold:5.1f} %", flush=True)
    median = float(np.median([p["ratio"] for p in pairs]))
    print(f"  median {100 * median:.1f} % of the first run", flush=True)
    results["main_job"] = dict(
        command="jaxbearing xu2014", t1_s=args.t1, pairs=pairs, median_ratio=median,
        machine=_machine(),  # this group may be measured alone, on another day than the rest
        calibrator_s=_calibrator(),
    )


def _compile_rows(args, results):
    """The compile group: each row of `COMPILE_ROWS` (``--quick``: `QUICK_COMPILE_ROWS`) in
    ``--processes`` fresh processes without a persistent cache, one after another; the median
    of each figure, and the first call's ratio to the reference's (diffrax's Lorenz solve, first
    call and first `jax.grad`), measured in the same run."""
    print("\nfirst calls, fresh processes, no persistent cache (median of "
          f"{args.processes}; ratio: to the reference's first call, or first jax.grad for derivatives)")
    group = results["compile"] = dict(processes=args.processes, t1_s=args.t1,
                                      gradient_t1_s=min(GRADIENT_SPAN, args.t1), rows=[],
                                      machine=_machine(), calibrator_s=_calibrator())
    reference, start = {}, time.perf_counter()
    for case, transform, variant in QUICK_COMPILE_ROWS if args.quick else COMPILE_ROWS:
        t1 = args.t1 if transform in ("simulate", "build") else min(GRADIENT_SPAN, args.t1)
        runs = [
            _child("compile", dict(t1=t1), case=case, transform=transform, variant=variant, no_cache=True)
            for _ in range(args.processes)
        ]
        median = {k: float(np.median([run[k] for run in runs])) for k in runs[0] if k.endswith("_s")}
        median.update({k: runs[0][k] for k in ("hlo_lines", "hlo_ops") if k in runs[0]})
        if case == "lorenz":
            reference[transform] = median["first_call_s"]
        against = "grad" if transform in ("grad", "jacfwd", "sensitivity") else "simulate"
        row = dict(case=case, transform=transform, variant=variant, t1_s=t1, median=median, runs=runs,
                   ratio=median["first_call_s"] / reference[against], ratio_to=f"lorenz {against}")
        group["rows"].append(row)
        _save(args, results)
        phases = [k for k in ("trace_s", "lower_s", "compile_s", "run_s") if k in median]
        split = "  ".join(f"{k[:-2]} {median[k]:5.2f}" for k in phases)
        if "first_call" in runs[0]:
            c = runs[0]["first_call"]
            split = (f"(events: trace {c['trace_s']:.2f}, lower {c['lower_s']:.2f}, backend compile "
                     f"{c['backend_compile_s']:.2f} s in {c['compiles']} programs)")
        size = f"  {median['hlo_lines']:6d} lines {median['hlo_ops']:6d} ops" if "hlo_lines" in median else ""
        label = f"{case} {transform}" + (f" ({variant})" if variant else "")
        print(f"  {label:32s} {median['first_call_s']:7.2f} s = {row['ratio']:5.1f} x  {split}{size}", flush=True)
    group["total_s"] = time.perf_counter() - start


def _wall(cmd, env) -> float:
    """Wall time [s] of ``cmd`` from its start to its exit; a `RuntimeError` if it fails."""
    start = time.perf_counter()
    done = subprocess.run(cmd, env=env, capture_output=True, text=True)
    wall = time.perf_counter() - start
    if done.returncode != 0:
        raise RuntimeError(f"{' '.join(cmd)} failed:\n{done.stderr[-4000:]}")
    return wall


def _save(args, results):
    """Write what is measured so far, atomically (an interrupted run keeps its finished rows)."""
    from jaxbearing import _files

    _files.write_text(args.json, json.dumps(results, indent=2))


def _targets(r) -> dict:
    """Issue 44's targets (of the groups measured), each with the figure and whether it is met."""
    targets = {}
    singles = r.get("single", [])
    default = next((row for row in singles if row["label"] == SOLVERS[0][0]), None)
    xla_defaults = next((row for row in singles if row["label"] == XLA_DEFAULTS_LABEL), None)
    kvaerno = next((row for row in singles if row["label"] == "Kvaerno5"), None)
    rk45 = next((row for row in r.get("scipy", []) if row["method"] == "RK45" and row["wall_s"]), None)
    two = [row for row in r.get("sweep", []) if row["devices"] == 2]
    sweep2 = next((row for row in two if row["output_times"] == 2), None)  # the sweep's default
    if rk45 and default:
        ratio = rk45["wall_s"] / default["wall_s"]
        met = ratio >= 30.0 and rk45["accurate"] and default["accurate"]
        targets[">= 30x faster than SciPy RK45 (default path)"] = (ratio, met)
    targets.update(_compile_targets(r.get("compile")))
    if default and "first_call_cached_s" in default:
        cold, cached = default["first_call"], default["cached_process"]["first_call"]
        served = (  # the solve (the largest compile) written, then read instead of compiled
            cold["cache_writes"] >= 1 and cached["cache_hits"] >= 1
            and cached["largest_compile_s"] < CACHED_FRACTION * cold["largest_compile_s"]
            and default["first_call_cached_s"] < CACHED_FRACTION * default["first_call_cold_s"]
        )
        cached_s = default["first_call_cached_s"]
        targets["2nd process's first call from the persistent cache [s]"] = (cached_s, served)
    if kvaerno:
        targets["Kvaerno5 <= 2.5 s"] = (kvaerno["wall_s"], kvaerno["wall_s"] <= 2.5)
    if r.get("gradient"):
        ratio = max(row["ratio"] for row in r["gradient"])
        targets["3-parameter gradient <= 5x forward"] = (ratio, ratio <= 5.0)
    if sweep2:
        rate = sweep2["throughput"]
        targets[">= 25 simulations/s on 2 CPU devices"] = (rate, rate >= 25.0)
    if default and xla_defaults:
        gain = xla_defaults["wall_s"] / default["wall_s"]
        targets[f"loop flag buys >= {FLAG_GAIN}x (XLA defaults / default)"] = (gain, gain >= FLAG_GAIN)
    gpu_rates = [row["throughput"] for row in r.get("gpu", {}).get("sweep", []) if row["throughput"]]
    if gpu_rates:
        targets[">= 2500 simulations/s on one GPU"] = (max(gpu_rates), max(gpu_rates) >= 2500.0)
    lines = _solve_lines()
    targets["jaxbearing/solve/ <= 1600 lines"] = (lines, lines <= 1600)
    parameters = len(inspect.signature(_jb().simulate).parameters)
    targets["simulate <= 10 parameters"] = (parameters, parameters <= 10)
    return {
        k: dict(measured=v, met=bool(ok), **({} if ok else {"in_the_way": IN_THE_WAY.get(k, "")}))
        for k, (v, ok) in targets.items()
    }


def _compile_targets(group) -> dict:
    """Issue 65's targets, of the compile group's medians: ratios of first calls to the
    reference's measured in the same run (first call, or first `jax.grad` for the paper's)."""
    if not group:
        return {}
    first = {(row["case"], row["transform"], row["variant"]): row["median"]["first_call_s"] for row in group["rows"]}
    ref, ref_grad = first.get(("lorenz", "simulate", "")), first.get(("lorenz", "grad", ""))
    paper, paper_grad = first.get(("paper", "simulate", "")), first.get(("paper", "grad", ""))
    build = first.get(("four_bar", "build", ""))
    targets = {}
    if ref and paper:
        targets["paper's first simulate <= 5x the reference's first call"] = (paper / ref, paper / ref <= 5.0)
    if ref_grad and paper_grad:
        ratio = paper_grad / ref_grad
        targets[GRAD_TARGET] = (ratio, ratio <= TODAY_GRAD_RATIO / 2)
    if paper and paper_grad:
        targets["paper's first jax.grad <= 5x its first simulate"] = (paper_grad / paper, paper_grad / paper <= 5.0)
    if ref and build:
        targets["jb.cases.four_bar() <= 1x the reference's first call"] = (build / ref, build / ref <= 1.0)
    return targets


def _solve_lines() -> int:
    """Lines of the package's solve (jaxbearing/solve/*.py)."""
    return sum(len(p.read_text().splitlines()) for p in (HERE.parent / "jaxbearing" / "solve").glob("*.py"))


def _jb():
    import jaxbearing

    return jaxbearing


# What stands in the way of a target, where it is not met (from profiles of this run's kind).
IN_THE_WAY = {
    "jaxbearing/solve/ <= 1600 lines": (
        "the records of every bearing joint and contact and of the user's own metrics (issue 63, "
        "which lets solve/ grow for them), the constant step and the drift record (issue 64) "
        "added to the core and its drivers; the next step is issue 63's third part, the engine "
        "recording a pytree of record states instead of the application's columns"
    ),
    "paper's first simulate <= 5x the reference's first call": (
        "XLA:CPU's backend compile of the solve is most of it (compile rows: trace_s, lower_s, "
        "compile_s): the loop body inlines the solver's stages of the Eq. 36 right-hand side, the "
        "event function, its root finder's step and the records (the variants' rows give each "
        "piece's share)"
    ),
    GRAD_TARGET: (
        "as for the next: the reverse-mode program's tracing and XLA compile"
    ),
    "paper's first jax.grad <= 5x its first simulate": (
        "tracing the reverse mode: JAX linearises and transposes the solve's lax.conds inside the "
        "checkpointed while loops, and the backward program is several times the forward one"
    ),
    "jb.cases.four_bar() <= 1x the reference's first call": (
        "XLA:CPU compiles the assembly's program (two small Newton loops on the joints' "
        "constraints and their forward-mode Jacobians) and the bearing's stiffness law, each "
        "a fixed cost of a compile"
    ),
}


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--json", default=None, help="default benchmarks/results.json (--quick: results_quick.json)")
    parser.add_argument("--quick", action="store_true", help="a short smoke run of every item")
    parser.add_argument("--t1", type=float, default=T1)
    parser.add_argument("--sweep-n", type=int, default=8, help="grid points per swept parameter")
    parser.add_argument("--chunk-size", type=int, default=0, help="sweep points per device per chunk (0: the sweep's default)")
    parser.add_argument("--scipy-methods", default=",".join(SCIPY_METHODS))
    parser.add_argument("--max-wall", type=float, default=SCIPY_MAX_WALL)
    parser.add_argument("--gpu-parts", default=",".join(GPU_PARTS), help="parts of the gpu group to measure")
    parser.add_argument("--gpu-batches", default=",".join(map(str, GPU_BATCHES)), help="GPU sweep sizes")
    parser.add_argument("--gpu-command-buffers", action="store_true", help="GPU sweeps with CUDA-graph loops")
    parser.add_argument("--gpu-repeat-max", type=int, default=4096,
                        help="GPU sweeps above this many points are timed on their first call only")
    parser.add_argument("--solver-rows", type=int, default=len(SOLVERS))
    parser.add_argument("--pairs", type=int, default=3, help="main jobs from an empty cache, each run twice")
    parser.add_argument("--processes", type=int, default=None,
                        help="fresh processes per row of the compile group (default 3; --quick: 1)")
    parser.add_argument("--only", default=",".join(CPU_GROUPS),
                        help="groups to measure; the others are kept from an existing --json file")
    # child-process options
    parser.add_argument("--item", choices=sorted(ITEMS))
    parser.add_argument("--reference")
    parser.add_argument("--solver")
    parser.add_argument("--force")
    parser.add_argument("--method")
    parser.add_argument("--sweep-ts", type=int, default=0, help="output times of a sweep member (0: the sweep's default)")
    parser.add_argument("--once", action="store_true", help="time a sweep's first call only")
    parser.add_argument("--case", choices=["lorenz", *COMPILE_CASES])
    parser.add_argument("--transform", choices=["simulate", "grad", "jacfwd", "sensitivity", "vmap", "build"])
    parser.add_argument("--variant", default="", choices=list(COMPILE_VARIANTS))
    parser.add_argument("--reference-file", help="reference runs: reuse this npz if it exists, else write it")
    args = parser.parse_args(argv)
    if args.item:
        jax, _ = _jax()  # imports jaxbearing: its process-wide settings (jaxbearing._process)
        from jaxbearing._process import LOOP_KERNELS_FLAG

        row = ITEMS[args.item](args)
        row["loop_kernels"] = LOOP_KERNELS_FLAG in os.environ.get("XLA_FLAGS", "").split()
        row["compilation_cache"] = dict(
            dir=jax.config.jax_compilation_cache_dir,
            min_compile_time_s=jax.config.jax_persistent_cache_min_compile_time_secs,
        )
        row["peak_memory_MiB"] = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
        print(json.dumps(row))
        return
    if args.quick:
        args.t1, args.repeats, args.sweep_n, args.chunk_size = 0.06, 1, 2, 2
        args.scipy_methods, args.solver_rows, args.pairs = "RK45", 1, 1
    args.processes = args.processes or (1 if args.quick else 3)
    args.only = args.only.split(",")
    default_json = "results_gpu.json" if args.only == ["gpu"] else "results.json"
    args.json = args.json or str(HERE / ("results_quick.json" if args.quick else default_json))
    unknown = sorted(set(args.only) - set(GROUPS))
    if unknown:
        parser.error(f"--only takes {', '.join(GROUPS)}; got {', '.join(unknown)}")
    path = Path(args.json)
    keep = set(args.only) != set(CPU_GROUPS) and path.exists()
    results = json.loads(path.read_text()) if keep else {}
    with tempfile.TemporaryDirectory() as tmp:
        reuse = args.reference_file and Path(args.reference_file).exists()
        args.reference = args.reference_file if reuse else str(Path(tmp) / "reference.npz")
        start = time.perf_counter()
        measure(args, results)
        total = time.perf_counter() - start
        if set(args.only) - OWN_SPAN:
            results["total_s"] = total
    results["targets"] = _targets(results)
    print("\ntargets")
    for name, t in results["targets"].items():
        print(f"  {name:58s} {t['measured']:8.3f}  {'met' if t['met'] else 'NOT MET'}")
    _save(args, results)
    print(f"\nwritten {args.json} ({total:.0f} s in all)")


if __name__ == "__main__":
    main()

"""Parameter sweeps (`jaxbearing.sweep`): many simulations of one model, chunked, spread over
devices, resumable.

    import jaxbearing as jb
    ds = jb.sweep(jb.cases.xu2014(),
                  {"bearing.clearance": [20e-6, 40e-6, 60e-6], "impact.restitution": [0.7, 0.9]},
                  out="results/map")            # writes as it goes; rerun to resume
    ds.peak_ball_load.sel({"impact.restitution": 0.9})

`sweep` evaluates the full grid of the given parameter values (``grid=True``) or a list of points
(``grid=False``), computes scalar metrics of each `Solution` (default `metrics.STANDARD`) and
returns an `xarray.Dataset`: one data variable per metric plus ``status`` (the `RESULTS` code of
the solve, 0 = successful) and ``failed`` (status != 0; the metrics of a failed member are NaN).

A metric is a `metrics.AbstractMetric`, computed as ``metric.value(sol, model)`` with the
member's own `Solution` and model (its swept parameters set): jaxbearing's own
(``metrics.peak_ball_load.replace(bearing=1)``), `metrics.Peak` and `metrics.Mean`, or the L10
life of `life.metric`, which reads the model (the bearing's geometry and ring speeds). A plain
function of a `Solution`, ``fn(sol) -> scalar``, is a metric that reads the output samples
(`metrics.as_metric`):

    metrics = {**jb.metrics.STANDARD,
               "l10_hours": jb.life.metric("lp", groove_inner=0.5219, groove_outer=0.5194)}

How it runs
-----------
- Points are processed in chunks of ``chunk_size`` points per device (see below). One chunk is
  one call of a jitted ``shard_map(map(point -> metrics))`` over a 1-D mesh of all JAX devices
  (``jax.devices()``), so each device integrates its own members; the chunk is
  padded to a multiple of the device count by repeating its last point (the padding is dropped;
  `arguments.padded_rows`).
  All chunks have the same shapes, so the function compiles once (and is reused by later sweeps
  of the same model structure, metrics and solver settings in the same process). Memory stays
  bounded by the chunk, whatever the number of points.
- On a CPU device the members run one after another (`jax.lax.map`), each exactly as its run
  alone, and the padding runs nothing; on an accelerator they run as one batch (`jax.vmap`),
  in which every member takes its own steps and locates its own events in each iteration of
  the solve's loop, and a chunk runs until its slowest member finishes. A CPU gains nothing
  from a batch: XLA:CPU compiles a single member's loop into one function, not a batch's
  (`kernel`'s docstring).
- Where nothing reads output samples (no ``ts`` given, only metrics of the solve's records),
  each member runs as `simulate_one_loop`: one while loop a member, the faster on CPUs and
  accelerators alike (docs/platforms.md); else as `simulate`. Both repeat the same
  integrator core, so the metrics agree to the solver's accuracy. The manifest records
  ``"solve": "one_loop"`` then, and the dataset's ``solve`` attribute says which ran.
- What a member records comes from its metrics alone (`metrics.AbstractMetric`'s interface):
  without ``ts`` it is solved with just the output times they need, ``[t0, t1]`` when none
  reads the output samples (``reads_samples``; jaxbearing's metrics, `metrics.Peak`,
  `metrics.Mean` and `life.metric` read the solve's records), so a member's memory does not
  grow with an output count, else `DEFAULT_SAMPLES` (2001) equally spaced times (a plain
  function). Members record the life's integrals (`Solution.fatigue`) only when a metric reads
  them (``reads_fatigue``: `life.metric`), unless ``fatigue`` is passed; each metric's
  ``records()`` are declared, and its ``edges()`` become stops (`metrics.solve_options`).
- Chunk size. On CPU devices the default is 32 points per device: the members run one after
  another, so the chunk sets how often results are written and what an interruption loses,
  against a fixed cost a chunk (dispatch, gathering, writing a file). The measured rates and memory per member are in
  docs/performance.md and ``benchmarks/results.json``
  (``benchmarks/run.py --only sweep --chunk-size N``). On accelerators the default is 4096 points
  per device for members run as `simulate` and 65536 for the one loop (the best measured on
  one GPU: docs/performance.md); there a chunk runs in lock-step too, but the device's
  threads are idle until tens of thousands of members share an iteration.
- Members run with ``simulate(..., throw=False)``: a member that fails (``max_steps``,
  ``max_segments``, a blown-up solve) is marked by ``status``/``failed`` and the sweep goes on.
  A chunk that raises at run time (an equinox check inside the solve) is rerun one point at a
  time with the same compiled function; the points that still raise get ``status = RAISED``
  (-1) and NaN metrics (in multi-process runs such an error is re-raised instead).
  Invalid parameter values (e.g. a negative clearance) are rejected before anything runs, with a
  `ValueError` naming the point.
- NaN is never a silent result: a member whose solve succeeded but one of whose metrics is NaN
  or infinite gets ``status = NOT_FINITE`` (-2, ``failed``); its message names those metrics
  and the usual cause (a window edge that is not a stop of the solve, or a window outside the
  solved span); its other metrics are kept. Window edges given to a metric as numbers
  (``metrics.peak_ball_load.replace(t_min=0.09)``, `life.metric`'s ``t_min``) are added to the
  members' ``window_edges`` where they are not stops already (`metrics.solve_options`), so
  those metrics are exact; an edge hidden inside a function (a `functools.partial` too) cannot
  be seen before the solve and gives NaN, so its member fails.
- Failed members are reported with their parameters: one `RuntimeWarning` at the end lists
  them (point index, parameter values, result name and message, up to 10 lines), and
  ``attrs["failures"]`` (JSON) holds them all, each as ``{"index", "point": {path: value},
  "status", "result", "message"}`` (for `RAISED` the error's message, for `NOT_FINITE` the
  metrics that are not finite).
- To use several CPU cores as devices, set ``XLA_FLAGS=--xla_force_host_platform_device_count=N``
  in the environment before JAX is imported.

Output folder (``out=``)
------------------------
``manifest.json`` records what the sweep is (its format version, ``store.FORMAT_VERSION``,
4 since metrics are labelled by their ``AbstractMetric.label``: a folder of another version is
refused as another sweep; parameter names and values, grid or list, metric names and labels,
each label followed by ``[code <digest>]`` where the metric holds code of the user's (a
function given to `metrics.Peak`, `metrics.Mean` or as a metric, a metric class of the user's):
a digest of what it computes, its bytecode, constants, defaults, closure and the globals it
loads (`fingerprint`), so that two functions of one label, such as two lambdas, are two
metrics and a folder never gives one's values for the other's; t1, ts, the solver settings, the points per chunk, every parameter of the model by dotted
path (`provenance.parameters`; the swept ones as ``"swept"``: their values are the
coordinates) and a fingerprint of the model: a hash of its tree structure and of the bytes of
all its array leaves, with the swept leaves blanked), and the package versions that started it
(`provenance.versions`). Each finished chunk is written at once, atomically (`jaxbearing._files`:
temporary file + ``os.replace``), as ``chunk_XXXXX.npz``; at the end the whole Dataset goes
to ``results.nc`` (netCDF, also atomic). Calling `sweep` again with the same arguments and
``out`` loads the chunks already written and computes only the missing ones: an interrupted
sweep resumes. If the manifest differs (other
values, model, metrics or settings) `sweep` raises a `ValueError` listing what differs: use
another ``out`` or delete the folder. A chunk file that cannot be read, or does not hold what the
manifest says, raises a `ValueError` naming the file (delete it to recompute that chunk). A sweep
started on one device count may be resumed on another: without an explicit ``chunk_size`` the
chunk layout of the manifest is kept. Package versions are recorded but not compared: a sweep
resumed under other versions goes on with a `RuntimeWarning` naming them (results may then
differ in the last bits between the chunks computed before and after), and ``results.nc``
records both sets. ``results.nc`` carries the manifest's records as attributes (``versions``,
``model_parameters``, ``simulate_kwargs``, ... as JSON): with the coordinates they are the full
input of every member.

One writer at a time. Process 0 holds an advisory lock on the folder (``fcntl.flock`` on
``.sweep.lock``, which names its pid and host) from checking the manifest to writing
``results.nc``; the kernel releases it when the process ends, however it ends. A second
process that calls the same sweep on the folder waits, with a message on stderr, and then
resumes from what the first wrote, so no point is computed twice and nothing is lost; a
different sweep (another manifest) is refused at once. With the lock held, the temporary files
of the sweep's own files (``.chunk_*.npz.*.tmp``, ...) found at start-up belong to a process
that has ended and are deleted; no other file is. (``flock`` locks work between the processes of
one host and, on Linux, on NFS; on a file system without locks the sweep goes on with a
`RuntimeWarning`.)

A folder this process cannot write (permissions, a read-only file system) is found before
anything is computed: `PermissionError` naming the folder, unless the sweep in it is finished
(every chunk written), which then loads; ``results.nc`` is written only when it is missing, does
not hold the loaded Dataset, or chunks were computed in this call.

Several hosts (``jax.distributed``)
-----------------------------------
Call ``jax.distributed.initialize()`` (with the coordinator address, process count and id where
the cluster does not provide them) on every host before importing models or calling `sweep`,
then run the *same* ``sweep(...)`` call, with the same arguments, in every process. The mesh then
spans the devices of all hosts and each chunk is shared among all of them:

- process 0 alone reads and writes ``out`` (it need not be on a shared file system); it checks the
  manifest, loads the chunks already done and broadcasts them to the other processes
  (`jax.experimental.multihost_utils.broadcast_one_to_all`), so every process skips the same
  chunks;
- after each chunk the per-device results are gathered to every process
  (`multihost_utils.process_allgather`); process 0 writes the chunk file and shows the progress;
- every process returns the same complete Dataset.

With one process these steps are no-ops. All processes must run the same JAX program in the same
order (as always with multi-controller JAX): do not make the call conditional on the process.

Modules, one job each: `arguments` (checks and resolves the arguments: points, metrics, output
times, chunk size), `kernel` (the sharded, vmapped chunk function), `store` (manifest, chunk
files, resume), `fingerprint` (the digest of a metric's code), `dataset` (the Dataset,
``results.nc``, the failure report), `progress` (the bar) and `driver` (`sweep`, a list of
these stages).
"""

from .arguments import DEFAULT_SAMPLES, default_chunk_size
from .driver import sweep
from .kernel import NOT_FINITE, RAISED
from .store import MANIFEST, RESULTS_FILE

__all__ = [
    "DEFAULT_SAMPLES",
    "MANIFEST",
    "NOT_FINITE",
    "RAISED",
    "RESULTS_FILE",
    "default_chunk_size",
    "sweep",
]

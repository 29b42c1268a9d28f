"""Parameter sweeps: many simulations of one model, vmapped, chunked, spread over devices, resumable.

    import jaxbearing as jb
    ds = jb.sweep(jb.cases.xu2014(),
                  {"bearing.clearance": [20e-6, 40e-6, 60e-6], "impact.restitution": [0.7, 0.9]},
                  out="results/map")            # writes as it goes; rerun to resume
    ds.peak_ball_load.sel({"impact.restitution": 0.9})

`sweep` evaluates the full grid of the given parameter values (``grid=True``) or a list of points
(``grid=False``), computes scalar metrics of each `Solution` (default `metrics.STANDARD`) and
returns an `xarray.Dataset`: one data variable per metric plus ``status`` (the `RESULTS` code of
the solve, 0 = successful) and ``failed`` (status != 0; the metrics of a failed member are NaN).

A metric is a function of the member's `Solution`, ``fn(sol) -> scalar``; one that also needs
the model (bearing life needs the bearing's geometry and the ring speeds) is wrapped in
`metrics.WithModel` and called ``fn(sol, model)`` with the member's own model, its swept
parameters set. `life.metric` makes the L10 life such a metric:

    metrics = {**jb.metrics.STANDARD,
               "l10_hours": jb.life.metric("lp", groove_inner=0.5219, groove_outer=0.5194)}

How it runs
-----------
- Points are processed in chunks of ``chunk_size`` points per device (see below). One chunk is one call of a
  jitted ``shard_map(vmap(point -> metrics))`` over a 1-D mesh of all JAX devices
  (``jax.devices()``), so each device integrates its own members in its own loop; the chunk is
  padded to a multiple of the device count by repeating its last point (the padding is dropped).
  All chunks have the same shapes, so the function compiles once (and is reused by later sweeps
  of the same model structure, metrics and solver settings in the same process). Memory stays
  bounded by the chunk, whatever the number of points.
- Under vmap a solver loop runs until its slowest member finishes: points that need many steps
  slow down their chunk, not the others.
- Chunk size. On CPU devices the default is 16 points per device. Measured on the paper's case
  with impact (0.2 s, 2001 output times, an 8 x 8 grid of clearance and restitution,
  `benchmarks/run.py --only sweep --chunk-size N`): 1.89, 2.32 and 2.88 simulations/s on one
  device at 4, 8 and 16 points per chunk; 4.03, 4.96 and 5.51 on 2 CPU devices. A batch runs in
  lock-step to its slowest member, but vectorised evaluation and fewer per-chunk overheads
  (dispatch, gathering, writing a file) outweigh that; a larger chunk loses more to an
  interruption. On accelerators the default is 8 points per device (not measured here: set
  ``chunk_size`` from a measurement on the machine at hand).
- Members run with ``simulate(..., throw=False)``: a member that fails (``max_steps``,
  ``max_segments``, a blown-up solve) is marked by ``status``/``failed`` and the sweep goes on.
  A chunk that raises at run time (an equinox check inside the solve) is rerun one point at a
  time with the same compiled function; the points that still raise get ``status = RAISED``
  (-1) and NaN metrics (in multi-process runs such an error is re-raised instead).
  Invalid parameter values (e.g. a negative clearance) are rejected before anything runs, with a
  `ValueError` naming the point.
- Failed members are reported with their parameters: one `RuntimeWarning` at the end lists
  them (point index, parameter values, result name and message, up to 10 lines), and
  ``attrs["failures"]`` (JSON) holds them all, each as ``{"index", "point": {path: value},
  "status", "result", "message"}`` (for `RAISED` the error's message).
- To use several CPU cores as devices, set ``XLA_FLAGS=--xla_force_host_platform_device_count=N``
  in the environment before JAX is imported.

Output folder (``out=``)
------------------------
``manifest.json`` records what the sweep is (parameter names and values, grid or list, metric
names, t1, ts, the solver settings, the points per chunk, every parameter of the model by dotted
path (`provenance.parameters`; the swept ones as ``"swept"``: their values are the
coordinates) and a
fingerprint of the model: a hash of its tree structure and of the bytes of all its array leaves,
with the swept leaves blanked), and the package versions that started it (`provenance.versions`).
Each finished chunk is written at once, atomically (temporary file + ``os.replace``), as
``chunk_XXXXX.npz``; at the end the whole Dataset goes to ``results.nc`` (netCDF, also atomic).
Calling `sweep` again with the same arguments and ``out`` loads the chunks already written and
computes only the missing ones: an interrupted sweep resumes. If the manifest differs (other
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
"""

from __future__ import annotations

import hashlib
import inspect
import json
import math
import os
import re
import time
import warnings
from collections.abc import Callable, Mapping
from pathlib import Path

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from . import _checks, metrics as _metrics, paths, provenance
from .multibody.mechanism import Mechanism
from .solution import RESULTS
from .solve import default_max_segments, default_solver, simulate

__all__ = ["sweep", "RAISED", "default_chunk_size", "DEFAULT_SAMPLES", "MANIFEST", "RESULTS_FILE"]

DEFAULT_CHUNK_SIZE = {"cpu": 16}  # points per device per chunk, by platform (see the module doc)
DEFAULT_CHUNK_SIZE_ACCELERATOR = 8
DEFAULT_SAMPLES = 2001  # output times when ts is not given
MANIFEST = "manifest.json"
SWEPT = "swept"  # the value of a swept parameter in the manifest's model_parameters
RESULTS_FILE = "results.nc"
FORMAT_VERSION = 2
AXIS = "d"  # name of the device axis of the mesh
_RESERVED = ("status", "failed", "point")
_NOT_FORWARDED = ("throw", "progress")  # simulate arguments that sweep sets itself
_SUCCESS = int(RESULTS.successful._value)
RAISED = -1  # status of a member whose solve raised an error (e.g. an equinox runtime check)
_NOT_RUN = -99  # placeholder, never returned
_RUNTIME_ERRORS = (eqx.EquinoxRuntimeError, jax.errors.JaxRuntimeError)


# ------------------------------------------------------------------------------ public entry


def sweep(
    model: Mechanism,
    params: Mapping[str, object],
    *,
    metrics: Mapping[str, Callable] | None = None,
    grid: bool = True,
    t1: float = 0.2,
    ts=None,
    out: str | os.PathLike | None = None,
    chunk_size: int | None = None,
    progress: bool = True,
    **simulate_kwargs,
):
    """Simulate ``model`` at many parameter values and return labelled metrics.

    Args:
        model: a `Mechanism`; the swept parameters replace its values (`paths.replace`).
        params: dotted parameter path -> 1-D values, e.g. ``{"bearing.clearance": [2e-5, 4e-5],
            "impact.restitution": [0.7, 0.9]}``.
        metrics: name -> function of a `Solution` returning a scalar, or a `metrics.WithModel`
            (a function of the solution and the member's model, e.g. `life.metric`) (default
            `jaxbearing.metrics.STANDARD`). Names must differ from the parameter paths and from
            ``status``, ``failed``, ``point``.
        grid: True: every combination of the values (dimensions in the order of ``params``).
            False: a list of points, the i-th value of every parameter together (all arrays of
            one length; dimension ``point``).
        t1: final time [s] of every simulation.
        ts: output times the metrics see (default ``linspace(t0, t1, 2001)``).
        out: folder to write to and resume from (see the module doc), or None.
        chunk_size: points per device per chunk (default `default_chunk_size()`: 16 on CPU, 8
            on accelerators; or the layout already in ``out``).
        progress: show a progress bar over chunks (tqdm, else plain lines).
        **simulate_kwargs: passed to `simulate` (t0, solver, rtol, atol, stepsize_controller,
            max_steps, max_segments, adjoint); ``throw`` and ``progress`` are set by the sweep.

    Returns:
        `xarray.Dataset` with one variable per metric, ``status`` (int32, a `RESULTS` code, 0 =
        successful, or `RAISED`; ``attrs["status_codes"]`` names them) and ``failed`` (bool). Grid: one
        dimension and coordinate per parameter. List: dimension ``point``, the parameters as
        coordinates along it. Attributes record t1, t0, the tolerances and solver, every model
        parameter (``model_parameters``), the model fingerprint, the package versions
        (``versions``) and the failed members with their parameters (``failures``); the
        returned object also carries timing of this call (``sweep_computed_points``,
        ``sweep_wall_s``, ``sweep_chunk_s``), which is not written to ``results.nc``.
    """
    import xarray as xr  # noqa: F401  (fail early with a clear ImportError)

    _checks.require_x64()
    started = time.perf_counter()
    if not isinstance(model, Mechanism):
        raise TypeError(f"sweep needs a jaxbearing Mechanism, got {type(model).__name__}.")
    names, axes = _parameters(model, params)
    points, shape = _points(names, axes, grid)
    metric_items = _metric_items(metrics, names)
    sim_kwargs = _simulate_kwargs(simulate_kwargs)
    t1 = float(t1)
    t0 = float(sim_kwargs.get("t0", 0.0))
    if sim_kwargs.get("max_segments") is None:
        sim_kwargs["max_segments"] = default_max_segments(model, t0, t1)
    ts = np.linspace(t0, t1, DEFAULT_SAMPLES) if ts is None else np.asarray(ts, dtype=np.float64)
    if ts.ndim != 1 or ts.size < 1:
        raise ValueError(f"ts must be a non-empty 1-D array of times; got shape {ts.shape}.")
    _check_points(model, names, points)

    n_points = points.shape[0]
    n_devices = jax.device_count()
    if chunk_size is not None and (int(chunk_size) != chunk_size or chunk_size < 1):
        raise ValueError(f"chunk_size must be a positive integer; got {chunk_size!r}.")
    out = None if out is None else Path(out)
    main = jax.process_index() == 0
    multi = jax.process_count() > 1

    manifest = _manifest(model, names, axes, grid, shape, metric_items, t1, ts, sim_kwargs)
    chunk_points = _default_chunk_points(chunk_size, n_devices, n_points)

    # process 0 checks the folder and loads what is done; the others get it by broadcast
    metric_names = [name for name, _ in metric_items]
    values = np.full((n_points, len(metric_names)), np.nan)
    status = np.full((n_points,), _NOT_RUN, np.int32)
    errors = np.full((n_points,), "", dtype=object)
    done = None
    error = None
    if main:
        try:
            chunk_points, done, stored_versions = _open_out(
                out, manifest, chunk_size, chunk_points, n_devices
            )
            if stored_versions is not None and stored_versions != manifest["versions"]:
                warnings.warn(_versions_changed(out, stored_versions, manifest["versions"]),
                              RuntimeWarning, stacklevel=2)  # fmt: skip
                manifest["versions_at_start"] = stored_versions
            if out is not None:
                _load_chunks(out, done, chunk_points, points, metric_names, values, status, errors)
        except Exception as err:  # noqa: BLE001  (re-raised below, after telling the others)
            error = err
    if multi:
        from jax.experimental import multihost_utils

        failed_there = multihost_utils.broadcast_one_to_all(np.int32(error is not None))
        if int(failed_there):
            if error is not None:
                raise error
            raise RuntimeError("sweep failed on process 0; its error message says why.")
        chunk_points = int(multihost_utils.broadcast_one_to_all(np.int64(chunk_points)))
        if done is None:
            done = np.zeros(math.ceil(n_points / chunk_points), bool)
        done, values, status = multihost_utils.broadcast_one_to_all(
            (done.astype(np.int32), values, status)
        )
        done, values, status = np.asarray(done) != 0, np.array(values), np.array(status)
    elif error is not None:
        raise error
    manifest["chunk_points"] = chunk_points
    n_chunks = math.ceil(n_points / chunk_points)

    # one compiled function for all chunks
    mesh = jax.make_mesh((n_devices,), (AXIS,), axis_types=(jax.sharding.AxisType.Auto,))
    padded = math.ceil(chunk_points / n_devices) * n_devices
    run = _ChunkRunner(model, names, metric_items, t1, ts, sim_kwargs, mesh, padded)

    bar = _Progress(n_chunks, int(done.sum()), enabled=progress and main)
    chunk_seconds = []
    computed = 0
    try:
        for k in range(n_chunks):
            if done[k]:
                continue
            tic = time.perf_counter()
            start, stop = k * chunk_points, min((k + 1) * chunk_points, n_points)
            try:
                chunk_values, chunk_status = run(points[start:stop])
                chunk_errors = np.full(stop - start, "")
            except _RUNTIME_ERRORS as err:
                if multi:  # the processes would no longer run the same program
                    raise
                warnings.warn(
                    f"sweep: chunk {k} raised an error at run time ({_first_line(err)}); "
                    "running its points one at a time to find the culprit(s).",
                    RuntimeWarning,
                    stacklevel=2,
                )
                chunk_values, chunk_status, chunk_errors = run.one_by_one(points[start:stop])
            values[start:stop] = chunk_values
            status[start:stop] = chunk_status
            errors[start:stop] = chunk_errors
            if out is not None and main:
                _save_chunk(
                    out / _chunk_name(k), start, stop, points[start:stop], metric_names,
                    chunk_values, chunk_status, chunk_errors,
                )
            done[k] = True
            computed += stop - start
            chunk_seconds.append(time.perf_counter() - tic)
            bar.update(stop - start, chunk_seconds[-1])
    finally:
        bar.close()

    ds = _dataset(names, axes, grid, shape, points, metric_names, values, status, errors, manifest)
    if out is not None and main:
        _write_netcdf(ds, out / RESULTS_FILE)
    failed = json.loads(ds.attrs["failures"])
    if failed and main:
        warnings.warn(_failure_report(failed, n_points), RuntimeWarning, stacklevel=2)
    ds.attrs["sweep_computed_points"] = computed
    ds.attrs["sweep_wall_s"] = time.perf_counter() - started
    ds.attrs["sweep_chunk_s"] = np.asarray(chunk_seconds)
    return ds


# ------------------------------------------------------------------------------ arguments


def _parameters(model, params):
    if not isinstance(params, Mapping) or not params:
        raise ValueError(
            "params must be a non-empty mapping of parameter paths to values, e.g. "
            '{"bearing.clearance": [2e-5, 4e-5]}.'
        )
    names, axes = [], []
    for name, raw in params.items():
        if not isinstance(name, str):
            raise TypeError(f"Parameter names must be dotted paths (str); got {name!r}.")
        if name in _RESERVED:
            raise ValueError(f"{name!r} cannot be a parameter name (reserved for the results).")
        leaf = paths.get(model, name)  # clear error for a bad path
        if not eqx.is_array(leaf) or jnp.shape(leaf) != ():
            raise ValueError(
                f"Parameter {name!r} must be a scalar array leaf of the model to be swept; "
                f"got {type(leaf).__name__} {getattr(leaf, 'shape', '')}."
            )
        v = np.asarray(raw, dtype=np.float64)
        if v.ndim == 0:
            v = v.reshape(1)
        if v.ndim != 1 or v.size == 0:
            raise ValueError(
                f"The values of {name!r} must be a non-empty 1-D array; got shape {v.shape}."
            )
        names.append(name)
        axes.append(v)
    return tuple(names), axes


def _points(names, axes, grid):
    if grid:
        shape = tuple(a.size for a in axes)
        mesh = np.meshgrid(*axes, indexing="ij")
        return np.stack([m.ravel() for m in mesh], axis=1), shape
    lengths = {name: a.size for name, a in zip(names, axes)}
    if len(set(lengths.values())) != 1:
        raise ValueError(
            f"With grid=False every parameter needs the same number of values (one per point); "
            f"got {lengths}."
        )
    return np.stack(axes, axis=1), (axes[0].size,)


def _metric_items(metrics, names):
    metrics = _metrics.STANDARD if metrics is None else metrics
    if not isinstance(metrics, Mapping) or not metrics:
        raise ValueError(
            "metrics must be a non-empty mapping of names to functions of a Solution (or "
            "metrics.WithModel functions of a Solution and the model)."
        )
    items = []
    for name, fn in metrics.items():
        if not isinstance(name, str) or not callable(fn):
            raise TypeError(f"metrics maps names (str) to functions of a Solution; got {name!r}: {fn!r}.")
        if name in _RESERVED or name in names:
            raise ValueError(
                f"Metric name {name!r} collides with a parameter or a reserved name {_RESERVED}."
            )
        items.append((name, fn))
    return tuple(items)


def _simulate_kwargs(kwargs):
    accepted = set(inspect.signature(simulate).parameters) - {"model", "t1", "ts"}
    for key in kwargs:
        if key in _NOT_FORWARDED:
            raise TypeError(f"sweep sets simulate's {key!r} itself; do not pass it.")
        if key not in accepted:
            raise TypeError(
                f"sweep got an unexpected keyword {key!r}; it forwards only simulate's "
                f"{sorted(accepted - set(_NOT_FORWARDED))}."
            )
    return dict(sorted(kwargs.items()))


def _resolved_settings(sim_kwargs):
    """simulate's keyword arguments with defaults filled in (for the manifest and attributes)."""
    settings = {}
    for name, p in inspect.signature(simulate).parameters.items():
        if p.kind is not inspect.Parameter.KEYWORD_ONLY or name in _NOT_FORWARDED:
            continue
        settings[name] = sim_kwargs.get(name, p.default)
    if settings.get("solver") is None:
        settings["solver"] = default_solver()
    return settings


def _check_points(model, names, points):
    """Raise a ValueError for the first point whose values break a parameter rule."""
    messages = [message for _, message, _ in model.violations()]
    flags = np.asarray(_violation_flags(model, names, jnp.asarray(points)))
    bad = np.argwhere(flags)
    if bad.size:
        i, r = bad[0]
        where = ", ".join(f"{n} = {v:.6g}" for n, v in zip(names, points[i]))
        raise ValueError(
            f"Sweep point {i} ({where}) is invalid: {messages[r]}. "
            f"{len(np.unique(bad[:, 0]))} of {points.shape[0]} points break a rule."
        )


@eqx.filter_jit
def _violation_flags(model, names, points):
    def one(row):
        m = paths.replace(model, dict(zip(names, row)))
        return jnp.stack([jnp.any(jnp.asarray(w)) for w, _, _ in m.violations()])

    return jax.vmap(one)(points)


def default_chunk_size(platform: str | None = None) -> int:
    """Points per device per chunk when ``chunk_size`` is not given: 16 on CPU devices, 8 on
    accelerators (the module doc says why)."""
    platform = jax.devices()[0].platform if platform is None else platform
    return DEFAULT_CHUNK_SIZE.get(platform, DEFAULT_CHUNK_SIZE_ACCELERATOR)


def _default_chunk_points(chunk_size, n_devices, n_points):
    per_device = default_chunk_size() if chunk_size is None else int(chunk_size)
    # never pad a small sweep beyond one round of the devices
    return max(1, min(per_device * n_devices, math.ceil(n_points / n_devices) * n_devices))


# ------------------------------------------------------------------------------ the kernel


class _ChunkRunner:
    """Evaluates one chunk of points: pads it, runs the sharded kernel, gathers, unpads."""

    def __init__(self, model, names, metric_items, t1, ts, sim_kwargs, mesh, padded):
        self.model = model
        self.names = names
        self.metric_items = metric_items
        self.t1 = t1
        self.sim_items = tuple(sim_kwargs.items())
        self.mesh = mesh
        self.padded = padded
        from jax.sharding import NamedSharding, PartitionSpec as P

        self.replicated = NamedSharding(mesh, P())
        self.split = NamedSharding(mesh, P(AXIS))
        # host values in, so that the same code places them on a mesh spanning several hosts
        self.ts = jax.device_put(np.asarray(ts, np.float64), self.replicated)
        self.dynamic = jax.device_put(
            jax.tree_util.tree_map(np.asarray, eqx.filter(model, eqx.is_array)), self.replicated
        )
        self.static = eqx.filter(model, eqx.is_array, inverse=True)

    def __call__(self, chunk_points):
        n = chunk_points.shape[0]
        rows = np.concatenate([chunk_points, np.repeat(chunk_points[-1:], self.padded - n, axis=0)])
        rows = jax.device_put(rows, self.split)
        model = eqx.combine(self.dynamic, self.static)
        values, status = _run_chunk(
            model, rows, self.ts, self.names, self.metric_items, self.t1, self.sim_items, self.mesh
        )
        values, status = _to_host((values, status))
        return values[:n], status[:n].astype(np.int32)

    def one_by_one(self, chunk_points):
        """Each point alone (its chunk filled with copies: no recompilation); a point whose
        solve raises gets status RAISED, NaN metrics and the error's first line."""
        n = chunk_points.shape[0]
        values = np.full((n, len(self.metric_items)), np.nan)
        status = np.full(n, RAISED, np.int32)
        errors = np.full(n, "", dtype=object)
        for i in range(n):
            try:
                v, c = self(chunk_points[i : i + 1])
            except _RUNTIME_ERRORS as err:
                errors[i] = _first_line(err)
                continue
            values[i], status[i] = v[0], c[0]
        return values, status, errors


def _first_line(err, limit=300):
    """The message of a runtime error (equinox puts it after the stack inside JIT)."""
    lines = [line.strip() for line in str(err).splitlines() if line.strip()]
    for line in reversed(lines):
        found = re.match(r"^[\w.]*(?:Error|Exception): (.+)$", line)
        if found and not found.group(1).startswith("Above is the stack"):
            return found.group(1)[:limit]
    return (lines[0] if lines else repr(err))[:limit]


def _to_host(tree):
    if jax.process_count() > 1:
        from jax.experimental import multihost_utils

        return jax.tree_util.tree_map(np.asarray, multihost_utils.process_allgather(tree, tiled=True))
    return jax.tree_util.tree_map(np.asarray, tree)


@eqx.filter_jit  # XLA's default options: see `jaxbearing.compile`
def _run_chunk(model, rows, ts, names, metric_items, t1, sim_items, mesh):
    from jax.sharding import PartitionSpec as P

    dynamic, static = eqx.partition(model, eqx.is_array)
    sim_kwargs = dict(sim_items)

    def point(dynamic, row, ts):
        m = paths.replace(eqx.combine(dynamic, static), dict(zip(names, row)))
        sol = simulate(m, t1, ts, throw=False, **sim_kwargs)
        code = jnp.asarray(sol.result._value, jnp.int32)
        ok = code == _SUCCESS
        outs = []
        for name, fn in metric_items:
            value = jnp.asarray(fn(sol, m) if isinstance(fn, _metrics.WithModel) else fn(sol))
            if value.shape != ():
                raise ValueError(f"Metric {name!r} must return a scalar; it returned shape {value.shape}.")
            outs.append(jnp.where(ok, value.astype(jnp.float64), jnp.nan))
        return jnp.stack(outs), code

    def per_device(dynamic, rows, ts):
        return jax.vmap(point, in_axes=(None, 0, None))(dynamic, rows, ts)

    sharded = jax.shard_map(
        per_device,
        mesh=mesh,
        in_specs=(P(), P(AXIS), P()),
        out_specs=(P(AXIS), P(AXIS)),
        check_vma=False,
    )
    return sharded(dynamic, rows, ts)


# ------------------------------------------------------------------------------ files


def _fingerprint(model, names):
    """sha256 of the tree structure and of every leaf, with the swept leaves blanked."""
    blank = paths.replace(model, {n: jnp.zeros_like(paths.get(model, n)) for n in names})
    leaves, treedef = jax.tree_util.tree_flatten(blank)
    h = hashlib.sha256()
    h.update(re.sub(r" at 0x[0-9a-fA-F]+", "", str(treedef)).encode())
    for leaf in leaves:
        if eqx.is_array(leaf):
            a = np.asarray(leaf)
            h.update(f"{a.dtype.str}{a.shape}".encode())
            h.update(np.ascontiguousarray(a).tobytes())
        else:
            h.update(re.sub(r" at 0x[0-9a-fA-F]+", "", repr(leaf)).encode())
    return h.hexdigest()


def _jsonable(value):
    if value is None or isinstance(value, (bool, int, float, str)):
        return value
    if isinstance(value, (np.generic, np.ndarray, jax.Array)):
        return np.asarray(value).tolist()
    if isinstance(value, (list, tuple)):
        return [_jsonable(v) for v in value]
    return re.sub(r" at 0x[0-9a-fA-F]+", "", repr(value))


def _metric_label(fn):
    if isinstance(fn, _metrics.WithModel):
        return f"WithModel({_metric_label(fn.fn)})"
    inner = getattr(fn, "func", fn)  # functools.partial
    label = f"{getattr(inner, '__module__', '?')}.{getattr(inner, '__qualname__', type(inner).__name__)}"
    if inner is not fn:
        args = ", ".join([repr(a) for a in fn.args] + [f"{k}={v!r}" for k, v in fn.keywords.items()])
        label = f"partial({label}, {args})"
    return label


def _model_parameters(model, names):
    """`provenance.parameters` of the model, the swept leaves marked ``"swept"``."""
    return provenance.parameters(paths.replace(model, {n: SWEPT for n in names}))


def _manifest(model, names, axes, grid, shape, metric_items, t1, ts, sim_kwargs):
    manifest = {
        "format": FORMAT_VERSION,
        "parameters": {n: a.tolist() for n, a in zip(names, axes)},
        "grid": bool(grid),
        "shape": list(shape),
        "metrics": {name: _metric_label(fn) for name, fn in metric_items},
        "t1": t1,
        "ts": np.asarray(ts).tolist(),
        "simulate": {k: _jsonable(v) for k, v in _resolved_settings(sim_kwargs).items()},
        "model_fingerprint": _fingerprint(model, names),
        "model_parameters": _model_parameters(model, names),
        "chunk_points": None,  # set once the folder is opened
        "versions": provenance.versions(),
    }
    return json.loads(json.dumps(manifest))  # normalised as it reads back


_NOT_COMPARED = ("versions", "chunk_points")
_MISSING = "(missing)"


def _open_out(out, manifest, chunk_size, chunk_points, n_devices):
    """Create or check ``out``; returns (points per chunk, done mask, the package versions of
    the stored manifest or None)."""
    n_points = int(np.prod(manifest["shape"]))
    stored_versions = None
    if out is None:
        return chunk_points, np.zeros(math.ceil(n_points / chunk_points), bool), stored_versions
    out.mkdir(parents=True, exist_ok=True)
    path = out / MANIFEST
    chunks = sorted(out.glob("chunk_*.npz"))
    if path.exists():
        try:
            old = json.loads(path.read_text())
        except (OSError, ValueError) as err:
            raise ValueError(
                f"{path} is unreadable ({err}); delete the folder {out} or use another `out`."
            ) from None
        differ = [k for k in manifest if k not in _NOT_COMPARED and old.get(k) != manifest[k]]
        differ += [k for k in old if k not in manifest]
        if differ:
            raise ValueError(
                f"The sweep in {out} was started with other arguments: {', '.join(differ)} "
                f"differ{'s' if len(differ) == 1 else ''} ({_describe_difference(old, manifest, differ)}). "
                "Use another `out` folder for this sweep, or delete the old one to start afresh."
            )
        stored = old.get("chunk_points")
        if not isinstance(stored, int) or stored < 1:
            raise ValueError(f"{path} has no valid chunk_points; delete the folder {out}.")
        if chunk_size is not None and stored != chunk_points:
            raise ValueError(
                f"The sweep in {out} was written in chunks of {stored} points; chunk_size="
                f"{chunk_size} on {n_devices} device(s) makes {chunk_points}. Leave chunk_size "
                "unset to resume with the stored layout, use another `out`, or delete it."
            )
        chunk_points = stored
        stored_versions = old.get("versions", {})
    else:
        if chunks:
            raise ValueError(
                f"{out} holds chunk files but no {MANIFEST}: they cannot be matched to this "
                "sweep. Delete them or use another `out` folder."
            )
        manifest = dict(manifest, chunk_points=chunk_points)
        _atomic_write_bytes(path, json.dumps(manifest, indent=1).encode())
    for tmp in out.glob(".*.tmp"):  # leftovers of an interrupted write
        tmp.unlink(missing_ok=True)
    n_chunks = math.ceil(n_points / chunk_points)
    done = np.array([(out / _chunk_name(k)).exists() for k in range(n_chunks)], bool)
    extra = [p.name for p in chunks if not re.fullmatch(r"chunk_\d{5,}\.npz", p.name)
             or int(p.stem.split("_")[1]) >= n_chunks]
    if extra:
        raise ValueError(f"{out} holds chunk files this sweep does not have: {extra}; delete them.")
    return chunk_points, done, stored_versions


def _versions_changed(out, stored, now):
    changed = ", ".join(
        f"{name} {stored.get(name)} -> {version}"
        for name, version in now.items() if stored.get(name) != version
    )  # fmt: skip
    return (
        f"sweep: resuming {out} under other package versions ({changed}); the chunks computed "
        "before may differ from new ones in the last bits. results.nc records both "
        "(attributes versions_at_start and versions)."
    )


def _describe_difference(old, new, keys):
    parts = []
    for k in keys[:3]:
        a, b = old.get(k), new.get(k)
        if isinstance(a, dict) and isinstance(b, dict):  # name the entries that differ
            inner = [e for e in {**a, **b} if a.get(e, _MISSING) != b.get(e, _MISSING)]
            parts += [
                f"{k} {e}: stored {_short(a.get(e, _MISSING))}, now {_short(b.get(e, _MISSING))}"
                for e in inner[:3]
            ]
        else:
            parts.append(f"{k}: stored {_short(a)}, now {_short(b)}")
    return "; ".join(parts)


def _short(value, limit=120):
    text = json.dumps(value)
    return text if len(text) <= limit else text[: limit - 3] + "..."


def _chunk_name(k):
    return f"chunk_{k:05d}.npz"


def _atomic_write_bytes(path, data: bytes):
    tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    with open(tmp, "wb") as f:
        f.write(data)
        f.flush()
        os.fsync(f.fileno())
    os.replace(tmp, path)


def _save_chunk(path, start, stop, points, metric_names, values, status, errors):
    """Write one chunk atomically (a reader sees the old state or the whole new file)."""
    tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    with open(tmp, "wb") as f:
        np.savez(
            f,
            start=np.int64(start),
            stop=np.int64(stop),
            points=points,
            metric_names=np.asarray(metric_names, dtype=str),
            values=values,
            status=status.astype(np.int32),
            errors=np.asarray(errors, dtype=str),
        )
        f.flush()
        os.fsync(f.fileno())
    os.replace(tmp, path)


def _load_chunks(out, done, chunk_points, points, metric_names, values, status, errors):
    n_points = points.shape[0]
    for k in np.flatnonzero(done):
        path = out / _chunk_name(k)
        start, stop = k * chunk_points, min((k + 1) * chunk_points, n_points)
        n = stop - start
        hint = "delete it to recompute that chunk, or delete the folder to start afresh"
        try:
            with np.load(path, allow_pickle=False) as f:
                data = {key: f[key] for key in ("start", "stop", "points", "metric_names", "values", "status", "errors")}
        except Exception as err:  # noqa: BLE001  (zip, npy and key errors alike)
            raise ValueError(f"Chunk file {path} is unreadable or corrupted ({type(err).__name__}: {err}); {hint}.") from None
        problem = None
        if int(data["start"]) != start or int(data["stop"]) != stop:
            problem = f"it holds points {int(data['start'])}..{int(data['stop'])}, expected {start}..{stop}"
        elif list(data["metric_names"]) != list(metric_names):
            problem = f"its metrics {list(data['metric_names'])} differ from {list(metric_names)}"
        elif (data["values"].shape != (n, len(metric_names)) or data["status"].shape != (n,)
              or data["errors"].shape != (n,)):
            problem = (f"its arrays have shapes {data['values'].shape} and {data['status'].shape}, "
                       f"expected {(n, len(metric_names))} and {(n,)}")
        elif data["points"].shape != points[start:stop].shape or not np.array_equal(data["points"], points[start:stop]):
            problem = "its parameter values are not those of this sweep"
        if problem:
            raise ValueError(f"Chunk file {path} does not match the manifest: {problem}; {hint}.")
        values[start:stop] = data["values"]
        status[start:stop] = data["status"]
        errors[start:stop] = data["errors"].astype(object)


# ------------------------------------------------------------------------------ results


def _status_codes():
    codes = {int(item._value): name for name, item in RESULTS._name_to_item.items()}
    codes[RAISED] = "raised"
    return codes


def _result_message(code):
    """The first paragraph of a `RESULTS` code's message, on one line."""
    return " ".join(RESULTS._index_to_message[code].split("\n\n")[0].split())


def _failures(names, points, status, errors) -> list[dict]:
    """One record per failed member (status != 0): its flat index, parameter values, status
    code, result name and message (a `RAISED` member's error message)."""
    codes = _status_codes()
    return [
        {
            "index": int(i),
            "point": dict(zip(names, points[i].tolist())),
            "status": int(status[i]),
            "result": codes.get(int(status[i]), "unknown"),
            "message": str(errors[i]) if status[i] == RAISED else _result_message(int(status[i])),
        }
        for i in np.flatnonzero(status != _SUCCESS)
    ]


def _failure_report(records, n_points, limit=10):
    """The warning that lists failed members with their parameters."""
    lines = [
        f"  point {r['index']} ({', '.join(f'{n} = {v:.6g}' for n, v in r['point'].items())}): "
        f"{r['result']}: {r['message']}"
        for r in records[:limit]
    ]
    if len(records) > limit:
        lines.append(f"  ... and {len(records) - limit} more")
    return (
        f"sweep: {len(records)} of {n_points} members failed; their metrics are NaN (the "
        "Dataset attribute 'failures' lists them all):\n" + "\n".join(lines)
    )


def _dataset(names, axes, grid, shape, points, metric_names, values, status, errors, manifest):
    import xarray as xr

    if grid:
        dims = list(names)
        coords = {n: (n, a) for n, a in zip(names, axes)}
    else:
        dims = ["point"]
        coords = {"point": np.arange(points.shape[0])}
        coords.update({n: ("point", points[:, i]) for i, n in enumerate(names)})
    data = {m: (dims, values[:, i].reshape(shape)) for i, m in enumerate(metric_names)}
    data["status"] = (dims, status.reshape(shape).astype(np.int32))
    data["failed"] = (dims, status.reshape(shape) != _SUCCESS)
    settings = manifest["simulate"]
    attrs = {
        "description": "jaxbearing.sweep: metrics of one simulation per point (NaN where failed)",
        "parameters": json.dumps(list(names)),
        "grid": int(grid),
        "metrics": json.dumps(manifest["metrics"]),
        "t1": manifest["t1"],
        "t0": float(settings["t0"]),
        "ts": np.asarray(manifest["ts"], np.float64),
        "rtol": float(settings["rtol"]),
        "atol": float(settings["atol"]),
        "max_steps": int(settings["max_steps"]),
        "max_segments": int(settings["max_segments"]),
        "solver": str(settings["solver"]),
        "simulate_kwargs": json.dumps(settings),
        "model_fingerprint": manifest["model_fingerprint"],
        "model_parameters": json.dumps(manifest["model_parameters"]),
        "versions": json.dumps(manifest["versions"]),
        "status_codes": json.dumps(_status_codes()),
        "failures": json.dumps(_failures(names, points, status, errors)),
    }
    if "versions_at_start" in manifest:
        attrs["versions_at_start"] = json.dumps(manifest["versions_at_start"])
    ds = xr.Dataset(data, coords=coords, attrs=attrs)
    ds["status"].attrs["description"] = "jaxbearing.RESULTS code of the solve, 0 = successful"
    ds["failed"].attrs["description"] = "status != 0: the solve failed, its metrics are NaN"
    return ds


def _write_netcdf(ds, path):
    tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    ds.to_netcdf(tmp, engine="netcdf4")
    os.replace(tmp, path)


# ------------------------------------------------------------------------------ progress


class _Progress:
    """A tqdm bar over chunks (already-done chunks counted at start), or plain lines."""

    def __init__(self, total, initial, enabled):
        self.total, self.count, self.enabled = total, initial, enabled
        self.bar = None
        self.points = 0
        self.seconds = 0.0
        if not enabled:
            return
        try:
            from tqdm.auto import tqdm
        except ImportError:
            print(f"sweep: {initial}/{total} chunks done", flush=True)
            return
        self.bar = tqdm(total=total, initial=initial, unit="chunk", desc="sweep", dynamic_ncols=True)

    def update(self, points, seconds):
        self.count += 1
        self.points += points
        self.seconds += seconds
        if not self.enabled:
            return
        rate = self.points / self.seconds if self.seconds > 0 else float("nan")
        if self.bar is not None:
            self.bar.set_postfix_str(f"{rate:.2f} sim/s", refresh=False)
            self.bar.update(1)
        else:
            print(f"sweep: {self.count}/{self.total} chunks done ({rate:.2f} sim/s)", flush=True)

    def close(self):
        if self.bar is not None:
            self.bar.close()

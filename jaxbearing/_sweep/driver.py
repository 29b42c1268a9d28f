"""`sweep`: its stages in order (arguments, output folder, kernel, chunks, dataset)."""

from __future__ import annotations

import json
import math
import os
import time
import warnings
from collections.abc import Callable, Mapping
from pathlib import Path

import jax
import numpy as np

from .. import _checks
from ..metrics import AbstractMetric
from ..multibody import Mechanism
from . import arguments, dataset as _dataset, kernel, store
from .progress import Progress


def sweep(
    model: Mechanism,
    params: Mapping[str, object],
    *,
    metrics: Mapping[str, AbstractMetric | Callable] | None = None,
    grid: bool = True,
    t1: float = 0.2,
    ts=None,
    out: str | os.PathLike | None = None,
    chunk_size: int | None = None,
    progress: bool = True,
    **simulate_kwargs,
):
    """Simulate ``model`` at many parameter values and return labelled metrics (how it runs, the
    output folder and several hosts: `jaxbearing._sweep`'s doc).

    Args:
        model: a `Mechanism`; the swept parameters replace its values (`paths.replace`).
        params: dotted parameter path -> 1-D values, e.g. ``{"bearing.clearance": [2e-5, 4e-5],
            "impact.restitution": [0.7, 0.9]}``.
        metrics: name -> `metrics.AbstractMetric` (a built-in such as
            ``metrics.peak_ball_load.replace(bearing=1)``, `metrics.Peak`, `metrics.Mean`,
            `life.metric`; computed as ``metric.value(sol, model)`` with the member's own model)
            or a function of a `Solution` returning a scalar, which reads the output samples
            (`metrics.as_metric`) (default `jaxbearing.metrics.STANDARD`). Names must differ
            from the parameter paths and from ``status``, ``failed``, ``point``.
        grid: True: every combination of the values (dimensions in the order of ``params``;
            an axis's values must differ).
            False: a list of points, the i-th value of every parameter together (all arrays of
            one length; dimension ``point``).
        t1: final time [s] of every simulation.
        ts: output times [s] the metrics see. Default: just what the metrics need: ``[t0, t1]``
            when none reads the output samples (``reads_samples`` False: every metric of
            jaxbearing's, `metrics.Peak`, `metrics.Mean`, `life.metric`), else
            ``linspace(t0, t1, 2001)``.
        out: folder to write to and resume from (see the package doc), or None. One sweep
            writes a folder at a time (an advisory lock, ``fcntl.flock`` on its ``.sweep.lock``):
            while another process holds it, the same sweep waits, with a message on stderr, and
            then resumes from what the other wrote, computing only what is still missing; a
            different sweep (another manifest) is refused at once with a `ValueError`. A folder
            this process cannot write is refused with a `PermissionError` naming it before
            anything is computed, unless the sweep in it is finished: then it loads, and
            ``results.nc`` is rewritten only if it is missing or differs from the chunk files.
        chunk_size: points per device per chunk (default `default_chunk_size`: 32 on CPU; on
            accelerators 4096, or 65536 where members run as one loop; or the layout already
            in ``out``).
        progress: show a progress bar over chunks (tqdm, else plain lines).
        **simulate_kwargs: the solve's settings, as `simulate` takes them (``solver``,
            ``stepsize_controller``, ``max_steps``, ``options``); ``throw``, ``progress`` and
            ``adjoint`` are the sweep's. Each member runs the same integrator core: as
            `simulate_one_loop` (one while loop, the faster in batches) where nothing reads
            output samples, else as `simulate`; the metrics agree to the solver's accuracy.
            Without ``options.fatigue`` set, members record the life's integrals only where a
            metric reads them (``reads_fatigue``). The metrics' records are declared, and their
            window edges given as numbers (``peak_ball_load.replace(t_min=0.09)``,
            `life.metric`'s ``t_min``: `metrics.AbstractMetric.edges`) that are not stops of
            the solve are added to ``options.window_edges``, so that the metrics are exact
            (`metrics.solve_options`).

    Returns:
        `xarray.Dataset` with one variable per metric, ``status`` (int32, a `RESULTS` code, 0 =
        successful, or `RAISED`, or `NOT_FINITE` where the solve succeeded but a metric is NaN
        or infinite; ``attrs["status_codes"]`` names them) and ``failed`` (bool). Grid: one
        dimension and coordinate per parameter. List: dimension ``point``, the parameters as
        coordinates along it. Attributes record t1, t0, ts, the tolerances and solver, every
        model parameter (``model_parameters``), the model fingerprint, the package versions
        (``versions``) and the failed members with their parameters (``failures``); the
        returned object also carries timing of this call (``sweep_computed_points``,
        ``sweep_wall_s``, ``sweep_chunk_s``), which is not written to ``results.nc``.
    """
    import xarray as xr  # noqa: F401  (fail early with a clear ImportError)

    _checks.require_x64()
    started = time.perf_counter()
    model = _checks.float_leaves(model)  # a Python float set by eqx.tree_at compiles nothing
    request = arguments.request(model, params, metrics, grid, t1, ts, simulate_kwargs)
    out = None if out is None else Path(out)
    n_devices = jax.device_count()
    n_points = request.points.shape[0]
    chunk_points = arguments.chunk_points(chunk_size, n_devices, n_points, request.solve)
    record = store.manifest(model, request)
    metric_names = [name for name, _ in request.metric_items]
    with store.Folder(out) as folder:  # locked from here to the end (process 0)
        state = store.restore(folder, record, chunk_size, chunk_points, n_devices, request.points,
                              metric_names)  # fmt: skip
        mesh = jax.make_mesh((n_devices,), (kernel.AXIS,), axis_types=(jax.sharding.AxisType.Auto,))
        padded = arguments.padded_rows(state.chunk_points, n_devices)
        runner = kernel.ChunkRunner(model, request, mesh, padded)
        computed, chunk_seconds = _compute(runner, request, state, out, metric_names, progress)
        ds = _dataset.dataset(request, state, record)
        _finish(ds, folder, n_points, computed)
    ds.attrs["sweep_computed_points"] = computed
    ds.attrs["sweep_wall_s"] = time.perf_counter() - started
    ds.attrs["sweep_chunk_s"] = np.asarray(chunk_seconds)
    return ds


def _compute(runner, request, state, out, metric_names, progress):
    """Run every chunk not done yet, writing each as it finishes (process 0); returns (points
    computed, seconds per chunk)."""
    points, n_points = request.points, request.points.shape[0]
    main = jax.process_index() == 0
    n_chunks = math.ceil(n_points / state.chunk_points)
    bar = Progress(n_chunks, int(state.done.sum()), enabled=progress and main)
    chunk_seconds, computed = [], 0
    try:
        for k in np.flatnonzero(~state.done):
            tic = time.perf_counter()
            start, stop = k * state.chunk_points, min((k + 1) * state.chunk_points, n_points)
            values, status, errors = _run_one(runner, k, points[start:stop])
            status, errors = _dataset.flag_not_finite(metric_names, values, status, errors)
            state.values[start:stop], state.status[start:stop], state.errors[start:stop] = values, status, errors
            if out is not None and main:
                store.save_chunk(out / store.chunk_name(k), start, stop, points[start:stop], metric_names,
                                 values, status, errors)  # fmt: skip
            state.done[k] = True
            computed += stop - start
            chunk_seconds.append(time.perf_counter() - tic)
            bar.update(stop - start, chunk_seconds[-1])
    finally:
        bar.close()
    return computed, chunk_seconds


def _run_one(runner, k, chunk):
    """(values, status, errors) of chunk ``k``; a chunk that raises at run time is rerun point
    by point (in a single process)."""
    try:
        values, status = runner(chunk)
        return values, status, np.full(chunk.shape[0], "")
    except kernel.RUNTIME_ERRORS as err:
        if jax.process_count() > 1:  # the processes would no longer run the same program
            raise
        warnings.warn(
            f"sweep: chunk {k} raised an error at run time ({kernel.first_line(err)}); "
            "running its points one at a time to find the culprit(s).",
            RuntimeWarning,
            stacklevel=4,
        )
        return runner.one_by_one(chunk)


def _finish(ds, folder, n_points, computed):
    """Write ``results.nc`` unless it holds ``ds`` already and nothing was computed (a finished
    sweep loads from a read-only folder), and warn about the failed members (process 0)."""
    if jax.process_index() != 0:
        return
    if folder.path is not None:
        path = folder.path / store.RESULTS_FILE
        if computed or not _dataset.holds(path, ds):
            if not folder.writable:
                why = f"{path.name} must be written (it is missing or differs from the chunk files)"
                raise store.not_writable(folder.path, folder.problem, why)
            _dataset.write_results(ds, path)
    failed = json.loads(ds.attrs["failures"])
    if failed:
        warnings.warn(_dataset.failure_report(failed, n_points), RuntimeWarning, stacklevel=3)

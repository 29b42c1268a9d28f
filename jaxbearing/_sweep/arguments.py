"""The sweep's arguments, checked and resolved before anything runs: parameters and points,
metrics (`metrics.AbstractMetric`s, which say what they need of the solve), simulate's
settings, output times, chunk size."""

from __future__ import annotations

import dataclasses
import inspect
import math
from collections.abc import Mapping
from typing import NamedTuple

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

# the package's public names (bound in jaxbearing/__init__.py before it imports the sweep)
from .. import _checks, metrics as _metrics, paths
from ..multibody import Mechanism
from ..simulation import default_controller, default_max_segments, default_solver
from ..simulation import simulate, simulate_one_loop
from ..solve import checked_controller, checked_solver, checked_span, checked_ts, window_stops
from ..simulation import SEGMENT_STEPS, _checked_options

DEFAULT_CHUNK_SIZE_CPU = 32  # points per CPU device per chunk (docs/performance.md)
DEFAULT_CHUNK_SIZE_ACCELERATOR = {"segments": 4096, "one_loop": 65536}  # a GPU, by solve (docs/performance.md)
DEFAULT_SAMPLES = 2001  # output times when ts is not given and a metric reads the samples
RESERVED = ("status", "failed", "point", "max_drift")
NOT_FORWARDED = ("throw", "progress", "adjoint")  # simulate arguments that sweep sets itself
SOLVES = {"segments": simulate, "one_loop": simulate_one_loop}  # what a member's solve calls

class Request(NamedTuple):
    """A checked sweep: ``points`` (n_points, n_params) in the order of ``names``; ``shape``
    of the result (the grid's, or (n_points,)); ``metric_items`` ((name, fn), ...); times [s]."""

    names: tuple[str, ...]
    axes: list[np.ndarray]
    grid: bool
    points: np.ndarray
    shape: tuple[int, ...]
    metric_items: tuple[tuple[str, _metrics.AbstractMetric], ...]
    t0: float
    t1: float
    ts: np.ndarray
    sim_kwargs: dict
    solve: str  # a key of `SOLVES`


def request(model, params, metrics, grid, t1, ts, simulate_kwargs) -> Request:
    """Check every argument of `jaxbearing.sweep` (ValueError/TypeError naming the fix)."""
    if not isinstance(model, Mechanism):
        raise TypeError(f"sweep needs a jaxbearing Mechanism, got {type(model).__name__}.")
    names, axes = parameters(model, params)
    points, shape = grid_points(names, axes, grid)
    items = metric_items(metrics, names)
    solve = driver_of(items, ts)
    sim_kwargs = simulate_kwargs_of(simulate_kwargs)
    options = _checked_options(sim_kwargs.get("options"))
    t0, t1 = (float(t) for t in checked_span(options.t0, t1))
    window_stops(options.window_edges, model.window_start)
    fixed_start = None if "window_start" in names else model.window_start  # a stop, unless swept
    options = _metrics.solve_options(options, [m for _, m in items], t1, fixed_start)
    if options.fatigue is None:
        options = dataclasses.replace(options, fatigue=any(m.reads_fatigue for _, m in items))
    if solve == "segments" and options.max_segments is None:  # resolved here, so that the manifest records it
        segments = default_max_segments(model, t0, t1, options.segment_steps or SEGMENT_STEPS)
        options = dataclasses.replace(options, max_segments=segments)
    sim_kwargs["options"] = options
    check_points(model, names, points, t0)
    ts = output_times(items, t0, t1, ts)
    start = model.window_start
    if metrics is None and start is not None and t1 <= float(start):
        raise ValueError(
            f"The standard metrics read the model's window from t = {float(start):g} s "
            f"(model.window_start), which t1 = {t1} s does not reach: simulate longer, or pass "
            "metrics with an earlier t_min (e.g. jb.metrics.peak_ball_load.replace(t_min=None))."
        )
    return Request(names, axes, bool(grid), points, shape, items, t0, t1, ts, sim_kwargs, solve)


def driver_of(items, ts) -> str:
    """How the members run (`SOLVES`): "one_loop" (`simulate_one_loop`, the faster in batches)
    where no output times are asked for and no metric reads the samples, else "segments"
    (`simulate`). Both repeat the same integrator core."""
    if ts is None and not any(m.reads_samples for _, m in items):
        return "one_loop"
    return "segments"


def parameters(model, params):
    """(names, 1-D float64 values) of the swept parameters, each a scalar array leaf."""
    if not isinstance(params, Mapping) or not params:
        raise ValueError(
            "params must be a non-empty mapping of parameter paths to values, e.g. "
            '{"bearing.clearance": [2e-5, 4e-5]}.'
        )
    names, axes = [], []
    for name, raw in params.items():
        if not isinstance(name, str):
            raise TypeError(f"Parameter names must be dotted paths (str); got {name!r}.")
        if name in RESERVED:
            raise ValueError(f"{name!r} cannot be a parameter name (reserved for the results).")
        paths.scalar_leaf(model, name, "to be swept")
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


def grid_points(names, axes, grid):
    """(points, result shape): every combination (grid) or the i-th values together (list)."""
    if grid:
        for name, a in zip(names, axes):
            values, counts = np.unique(a[np.isfinite(a)], return_counts=True)  # NaN: check_points
            if (counts > 1).any():
                raise ValueError(
                    f"{name} repeats {values[counts > 1].tolist()}: the values of a grid axis label "
                    "its results and must differ (grid=False takes a list of points, repeats allowed)."
                )
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


def metric_items(metrics, names):
    """((name, `metrics.AbstractMetric`), ...) of the metrics (default `metrics.STANDARD`; a
    function of a Solution: `metrics.as_metric`), then ``max_drift``."""
    metrics = _metrics.STANDARD if metrics is None else metrics
    if not isinstance(metrics, Mapping) or not metrics:
        raise ValueError(
            "metrics must be a non-empty mapping of names to metrics (jaxbearing.metrics."
            "AbstractMetric, e.g. jb.metrics.peak_ball_load.replace(bearing=1)) or functions of "
            "a Solution."
        )
    items = []
    for name, metric in metrics.items():
        if not isinstance(name, str):
            raise TypeError(f"metrics maps names (str) to metrics; got the name {name!r}.")
        if name in RESERVED or name in names:
            raise ValueError(
                f"Metric name {name!r} collides with a parameter or a reserved name {RESERVED}."
            )
        items.append((name, _metrics.as_metric(metric, f"metrics[{name!r}]")))
    return (*items, ("max_drift", _metrics.max_drift))  # every member's, whatever was asked


def output_times(items, t0, t1, ts) -> np.ndarray:
    """``ts`` as given, else just what the metrics need: [t0, t1] when none reads the samples,
    else `DEFAULT_SAMPLES` equally spaced times."""
    if ts is None:
        dense = any(m.reads_samples for _, m in items)
        return np.linspace(t0, t1, DEFAULT_SAMPLES if dense else 2)
    return np.asarray(checked_ts(ts, t0, t1))


def simulate_kwargs_of(kwargs):
    """The keyword arguments forwarded to the solve, sorted: `simulate`'s that both drivers
    take; TypeError for others, and for a solver that is not one (`solve.checked_solver`)."""
    name = simulate.__name__
    accepted = set(_simulate_parameters("one_loop")) - {"model", "t1"}
    for key in kwargs:
        if key in NOT_FORWARDED:
            raise TypeError(f"sweep sets {name}'s {key!r} itself; do not pass it.")
        if key not in accepted:
            raise TypeError(
                f"sweep got an unexpected keyword {key!r}; it forwards only {name}'s "
                f"{sorted(accepted - set(NOT_FORWARDED))}."
            )
    if kwargs.get("solver") is not None:
        checked_solver(kwargs["solver"])
    return dict(sorted(kwargs.items()))


def resolved_settings(sim_kwargs, solve="segments"):
    """The solve's settings with defaults filled in, flat (for the manifest and attributes):
    `simulate`'s keywords (or `simulate_one_loop`'s, with ``max_segments`` 0), the controller's ``rtol`` and ``atol``, and every field of its
    `SolveOptions`."""
    settings = {}
    for name, p in _simulate_parameters(solve).items():
        if p.kind is not inspect.Parameter.KEYWORD_ONLY or name in NOT_FORWARDED + ("options",):
            continue
        settings[name] = sim_kwargs.get(name, p.default)
    if settings.get("solver") is None:
        settings["solver"] = default_solver()
    controller = settings.get("stepsize_controller")
    controller = default_controller() if controller is None else checked_controller(controller)
    settings["stepsize_controller"] = type(controller).__name__
    settings["rtol"] = getattr(controller, "rtol", None)
    settings["atol"] = getattr(controller, "atol", None)
    options = _checked_options(sim_kwargs.get("options"))
    settings.update({f.name: getattr(options, f.name) for f in dataclasses.fields(options)})
    if settings["dt0"] is None:  # recorded only when set: older folders stay resumable
        del settings["dt0"]
    if settings.get("max_segments") is None:
        settings["max_segments"] = 0
    return dict(sorted(settings.items()))


def _simulate_parameters(solve="segments"):
    return inspect.signature(SOLVES[solve]).parameters


def check_points(model, names, points, t0=0.0):
    """Raise a ValueError for the first point whose values break a parameter rule (the initial
    state's rules at ``t0`` [s])."""
    index, messages = _broken_rules(model, names, jnp.asarray(points), t0)
    index = np.asarray(index)
    bad = np.flatnonzero(index >= 0)
    if bad.size:
        i = bad[0]
        where = ", ".join(f"{n} = {v:.6g}" for n, v in zip(names, points[i]))
        raise ValueError(
            f"Sweep point {i} ({where}) is invalid: {messages[index[i]]}. "
            f"{bad.size} of {points.shape[0]} points break a rule."
        )


@eqx.filter_jit
def _broken_rules(model, names, points, t0):
    """The index of each point's first broken rule (`_checks.first_broken`, -1: none) and the
    rules' messages."""

    def one(row):
        m = paths.replace(model, dict(zip(names, row)))
        return _checks.first_broken(m.violations(jnp, t0))[0]

    return jax.vmap(one)(points), _checks.messages(model.violations(jnp, t0))


def default_chunk_size(platform: str | None = None, solve: str = "segments") -> int:
    """Points per device per chunk when ``chunk_size`` is not given: 32 on CPU devices; on
    accelerators 4096 for members run as `simulate` and 65536 as `simulate_one_loop` (``solve``
    "one_loop", `driver_of`), whose members cost
    little more an iteration in larger batches until the device fills (measured:
    docs/performance.md)."""
    platform = jax.devices()[0].platform if platform is None else platform
    return DEFAULT_CHUNK_SIZE_CPU if platform == "cpu" else DEFAULT_CHUNK_SIZE_ACCELERATOR[solve]


def padded_rows(chunk_points, n_devices) -> int:
    """Rows a chunk of ``chunk_points`` points runs as: a multiple of the device count (the
    padding repeats the last point)."""
    return math.ceil(chunk_points / n_devices) * n_devices


def chunk_points(chunk_size, n_devices, n_points, solve="segments") -> int:
    """Points per chunk: ``chunk_size`` (default `default_chunk_size` of ``solve``) per device,
    but a small sweep is never padded beyond one round of the devices."""
    if chunk_size is not None and (
        isinstance(chunk_size, bool) or int(chunk_size) != chunk_size or chunk_size < 1
    ):
        raise ValueError(f"chunk_size must be a positive integer; got {chunk_size!r}.")
    per_device = default_chunk_size(solve=solve) if chunk_size is None else int(chunk_size)
    return max(1, min(per_device * n_devices, math.ceil(n_points / n_devices) * n_devices))

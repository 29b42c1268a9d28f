"""The sweep's result: the labelled `xarray.Dataset`, its ``results.nc``, and the report of the
failed members with their parameters."""

from __future__ import annotations

import json

import numpy as np

from .. import _files
from ..solution import RESULTS
from .kernel import NOT_FINITE, RAISED, SUCCESS

NOT_FINITE_HINT = (
    "a metric is NaN when its window starts or ends at a time the solve did not stop at (add "
    "that time to SolveOptions(window_edges=...)), holds none of the solved span or ends after t1"
)


def status_codes():
    """{code: name} of every status a member can have (`RESULTS`, `RAISED`, `NOT_FINITE`)."""
    codes = {int(item._value): name for name, item in RESULTS._name_to_item.items()}
    codes[RAISED] = "raised"
    codes[NOT_FINITE] = "metric_not_finite"
    return codes


def flag_not_finite(metric_names, values, status, errors):
    """(status, errors) with every member whose solve succeeded but whose metric ``values``
    (n, n_metrics) hold NaN or infinity marked `NOT_FINITE`, its error naming those metrics."""
    status, errors = status.copy(), np.asarray(errors, dtype=object).copy()
    for i in np.flatnonzero((status == SUCCESS) & ~np.isfinite(values).all(axis=1)):
        bad = [f"{n} = {v}" for n, v in zip(metric_names, values[i]) if not np.isfinite(v)]
        status[i] = NOT_FINITE
        errors[i] = f"{', '.join(bad)}: {NOT_FINITE_HINT}"
    return status, errors


def _result_message(code):
    """The first paragraph of a `RESULTS` code's message, on one line."""
    return " ".join(RESULTS._index_to_message[code].split("\n\n")[0].split())


def failures(names, points, status, errors) -> list[dict]:
    """One record per failed member (status != 0): its flat index, parameter values, status
    code, result name and message (for `RAISED` and `NOT_FINITE` its ``errors`` entry)."""
    codes = status_codes()
    return [
        {
            "index": int(i),
            "point": dict(zip(names, points[i].tolist())),
            "status": int(status[i]),
            "result": codes.get(int(status[i]), "unknown"),
            "message": (str(errors[i]) if status[i] in (RAISED, NOT_FINITE)
                        else _result_message(int(status[i]))),  # fmt: skip
        }
        for i in np.flatnonzero(status != SUCCESS)
    ]


def failure_report(records, n_points, limit=10):
    """The warning that lists failed members with their parameters."""
    lines = [
        f"  point {r['index']} ({', '.join(f'{n} = {v:.6g}' for n, v in r['point'].items())}): "
        f"{r['result']}: {r['message']}"
        for r in records[:limit]
    ]
    if len(records) > limit:
        lines.append(f"  ... and {len(records) - limit} more")
    return (
        f"sweep: {len(records)} of {n_points} members failed; the metrics of a failed solve are "
        "NaN (the Dataset attribute 'failures' lists them all):\n" + "\n".join(lines)
    )


def dataset(request, state, record):
    """The `xarray.Dataset` of a finished sweep (see `jaxbearing.sweep`'s Returns)."""
    import xarray as xr

    names, points, shape = request.names, request.points, request.shape
    if request.grid:
        dims = list(names)
        coords = {n: (n, a) for n, a in zip(names, request.axes)}
    else:
        dims = ["point"]
        coords = {"point": np.arange(points.shape[0])}
        coords.update({n: ("point", points[:, i]) for i, n in enumerate(names)})
    data = {m: (dims, state.values[:, i].reshape(shape)) for i, (m, _) in enumerate(request.metric_items)}
    data["status"] = (dims, state.status.reshape(shape).astype(np.int32))
    data["failed"] = (dims, state.status.reshape(shape) != SUCCESS)
    ds = xr.Dataset(data, coords=coords, attrs=_attributes(request, state, record))
    ds["status"].attrs["description"] = "jaxbearing.RESULTS code of the solve, 0 = successful"
    ds["failed"].attrs["description"] = (
        "status != 0: the solve failed or raised (its metrics are NaN), or a metric is NaN or "
        "infinite (metric_not_finite; the other metrics are kept)"
    )
    return ds


def _attributes(request, state, record):
    settings = record["simulate"]
    attrs = {
        "description": "jaxbearing.sweep: metrics of one simulation per point (NaN where failed)",
        "parameters": json.dumps(list(request.names)),
        "grid": int(request.grid),
        "metrics": json.dumps(record["metrics"]),
        "t1": record["t1"],
        "t0": float(settings["t0"]),
        "ts": np.asarray(record["ts"], np.float64),
        "rtol": float(settings["rtol"]),
        "atol": float(settings["atol"]),
        "max_steps": int(settings["max_steps"]),
        "max_segments": int(settings["max_segments"]),
        "solver": str(settings["solver"]),
        "solve": request.solve,  # how the members ran: "one_loop" or "segments" (`driver_of`)
        "simulate_kwargs": json.dumps(settings),
        "model_fingerprint": record["model_fingerprint"],
        "model_parameters": json.dumps(record["model_parameters"]),
        "versions": json.dumps(record["versions"]),
        "status_codes": json.dumps(status_codes()),
        "failures": json.dumps(failures(request.names, request.points, state.status, state.errors)),
    }
    if "versions_at_start" in record:
        attrs["versions_at_start"] = json.dumps(record["versions_at_start"])
    return attrs


VERSION_ATTRS = ("versions", "versions_at_start")  # the package versions of the call


def holds(path, ds) -> bool:
    """Whether the netCDF file ``path`` holds ``ds``: its data, coordinates and attributes, the
    package versions of this call aside (False when missing or unreadable)."""
    import xarray as xr

    try:
        with xr.open_dataset(path, engine="netcdf4") as saved:
            saved = saved.load()
    except (OSError, ValueError):
        return False
    return _without_versions(saved).identical(_without_versions(ds))


def _without_versions(ds):
    ds = ds.copy()
    ds.attrs = {k: v for k, v in ds.attrs.items() if k not in VERSION_ATTRS}
    return ds


def write_results(ds, path):
    """Write ``ds`` as netCDF to ``path``, atomically."""
    with _files.atomic_path(path) as tmp:
        ds.to_netcdf(tmp, engine="netcdf4")

"""The sweep's result: the labelled `xarray.Dataset`, its ``results.nc``, and the report of the
failed members with their parameters."""

from __future__ import annotations

import json

import numpy as np

from .. import _files
from ..solution import RESULTS
from .kernel import RAISED, SUCCESS


def status_codes():
    """{code: name} of every status a member can have (`RESULTS` and `RAISED`)."""
    codes = {int(item._value): name for name, item in RESULTS._name_to_item.items()}
    codes[RAISED] = "raised"
    return codes


def _result_message(code):
    """The first paragraph of a `RESULTS` code's message, on one line."""
    return " ".join(RESULTS._index_to_message[code].split("\n\n")[0].split())


def failures(names, points, status, errors) -> list[dict]:
    """One record per failed member (status != 0): its flat index, parameter values, status
    code, result name and message (a `RAISED` member's error message)."""
    codes = status_codes()
    return [
        {
            "index": int(i),
            "point": dict(zip(names, points[i].tolist())),
            "status": int(status[i]),
            "result": codes.get(int(status[i]), "unknown"),
            "message": str(errors[i]) if status[i] == RAISED else _result_message(int(status[i])),
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
        f"sweep: {len(records)} of {n_points} members failed; their metrics are NaN (the "
        "Dataset attribute 'failures' lists them all):\n" + "\n".join(lines)
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
    ds["failed"].attrs["description"] = "status != 0: the solve failed, its metrics are NaN"
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


def write_results(ds, path):
    """Write ``ds`` as netCDF to ``path``, atomically."""
    with _files.atomic_path(path) as tmp:
        ds.to_netcdf(tmp, engine="netcdf4")

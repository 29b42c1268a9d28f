"""CSV time series and strict JSON, each written atomically (`jaxbearing._files`)."""

from __future__ import annotations

import io
import json
import math
from collections.abc import Mapping
from pathlib import Path

import numpy as np

from .. import _files
from ._series import as_series, unit


def _json_ready(x):
    if isinstance(x, Mapping):
        return {str(k): _json_ready(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [_json_ready(v) for v in x]
    if isinstance(x, np.ndarray):
        return _json_ready(x.tolist())
    if isinstance(x, np.generic):
        x = x.item()
    if isinstance(x, float) and not math.isfinite(x):
        return None  # strict JSON has no NaN/inf
    return x


def write_json(path, obj) -> Path:
    """Write ``obj`` as indented strict JSON (NaN and inf become null), atomically."""
    _files.write_text(path, json.dumps(_json_ready(obj), indent=2) + "\n")
    return Path(path)


def csv_columns(data) -> list[str]:
    """CSV column names: series names with their unit as a suffix (``t_s``, ``slider_x_m``,
    ``slider_v_m/s`` is written ``slider_v_m_per_s``, ``ball1_N``, ...)."""
    data = as_series(data)
    return [f"{k}_{unit(k).replace('/', '_per_')}" for k in data]


def write_csv(path, data, stride: int = 1) -> Path:
    """Write the series of ``data`` (a `Solution` or `series` dict) as CSV, one header row of
    `csv_columns`, every ``stride``-th sample (the last sample always included), atomically."""
    data = as_series(data)
    n = data["t"].size
    rows = np.unique(np.append(np.arange(0, n, max(1, int(stride))), n - 1))
    table = np.column_stack([np.asarray(v, dtype=float)[rows] for v in data.values()])
    text = io.StringIO()
    np.savetxt(text, table, delimiter=",", fmt="%.10g", header=",".join(csv_columns(data)), comments="")
    _files.write_text(path, text.getvalue())
    return Path(path)

"""The sweep's output folder: the manifest (what the sweep is), one atomic ``chunk_XXXXX.npz``
per finished chunk, and the resume step that checks the folder and loads what is done (on
process 0, broadcast to the others)."""

from __future__ import annotations

import dataclasses
import errno
import fcntl
import hashlib
import io
import json
import math
import os
import re
import socket
import sys
import tempfile
import warnings
from pathlib import Path

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from .. import _files, paths, provenance
from .arguments import resolved_settings
from .dataset import flag_not_finite
from .fingerprint import labelled, without_address as _no_address

MANIFEST = "manifest.json"
RESULTS_FILE = "results.nc"
LOCK_FILE = ".sweep.lock"  # flock'ed by the process that writes the folder; holds its pid and host
FORMAT_VERSION = 4  # 3: max_drift, metrics.Peak and Mean; 4: metrics named by their labels
SWEPT = "swept"  # the value of a swept parameter in the manifest's model_parameters
NOT_RUN = -99  # status placeholder of a point not computed yet, never returned
_NOT_COMPARED = ("versions", "chunk_points")
_MISSING = "(missing)"
_CHUNK_KEYS = ("start", "stop", "points", "metric_names", "values", "status", "errors")


def manifest(model, request):
    """What the sweep is, as JSON reads it back (see the package doc, 'Output folder')."""
    names = request.names
    record = {
        "format": FORMAT_VERSION,
        "parameters": {n: a.tolist() for n, a in zip(names, request.axes)},
        "grid": request.grid,
        "shape": list(request.shape),
        "metrics": {name: labelled(metric) for name, metric in request.metric_items},
        "t1": request.t1,
        "ts": np.asarray(request.ts).tolist(),
        "simulate": {
            k: _jsonable(v) for k, v in resolved_settings(request.sim_kwargs, request.solve).items()
        },
        "model_fingerprint": _fingerprint(model, names),
        "model_parameters": provenance.parameters(paths.replace(model, {n: SWEPT for n in names})),
        "chunk_points": None,  # set once the folder is opened
        "versions": provenance.versions(),
    }
    if request.solve != "segments":  # recorded only then: older folders stay resumable
        record["solve"] = request.solve
    return json.loads(json.dumps(record))


class Folder:
    """The output folder ``out`` (None: no folder) and this process's hold on it: `acquire`
    (process 0) creates it, checks that it is writable and takes its lock; leaving the ``with``
    block releases the lock (so does the end of the process, however it ends)."""

    def __init__(self, out):
        self.path = None if out is None else Path(out)
        self.problem = None  # why this process may not create files in it (`acquire` checks)
        self._fd = None

    @property
    def writable(self) -> bool:
        return self.problem is None

    def __enter__(self):
        return self

    def __exit__(self, *exc_info):
        if self._fd is not None:
            os.close(self._fd)  # releases the flock
            self._fd = None

    def acquire(self, record):
        """Create the folder, check that it is writable and lock it: one sweep writes a folder
        at a time. When another process holds the lock, a different sweep (another manifest)
        is refused at once, the same one waits (a message on stderr) and then resumes from
        what the other wrote."""
        if self.path is None:
            return
        try:
            self.path.mkdir(parents=True, exist_ok=True)
        except OSError as err:
            raise not_writable(self.path, err.strerror, "it cannot be created") from None
        self.problem = _write_problem(self.path)
        lock = self.path / LOCK_FILE
        self._fd, named = _open_lock(lock, self.writable)
        if self._fd is None:  # a read-only folder without a lock file: nobody writes it
            return
        try:
            fcntl.flock(self._fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            self._wait(record)
        except OSError as err:  # a file system without locks
            if err.errno not in (errno.ENOLCK, errno.EOPNOTSUPP, errno.ENOSYS):
                raise
            warnings.warn(f"sweep: cannot lock {lock} ({err.strerror}): nothing stops another "
                          "sweep from writing this folder at the same time.", RuntimeWarning,
                          stacklevel=4)  # fmt: skip
        if named:  # who holds it, for the message of a process that waits
            os.ftruncate(self._fd, 0)
            os.pwrite(self._fd, f"pid {os.getpid()} on {socket.gethostname()}\n".encode(), 0)

    def _wait(self, record):
        """Wait for the lock that another process holds; a different sweep is refused first."""
        if (self.path / MANIFEST).exists():
            _check_same(_read_manifest(self.path / MANIFEST, self.path), record, self.path)
        holder = os.pread(self._fd, 200, 0).decode(errors="replace").strip() or "another process"
        print(f"sweep: {self.path} is being written by another sweep ({holder}); waiting for it "
              "to finish, then resuming from what it wrote (Ctrl-C stops).",
              file=sys.stderr, flush=True)  # fmt: skip
        fcntl.flock(self._fd, fcntl.LOCK_EX)
        print(f"sweep: {self.path} is free; going on.", file=sys.stderr, flush=True)


def _open_lock(path, writable):
    """(descriptor of the lock file ``path``, whether it is open for writing): created in a
    ``writable`` folder; else, or where the file is read-only, opened for reading (`flock`
    locks it all the same); (None, False) where it does not exist and cannot be created."""
    if writable:
        try:
            return os.open(path, os.O_RDWR | os.O_CREAT, 0o666), True
        except PermissionError:
            pass
    try:
        return os.open(path, os.O_RDONLY), False
    except FileNotFoundError:
        return None, False


def _write_problem(out):
    """None when this process may create files in the folder ``out``, else why not."""
    try:
        with tempfile.TemporaryFile(dir=out):
            return None
    except OSError as err:
        if err.errno in (errno.EACCES, errno.EPERM, errno.EROFS):
            return err.strerror
        raise


def not_writable(out, problem, what):
    """The error for a folder that this process cannot write."""
    return PermissionError(
        f"The sweep folder {out} is not writable ({problem}) and {what}: make it writable, or use "
        "another `out` (a copy of the folder keeps what is done)."
    )


@dataclasses.dataclass
class State:
    """What is done: ``chunk_points`` per chunk, ``done`` per chunk, and per point ``values``
    (n_points, n_metrics), ``status`` and ``errors`` (NaN, `NOT_RUN` and "" until computed)."""

    chunk_points: int
    done: np.ndarray | None
    values: np.ndarray
    status: np.ndarray
    errors: np.ndarray


def restore(folder, record, chunk_size, chunk_points, n_devices, points, metric_names) -> State:
    """Lock and check the `Folder` and load the chunks already written (process 0), then share
    that with the other processes; every process returns the same `State`. Sets
    ``record["chunk_points"]`` (and ``versions_at_start`` when the stored versions differ)."""
    out = folder.path
    n_points = points.shape[0]
    state = State(
        chunk_points=chunk_points,
        done=None,
        values=np.full((n_points, len(metric_names)), np.nan),
        status=np.full((n_points,), NOT_RUN, np.int32),
        errors=np.full((n_points,), "", dtype=object),
    )
    error = None
    if jax.process_index() == 0:
        try:
            folder.acquire(record)
            state.chunk_points, state.done, stored_versions = _open_out(
                folder, record, chunk_size, chunk_points, n_devices
            )
            if stored_versions is not None and stored_versions != record["versions"]:
                warnings.warn(_versions_changed(out, stored_versions, record["versions"]),
                              RuntimeWarning, stacklevel=3)  # fmt: skip
                record["versions_at_start"] = stored_versions
            if out is not None:
                load_chunks(out, state, points, metric_names)
        except Exception as err:  # noqa: BLE001  (re-raised below, after telling the others)
            error = err
    if jax.process_count() > 1:
        _share(state, error, n_points)
    elif error is not None:
        raise error
    record["chunk_points"] = state.chunk_points
    # chunk files of earlier versions may hold a NaN metric as a success
    state.status, state.errors = flag_not_finite(metric_names, state.values, state.status,
                                                 state.errors)  # fmt: skip
    return state


def _share(state, error, n_points):
    """Process 0's folder check and loaded chunks, broadcast to every process."""
    from jax.experimental import multihost_utils

    failed_there = multihost_utils.broadcast_one_to_all(np.int32(error is not None))
    if int(failed_there):
        if error is not None:
            raise error
        raise RuntimeError("sweep failed on process 0; its error message says why.")
    state.chunk_points = int(multihost_utils.broadcast_one_to_all(np.int64(state.chunk_points)))
    if state.done is None:
        state.done = np.zeros(math.ceil(n_points / state.chunk_points), bool)
    done, values, status = multihost_utils.broadcast_one_to_all(
        (state.done.astype(np.int32), state.values, state.status)
    )
    state.done, state.values, state.status = np.asarray(done) != 0, np.array(values), np.array(status)


def _open_out(folder, record, chunk_size, chunk_points, n_devices):
    """Start or check the locked `Folder`; returns (points per chunk, done mask, the package
    versions of the stored manifest or None). A folder this process cannot write is refused
    unless the sweep in it is complete (every chunk written)."""
    n_points = int(np.prod(record["shape"]))
    out = folder.path
    if out is None:
        return chunk_points, np.zeros(math.ceil(n_points / chunk_points), bool), None
    path = out / MANIFEST
    chunks = sorted(out.glob("chunk_*.npz"))
    stored_versions = None
    if path.exists():
        old = _read_manifest(path, out)
        _check_same(old, record, out)
        chunk_points = _stored_chunk_points(old, path, out, chunk_size, chunk_points, n_devices)
        stored_versions = old.get("versions", {})
    elif chunks:
        raise ValueError(
            f"{out} holds chunk files but no {MANIFEST}: they cannot be matched to this "
            "sweep. Delete them or use another `out` folder."
        )
    elif not folder.writable:
        raise not_writable(out, folder.problem, f"holds no {MANIFEST} to load")
    else:
        _files.write_text(path, json.dumps(dict(record, chunk_points=chunk_points), indent=1))
    n_chunks = math.ceil(n_points / chunk_points)
    done = np.array([(out / chunk_name(k)).exists() for k in range(n_chunks)], bool)
    extra = [p.name for p in chunks if not re.fullmatch(r"chunk_\d{5,}\.npz", p.name)
             or int(p.stem.split("_")[1]) >= n_chunks]  # fmt: skip
    if extra:
        raise ValueError(f"{out} holds chunk files this sweep does not have: {extra}; delete them.")
    if not folder.writable and not done.all():
        raise not_writable(out, folder.problem, f"{int((~done).sum())} of {n_chunks} chunks "
                            "are still to compute")  # fmt: skip
    if folder.writable:
        _remove_leftovers(out)
    return chunk_points, done, stored_versions


def _remove_leftovers(out):
    """Delete the temporary files of this sweep's own files (`_files.atomic_path`) that an
    interrupted write left. Safe under the folder's lock: the process that holds it is the
    only sweep writing here, so such a file belongs to a process that has ended."""
    for name in ("chunk_*.npz", MANIFEST, RESULTS_FILE):
        for tmp in out.glob(f".{name}.*.tmp"):
            tmp.unlink(missing_ok=True)


def _read_manifest(path, out):
    try:
        return json.loads(path.read_text())
    except (OSError, ValueError) as err:
        raise ValueError(
            f"{path} is unreadable ({err}); delete the folder {out} or use another `out`."
        ) from None


def _check_same(old, record, out):
    differ = [k for k in record if k not in _NOT_COMPARED and old.get(k) != record[k]]
    differ += [k for k in old if k not in record]
    if differ:
        code = (" A metric's [code ...] is a digest of what it computes (its code, constants, "
                "defaults, closure and globals): a metric of the same label that computes "
                "something else is another metric." if "metrics" in differ else "")  # fmt: skip
        raise ValueError(
            f"The sweep in {out} was started with other arguments: {', '.join(differ)} "
            f"differ{'s' if len(differ) == 1 else ''} ({_describe_difference(old, record, differ)}).{code} "
            "Use another `out` folder for this sweep, or delete the old one to start afresh."
        )


def _stored_chunk_points(old, path, out, chunk_size, chunk_points, n_devices):
    stored = old.get("chunk_points")
    if not isinstance(stored, int) or stored < 1:
        raise ValueError(f"{path} has no valid chunk_points; delete the folder {out}.")
    if chunk_size is not None and stored != chunk_points:
        raise ValueError(
            f"The sweep in {out} was written in chunks of {stored} points; chunk_size="
            f"{chunk_size} on {n_devices} device(s) makes {chunk_points}. Leave chunk_size "
            "unset to resume with the stored layout, use another `out`, or delete it."
        )
    return stored


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
    """``value`` as JSON, its middle cut where longer than ``limit``: the end (a metric's code
    digest) stays readable."""
    text = json.dumps(value)
    head = (limit - 3) // 2
    return text if len(text) <= limit else text[:head] + "..." + text[len(text) - (limit - 3 - head):]


def chunk_name(k):
    return f"chunk_{k:05d}.npz"


def save_chunk(path, start, stop, points, metric_names, values, status, errors):
    """Write one chunk atomically (a reader sees the old state or the whole new file)."""
    data = io.BytesIO()
    np.savez(
        data,
        start=np.int64(start),
        stop=np.int64(stop),
        points=points,
        metric_names=np.asarray(metric_names, dtype=str),
        values=values,
        status=status.astype(np.int32),
        errors=np.asarray(errors, dtype=str),
    )
    _files.write_bytes(path, data.getvalue())


def load_chunks(out, state, points, metric_names):
    """Fill ``state``'s values, status and errors from the chunk files marked done."""
    n_points, chunk_points = points.shape[0], state.chunk_points
    for k in np.flatnonzero(state.done):
        start, stop = k * chunk_points, min((k + 1) * chunk_points, n_points)
        data = _read_chunk(out / chunk_name(k), start, stop, points, metric_names)
        state.values[start:stop] = data["values"]
        state.status[start:stop] = data["status"]
        state.errors[start:stop] = data["errors"].astype(object)


_HINT = "delete it to recompute that chunk, or delete the folder to start afresh"


def _read_chunk(path, start, stop, points, metric_names):
    try:
        with np.load(path) as f:  # plain arrays: NumPy loads no Python objects by default
            data = {key: f[key] for key in _CHUNK_KEYS}
    except Exception as err:  # noqa: BLE001  (zip, npy and key errors alike)
        raise ValueError(
            f"Chunk file {path} is unreadable or corrupted ({type(err).__name__}: {err}); {_HINT}."
        ) from None
    n = stop - start
    problem = None
    if int(data["start"]) != start or int(data["stop"]) != stop:
        problem = f"it holds points {int(data['start'])}..{int(data['stop'])}, expected {start}..{stop}"
    elif list(data["metric_names"]) != list(metric_names):
        problem = f"its metrics {list(data['metric_names'])} differ from {list(metric_names)}"
    elif (data["values"].shape != (n, len(metric_names)) or data["status"].shape != (n,)
          or data["errors"].shape != (n,)):  # fmt: skip
        problem = (f"its arrays have shapes {data['values'].shape} and {data['status'].shape}, "
                   f"expected {(n, len(metric_names))} and {(n,)}")  # fmt: skip
    elif data["points"].shape != points[start:stop].shape or not np.array_equal(data["points"], points[start:stop]):
        problem = "its parameter values are not those of this sweep"
    if problem:
        raise ValueError(f"Chunk file {path} does not match the manifest: {problem}; {_HINT}.")
    return data


def _fingerprint(model, names):
    """sha256 of the tree structure and of every leaf, with the swept leaves blanked."""
    blank = paths.replace(model, {n: jnp.zeros_like(paths.get(model, n)) for n in names})
    leaves, treedef = jax.tree_util.tree_flatten(blank)
    h = hashlib.sha256()
    h.update(_no_address(str(treedef)).encode())
    for leaf in leaves:
        if eqx.is_array(leaf):
            a = np.asarray(leaf)
            h.update(f"{a.dtype.str}{a.shape}".encode())
            h.update(np.ascontiguousarray(a).tobytes())
        else:
            h.update(_no_address(repr(leaf)).encode())
    return h.hexdigest()


def _jsonable(value):
    if value is None or isinstance(value, (bool, int, float, str)):
        return value
    if isinstance(value, (np.generic, np.ndarray, jax.Array)):
        return np.asarray(value).tolist()
    if isinstance(value, (list, tuple)):
        return [_jsonable(v) for v in value]
    return _no_address(repr(value))

"""A sweep's folder is safe to share and to read: one writer at a time (a second process on the
same sweep waits and computes nothing, a different sweep is refused at once, a live process's
temporary file is never removed), a read-only folder is refused before anything is computed and
a finished one loads from it; a NaN or infinite metric marks its member failed, with a reason.

Every sweep here has the same model structure, metrics, points per chunk and settings, so its
kernel compiles once in this process: a rotor in the paper's SKF 98205 (a small mechanism,
quick to compile) over 0.01 s, two clearances, one point a chunk (two chunks).
"""

from __future__ import annotations

import contextlib
import json
import os
import re
import subprocess
import sys
import tempfile
import textwrap
import threading
from typing import ClassVar

import jax
import jax.numpy as jnp
import numpy as np
import pytest
import xarray as xr

import jaxbearing as jb
from jaxbearing import metrics as M
from jaxbearing._sweep import fingerprint, kernel, store

T1 = 0.01
POINTS = {"bearing.clearance": [20e-6, 40e-6]}
LATE = 0.005  # [s] a window start that is no stop of the solve unless the sweep adds it
HIDDEN = 0.002  # [s] the same, inside a function the sweep cannot read it from
LOAD_LIMIT = 150.0  # [N] between the two members' peak ball loads over 0-0.01 s (121, 174 N)


class HiddenWindow(M.AbstractMetric):
    """The peak ball load from HIDDEN on where the peak from t0 exceeds LOAD_LIMIT, else 0:
    NaN for the member above it (HIDDEN is not a stop: the edge is inside `value`, which
    `edges` does not name), a finite value for the other. It reads the solve's records only:
    members run as one loop."""

    reads_samples: ClassVar[bool] = False
    reads_fatigue: ClassVar[bool] = False

    def value(self, sol, model):
        whole = M.peak_ball_load(sol, t_min=0.0)
        return jnp.where(whole > LOAD_LIMIT, M.peak_ball_load(sol, t_min=HIDDEN), 0.0)


METRICS = {
    "peak_ball_load": M.peak_ball_load.replace(t_min=0.0),
    "late_peak": M.peak_ball_load.replace(t_min=LATE),  # the sweep adds the stop
    "hidden": HiddenWindow(),
}
TESTS = os.path.dirname(os.path.abspath(__file__))

pytestmark = [  # the member with a NaN metric is reported
    pytest.mark.filterwarnings("ignore:sweep. [0-9]+ of [0-9]+ members failed:RuntimeWarning"),
]


def run(params=POINTS, **kwargs):
    options = dict(metrics=METRICS, t1=T1, chunk_size=1, progress=False)
    return jb.sweep(rotor(), params, **{**options, **kwargs})


def rotor(clearance=40e-6):
    return jb.cases.rotor(jb.cases.skf98205(clearance=clearance), speed=100.0)


@pytest.fixture(scope="module")
def finished(tmp_path_factory):
    """A finished sweep: (its Dataset, its folder)."""
    out = tmp_path_factory.mktemp("finished")
    return run(out=out), out


def _can_write(folder) -> bool:
    try:
        with tempfile.TemporaryFile(dir=folder):
            return True
    except OSError:
        return False


@contextlib.contextmanager
def read_only(folder):
    """``folder`` read-only for this process: its write bits cleared, and where that does not
    stop this process (root), a read-only bind mount over it; skips the test where neither
    works."""
    modes = {p: p.stat().st_mode for p in [folder, *folder.iterdir()]}
    for path, mode in modes.items():
        path.chmod(mode & ~0o222)
    mounted = False
    try:
        if _can_write(folder):
            mounted = subprocess.run(["mount", "--bind", folder, folder], capture_output=True).returncode == 0
            remounted = mounted and subprocess.run(
                ["mount", "-o", "remount,bind,ro", folder], capture_output=True
            ).returncode == 0
            if not remounted or _can_write(folder):
                pytest.skip("cannot make a folder read-only for this process")
        yield folder
    finally:
        if mounted:
            subprocess.run(["umount", folder], check=True)
        for path, mode in modes.items():
            path.chmod(mode)


@pytest.fixture
def no_computing(monkeypatch):
    """Fail the test if a chunk is computed."""

    def refuse(self, points):
        raise AssertionError("a chunk was computed")

    monkeypatch.setattr(kernel.ChunkRunner, "__call__", refuse)


def test_a_nan_or_infinite_metric_marks_its_member_failed_with_a_reason(finished):
    ds, out = finished
    # member 1's hidden window starts at a time the solve did not stop at: NaN, failed
    np.testing.assert_array_equal(ds.status.values, [0, kernel.NOT_FINITE])
    np.testing.assert_array_equal(ds.failed.values, [False, True])
    assert ds.hidden.values[0] == 0.0 and np.isnan(ds.hidden.values[1])
    assert np.isfinite(ds.peak_ball_load.values).all()  # its other metrics are kept
    assert json.loads(ds.attrs["status_codes"])[str(kernel.NOT_FINITE)] == "metric_not_finite"
    (failure,) = json.loads(ds.attrs["failures"])
    assert failure["index"] == 1 and failure["result"] == "metric_not_finite"
    assert failure["point"] == {"bearing.clearance": 40e-6}
    assert failure["message"].startswith("hidden = nan: a metric is NaN when its window starts or ends "
                                         "at a time the solve did not stop at (add that time to "
                                         "SolveOptions(window_edges=...))")
    # recorded in the chunk file and results.nc: a reload reports the same
    with xr.open_dataset(out / "results.nc") as saved:
        np.testing.assert_array_equal(saved.status.values, ds.status.values)
        assert saved.attrs["failures"] == ds.attrs["failures"]
    with np.load(out / "chunk_00001.npz") as chunk:
        assert chunk["status"].tolist() == [kernel.NOT_FINITE]


def test_the_failure_report_names_the_metric():
    with pytest.warns(RuntimeWarning, match=r"sweep: 1 of 1 members failed.*\n  point 0 "
                      r"\(bearing\.clearance = 4e-05\): metric_not_finite: hidden = nan: a metric is NaN"):
        run({"bearing.clearance": [40e-6]})


def test_a_window_edge_known_before_the_solve_becomes_a_stop(finished):
    """A metric's t_min given as a number (``peak_ball_load.replace(t_min=LATE)``: its
    ``edges()``) is added to the members' window_edges, so the metric is exact: the value of a
    single run asked for that stop; the manifest names it by its label."""
    ds, out = finished
    assert json.loads(ds.attrs["simulate_kwargs"])["window_edges"] == [LATE]
    labels = json.loads((out / "manifest.json").read_text())["metrics"]
    hidden = labels.pop("hidden")  # a class of this file's: its code's digest too
    assert labels == {"peak_ball_load": "peak_ball_load(t_min=0.0)", "late_peak": f"peak_ball_load(t_min={LATE})",
                      "max_drift": "max_drift"}
    assert re.fullmatch(r"HiddenWindow\(\) \[code [0-9a-f]{16}\]", hidden), hidden
    for clearance, value in zip(POINTS["bearing.clearance"], ds.late_peak.values):
        model = rotor(clearance)
        sol = jb.simulate_one_loop(model, T1, options=jb.SolveOptions(window_edges=(LATE,)))
        # the same integrator and stops, but another compiled program (vmapped): rounding, which
        # the step control may turn into other steps within the solver's relative tolerance
        np.testing.assert_allclose(value, M.peak_ball_load(sol, t_min=LATE), rtol=1e-6)



def largest(i):
    """The largest |q_i| [m or rad] over the run: a metric of a lambda that closes over ``i``;
    every one is labelled ``Peak(largest.<locals>.<lambda>)``, whatever ``i``."""
    return M.Peak(lambda model, x: jnp.abs(x.q[i]))


OWN = {  # metrics of this file's code (`test_a_metric_s_code_digest_is_the_same_in_another_process`)
    "lambda": M.Peak(lambda model, x: jnp.abs(x.q[0]) + len({"a", "b"})),
    "closure": largest(2),
    "class": HiddenWindow(),
}


def stopped_after_the_first_chunk(monkeypatch, **kwargs):
    """Run the sweep with ``kwargs`` and stop it (KeyboardInterrupt) once its first chunk is
    written: a process killed there."""
    save = store.save_chunk

    def save_then_stop(path, *args):
        save(path, *args)
        raise KeyboardInterrupt

    with monkeypatch.context() as patch:
        patch.setattr(store, "save_chunk", save_then_stop)
        with pytest.raises(KeyboardInterrupt):
            run(**kwargs)


OTHER_FUNCTION = r"was started with other arguments: metrics differs \(metrics own: stored " \
                 r"\"Peak\(.*<lambda>\) \[code [0-9a-f]{16}\]\", now \"Peak\(.*<lambda>\) \[code [0-9a-f]{16}\]\"\)\. " \
                 r"A metric's \[code \.\.\.\] is a digest of what it computes"


@contextlib.contextmanager
def nothing_computed(monkeypatch):
    """Within its block, fail the test if a chunk is computed."""
    with monkeypatch.context() as patch:
        patch.setattr(kernel.ChunkRunner, "__call__", lambda *_: pytest.fail("a chunk was computed"))
        yield


def test_another_function_of_the_same_label_never_takes_a_finished_folder_s_values(tmp_path, monkeypatch):
    """Two ``Peak(lambda model, x: ...)`` over different quantities are both labelled
    ``Peak(<lambda>)``: before, a sweep of the second into the first's finished folder returned
    the first's values. The manifest records a digest of each metric's code beside its label:
    the other function is refused before anything is computed."""
    first, second = (lambda model, x: jnp.abs(x.q[0])), (lambda model, x: jnp.abs(x.q[1]))
    run(metrics={"own": M.Peak(first)}, out=tmp_path)
    with nothing_computed(monkeypatch), pytest.raises(ValueError, match=OTHER_FUNCTION):
        run(metrics={"own": M.Peak(second)}, out=tmp_path)


def test_a_sweep_resumed_with_another_function_of_the_same_label_is_refused(tmp_path, monkeypatch):
    """A sweep of one lambda stopped after its first chunk, resumed with the same lambda closing
    over another index (the same label, the same bytecode): before, the resume filled the rest
    of the grid with the other quantity's values. Refused before anything is computed; the same
    function made again (as a notebook's cell run again makes it) resumes, computing the rest
    only, and equals an uninterrupted sweep."""
    stopped_after_the_first_chunk(monkeypatch, metrics={"own": largest(0)}, out=tmp_path)
    assert [p.name for p in tmp_path.glob("chunk_*")] == ["chunk_00000.npz"]
    with nothing_computed(monkeypatch), pytest.raises(ValueError, match=OTHER_FUNCTION):
        run(metrics={"own": largest(1)}, out=tmp_path)
    resumed = run(metrics={"own": largest(0)}, out=tmp_path)
    assert resumed.attrs["sweep_computed_points"] == 1
    whole = run(metrics={"own": largest(0)})
    # another compiled program (another function object): its rounding, within the solver's error
    np.testing.assert_allclose(resumed.own.values, whole.own.values, rtol=1e-9)
    assert np.ptp(whole.own.values) > 0  # two members, two values


def test_a_metric_s_code_digest_is_the_same_in_another_process():
    """The digest depends on what the metric computes alone, never on the process: the same in
    processes of other hash seeds (the order of sets and dicts) for a lambda, a closure and a
    metric class of this file's; two quantities have two digests; jaxbearing's own metrics have
    none (their labels name them)."""
    here = {name: fingerprint.labelled(metric) for name, metric in OWN.items()}
    assert len({label.split(" [code ")[1] for label in here.values()}) == len(OWN)
    assert fingerprint.labelled(largest(1)) != here["closure"]
    jitted = [M.Peak(jax.jit(f)) for f in (lambda model, x: x.q[0], lambda model, x: x.q[1])]  # what it wraps
    assert fingerprint.code_digest(jitted[0]) != fingerprint.code_digest(jitted[1])
    assert fingerprint.labelled(M.peak_ball_load.replace(t_min=0.0)) == "peak_ball_load(t_min=0.0)"
    assert fingerprint.code_digest(jb.life.metric("lp")) is None
    code = """
        from jaxbearing._sweep import fingerprint
        print(repr({name: fingerprint.labelled(metric) for name, metric in t.OWN.items()}))
        """
    for seed in ("1", "2"):
        job = start_process(code, PYTHONHASHSEED=seed)
        out, err = job.communicate(timeout=120)
        assert job.returncode == 0, err[-3000:]
        assert eval(out.strip().splitlines()[-1]) == here

def test_a_read_only_folder_is_refused_before_computing(tmp_path, no_computing):
    with read_only(tmp_path), pytest.raises(
        PermissionError, match=rf"The sweep folder {tmp_path} is not writable \(.*\) and holds no "
                               r"manifest\.json to load: make it writable, or use another `out`"):
        run(out=tmp_path)


def test_an_unfinished_sweep_in_a_read_only_folder_is_refused_before_computing(finished, tmp_path, no_computing):
    _, out = finished
    copy = tmp_path / "copy"
    copy.mkdir()
    for name in ("manifest.json", "chunk_00000.npz"):
        (copy / name).write_bytes((out / name).read_bytes())
    with read_only(copy), pytest.raises(
        PermissionError, match=rf"The sweep folder {copy} is not writable \(.*\) and 1 of 2 chunks "
                               r"are still to compute"):
        run(out=copy)


def test_a_finished_sweep_loads_from_a_read_only_folder(finished, no_computing):
    ds, out = finished
    stamp = (out / "results.nc").stat().st_mtime_ns
    with read_only(out):
        again = run(out=out)
    assert again.attrs["sweep_computed_points"] == 0
    assert (out / "results.nc").stat().st_mtime_ns == stamp  # not rewritten
    xr.testing.assert_identical(again.drop_attrs(), ds.drop_attrs())


def test_a_missing_results_file_in_a_read_only_folder_is_named(finished, tmp_path, no_computing):
    _, out = finished
    copy = tmp_path / "copy"
    copy.mkdir()
    for name in ("manifest.json", "chunk_00000.npz", "chunk_00001.npz"):
        (copy / name).write_bytes((out / name).read_bytes())
    with read_only(copy), pytest.raises(
        PermissionError, match=rf"The sweep folder {copy} is not writable \(.*\) and results\.nc must "
                               r"be written \(it is missing"):
        run(out=copy)


def start_process(body: str, **env):
    """A python process (CPU) that imports this file as ``t`` and runs ``body`` (``env``: more
    environment variables)."""
    preamble = f"""
import pathlib, sys, time
sys.path.insert(0, {TESTS!r})
import jax
jax.config.update("jax_enable_x64", True)
import test_sweep_folder as t
"""
    env = dict(os.environ, JAX_PLATFORMS="cpu", **env)
    return subprocess.Popen([sys.executable, "-c", preamble + textwrap.dedent(body)], env=env,
                            text=True, stdout=subprocess.PIPE, stderr=subprocess.PIPE)


@pytest.mark.slow  # 15 s: two more processes that each import JAX and load the solve
def test_two_processes_on_one_folder_compute_each_chunk_once(finished, tmp_path, capfd):
    """The other process runs the sweep and stalls while writing its first chunk (a slow disk:
    the temporary file is written, not yet moved into place). Here, a different sweep in that
    folder is refused at once; the same sweep waits for the other to finish, leaves its
    temporary file alone and then loads what it wrote, computing nothing."""
    reference, _ = finished
    out = tmp_path / "shared"
    job = start_process(
        f"""
        from jaxbearing import _files
        write_bytes = _files.write_bytes

        def slow(path, data):  # the first chunk's file waits for `release` before it is moved
            if path.name != "chunk_00000.npz":
                return write_bytes(path, data)
            with _files.atomic_path(path) as tmp:
                tmp.write_bytes(data)
                print("WRITING", flush=True)
                deadline = time.monotonic() + 300.0
                while not (path.parent / "release").exists() and time.monotonic() < deadline:
                    time.sleep(0.01)

        _files.write_bytes = slow
        t.run(out=pathlib.Path({str(out)!r}))
        print("DONE", flush=True)
        """
    )
    try:
        assert job.stdout.readline().strip() == "WRITING", job.communicate()[1][-3000:]
        tmp = list(out.glob(".chunk_00000.npz.*.tmp"))
        assert len(tmp) == 1
        with pytest.raises(ValueError, match="was started with other arguments: parameters, shape differ"):
            run({"bearing.clearance": [30e-6]}, out=out)  # at once: the other process still stalls
        assert job.poll() is None and tmp[0].exists()
        # the other process goes on 5 s later, while this one waits for the folder
        threading.Timer(5.0, (out / "release").touch).start()
        ds = run(out=out)
        assert job.wait(timeout=300) == 0, job.stderr.read()[-3000:]
        assert job.stdout.read().strip() == "DONE"
    finally:
        if job.poll() is None:
            job.kill()
        job.communicate()
    err = capfd.readouterr().err
    assert f"sweep: {out} is being written by another sweep (pid {job.pid} on " in err
    assert "waiting for it to finish, then resuming from what it wrote" in err
    assert ds.attrs["sweep_computed_points"] == 0
    assert not list(out.glob(".*.tmp"))
    with xr.open_dataset(out / "results.nc") as theirs:
        xr.testing.assert_identical(ds.drop_attrs(), theirs.load().drop_attrs())
    # the other process's own compilation: rounding may differ (see test_sweep's METRIC_RTOL)
    for name in METRICS:
        np.testing.assert_allclose(ds[name].values, reference[name].values, rtol=1e-4)

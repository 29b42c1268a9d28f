"""`jaxbearing.sweep`: labelled grid and list results equal to single runs (bearing life among
the metrics), failed members marked and reported with their parameters, resumable output (also
after a real SIGKILL), clear errors for foreign or corrupted folders, version and parameter
records, bitwise reproducibility across runs and processes, several devices.

Every sweep here uses the same model structure, metrics, output times, solver settings and chunk
shape, so the sweep kernel compiles once in this process; the subprocess on 4 devices, started
first, compiles its own while the first tests run, and the one on a single device, started after
this process's grid sweep, loads this process's from JAX's persistent cache. The mechanism
is small, a smaller program than the paper's case: a 2 kg rotor in the paper's
SKF 98205, driven at 100 rad/s, falling onto the race. Over 0.01 s it takes about 210 steps; a
bearing damping of 1e8 N s/m makes the ball contacts so stiff that max_steps=1500 runs out at
t = 3 ms, so those members fail (max_steps_reached) while the others succeed.

Bit-for-bit comparisons are made only between runs of the same XLA program on the same inputs
(a sweep run again, resumed or rerun in another process on as many devices). A different
program (a point run alone, another device count or vmap width) may round differently in the
last bits, which the adaptive step control can turn into another step sequence; such results are
compared within `METRIC_RTOL`.
"""

from __future__ import annotations

import functools
import json
import os
import signal
import subprocess
import sys
import textwrap
import time

import jax
import numpy as np
import pytest
import xarray as xr

import jaxbearing as jb
from jaxbearing import _sweep, metrics as M, paths, provenance
from jaxbearing._sweep import kernel, store

sweep = jb.sweep

T1 = 0.01
TS = np.linspace(0.0, T1, 11)
MAX_STEPS = 1500
CHUNK = 2  # points per device per chunk
GROOVES = {"groove_inner": 0.5219, "groove_outer": 0.5194}  # those of cases.skf98205
METRICS = {  # window from t = 0: the standard one starts at 0.04 s
    "peak_ball_load": M.peak_ball_load.replace(t_min=0.0),
    "rms_bearing_force": M.rms_bearing_force.replace(t_min=0.0),
    # life needs the model as well: each member's own (LifeMetric.value(sol, model))
    "l10_iso_hours": jb.life.metric("iso", t_min=0.0),
    "l10_lp_mrev": jb.life.metric("lp", unit="mrev", t_min=0.0, **GROOVES),
    "l10_reference_mrev": jb.life.metric("reference", unit="mrev", t_min=0.0, **GROOVES),
}
CLEARANCES = [20e-6, 40e-6, 60e-6]
DAMPINGS = [300.0, 1e8]  # the second fails at MAX_STEPS
GRID = {"bearing.clearance": CLEARANCES, "bearing.damping": DAMPINGS}
# relative: another compiled program (another process, device count or vmap width) may round
# differently, and the step control turns that into other steps: positions then differ within
# atol 1e-10 m, against ball deflections of about 1 um as the rotor lands on the race, so ball
# forces (Hertz, d^1.5) within about 1e-4 (measured for this rotor: within 2e-16 alone, in
# chunks of one and on 4 devices; for the paper's case, which rattles more, 1.5e-6 on 4 devices)
METRIC_RTOL = 1e-4
MAX_STEPS_REACHED = int(jb.RESULTS.max_steps_reached._value)
# the sweep that is killed mid-way: the grid's 6 points twice, as a list of 12 (6 chunks); a
# member's result does not depend on the others in its chunk, so it equals the grid's
KILL_POINTS = {
    "bearing.clearance": np.tile(np.repeat(CLEARANCES, len(DAMPINGS)), 2),
    "bearing.damping": np.tile(DAMPINGS, 2 * len(CLEARANCES)),
}
TESTS = os.path.dirname(os.path.abspath(__file__))

# every sweep with DAMPINGS[1] reports its failed members; the tests that check it catch it
pytestmark = pytest.mark.filterwarnings("ignore:sweep. [0-9]+ of [0-9]+ members failed:RuntimeWarning")


def model():
    return jb.cases.rotor(jb.cases.skf98205(), speed=100.0)


def run(params=GRID, **kwargs):
    options = dict(metrics=METRICS, t1=T1, ts=TS, max_steps=MAX_STEPS, chunk_size=CHUNK, progress=False)
    options.update(kwargs)
    return sweep(model(), params, **options)


def assert_same(a: xr.Dataset, b: xr.Dataset, rtol: float = 0.0):
    """Equal status and failures, and metrics within ``rtol`` (0: the same program on the same
    inputs, equal to the last bit; another program: `METRIC_RTOL`)."""
    for name in ["status", "failed"]:
        np.testing.assert_array_equal(a[name].values, b[name].values, err_msg=name)
    for name in METRICS:
        np.testing.assert_allclose(a[name].values, b[name].values, rtol=rtol, atol=0, err_msg=name)


def start_process(body: str, devices: int, stderr=subprocess.PIPE):
    """A python process on ``devices`` CPU devices that imports this file as ``t`` and runs
    ``body``."""
    preamble = f"""
import pathlib, sys, time
sys.path.insert(0, {TESTS!r})
import jax
jax.config.update("jax_enable_x64", True)
import test_sweep as t  # imports jaxbearing before the first computation, as a user would
assert jax.device_count() == {devices}, jax.devices()
"""
    env = dict(os.environ, JAX_PLATFORMS="cpu")
    env["XLA_FLAGS"] = f"--xla_force_host_platform_device_count={devices}"
    return subprocess.Popen([sys.executable, "-c", preamble + textwrap.dedent(body)], env=env,
                            text=True, stdout=subprocess.PIPE, stderr=stderr)


def stop(job):
    if job.poll() is None:
        job.kill()
        job.communicate()


@pytest.fixture(scope="module", autouse=True)
def four_devices(tmp_path_factory):
    """The grid sweep in a subprocess with 4 CPU devices, started first so that it compiles
    while the other tests run."""
    out = tmp_path_factory.mktemp("four_devices")
    job = start_process(
        f"""
        t.run(out={str(out)!r})
        print("CHUNKS", len(list(pathlib.Path({str(out)!r}).glob("chunk_*"))))
        """,
        devices=4,
    )
    yield job, out
    stop(job)


@pytest.fixture(scope="module", autouse=True)
def other_process(tmp_path_factory, grid_result):
    """A second process (one CPU device, as here) that runs the grid sweep uninterrupted, says
    READY, waits for the file ``go`` and then runs the KILL_POINTS sweep, which the test kills.
    Started once this process has run the grid sweep, so that it loads the compiled sweep from
    JAX's persistent cache (jaxbearing turns it on) instead of compiling it again on a core the
    other tests need; it does so while they run."""
    root = tmp_path_factory.mktemp("other_process")
    with (root / "stderr.txt").open("w") as log:  # the child keeps its own copy
        job = start_process(
            f"""
            root = pathlib.Path({str(root)!r})
            t.run(out=root / "grid")
            print("READY", flush=True)
            while not (root / "go").exists():
                time.sleep(0.01)
            t.run(t.KILL_POINTS, grid=False, out=root / "killed")
            print("FINISHED", flush=True)
            """,
            devices=1,
            stderr=log,
        )
    yield job, root
    stop(job)


@pytest.fixture(scope="module")
def other_process_ready(other_process):
    """The other process once it has written its grid sweep (it then waits for ``go``)."""
    job, root = other_process
    line = job.stdout.readline()  # blocks until READY, or "" if the process died
    assert line.strip() == "READY", (root / "stderr.txt").read_text()[-3000:]
    return job, root


@pytest.fixture(scope="module")
def grid_result(tmp_path_factory):
    out = tmp_path_factory.mktemp("grid")
    with pytest.warns(RuntimeWarning, match="members failed") as caught:
        ds = run(out=out, progress=True)
    return ds, out, str(caught[0].message)


@jax.jit
def single(c, d):
    """One point alone, under jit with the parameters traced (as in the sweep): its metrics,
    life by `jb.life.iso_life` and `jb.life.lp_life`, and the result code."""
    m = paths.replace(model(), {"bearing.clearance": c, "bearing.damping": d})
    sol = jb.simulate(m, T1, TS, max_steps=MAX_STEPS, throw=False)
    values = {name: METRICS[name](sol) for name in ("peak_ball_load", "rms_bearing_force")}
    values["l10_iso_hours"] = jb.life.iso_life(sol, m, t_min=0.0).l10_hours
    values["l10_lp_mrev"] = jb.life.lp_life(sol, m, t_min=0.0, **GROOVES).l10
    values["l10_reference_mrev"] = jb.life.reference_life(sol, m, t_min=0.0, **GROOVES).l10
    return values, sol.result._value


def test_grid_labels_and_values_match_single_runs(grid_result):
    ds, out, _ = grid_result
    assert dict(ds.sizes) == {"bearing.clearance": 3, "bearing.damping": 2}
    assert list(ds["peak_ball_load"].dims) == ["bearing.clearance", "bearing.damping"]
    np.testing.assert_array_equal(ds["bearing.clearance"].values, CLEARANCES)
    np.testing.assert_array_equal(ds["bearing.damping"].values, DAMPINGS)
    assert set(ds.data_vars) == set(METRICS) | {"status", "failed", "max_drift"}
    assert ds.attrs["t1"] == T1 and ds.attrs["max_steps"] == MAX_STEPS and ds.attrs["rtol"] == 1e-8
    assert json.loads(ds.attrs["status_codes"])[str(MAX_STEPS_REACHED)] == "max_steps_reached"

    # the stiffly damped members fail and read NaN; the others succeed
    np.testing.assert_array_equal(ds.failed.values, [[False, True]] * 3)
    np.testing.assert_array_equal(ds.status.values, [[0, MAX_STEPS_REACHED]] * 3)
    assert np.isnan(ds.peak_ball_load.values[:, 1]).all()
    assert np.isfinite(ds.peak_ball_load.values[:, 0]).all()

    # each point run alone, under jit with the parameters traced (as in the sweep): the metrics
    # (bearing life included) within METRIC_RTOL (another program: module docstring)
    for c in CLEARANCES:
        for d in DAMPINGS:
            values, status = single(c, d)
            point = ds.sel({"bearing.clearance": c, "bearing.damping": d})
            assert int(point.status) == int(status)
            if int(status) == 0:
                for name in METRICS:
                    np.testing.assert_allclose(
                        float(point[name]), float(values[name]), rtol=METRIC_RTOL, atol=0,
                        err_msg=f"{name} at clearance {c}, damping {d}",
                    )

    # the failed members are reported with their parameters: a warning and an attribute
    failures = json.loads(ds.attrs["failures"])
    assert [f["index"] for f in failures] == [1, 3, 5]
    for f, c in zip(failures, CLEARANCES):
        assert f["point"] == {"bearing.clearance": c, "bearing.damping": 1e8}
        assert (f["status"], f["result"]) == (MAX_STEPS_REACHED, "max_steps_reached")
        assert f["message"] == "The maximum number of solver steps was reached. Try increasing `max_steps`."
    warning = grid_result[2]
    assert warning.startswith("sweep: 3 of 6 members failed; the metrics of a failed solve are NaN")
    assert ("\n  point 3 (bearing.clearance = 4e-05, bearing.damping = 1e+08): max_steps_reached: "
            "The maximum number of solver steps was reached.") in warning

    # written as netCDF, same content
    with xr.open_dataset(out / "results.nc") as saved:
        assert_same(ds, saved.load())


def test_results_record_versions_and_every_model_parameter(grid_result):
    ds, out, _ = grid_result
    manifest = json.loads((out / "manifest.json").read_text())
    assert manifest["versions"] == json.loads(ds.attrs["versions"]) == provenance.versions()
    assert set(manifest["versions"]) == {"python", "jaxbearing", "jax", "jaxlib", "diffrax", "equinox", "numpy"}
    recorded = manifest["model_parameters"]
    assert recorded == json.loads(ds.attrs["model_parameters"])
    # every parameter of the model by its path, the swept ones marked: with the coordinates and
    # the settings (attribute simulate_kwargs) they are the whole input of each member
    assert recorded["forces.0.bearing.clearance"] == recorded["forces.0.bearing.damping"] == "swept"
    full = provenance.parameters(model())
    assert recorded.keys() == full.keys()
    assert {k for k in full if full[k] != recorded[k]} == {"forces.0.bearing.clearance", "forces.0.bearing.damping"}
    assert json.loads(ds.attrs["simulate_kwargs"])["max_steps"] == MAX_STEPS
    with xr.open_dataset(out / "results.nc") as saved:
        for key in ("versions", "model_parameters", "failures", "simulate_kwargs", "model_fingerprint"):
            assert saved.attrs[key] == ds.attrs[key], key


def test_progress_bar_counts_chunks(tmp_path, capsys):
    run(out=tmp_path, progress=True)
    assert "3/3" in capsys.readouterr().err
    run(out=tmp_path, progress=True)  # all done already: the bar starts full
    assert "3/3" in capsys.readouterr().err


def test_one_point_a_chunk_equals_larger_chunks(grid_result):
    """``chunk_size=1``: XLA compiles a batch of one as a program of its own, which may round
    differently; a member agrees with its value in chunks of 2 within the solver's tolerance."""
    points = {"bearing.clearance": CLEARANCES[:2], "bearing.damping": [DAMPINGS[0]] * 2}
    ds = run(points, grid=False, chunk_size=1)
    for i in range(2):
        where = {name: values[i] for name, values in points.items()}
        assert_same(ds.isel(point=i), grid_result[0].sel(where), rtol=METRIC_RTOL)


def test_default_chunks_follow_the_platform_and_the_solve():
    """32 points a CPU device; on accelerators a one-loop chunk is as large as the GPU
    measurements found best (docs/performance.md), and a small sweep is not padded."""
    from jaxbearing._sweep import arguments

    assert arguments.default_chunk_size("cpu") == arguments.default_chunk_size("cpu", "one_loop") == 32
    assert arguments.default_chunk_size("gpu") == 4096
    assert arguments.default_chunk_size("gpu", "one_loop") == 65536
    largest = arguments.default_chunk_size(solve="one_loop")  # on this machine's platform
    assert arguments.chunk_points(None, 1, 10**6, "one_loop") == largest
    assert arguments.chunk_points(None, 2, 7, "one_loop") == 8  # one round of 2 devices


def test_list_of_points(grid_result):
    grid = grid_result[0]
    points = {"bearing.clearance": [60e-6, 20e-6, 40e-6], "bearing.damping": [300.0, 1e8, 300.0]}
    ds = run(points, grid=False)
    assert dict(ds.sizes) == {"point": 3}
    np.testing.assert_array_equal(ds["bearing.clearance"].values, points["bearing.clearance"])
    np.testing.assert_array_equal(ds["bearing.damping"].values, points["bearing.damping"])
    np.testing.assert_array_equal(ds.failed.values, [False, True, False])
    for i in range(3):
        where = {name: values[i] for name, values in points.items()}
        assert_same(ds.isel(point=i), grid.sel(where))
    with pytest.raises(ValueError, match="same number of values"):
        run({"bearing.clearance": [1e-5, 2e-5], "bearing.damping": [300.0]}, grid=False)


@pytest.mark.slow  # 12 s: sweeps compiled for sample-reading metrics
def test_default_output_times_are_what_the_metrics_need():
    """Metrics of the solve's per-step records need no samples: without ts the members are
    solved with [t0, t1] only, and their metrics agree with `jb.metrics` of a dense single run
    (another XLA program rounds differently, and the solver amplifies that up to its accuracy:
    the benchmark finds ball loads within 0.04 N of a 1000x tighter reference, 1e-4 of this
    window's RMS; measured 1.3e-6 apart here)."""
    exact = {name: METRICS[name] for name in ("peak_ball_load", "rms_bearing_force")}
    ds = run({"bearing.clearance": CLEARANCES[::2]}, metrics=exact, ts=None)
    np.testing.assert_array_equal(ds.attrs["ts"], [0.0, T1])
    for c in CLEARANCES[::2]:
        m = paths.replace(model(), {"bearing.clearance": c})
        sol = jb.simulate(m, T1, TS, max_steps=MAX_STEPS)
        for name, fn in exact.items():
            np.testing.assert_allclose(ds[name].sel({"bearing.clearance": c}), fn(sol), rtol=1e-5, err_msg=name)

    # the rule: each metric says whether it reads the samples (`AbstractMetric.reads_samples`):
    # jaxbearing's, replaced or not, and the life do not; a function of a Solution does, and so
    # does a functools.partial, whose keywords are not read
    def own(sol):
        return M.peak_ball_load(sol, t_min=0.0)

    when = M.peak_time.replace(metric=M.peak_impact_force)
    free = (*exact.values(), M.smooth_peak_ball_load, when, M.peak_ball, METRICS["l10_iso_hours"])
    sampled = (own, functools.partial(M.peak_ball_load, t_min=0.0))
    assert [M.as_metric(m).reads_samples for m in (*free, *sampled)] == [False] * len(free) + [True] * 2
    items = (*METRICS.items(), ("own", M.as_metric(own)))
    times = _sweep.arguments.output_times(items, 0.0, T1, None)
    np.testing.assert_array_equal(times, np.linspace(0.0, T1, _sweep.DEFAULT_SAMPLES))
    # members record the life's integrals only for a metric that reads them
    assert METRICS["l10_lp_mrev"].reads_fatigue
    assert not any(M.as_metric(m).reads_fatigue for m in (*exact.values(), own))


def test_interrupted_sweep_resumes_without_recomputing(tmp_path, monkeypatch, grid_result):
    reference = grid_result[0]
    calls = []
    original = kernel.ChunkRunner.__call__

    def counting(self, points):
        calls.append(points.copy())
        return original(self, points)

    monkeypatch.setattr(kernel.ChunkRunner, "__call__", counting)

    # interrupted after the first chunk is written
    original_save = store.save_chunk

    def save_then_stop(path, *args):
        original_save(path, *args)
        raise KeyboardInterrupt

    monkeypatch.setattr(store, "save_chunk", save_then_stop)
    with pytest.raises(KeyboardInterrupt):
        run(out=tmp_path)
    monkeypatch.setattr(store, "save_chunk", original_save)
    assert sorted(p.name for p in tmp_path.glob("chunk_*")) == ["chunk_00000.npz"]
    assert not (tmp_path / "results.nc").exists()

    calls.clear()
    ds = run(out=tmp_path)  # resumes: chunks 1 and 2 only
    assert len(calls) == 2
    assert ds.attrs["sweep_computed_points"] == 4
    assert_same(ds, reference)

    # a lost chunk is recomputed, alone; the others are not rewritten
    stamps = {p.name: p.stat().st_mtime_ns for p in tmp_path.glob("chunk_*")}
    (tmp_path / "chunk_00001.npz").unlink()
    calls.clear()
    again = run(out=tmp_path)
    assert len(calls) == 1
    np.testing.assert_array_equal(calls[0][:, 0], [40e-6, 40e-6])  # chunk 1: points 2, 3
    for name in ("chunk_00000.npz", "chunk_00002.npz"):
        assert (tmp_path / name).stat().st_mtime_ns == stamps[name]
    assert_same(again, reference)

    calls.clear()
    assert_same(run(out=tmp_path), reference)  # complete: nothing to compute
    assert calls == []


def test_a_chunk_that_raises_is_rerun_point_by_point(tmp_path, monkeypatch, grid_result):
    """An error raised inside the solve (an equinox check) would abort the whole chunk: the
    sweep reruns its points alone and marks only those that still raise."""
    reference = grid_result[0]
    real = kernel.run_chunk

    def raising(model, rows, *args):
        if np.any(np.asarray(rows)[:, 0] == 40e-6):
            raise jax.errors.JaxRuntimeError("INTERNAL: a check failed for clearance 40 um")
        return real(model, rows, *args)

    monkeypatch.setattr(kernel, "run_chunk", raising)
    with pytest.warns(RuntimeWarning) as caught:
        ds = run(out=tmp_path)
    assert "chunk 1 raised" in str(caught[0].message)
    bad = ds["bearing.clearance"] == 40e-6
    assert (ds.status.where(bad, drop=True) == _sweep.RAISED).all()
    assert ds.failed.where(bad, drop=True).all()
    assert np.isnan(ds.peak_ball_load.where(bad, drop=True)).all()
    raised = [f for f in json.loads(ds.attrs["failures"]) if f["result"] == "raised"]
    assert [f["point"] for f in raised] == [{"bearing.clearance": 40e-6, "bearing.damping": d} for d in DAMPINGS]
    assert all(f["status"] == _sweep.RAISED for f in raised)
    assert raised[0]["message"] == "INTERNAL: a check failed for clearance 40 um"
    assert "point 2 (bearing.clearance = 4e-05, bearing.damping = 300): raised: INTERNAL: a check failed" in str(caught[-1].message)
    assert_same(ds.where(~bad, drop=True), reference.where(~bad, drop=True))
    # kept in the chunk files: a rerun loads the marks
    monkeypatch.setattr(kernel, "run_chunk", real)
    again = run(out=tmp_path)
    assert again.attrs["sweep_computed_points"] == 0
    assert again.attrs["failures"] == ds.attrs["failures"]


def test_different_arguments_in_the_same_folder_raise(grid_result):
    out = grid_result[1]
    with pytest.raises(ValueError, match=r"parameters.*another `out`"):
        run({"bearing.clearance": [20e-6, 40e-6], "bearing.damping": DAMPINGS}, out=out)
    with pytest.raises(ValueError, match="metrics"):
        run(out=out, metrics={"peak_ball_load": METRICS["peak_ball_load"]})
    with pytest.raises(ValueError, match=r"model_fingerprint, model_parameters differ .*"
                       r"model_parameters joints\.0\.speed: stored 100\.0, now 30\.0"):
        sweep(jb.cases.rotor(jb.cases.skf98205(), speed=30.0), GRID, metrics=METRICS, t1=T1,
              ts=TS, max_steps=MAX_STEPS, chunk_size=CHUNK,
              progress=False, out=out)
    with pytest.raises(ValueError, match="simulate rtol: stored 1e-08, now 1e-07"):
        run(out=out, stepsize_controller=jb.default_controller(rtol=1e-7))
    with pytest.raises(ValueError, match="chunks of 2 points"):
        run(out=out, chunk_size=3)


def test_corrupted_files_are_named(tmp_path):
    run({"bearing.clearance": CLEARANCES[:2], "bearing.damping": DAMPINGS[:1]}, out=tmp_path)
    chunk = tmp_path / "chunk_00000.npz"
    good = chunk.read_bytes()
    chunk.write_bytes(good[: len(good) // 2])  # truncated
    with pytest.raises(ValueError, match="chunk_00000.npz.*corrupted"):
        run({"bearing.clearance": CLEARANCES[:2], "bearing.damping": DAMPINGS[:1]}, out=tmp_path)
    with open(chunk, "wb") as f:  # readable, but not what the manifest says
        names = [*METRICS, "max_drift"]  # every sweep records the members' drift
        np.savez(f, start=0, stop=2, points=np.zeros((2, 2)), metric_names=np.array(names),
                 values=np.zeros((2, len(names))), status=np.zeros(2, np.int32),
                 errors=np.array(["", ""]))
    with pytest.raises(ValueError, match="chunk_00000.npz.*parameter values"):
        run({"bearing.clearance": CLEARANCES[:2], "bearing.damping": DAMPINGS[:1]}, out=tmp_path)
    manifest = tmp_path / "manifest.json"
    manifest.write_text(manifest.read_text()[:100])  # cut short
    with pytest.raises(ValueError, match=r"manifest\.json is unreadable .*delete the folder"):
        run({"bearing.clearance": CLEARANCES[:2], "bearing.damping": DAMPINGS[:1]}, out=tmp_path)


def test_bad_arguments_are_rejected_before_running():
    with pytest.raises(ValueError, match=r"point 1 \(bearing.clearance = -0.0001.*clearance must be at least -0.01 of the ball diameter"):
        run({"bearing.clearance": [1e-5, -1e-4]})
    with pytest.raises(ValueError, match="does not exist"):
        run({"bearing.nonsense": [1.0]})
    with pytest.raises(TypeError, match="throw"):
        run(throw=True)
    with pytest.raises(ValueError, match="collides"):
        run(metrics={"status": METRICS["peak_ball_load"]})


def test_resume_under_other_versions_warns_and_records_both(tmp_path):
    """Versions are recorded, not compared: a resume under others goes on, with a warning."""
    points = {"bearing.clearance": CLEARANCES[:2], "bearing.damping": DAMPINGS[:1]}
    first = run(points, out=tmp_path)
    path = tmp_path / "manifest.json"
    manifest = json.loads(path.read_text())
    manifest["versions"]["jax"] = "0.0.1"
    path.write_text(json.dumps(manifest))
    with pytest.warns(RuntimeWarning, match=rf"resuming .* under other package versions \(jax 0\.0\.1 -> {jax.__version__}\)"):
        again = run(points, out=tmp_path)
    assert again.attrs["sweep_computed_points"] == 0
    assert json.loads(again.attrs["versions_at_start"])["jax"] == "0.0.1"
    assert json.loads(again.attrs["versions"]) == provenance.versions()
    assert_same(again, first)


def test_sweep_killed_by_sigkill_resumes_with_identical_results(other_process_ready, grid_result):
    """A real kill: the other process runs the KILL_POINTS sweep and gets SIGKILL as soon as its
    first chunk file appears. Resumed here, the sweep computes only the missing chunks, leaves
    the written ones untouched and equals the uninterrupted grid sweep bit for bit."""
    job, root = other_process_ready
    reference = grid_result[0]
    killed = root / "killed"
    n_points = len(KILL_POINTS["bearing.clearance"])
    (root / "go").touch()
    deadline = time.monotonic() + 120.0
    while not list(killed.glob("chunk_*.npz")):
        assert job.poll() is None, "the other process ended before writing a chunk"
        assert time.monotonic() < deadline, "no chunk written within 120 s"
        time.sleep(0.002)
    job.send_signal(signal.SIGKILL)
    assert job.wait() == -signal.SIGKILL
    written = {p.name: p.stat().st_mtime_ns for p in killed.glob("chunk_*.npz")}
    assert 1 <= len(written) < n_points // CHUNK, sorted(written)  # killed mid-way
    assert not (killed / "results.nc").exists()

    resumed = run(KILL_POINTS, grid=False, out=killed)
    assert resumed.attrs["sweep_computed_points"] == n_points - CHUNK * len(written)
    for name, stamp in written.items():  # not recomputed, not rewritten
        assert (killed / name).stat().st_mtime_ns == stamp, name
    assert not list(killed.glob(".*.tmp"))  # a write cut short by the kill is cleaned up

    expected = {name: np.tile(reference[name].values.ravel(), 2) for name in [*METRICS, "status", "failed"]}
    for name, values in expected.items():  # the killed process's chunks: another process
        np.testing.assert_allclose(resumed[name].values, values, rtol=METRIC_RTOL, err_msg=name)
    assert resumed.failed.values.sum() == 6  # the members with damping 1e8
    with xr.open_dataset(killed / "results.nc") as saved:
        assert_same(saved.load(), resumed)
    rows = np.stack([resumed[name].values for name in [*METRICS, "max_drift"]], axis=1)
    for name in written:  # what the killed process wrote is what the resumed sweep returns
        k = int(name[6:11])
        with np.load(killed / name) as before:
            np.testing.assert_array_equal(before["values"], rows[CHUNK * k : CHUNK * (k + 1)])
            np.testing.assert_array_equal(before["status"], expected["status"][CHUNK * k : CHUNK * (k + 1)])


def test_same_inputs_give_the_same_results(grid_result, other_process_ready, tmp_path):
    """Again in this process (the first chunk's points: the same compiled program on the same
    inputs, equal bit for bit, in the returned data and in the file) and in another process (the
    whole grid, with the program it loaded from the cache or compiled: the same records, the
    metrics within METRIC_RTOL)."""
    reference, out, _ = grid_result
    first_chunk = {"bearing.clearance": CLEARANCES[:1], "bearing.damping": DAMPINGS}
    assert_same(run(first_chunk, out=tmp_path), reference.isel({"bearing.clearance": [0]}))
    name = "chunk_00000.npz"
    with np.load(tmp_path / name) as a, np.load(out / name) as b:
        assert a.files == b.files
        for key in b.files:
            np.testing.assert_array_equal(a[key], b[key], err_msg=f"{name} {key}")
    _, root = other_process_ready
    other = root / "grid"
    with xr.open_dataset(other / "results.nc") as there, xr.open_dataset(out / "results.nc") as here:
        assert_same(there.load(), here.load(), rtol=METRIC_RTOL)
        assert there.attrs.keys() == here.attrs.keys()
        for key, value in here.attrs.items():
            np.testing.assert_array_equal(there.attrs[key], value, err_msg=key)


def test_four_devices_give_the_same_numbers(grid_result, four_devices):
    reference = grid_result[0]
    job, out = four_devices
    stdout, stderr = job.communicate(timeout=600)
    assert job.returncode == 0, stderr[-3000:]
    assert "CHUNKS 1" in stdout  # 4 devices x 2 points: 8 slots, 2 of them padding
    with xr.open_dataset(out / "results.nc") as four:
        four = four.load()
    assert four.attrs["parameters"] == reference.attrs["parameters"]
    assert_same(four, reference, rtol=METRIC_RTOL)


@pytest.mark.slow
def test_two_processes_with_jax_distributed(grid_result, tmp_path):
    """The multi-host path on one machine: two processes of one CPU device each, joined by
    `jax.distributed` (gloo collectives); process 0 writes, both return the whole result, and a
    rerun loads it (broadcast from process 0) instead of recomputing."""
    import socket

    reference = grid_result[0]
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    script = textwrap.dedent(
        f"""
        import json, sys
        sys.path.insert(0, {os.path.dirname(os.path.abspath(__file__))!r})
        import jax
        jax.config.update("jax_enable_x64", True)
        jax.config.update("jax_cpu_collectives_implementation", "gloo")
        import test_sweep as t  # imports jaxbearing before the first computation
        jax.distributed.initialize("127.0.0.1:{port}", num_processes=2, process_id=int(sys.argv[1]))
        assert jax.device_count() == 2 and jax.local_device_count() == 1
        first = t.run(out={str(tmp_path)!r})
        again = t.run(out={str(tmp_path)!r})
        print(json.dumps([first.peak_ball_load.values.tolist(), first.status.values.tolist(),
                          again.attrs["sweep_computed_points"]]))
        """
    )
    env = dict(os.environ, JAX_PLATFORMS="cpu")
    env.pop("XLA_FLAGS", None)
    jobs = [subprocess.Popen([sys.executable, "-c", script, str(i)], env=env, text=True,
                             stdout=subprocess.PIPE, stderr=subprocess.PIPE) for i in range(2)]
    outputs = [job.communicate(timeout=600) for job in jobs]
    for job, (_, err) in zip(jobs, outputs):
        assert job.returncode == 0, err[-3000:]
    for stdout, _ in outputs:
        loads, status, recomputed = json.loads(stdout.strip().splitlines()[-1])
        np.testing.assert_allclose(np.array(loads, float), reference.peak_ball_load.values, rtol=METRIC_RTOL)
        np.testing.assert_array_equal(status, reference.status.values)
        assert recomputed == 0
    assert sorted(p.name for p in tmp_path.glob("chunk_*")) == ["chunk_00000.npz", "chunk_00001.npz"]
    with xr.open_dataset(tmp_path / "results.nc") as saved:
        assert_same(saved.load(), reference, rtol=METRIC_RTOL)

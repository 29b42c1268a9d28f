"""`jaxbearing.sweep`: labelled grid and list results equal to single runs, failed members marked,
resumable output, clear errors for foreign or corrupted folders, several devices.

Every sweep here uses the same model structure, metrics, output times, solver settings and chunk
shape, so the sweep kernel compiles once for the whole file. The paper's case without impact over
0.01 s takes ~1000 steps; a bearing damping of 3e5 N s/m needs ~2200, so with max_steps=1500 those
members fail (max_steps_reached) while the others succeed.

Bit-for-bit comparisons hold between runs of the same XLA program for one member: an individual
run under jit with traced parameters, or a sweep with the same points per device on another
device count. A different program (an eager `simulate` with the values compiled in, or another
vmap width) rounds differently in the last bits; the adaptive step control turns that into
another step sequence (938 vs 944 steps here) and the start-up ball loads then differ at the
solver-tolerance level (3e-5 relative over these 0.01 s).
"""

from __future__ import annotations

import functools
import importlib
import json
import os
import subprocess
import sys
import textwrap

import jax
import numpy as np
import pytest
import xarray as xr

import jaxbearing as jb
from jaxbearing import metrics as M, paths

sweep_module = importlib.import_module("jaxbearing.sweep")
sweep = sweep_module.sweep

T1 = 0.01
TS = np.linspace(0.0, T1, 11)
MAX_STEPS = 1500
CHUNK = 2  # points per device per chunk
METRICS = {  # window from t = 0: the standard one starts at 0.04 s
    "peak_ball_load": functools.partial(M.peak_ball_load, t_min=0.0),
    "rms_bearing_force": functools.partial(M.rms_bearing_force, t_min=0.0),
}
CLEARANCES = [20e-6, 40e-6, 60e-6]
DAMPINGS = [300.0, 3e5]  # the second fails at MAX_STEPS
GRID = {"bearing.clearance": CLEARANCES, "bearing.damping": DAMPINGS}
MAX_STEPS_REACHED = int(jb.RESULTS.max_steps_reached._value)


def model():
    return jb.cases.xu2014(impact=False)


def run(params=GRID, **kwargs):
    options = dict(metrics=METRICS, t1=T1, ts=TS, max_steps=MAX_STEPS, chunk_size=CHUNK, progress=False)
    options.update(kwargs)
    return sweep(model(), params, **options)


def assert_same(a: xr.Dataset, b: xr.Dataset):
    for name in list(METRICS) + ["status", "failed"]:
        np.testing.assert_array_equal(a[name].values, b[name].values, err_msg=name)


@pytest.fixture(scope="module", autouse=True)
def four_devices(tmp_path_factory):
    """The grid sweep in a subprocess with 4 CPU devices (XLA_FLAGS must be set before JAX is
    imported), started first so that it compiles while the other tests run."""
    out = tmp_path_factory.mktemp("four_devices")
    script = textwrap.dedent(
        f"""
        import pathlib, sys
        sys.path.insert(0, {os.path.dirname(os.path.abspath(__file__))!r})
        import jax
        jax.config.update("jax_enable_x64", True)
        assert jax.device_count() == 4, jax.devices()
        import test_sweep as t
        t.run(out={str(out)!r})
        print("CHUNKS", len(list(pathlib.Path({str(out)!r}).glob("chunk_*"))))
        """
    )
    env = dict(os.environ, XLA_FLAGS="--xla_force_host_platform_device_count=4", JAX_PLATFORMS="cpu")
    job = subprocess.Popen([sys.executable, "-c", script], env=env, text=True,
                           stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    yield job, out
    if job.poll() is None:
        job.kill()
        job.communicate()


@pytest.fixture(scope="module")
def grid_result(tmp_path_factory):
    out = tmp_path_factory.mktemp("grid")
    return run(out=out, progress=True), out


def test_grid_labels_and_values_match_single_runs(grid_result):
    ds, out = grid_result
    assert dict(ds.sizes) == {"bearing.clearance": 3, "bearing.damping": 2}
    assert list(ds["peak_ball_load"].dims) == ["bearing.clearance", "bearing.damping"]
    np.testing.assert_array_equal(ds["bearing.clearance"].values, CLEARANCES)
    np.testing.assert_array_equal(ds["bearing.damping"].values, DAMPINGS)
    assert set(ds.data_vars) == {"peak_ball_load", "rms_bearing_force", "status", "failed"}
    assert ds.attrs["t1"] == T1 and ds.attrs["max_steps"] == MAX_STEPS and ds.attrs["rtol"] == 1e-8
    assert ds.attrs["jaxbearing_version"] == jb.__version__
    assert json.loads(ds.attrs["status_codes"])[str(MAX_STEPS_REACHED)] == "max_steps_reached"

    # the stiffly damped members fail and read NaN; the others succeed
    np.testing.assert_array_equal(ds.failed.values, [[False, True]] * 3)
    np.testing.assert_array_equal(ds.status.values, [[0, MAX_STEPS_REACHED]] * 3)
    assert np.isnan(ds.peak_ball_load.values[:, 1]).all()
    assert np.isfinite(ds.peak_ball_load.values[:, 0]).all()

    # each point run alone, under jit with the parameters traced (as in the sweep): equal to
    # the last bits
    @jax.jit
    def single(c, d):
        sol = jb.simulate(paths.replace(model(), {"bearing.clearance": c, "bearing.damping": d}),
                          T1, TS, max_steps=MAX_STEPS, throw=False)
        return {name: fn(sol) for name, fn in METRICS.items()}, sol.result._value

    for c in CLEARANCES:
        for d in DAMPINGS:
            values, status = single(c, d)
            point = ds.sel({"bearing.clearance": c, "bearing.damping": d})
            assert int(point.status) == int(status)
            if int(status) == 0:
                for name in METRICS:
                    np.testing.assert_allclose(float(point[name]), float(values[name]), rtol=1e-12, atol=0)

    # written as netCDF, same content
    with xr.open_dataset(out / "results.nc") as saved:
        assert_same(ds, saved.load())


def test_progress_bar_counts_chunks(tmp_path, capsys):
    run(out=tmp_path, progress=True)
    assert "3/3" in capsys.readouterr().err
    run(out=tmp_path, progress=True)  # all done already: the bar starts full
    assert "3/3" in capsys.readouterr().err


def test_list_of_points(grid_result):
    grid, _ = grid_result
    points = {"bearing.clearance": [60e-6, 20e-6, 40e-6], "bearing.damping": [300.0, 3e5, 300.0]}
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


def test_interrupted_sweep_resumes_without_recomputing(tmp_path, monkeypatch, grid_result):
    reference, _ = grid_result
    calls = []
    original = sweep_module._ChunkRunner.__call__

    def counting(self, points):
        calls.append(points.copy())
        return original(self, points)

    monkeypatch.setattr(sweep_module._ChunkRunner, "__call__", counting)

    # interrupted after the first chunk is written
    original_save = sweep_module._save_chunk

    def save_then_stop(path, *args):
        original_save(path, *args)
        raise KeyboardInterrupt

    monkeypatch.setattr(sweep_module, "_save_chunk", save_then_stop)
    with pytest.raises(KeyboardInterrupt):
        run(out=tmp_path)
    monkeypatch.setattr(sweep_module, "_save_chunk", original_save)
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
    reference, _ = grid_result
    real = sweep_module._run_chunk

    def raising(model, rows, *args):
        if np.any(np.asarray(rows)[:, 0] == 40e-6):
            raise jax.errors.JaxRuntimeError("INTERNAL: a check failed for clearance 40 um")
        return real(model, rows, *args)

    monkeypatch.setattr(sweep_module, "_run_chunk", raising)
    with pytest.warns(RuntimeWarning, match="chunk 1 raised"):
        ds = run(out=tmp_path)
    bad = ds["bearing.clearance"] == 40e-6
    assert (ds.status.where(bad, drop=True) == sweep_module.RAISED).all()
    assert ds.failed.where(bad, drop=True).all()
    assert np.isnan(ds.peak_ball_load.where(bad, drop=True)).all()
    errors = json.loads(ds.attrs["errors"])
    assert [e["point"]["bearing.clearance"] for e in errors] == [40e-6, 40e-6]
    assert "a check failed" in errors[0]["error"]
    assert_same(ds.where(~bad, drop=True), reference.where(~bad, drop=True))
    # kept in the chunk files: a rerun loads the marks
    monkeypatch.setattr(sweep_module, "_run_chunk", real)
    again = run(out=tmp_path)
    assert again.attrs["sweep_computed_points"] == 0
    assert again.attrs["errors"] == ds.attrs["errors"]


def test_different_arguments_in_the_same_folder_raise(grid_result):
    _, out = grid_result
    with pytest.raises(ValueError, match=r"parameters.*another `out`"):
        run({"bearing.clearance": [20e-6, 40e-6], "bearing.damping": DAMPINGS}, out=out)
    with pytest.raises(ValueError, match="metrics"):
        run(out=out, metrics={"peak_ball_load": METRICS["peak_ball_load"]})
    with pytest.raises(ValueError, match="model_fingerprint"):
        sweep(jb.cases.xu2014(impact=False, crank_speed=30.0), GRID, metrics=METRICS, t1=T1,
              ts=TS, max_steps=MAX_STEPS, chunk_size=CHUNK, progress=False, out=out)
    with pytest.raises(ValueError, match="simulate"):
        run(out=out, rtol=1e-7)
    with pytest.raises(ValueError, match="chunks of 2 points"):
        run(out=out, chunk_size=3)


def test_corrupted_chunk_names_the_file(tmp_path):
    run({"bearing.clearance": CLEARANCES[:2], "bearing.damping": DAMPINGS[:1]}, out=tmp_path)
    chunk = tmp_path / "chunk_00000.npz"
    good = chunk.read_bytes()
    chunk.write_bytes(good[: len(good) // 2])  # truncated
    with pytest.raises(ValueError, match="chunk_00000.npz.*corrupted"):
        run({"bearing.clearance": CLEARANCES[:2], "bearing.damping": DAMPINGS[:1]}, out=tmp_path)
    with open(chunk, "wb") as f:  # readable, but not what the manifest says
        np.savez(f, start=0, stop=2, points=np.zeros((2, 2)), metric_names=np.array(list(METRICS)),
                 values=np.zeros((2, 2)), status=np.zeros(2, np.int32), errors=np.array(["", ""]))
    with pytest.raises(ValueError, match="chunk_00000.npz.*parameter values"):
        run({"bearing.clearance": CLEARANCES[:2], "bearing.damping": DAMPINGS[:1]}, out=tmp_path)


def test_bad_arguments_are_rejected_before_running():
    with pytest.raises(ValueError, match=r"point 1 \(bearing.clearance = -1e-05.*clearance must be zero or positive"):
        run({"bearing.clearance": [1e-5, -1e-5]})
    with pytest.raises(ValueError, match="does not exist"):
        run({"bearing.nonsense": [1.0]})
    with pytest.raises(TypeError, match="throw"):
        run(throw=True)
    with pytest.raises(ValueError, match="collides"):
        run(metrics={"status": METRICS["peak_ball_load"]})


def test_four_devices_give_the_same_numbers(grid_result, four_devices):
    reference, _ = grid_result
    job, out = four_devices
    stdout, stderr = job.communicate(timeout=600)
    assert job.returncode == 0, stderr[-3000:]
    assert "CHUNKS 1" in stdout  # 4 devices x 2 points: 8 slots, 2 of them padding
    with xr.open_dataset(out / "results.nc") as four:
        four = four.load()
    assert four.attrs["parameters"] == reference.attrs["parameters"]
    assert_same(four, reference)


@pytest.mark.slow
def test_two_processes_with_jax_distributed(grid_result, tmp_path):
    """The multi-host path on one machine: two processes of one CPU device each, joined by
    `jax.distributed` (gloo collectives); process 0 writes, both return the whole result, and a
    rerun loads it (broadcast from process 0) instead of recomputing."""
    import socket

    reference, _ = grid_result
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
        jax.distributed.initialize("127.0.0.1:{port}", num_processes=2, process_id=int(sys.argv[1]))
        assert jax.device_count() == 2 and jax.local_device_count() == 1
        import test_sweep as t
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
        np.testing.assert_array_equal(np.array(loads, float), reference.peak_ball_load.values)
        np.testing.assert_array_equal(status, reference.status.values)
        assert recomputed == 0
    assert sorted(p.name for p in tmp_path.glob("chunk_*")) == ["chunk_00000.npz", "chunk_00001.npz"]
    with xr.open_dataset(tmp_path / "results.nc") as saved:
        assert_same(saved.load(), reference)

"""Every study runs in its quick mode and writes its outputs."""

import json
import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).parent.parent
TUNE = ROOT / "studies" / "tune_clearance.py"
SWEEP = ROOT / "studies" / "clearance_sweep.py"
# life_clearance: ~3 min quick (a tight-tolerance derivative check and a tuning compile);
# xu2014: 36 s, the same command line that tests/test_cli.py runs end to end;
# roller_comparison: four compiles of the paper's case (ball and roller, with and without impact);
# clearance_life: a sweep and a tuning compile (forward mode: tune's auto) for each of two bearings;
# joint_comparison: five compiles of the paper's crank (each joint at its crank pin)
SLOW_STUDIES = {"clearance_life.py", "joint_comparison.py", "life_clearance.py", "roller_comparison.py", "xu2014.py"}
OTHER_STUDIES = [
    pytest.param(p, marks=pytest.mark.slow) if p.name in SLOW_STUDIES else p
    for p in sorted((ROOT / "studies").glob("*.py"))
    if p != TUNE
]


def run(script, *args):
    result = subprocess.run(
        [sys.executable, str(script), *args], cwd=ROOT, capture_output=True, text=True, timeout=900
    )
    assert result.returncode == 0, result.stdout[-2000:] + result.stderr[-4000:]
    return result.stdout


@pytest.mark.parametrize("script", OTHER_STUDIES, ids=lambda p: p.name)
def test_study_runs_quick(script, tmp_path):
    run(script, "--quick", "--out", str(tmp_path))
    assert any(tmp_path.iterdir())


@pytest.mark.slow  # 35 s: another process and sweep compile; the study's quick run is in the default set
def test_dense_map_with_the_one_loop_solve(tmp_path):
    """``--grid`` spaces the values evenly and the members run as one loop (no output samples
    are read); a grid too large to print reports each metric's extremes, which are those of the
    written results."""
    import xarray as xr

    stdout = run(SWEEP, "--grid", "17", "2", "--t1", "0.045", "--out", str(tmp_path))
    ds = xr.open_dataset(tmp_path / "results.nc")
    assert dict(ds.sizes) == {"bearing.clearance": 17, "impact.restitution": 2}
    assert not ds.failed.any()
    assert json.loads((tmp_path / "manifest.json").read_text())["solve"] == "one_loop"
    assert ds["bearing.clearance"].values[[0, -1]].tolist() == pytest.approx([5e-6, 80e-6])
    printed = re.search(r"peak_ball_load: largest (\d+) N", stdout)
    assert printed and int(printed[1]) == round(float(ds.peak_ball_load.max()))
    assert (tmp_path / "peak_ball_load.png").stat().st_size > 10_000
    convergence = json.loads((tmp_path / "convergence.json").read_text())  # the paper's point
    assert convergence["converged"] and convergence["spread"] < 1e-3
    assert "peak ball load at the paper's point, rtol 1e-8 and 1e-10" in stdout


@pytest.mark.slow  # ~80 s: two forward-mode compilations of the paper's case (tune's auto)
def test_tune_study_outputs(tmp_path):
    run(TUNE, "--quick", "--out", str(tmp_path))
    summary = json.loads((tmp_path / "summary.json").read_text())
    assert (tmp_path / "convergence.png").stat().st_size > 10_000
    assert len(summary["identification"]["loss"]) == 3
    # two Adam steps from +15 % / -11 % already reduce the misfit
    assert summary["identification"]["loss"][-1] < summary["identification"]["loss"][0]
    assert 5e-6 <= summary["design"]["clearance_m"] <= 80e-6

"""The ``jaxbearing xu2014`` command (jaxbearing.cli) and its helpers (jaxbearing.report)."""

import contextlib
import csv
import dataclasses
import inspect
import json
import math
import os
import re
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path
from types import SimpleNamespace

import equinox as eqx
import jax
import numpy as np
import pytest

from jaxbearing import _files, cases, cli, paths, provenance, report
from jaxbearing.cli import config
from jaxbearing.cases import TABLE5, TABLE5_TIMES
from jaxbearing.solution import (
    RESULTS, Contacts, ElementRecords, Episodes, Intervals, Layout, Records, Samples, Solution,
)  # fmt: skip

ROOT = Path(__file__).resolve().parents[1]


# ---------------------------------------------------------------------------------------------
# Hand-made Solution-like inputs
# ---------------------------------------------------------------------------------------------


class Still(eqx.Module):
    """The model of a hand-made solution (`fake_solution`): every acceleration zero."""

    q0: np.ndarray
    qd0: np.ndarray

    def accelerations(self, t, q, qd, states, *, sparse=False):
        return jax.numpy.zeros_like(q)


def fake_solution(ts, ball_loads=None, contact_force=None, onsets=(), max_segments=6):
    """A `Solution` of the xu2014 layout (4 bodies x 3 coordinates; a bearing joint, a spring,
    a contact) made by hand: its samples as given, its records the peaks of the samples over
    the intervals between the stops a solve of [ts[0], ts[-1]] has (t0, the paper case's
    window start where inside, t1). ``onsets``: (slot, (time, approach speed[, end, peak force,
    peak time[, contact index]]))."""
    ts = np.asarray(ts, dtype=float)
    T = ts.size
    q = np.zeros((T, 12))
    q[:, 6] = 0.1 + ts  # slider x
    q[:, 9] = 0.18  # target x
    qd = np.zeros((T, 12))
    qd[:, 6] = 1.0
    loads = np.zeros((T, 8)) if ball_loads is None else np.asarray(ball_loads, dtype=float)
    force = np.stack([3.0 * np.ones(T), 4.0 * np.ones(T)], axis=1)  # |F| = 5 N
    records = np.full((5, max_segments), np.nan)  # time, speed, end, peak force, peak time
    index = np.full(max_segments, -1)
    for slot, record in onsets:
        records[: len(record[:5]), slot] = record[:5]
        index[slot] = record[5] if len(record) > 5 else 0
    contact = np.zeros(T) if contact_force is None else np.asarray(contact_force, dtype=float)
    magnitude = np.hypot(force[:, 0], force[:, 1])
    layout = Layout((None,) * 3, ("BearingJoint", "SpringDamper", "CircleContact"), (0,), (2,), (2,), (9,))
    bearing = {
        "element_loads": loads, "force": force, "cage_angle": np.zeros(T),
        "max_element_load": loads.max(axis=1), "force_magnitude": magnitude,
    }  # fmt: skip
    samples = Samples(q, qd, np.linspace(0.0, 1e-11, T), (
        bearing,
        {"tension": np.zeros(T), "length": np.zeros(T)},
        {"normal_force": contact, "friction_force": np.zeros(T), "penetration": np.zeros(T),
         "approach_speed": np.zeros(T)},
    ), (), Still(np.zeros(12), np.zeros(12)))  # fmt: skip
    intervals, peaks, times, at_peak = fake_records(ts, loads, magnitude, contact)
    none = ElementRecords({}, {}, {}, {})
    elements = (
        ElementRecords(
            {"max_element_load": peaks[0], "force_magnitude": peaks[1]},
            {"max_element_load": times[0], "force_magnitude": times[1]},
            {"max_element_load": at_peak}, {},
        ),
        none,
        ElementRecords({"normal_force": peaks[2]}, {"normal_force": times[2]}, {}, {}),
    )
    valid = index >= 0
    contacts = Contacts(records[0], records[1], index, valid, records[2], records[3], records[4])
    episodes = Episodes(records[0], records[1], np.where(valid, 2, -1), valid, *records[2:])
    zeros = np.zeros((intervals.t_start.size, 12))
    recorded = Records(
        intervals, elements, zeros, zeros, none, episodes, contacts, np.asarray(1e-11), {},
    )
    stats = {"num_steps": 100, "num_rejected_steps": 7, "num_segments": 3, "num_events": 2}
    return Solution(ts, samples, recorded, stats, RESULTS.successful, np.asarray(ts[-1]),
                    np.asarray(ts[-1]), None, layout)


def fake_records(ts, loads, bearing, contact):
    """`Intervals` and the peaks (3, C), their times (3, C) of the largest ball load, |F| and
    the contact force, and the ball loads at the largest ball load (C, 8), of the samples, over
    the intervals between the stops that a solve of [ts[0], ts[-1]] has (t0, the paper case's
    window start where inside, t1)."""
    edges = np.unique(np.clip([ts[0], report.PEAK_FROM, ts[-1]], ts[0], ts[-1]))
    rows, times, at_peak = [], [], []
    for a, b in zip(edges[:-1], edges[1:]):
        inside = np.flatnonzero((ts >= a) & (ts <= b))
        largest = loads[inside].max(axis=1)
        series = (largest, bearing[inside], contact[inside])
        rows.append([x.max() for x in series])
        times.append([ts[inside[np.argmax(x)]] for x in series])
        at_peak.append(loads[inside[np.argmax(largest)]])
    intervals = Intervals(edges[:-1], edges[1:], edges[1:] - edges[:-1], np.ones(len(rows), bool))
    return intervals, np.array(rows).T.copy(), np.array(times).T.copy(), np.array(at_peak)


def test_series_names_and_values():
    sol = fake_solution([0.0, 0.1, 0.2])
    data = report.series(sol)
    assert list(data)[:7] == [
        "t",
        "slider_x",
        "slider_v",
        "slider_a",
        "target_x",
        "target_v",
        "target_a",
    ]
    assert report.ball_keys(data) == [f"ball{i}" for i in range(1, 9)]
    np.testing.assert_allclose(data["slider_x"], [0.1, 0.2, 0.3])
    np.testing.assert_allclose(data["bearing_f"], 5.0)
    assert report.csv_columns(data)[:3] == ["t_s", "slider_x_m", "slider_v_m_per_s"]


def test_peak_over_window():
    ts = np.linspace(0.0, 0.1, 11)  # 0, 0.01, ..., 0.1
    force = np.zeros(11)
    force[1] = 900.0  # start-up transient at 0.01 s: outside the window
    force[6] = 300.0  # 0.06 s
    force[7] = np.nan  # a failed sample is ignored
    data = report.series(fake_solution(ts, contact_force=force))
    assert report.peak(data, "contact_force") == (900.0, pytest.approx(0.01), "contact_force")
    p = report.peak(data, "contact_force", t_min=0.04)
    assert (p.value, p.time) == (300.0, pytest.approx(0.06))
    p = report.peak(data, "contact_force", 0.07, 0.1)
    assert p.value == 0.0 and p.time == pytest.approx(0.08)
    p = report.peak(data, "contact_force", 0.2)  # empty window
    assert math.isnan(p.value) and math.isnan(p.time) and p.key is None


def test_peak_over_balls():
    ts = np.linspace(0.0, 0.1, 11)
    loads = np.zeros((11, 8))
    loads[2, 0] = 500.0  # ball 1 at 0.02 s
    loads[5, 3] = 120.0  # ball 4 at 0.05 s
    loads[9, 6] = 80.0  # ball 7 at 0.09 s
    sol = fake_solution(ts, ball_loads=loads)
    assert report.peak(sol, "ball_loads") == (500.0, pytest.approx(0.02), "ball1")
    assert report.peak(sol, "ball_loads", t_min=0.04) == (120.0, pytest.approx(0.05), "ball4")
    assert report.peak(sol, ["ball7", "ball8"]) == (80.0, pytest.approx(0.09), "ball7")


def test_onsets_from_padded_contacts():
    sol = fake_solution([0.0, 1.0], onsets=[(2, (0.095, 0.5)), (0, (0.0913, 2.2))])
    times, speeds = report.onsets(sol)
    np.testing.assert_allclose(times, [0.0913, 0.095])
    np.testing.assert_allclose(speeds, [2.2, 0.5])
    assert report.first_contact(sol) == (0.0913, 2.2)
    assert all(math.isnan(x) for x in report.first_contact(fake_solution([0.0, 1.0])))


def test_contacts_from_the_records():
    """`report.contacts`: one impact contact's records in time order, padded slots and other
    contacts left out, a contact still on at the end ending at t_final; the summary's contact
    intervals are these (the only contact's); with several, the one named by ``contact=``."""
    sol = fake_solution(
        np.linspace(0.0, 0.1, 11),
        onsets=[
            (4, (0.095, 0.5, math.nan, 80.0, 0.097)),
            (1, (0.0913, 2.2, 0.0915, 6900.0, 0.0914)),
            (2, (0.092, 0.3, 0.093, math.nan, math.nan, 1)),
        ],
    )
    found = report.contacts(sol)
    assert found == [
        report.Contact(0.0913, 0.0915, 6900.0, 0.0914, 2.2),
        report.Contact(0.095, 0.1, 80.0, 0.097, 0.5),
    ]
    assert report.summarize(sol)["contact_intervals"] == [
        [0.0913, 0.0915, 6900.0, 0.0914],
        [0.095, 0.1, 80.0, 0.097],
    ]
    # a model of two contacts: each one's by its index, None refused
    two = sol.layout._replace(names=(None,) * 4, kinds=sol.layout.kinds + ("CircleContact",), contacts=(2, 3))
    sol = dataclasses.replace(sol, layout=two)
    (second,) = report.contacts(sol, contact=1)
    assert (second.start, second.end, second.approach_speed) == (0.092, 0.093, 0.3)
    assert math.isnan(second.peak_force)  # its slot recorded no peak
    assert [c.start for c in report.contacts(sol, contact=0)] == [0.0913, 0.095]
    with pytest.raises(ValueError, match="pass contact="):
        report.contacts(sol)
    with pytest.raises(ValueError, match="contact must index"):
        report.contacts(sol, contact=2)


def test_contact_intervals():
    ts = np.arange(10) * 1e-3
    force = np.array([0, 5, 7, 0, 0, 0, 2, 9, 4, 1.0])
    intervals = report.contact_intervals(report.series(fake_solution(ts, contact_force=force)))
    assert intervals == [(1e-3, 2e-3, 7.0), (6e-3, pytest.approx(9e-3), 9.0)]


def test_table5_interpolates_and_compares():
    ts = np.linspace(0.0, 0.2, 21)  # 10 ms steps: 0.04 ... 0.12 are samples, odd values are not
    loads = np.outer(ts, np.arange(1, 9))  # ball r: r * t [N]
    sim = report.table5(fake_solution(ts, ball_loads=loads))
    assert sim.shape == (8, 5)
    np.testing.assert_allclose(sim, np.outer(np.arange(1, 9), TABLE5_TIMES), rtol=1e-12)
    between = report.table5(fake_solution(ts, ball_loads=loads), times=[0.045, 0.5])
    np.testing.assert_allclose(between[:, 0], 0.045 * np.arange(1, 9), rtol=1e-12)
    assert np.isnan(between[:, 1]).all()  # beyond the simulated span

    assert report.table5_rms(TABLE5) == 0.0
    assert report.table5_mismatches(TABLE5) == 0
    shifted = TABLE5 + 2.0 * (TABLE5 > 0)  # 2 N more on every loaded entry, none switches
    n_loaded = int((TABLE5 > 0).sum())
    assert report.table5_rms(shifted) == pytest.approx(2.0 * math.sqrt(n_loaded / 40))
    assert report.table5_mismatches(shifted) == 0
    flipped = TABLE5.copy()
    flipped[0, 0] = 10.0  # ball 1 loaded where the paper has it free
    flipped[1, 0] = 0.0  # ball 2 free where the paper has 42.9 N
    assert report.table5_mismatches(flipped) == 2
    partial = np.where(np.arange(5) < 3, TABLE5 + 1.0, np.nan)  # a run that stopped before 0.1 s
    assert report.table5_rms(partial) == pytest.approx(1.0)
    t5 = report.table5_summary(fake_solution(ts, ball_loads=loads))
    assert t5["entries_compared"] == 40 and len(t5["simulated_N"]) == 8


def test_summarize_is_json_ready(tmp_path):
    ts = np.linspace(0.0, 0.1, 11)
    sol = fake_solution(
        ts, contact_force=np.where(ts > 0.085, 50.0, 0.0), onsets=[(1, (0.0913, 2.2))]
    )
    s = report.summarize(sol)
    assert s["first_contact_time_s"] == 0.0913 and s["contact_count"] == 1
    assert s["peak_impact_force_N"] == 50.0 and s["peak_bearing_force_N"] == 5.0
    assert s["num_steps"] == 100 and s["max_drift"] == pytest.approx(1e-11)
    path = report.write_json(tmp_path / "s.json", {"a": s, "nan": math.nan, "arr": np.arange(2)})
    loaded = json.loads(path.read_text())
    assert loaded["nan"] is None and loaded["arr"] == [0, 1]
    assert "peak impact force" in report.format_summary("with impact", s)


def test_summary_peaks_come_from_the_solution_not_the_samples():
    """The summary's peaks, their times and the peak ball are `jb.metrics`' (every step and its
    interpolant, recorded per stop interval), not the largest sample's; NaN (ball None) in a
    window the run did not reach."""
    ts = np.linspace(0.0, 0.1, 11)
    loads = np.zeros((11, 8))
    loads[9, 1] = 5.0  # ball 2 carries the largest sampled load
    sol = fake_solution(ts, ball_loads=loads, contact_force=np.where(ts > 0.085, 50.0, 0.0))
    assert report.summarize(sol)["peak_ball_load_ball"] == 2
    bearing, contact = sol.records.elements[0], sol.records.elements[2]
    for records, name, peak, when in (  # between samples, after 0.04 s
        (bearing, "max_element_load", 7.0, 0.0512),
        (bearing, "force_magnitude", 6.0, 0.0634),
        (contact, "normal_force", 64.0, 0.0937),
    ):
        records.peaks[name][-1], records.peak_times[name][-1] = peak, when
    bearing.at_peak["max_element_load"][-1] = [0.0, 1.0, 2.0, 3.0, 7.0, 2.0, 1.0, 0.0]
    s = report.summarize(sol)
    assert (s["peak_ball_load_N"], s["peak_bearing_force_N"], s["peak_impact_force_N"]) == (7.0, 6.0, 64.0)
    times = [s[f"peak_{name}_time_s"] for name in ("ball_load", "bearing_force", "impact_force")]
    assert times == [0.0512, 0.0634, 0.0937] and s["peak_ball_load_ball"] == 5
    early = report.summarize(fake_solution(np.linspace(0.0, 0.03, 4)))
    assert math.isnan(early["peak_bearing_force_N"]) and math.isnan(early["peak_ball_load_N"])
    assert math.isnan(early["peak_ball_load_time_s"]) and early["peak_ball_load_ball"] is None
    assert early["peak_impact_force_N"] == 0.0


def test_figures_draw_each_curve_s_envelope_with_every_extreme():
    """A 200 001-sample curve with 1-sample spikes is drawn from about 2 x 2000 points that
    hold every run's minimum and maximum: the spikes, the global extremes and the ends."""
    from jaxbearing.report._figures import envelope

    t = np.linspace(0.0, 0.2, 200_001)
    y = np.sin(2 * np.pi * 10 * t)
    spikes = [1234, 99_999, 150_001]
    y[spikes] = [5.0, -7.0, 3.0]
    te, ye = envelope(t, y, 2000)
    assert te.size <= 4000 and np.all(np.diff(te) > 0)
    assert set(t[spikes]) <= set(te)
    assert ye.max() == 5.0 and ye.min() == -7.0
    small = envelope(t[:100], y[:100], 2000)
    assert small[0].size == 100


def test_write_csv_stride_and_atomic(tmp_path):
    ts = np.linspace(0.0, 1.0, 11)
    path = report.write_csv(tmp_path / "x.csv", fake_solution(ts), stride=3)
    rows = list(csv.reader(path.open()))
    assert rows[0][0] == "t_s" and rows[0][-1] == "penetration_m" and len(rows[0]) == 20
    np.testing.assert_allclose([float(r[0]) for r in rows[1:]], [0.0, 0.3, 0.6, 0.9, 1.0])
    with pytest.raises(RuntimeError), _files.atomic_path(path) as tmp:
        tmp.write_text("half-written")
        raise RuntimeError("interrupted")
    assert path.read_text().startswith("t_s,")  # the old file survives
    assert os.listdir(tmp_path) == ["x.csv"]  # no temp file left


# ---------------------------------------------------------------------------------------------
# The command, in quick settings
# ---------------------------------------------------------------------------------------------


# the paper's span at up to 2048 output times: both cases are the compiled solves of
# tests/test_xu2014.py and tests/test_life.py, on the same worker (tests/conftest.py)
QUICK = ["--t1", "0.2", "--samples", "2001", "--no-rerun"]


@pytest.fixture(scope="module")
def quick_run(tmp_path_factory):
    out = tmp_path_factory.mktemp("xu2014")
    rc = cli.main(["xu2014", "--out", str(out), *QUICK])
    return rc, out


def test_cli_writes_files(quick_run):
    rc, out = quick_run
    assert rc == 0
    for name in ("with_impact.csv", "without_impact.csv", "summary.json", *FIGURES):
        assert (out / name).stat().st_size > 1000, name
    assert not [p for p in os.listdir(out) if p.endswith(".tmp")]
    with (out / "with_impact.csv").open() as f:
        header = next(csv.reader(f))
        n_rows = sum(1 for _ in f)
    assert header[:2] == ["t_s", "slider_x_m"] and "ball8_N" in header
    assert n_rows == 2001  # every sample: they are 100 µs apart, more than --csv-dt (10 µs)


FIGURES = ("fig12_slider_target.png", "fig13_impact_force.png", "fig14_bearing_force.png", "fig15_ball_loads.png")


def fake_cases(monkeypatch, stop_at=None, stop="Ctrl-C"):
    """Stand-ins for the solves (`fake_solution`); the case ``stop_at`` fails (`_run_case`
    returns None after printing the solve's error) or raises KeyboardInterrupt."""
    sol = fake_solution(np.linspace(0.0, 0.2, 2001))

    def run_case(args, model, ts, label):
        if label == stop_at:
            if stop == "Ctrl-C":
                raise KeyboardInterrupt
            return None
        return sol, report.summarize(sol) | {"wall_first_s": 0.5, "wall_second_s": None}

    monkeypatch.setattr(cli, "_run_case", run_case)


def staging_folders(out):
    return sorted(out.parent.glob(f"{out.name}.partial-*"))


def snapshot(folder):
    return {p.name: p.read_bytes() for p in folder.iterdir()}


@pytest.mark.parametrize("stop", ["a failed solve", "Ctrl-C"])
def test_a_run_stopped_in_its_second_case_keeps_the_first_in_its_staging_folder(tmp_path, monkeypatch, capsys, stop):
    """A run writes into a staging folder and moves it to --out only when complete. One that
    stops in its second case (its solve fails: status 1, the figures of the first case drawn;
    Ctrl-C: status 130, at once) leaves --out uncreated, and the staging folder holds the first
    case's CSV and summary.json and a marker that says what it is; one line on stderr names it."""
    fake_cases(monkeypatch, stop_at="without impact", stop=stop)
    out = tmp_path / "out"
    assert cli.main(["xu2014", "--out", str(out)]) == (130 if stop == "Ctrl-C" else 1)
    assert not out.exists()
    [staging] = staging_folders(out)
    figures = FIGURES if stop == "a failed solve" else ()
    assert set(os.listdir(staging)) == {"with_impact.csv", "summary.json", "INCOMPLETE", *figures}
    assert list(json.loads((staging / "summary.json").read_text())["cases"]) == ["with_impact"]
    why = "the solve of the case without impact failed" if stop == "a failed solve" else "stopped (KeyboardInterrupt)"
    marker = (staging / "INCOMPLETE").read_text()
    assert f"Stopped: {why}." in marker and "Finished: with impact" in marker and str(out) in marker
    line = capsys.readouterr().err.strip().split("\n")[-1]
    assert line == (f"jaxbearing xu2014: {why}; the cases finished (with impact) are in {staging}, "
                    f"marked INCOMPLETE; {out} was not created")


def test_a_folder_never_holds_files_of_two_runs(tmp_path, monkeypatch, capsys):
    """A complete run replaces an earlier result whole (its figures do not survive a rerun
    without figures); a rerun stopped after its first case leaves the complete earlier result
    as it was, byte for byte, and its own first case in its staging folder; a run stopped
    before any case deletes its staging folder."""
    out = tmp_path / "out"
    fake_cases(monkeypatch)
    assert cli.main(["xu2014", "--out", str(out)]) == 0
    assert set(os.listdir(out)) == {"with_impact.csv", "without_impact.csv", "summary.json", *FIGURES}
    assert not staging_folders(out) and os.listdir(tmp_path) == ["out"]
    assert cli.main(["xu2014", "--out", str(out), "--no-figures", "--t1", "0.15"]) == 0
    complete = snapshot(out)
    assert set(complete) == {"with_impact.csv", "without_impact.csv", "summary.json"}
    assert json.loads(complete["summary.json"])["t1_s"] == 0.15

    fake_cases(monkeypatch, stop_at="without impact")
    assert cli.main(["xu2014", "--out", str(out), "--no-figures", "--t1", "0.1"]) == 130
    assert snapshot(out) == complete
    [staging] = staging_folders(out)
    assert set(os.listdir(staging)) == {"with_impact.csv", "summary.json", "INCOMPLETE"}
    assert json.loads((staging / "summary.json").read_text())["t1_s"] == 0.1
    assert capsys.readouterr().err.strip().endswith(f"marked INCOMPLETE; {out} is as it was")

    fake_cases(monkeypatch, stop_at="with impact")
    assert cli.main(["xu2014", "--out", str(out), "--no-figures"]) == 130
    assert snapshot(out) == complete and staging_folders(out) == [staging]  # the earlier one kept
    assert capsys.readouterr().err.strip() == (
        f"jaxbearing xu2014: stopped (KeyboardInterrupt) before any case was finished; nothing was "
        f"written ({out} is as it was)")


def _file_out(tmp_path):
    (tmp_path / "results").write_text("a file")
    return tmp_path / "results", r"is a file, not a folder: name a folder \(it is created if missing\)"


def _foreign_out(tmp_path):
    out = tmp_path / "results"
    out.mkdir()
    (out / "summary.json").write_text("{}")
    (out / "notes.txt").write_text("mine")
    return out, (r"holds files that are not a result of this command \(notes\.txt\), which replacing "
                 r"it by the new result would delete: name another folder, or empty it")


def _read_only_parent(tmp_path):
    parent = tmp_path / "parent"
    parent.mkdir()
    return parent / "results", (rf"cannot write beside it, in {re.escape(str(parent))} "
                                r"\((Read-only file system|Permission denied)\)")


def _read_only_out(tmp_path):
    out = tmp_path / "results"
    out.mkdir()
    (out / "summary.json").write_text("{}")
    return out, r"is a read-only folder: name a folder this process may write"


@pytest.mark.parametrize("where", [_file_out, _foreign_out, _read_only_parent, _read_only_out])
def test_out_is_checked_before_anything_is_solved(tmp_path, monkeypatch, capsys, where):
    """--out naming a file, a folder that holds other files, or a folder that cannot be written
    or created: status 2 and one line on stderr, before any case is solved; nothing changes."""
    from test_sweep_folder import read_only

    def run_case(*args):
        raise AssertionError("a case was solved")

    monkeypatch.setattr(cli, "_run_case", run_case)
    out, message = where(tmp_path)
    locked = out.parent if where is _read_only_parent else out
    before = sorted(p.relative_to(tmp_path) for p in tmp_path.rglob("*"))
    with read_only(locked) if where in (_read_only_parent, _read_only_out) else contextlib.nullcontext():
        assert cli.main(["xu2014", "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert re.fullmatch(rf"jaxbearing xu2014: --out {re.escape(str(out))}: {message}\n", err), err
    assert sorted(p.relative_to(tmp_path) for p in tmp_path.rglob("*")) == before


def test_cli_summary(quick_run):
    _, out = quick_run
    s = json.loads((out / "summary.json").read_text())
    imp, free = s["cases"]["with_impact"], s["cases"]["without_impact"]
    for case in (imp, free):
        for key in (
            "first_contact_time_s",
            "first_contact_approach_speed_m_per_s",
            "contact_count",
            "peak_impact_force_N",
            "peak_bearing_force_N",
            "peak_ball_load_N",
            "max_drift",
            "num_steps",
            "num_rejected_steps",
            "wall_first_s",
        ):
            assert key in case, key
        assert case["t_final_s"] == pytest.approx(0.2)
        assert case["max_drift"] < 1e-8
    # the paper's case as the library computes it (docs/xu2014.md's table; tests/test_xu2014.py checks
    # it against the paper): the onset to the event's tolerance, the peaks to 2e-3, which covers
    # another step sequence on another machine (two solves of this case differ by up to 5e-4)
    assert imp["first_contact_time_s"] == pytest.approx(0.091348, abs=2e-6)
    assert imp["first_contact_approach_speed_m_per_s"] == pytest.approx(2.2164, rel=2e-3)
    assert imp["contact_count"] == 12  # 6 strikes per revolution, from 0.091 s and 0.191 s
    assert imp["peak_impact_force_N"] == pytest.approx(6933.0, rel=2e-3)
    assert imp["peak_bearing_force_N"] > 1e3  # impacts lift the bearing to kN levels
    assert free["contact_count"] == 0 and free["peak_impact_force_N"] == 0.0
    assert free["peak_bearing_force_N"] == pytest.approx(248.7, rel=2e-3)
    t5 = s["table5"]
    assert np.array(t5["simulated_N"]).shape == (8, 5)
    assert t5["entries_compared"] == 40  # 0.04 ... 0.12 s
    assert t5["rms_N"] == pytest.approx(7.35, rel=1e-2) and t5["loaded_state_mismatches"] <= 3



def test_the_summary_says_where_each_peak_lies_against_the_figures():
    """The summary's peaks are over the whole run (from the window start), the figures over
    `cases.FIGURE_WINDOW`: a peak outside them is said to be so, and the figures' own peak is
    given below it, read off the samples as the figures draw them; one inside says so alone."""
    ts = np.linspace(0.0, 0.2, 201)
    loads = np.zeros((201, 8))
    loads[100, 2] = 40.0  # ball 3 at 0.1 s: in the figures
    loads[190, 3] = 90.0  # ball 4 at 0.19 s: after them
    contact = np.where(np.isclose(ts, 0.092), 700.0, 0.0)  # inside
    sol = fake_solution(ts, ball_loads=loads, contact_force=contact, onsets=[(0, (0.0915, 2.2))])
    s = report.summarize(sol) | report.figure_peaks(report.series(sol))
    assert s["figure_window_s"] == [0.04, 0.14] == list(cases.FIGURE_WINDOW)
    assert (s["figure_peak_ball_load_N"], s["figure_peak_ball_load_time_s"], s["figure_peak_ball_load_ball"]) \
        == (40.0, pytest.approx(0.1), 3)
    assert s["figure_peak_impact_force_N"] == 700.0
    text = report.format_summary("with impact", s)
    assert "ball 4 at t = 0.190000 s  (t >= 0.04 s; after the figures' 0.04-0.14 s)\n" \
           "                       40.0 N, ball 3 at t = 0.100000 s  the figures' peak (sampled)" in text
    assert "700.0 N at t = 0.092000 s  (whole run; in the figures)\n  peak bearing" in text
    assert "5.0 N at t = 0.040000 s  (t >= 0.04 s; in the figures)\n  peak ball load" in text
    without = report.format_summary("with impact", report.summarize(sol))  # no figures drawn
    assert "figures" not in without


def test_the_run_s_summary_places_its_peaks_against_its_figures(quick_run):
    """The paper's case: the bearing's and the balls' peaks over t >= 0.04 s come at 0.1925 s,
    in the second revolution, after the figures' 0.04-0.14 s; the summary says so and gives
    the figures' peaks, which lie in them and below the run's."""
    _, out = quick_run
    s = json.loads((out / "summary.json").read_text())
    imp = s["cases"]["with_impact"]
    a, b = imp["figure_window_s"]
    for name in ("bearing_force", "ball_load"):
        assert imp[f"peak_{name}_time_s"] > b
        assert a <= imp[f"figure_peak_{name}_time_s"] <= b
        assert imp[f"figure_peak_{name}_N"] <= imp[f"peak_{name}_N"]
    assert a <= imp["peak_impact_force_time_s"] <= b  # the first strike, at 0.0914 s
    text = report.format_summary("with impact", imp)
    assert text.count("after the figures' 0.04-0.14 s") == 2
    assert text.count("the figures' peak (sampled)") == 2


def test_module_entry_point_help():
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    for args, options in (
        (["-m", "jaxbearing.cli", "xu2014", "--help"], ("--out", "--config")),
        ([str(ROOT / "studies" / "xu2014.py"), "--help"], ("--out",)),
    ):
        done = subprocess.run(
            [sys.executable, *args],
            check=False,
            capture_output=True,
            text=True,
            env=env,
            cwd=ROOT,
            timeout=60,
        )
        assert done.returncode == 0, done.stderr
        assert all(option in done.stdout for option in options)


def start_command(out, *options, env=None):
    """``python -m jaxbearing.cli xu2014 --out OUT *options`` as a child process (its stdout and
    stderr piped, as text)."""
    return subprocess.Popen(
        [sys.executable, "-m", "jaxbearing.cli", "xu2014", "--out", str(out), *options],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, cwd=ROOT,
        env=dict(os.environ if env is None else env, PYTHONPATH=str(ROOT)),
    )


def read_until(stream, text):
    """The lines of ``stream`` up to the first that holds ``text`` (AssertionError at the end)."""
    lines = []
    while line := stream.readline():
        lines.append(line)
        if text in line:
            return lines
    raise AssertionError(f"{text!r} not found in {''.join(lines)!r}")


def earlier_result(out):
    """A complete result of an earlier run in ``out`` (the names of one; made-up contents)."""
    out.mkdir()
    for name in ("with_impact.csv", "without_impact.csv", "summary.json"):
        (out / name).write_text(f"an earlier run's {name}")
    return snapshot(out)


@pytest.mark.slow  # 60-90 s: five processes each start compiling the paper's case
@pytest.mark.parametrize("stop", [(signal.SIGTERM, "with", 1.0, 143), (signal.SIGTERM, "with", 4.0, 143),
                                  (signal.SIGTERM, "with", 10.0, 143), (signal.SIGTERM, "without", 2.0, 143),
                                  (signal.SIGINT, "with", 6.0, 130)],
                         ids=lambda s: f"{s[0].name}-{s[1]}-impact-{s[2]:g}s")
def test_a_signal_stops_the_command_at_once_while_a_case_compiles(tmp_path, own_cache_env, stop):
    """SIGTERM (or SIGINT) sent while a case is traced, lowered or compiled by XLA (without the
    compilation cache, so that it compiles; the delay counts from that case's "compiling" line,
    so that no machine is fast enough to finish the run first) stops the command within seconds,
    every time: exit status 143 (130), one line on stderr, no traceback; the earlier result in
    --out is as it was and, where no case was finished, the staging folder is gone. Before,
    SIGTERM was mapped to KeyboardInterrupt, which JAX's garbage-collection callback swallowed in
    3 of 5 tries: the run went on and exited 0."""
    number, case, delay, status = stop
    out = tmp_path / "out"
    before = earlier_result(out)
    child = start_command(out, *QUICK, "--no-figures", env=own_cache_env(JAXBEARING_NO_COMPILATION_CACHE="1"))
    try:
        read_until(child.stderr, "with impact: compiling the model")
        lines = read_until(child.stderr, "without impact: compiling the model") if case == "without" else []
        time.sleep(delay)
        child.send_signal(number)
        sent = time.monotonic()
        _, rest = child.communicate(timeout=60)
    finally:
        child.kill()
    err = "".join(lines) + rest  # what followed the first case's "compiling" line
    assert time.monotonic() - sent < 10, "the signal did not stop the command at once"
    assert child.returncode == status, err
    stopped = f"jaxbearing xu2014: stopped by {number.name}"
    if "with impact: done" in err:  # the first case was solved before the signal
        assert err.rstrip("\n").split("\n")[-1].startswith(stopped), err
    else:
        assert err == f"{stopped} before any case was finished; nothing was written ({out} is as it was)\n"
        assert not staging_folders(out)
    assert "Traceback" not in err
    assert snapshot(out) == before


@pytest.mark.slow  # 10-20 s: the quick run's solves, loaded from the compilation cache
def test_sigterm_in_the_second_case_keeps_the_first_beside_the_earlier_result(quick_run, tmp_path):
    """A rerun into a folder that holds a complete result, stopped by SIGTERM in its second case:
    exit status 143 with one line naming the staging folder; --out holds the earlier result as
    it was, and the staging folder the first case's CSV and summary.json, marked INCOMPLETE."""
    out = tmp_path / "out"
    shutil.copytree(quick_run[1], out)
    before = snapshot(out)
    child = start_command(out, *QUICK, "--no-figures")
    try:
        read_until(child.stderr, "without impact: compiling the model")
        child.send_signal(signal.SIGTERM)
        _, err = child.communicate(timeout=60)
    finally:
        child.kill()
    assert child.returncode == 143, err
    [staging] = staging_folders(out)
    assert err == (f"jaxbearing xu2014: stopped by SIGTERM; the cases finished (with impact) are in "
                   f"{staging}, marked INCOMPLETE; {out} is as it was\n")
    assert set(os.listdir(staging)) == {"with_impact.csv", "summary.json", "INCOMPLETE"}
    assert "Stopped: stopped by SIGTERM." in (staging / "INCOMPLETE").read_text()
    assert snapshot(out) == before



@pytest.mark.parametrize("options, message", [
    (["--t1", "100"], r"--t1 100 s with 100000001 output times needs about 166 GB of memory \(1664 B an "
                      r"output time, 4\.72 MB for the solve's segments\), more than the 2 GB available: "
                      r"pass --samples 1199087 or fewer, or a shorter --t1"),
    (["--t1", "1e9", "--samples", "1001"], r"--t1 1e\+09 s with 1001 output times needs about 39\.6 TB of "
                                           r"memory .*, more than the 2 GB available: use a shorter --t1"),
])
def test_a_run_larger_than_memory_is_refused_before_anything_is_solved(tmp_path, monkeypatch, capsys, options, message):
    """--t1 100 (10^8 output times) or 1e9 (the solve's segment slots alone) ended in raw
    out-of-memory tracebacks and left a staging folder marked as running. The outputs' size is
    checked against the memory available first: status 2, one line naming both and the fix,
    nothing written."""
    monkeypatch.setattr(cli, "_available_memory", lambda: 2_000_000_000)
    monkeypatch.setattr(cli, "_run_case", lambda *args: pytest.fail("a case was solved"))
    assert cli.main(["xu2014", "--out", str(tmp_path / "out"), *options]) == 2
    err = capsys.readouterr().err
    assert re.fullmatch(rf"jaxbearing xu2014: {message}\n", err), err
    assert os.listdir(tmp_path) == []


def test_the_memory_check_bounds_what_a_run_takes():
    """The estimate (`OUTPUT_COPIES` copies of the outputs' floats) counts every float a
    solution holds per output time, and lets the default run (0.2 s at 1 µs) pass with room;
    the machine's memory is read (where the platform tells it)."""
    model = cases.xu2014()
    n_floats = 1 + 3 * 12 + (8 + 2 + 1) + 3 * 1 + 1  # t, q qd qdd, ball loads force cage, contact, drift
    assert cli._floats_per_output(model) == n_floats == 52
    sol_fields = report.series(fake_solution(np.linspace(0.0, 0.2, 3)))
    assert len(sol_fields) <= n_floats  # the series copy no more than that
    args = cli.build_parser().parse_args(["xu2014"])
    need = cli._sample_count(args) * 8 * cli.OUTPUT_COPIES * n_floats
    assert need < 0.5e9
    available = cli._available_memory()
    assert available is None or available > 0


def test_the_memory_check_reads_an_accelerator_s_free_memory(monkeypatch):
    """On an accelerator that reports its limit, the less of its free memory and the host's."""
    host = cli._available_memory()  # this process's CPU device: the host's alone
    gpu = SimpleNamespace(platform="gpu", memory_stats=lambda: {"bytes_limit": 10**10, "bytes_in_use": 4 * 10**9})
    monkeypatch.setattr(jax, "devices", lambda *args: [gpu])
    assert cli._available_memory() == min(6 * 10**9, host if host is not None else math.inf)


def staged_failure(monkeypatch, error):
    """Fake cases, the second of which raises ``error``."""
    fake_cases(monkeypatch)
    run_case = cli._run_case

    def failing(args, model, ts, label):
        if label == "without impact":
            raise error
        return run_case(args, model, ts, label)

    monkeypatch.setattr(cli, "_run_case", failing)


def test_any_error_marks_the_staging_folder(tmp_path, monkeypatch, capsys):
    """An unexpected error in a case left the staging folder marked "The run is going on (or was
    killed)". It is marked stopped, with the error, and one line names it; the error itself goes
    on (its traceback is a bug report). An error of memory ends there: status 1, the fix."""
    out = tmp_path / "out"
    staged_failure(monkeypatch, RuntimeError("boom\nsecond line"))
    with pytest.raises(RuntimeError, match="boom"):
        cli.main(["xu2014", "--out", str(out), "--no-figures"])
    [staging] = staging_folders(out)
    assert "Stopped: failed: RuntimeError (boom)." in (staging / "INCOMPLETE").read_text()
    assert capsys.readouterr().err.strip().split("\n")[-1] == (
        f"jaxbearing xu2014: failed: RuntimeError (boom); the cases finished (with impact) are in "
        f"{staging}, marked INCOMPLETE; {out} was not created")
    shutil.rmtree(staging)

    staged_failure(monkeypatch, MemoryError("Unable to allocate 7.28 PiB"))
    assert cli.main(["xu2014", "--out", str(out), "--no-figures"]) == 1
    [staging] = staging_folders(out)
    assert "Stopped: failed: out of memory (Unable to allocate 7.28 PiB)." in (staging / "INCOMPLETE").read_text()
    err = capsys.readouterr().err
    assert err.endswith("marked INCOMPLETE; " + str(out) + " was not created\n"
                        "jaxbearing xu2014: pass fewer --samples or a shorter --t1\n"), err
    assert "Traceback" not in err


def test_sigint_while_the_process_ends_after_its_result_is_in_place_exits_cleanly(tmp_path):
    """Ctrl-C once the result is in place, while the process ends (here a slow exit handler
    stands in for JAX's, which free its backends and compiled programs): before, the
    KeyboardInterrupt was raised inside the exit handler, a traceback on stderr. The command
    ignores SIGINT from its end on: status 0, no traceback, the result complete."""
    out = tmp_path / "out"
    script = f"""
import atexit, sys, time
sys.path.insert(0, {str(ROOT / "tests")!r})
import pytest
import test_cli as t
from jaxbearing import cli
atexit.register(time.sleep, 4.0)  # runs after JAX's own exit handlers (registered later)
t.fake_cases(pytest.MonkeyPatch())
sys.argv = ["jaxbearing", "xu2014", "--out", {str(out)!r}, "--no-figures"]
sys.exit(cli.main())
"""
    env = dict(os.environ, PYTHONPATH=str(ROOT), PYTHONUNBUFFERED="1", JAX_PLATFORMS="cpu")
    child = subprocess.Popen([sys.executable, "-c", script], stdout=subprocess.PIPE,
                             stderr=subprocess.PIPE, text=True, cwd=tmp_path, env=env)
    try:
        read_until(child.stdout, "summary.json")  # the last file listed: the run has returned
        time.sleep(1.0)
        child.send_signal(signal.SIGINT)
        _, err = child.communicate(timeout=60)
    finally:
        child.kill()
    assert child.returncode == 0, err
    assert "Traceback" not in err and "KeyboardInterrupt" not in err, err
    assert set(os.listdir(out)) == {"with_impact.csv", "without_impact.csv", "summary.json"}


# ---------------------------------------------------------------------------------------------
# Configuration files (--config) and the records in summary.json
# ---------------------------------------------------------------------------------------------

ALLOWED = r"the allowed keys are bearing\.clearance, bearing\.damping, bearing\.cage, " \
    r"bearing\.ball_force, bearing\.designation, impact\.restitution, impact\.friction, impact\.contact_on, crank\.speed, metrics\.window_start"

BAD_CONFIGS = [
    ("[bearing]\nclearence = 4e-5\n", r"unknown key bearing\.clearence; " + ALLOWED),
    ("[gearbox]\nratio = 3.0\n", r"unknown table 'gearbox'; " + ALLOWED),
    ("clearance = 4e-5\n", r"unknown top-level key 'clearance'; " + ALLOWED + r" \(each inside its table"),
    ("bearing = 4e-5\n", r"'bearing' must be a table \(\[bearing\]\) of keys; got the number 4e-05"),
    ('[bearing]\nclearance = "40 um"\n',
     r"bearing\.clearance must be a number in SI units \[m\]; got the string '40 um' \(unit strings are not accepted"),
    ('[crank]\nspeed = "600 rpm"\n', r"crank\.speed must be a number in SI units \[rad/s\]; got the string '600 rpm'"),
    ("[impact]\nrestitution = true\n", r"impact\.restitution must be a single number in SI units \[-\]; got a boolean True"),
    ("[impact]\nfriction = [0.1, 0.2]\n", r"impact\.friction must be a single number in SI units \[-\]; got an array \[0\.1, 0\.2\]"),
    ("[impact.contact_on]\nvalue = 0.05\n", r"impact\.contact_on must be a single number in SI units \[s\]; got a table"),
    ("[bearing]\ndamping = 1979-05-27\n", r"bearing\.damping must be a single number in SI units \[N s/m\]; got a date"),
    ("[crank]\nspeed = nan\n", r"crank\.speed must be a finite number \[rad/s\]; got nan"),
    ("[crank]\nspeed = " + "9" * 400 + "\n", r"crank\.speed must be a finite number \[rad/s\]; got 999"),
    ('[bearing]\ncage = "free"\n', r"bearing\.cage must be one of 'kinematic', 'constant'; got the string 'free'"),
    ("[bearing]\nball_force = 1\n", r"bearing\.ball_force must be one of 'paper', 'smooth'; got the number 1"),
    ("[bearing]\nclearance = -1e-4\n", r"clearance must be at least -0\.01 of the ball diameter .*; got -0\.0001\."),
    ("[impact]\nrestitution = 1.5\n", r"restitution must lie in \(0\.0, 1\.0\]; got 1\.5\."),
    ("[bearing\nclearance = 4e-5\n", r"is not valid TOML"),
    ("[impact]\nrestitution = __import__('os').system('touch evaluated')\n", r"is not valid TOML"),
    pytest.param('[bearing]\ncage = "k\xe9"\n'.encode("latin-1"),
                 r"is not UTF-8 text \(byte 19 is b'\\xe9'\): a TOML file must be UTF-8", id="latin-1"),
    pytest.param('[bearing]\ncage = "' + "x" * 20_000_000 + '"\n',
                 r"got the string 'x{79}\.\.\. \(20000002 characters\)\.\n$", id="20 MB string"),
]


@pytest.mark.parametrize("text, message", BAD_CONFIGS)
def test_bad_config_is_refused_before_anything_runs(tmp_path, capsys, monkeypatch, text, message):
    path = tmp_path / "overrides.toml"
    path.write_bytes(text if isinstance(text, bytes) else text.encode())
    out = tmp_path / "out"
    monkeypatch.chdir(tmp_path)  # where an evaluated expression would write
    assert cli.main(["xu2014", "--out", str(out), "--config", str(path)]) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"jaxbearing xu2014: {path.resolve()}"), err
    assert re.search(message, err), err
    assert not out.exists()  # refused before any output
    assert not (tmp_path / "evaluated").exists()


def test_missing_config_file(tmp_path, capsys):
    assert cli.main(["xu2014", "--config", str(tmp_path / "nowhere.toml")]) == 2
    assert "cannot read the configuration file" in capsys.readouterr().err


def test_config_schema_covers_every_argument_of_the_case():
    keywords = [option.keyword for keys in config.XU2014.values() for option in keys.values()]
    assert sorted(keywords) == sorted(set(inspect.signature(cases.xu2014).parameters) - {"impact"})
    overrides = config.check_overrides({"bearing": {"damping": 400, "cage": "constant"}, "crank": {"speed": 30}})
    assert overrides == {"bearing": {"damping": 400.0, "cage": "constant"}, "crank": {"speed": 30.0}}
    assert isinstance(overrides["bearing"]["damping"], float)  # TOML integers become floats
    assert config.xu2014_kwargs(overrides) == {"bearing_damping": 400.0, "cage": "constant", "crank_speed": 30.0}


OVERRIDES = """
# SI units
[bearing]
clearance = 60e-6   # [m]

[impact]
restitution = 0.5
"""


def test_config_overrides_change_the_result_and_are_recorded(quick_run, tmp_path):
    _, default_out = quick_run
    path = tmp_path / "overrides.toml"
    path.write_text(OVERRIDES)
    out = tmp_path / "out"
    args = [*QUICK, "--no-figures"]  # the compiled solves of quick_run
    assert cli.main(["xu2014", "--out", str(out), "--config", str(path), *args]) == 0
    new = json.loads((out / "summary.json").read_text())
    old = json.loads((default_out / "summary.json").read_text())

    assert new["config_file"] == str(path.resolve()) and old["config_file"] is None
    assert new["overrides"] == {"bearing": {"clearance": 6e-5}, "impact": {"restitution": 0.5}}
    assert old["overrides"] == {}
    assert new["versions"] == old["versions"] == provenance.versions()
    assert set(new["versions"]) == {"python", "jaxbearing", "jax", "jaxlib", "diffrax", "equinox", "numpy"}
    # the parameter records differ exactly where the file says
    for case, changed in (
        ("with_impact", {"forces.0.bearing.clearance", "forces.2.impact.restitution"}),
        ("without_impact", {"forces.0.bearing.clearance"}),
    ):
        a, b = old["parameters"][case], new["parameters"][case]
        assert a.keys() == b.keys()
        assert {k for k in a if a[k] != b[k]} == changed
    assert new["parameters"]["with_impact"]["forces.2.impact.restitution"] == 0.5
    # and so do the results: both cases feel the clearance
    for case in ("with_impact", "without_impact"):
        for key in ("peak_bearing_force_N", "peak_ball_load_N", "num_steps"):
            assert new["cases"][case][key] != old["cases"][case][key], (case, key)


def test_parameter_record_rebuilds_the_model():
    """The array entries of `provenance.parameters`, set onto a default model, give back the
    model they were recorded from; the static entries record its structure."""
    model = cases.xu2014(clearance=6e-5, restitution=0.5, crank_speed=30.0, cage="constant")
    record = json.loads(json.dumps(provenance.parameters(model)))  # as read from summary.json
    default = cases.xu2014()
    arrays = {p: np.asarray(v) for p, v in record.items() if eqx.is_array(paths.get(default, p))}
    rebuilt = paths.replace(default, arrays)
    for a, b in zip(jax.tree_util.tree_leaves(rebuilt), jax.tree_util.tree_leaves(model)):
        np.testing.assert_array_equal(np.asarray(a), np.asarray(b))
    assert record["forces.0.bearing.cage"] == "constant" and record["forces.0.bearing.n_balls"] == 8
    assert record["body_names"] == ["crank", "rod", "slider", "target"]
    assert not any(k.endswith(".acceleration") for k in record)  # no Gravity element: gravity off


@pytest.mark.slow  # 20 s: another span of both cases
def test_short_run_warns_that_both_cases_are_the_same_and_says_what_each_case_does(tmp_path, capsys):
    """--t1 0.05 ends when the contact switches on: the CLI says the cases coincide; the
    console says for each case that it compiles (or loads) and solves, and when it is done and
    whether the compilation cache served (nothing for the timing rerun), not a line per
    segment."""
    args = ["xu2014", "--out", str(tmp_path), "--t1", "0.05", "--samples", "501", "--no-figures"]
    assert cli.main(args) == 0
    out, err = capsys.readouterr()
    assert "warning: --t1 0.05 s does not pass the time the slider-target contact switches on " \
        "(contact_on = 0.05 s)" in err
    assert "first contact comes near t = 0.091 s" in err
    s = json.loads((tmp_path / "summary.json").read_text())
    imp, free = s["cases"]["with_impact"], s["cases"]["without_impact"]
    assert imp["peak_bearing_force_N"] == free["peak_bearing_force_N"]
    lines = err.split("\n")
    for label in ("with impact", "without impact"):
        started, done = [line for line in lines if line.startswith(f"{label}:")]
        assert "compiling the model" in started and "compilation cache" in started
        assert "solving 0-0.05 s" in started
        # the done line says whether the cache served (this test's process: either)
        said = r"(compiled.*|the compiled model came from this machine's compilation cache)"
        assert re.fullmatch(rf"{label}: done in [0-9.]+ s \({said}\)", done)
    assert len(lines) <= 6  # the warning, two lines a case, the final newline
    assert "100.0 %" not in err + out and "%|" not in out


@pytest.mark.slow  # 20 s: both cases compiled for another span
def test_a_run_that_ends_before_the_metrics_window_reports_no_peaks_and_no_life(tmp_path):
    """--t1 0.03 ends before the case's window start (0.04 s): the peaks after it and the lives
    have no value (null in summary.json), and the run succeeds: the life's window is not
    asked for an empty span."""
    args = ["xu2014", "--out", str(tmp_path), "--t1", "0.03", "--samples", "301", "--no-figures", "--no-rerun"]
    assert cli.main(args) == 0
    s = json.loads((tmp_path / "summary.json").read_text())
    assert s["peak_window_from_s"] == 0.04
    for case in s["cases"].values():
        assert case["peak_ball_load_N"] is None and case["l10_iso_hours"] is None

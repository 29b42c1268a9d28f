"""Metrics come from the solution, not from the output times (issue 11): `simulate` records per
interval between its stops the peaks and integrals over every accepted step's interpolant (each
element's `ElementRecords`), so a metric has the same value whatever ``ts`` is, windows need
stops as edges, and the smooth metrics keep exact derivatives (tests/test_derivatives.py)."""

import diffrax
import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import pytest

import jaxbearing as jb
from jaxbearing import metrics as M
from jaxbearing import report
from jaxbearing.solution import map_per_time

T1 = 0.02  # [s] short run of the paper's case: ball engagements and releases (no impact yet)
EDGE = 0.013  # [s] a window edge that is no stop of `dense`
STOP = 0.01  # [s] a window edge that is a stop of `dense` and `coarse`: the model's window start


@pytest.fixture(scope="module")
def model():
    return jb.cases.xu2014(impact=False, window_start=STOP)


@pytest.fixture(scope="module")
def dense(model):
    """The solve sampled 1 µs apart: 10 runs of `coarse`'s compiled solve (up to 2048 output
    times share it), each sampling a tenth of the 20001 times; the solution's own records
    (intervals, element records, contacts) are those of any run, as they do not depend on the output times."""
    runs = [jb.simulate(model, T1, part) for part in np.array_split(np.linspace(0.0, T1, 20001), 10)]
    for run in runs[1:]:
        assert int(run.num_steps) == int(runs[0].num_steps)  # the same solve, sampled elsewhere
    return map_per_time(lambda *rows: jnp.concatenate(rows), *runs)  # as first_rows


@pytest.fixture(scope="module")
def coarse(model):
    # the compiled solve of tests/conftest.py's "free_0.02s" (the window start is a value)
    return jb.simulate(model, T1, jnp.linspace(0.0, T1, 201))


def span(sol):
    s = sol.intervals
    return float(jnp.sum(jnp.where(s.valid, s.duration, 0.0)))


def test_intervals_cover_the_span_exactly(dense):
    s = dense.intervals
    valid = np.asarray(s.valid)
    starts, ends = np.asarray(s.t_start)[valid], np.asarray(s.t_end)[valid]
    assert starts[0] == 0.0 and ends[-1] == T1
    np.testing.assert_array_equal(starts[1:], ends[:-1])  # contiguous
    # the steps recorded in each interval tile it: steps end at the stops, and a step across an
    # event counts only up to the event
    duration = np.asarray(s.duration)[valid]
    np.testing.assert_allclose(duration, ends - starts, rtol=1e-12)
    assert span(dense) == pytest.approx(T1, rel=1e-12)
    # one entry per stop (STOP and T1), however many steps and events
    assert int(np.sum(valid)) == 2 < int(dense.num_events)


def test_metrics_agree_with_dense_samples(dense, coarse):
    for name, fn in {**M.STANDARD, **M.SMOOTH}.items():  # one compiled solve: the same numbers
        assert float(fn(coarse, t_min=0.0)) == float(fn(dense, t_min=0.0)), name
    ts = np.asarray(dense.ts)
    f = np.linalg.norm(np.asarray(dense.bearing_force), axis=1)
    loads = np.asarray(dense.ball_loads)
    # peaks: at least the coarse samples' maxima, and the dense samples' within 1e-3
    for peak, samples in (
        (M.peak_ball_load, lambda s: np.max(s.ball_loads)),
        (M.peak_bearing_force, lambda s: np.max(np.linalg.norm(np.asarray(s.bearing_force), axis=1))),
    ):
        value = float(peak(dense, t_min=0.0))
        assert value >= float(samples(coarse))
        assert value == pytest.approx(float(samples(dense)), rel=1e-3)
    # integrals: a trapezoid on 1 µs samples (measured: within 2e-6 and 1e-9)
    rms = np.sqrt(np.trapezoid(f**2, ts) / T1)
    assert float(M.rms_bearing_force(dense, t_min=0.0)) == pytest.approx(rms, rel=1e-4)
    smooth = (np.trapezoid(np.mean(loads**16, axis=1), ts) / T1) ** (1 / 16)
    assert float(M.smooth_peak_ball_load(dense, t_min=0.0)) == pytest.approx(smooth, rel=1e-4)


@pytest.mark.parametrize("t_min", [0.0, STOP])
def test_peak_times_and_ball_come_from_the_solution(dense, coarse, t_min):
    """`peak_time` and `peak_ball` are the same whatever the output times; the solution takes
    the peak value at `peak_time`: samples 1 µs apart, interpolated linearly there, agree within
    2e-5 (the interpolation's error near a maximum, f'' (1 µs)^2 / 8: measured up to 7e-6 at
    the sharp first peak), and so do every ball's loads (`loads_at_peak`); the ball is the one
    the largest sample names."""
    ts = np.asarray(dense.ts)
    after = ts >= t_min
    loads = np.where(after[:, None], np.asarray(dense.ball_loads), -np.inf)
    bearing = np.where(after, np.linalg.norm(np.asarray(dense.bearing_force), axis=1), -np.inf)
    for peak, sampled in ((M.peak_ball_load, loads.max(axis=1)), (M.peak_bearing_force, bearing)):
        time = float(M.peak_time(dense, peak, t_min=t_min))
        assert time == float(M.peak_time(coarse, peak, t_min=t_min)), peak.label
        value = float(peak(dense, t_min=t_min))
        assert np.interp(time, ts, sampled) == pytest.approx(value, rel=2e-5), peak.label
    ball = int(M.peak_ball(dense, t_min=t_min))
    assert ball == int(M.peak_ball(coarse, t_min=t_min))
    assert ball == np.argmax(loads[np.argmax(loads.max(axis=1))])
    # every ball's load at that time: the peak on its ball, the samples' loads there
    at_peak = np.asarray(M.loads_at_peak(dense, t_min=t_min))
    value = float(M.peak_ball_load(dense, t_min=t_min))
    assert at_peak[ball] == value == at_peak.max()
    time = float(M.peak_time(dense, M.peak_ball_load, t_min=t_min))
    there = [np.interp(time, ts, loads[:, k]) for k in range(loads.shape[1])]
    np.testing.assert_allclose(at_peak, there, rtol=0, atol=2e-5 * value)
    with pytest.raises(ValueError, match="must be an exact peak"):
        M.peak_time(dense, M.rms_bearing_force)


def test_peaks_lie_between_the_recorded_points(dense):
    """A peak is the interpolant's maximum, also where it falls between the 4 points a step
    records: on the smooth stretch t >= 0.01 s, with long steps, the largest of those points
    lay 7.0e-4 (ball load) and 2.6e-4 (|F|) below the largest of the 1 µs samples, 7 µs and 4 µs
    from it. The peak is at least the largest sample (the interpolant at the parabola's vertex
    is the maximum to its third-order error; measured 3e-6 and 6e-7 above), and within 2e-5
    of it and 1 µs in time (between samples 1 µs apart the maximum rises by up to
    f'' (0.5 µs)^2 / 2 above the nearest)."""
    ts = np.asarray(dense.ts)
    after = ts >= 0.01
    loads = np.where(after, np.asarray(dense.ball_loads).max(axis=1), -np.inf)
    bearing = np.where(after, np.linalg.norm(np.asarray(dense.bearing_force), axis=1), -np.inf)
    for peak, sampled in ((M.peak_ball_load, loads), (M.peak_bearing_force, bearing)):
        value = float(peak(dense, t_min=0.01))
        assert sampled.max() * (1.0 - 1e-7) <= value <= sampled.max() * (1.0 + 2e-5), peak.label
        time = float(M.peak_time(dense, peak, t_min=0.01))
        assert abs(time - ts[np.argmax(sampled)]) <= 1e-6, peak.label


@pytest.mark.parametrize("solver", [diffrax.Tsit5(), diffrax.Dopri5(), jb.kvaerno5()])
def test_each_coordinate_of_an_interpolant_alone(solver):
    """`recorder._coordinates_at` evaluates each coordinate's interpolant by itself, cut from
    the step's dense information: it equals that coordinate of the whole state's interpolant."""
    from jaxbearing.recorder import _coordinates_at

    n = 3
    matrix = jnp.asarray(np.random.default_rng(0).normal(size=(2 * n, 2 * n)))
    term = diffrax.ODETerm(lambda t, y, args: jnp.sin(matrix @ y) + t)

    @jax.jit  # one program, not one per operation of the step
    def both(y0, t0, t1, times):
        state = solver.init(term, t0, t1, y0, None)
        _, _, dense, _, _ = solver.step(term, t0, t1, y0, None, state, False)
        interpolation = solver.interpolation_cls(t0=t0, t1=t1, **dense)
        whole = jnp.stack([interpolation.evaluate(times[j])[j] for j in range(times.shape[0])])
        return _coordinates_at(interpolation, n, times), whole

    alone, whole = both(jnp.linspace(0.1, 0.6, 2 * n), 0.0, 0.1, jnp.asarray([0.013, 0.05, 0.097]))
    np.testing.assert_allclose(alone, whole, rtol=1e-14)


def test_vertex_of_the_recorded_points():
    """`_recording._vertices` on a parabola: its vertex and its rise above the largest point,
    wherever the vertex lies in the step; nothing for a monotone or convex column."""
    from jaxbearing.solve._recording import _NODES, _vertices

    s = jnp.asarray(_NODES)
    tops = jnp.asarray([0.05, 0.3, 0.7, 0.95])
    columns = [1.0 - (s - top) ** 2 for top in tops] + [s, (s - 0.5) ** 2]
    vertex, rise = _vertices(jnp.stack(columns, axis=1))
    largest = jnp.stack(columns, axis=1).max(axis=0)
    np.testing.assert_allclose(vertex[:4], tops, rtol=1e-12)
    np.testing.assert_allclose(rise[:4], 1.0 - largest[:4], rtol=1e-12)
    assert vertex[4] == s[2] and rise[4] == 0.0  # monotone: the end is the step's largest
    assert rise[5] == 0.0


def test_window_edges_must_be_stops(model, coarse):
    with pytest.raises(ValueError, match="window_edges"):
        M.rms_bearing_force(coarse, t_min=EDGE)
    # under jit the edge cannot be checked in Python: NaN, never an approximate number
    assert np.isnan(float(jax.jit(lambda s: M.rms_bearing_force(s, t_min=EDGE))(coarse)))
    with pytest.raises(TypeError, match="has no field p"):  # its order is the record's (16)
        M.smooth_peak_ball_load(coarse, p=8.0)
    sol = jb.simulate(eqx.tree_at(lambda m: m.window_start, model, EDGE), T1, jnp.linspace(0.0, T1, 201))
    before, after = M.rms_bearing_force(sol, 0.0, EDGE), M.rms_bearing_force(sol, t_min=EDGE)
    whole = M.rms_bearing_force(sol, t_min=0.0)
    mean_square = (before**2 * EDGE + after**2 * (T1 - EDGE)) / T1
    assert float(whole) ** 2 == pytest.approx(float(mean_square), rel=1e-12)
    peaks = M.peak_ball_load(sol, 0.0, EDGE), M.peak_ball_load(sol, t_min=EDGE)
    assert float(M.peak_ball_load(sol, t_min=0.0)) == max(float(p) for p in peaks)
    with pytest.raises(ValueError, match="must hold part of the solved span"):  # empty window
        M.rms_bearing_force(sol, t_min=T1)


@pytest.mark.slow
def test_metrics_do_not_depend_on_the_output_times():
    """The paper's case with impact over 0.2 s: every metric the same at 21 ... 200 001 output
    times (the sample maxima of 2001 outputs were up to 30 % low), the peak impact force within
    1 % of the maximum over 200 001 samples and its time within 1 µs of that sample's; the
    target's displacement at its `peak_time` equal to its peak."""
    model, t1 = jb.cases.xu2014(impact=True), 0.2
    values, times, contacts = {}, [], []
    for n in (21, 201, 2001, 200_001):
        sol = jb.simulate(model, t1, jnp.linspace(0.0, t1, n))
        values[n] = {name: float(fn(sol)) for name, fn in {**M.STANDARD, **M.SMOOTH}.items()}
        times.append(float(M.peak_time(sol, M.peak_impact_force)))
        contacts.append(np.array([tuple(c) for c in report.contacts(sol)], dtype=float))
    # the same time and contacts whatever the output times: 21 ... 2001 times share one compiled
    # solve, 200 001 compile another (other rounding: within 1e-12 s, 1e-9 relative)
    assert max(times) - min(times) <= 1e-12
    for other in contacts[1:]:
        np.testing.assert_allclose(other, contacts[0], rtol=1e-9, atol=1e-12)
    # each contact against its samples 1 µs apart: it starts before its first sample in
    # contact and ends after its last, by less than 1 µs (plus 1 nm at >= 0.01 m/s for the
    # separation event); its peak at or above the largest sample (to 1e-7), by less than 1e-3
    sampled = report.contact_intervals(report.series(sol))
    found = report.contacts(sol)
    assert len(found) == len(sampled) == 12
    for contact, (start, end, peak) in zip(found, sampled):
        assert start - 1e-6 < contact.start <= start
        assert end <= contact.end < end + 1e-6 + 1e-9 / 0.01 or contact.end == t1
        assert peak * (1 - 1e-7) <= contact.peak_force < peak * (1 + 1e-3)
    for n in (21, 201, 2001):
        for name, value in values[n].items():
            assert value == pytest.approx(values[200_001][name], rel=0.005), (n, name)
    after = np.asarray(sol.ts) >= float(sol.window_start)
    sampled = float(np.max(np.asarray(sol.contact_force)[after]))
    assert values[200_001]["peak_impact_force"] == pytest.approx(sampled, rel=0.01)
    assert values[200_001]["peak_impact_force"] >= sampled * (1 - 1e-3)
    at = np.asarray(sol.ts)[np.argmax(np.where(after, np.asarray(sol.contact_force), -np.inf))]
    assert times[-1] == pytest.approx(at, abs=1e-6)
    # the target's displacement takes its peak at its peak_time (samples interpolated there, as
    # in test_peak_times_and_ball_come_from_the_solution)
    target = np.abs(np.asarray(sol.q[:, sol.target]) - float(sol.q[0, sol.target]))
    when = float(M.peak_time(sol, M.max_target_displacement))
    assert np.interp(when, np.asarray(sol.ts), target) == pytest.approx(
        values[200_001]["max_target_displacement"], rel=2e-5
    )


SPEED = M.Peak(lambda model, x: jnp.abs(x.qd[6]))  # the slider's speed [m/s]
SPEED_SQUARED = M.Mean(lambda model, x: x.qd[6] ** 2)  # [m^2/s^2]
# a peak over a window of its own, from the start (before the model's window): the slowest
SLOWEST = M.Peak(lambda model, x: -jnp.abs(x.qd[6]), t_min=0.0)  # -min |speed| [m/s]
OWN = jb.SolveOptions(records={"speed": SPEED, "speed_squared": SPEED_SQUARED, "slowest": SLOWEST})


def test_metrics_of_your_own_against_dense_samples(model, dense):
    """A `Peak` and a `Mean` of a smooth quantity (the slider's speed), recorded in a run with
    21 output times, against the samples 1 µs apart over the model's window, and a `Peak` over
    a window of its own from the start (the least speed): within 1e-6 (the sampled maximum
    lies below the true one by about f'' (1 µs)^2 / 8, 1e-9 relative here; the trapezoid's
    error is of the same order)."""
    sol = jb.simulate(model, T1, jnp.linspace(0.0, T1, 21), options=OWN)
    ts = np.asarray(dense.ts)
    after = ts >= STOP
    speed = np.abs(np.asarray(dense.qd)[after, 6])
    assert float(sol.records["speed"]) == pytest.approx(speed.max(), rel=1e-6)
    assert float(SPEED(sol)) == float(sol.records["speed"])
    mean = np.trapezoid(speed**2, ts[after]) / (T1 - STOP)
    assert float(sol.records["speed_squared"]) == pytest.approx(mean, rel=1e-6)
    slowest = np.abs(np.asarray(dense.qd)[:, 6]).min()
    assert -float(sol.records["slowest"]) == pytest.approx(slowest, rel=1e-6)
    assert slowest < speed.min()  # before the model's window: not the window's number


def test_records_of_your_own_of_a_run_that_stopped_short_are_nan(model):
    """A run stopped by its step limit (inside the window from the start, before the model's)
    records NaN for every metric of your own, read inside the compiled solve: never the peak of
    the part it ran (issue 64; the run of the test above, so the same compiled solve)."""
    stopped = jb.simulate(model, T1, jnp.linspace(0.0, T1, 21), options=OWN, max_steps=20, throw=False)
    assert stopped.result == jb.RESULTS.max_steps_reached and 0.0 < float(stopped.t_final) < STOP
    for name in ("speed", "speed_squared", "slowest"):
        assert np.isnan(float(stopped.records[name])), name

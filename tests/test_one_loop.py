"""`simulate_one_loop`, and sweeps whose members run as one loop, against `simulate`.

Both integrate the same equations with diffrax's Tsit5 tableau, the same PID controller and the
same event rules, but in other step sequences (`simulate` restarts a segment at each event and
stop with a fresh step size; the one loop goes on with the controller's proposal), so they agree
to the solver's accuracy, not to the last bit. The tolerances below follow from that:

- a peak is a maximum over the points the steps record (each step's end and its 3
  Gauss–Legendre points); with other steps these points lie elsewhere on the curve, and the peak
  ball load of the paper's case moves by up to 2e-4 relative between two such runs (measured
  with 0.2 s: 1.9e-4; the impact and bearing peaks 3e-5). 5e-4 allows for that;
- integrals (the RMS force) are quadratures of the interpolants; after the impact the two
  trajectories differ by more than the step tolerance (measured: 1.7e-5 relative at 20 µm
  clearance): 1e-4;
- contact onsets are located to 1e-13 s on each run's own trajectory; positions of the two runs
  differ by ~1e-9 m, at approach speeds of 0.1–2 m/s: times within 1e-8 s; the approach
  speeds, velocities after a sequence of contacts, by up to 1.5e-5 m/s (measured): 5e-5 m/s;
  the contacts' ends are events like the onsets (1e-8 s), their peak forces peaks (5e-4); the
  time of a peak moves along its flat top (measured up to 4.6e-8 s over 0.2 s): 1e-6 s.

One span for every run (the paper's 0.2 s: two impacts of six contact onsets each, from 0.0913
s and 0.1913 s) and a window start of the model (a value, not a compiled option), so that the
one-loop runs share one compiled solve and `simulate`'s run is tests/test_xu2014.py's (the same
worker: tests/conftest.py).
"""

import diffrax
import jax
import jax.numpy as jnp
import numpy as np
import pytest

import jaxbearing as jb

T1 = 0.2
WINDOW = 0.09  # [s] the models' window start: the metrics' default window holds both impacts
PEAK_TOLERANCE = 5e-4
INTEGRAL_TOLERANCE = 1e-4
ONSET_TOLERANCE = 1e-8  # [s]
SPEED_TOLERANCE = 5e-5  # [m/s]
PEAK_TIME_TOLERANCE = 1e-6  # [s]
LIFE_TOLERANCE = 5e-4


def _metrics(sol):
    values = {name: float(fn(sol)) for name, fn in jb.metrics.STANDARD.items()}
    values["peak_ball_load_whole"] = float(jb.metrics.peak_ball_load(sol, t_min=0.0))
    return values


def _assert_metrics_close(one_loop, segments):
    for name, value in _metrics(segments).items():
        tolerance = INTEGRAL_TOLERANCE if name.startswith("rms") else PEAK_TOLERANCE
        assert _metrics(one_loop)[name] == pytest.approx(value, rel=tolerance), name


@pytest.fixture(scope="module")
def paper_case():
    model = jb.cases.xu2014(window_start=WINDOW)
    one_loop = jb.simulate_one_loop(model, T1)
    segments = jb.simulate(model, T1, [0.0, T1])
    return model, one_loop, segments


def test_metrics_agree_with_simulate(paper_case):
    _, one_loop, segments = paper_case
    assert float(jb.metrics.peak_impact_force(segments)) > 1000.0  # the impact is in the span
    _assert_metrics_close(one_loop, segments)


def test_contacts_agree_with_simulate(paper_case):
    _, one_loop, segments = paper_case
    read = lambda c, name: np.asarray(getattr(c, name))[np.asarray(c.valid)]  # noqa: E731
    runs = (one_loop.contacts, segments.contacts)
    names = ("time", "approach_speed", "end", "peak_force", "peak_time")
    found, speeds, ends, peaks, when = ([read(c, name) for c in runs] for name in names)
    assert found[0].size == found[1].size == 12
    np.testing.assert_allclose(found[0], found[1], rtol=0.0, atol=ONSET_TOLERANCE)
    np.testing.assert_allclose(speeds[0], speeds[1], rtol=0.0, atol=SPEED_TOLERANCE)
    # ends are events like the onsets; the last contact lasts past T1 (NaN in both)
    np.testing.assert_allclose(ends[0], ends[1], rtol=0.0, atol=ONSET_TOLERANCE)
    assert np.isnan(ends[1][-1]) and np.all(np.isfinite(ends[1][:-1]))
    np.testing.assert_allclose(peaks[0], peaks[1], rtol=PEAK_TOLERANCE)
    np.testing.assert_allclose(when[0], when[1], rtol=0.0, atol=PEAK_TIME_TOLERANCE)


def test_outputs_are_the_two_ends(paper_case):
    model, one_loop, segments = paper_case
    np.testing.assert_array_equal(np.asarray(one_loop.ts), [0.0, T1])
    np.testing.assert_array_equal(np.asarray(one_loop.q[0]), np.asarray(model.q0))
    # the final states of two runs at rtol 1e-8: positions ~1e-9 m apart
    np.testing.assert_allclose(one_loop.q[-1], segments.q[-1], rtol=0.0, atol=1e-7)
    assert one_loop.result == jb.RESULTS.successful and float(one_loop.t_final) == T1
    assert int(one_loop.num_steps) > int(one_loop.num_rejected_steps) > 0


def test_bearing_lives_agree_with_simulate(paper_case):
    # L10 goes as the equivalent load to the power -3 (ISO) or about -10/3 (Lundberg–Palmgren):
    # the integrals' 1e-4 becomes a few 1e-4 in the life
    model, one_loop, segments = paper_case
    for method, kwargs in (("iso", {}), ("lp", {"groove_inner": 0.5219, "groove_outer": 0.5194})):
        life = jb.life.metric(method, **kwargs)
        assert float(life(one_loop, model)) == pytest.approx(float(life(segments, model)), rel=LIFE_TOLERANCE)


@pytest.mark.slow  # 12 s; tests/test_sweep.py compares a sweep with single runs by default
def test_sweep_members_agree_with_simulate_one_by_one(paper_case):
    model, _, _ = paper_case
    clearances = [20e-6, 80e-6]
    ds = jb.sweep(model, {"bearing.clearance": clearances}, t1=T1, progress=False)
    assert not bool(ds.failed.any())
    assert ds.attrs["solve"] == "one_loop"  # no output samples asked for: the one loop ran
    for c in clearances:
        point = jb.paths.replace(model, {"bearing.clearance": c})
        reference = _metrics(jb.simulate(point, T1, [0.0, T1]))
        member = ds.sel({"bearing.clearance": c})
        for name in jb.metrics.STANDARD:
            tolerance = INTEGRAL_TOLERANCE if name.startswith("rms") else PEAK_TOLERANCE
            assert float(member[name]) == pytest.approx(reference[name], rel=tolerance), (c, name)


def test_a_failed_run_says_so(paper_case):
    model, _, _ = paper_case
    sol = jb.simulate_one_loop(model, T1, max_steps=50, throw=False)
    assert sol.result == jb.RESULTS.max_steps_reached
    assert 0.0 < float(sol.t_final) < T1
    assert np.isfinite(np.asarray(sol.q[-1])).all()  # the state it reached, not NaN
    with pytest.raises(jb.SimulationError, match="stopped at t ="):
        jb.simulate_one_loop(model, T1, max_steps=50)


def test_a_contact_switched_on_while_overlapping_is_named(paper_case):
    """The paper's circles overlap at 1 ms: the contact force jumps on there, so no step across
    is accepted; the run fails with the cause `simulate` reports (tests/test_validation.py),
    not as a step size that fell to nothing."""
    model, _, _ = paper_case
    early = jb.paths.replace(model, {"contacts.0.active_from": 0.001})
    sol = jb.simulate_one_loop(early, T1, throw=False)
    assert sol.result == jb.RESULTS.contact_overlap
    assert float(sol.t_final) == pytest.approx(0.001, abs=1e-12)
    with pytest.raises(jb.SimulationError, match=r"a contact switched on \(its active_from\) while"):
        jb.simulate_one_loop(early, T1)


def test_parameters_changed_after_construction_are_checked(paper_case):
    model, _, _ = paper_case
    bad = jb.paths.replace(model, {"bearing.clearance": -1e-4})  # as eqx.tree_at would
    with pytest.raises(ValueError, match=r"^bearing\.clearance must be at least -0\.01 of the ball diameter .*; got -0\.0001\.$"):
        jb.simulate_one_loop(bad, T1)


ROTOR_T1 = 0.02  # [s] the rotor falls onto the race: 23 ball engagements and releases


def _rotor_metrics(solve):
    """RMS bearing force and peak ball load [N] of the rotor in the paper-force SKF 98205 over
    [0, ROTOR_T1] as functions of the clearance, with ``solve(model) -> Solution``."""
    model = jb.cases.rotor(jb.cases.skf98205(ball_force="paper"), speed=100.0)

    def metrics(clearance):
        sol = solve(jb.paths.replace(model, {"bearing.clearance": clearance}))
        return jnp.stack([jb.metrics.rms_bearing_force(sol, t_min=0.0), jb.metrics.peak_ball_load(sol, t_min=0.0)])

    return jax.jit(metrics)


@pytest.mark.slow  # 14 s: two forward-mode programs at rtol 1e-10 (tests/test_tune.py checks
# forward mode against central differences in the default set, a batch of tangents on the rotor)
def test_forward_mode_derivatives_agree_with_simulate():
    """d/d clearance of the RMS bearing force and the peak ball load through the while loop
    (forward mode, the event times' tangents from the implicit function theorem) against the
    segmented solve's (diffrax's events) and against central differences of the loop itself.
    Measured at rtol 1e-10: the two drivers 0.69 % apart on the RMS (the segmented one 0.7 %
    from its own central differences, the loop 0.14 %), 7e-9 on the peak; 1 % is the target."""
    controller = jb.default_controller(rtol=1e-10, atol=1e-12)
    one_loop = _rotor_metrics(lambda m: jb.simulate_one_loop(m, ROTOR_T1, stepsize_controller=controller))
    segments = _rotor_metrics(
        lambda m: jb.simulate(m, ROTOR_T1, [0.0, ROTOR_T1], stepsize_controller=controller,
                              adjoint=diffrax.ForwardMode())
    )
    c, dc = jnp.asarray(40e-6), jnp.asarray(1.0)
    value, tangent = jax.jvp(one_loop, (c,), (dc,))
    value_s, tangent_s = jax.jvp(segments, (c,), (dc,))
    np.testing.assert_allclose(value, value_s, rtol=1e-6)
    np.testing.assert_allclose(tangent, tangent_s, rtol=1e-2)
    h = 1e-8  # [m]: 0.025 % of the clearance
    value_at = lambda x: jax.jvp(one_loop, (x,), (dc,))[0]  # noqa: E731 (the compiled jvp: no other compile)
    central = (value_at(c + h) - value_at(c - h)) / (2 * h)
    np.testing.assert_allclose(tangent, central, rtol=1e-2)


@pytest.mark.slow  # 25 s: JAX traces the reverse pass before it refuses
def test_reverse_mode_raises_naming_simulate(paper_case):
    model, _, _ = paper_case

    def peak(c):
        point = jb.paths.replace(model, {"bearing.clearance": c})
        return jb.metrics.peak_ball_load(jb.simulate_one_loop(point, T1))

    with pytest.raises(Exception, match="forward mode .* only: use simulate for reverse mode"):
        jax.grad(peak)(jnp.asarray(40e-6))


@pytest.mark.slow  # 15 s: another compile of each driver
def test_a_model_without_events_agrees_with_simulate():
    # no impact and the smooth ball force: no event at all, the loop only steps
    model = jb.cases.xu2014(impact=False, ball_force="smooth", window_start=WINDOW)
    assert not model.contacts and sum(model.event_counts()) == 0
    _assert_metrics_close(
        jb.simulate_one_loop(model, T1),
        jb.simulate(model, T1, [0.0, T1]),
    )


@pytest.mark.parametrize(
    "kwargs, solve",
    [
        ({}, "one_loop"),
        (dict(ts=[0.0, T1]), "segments"),
        (dict(metrics={"ball": lambda sol: jnp.max(sol.ball_loads)}), "segments"),
    ],
)
def test_sweep_runs_the_one_loop_unless_samples_are_read(kwargs, solve):
    """A sweep runs its members as one loop (the faster in batches) unless output times are
    asked for or a metric reads the samples, which `simulate` writes."""
    from jaxbearing._sweep import arguments

    metrics = kwargs.get("metrics", jb.metrics.STANDARD)
    items = arguments.metric_items(metrics, ["bearing.clearance"])
    assert arguments.driver_of(items, kwargs.get("ts")) == solve


@pytest.mark.parametrize("key", ["adjoint", "throw", "progress_label"])
def test_sweep_refuses_what_it_sets_or_does_not_know(key):
    with pytest.raises(TypeError, match="sweep"):
        jb.sweep(jb.cases.xu2014(), {"bearing.clearance": [20e-6]}, t1=T1, progress=False, **{key: None})

"""Pausing segments (`SolveOptions.segment_steps`): a pause resumes with the step-size
controller's state and proposed step, so the solution does not depend on it, and vmapped members
agree with the same points run alone.

Runs that pause elsewhere, or run as members of a batch, are other compiled programs, which XLA
may round differently; the solver amplifies such differences up to its accuracy (rtol 1e-8 on
states of millimetres and angles of 0.1 rad). So they are compared with tolerances that the
solver's own error sets: positions within 1e-7 m (the benchmark's reference check), angles
within 5e-7 rad (the rod's angle at 80 um clearance, 0.08 s, is 3.5e-7 rad from a run at
1000x tighter tolerances; a batch member and its single run measured 1.1e-7 rad apart), the
metrics within 1e-4 relative (the same member's peak ball load is 9.5e-5 from the tighter run,
2.9e-5 from its single run: ball loads go as deflections of micrometres to the power 1.5), step
counts within 1 %.
"""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

import jaxbearing as jb

T1 = 0.08  # [s] past the impact's onset: contact events and ball switches both occur
TS = jnp.linspace(0.0, T1, 41)
POSITION_TOLERANCE = 1e-7  # [m]
ANGLE_TOLERANCE = 5e-7  # [rad]
METRIC_TOLERANCE = 1e-4  # relative


def _model():
    return jb.cases.xu2014(impact=True)


def _assert_agree(sol, ref):
    xy = np.arange(sol.q.shape[-1]) % 3 != 2  # (x, y, angle) per body
    np.testing.assert_allclose(sol.q[:, xy], ref.q[:, xy], rtol=0, atol=POSITION_TOLERANCE)
    np.testing.assert_allclose(sol.q[:, ~xy], ref.q[:, ~xy], rtol=0, atol=ANGLE_TOLERANCE)
    assert abs(int(sol.num_steps) - int(ref.num_steps)) <= 0.01 * int(ref.num_steps)
    onsets = lambda s: np.asarray(s.contacts.time)[np.asarray(s.contacts.valid)]  # noqa: E731
    np.testing.assert_allclose(onsets(sol), onsets(ref), rtol=0, atol=1e-9)
    for name, metric in jb.metrics.STANDARD.items():
        np.testing.assert_allclose(metric(sol), metric(ref), rtol=METRIC_TOLERANCE, err_msg=name)


@pytest.mark.slow  # 30 s: three compiles of the paper's case with impact
def test_pauses_leave_the_solution_unchanged():
    plain = jb.simulate(_model(), T1, TS)  # pausing every SEGMENT_STEPS steps
    for k in (8, 64):
        paused = jb.simulate(_model(), T1, TS, options=jb.SolveOptions(segment_steps=k))
        assert int(paused.num_segments) > int(plain.num_segments)  # it did pause
        _assert_agree(paused, plain)


@pytest.mark.slow  # 25 s each: vmapped and single compiles; tests/test_sweep.py compares by default
@pytest.mark.parametrize("segment_steps", [None, 8])  # 8: a sweep's segments
def test_vmapped_members_agree_with_single_runs(segment_steps):
    """Under vmap diffrax moves a member without an event to the end of its last attempted step
    when another member stops at one; `simulate` ends such a member at its last accepted step."""
    clearances = jnp.array([20e-6, 50e-6, 80e-6])
    restitutions = jnp.array([0.95, 0.7, 0.5])
    options = jb.SolveOptions(segment_steps=segment_steps)

    def one(clearance, restitution):
        model = jb.paths.replace(_model(), {"bearing.clearance": clearance, "impact.restitution": restitution})
        return jb.simulate(model, T1, TS, options=options, throw=False)

    batch = jax.jit(jax.vmap(one))(clearances, restitutions)
    single = jax.jit(one)
    for i in range(clearances.shape[0]):
        member = jax.tree_util.tree_map(lambda x: x[i], batch)
        _assert_agree(member, single(clearances[i], restitutions[i]))


@pytest.mark.slow  # 25 s: three compiles
def test_a_paused_segment_keeps_its_step_limit():
    """max_steps bounds the run's steps however it is cut into segments: the run fails, it does
    not go on."""
    model, ts = jb.cases.xu2014(impact=False), jnp.array([0.0, 0.01])
    # pausing every 40 steps: the compiled solve that the python-span test below runs as well
    assert int(jb.simulate(model, 0.01, ts, options=jb.SolveOptions(segment_steps=40)).num_steps) > 40
    for k in (None, 8):
        sol = jb.simulate(model, 0.01, ts, options=jb.SolveOptions(segment_steps=k), max_steps=40, throw=False)
        assert sol.result == jb.RESULTS.max_steps_reached
    with pytest.raises(jb.SimulationError):
        jb.simulate(model, 0.01, ts, options=jb.SolveOptions(segment_steps=8), max_steps=40)


# 4 segments of at most 8 steps: a run that pauses and runs out of segments in its first 32
# steps (one compiled solve, whatever the span and up to 2048 output times)
SHORT = jb.SolveOptions(segment_steps=8, max_segments=4)


def test_a_failed_run_keeps_the_outputs_it_reached():
    """A run that runs out of segments returns, with throw=False, the output times before its
    t_final as a run with enough segments computes them (the same steps up to there, paused
    elsewhere: another compiled program, whose rounding may differ in the last bits; 1e-12
    relative is far above it and far below any other step), and NaN after; the block of output
    times it was filling when it stopped included."""
    model, ts = jb.cases.xu2014(impact=False), jnp.linspace(0.0, 0.02, 201)
    full = jb.simulate(model, 0.02, ts)  # the compiled solve of tests/conftest.py's "free_0.02s"
    cut = jb.simulate(model, 0.02, ts, options=SHORT, throw=False)
    assert cut.result == jb.RESULTS.max_segments_reached
    reached = np.asarray(ts) < float(cut.t_final)
    assert 0 < reached.sum() < ts.shape[0]
    for name in ("q", "qd", "qdd", "ball_loads"):
        np.testing.assert_allclose(getattr(cut, name)[reached], getattr(full, name)[reached], rtol=1e-12, atol=1e-12)
        assert np.isnan(np.asarray(getattr(cut, name))[~reached]).all(), name


def test_pauses_count_against_max_segments():
    sol = jb.simulate(jb.cases.xu2014(impact=False), 0.01, jnp.array([0.0, 0.01]), options=SHORT, throw=False)
    assert sol.result == jb.RESULTS.max_segments_reached
    assert jb.default_max_segments(_model(), 0.0, 0.2, 8) > jb.default_max_segments(_model(), 0.0, 0.2)


def test_a_python_span_sets_the_default_segments_also_under_jit():
    """A span given as Python numbers is known when `simulate` is traced inside the caller's jit
    (or `jb.sensitivity`), so the defaults that follow from it (max_segments, max_onsets) are
    those of the span, not of 1 s."""
    model, ts = jb.cases.xu2014(impact=False), jnp.array([0.0, 0.01])
    traced = jax.eval_shape(lambda: jb.simulate(model, 0.01, ts))  # traced, not compiled
    slots = traced.contacts.time.shape[0]  # max_onsets
    assert slots == jb.default_max_onsets(0.0, 0.01) < jb.default_max_onsets(0.0, 1.0)


def test_segment_steps_must_be_positive():
    with pytest.raises(ValueError, match="segment_steps must be None or an integer of at least 1"):
        jb.simulate(_model(), T1, TS, options=jb.SolveOptions(segment_steps=0))


def cradle():
    """Three 10 mm steel spheres in a row on frictionless slides, 20 um apart; the first comes at
    1 m/s: it strikes the second at 20 us (for about 15 us), which then strikes the third (at
    about 55 us): two contact onsets (a smaller program than the paper's case)."""
    from jaxbearing.multibody import Body, CircleContact, Mechanism, Translational

    r, gap = 0.005, 2e-5
    impact = jb.Impact.from_geometry(radius_j=r, radius_k=r, restitution=1.0)
    pitch = 2 * r + gap
    return Mechanism(
        [Body(0.004, 1e-8)] * 3,
        [Translational(k) for k in range(3)],
        [0.0, 0.0, 0.0, pitch, 0.0, 0.0, 2 * pitch, 0.0, 0.0],
        [1.0] + [0.0] * 8,
        forces=tuple(CircleContact(k, (0.0, 0.0), r, k + 1, (0.0, 0.0), r, impact) for k in (0, 1)),
    )


def test_more_onsets_than_recorded_fail_loudly():
    """`Solution.contacts` records ``max_onsets`` contact onsets; a run with more fails (a wrong
    answer, contacts silently dropped, is worse than an error), naming the option to raise."""
    model, t1 = cradle(), 5e-4
    ts = jnp.array([0.0, t1])
    sol = jb.simulate(model, t1, ts, options=jb.SolveOptions(max_onsets=1), throw=False)
    assert sol.result == jb.RESULTS.max_onsets_reached
    assert int(sol.contacts.count) == 1 and float(sol.t_final) < t1  # stopped at the second strike
    assert float(sol.contacts.time[0]) == pytest.approx(2e-5, rel=1e-9)  # the gap over the speed
    assert float(sol.t_final) > 4e-5  # the first strike's end, then the second sphere's gap
    with pytest.raises(jb.SimulationError, match="max_onsets"):
        jb.simulate(model, t1, ts, options=jb.SolveOptions(max_onsets=1))

"""Pausing segments (`simulate(..., segment_steps=K)`): a pause resumes with the step-size
controller's state and proposed step, so the solution does not depend on K, and vmapped members
equal the same points run alone, to the last bit."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

import jaxbearing as jb

T1 = 0.08  # [s] past the impact's onset: contact events and ball switches both occur
TS = jnp.linspace(0.0, T1, 41)


def _model():
    return jb.cases.xu2014(impact=True)


def test_pauses_leave_the_solution_unchanged_to_the_last_bit():
    plain = jb.simulate(_model(), T1, TS)  # pausing every SEGMENT_STEPS steps
    for k in (8, 64):
        paused = jb.simulate(_model(), T1, TS, segment_steps=k)
        assert int(paused.num_segments) > int(plain.num_segments)  # it did pause
        assert int(paused.num_steps) == int(plain.num_steps)
        np.testing.assert_array_equal(paused.q, plain.q)
        np.testing.assert_array_equal(paused.ball_loads, plain.ball_loads)
        onsets = lambda sol: np.asarray(sol.contacts.time)[np.asarray(sol.contacts.valid)]  # noqa: E731
        np.testing.assert_array_equal(onsets(paused), onsets(plain))
        for name, metric in jb.metrics.STANDARD.items():
            np.testing.assert_allclose(metric(paused), metric(plain), rtol=1e-14, err_msg=name)


@pytest.mark.parametrize(
    "segment_steps", [pytest.param(None, marks=pytest.mark.slow), 8]  # 8: a sweep's segments
)
def test_vmapped_members_equal_single_runs_to_the_last_bit(segment_steps):
    """Under vmap diffrax moves a member without an event to the end of its last attempted step
    when another member stops at one; `simulate` ends such a member at its last accepted step."""
    clearances = jnp.array([20e-6, 50e-6, 80e-6])
    restitutions = jnp.array([0.95, 0.7, 0.5])

    def one(clearance, restitution):
        model = jb.paths.replace(_model(), {"bearing.clearance": clearance, "impact.restitution": restitution})
        sol = jb.simulate(model, T1, TS, segment_steps=segment_steps, throw=False)
        return sol.q, jb.metrics.peak_ball_load(sol), sol.num_steps

    batch = jax.jit(jax.vmap(one))(clearances, restitutions)
    single = jax.jit(one)
    for i in range(clearances.shape[0]):
        alone = single(clearances[i], restitutions[i])
        for b, a in zip(batch, alone):
            np.testing.assert_array_equal(b[i], a)


def test_cos_and_sin_held_change_no_bit(monkeypatch):
    """The solver's cos and sin returned through a conditional (`jaxbearing._forms`, taken with
    loops compiled whole, which this suite runs without: forced here) give a run the plain
    form's numbers to the last bit, and vmapped members their single runs'."""
    from jaxbearing import _forms

    clearances = jnp.array([20e-6, 80e-6])

    def one(clearance):
        model = jb.paths.replace(_model(), {"bearing.clearance": clearance})
        sol = jb.simulate(model, T1, TS, segment_steps=8, throw=False)
        return sol.q, sol.ball_loads, jb.metrics.peak_ball_load(sol), sol.num_steps

    def runs(held: bool):
        monkeypatch.setattr(_forms, "loop_kernels", lambda: held)
        jax.clear_caches()  # trace again, in this form
        batch = jax.jit(jax.vmap(one))(clearances)
        return batch, [jax.jit(one)(c) for c in clearances]

    held_batch, held = runs(True)
    _, plain = runs(False)
    jax.clear_caches()
    for i in range(clearances.shape[0]):
        for b, h, p in zip(held_batch, held[i], plain[i]):
            np.testing.assert_array_equal(b[i], h)
            np.testing.assert_array_equal(h, p)


def test_a_paused_segment_keeps_its_step_limit():
    """max_steps bounds a segment's steps over all its pauses: the run fails, it does not go on."""
    model, ts = jb.cases.xu2014(impact=False), jnp.array([0.0, 0.01])
    # pausing every 40 steps: the compiled solve that the python-span test below runs as well
    assert int(jb.simulate(model, 0.01, ts, segment_steps=40, time_cells=1).num_steps) > 40
    for k in (None, 8):
        sol = jb.simulate(model, 0.01, ts, segment_steps=k, max_steps=40, time_cells=1, throw=False)
        assert sol.result == jb.RESULTS.max_steps_reached
    with pytest.raises(jb.SimulationError):
        jb.simulate(model, 0.01, ts, segment_steps=8, max_steps=40, time_cells=1)


def test_a_failed_run_keeps_the_outputs_it_reached():
    """A run that runs out of segments returns, with throw=False, the output times before its
    t_final as a run with enough segments computes them (the same segments up to there), and
    NaN after; the block of output times it was filling when it stopped included."""
    model, ts = jb.cases.xu2014(impact=False), jnp.linspace(0.0, 0.02, 201)
    full = jb.simulate(model, 0.02, ts)  # the compiled solve of tests/conftest.py's "free_0.02s"
    cut = jb.simulate(model, 0.02, ts, max_segments=2, throw=False)
    assert cut.result == jb.RESULTS.max_segments_reached
    reached = np.asarray(ts) < float(cut.t_final)
    assert 0 < reached.sum() < ts.shape[0]
    for name in ("q", "qd", "qdd", "ball_loads"):
        np.testing.assert_array_equal(getattr(cut, name)[reached], getattr(full, name)[reached])
        assert np.isnan(np.asarray(getattr(cut, name))[~reached]).all(), name


def test_pauses_count_against_max_segments():
    sol = jb.simulate(
        jb.cases.xu2014(impact=False), 0.01, jnp.array([0.0, 0.01]), segment_steps=8, max_segments=4,
        time_cells=1, throw=False,
    )
    assert sol.result == jb.RESULTS.max_segments_reached
    assert jb.default_max_segments(_model(), 0.0, 0.2, 8) > jb.default_max_segments(_model(), 0.0, 0.2)


def test_a_python_span_sets_the_default_segments_also_under_jit():
    """A span given as Python numbers is known when `simulate` is traced inside the caller's jit
    (or `jb.sensitivity`), so the default max_segments is that of the span, not of 1 s (8x the
    slots for 0.2 s, each a zero-length solve in a single run)."""
    model, ts = jb.cases.xu2014(impact=False), jnp.array([0.0, 0.01])
    slots = lambda sol: sol.contacts.time.shape[0]  # noqa: E731
    kw = dict(segment_steps=40, time_cells=1)  # the first solve of the step-limit test
    plain = jb.simulate(model, 0.01, ts, **kw)
    traced = jax.eval_shape(lambda: jb.simulate(model, 0.01, ts, **kw))
    assert slots(traced) == slots(plain) < jb.default_max_segments(model, 0.0, 1.0, 40)


def test_segment_steps_must_be_positive():
    with pytest.raises(ValueError, match="segment_steps must be None or at least 1"):
        jb.simulate(_model(), T1, TS, segment_steps=0)

"""A metric or life over a window without output times has no value: it raises when the
inputs are concrete, and is NaN when traced (jit, vmap; sweeps mark the member failed); never -inf
or an infinite life."""

import json
import warnings

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import pytest

import jaxbearing as jb
from jaxbearing import life, metrics

TS = np.linspace(0.0, 0.005, 51)  # a run shorter than the default window start, 0.04 s
EMPTY = r"t_min = 0\.04 s to t_max = inf s must hold part of the solved span \[0, 0\.005\] s: " \
    r"lower t_min \(a metric of a Solution starts by default at the model's window_start\)"


@pytest.fixture(scope="module")
def short():
    """A run of the paper's case (with its contact, switched off until 0.05 s) to 0.005 s."""
    return jb.simulate(jb.cases.xu2014(impact=True), 0.005, TS)


ALL = {**metrics.STANDARD, **metrics.SMOOTH}


@pytest.mark.parametrize("name", sorted(ALL))
def test_empty_window_raises_naming_t_min_and_the_span(name, short):
    with pytest.raises(ValueError, match=EMPTY):
        ALL[name](short)


@pytest.mark.parametrize("name", sorted(ALL))
def test_empty_window_is_nan_under_jit_without_a_callback(name, short):
    """Traced, nothing can be raised: NaN, and no warning from inside the compiled program
    (its host callback would keep the program out of the persistent compilation cache)."""
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        value = float(jax.jit(ALL[name])(short))
    assert np.isnan(value)


@pytest.mark.parametrize("name", ["peak_ball_load", "rms_bearing_force"])
def test_a_vmapped_metric_equals_its_members_and_stays_differentiable(name, short):
    """A batch of solutions (their records and times scaled, as a sweep's members differ): the
    vmapped metric over the whole span equals each member's own, and it is differentiable in
    both modes."""

    def scaled(x):
        where = lambda s: (  # noqa: E731
            s.records.elements[0].peaks["max_element_load"], s.records.elements[0].integrals["force_squared"],
            s.intervals.t_start, s.intervals.t_end,
        )  # fmt: skip
        return ALL[name](eqx.tree_at(where, short, tuple(a * x for a in where(short))), t_min=None)

    xs = jnp.array([1.0, 3.0])
    batch = np.asarray(jax.jit(jax.vmap(scaled))(xs))
    singles = np.array([float(jax.jit(scaled)(x)) for x in xs])
    np.testing.assert_allclose(batch, singles, rtol=1e-12)
    assert np.isfinite(batch).all()
    assert np.isfinite(np.asarray(jax.jit(jax.vmap(jax.grad(scaled)))(xs))).all()
    assert np.isfinite(float(jax.jvp(scaled, (xs[1],), (1.0,))[1]))


PAST = r"The window ends at t_max = 0\.01 s, after the end of the run, t1 = 0\.005 s"


@pytest.mark.parametrize("name", sorted(ALL))
def test_a_window_past_the_end_of_a_successful_run_raises_or_is_nan(name, short):
    """Issue 71: a window that ends after t1 was cut at t1 without a word (the peak of what
    the run covered); it has no value: a ValueError, NaN under jit."""
    with pytest.raises(ValueError, match=PAST):
        ALL[name](short, t_min=None, t_max=0.01)
    assert np.isnan(float(jax.jit(lambda s: ALL[name](s, t_min=None, t_max=0.01))(short)))
    assert np.isfinite(float(ALL[name](short, t_min=None, t_max=0.005)))  # t1 itself is the end


def test_every_window_past_the_end_of_a_successful_run_raises(short):
    """The windows of `peak_time`, `loads_at_peak`, `peak_ball` and the lives, and a window
    that starts after t1; traced, `peak_time` is NaN and `peak_ball` -1."""
    model = jb.cases.xu2014(impact=True)
    past = dict(t_min=None, t_max=0.01)
    for read in (
        lambda: metrics.peak_time(short, metrics.peak_ball_load, **past),
        lambda: metrics.peak_time(short, metrics.peak_ball_load.replace(**past)),
        lambda: metrics.loads_at_peak(short, **past),
        lambda: metrics.peak_ball(short, **past),
        lambda: life.iso_life(short, model, **past),
        lambda: life.lp_life(short, model, **past),
    ):
        with pytest.raises(ValueError, match=PAST):
            read()
    assert np.isnan(float(jax.jit(lambda s: metrics.peak_time(s, metrics.peak_ball_load, **past))(short)))
    assert int(jax.jit(lambda s: metrics.peak_ball(s, **past))(short)) == -1
    with pytest.raises(ValueError, match=r"t_min = 0\.01 s to t_max = inf s must hold part of the solved span"):
        metrics.peak_ball_load(short, t_min=0.01)


def test_a_record_whose_window_lies_past_t1_is_refused_before_the_solve(compiled_functions):
    """`Peak` and `Mean` are read inside the compiled solve, where a window past t1 can only
    be NaN: `simulate` refuses them first, naming the record (a window that ends after t1, or
    one that starts at or after it, by its own t_min or the model's window_start)."""
    model = jb.cases.xu2014(impact=True)
    load = lambda m, x: jnp.max(x.bearings[0].ball_loads)  # noqa: E731
    cases = (
        (metrics.Peak(load, t_max=0.01), r"records\['late'\]: its window ends at t_max = 0\.01 s, after the end of the run, t1 = 0\.005 s"),
        (metrics.Mean(load, t_min=0.006), r"records\['late'\]: its window starts at t_min = 0\.006 s, at or after the end"),
        (metrics.Peak(load), r"records\['late'\]: its window starts at the model's window_start = 0\.04 s, at or after"),
    )
    with compiled_functions() as compiles:
        for record, message in cases:
            with pytest.raises(ValueError, match=message):
                jb.simulate(model, 0.005, TS, options=jb.SolveOptions(records={"late": record}))
    assert "jit(_simulate)" not in compiles


def test_a_sweep_s_window_past_t1_fails_its_members():
    """In a sweep (traced) a window that ends after t1 makes the metric NaN and the member
    failed, with the reason (it was the value over the part the run covered)."""
    rotor = jb.cases.rotor(jb.cases.skf98205(), speed=100.0)
    past = {"past": metrics.peak_ball_load.replace(t_min=None, t_max=0.01)}
    with pytest.warns(RuntimeWarning, match="2 of 2 members failed"):
        ds = jb.sweep(rotor, {"bearing.clearance": [20e-6, 40e-6]}, t1=0.005, metrics=past, progress=False)
    assert ds.failed.values.all() and np.isnan(ds["past"].values).all()
    assert all("ends after t1" in f["message"] for f in json.loads(ds.attrs["failures"]))


def test_window_inside_the_span_has_a_value(short):
    assert np.isfinite(float(metrics.peak_ball_load(short, t_min=0.0)))
    assert np.isfinite(float(jax.jit(lambda s: metrics.rms_bearing_force(s, t_min=0.0))(short)))


def test_simulated_short_run_and_its_vmapped_batch():
    """The case of issue 15: a run to t1 = 0.005 s with a default window that starts later (the
    paper's, 0.04 s), as in a sweep; on a rotor in the paper's bearing (quick to compile)."""
    model = jb.cases.rotor(jb.cases.skf98205(), speed=100.0, window_start=0.04)

    def member(c):
        s = jb.simulate(eqx.tree_at(lambda m: m.bearing.clearance, model, c), 0.005, TS)
        return metrics.peak_ball_load(s), metrics.peak_ball_load(s, t_min=0.0)

    empty, full = jax.jit(jax.vmap(member))(jnp.array([20e-6, 40e-6]))
    assert np.isnan(np.asarray(empty)).all() and np.isfinite(np.asarray(full)).all()


LIFE_EMPTY = r"t_min = 0\.04 s to t_max = inf s must hold at least two of the output times, " \
    r"which span \[0, 0\.005\] s"


def life_values(ts, force, rel, loads, t_min=0.04):
    return (
        life.equivalent_load(ts, force, rel, t_min),
        life.mean_speed_rpm(ts, rel, t_min),
        life.ball_equivalent_load(ts, loads, rel, 3.0, t_min),
        life.ring_equivalent_load(ts, loads, rel, t_min),
        life.rating_life(15e3, life.equivalent_load(ts, force, rel, t_min)),
    )


def test_life_over_an_empty_window_raises_or_is_nan():
    args = (TS, np.ones((TS.size, 2)), np.full(TS.size, 20.0 * np.pi), np.ones((TS.size, 8)))
    with pytest.raises(ValueError, match=LIFE_EMPTY):
        life_values(*args)
    values = [float(v) for v in jax.jit(life_values)(*args)]
    assert np.isnan(values).all()  # the rating life was +inf
    longer = jax.jit(life_values)(np.linspace(0.0, 0.1, 51), *args[1:])  # a window that holds
    assert np.isfinite([float(v) for v in longer]).all()


# ----------------------------------------------------------- one weighting of sampled windows


def test_window_weights_integrate_a_linear_function_exactly_between_samples():
    """`metrics.window` (and the life's revolution weights) integrate the samples' linear
    interpolant over the window: exact for f(t) = 3 + 2 t with edges between samples, on
    samples, and unbounded."""
    ts = jnp.asarray(np.sort(np.random.default_rng(0).uniform(0.0, 1.0, 40)))
    f = 3.0 + 2.0 * ts
    exact = lambda a, b: 3.0 * (b - a) + (b * b - a * a)
    for lo, hi in ((0.2137, 0.7771), (float(ts[5]), float(ts[30])), (0.5, None)):
        w = metrics.window(ts, lo, hi)
        b = float(ts[-1]) if hi is None else hi
        np.testing.assert_allclose(float(w @ f), exact(lo, b), rtol=1e-13)
        np.testing.assert_allclose(float(jnp.sum(w)), b - lo, rtol=1e-13)


def test_life_and_metrics_weight_a_window_alike():
    ts = jnp.linspace(0.0, 1.0, 21)
    rel = jnp.full(21, 2.0 * jnp.pi)  # one relative revolution per second
    w = metrics.window(ts, 0.33, 0.81)
    np.testing.assert_allclose(life.revolution_weights(ts, rel, 0.33, 0.81), w, rtol=1e-14)

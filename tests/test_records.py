"""Metrics of your own (`jb.metrics.Peak`, `jb.metrics.Mean`), declared before the solve and
recorded from every accepted step: on a rotor in the SKF 98205 (about 200 steps over 0.01 s).
The independent truths: the built-in metrics they restate (the same recorded points, so equal to
1e-12), a sweep's members equal to their single runs, and forward-mode derivatives against
central differences."""

import equinox as eqx
import jax.numpy as jnp
import pytest

import jaxbearing as jb

M = jb.metrics
T1 = 0.01  # [s]
EDGE = 0.004  # [s] a window edge of a record


def loads(model, x):
    return jnp.max(x.bearings[0].ball_loads)


def squared(model, x):
    return jnp.sum(x.bearings[0].force ** 2)


def clearance_scaled(model, x):  # reads the model: derivatives see its parameters
    return jnp.sum(x.bearings[0].force ** 2) / model.bearing.clearance


@pytest.fixture(scope="module")
def rotor():
    return jb.cases.rotor(jb.cases.skf98205(ball_force="smooth"), speed=100.0)


@pytest.fixture(scope="module")
def run(rotor):
    records = {
        "peak": M.Peak(loads),
        "mean": M.Mean(squared),
        "late_peak": M.Peak(loads, t_min=EDGE),
        "early_mean": M.Mean(squared, t_max=EDGE),
    }
    return jb.simulate(rotor, T1, options=jb.SolveOptions(records=records))


def test_records_restating_builtins_equal_them(run):
    sol = run
    assert float(sol.records["peak"]) == pytest.approx(float(M.peak_ball_load(sol)), rel=1e-12)
    rms = float(M.rms_bearing_force(sol))
    assert float(sol.records["mean"]) == pytest.approx(rms**2, rel=1e-12)
    # a record's window edges are stops of the solve: the built-ins read the same windows
    late = float(M.peak_ball_load(sol, t_min=EDGE))
    assert float(sol.records["late_peak"]) == pytest.approx(late, rel=1e-12)
    early = float(M.rms_bearing_force(sol, t_max=EDGE))
    assert float(sol.records["early_mean"]) == pytest.approx(early**2, rel=1e-12)
    assert float(sol.records["late_peak"]) <= float(sol.records["peak"])


def test_a_record_must_be_declared_and_return_a_scalar(rotor, run):
    with pytest.raises(ValueError, match=r"not recorded by the solve: declare it"):
        M.Peak(squared)(run)
    with pytest.raises(ValueError, match=r"must return a scalar"):
        jb.simulate(rotor, T1, options=jb.SolveOptions(records={"v": M.Peak(lambda m, x: x.q)}))
    with pytest.raises(TypeError, match=r"records\['v'\] must be a jaxbearing.metrics.Peak or Mean"):
        jb.SolveOptions(records={"v": M.peak_ball_load})
    with pytest.raises(ValueError, match=r"t_max must exceed t_min"):
        M.Mean(squared, t_min=0.005, t_max=0.002)


@pytest.mark.slow  # a sweep of two members and two forward-mode derivatives of the rotor
def test_sweeps_and_sensitivity_take_records(rotor):
    peak = M.Peak(loads)
    clearances = [20e-6, 40e-6]
    ds = jb.sweep(rotor, {"bearing.clearance": clearances}, t1=T1, metrics={"peak": peak}, progress=False)
    assert not ds["failed"].any()
    for c, value in zip(clearances, ds["peak"].values):
        single = jb.simulate(eqx.tree_at(lambda m: m.bearing.clearance, rotor, c), T1)
        assert value == pytest.approx(float(M.peak_ball_load(single)), rel=1e-6)
    # a record that reads the model: d mean(|F|^2 / c) / dc by forward mode is the product
    # rule's d mean(|F|^2) / dc / c - mean(|F|^2) / c^2 of the same solve's derivative (to
    # rounding); a record that closed over the model would miss the second term, here as large
    # as the first
    c = float(rotor.bearing.clearance)
    value, grad = jb.sensitivity(rotor, M.Mean(clearance_scaled), ["bearing.clearance"], t1=T1)
    plain, plain_grad = jb.sensitivity(rotor, M.Mean(squared), ["bearing.clearance"], t1=T1)
    assert float(value) == pytest.approx(float(plain) / c, rel=1e-12)
    expected = float(plain_grad["bearing.clearance"]) / c - float(plain) / c**2
    assert float(grad["bearing.clearance"]) == pytest.approx(expected, rel=1e-9)
    assert abs(float(plain) / c**2) > 0.1 * abs(expected)

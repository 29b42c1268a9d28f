"""Every metric is a `metrics.AbstractMetric`: a built-in with other fields (`replace`) computes
what the call with those arguments computes, its fields are checked when set, and it tells the
sweep, `sensitivity` and `converged` its window edges, records, needs and label; the L10 life is
such a metric, so `sensitivity` differentiates it (against central differences).

The solves: a rotor in the paper's SKF 98205 (a small mechanism, quick to compile) over 0.01 s.
"""

from __future__ import annotations

import functools

import numpy as np
import pytest

import jaxbearing as jb
from jaxbearing import metrics as M

T1 = 0.01
EDGE = 0.005  # [s] a window edge the solve stops at


@pytest.fixture(scope="module")
def rotor():
    return jb.cases.rotor(jb.cases.skf98205(), speed=100.0)


@pytest.fixture(scope="module")
def run(rotor):
    return jb.simulate(rotor, T1, options=jb.SolveOptions(window_edges=(EDGE,)))


def test_a_replaced_metric_is_the_call_with_those_arguments(rotor, run):
    """The same function on the same solution: equal to the last bit."""
    cases = [
        (M.peak_ball_load, {"t_min": EDGE}),
        (M.peak_ball_load, {"t_min": None, "t_max": EDGE, "bearing": 0}),
        (M.rms_bearing_force, {"t_min": EDGE}),
        (M.smooth_peak_ball_load, {"t_min": None}),
        (M.max_target_displacement, {"coordinate": 1, "t_min": None}),
        (M.peak_time, {"metric": M.peak_bearing_force, "t_min": EDGE}),
    ]
    for metric, fields in cases:
        replaced = metric.replace(**fields)
        expected = float(metric(run, **fields))
        assert float(replaced(run)) == expected, replaced.label
        assert float(replaced.value(run, rotor)) == expected, replaced.label
        assert all(getattr(replaced, k) == v for k, v in fields.items())  # fields read as attributes
    # peak_time reads the element and window of its metric where it is not given them itself
    assert float(M.peak_time(run, M.peak_ball_load.replace(t_min=EDGE))) == float(
        M.peak_time(run, M.peak_ball_load, t_min=EDGE)
    )
    assert float(M.peak_time(run, M.peak_ball_load.replace(bearing=0), bearing=0)) == float(
        M.peak_time(run, M.peak_ball_load)
    )
    with pytest.raises(ValueError, match=r"peak_time got t_min=0\.002 and a metric with t_min=0\.005: give t_min once"):
        M.peak_time(run, M.peak_ball_load.replace(t_min=EDGE), t_min=0.002)
    # an index is checked against the model when the metric is computed
    with pytest.raises(ValueError, match=r"bearing must index one of the model's 1 bearing joint"):
        M.peak_ball_load.replace(bearing=1)(run)


@pytest.mark.parametrize(
    "metric, fields, error, message",
    [
        (M.peak_ball_load, {"t_min": "start"}, ValueError,
         r"t_min must be a time \[s\], \"model\" \(the model's window_start\) or None \(from t0\); got 'start'"),
        (M.peak_ball_load, {"t_max": float("nan")}, ValueError,
         r"t_max must be a time \[s\] or None \(to the end of the run\); got nan"),
        (M.peak_ball_load, {"t_min": 0.2, "t_max": 0.1}, ValueError, r"t_max must exceed t_min"),
        (M.peak_ball_load, {"bearing": -1}, ValueError,
         r"bearing must be None \(the only one\) or an index, an integer >= 0; got -1"),
        (M.peak_impact_force, {"contact": 1.5}, ValueError, r"contact must be None .* got 1\.5"),
        (M.max_target_displacement, {"coordinate": True}, ValueError, r"coordinate must be None .* got True"),
        (M.smooth_peak_ball_load, {"p": 8}, TypeError, r"smooth_peak_ball_load has no field p"),
        (M.peak_time, {"metric": M.rms_bearing_force}, ValueError,
         r"metric must be an exact peak .* got jaxbearing\.metrics\.rms_bearing_force"),
        (M.peak_ball_load, {"contact": 0}, TypeError,
         r"peak_ball_load has no field contact; its fields: t_min, t_max, bearing"),
        (M.Peak(abs), {"t_min": "model"}, ValueError, r"t_min must be a time \[s\] or None; got 'model'"),
    ],
)
def test_replace_checks_each_field(metric, fields, error, message):
    with pytest.raises(error, match=message):
        metric.replace(**fields)


def test_labels_edges_records_and_equality():
    late = M.peak_ball_load.replace(bearing=1, t_min=0.05)
    assert late.label == "peak_ball_load(t_min=0.05, bearing=1)"  # the fields that differ, in call order
    assert repr(late) == "jaxbearing.metrics.peak_ball_load(t_min=0.05, bearing=1)"
    assert M.peak_ball_load.label == "peak_ball_load" and M.max_drift.label == "max_drift"
    when = M.peak_time.replace(metric=M.peak_impact_force.replace(t_max=0.08), t_min=0.01)
    assert when.label == "peak_time(metric=peak_impact_force(t_max=0.08), t_min=0.01)"
    assert sorted(when.edges()) == [0.01, 0.08]  # its own and its metric's
    assert M.peak_ball_load.edges() == () and M.peak_ball_load.replace(t_min=None).edges() == ()
    # compared and hashed by value: a sweep's, a manifest's and a compiled call's key
    assert late == M.peak_ball_load.replace(t_min=0.05).replace(bearing=1)
    assert late != M.peak_ball_load.replace(bearing=1)
    assert len({late, M.peak_ball_load.replace(t_min=0.05, bearing=1), M.peak_ball_load}) == 2
    # what they need of the solve
    for metric in (*M.STANDARD.values(), *M.SMOOTH.values(), when, M.peak_ball, M.loads_at_peak):
        assert not metric.reads_samples and not metric.reads_fatigue and metric.records() == ()
    life = jb.life.metric("iso", t_min=0.05)
    assert life.reads_fatigue and not life.reads_samples and life.edges() == (0.05,)
    # a metric of your own declares itself, under its label
    peak = M.Peak(abs, t_max=0.08)
    assert peak.records() == (("Peak(abs, t_max=0.08)", peak),)
    assert peak.edges() == (0.08,) and peak.replace(t_max=None).edges() == ()


def largest_sampled_load(sol):
    return np.max(sol.ball_loads)


def test_a_function_is_a_metric_that_reads_the_samples(rotor, run):
    metric = M.as_metric(largest_sampled_load)
    assert metric.reads_samples and not metric.reads_fatigue
    assert metric.edges() == () and metric.records() == ()
    assert metric.label == f"{__name__}.largest_sampled_load"
    assert float(metric.value(run, rotor)) == float(np.max(run.ball_loads))
    # a functools.partial is such a function: its keywords are not read (no edge)
    partial = M.as_metric(functools.partial(M.peak_ball_load, t_min=EDGE))
    assert partial.reads_samples and partial.edges() == ()
    assert float(partial.value(run, rotor)) == float(M.peak_ball_load(run, t_min=EDGE))
    assert M.as_metric(M.peak_ball_load) is M.peak_ball_load
    with pytest.raises(TypeError, match=r"metric must be a metric \(a jaxbearing\.metrics\.AbstractMetric"):
        M.as_metric(3.0)


def test_solve_options_declare_records_and_add_edges(rotor):
    peak = M.Peak(abs, t_min=0.004)
    metrics = (peak, M.peak_ball_load.replace(t_min=0.002), M.rms_bearing_force.replace(t_max=T1), peak)
    options = M.solve_options(jb.SolveOptions(window_edges=(0.002,)), metrics, T1, rotor.window_start)
    assert options.records == peak.records()  # declared once
    assert options.window_edges == (0.002, 0.004)  # t1 and the edge given already are stops
    # two records under one label: numbered in order, the same names in every process
    one, other = M.Peak(lambda m, x: x.t), M.Peak(lambda m, x: x.t)
    options = M.solve_options(None, (one, other), T1)
    label = one.label
    assert options.records == ((label, one), (f"{label}#2", other))


@pytest.mark.slow  # 10-40 s: forward mode, 3 solves at rtol 1e-10 (issue 75: the suite's time)
def test_sensitivity_of_the_life_to_the_clearance():
    """d L10h / d clearance of `life.metric()` (ISO 281, of the model at the perturbed
    clearance: it enters through the solve) by forward mode against central differences (step
    1e-3 of the clearance) within 2e-3: the derivative of the discrete solve converges more
    slowly than the solution (docs/gradients.md); measured 1.7e-4 apart (-1.760e13 h/m at
    L10h = 6.09e8 h), smooth ball force."""
    model = jb.cases.rotor(jb.cases.skf98205(ball_force="smooth", damping=3000.0), speed=100.0)
    controller = jb.default_controller(rtol=1e-10, atol=1e-12)
    metric = jb.life.metric()
    value, grad = jb.sensitivity(model, metric, ["bearing.clearance"], t1=T1, stepsize_controller=controller)

    def at(c):
        m = jb.paths.replace(model, {"bearing.clearance": c})
        return float(jb.life.iso_life(jb.simulate(m, T1, stepsize_controller=controller), m).l10_hours)

    c, h = float(model.bearing.clearance), 1e-3 * float(model.bearing.clearance)
    assert float(value) == pytest.approx(at(c), rel=1e-6)  # another compiled program: rounding
    difference = (at(c + h) - at(c - h)) / (2 * h)
    assert float(grad["bearing.clearance"]) == pytest.approx(difference, rel=2e-3)

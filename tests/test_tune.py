"""Gradients through the simulation against central finite differences, vmapped gradients, and
the optax tuning loop."""

import diffrax
import jax
import jax.numpy as jnp
import numpy as np
import optax
import pytest

import jaxbearing as jb
from jaxbearing import metrics


def rotor_model(clearance=20e-6, stiffness=5e9, damping=200.0):
    bearing = jb.BallBearing(clearance, stiffness, damping, 29.2e-3, 46.6e-3, 8, ball_force="smooth")
    return jb.cases.rotor(bearing, mass=2.0, speed=300.0, eccentricity=2e-5)


ROTOR_TS = jnp.linspace(0.0, 0.02, 201)
ROTOR_KW = dict(stepsize_controller=jb.default_controller(rtol=1e-10, atol=1e-13), options=jb.SolveOptions(window_edges=(0.005,)))  # the metric starts at 0.005 s
NAMES = ["bearing.clearance", "bearing.stiffness", "bearing.damping"]


def rotor_metric(sol):
    return metrics.rms_bearing_force(sol, t_min=0.005)


def central_difference(model, name, rel_step):
    x = float(jb.paths.get(model, name))
    h = rel_step * x
    f = [
        float(rotor_metric(jb.simulate(jb.paths.replace(model, {name: x + s * h}), 0.02, ROTOR_TS, **ROTOR_KW)))
        for s in (1.0, -1.0)
    ]
    return (f[0] - f[1]) / (2 * h)


@pytest.mark.slow  # ~20 s; tests/test_derivatives.py checks both modes in the default suite
def test_forward_and_reverse_gradients_match_finite_differences():
    model = rotor_model()
    value_f, grad_f = jb.sensitivity(model, rotor_metric, NAMES, 0.02, ROTOR_TS, mode="forward", **ROTOR_KW)
    value_r, grad_r = jb.sensitivity(model, rotor_metric, NAMES, 0.02, ROTOR_TS, mode="reverse", **ROTOR_KW)
    # the two modes compile the primal solve differently (other fusions, other rounding), and
    # the adaptive step sequence amplifies rounding to ~1e-8 of the value (measured 4e-8)
    assert float(value_f) == pytest.approx(float(value_r), rel=1e-6)
    for name in NAMES:
        # central differences with a 1e-3 relative step at rtol 1e-10: at 1e-4 the step-sequence
        # noise reaches 1e-3 (measured for the stiffness: 1.5e-3, while steps of 1e-2 and 1e-3
        # agree within 7e-5 and the forward derivative lies within 1.5e-4 of them)
        fd = central_difference(model, name, 1e-3)
        assert float(grad_f[name]) == pytest.approx(fd, rel=1e-3), name
        assert float(grad_r[name]) == pytest.approx(fd, rel=1e-3), name


@pytest.mark.slow  # 30 s: a vmapped jacfwd compile
def test_vmapped_forward_gradients():
    base = rotor_model()

    def grad_at(clearance):
        model = jb.paths.replace(base, {"bearing.clearance": clearance})

        def f(c):
            sol = jb.simulate(jb.paths.replace(model, {"bearing.clearance": c}), 0.02, ROTOR_TS,
                              adjoint=diffrax.ForwardMode(), **ROTOR_KW)
            return rotor_metric(sol)

        return jax.jacfwd(f)(clearance)

    clearances = jnp.array([10e-6, 30e-6])
    batched = jax.vmap(grad_at)(clearances)
    single = [jb.sensitivity(rotor_model(float(c)), rotor_metric, ["bearing.clearance"], 0.02, ROTOR_TS,
                             **ROTOR_KW)[1]["bearing.clearance"] for c in clearances]
    # vmap batches the arithmetic (other rounding), so step sequences differ at round-off level
    # and the derivatives of this rattling rotor by ~1e-4 (measured 1.4e-4); 1e-3 bounds it
    np.testing.assert_allclose(np.asarray(batched), np.asarray(single), rtol=1e-3)
    assert np.all(np.isfinite(np.asarray(batched)))


def test_tune_mechanics_on_an_analytic_loss():
    model = jb.cases.xu2014(impact=True)

    def loss(m):  # no simulation: minimum at P_d = 30 µm, e = 0.7 (outside the bound 0.75)
        return ((m.bearing.clearance - 30e-6) / 1e-5) ** 2 + (m.impact.restitution - 0.7) ** 2

    seen = []
    result = jb.tune(
        loss, model, ["bearing.clearance", "impact.restitution"], optax.adam(0.05), 300,
        bounds={"impact.restitution": (0.75, 1.0)}, callback=lambda k, v, p: seen.append(k),
    )
    assert result.values["bearing.clearance"] == pytest.approx(30e-6, rel=1e-3)
    assert result.values["impact.restitution"] == pytest.approx(0.75, abs=1e-9)  # projected
    assert float(result.model.bearing.clearance) == pytest.approx(30e-6, rel=1e-3)
    assert seen == list(range(301))
    assert result.history_loss.shape == (301,)
    assert float(model.bearing.clearance) == 4e-5  # the input model is unchanged


@pytest.mark.slow  # 13 s (forward mode); test_tune_returns_the_best_valid_iterate runs tune by default,
# in reverse mode
def test_tune_identifies_rotor_damping():
    """A rotor's bearing-force history at known damping; start 30 % off; a few Adam steps move
    the damping towards the truth and reduce the misfit (the full identification is a study)."""
    truth = rotor_model(damping=200.0)
    measured = jb.simulate(truth, 0.02, ROTOR_TS, **ROTOR_KW).bearing_force

    def loss(m):
        f = jb.simulate(m, 0.02, ROTOR_TS, **ROTOR_KW).bearing_force
        return jnp.mean((f - measured) ** 2) / jnp.mean(measured**2)

    result = jb.tune(loss, rotor_model(damping=260.0), ["bearing.damping"], optax.adam(0.1), 6)
    assert result.history_loss[-1] < 0.5 * result.history_loss[0]
    assert abs(result.values["bearing.damping"] - 200.0) < abs(260.0 - 200.0)


def test_tune_rejects_bad_arguments():
    model = jb.cases.xu2014()
    with pytest.raises(ValueError, match="outside its bounds"):
        jb.tune(lambda m: m.bearing.clearance, model, ["bearing.clearance"], optax.sgd(0.1), 1,
                bounds={"bearing.clearance": (0.0, 1e-5)})
    with pytest.raises(ValueError, match="does not exist"):
        jb.tune(lambda m: 0.0, model, ["bearing.clearence"], optax.sgd(0.1), 1)


def test_a_batch_of_tangents_matches_central_differences():
    """`sensitivity` takes all its tangents through one solve (a vmapped jvp); each derivative
    matches central differences of the metric. Differences with steps of 1e-3 to 1e-5 of the
    value scatter by up to 5e-5 (clearance) and 2e-4 (stiffness, roundoff at 1e-5); at 1e-4 both
    lie within 2e-5 of the tangents: 1e-4."""
    model = jb.cases.rotor(jb.cases.skf98205(ball_force="smooth"), speed=100.0)
    metric = metrics.rms_bearing_force
    names = ["bearing.clearance", "bearing.stiffness"]
    _, grads = jb.sensitivity(model, metric, names, 0.005)
    for name in names:
        x = float(jb.paths.get(model, name))
        h = 1e-4 * x
        # the metric's values from the same compiled solve (its primal half: no other compile)
        f = [float(jb.sensitivity(jb.paths.replace(model, {name: x + s * h}), metric, names, 0.005)[0])
             for s in (1.0, -1.0)]
        assert float(grads[name]) == pytest.approx((f[0] - f[1]) / (2 * h), rel=1e-4), name


def test_sensitivity_defaults_to_the_derivative_tolerance(monkeypatch):
    """Without a stepsize_controller `sensitivity` simulates at `derivative_controller()` (rtol
    `DERIVATIVE_RTOL`), not at simulate's default; a controller passed wins. Checked on what it
    hands to its compiled solve, without solving."""
    from jaxbearing import _tune

    assert float(_tune.derivative_controller().rtol) == _tune.DERIVATIVE_RTOL == 1e-11
    assert float(_tune.derivative_controller().atol) == pytest.approx(_tune.DERIVATIVE_RTOL / 100)
    seen = []

    def spy(model, x, metric, names, t1, ts, mode, simulate_kwargs):  # in place of the compiled solve
        seen.append(simulate_kwargs["stepsize_controller"])
        return jnp.zeros(()), jnp.zeros((1,)), jnp.zeros((), bool)  # value, gradient, failed

    monkeypatch.setattr(_tune, "_value_and_grad", spy)
    model = rotor_model()
    for given, rtol in ((None, _tune.DERIVATIVE_RTOL), (jb.default_controller(rtol=1e-9), 1e-9)):
        kw = {} if given is None else {"stepsize_controller": given}
        jb.sensitivity(model, rotor_metric, ["bearing.clearance"], 0.02, **kw)
        assert float(seen[-1].rtol) == rtol


def test_tune_warns_when_the_loss_jumps():
    model = jb.cases.xu2014()

    def loss(m):  # x = clearance / 40 µm; SGD at 5 multiplies x - 0.5 by -9 a step
        return (m.bearing.clearance / 4e-5 - 0.5) ** 2

    with pytest.warns(jb.TuneWarning, match=r"the loss jumped above 10 times the previous step's at step 1, 2 "):
        result = jb.tune(loss, model, ["bearing.clearance"], optax.sgd(5.0), 2)
    assert float(result.loss) == pytest.approx(0.25) and result.values["bearing.clearance"] == 4e-5  # step 0
    assert result.invalid_steps == () and len(result.notes) == 1


def test_tune_warns_when_the_gradient_is_zero():
    """A loss that goes flat (no load: a hinge at 50 µm) past the first step."""
    model = jb.cases.xu2014()
    with pytest.warns(jb.TuneWarning, match=r"the gradient is zero \(or the loss 0\) at step 1, 2 .*"
                      r"no contact/no load in the window\?"):
        result = jb.tune(lambda m: jax.nn.relu(5e-5 - m.bearing.clearance) / 1e-5, model,
                         ["bearing.clearance"], optax.sgd(1.0), 2)
    np.testing.assert_allclose(result.history_loss, [1.0, 0.0, 0.0], rtol=1e-12)


def test_tune_stops_at_a_non_finite_loss():
    model = jb.cases.xu2014()

    def loss(m):  # NaN below 20 µm: SGD at 1 jumps from 40 µm to 0
        c = m.bearing.clearance / 4e-5
        return jnp.where(c > 0.5, (c - 0.75) ** 2 * 4, jnp.nan)

    with pytest.warns(jb.TuneWarning, match=r"step 1 .* is not valid: the loss or its gradient is "
                      r"not finite\. tune stopped there .* returns the best valid iterate, step 0"):
        result = jb.tune(loss, model, ["bearing.clearance"], optax.sgd(0.5), 5)
    assert result.invalid_steps == (1,)
    assert result.history_loss.shape == (2,) and np.isnan(result.history_loss[1])
    assert float(result.loss) == pytest.approx(0.25) and result.values["bearing.clearance"] == 4e-5


def test_tune_returns_the_best_valid_iterate_past_an_invalid_clearance():
    """An unbounded tune with a huge step: Adam's first step moves the clearance by 1000 of its
    scale (20 mm, beyond the model's rules either way); the solve refuses it, tune stops, warns
    and returns the starting point, the only valid iterate. In reverse mode: the default set's
    one `jax.grad` through a solve (auto would take forward mode for one parameter)."""
    model = rotor_model()

    def loss(m):
        return rotor_metric(jb.simulate(m, 0.02, ROTOR_TS, **ROTOR_KW))

    with pytest.warns(jb.TuneWarning, match=r"step 1 .* is not valid: its evaluation failed "
                      r"\(bearing\.clearance must .*\)\. tune stopped there"):
        result = jb.tune(loss, model, ["bearing.clearance"], optax.adam(1000.0), 3, mode="reverse")
    assert result.invalid_steps == (1,)
    assert abs(result.history_values["bearing.clearance"][1]) > 1e-2
    assert result.values["bearing.clearance"] == 20e-6
    assert np.isfinite(float(result.loss)) and float(result.loss) == result.history_loss[0]
    assert float(result.model.bearing.clearance) == 20e-6


@pytest.mark.slow
def test_four_bar_derivative_at_the_default_tolerance_is_within_2_percent():
    """docs/gradients.md's table: the four-bar's derivatives w.r.t. the clearance at
    `sensitivity`'s default tolerance against the converged ones (rtol 1e-12, which central
    differences at rtol 1e-12 match within 0.2 %); at rtol 1e-10 they were up to 4.5 % off."""
    model = jb.cases.four_bar(jb.cases.skf98205(ball_force="smooth"), window_start=0.06)

    def metric(sol):
        return jnp.stack([metrics.rms_bearing_force(sol), metrics.smooth_peak_ball_load(sol),
                          metrics.peak_bearing_force(sol)])

    _, default = jb.sensitivity(model, metric, ["bearing.clearance"], 0.12)
    _, converged = jb.sensitivity(model, metric, ["bearing.clearance"], 0.12,
                                  stepsize_controller=jb.default_controller(rtol=1e-12, atol=1e-14))
    np.testing.assert_allclose(np.asarray(default["bearing.clearance"]),
                               np.asarray(converged["bearing.clearance"]), rtol=0.02)


def test_auto_mode_takes_forward_mode_for_a_few_parameters_and_reverse_for_many(monkeypatch):
    """`derivative_mode`: forward up to `FORWARD_MAX_PARAMETERS` names, reverse beyond; `tune`
    traces its loss inside ``default_adjoint(ForwardMode())`` in forward mode only, and
    `sensitivity` hands the mode it chose to its compiled derivative (checked without a solve)."""
    from jaxbearing import _tune

    n = jb.FORWARD_MAX_PARAMETERS
    chosen = [_tune.derivative_mode("auto", k) for k in (1, n, n + 1)]
    assert chosen == ["forward", "forward", "reverse"]
    assert _tune.derivative_mode("reverse", 1) == "reverse"
    assert _tune.derivative_mode("forward", 50) == "forward"
    model = jb.cases.xu2014(impact=True)
    scalars = [p for p in jb.paths.parameter_paths(model) if jnp.ndim(jb.paths.get(model, p)) == 0]
    names = scalars[: n + 1]
    assert len(names) == n + 1
    seen = []

    def loss(m):  # no simulation: records the adjoint a simulate here would take
        seen.append(jb.simulation._ADJOINT.get())
        return sum(jb.paths.get(m, p) ** 2 for p in names[:1])

    for k, mode, adjoint in ((1, "auto", diffrax.ForwardMode), (n + 1, "auto", type(None)),
                             (1, "reverse", type(None)), (n + 1, "forward", diffrax.ForwardMode)):
        jb.tune(loss, model, names[:k], optax.sgd(1e-3), 1, mode=mode)
        assert isinstance(seen[-1], adjoint), (k, mode)
    assert jb.simulation._ADJOINT.get() is None  # the block is left

    modes = []
    monkeypatch.setattr(_tune, "_value_and_grad", lambda *a: modes.append(a[6]) or (  # a spy
        jnp.zeros(()), jnp.zeros((len(a[3]),)), jnp.zeros((), bool)))
    for k in (1, n + 1):
        jb.sensitivity(model, metrics.rms_bearing_force, names[:k], 0.02)
    assert modes == ["forward", "reverse"]


def test_a_bad_mode_is_refused_naming_the_modes():
    model = jb.cases.xu2014()
    allowed = r"mode must be one of 'auto', 'forward', 'reverse'; got 'backward'"
    with pytest.raises(ValueError, match=allowed):
        jb.tune(lambda m: m.bearing.clearance, model, ["bearing.clearance"], optax.sgd(0.1), 1,
                mode="backward")
    with pytest.raises(ValueError, match=allowed):
        jb.sensitivity(model, metrics.rms_bearing_force, ["bearing.clearance"], 0.02,
                       mode="backward")
    with pytest.raises(TypeError, match="default_adjoint takes a diffrax adjoint"):
        with jb.default_adjoint("forward"):
            pass


def test_an_explicit_adjoint_wins_over_default_adjoint(monkeypatch):
    """`simulate` takes the adjoint of the enclosing `default_adjoint` block where given none,
    and its own where given one; blocks nest and restore (checked on what `simulate` hands to
    its compiled solve, without solving)."""
    seen = []

    class Stop(Exception):
        pass

    def spy(adjoint, *args):
        seen.append(adjoint)
        raise Stop

    monkeypatch.setattr(jb.simulation, "_with_adjoint", spy)
    model = jb.cases.xu2014()
    forward, checkpointed = diffrax.ForwardMode(), diffrax.RecursiveCheckpointAdjoint()

    def adjoint_of(**kw):
        with pytest.raises(Stop):
            jb.simulate(model, 0.005, **kw)
        return seen[-1]

    assert adjoint_of() is None
    with jb.default_adjoint(forward):
        assert adjoint_of() is forward and adjoint_of(adjoint=None) is forward
        assert adjoint_of(adjoint=checkpointed) is checkpointed
        with jb.default_adjoint(None):
            assert adjoint_of() is None
        assert adjoint_of() is forward
    assert adjoint_of() is None


@pytest.mark.slow  # 45 s: a forward- and a reverse-mode compile
def test_tune_s_forward_and_reverse_modes_give_the_same_gradient():
    """One SGD step of `tune` in each mode on a short rotor run at the derivative tolerance: the
    step is the learning rate times the gradient (scaled variables), so the two iterates give
    the two gradients. The loss calls `simulate` with its defaults in both modes."""
    model = jb.cases.rotor(jb.cases.skf98205(ball_force="smooth"), speed=100.0)
    names = ["bearing.clearance", "bearing.stiffness"]

    def loss(m):
        sol = jb.simulate(m, 0.005, stepsize_controller=jb.derivative_controller())
        return metrics.rms_bearing_force(sol)

    steps, losses = {}, {}
    for mode in ("forward", "reverse"):
        result = jb.tune(loss, model, names, optax.sgd(1e-3), 1, mode=mode)
        steps[mode] = np.array([np.diff(result.history_values[n])[0] for n in names])
        losses[mode] = result.history_loss[0]
    # two compiled programs round differently: the step sequences, and so the values, differ
    # at round-off level (as test_forward_and_reverse_gradients_match_finite_differences)
    assert losses["forward"] == pytest.approx(losses["reverse"], rel=1e-6)
    assert np.all(steps["forward"] != 0)
    np.testing.assert_allclose(steps["forward"], steps["reverse"], rtol=0.02)

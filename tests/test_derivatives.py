"""Every derivative path against converged central differences, for both ball forces, with and
without impact (issue 15).

The paper's ball force switches each ball's damping on at first touch; `simulate` locates every
switch as an event, so derivatives include the jump terms. The references are central
differences whose step comes from a convergence study: steps of 1e-3 ... 1e-6 of the value, the
two neighbours that agree best define the reference (their mean) and must agree within 0.5 %
(the difference has converged: truncation below, solver noise above). Solves run at rtol 1e-12,
atol 1e-14 so that the noise floor lies well below the steps used; a step of 1e-3 of the
clearance (40 nm) can already straddle a grazing ball (measured: 13 % off), while the ball
stiffness needs it (its smaller steps scatter by 2 %): no step is trusted without its neighbour.
"""

import diffrax
import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import pytest

import jaxbearing as jb
from jaxbearing import metrics

TIGHT = dict(stepsize_controller=jb.default_controller(rtol=1e-12, atol=1e-14), max_steps=400_000)
REL_STEPS = (1e-3, 1e-4, 1e-5, 1e-6)
CONVERGED = 0.005  # neighbouring differences agree this well at the chosen step
AGREE = 0.02  # derivatives within 2 % of the converged difference (the bound)


def converged_difference(f, model, name):
    """Central difference of ``f(model)`` w.r.t. parameter ``name`` at the converged step."""
    x = float(jb.paths.get(model, name))
    fd = []
    for rel in REL_STEPS:
        h = rel * abs(x)
        plus = float(f(jb.paths.replace(model, {name: x + h})))
        minus = float(f(jb.paths.replace(model, {name: x - h})))
        fd.append((plus - minus) / (2 * h))
    gaps = [abs(a - b) / max(abs(a), abs(b)) for a, b in zip(fd[:-1], fd[1:])]
    best = int(np.argmin(gaps))
    assert gaps[best] < CONVERGED, f"{name}: differences did not converge: {fd}"
    return 0.5 * (fd[best] + fd[best + 1])


class Case:
    def __init__(self, ball_force, impact):
        self.model = jb.cases.xu2014(impact=impact, ball_force=ball_force)
        self.t1 = 0.1 if impact else 0.02
        self.ts = jnp.linspace(0.0, self.t1, 201)
        t_min = 0.04 if impact else 0.0  # with impact: after the start-up, through the impacts
        self.metric = lambda sol: metrics.rms_bearing_force(sol, t_min=t_min)
        self.names = ["bearing.clearance", "bearing.stiffness", "bearing.damping"]
        if impact:
            self.names.append("impact.restitution")
        # the differences run `simulate` itself: without impact its compiled solve is the one
        # of other tests of the same run (tests/conftest.py, COMPILE_GROUPS)
        metric = jax.jit(self.metric)
        self.value = lambda m: metric(jb.simulate(m, self.t1, self.ts, **TIGHT))
        self.reference = {n: converged_difference(self.value, self.model, n) for n in self.names}
        # second member of the vmapped batch: with impact the RMS force is a rough function of
        # the clearance away from 40 um (the motion rattles between impacts: at 44 um central
        # differences scatter by 10 % and do not converge), so the batch repeats the design point
        # and checks only that vmap carries the derivative (each lane against the reference)
        self.second = float(jb.paths.get(self.model, "bearing.clearance")) * (1.0 if impact else 1.1)


_CASES = {}


def case(ball_force, impact):
    if (ball_force, impact) not in _CASES:
        _CASES[ball_force, impact] = Case(ball_force, impact)
    return _CASES[ball_force, impact]


def check_paths(c):
    """sensitivity forward (jax.jacfwd with ForwardMode) and reverse (jax.grad)."""
    for mode in ("forward", "reverse"):
        _, grad = jb.sensitivity(c.model, c.metric, c.names, c.t1, c.ts, mode=mode, **TIGHT)
        for name in c.names:
            assert float(grad[name]) == pytest.approx(c.reference[name], rel=AGREE), (mode, name)


def check_vmapped_jacfwd(c):
    """A user's own jax.jacfwd around simulate (ForwardMode), vmapped over two design points."""
    name = "bearing.clearance"
    x0 = float(jb.paths.get(c.model, name))

    def f(x):
        m = jb.paths.replace(c.model, {name: x})
        return c.metric(jb.simulate(m, c.t1, c.ts, adjoint=diffrax.ForwardMode(), **TIGHT))

    batched = eqx.filter_jit(jax.vmap(jax.jacfwd(f)))(jnp.array([x0, c.second]))
    assert float(batched[0]) == pytest.approx(c.reference[name], rel=AGREE)
    if c.second == x0:  # with impact: the repeated point, against the finite difference too
        assert float(batched[1]) == pytest.approx(c.reference[name], rel=AGREE)
    else:
        second = jb.paths.replace(c.model, {name: c.second})
        assert float(batched[1]) == pytest.approx(converged_difference(c.value, second, name), rel=AGREE)


@pytest.mark.slow  # ~70 s: two compiles of the solve (reverse and forward mode)
def test_reverse_mode_replays_no_step():
    """Reverse mode through a state sample at 2.5 ms, over ~800 steps in segments of up to 128:
    with diffrax's default checkpointing (about 15 checkpoints for 128 steps) its reverse pass
    recomputed steps in another compiled program, whose rounding made the step-size controller
    take other steps than the forward pass, and came out 3e-2 off forward mode (whether a
    recomputed step flips is chance: at 2 or 3 ms it did not). `simulate` stores every step of a
    segment (`stored_steps`); the two modes then differentiate the same steps but for their
    programs' rounding, which can still flip a step of the controller (measured: 4e-4 with the
    XLA:CPU options of f7a5625, 6.5e-3 with XLA's defaults), hence 1e-2, below the 3e-2 of the
    replayed steps."""
    model, name = jb.cases.xu2014(impact=False, ball_force="smooth"), "bearing.clearance"
    t1, ts = 0.005, jnp.linspace(0.0, 0.005, 11)

    def at(x, adjoint=None):
        m = jb.paths.replace(model, {name: x})
        sol = jb.simulate(m, t1, ts, adjoint=adjoint, stepsize_controller=jb.default_controller(rtol=1e-10, atol=1e-12), options=jb.SolveOptions(fatigue=False))
        return sol.q[5, 3]

    x0 = float(jb.paths.get(model, name))
    reverse = float(eqx.filter_jit(jax.grad(at))(x0))
    forward = float(jax.jacfwd(lambda x: at(x, diffrax.ForwardMode()))(x0))
    assert reverse == pytest.approx(forward, rel=1e-2)


@pytest.mark.slow  # 45 s: two compiles of the solve (reverse and forward mode)
def test_output_samples_differentiate_alike_in_both_modes():
    """Reverse mode through the output samples, not a metric: the segment loop writes the
    samples in blocks of 64 that span several segments here (about 5 samples a segment), each
    block once (eqxi's buffers: a block written twice gets its cotangent twice). Against
    forward mode, which runs another loop without such buffers (its own
    agreement with central differences: test_sensitivities_without_impact). The modes agree to 5e-4,
    not to rounding: their programs round differently, take other steps, and the derivative of
    the discrete solution is not under the step control (docs/gradients.md), hence 1e-2."""
    model, name = jb.cases.xu2014(impact=False), "bearing.clearance"
    t1, ts = 0.01, jnp.linspace(0.0, 0.01, 301)
    weights = jnp.asarray(np.random.default_rng(0).normal(size=ts.shape[0]))

    def f(m, adjoint=None):
        sol = jb.simulate(m, t1, ts, adjoint=adjoint, **TIGHT)
        return jnp.sum(weights * sol.q[:, 3]) + 1e-6 * jnp.sum(weights * sol.ball_loads[:, 0])

    at = lambda x, adjoint=None: f(jb.paths.replace(model, {name: x}), adjoint)
    x0 = float(jb.paths.get(model, name))
    reverse = float(eqx.filter_jit(jax.grad(at))(x0))
    forward = float(jax.jacfwd(lambda x: at(x, diffrax.ForwardMode()))(x0))
    assert reverse == pytest.approx(forward, rel=1e-2)


@pytest.mark.slow  # 1 min each: 3 tangents at once through the paper's case; the default set checks
# forward mode against central differences on the rotor (tests/test_tune.py, a batch of tangents)
# and runs reverse mode through tune (tests/test_tune.py, mode="reverse")
@pytest.mark.parametrize("ball_force", ["paper", "smooth"])
def test_sensitivities_without_impact(ball_force):
    check_paths(case(ball_force, impact=False))


@pytest.mark.slow  # 20 s: a vmapped forward-mode compile
def test_vmapped_jacfwd_without_impact():
    """Smooth force, at the design point and 10 % wider. A user's `jax.grad` of this model
    without impact: tests/test_transforms.py."""
    check_vmapped_jacfwd(case("smooth", impact=False))


@pytest.mark.slow  # 70 s: a reverse- and a forward-mode compile
def test_user_transforms_of_the_standard_and_smooth_metrics_without_impact():
    """A user's `jax.jacrev` and vmapped `jax.jacfwd` of two metrics at once, the RMS bearing
    force and the smooth peak ball load (its derivative is exact: the peak is a smooth function
    of the recorded forces), paper force, without impact."""
    c = case("paper", impact=False)
    name, x0 = "bearing.clearance", float(jb.paths.get(c.model, "bearing.clearance"))

    def f(x, adjoint=None):
        sol = jb.simulate(jb.paths.replace(c.model, {name: x}), c.t1, c.ts, adjoint=adjoint, **TIGHT)
        return jnp.stack([c.metric(sol), metrics.smooth_peak_ball_load(sol, t_min=0.0)])

    value = eqx.filter_jit(lambda m: f(jb.paths.get(m, name)))
    reference = [c.reference[name], converged_difference(lambda m: value(m)[1], c.model, name)]
    np.testing.assert_allclose(np.asarray(eqx.filter_jit(jax.jacrev(f))(x0)), reference, rtol=AGREE)
    forward = jax.vmap(jax.jacfwd(lambda x: f(x, diffrax.ForwardMode())))
    second = jb.paths.replace(c.model, {name: c.second})
    reference_second = [converged_difference(lambda m: value(m)[i], second, name) for i in range(2)]
    batched = np.asarray(eqx.filter_jit(forward)(jnp.array([x0, c.second])))
    np.testing.assert_allclose(batched, [reference, reference_second], rtol=AGREE)


@pytest.mark.slow  # ~2 min each: forward-, reverse- and vmapped forward-mode compiles with impact
@pytest.mark.parametrize("ball_force", ["paper", "smooth"])
def test_derivatives_with_impact(ball_force):
    """`sensitivity` in both modes and a user's vmapped `jax.jacfwd`. Reverse mode through a
    user's own `jax.grad` is the program of `sensitivity`'s reverse mode (with simulate's
    error checks): tests/test_transforms.py checks it, and tests/test_tune.py through `tune`."""
    c = case(ball_force, impact=True)
    check_paths(c)
    check_vmapped_jacfwd(c)

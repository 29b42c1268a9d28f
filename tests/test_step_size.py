"""Step-size control: a constant step stated in `SolveOptions.dt0` (`diffrax.ConstantStepSize`),
and the first step of an adaptive run.

Truth: a body on a linear spring-damper (no joints), m u'' = -k u - c u', whose closed form is
u(t) = exp(-s t) (u0 cos(w t) + s u0 / w sin(w t)), s = c / 2m, w = sqrt(k/m - s^2). The model,
the span and the output times are the same in every run of a controller: other steps compile
nothing new.
"""

import jax

jax.config.update("jax_enable_x64", True)

import diffrax  # noqa: E402
import numpy as np  # noqa: E402
import pytest  # noqa: E402

import jaxbearing as jb  # noqa: E402
from jaxbearing.multibody import GROUND, Body, Mechanism, SpringDamper  # noqa: E402

MASS, STIFFNESS, DAMPING = 1.0, 1e4, 2.0  # [kg, N/m, N s/m]: w = 100 rad/s, a period of 63 ms
FREE_LENGTH, U0 = 0.1, 0.01  # [m]
T1 = 0.048  # [s]
TS = np.linspace(0.0, T1, 7)  # every 8 ms: a step end of every constant step below


def oscillator(stiffness=STIFFNESS):
    """The body, pulled by the spring towards the ground point at the origin, starts at rest
    U0 beyond the spring's free length, on the x axis (it stays there)."""
    spring = SpringDamper(GROUND, (0.0, 0.0), 0, (0.0, 0.0), stiffness, DAMPING, FREE_LENGTH)
    return Mechanism([Body(MASS, 0.1)], [], [FREE_LENGTH + U0, 0.0, 0.0], forces=[spring])


def closed_form(t):
    s = DAMPING / (2.0 * MASS)
    w = np.sqrt(STIFFNESS / MASS - s * s)
    return np.exp(-s * t) * (U0 * np.cos(w * t) + s * U0 / w * np.sin(w * t))


def error(sol) -> float:
    """The largest error [m] of the stretch at the output times."""
    return float(np.max(np.abs(np.asarray(sol.q)[:, 0] - FREE_LENGTH - closed_form(TS))))


def constant(dt0, model=None, **options):
    return jb.simulate(
        oscillator() if model is None else model, T1, TS,
        stepsize_controller=diffrax.ConstantStepSize(), options=jb.SolveOptions(dt0=dt0, **options),
    )


def test_a_constant_step_converges_to_the_closed_form_at_the_method_s_order():
    """Tsit5 is of order 5: its global error is C (w h)^5 times the amplitude for small w h,
    so halving the step divides it by 2^5 = 32 (measured 57, 43, 40 from w h = 0.4 down: the
    higher-order terms fade). The ratios of the two smallest pairs must lie within 2^4.5 and
    2^6, and at w h = 0.1 the error is below 1e-9 m, 1e-7 of the amplitude (measured 1.7e-11 m).
    Every output time is a step end, so no interpolation enters."""
    steps = (2e-3, 1e-3, 5e-4)
    runs = [constant(h) for h in steps]
    for h, sol in zip(steps, runs):
        assert int(sol.num_steps) == round(T1 / h)  # every step dt0 long, none rejected
        assert int(sol.num_rejected_steps) == 0
    errors = [error(sol) for sol in runs]
    orders = np.log2(np.array(errors[:-1]) / np.array(errors[1:]))
    assert np.all((orders > 4.5) & (orders < 6.0)), orders
    assert errors[1] < 1e-9


def test_a_constant_step_starts_again_after_a_stop():
    """Steps end at a window edge (a stop, as at an event) and the next ones are dt0 long from
    there: 21 steps to 0.0205 s (the last one cut short), 28 more to 0.048 s. diffrax's own
    grid over [t0, t1] would take 48, one of them 1.5 dt0 long."""
    sol = constant(1e-3, window_edges=(0.0205,))
    assert int(sol.num_steps) == 21 + 28
    assert error(sol) < 1e-9  # as the run without the stop: no step longer than dt0


def test_a_constant_step_whose_result_is_not_finite_fails_at_once():
    """A spring 1e8 times stiffer (w h = 1000): the steps blow up to inf and the run fails when
    the first step is not finite, far before max_steps or max_segments, naming the time."""
    with pytest.raises(jb.SimulationError, match=r"stopped at t = .* s of t1 = 0\.048 s: The minimum step"):
        constant(1e-3, model=oscillator(1e12))
    sol = jb.simulate(oscillator(1e12), T1, TS, stepsize_controller=diffrax.ConstantStepSize(),
                      options=jb.SolveOptions(dt0=1e-3), throw=False)
    assert sol.result == jb.RESULTS.dt_min_reached
    assert int(sol.num_steps) < 20 and float(sol.t_final) < T1


def test_an_adaptive_run_from_a_stated_first_step_agrees_with_the_default():
    """dt0 is only where the adaptive control starts (1e-6 s instead of 1e-7 (t1 - t0)): the
    run takes other steps (their count differs) and meets the same tolerances (rtol 1e-8, atol
    1e-10 per step), so both are within 1e-9 m, 10 atol, of the closed form (measured 6e-11
    and 4e-11 m over 0.05 s) and of each other."""
    default = jb.simulate(oscillator(), T1, TS)
    stated = jb.simulate(oscillator(), T1, TS, options=jb.SolveOptions(dt0=1e-6))
    assert int(stated.num_steps) != int(default.num_steps)
    assert error(default) < 1e-9 and error(stated) < 1e-9
    np.testing.assert_allclose(np.asarray(stated.q), np.asarray(default.q), rtol=0, atol=1e-9)

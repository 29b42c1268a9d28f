"""The root finder that locates event times (`_core`'s ITP method) against closed-form roots
and bisection's step count, the event time's implicit derivative, and its use under vmap."""

import math

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from jaxbearing.solve._core import EVENT_TIME_TOLERANCE, ITP_SLACK, _event_time, itp_start, itp_step

ROOT = 0.1234  # [s]
# name: (f(t, p), lower, upper); each crosses zero once in the bracket, at ROOT, at most 4 m/s
# steep (an event value is a penetration or a deflection [m]; rates of the paper's case are below
# 1 m/s)
FUNCTIONS = {
    "linear": (lambda t, p: 2.0 * (t - p), 0.1, 0.13),
    "cubic": (lambda t, p: 3e-2 * (t - p) * (1.0 + 1e4 * (t - p) ** 2), ROOT - 3e-6, ROOT + 5e-6),
    "falling sine": (lambda t, p: -1e-6 * jnp.sin(1e5 * (t - p)), ROOT - 1e-6, ROOT + 2e-5),
    # the maximum of two event values (as the core takes): a slow one crossing zero at the root,
    # a steep one that overtakes it 0.25 us later
    "kinked maximum": (lambda t, p: jnp.maximum(1e-3 * (t - p), 4.0 * (t - p) - 1e-6), ROOT - 1e-5, ROOT + 1e-5),
}


@jax.jit
def _locate(p, lower, upper, which):
    """The event time as the core locates it: ITP steps until the bracket is narrower than the
    tolerance; (its upper end, the steps taken)."""
    f = lambda t: jax.lax.switch(which, [lambda t, g=g: g(t, p) for g, _, _ in FUNCTIONS.values()], t)  # noqa: E731
    state = itp_start(lower, upper, f(lower), f(upper), EVENT_TIME_TOLERANCE)

    def body(carry):
        state, steps = carry
        return itp_step(state, f(state.next)), steps + 1

    state, steps = jax.lax.while_loop(
        lambda c: c[0].upper - c[0].lower >= EVENT_TIME_TOLERANCE, body, (state, 0)
    )
    return state.upper, steps


def _solve(name, p=ROOT):
    _, lower, upper = FUNCTIONS[name]
    return _locate(p, jnp.asarray(lower), jnp.asarray(upper), list(FUNCTIONS).index(name))


@pytest.mark.parametrize("name", FUNCTIONS)
def test_event_time_is_found_to_the_tolerance_in_fewer_steps_than_bisection(name):
    _, lower, upper = FUNCTIONS[name]
    t, steps = _solve(name)
    assert abs(float(t) - ROOT) < EVENT_TIME_TOLERANCE
    # ITP's bound: bisection's steps to a bracket narrower than the tolerance plus its slack
    bisection = math.ceil(math.log2((upper - lower) / EVENT_TIME_TOLERANCE))
    assert int(steps) <= bisection + ITP_SLACK + 1  # ITP: n_1/2 + n0 to a bracket below 2 tol, one more below tol
    if name != "kinked maximum":  # there regula falsi creeps from one side: bisection's pace
        assert int(steps) <= 10 < bisection  # superlinear on a smooth f


def test_a_root_at_the_upper_end_takes_no_step():
    f = lambda t: ROOT - t  # noqa: E731
    state = itp_start(jnp.asarray(0.1), jnp.asarray(ROOT), f(0.1), f(ROOT), EVENT_TIME_TOLERANCE)
    assert float(state.lower) == float(state.upper) == ROOT


def test_derivative_of_the_event_time_is_the_implicit_one():
    # root of t^3 = p: dt/dp = 1 / (3 t^2), from the located time, not the iterates; the
    # located event is the largest of the event values there (the other, t - 1, is below zero)
    def root(p):
        f = lambda t: t**3 - p  # noqa: E731
        state = itp_start(0.4, 0.6, f(0.4), f(0.6), EVENT_TIME_TOLERANCE)
        state = jax.lax.fori_loop(0, 60, lambda _, state: itp_step(state, f(state.next)), state)
        t_event, values = _event_time(lambda t: jnp.stack([t - 1.0, f(t)]), jax.lax.stop_gradient(state.upper))
        assert values.shape == (2,)
        return t_event

    p = 0.5**3 + 1e-3
    t = p ** (1 / 3)
    # each compiled whole: eagerly, every operation of the 60 steps would compile a program
    np.testing.assert_allclose(float(jax.jit(root)(p)), t, rtol=1e-12)
    np.testing.assert_allclose(float(jax.jit(jax.grad(root))(p)), 1.0 / (3.0 * t**2), rtol=1e-10)
    tangent = jax.jit(lambda p: jax.jvp(root, (p,), (1.0,))[1])(p)
    np.testing.assert_allclose(float(tangent), 1.0 / (3.0 * t**2), rtol=1e-10)


def test_vmapped_members_agree_with_single_solves():
    ps = jnp.array([ROOT, ROOT + 3e-6, ROOT - 4e-7])
    which = list(FUNCTIONS).index("falling sine")
    _, lower, upper = FUNCTIONS["falling sine"]
    batch, _ = jax.vmap(lambda p: _locate(p, jnp.asarray(lower), jnp.asarray(upper), which))(ps)
    for p, t in zip(ps, batch):
        assert abs(float(t) - float(_solve("falling sine", p)[0])) < EVENT_TIME_TOLERANCE
        assert abs(float(t) - float(p)) < EVENT_TIME_TOLERANCE

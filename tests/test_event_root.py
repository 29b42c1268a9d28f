"""The root finder that locates event times (`_segment._EventRoot`, the ITP method) against
closed-form roots, bisection's step count, its derivative and its use under vmap."""

import math

import jax
import jax.numpy as jnp
import numpy as np
import optimistix as optx
import pytest

from jaxbearing.solve._segment import EVENT_TIME_TOLERANCE, ITP_SLACK, _EventRoot

ROOT = 0.1234  # [s]
# name: (f(t, p), lower, upper); each crosses zero once in the bracket, at ROOT, at most 4 m/s
# steep (an event value is a penetration or a deflection [m]; rates of the paper's case are below
# 1 m/s), so that |f| < the tolerance is reachable on the root finder's time grid
FUNCTIONS = {
    "linear": (lambda t, p: 2.0 * (t - p), 0.1, 0.13),
    "cubic": (lambda t, p: 3e-2 * (t - p) * (1.0 + 1e4 * (t - p) ** 2), ROOT - 3e-6, ROOT + 5e-6),
    "falling sine": (lambda t, p: -1e-6 * jnp.sin(1e5 * (t - p)), ROOT - 1e-6, ROOT + 2e-5),
    # the maximum of two event values (as `first_event` takes): a slow one crossing zero at the
    # root, a steep one that overtakes it 0.25 us later
    "kinked maximum": (lambda t, p: jnp.maximum(1e-3 * (t - p), 4.0 * (t - p) - 1e-6), ROOT - 1e-5, ROOT + 1e-5),
}


def _solve(f, lower, upper, p=ROOT, finder=None):
    finder = _EventRoot(rtol=0.0, atol=EVENT_TIME_TOLERANCE) if finder is None else finder
    return optx.root_find(f, finder, y0=jnp.asarray(upper), args=p, options=dict(lower=lower, upper=upper), throw=False)


@pytest.mark.parametrize("name", FUNCTIONS)
def test_event_time_is_found_to_the_tolerance_in_fewer_steps_than_bisection(name):
    f, lower, upper = FUNCTIONS[name]
    sol = _solve(f, lower, upper)
    assert sol.result == optx.RESULTS.successful
    assert abs(float(sol.value) - ROOT) < EVENT_TIME_TOLERANCE
    # ITP's bound: bisection's steps to a bracket narrower than the tolerance plus its slack,
    # and one more for |f| < tolerance at the last point evaluated (the stop also asks that)
    bisection = math.ceil(math.log2((upper - lower) / EVENT_TIME_TOLERANCE))
    steps = int(sol.stats["num_steps"])
    assert steps <= bisection + ITP_SLACK + 1
    if name != "kinked maximum":  # there regula falsi creeps from one side: bisection's pace
        assert steps <= 10 < bisection  # superlinear on a smooth f


def test_a_root_at_the_upper_end_takes_one_step():
    # what diffrax asks of a batch member without an event: the root of t_next - t
    sol = _solve(lambda t, p: p - t, 0.1, ROOT)
    assert sol.result == optx.RESULTS.successful
    assert float(sol.value) == ROOT
    assert int(sol.stats["num_steps"]) == 1


def test_derivative_of_the_event_time_is_the_implicit_one():
    # root of t^3 = p: dt/dp = 1 / (3 t^2) (optimistix differentiates the root implicitly)
    def root(p):
        return _solve(lambda t, p: t**3 - p, 0.4, 0.6, p=p).value

    p = 0.5**3 + 1e-3
    t = p ** (1 / 3)
    np.testing.assert_allclose(float(jax.grad(root)(p)), 1.0 / (3.0 * t**2), rtol=1e-10)


def test_vmapped_members_equal_single_solves_to_the_last_bit():
    # a batch as diffrax root-finds it: members with their own roots and one without an event
    f = lambda t, p: jnp.where(p > 0.5, ROOT + 2e-5 - t, -1e-6 * jnp.sin(1e5 * (t - p)))  # noqa: E731
    ps = jnp.array([ROOT, ROOT + 3e-6, 0.9, ROOT - 4e-7])
    batch = jax.vmap(lambda p: _solve(f, ROOT - 1e-6, ROOT + 2e-5, p=p).value)(ps)
    alone = [float(_solve(f, ROOT - 1e-6, ROOT + 2e-5, p=p).value) for p in ps]
    assert [float(x) for x in batch] == alone

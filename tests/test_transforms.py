"""`jax.grad`, `jax.jacfwd`, `jax.vmap` and `jax.jit` around `simulate`, written as a JAX user
writes them, on a short run: 5 ms of the paper's case without impact (smooth ball force), the x
coordinate of body 1 at t1 as a function of the bearing clearance (`jax.jacrev` of two metrics:
tests/test_derivatives.py).

All solves run at rtol 1e-10: at rtol 1e-6 the derivative of the discrete solve is 6 % away from
the converged one (2.0905 against 1.9688), at 1e-10 within 0.2 %.
"""

import diffrax
import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import pytest

import jaxbearing as jb

MODEL = jb.cases.xu2014(impact=False, ball_force="smooth")
T1 = 0.005  # [s]
TS = jnp.linspace(0.0, T1, 3)
CLEARANCE = 4e-5  # [m]
H = 1e-7  # [m] central-difference step, 0.25 % of the clearance

# Tolerance against the central difference: the adaptive step sequence changes with the
# clearance, so the difference itself scatters by 0.3 % (h = 1e-9, 1e-8, 1e-7 m gave 1.9732,
# 1.9671, 1.9688), and forward and reverse mode differentiate slightly different step
# sequences (1.9739 against 1.9724): 1 % separates a right derivative from a wrong one (a
# dropped term of the bearing force changes it by far more).
RTOL_FD = 1e-2


def end_x(clearance, adjoint=None):
    """x of body 1 at t1 [m]."""
    model = eqx.tree_at(lambda m: m.bearing.clearance, MODEL, clearance)
    return jb.simulate(model, T1, TS, stepsize_controller=jb.default_controller(rtol=1e-10, atol=1e-12), adjoint=adjoint).q[-1, 3]


@pytest.fixture(scope="module")
def ends():
    """end_x at CLEARANCE -+ H under `jax.jit`."""
    f = jax.jit(end_x)
    return np.array([f(CLEARANCE - H), f(CLEARANCE + H)])


@pytest.fixture(scope="module")
def central_difference(ends):
    return (ends[1] - ends[0]) / (2 * H)


@pytest.mark.slow  # 20 s: a vmapped compile; tests/test_windows.py vmaps simulate by default
def test_vmap_equals_jit(ends):
    batch = jax.vmap(end_x)(jnp.array([CLEARANCE - H, CLEARANCE + H]))
    # batched kernels round differently, and the steps adapt to it: equal within the solver's
    # tolerance on a step (rtol 1e-10 of x = 0.107 m)
    np.testing.assert_allclose(batch, ends, rtol=0, atol=1e-10)
    assert ends[0] < ends[1]  # a wider clearance lets the body move further


@pytest.mark.slow  # 30 s: a reverse-mode compile of the paper's case; test_tune runs reverse mode in the default set
def test_grad_matches_central_difference(central_difference):
    # jax.jacrev of two metrics at once: tests/test_derivatives.py
    np.testing.assert_allclose(jax.grad(end_x)(CLEARANCE), central_difference, rtol=RTOL_FD)


@pytest.mark.slow  # 20 s: a forward-mode compile; tests/test_one_loop.py checks forward mode by default
def test_jacfwd_with_forward_mode_matches_central_difference(central_difference):
    forward = jax.jacfwd(lambda c: end_x(c, diffrax.ForwardMode()))(CLEARANCE)
    np.testing.assert_allclose(forward, central_difference, rtol=RTOL_FD)


@pytest.mark.parametrize("adjoint", [None, diffrax.RecursiveCheckpointAdjoint()], ids=["default", "checkpoint"])
def test_jacfwd_with_a_reverse_mode_adjoint_names_the_fix(adjoint):
    # reverse mode is the default, as in diffrax; JAX's own error carries a note naming the fix
    with pytest.raises(TypeError) as err:
        jax.jacfwd(lambda c: end_x(c, adjoint))(CLEARANCE)
    assert any("pass adjoint=diffrax.ForwardMode()" in note for note in err.value.__notes__)

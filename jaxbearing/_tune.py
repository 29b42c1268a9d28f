"""Gradients of metrics through the whole simulation, and tuning of parameters with optax.

No physics here: a loss is any function ``loss(model) -> scalar`` (it simulates and measures),
parameters are named by dotted paths (`jaxbearing.paths`).

Which differentiation mode:

- forward mode (`jax.jacfwd` with ``adjoint=diffrax.ForwardMode()`` in `simulate`) costs about one
  extra forward solve per parameter and works under `jax.vmap` (batches of design points): the
  right choice for the handful of design parameters of a bearing (clearance, restitution,
  stiffness, damping). `sensitivity` uses it by default.
- reverse mode (`jax.grad` with the default `RecursiveCheckpointAdjoint`) costs a fixed multiple
  of a forward run whatever the number of parameters (docs/performance.md gives the measured costs); use
  it for many parameters. `tune` uses it, so a loss can call `simulate` with its defaults.

Both ball forces give derivatives of the computed solution that are exact to the solver's
tolerance: the paper force's switches are located as events, whose implicit time derivatives
supply the jump terms (docs/model.md, 'Paper force: switched damping'). The paper force's metrics
are rougher functions of the parameters, though: a ball that barely grazes the race switches its
damping on with a jump, so a metric can bend sharply within a few tens of nanometres of clearance.
For optimisation prefer the smooth force and smooth metrics (`metrics.SMOOTH`); the exact peaks
jump when another sample takes the maximum.

Tolerances: the derivative of an adaptive solve is the derivative of the steps it took, not
under the step control, and converges more slowly than the solution. At simulate's default
(rtol 1e-8) derivatives of the standard metrics w.r.t. the clearance were 2-23 % off their
converged values on the paper's case and the four-bar, at rtol 1e-10 up to 4.5 %, at
`DERIVATIVE_RTOL` (1e-11) at most 0.7 % (docs/gradients.md has the table). `sensitivity`
simulates at `derivative_controller()` unless given a ``stepsize_controller``; `tune`
differentiates whatever the loss simulates, so a loss should pass it itself.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence

import diffrax
import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import optax

from . import _checks, paths as _paths
from .solve import default_controller, simulate

DERIVATIVE_RTOL = 1e-11  # derivatives of the standard metrics within 2 % (docs/gradients.md)
DERIVATIVE_ATOL = DERIVATIVE_RTOL / 100  # [m, rad, m/s], in simulate's default ratio to rtol


def derivative_controller() -> diffrax.PIDController:
    """``default_controller(DERIVATIVE_RTOL, DERIVATIVE_ATOL)`` (rtol 1e-11, atol 1e-13): the
    step-size control at which derivatives of the standard metrics were within 2 % of their
    converged values on the paper's case and the four-bar (at most 0.7 %; at simulate's default
    rtol 1e-8 up to 23 %, at 1e-10 up to 4.5 %: docs/gradients.md). The derivative of an adaptive
    solve converges more slowly than the solution: the step control bounds the error of the
    states, not of their derivatives. About four times the steps of simulate's default.
    `sensitivity` uses it by default; pass it to `simulate` in a `tune` loss."""
    return default_controller(rtol=DERIVATIVE_RTOL, atol=DERIVATIVE_ATOL)


def _values(model, names: Sequence[str], purpose: str) -> jax.Array:
    """The named parameters' values, (len(names),); a `ValueError` unless ``names`` are distinct
    paths to scalar array leaves (at least one)."""
    if isinstance(names, str) or not names:
        raise ValueError(f"names must be a non-empty list of parameter paths; got {names!r}.")
    _paths.check_distinct(model, names)
    model = _checks.float_leaves(model)  # a Python float set by eqx.tree_at is a value too
    return jnp.stack([jnp.asarray(_paths.scalar_leaf(model, n, purpose), jnp.float64) for n in names])


def _set(model, names: Sequence[str], values):
    return _paths.replace(model, {n: values[i] for i, n in enumerate(names)})


def sensitivity(
    model,
    metric: Callable,
    names: Sequence[str],
    t1: float,
    ts=None,
    *,
    mode: str = "forward",
    **simulate_kwargs,
):
    """d metric / d parameter for each named parameter, through the whole simulation.

    Args:
        model: the model at the design point.
        metric: a function of a `Solution` returning a scalar (e.g. `metrics.rms_bearing_force`).
        names: parameter paths, e.g. ``["bearing.clearance", "impact.restitution"]``.
        t1, ts, **simulate_kwargs: passed to `simulate`. Without a ``stepsize_controller``
            (or with None) it simulates at `derivative_controller()` (rtol `DERIVATIVE_RTOL` =
            1e-11, atol 1e-13), not at simulate's default (rtol 1e-8): the derivative of the
            discrete solve converges more slowly than the solution, and at rtol 1e-8 the
            derivatives of the standard metrics were up to 23 % off (docs/gradients.md). A
            ``stepsize_controller`` you pass wins.
        mode: ``"forward"`` (one `jax.jvp` per parameter, `diffrax.ForwardMode`) or
            ``"reverse"`` (`jax.grad`).

    Returns:
        ``(value, {name: derivative})`` in the metric's units per parameter unit.
    """
    if mode not in ("forward", "reverse"):
        raise ValueError(f"mode must be 'forward' or 'reverse'; got {mode!r}.")
    if simulate_kwargs.get("stepsize_controller") is None:
        simulate_kwargs = {**simulate_kwargs, "stepsize_controller": derivative_controller()}
    names = tuple(names) if not isinstance(names, str) else names
    x = _values(model, names, "to be differentiated")
    value, grad = _value_and_grad(model, x, metric, names, t1, ts, mode, simulate_kwargs)
    return value, {n: grad[i] for i, n in enumerate(names)}


@eqx.filter_jit
def _value_and_grad(model, x, metric, names, t1, ts, mode, simulate_kwargs):
    """Compiled once per metric, parameter names and settings: later calls at other designs
    (arrays of the same shapes) reuse it."""
    adjoint = diffrax.ForwardMode() if mode == "forward" else None

    def f(values):
        sol = simulate(_set(model, names, values), t1, ts, adjoint=adjoint, **simulate_kwargs)
        return metric(sol)

    if mode == "reverse":
        return jax.value_and_grad(f)(x)

    # one tangent at a time (`lax.map` over the unit vectors: one compiled jvp), not a batch of
    # them as `jax.jacfwd` takes: batched tangents cost more per tangent on a CPU than a
    # tangent alone, and compile longer (docs/performance.md)
    values, grad = jax.lax.map(lambda v: jax.jvp(f, (x,), (v,)), jnp.eye(x.shape[0], dtype=x.dtype))
    return values[0], grad


class TuneResult(eqx.Module):
    """Outcome of `tune`.

    Fields:
        model: the model at the best parameters found.
        values: {name: best value}.
        loss: the best loss.
        history_loss: (steps + 1,) loss at each iterate (the last one included).
        history_values: {name: (steps + 1,) values}.
    """

    model: object
    values: dict
    loss: jax.Array
    history_loss: np.ndarray
    history_values: dict


def tune(
    loss: Callable,
    model,
    names: Sequence[str],
    optimizer: optax.GradientTransformation,
    steps: int,
    *,
    bounds: Mapping[str, tuple[float, float]] | None = None,
    scale: Mapping[str, float] | None = None,
    callback: Callable | None = None,
) -> TuneResult:
    """Minimise ``loss(model)`` over the named parameters with an optax optimiser.

    The optimiser works on scaled variables x = value / scale (scale defaults to |initial value|)
    so that parameters of different units (a clearance of 4e-5 m, a restitution of 0.9) move at
    comparable rates; after each update the values are projected onto ``bounds``.

    Tolerances: `tune` follows the gradient of the loss as the loss computes it, at whatever
    tolerance its `simulate` runs. simulate's default (rtol 1e-8) gave derivatives of the
    standard metrics up to 23 % off their converged values; the derivative of the discrete solve
    converges more slowly than the solution. For gradients within 2 % (measured, with margin, on
    the paper's case and the four-bar: docs/gradients.md) simulate in the loss at
    ``stepsize_controller=derivative_controller()``, i.e. ``default_controller(rtol=1e-11,
    atol=1e-13)`` (`DERIVATIVE_RTOL`), about four times the steps.

    Args:
        loss: function of a model returning a scalar (it simulates and measures).
        model: the starting model.
        names: parameter paths to tune.
        optimizer: an optax `GradientTransformation` (e.g. ``optax.adam(0.05)``).
        steps: number of gradient steps.
        bounds: {name: (low, high)} in parameter units.
        scale: {name: scale} in parameter units.
        callback: called as ``callback(step, loss, {name: value})`` after each evaluation.
    """
    names = list(names) if not isinstance(names, str) else names
    if steps < 1:
        raise ValueError(f"steps must be at least 1; got {steps}.")
    x0 = _values(model, names, "to be tuned")
    for what, given in (("scale", scale), ("bounds", bounds)):
        unknown = sorted(set(given or {}) - set(names))
        if unknown:
            raise ValueError(f"{what} names {unknown}, which are not among the tuned names {names}.")
    scales = jnp.asarray(
        [float((scale or {}).get(n, abs(float(x0[i])) or 1.0)) for i, n in enumerate(names)]
    )
    for n, s in zip(names, np.asarray(scales)):
        if not (np.isfinite(s) and s > 0):
            raise ValueError(f"scale of {n} must be a finite number > 0 (in its units); got {s}.")
    lo = jnp.asarray([(bounds or {}).get(n, (-jnp.inf, jnp.inf))[0] for n in names], jnp.float64)
    hi = jnp.asarray([(bounds or {}).get(n, (-jnp.inf, jnp.inf))[1] for n in names], jnp.float64)
    for i, n in enumerate(names):
        if not float(lo[i]) <= float(x0[i]) <= float(hi[i]):
            raise ValueError(f"Initial {n} = {float(x0[i]):.6g} lies outside its bounds.")

    @eqx.filter_jit
    def value_and_grad(x):
        return jax.value_and_grad(lambda x_: loss(_set(model, names, x_ * scales)))(x)

    @eqx.filter_jit
    def update(x, grad, state):
        updates, state = optimizer.update(grad, state, x)
        x = optax.apply_updates(x, updates)
        return jnp.clip(x, lo / scales, hi / scales), state

    x = x0 / scales
    state = optimizer.init(x)
    losses, iterates = [], []
    for step in range(steps + 1):
        value, grad = value_and_grad(x)
        if not bool(jnp.isfinite(value)) or not bool(jnp.all(jnp.isfinite(grad))):
            raise FloatingPointError(
                f"tune: the loss or its gradient is not finite at step {step} "
                f"({dict(zip(names, np.asarray(x * scales).tolist()))}); check the loss, the "
                "bounds, and use the smooth ball force for gradients."
            )
        losses.append(float(value))
        iterates.append(np.asarray(x * scales))
        if callback is not None:
            callback(step, float(value), dict(zip(names, iterates[-1].tolist())))
        if step < steps:
            x, state = update(x, grad, state)
    best = int(np.argmin(losses))
    values = dict(zip(names, iterates[best].tolist()))
    history = np.stack(iterates)
    return TuneResult(
        model=_set(model, names, jnp.asarray(iterates[best])),
        values=values,
        loss=jnp.asarray(losses[best]),
        history_loss=np.asarray(losses),
        history_values={n: history[:, i] for i, n in enumerate(names)},
    )

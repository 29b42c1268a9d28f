"""Gradients of metrics through the whole simulation, and tuning of parameters with optax.

No physics here: a loss is any function ``loss(model) -> scalar`` (it simulates and measures),
parameters are named by dotted paths (`jaxbearing.paths`).

Which differentiation mode (``mode="auto"``, the default of `sensitivity` and `tune`):

- forward mode (a batch of `jax.jvp`s over the unit vectors, as `jax.jacfwd` takes them, with
  ``adjoint=diffrax.ForwardMode()`` in `simulate`) costs a forward solve plus a tangent per
  parameter and works under `jax.vmap`: "auto" takes it for up to `FORWARD_MAX_PARAMETERS`
  parameters, the handful of a bearing's design (clearance, restitution, stiffness, damping).
  `tune` runs the loss inside `default_adjoint(diffrax.ForwardMode())`, so a loss that calls
  `simulate` with its defaults needs no change.
- reverse mode (`jax.grad` with the default `RecursiveCheckpointAdjoint`) costs a fixed multiple
  of a forward run whatever the number of parameters: "auto" takes it for more. docs/performance.md
  gives both costs; ``mode="forward"`` or ``"reverse"`` overrides the choice.

Both ball forces give derivatives of the computed solution that are exact to the solver's
tolerance: the paper force's switches are located as events, whose implicit time derivatives
supply the jump terms (docs/model.md, 'Paper force: switched damping'). The paper force's metrics
are rougher functions of the parameters, though: a ball that barely grazes the race switches its
damping on with a jump, so a metric can bend sharply within a few tens of nanometres of clearance.
For optimisation prefer the smooth force and smooth metrics (`metrics.SMOOTH`); the exact peaks
jump when another sample takes the maximum.

Tolerances: the derivative of an adaptive solve is the derivative of the steps it took, which
the step control does not bound, and it converges more slowly than the solution: at simulate's
default tolerances the derivatives of the standard metrics are off by several per cent, at
`DERIVATIVE_RTOL` within 2 % of converged on the paper's case and the four-bar
(docs/gradients.md has the measured table). `sensitivity` simulates at `derivative_controller()`
unless given a ``stepsize_controller``; `tune` differentiates whatever the loss simulates, so a
loss should pass it itself.
"""

from __future__ import annotations

import warnings
from collections.abc import Callable, Mapping, Sequence

import diffrax
import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import optax

from . import _checks, paths as _paths
from .metrics import AbstractMetric, as_metric, solve_options
from .solution import RESULTS, SimulationError
from .simulation import default_adjoint, default_controller, simulate

DERIVATIVE_RTOL = 1e-11  # derivatives of the standard metrics within 2 % (docs/gradients.md)
DERIVATIVE_ATOL = DERIVATIVE_RTOL / 100  # [m, rad, m/s], in simulate's default ratio to rtol
LOSS_JUMP = 10.0  # `tune` warns when the loss rises above this factor of the previous one
FORWARD_MAX_PARAMETERS = 4  # "auto" differentiates in forward mode up to this many parameters
MODES = ("auto", "forward", "reverse")


def derivative_controller() -> diffrax.PIDController:
    """``default_controller(DERIVATIVE_RTOL, DERIVATIVE_ATOL)``: the step-size control at which
    derivatives of the standard metrics are within 2 % of their converged values on the paper's
    case and the four-bar (docs/gradients.md has the measurements). The step control bounds the
    error of the states, not of their derivatives, which converge more slowly. It takes several
    times the steps of simulate's default. `sensitivity` uses it by default; pass it to
    `simulate` in a `tune` loss."""
    return default_controller(rtol=DERIVATIVE_RTOL, atol=DERIVATIVE_ATOL)


def derivative_mode(mode: str, n_parameters: int) -> str:
    """``"forward"`` or ``"reverse"``: ``mode`` itself, or for ``"auto"`` forward mode up to
    `FORWARD_MAX_PARAMETERS` parameters and reverse mode beyond; a `ValueError` naming the
    allowed modes for anything else."""
    if not isinstance(mode, str) or mode not in MODES:
        raise ValueError(f"mode must be one of {', '.join(map(repr, MODES))}; got {mode!r}.")
    if mode != "auto":
        return mode
    return "forward" if n_parameters <= FORWARD_MAX_PARAMETERS else "reverse"


def _forward(f, x, has_aux=False):
    """``f(x)`` and its gradient (with ``f``'s aux where ``has_aux``) by forward mode: every
    tangent through one solve, a batch of `jax.jvp`s over the unit vectors as `jax.jacfwd`
    takes them; the value and the aux do not depend on the tangent. ``x``: (n,)."""
    tangent = lambda v: jax.jvp(f, (x,), (v,), has_aux=has_aux)  # noqa: E731
    axes = (None, 0, None) if has_aux else (None, 0)
    return jax.vmap(tangent, out_axes=axes)(jnp.eye(x.shape[0], dtype=x.dtype))


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
    metric: AbstractMetric | Callable,
    names: Sequence[str],
    t1: float,
    ts=None,
    *,
    mode: str = "auto",
    **simulate_kwargs,
):
    """d metric / d parameter for each named parameter, through the whole simulation.

    Args:
        model: the model at the design point.
        metric: a `metrics.AbstractMetric` (e.g. `metrics.rms_bearing_force`,
            ``metrics.peak_ball_load.replace(bearing=1)``, `metrics.Peak`, `life.metric()`),
            computed as ``metric.value(sol, model)`` with the model at the perturbed
            parameters, its records declared and its window edges made stops
            (`metrics.solve_options`); or a function of a `Solution` returning a scalar.
        names: parameter paths, e.g. ``["bearing.clearance", "impact.restitution"]``.
        t1, ts, **simulate_kwargs: passed to `simulate` (not ``throw``: a failure raises
            here, after the compiled call). Without a ``stepsize_controller`` (or with None) it
            simulates at `derivative_controller()`, not at simulate's default: the derivative
            of the discrete solve converges more slowly than the solution (docs/gradients.md).
            A ``stepsize_controller`` you pass wins.
        mode: ``"auto"`` (forward mode up to `FORWARD_MAX_PARAMETERS` names, else reverse),
            ``"forward"`` (a batch of `jax.jvp`s, `diffrax.ForwardMode`) or ``"reverse"``
            (`jax.grad`).

    Returns:
        ``(value, {name: derivative})`` in the metric's units per parameter unit.

    Raises the simulation's own error (`SimulationError`, or a `ValueError` naming a broken
    rule or the metric's window) when the solve fails or the value or a derivative is not
    finite. The compiled derivative carries no host callback, so JAX's persistent compilation
    cache keeps it for the next process.
    """
    if "throw" in simulate_kwargs:
        raise TypeError("sensitivity takes no throw: a failure raises after the compiled call.")
    if simulate_kwargs.get("stepsize_controller") is None:
        simulate_kwargs = {**simulate_kwargs, "stepsize_controller": derivative_controller()}
    names = tuple(names) if not isinstance(names, str) else names
    metric = as_metric(metric)
    options = solve_options(simulate_kwargs.get("options"), (metric,), t1, model.window_start)
    simulate_kwargs = {**simulate_kwargs, "options": options}
    x = _values(model, names, "to be differentiated")
    mode = derivative_mode(mode, x.shape[0])
    value, grad, failed = _value_and_grad(model, x, metric, names, t1, ts, mode, simulate_kwargs)
    finite = np.all(np.isfinite(np.asarray(value))) and np.all(np.isfinite(np.asarray(grad)))
    if bool(failed) or not finite:
        _raise_cause(model, metric, t1, ts, simulate_kwargs)
    return value, {n: grad[i] for i, n in enumerate(names)}


def _raise_cause(model, metric, t1, ts, simulate_kwargs):
    """The error of a failed `sensitivity`: the simulation's or the metric's own, found by
    running them on the host at the design point; else a `ValueError` saying what was not
    finite."""
    value = np.asarray(metric.value(simulate(model, t1, ts, **simulate_kwargs), model))
    raise ValueError(
        f"the derivatives of the metric at this design point are not finite (the metric is "
        f"{value}): a parameter may sit where the metric does not depend smoothly on "
        "it (an exact peak that changes hands, a contact that just touches)."
    )


@eqx.filter_jit
def _value_and_grad(model, x, metric, names, t1, ts, mode, simulate_kwargs):
    """Compiled once per metric, parameter names and settings: later calls at other designs
    (arrays of the same shapes) reuse it."""
    adjoint = diffrax.ForwardMode() if mode == "forward" else None

    def f(values):  # (metric, whether the solve failed): failures are raised on the host
        at = _set(model, names, values)
        sol = simulate(at, t1, ts, adjoint=adjoint, throw=False, **simulate_kwargs)
        return metric.value(sol, at), sol.result != RESULTS.successful

    if mode == "reverse":
        (value, failed), grad = jax.value_and_grad(f, has_aux=True)(x)
        return value, grad, failed

    return _forward(f, x, has_aux=True)  # (value, derivative, failed)


class TuneWarning(UserWarning):
    """What `tune` noticed on its way: an invalid iterate, a loss that jumps, a gradient that is
    zero (`TuneResult.notes` keeps the messages)."""


# what an iterate's failed simulation raises under tune's jit: a broken rule or a solver failure
# (`eqx.error_if` at run time), or a failure outside any transformation
_FAILURES = tuple(
    c
    for c in (SimulationError, getattr(eqx, "EquinoxRuntimeError", None),
              getattr(jax.errors, "JaxRuntimeError", None))
    if c is not None
)


class TuneResult(eqx.Module):
    """Outcome of `tune`.

    Fields:
        model: the model at the best valid parameters found.
        values: {name: best value}.
        loss: the best loss (of a valid iterate: never NaN).
        history_loss: loss at each iterate evaluated, (steps + 1,) unless `tune` stopped at an
            invalid iterate: then the last, its loss NaN.
        history_values: {name: values at each iterate evaluated}, as ``history_loss``.
        invalid_steps: steps whose iterate was invalid (its simulation failed, or its loss or
            gradient was not finite); `tune` stops at the first, so at most one.
        notes: the messages of the `TuneWarning`s `tune` gave (invalid iterate, loss jumps,
            zero gradient), in that order.
    """

    model: object
    values: dict
    loss: jax.Array
    history_loss: np.ndarray
    history_values: dict
    invalid_steps: tuple = ()
    notes: tuple = ()


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
    mode: str = "auto",
) -> TuneResult:
    """Minimise ``loss(model)`` over the named parameters with an optax optimiser.

    The optimiser works on scaled variables x = value / scale (scale defaults to |initial value|)
    so that parameters of different units (a clearance of 4e-5 m, a restitution of 0.9) move at
    comparable rates; after each update the values are projected onto ``bounds``.

    Tolerances: `tune` follows the gradient of the loss as the loss computes it, at whatever
    tolerance its `simulate` runs; at simulate's default the derivatives of the standard metrics
    are off by several per cent (the derivative of the discrete solve converges more slowly than
    the solution). For gradients within 2 % (docs/gradients.md) simulate in the loss at
    ``stepsize_controller=derivative_controller()`` (`DERIVATIVE_RTOL`), several times the
    steps.

    Valid iterates only: an iterate whose evaluation fails (a parameter value the model's rules
    refuse, such as a clearance above a tenth of the ball diameter; a solver failure; a loss or
    gradient that is not finite) is invalid. Its gradient cannot be followed, so `tune` stops
    there, warns (`TuneWarning`, naming the step, the values and the cause) and returns the best
    valid iterate; ``invalid_steps`` names it. An invalid starting point raises. `tune` also
    warns, once each after the run, when the loss rises from one step to the next above
    `LOSS_JUMP` (10) times the previous one (by more than 9 times its magnitude, for a loss of
    either sign: the optimiser overshot), and when the loss is 0 or its gradient exactly zero at
    an iterate (no contact or no load in the window: the optimiser gets no direction there).

    Args:
        loss: function of a model returning a scalar (it simulates and measures).
        model: the starting model.
        names: parameter paths to tune.
        optimizer: an optax `GradientTransformation` (e.g. ``optax.adam(0.05)``).
        steps: number of gradient steps.
        bounds: {name: (low, high)} in parameter units.
        scale: {name: scale} in parameter units.
        callback: called as ``callback(step, loss, {name: value})`` after each evaluation (the
            loss NaN for an invalid iterate).
        mode: how the gradient is taken: ``"auto"`` (forward mode up to
            `FORWARD_MAX_PARAMETERS` names, else reverse), ``"forward"`` (a batch of `jax.jvp`s;
            the loss runs inside ``default_adjoint(diffrax.ForwardMode())``, so its `simulate`
            calls without an ``adjoint`` differentiate forward) or ``"reverse"`` (`jax.grad`).
            A loss that passes its own ``adjoint`` to `simulate` needs the matching mode.
    """
    names = list(names) if not isinstance(names, str) else names
    if steps < 1:
        raise ValueError(f"steps must be at least 1; got {steps}.")
    x0 = _values(model, names, "to be tuned")
    mode = derivative_mode(mode, x0.shape[0])
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

    def scaled_loss(x):
        return loss(_set(model, names, x * scales))

    @eqx.filter_jit
    def value_and_grad(x):
        if mode == "reverse":
            return jax.value_and_grad(scaled_loss)(x)
        with default_adjoint(diffrax.ForwardMode()):  # while the loss is traced
            return _forward(scaled_loss, x)

    @eqx.filter_jit
    def update(x, grad, state):
        updates, state = optimizer.update(grad, state, x)
        x = optax.apply_updates(x, updates)
        return jnp.clip(x, lo / scales, hi / scales), state

    x = x0 / scales
    state = optimizer.init(x)
    losses, iterates, invalid, flat, jumps = [], [], [], [], []
    cause = None
    for step in range(steps + 1):
        iterates.append(np.asarray(x * scales))
        here = dict(zip(names, iterates[-1].tolist()))
        try:
            value, grad = value_and_grad(x)
            if not bool(jnp.isfinite(value)) or not bool(jnp.all(jnp.isfinite(grad))):
                cause = "the loss or its gradient is not finite"
        except _FAILURES as error:
            if step == 0:
                raise  # the starting point itself: nothing valid to return
            value, cause = jnp.nan, f"its evaluation failed ({_first_line(error)})"
        if cause is not None and step == 0:
            raise FloatingPointError(
                f"tune: the loss or its gradient is not finite at step 0 ({here}); check the loss "
                "and use the smooth ball force for gradients."
            )
        losses.append(float(value) if cause is None else float("nan"))
        if callback is not None:
            callback(step, losses[-1], here)
        if cause is not None:
            invalid.append(step)
            break
        if losses[-1] == 0.0 or not bool(jnp.any(grad != 0)):
            flat.append(step)
        if step > 0 and losses[-2] != 0.0 and losses[-1] - losses[-2] > (LOSS_JUMP - 1.0) * abs(losses[-2]):
            jumps.append(step)
        if step < steps:
            x, state = update(x, grad, state)
    best = int(np.nanargmin(losses))  # invalid iterates have NaN losses; step 0 is valid
    values = dict(zip(names, iterates[best].tolist()))
    notes = _notes(names, losses, iterates, best, invalid, jumps, flat, cause)
    for note in notes:
        warnings.warn(note, TuneWarning, stacklevel=2)
    history = np.stack(iterates)
    return TuneResult(
        model=_set(model, names, jnp.asarray(iterates[best])),
        values=values,
        loss=jnp.asarray(losses[best]),
        history_loss=np.asarray(losses),
        history_values={n: history[:, i] for i, n in enumerate(names)},
        invalid_steps=tuple(invalid),
        notes=tuple(notes),
    )


def _first_line(error: BaseException) -> str:
    """The message of ``error`` in one line: for an `eqx.error_if` under jit the message itself,
    which its text wraps in stack traces and paragraphs on debugging; else its first line."""
    lines = [line.strip() for line in str(error).splitlines() if line.strip()]
    raised = [line.split("RuntimeError: ", 1)[1] for line in lines if "EquinoxRuntimeError: " in line]
    return (raised or lines or [type(error).__name__])[0]


def _steps(steps: list[int]) -> str:
    """``steps`` written out, the first ten of them."""
    shown = ", ".join(str(k) for k in steps[:10])
    return f"{shown}, ... ({len(steps)} in all)" if len(steps) > 10 else shown


def _notes(names, losses, iterates, best, invalid, jumps, flat, cause) -> list[str]:
    """The messages of `tune`'s warnings: invalid iterate, loss jumps, zero gradient."""
    def at(k):
        return dict(zip(names, iterates[k].tolist()))

    kept = f"returns the best valid iterate, step {best} (loss {losses[best]:.6g}, {at(best)})"
    notes = []
    for k in invalid:
        notes.append(
            f"tune: the iterate of step {k} ({at(k)}) is not valid: {cause}. tune stopped there (its "
            f"gradient cannot be followed) and {kept}. Bounds on the parameters, a smaller learning "
            "rate or a scale keep the iterates valid."
        )
    if jumps:
        k = jumps[0]
        notes.append(
            f"tune: the loss jumped above {LOSS_JUMP:g} times the previous step's at step "
            f"{_steps(jumps)} (at step {k} from {losses[k - 1]:.6g} to {losses[k]:.6g}, {at(k)}): "
            f"the optimiser overshot; a smaller learning rate, bounds or a scale keep it near. "
            f"tune {kept}."
        )
    if flat:
        k = flat[0]
        notes.append(
            f"tune: the gradient is zero (or the loss 0) at step {_steps(flat)} (at step {k} loss "
            f"{losses[k]:.6g}, {at(k)}): no contact/no load in the window? The optimiser gets no "
            "direction there; "
            "check that the objective's contact exists at these values (a clearance too large to "
            "touch?), the metric's window, or bound the parameters."
            + (f" The best iterate, step {best}, is one of them." if best in flat else "")
        )
    return notes

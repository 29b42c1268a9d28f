"""What `jaxbearing.simulate` returns, and what the metrics and the life read from it: the
`Solution`, which mirrors the model's force elements (``sol.elements[i]``: each element's
quantities at the output times and its exact records), with the views ``sol.bearings`` and
``sol.contacts``; the result codes (`RESULTS`, `SimulationError`) and the error a result code
stands for (`raise_on_failure`). `jaxbearing.recorder` makes the `Solution` of the solve's
records; `jaxbearing.metrics` and `jaxbearing.life` read it without the model's classes.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from typing import NamedTuple

import equinox as eqx
import jax
import jax.numpy as jnp

from . import _checks
from ._checks import is_concrete
from .multibody.forces import (  # the bearing joint's records that the lives read
    FAT_ELEMENT_POWER,
    FAT_ELEMENT_SLOPE_POWER,
    FAT_FORCE_POWER,
    FAT_REVOLUTIONS,
    FAT_TIME,
    FORCE_SCALE,
    POWER,
    RING_POINTS_PER_BALL,
)
from .solve import RESULTS


__all__ = [
    "FAT_ELEMENT_POWER",
    "FAT_ELEMENT_SLOPE_POWER",
    "FAT_FORCE_POWER",
    "FAT_REVOLUTIONS",
    "FAT_TIME",
    "FORCE_SCALE",
    "POWER",
    "RESULTS",
    "RING_POINTS_PER_BALL",
]


EDGE_TOLERANCE = 1e-12  # [s] a window edge this close to an interval end counts as that end


class SimulationError(RuntimeError):
    """A solve failed: the message says when (simulated time) and what to change."""


class AccuracyWarning(UserWarning):
    """A run whose numbers may not be results: the base of `DriftWarning`,
    `ToleranceWarning` and `RattleWarning`, so that one filter takes them all
    (``warnings.simplefilter("error", jaxbearing.solution.AccuracyWarning)``)."""


class DriftWarning(AccuracyWarning):
    """A run's joints drifted further than `Mechanism.drift_bound`: its forces are not trusted."""


class ToleranceWarning(AccuracyWarning):
    """A run's step-size control is looser than the tolerances at which the metrics were found
    converged (docs/simulate.md, 'Trusting a run')."""


class RattleWarning(AccuracyWarning):
    """A bearing joint carried no load for most of the metrics' window after the model's
    start-up transient: its journal rattles in the clearance, a chaotic motion whose peaks and
    means move with the tolerance (docs/simulate.md, 'Trusting a run')."""


class Layout(NamedTuple):
    """What a `Solution` knows of its model's force elements (static): each element's name
    (None: unnamed) and class name, in ``model.forces`` order; the indices of the bearing
    joints, of the impact contacts and of the elements with episodes; for each contact, the
    index in q of the x coordinate of its body k (the body its normal force pushes along +n)."""

    names: tuple = ()
    kinds: tuple = ()
    bearings: tuple = ()
    contacts: tuple = ()
    episodic: tuple = ()
    targets: tuple = ()

    def index(self, key) -> int:
        """The element index of ``key``: an index into the elements or a name."""
        if isinstance(key, str):
            if key not in self.names:
                named = [n for n in self.names if n is not None]
                raise ValueError(
                    f"No force element named {key!r}; the named ones: {named or 'none'} (name "
                    "them by passing Mechanism(forces=...) a mapping, name -> element)."
                )
            return self.names.index(key)
        count = len(self.kinds)
        if isinstance(key, bool) or not isinstance(key, int) or not -count <= key < count:
            raise IndexError(
                f"This model has {count} force elements: an element is an index from 0 to "
                f"{count - 1} or a name; got {key!r}."
            )
        return key % count


class Intervals(eqx.Module):
    """The intervals between the solve's stops (t0, the model's ``window_start``, the window
    edges asked for, t1), over which every record is kept (C of them): ``t_start``, ``t_end``
    (C,) [s], up to where the solve reached; ``duration`` (C,) [s], the solved time in each;
    ``valid`` (C,) bool, True where the interval holds part of the solved span."""

    t_start: jax.Array
    t_end: jax.Array
    duration: jax.Array
    valid: jax.Array


class ElementRecords(eqx.Module):
    """One force element's exact records, per interval between the solve's stops
    (`Intervals`), taken from the solution itself: every accepted solver step and its
    interpolant, not the output times.

    Each step contributes the values at its end and at its 3 Gauss–Legendre points, and their
    Gauss–Legendre quadrature over the step; a step across an event counts only up to the
    event. Peaks are maxima of the interpolant: where a step may rise above the interval's peak
    so far between those 4 points, each value is also taken at the vertex of the parabola
    through the 3 points around its largest, which is the step's maximum to the parabola's
    third-order error. Integrals are exact for integrands that are polynomials of degree <= 5
    over each step.

    Fields (keyed by the element's declared names, `AbstractForceElement.peak_records` and
    ``integral_records``):
        peaks: name -> (C,), the maxima over each interval (0 where not reached).
        peak_times: name -> (C,) [s], the earliest recorded point that attains each (NaN where
            not reached).
        at_peak: peak name -> (C, ...), the peak's carried array as it was then (0 where not
            reached).
        integrals: name -> (C, ...), the integrals over each interval.
        powers: ((name, power, scale), ...) of the power integrals (static):
            scale (integral / duration)^(1/power) is the power mean.
    """

    peaks: dict
    peak_times: dict
    at_peak: dict
    integrals: dict
    powers: tuple = eqx.field(static=True, default=())

    def power(self, name: str) -> tuple[float, float]:
        """(power, scale) of the power integral ``name``; a ValueError where it is none."""
        for n, power, scale in self.powers:
            if n == name:
                return power, scale
        raise ValueError(
            f"{name!r} is not a power integral of this element; its power integrals: "
            f"{[n for n, _, _ in self.powers] or 'none'}."
        )


class Episodes(eqx.Module):
    """Episodes of the elements that have them (a contact's contacts), one slot per onset
    (``max_onsets`` of `SolveOptions`, padded; read ``valid``), in time order. Onsets and ends
    are the solve's events, located to 1e-13 s, and the peak is the maximum of the solution
    over the episode's steps and their interpolants, so none depends on the output times.

    Fields (each (max_onsets,)):
        time: onset times [s], NaN in unused slots.
        value: the value the element logs at the onset (a contact's approach speed [m/s]).
        element: which element (index into ``model.forces``), -1 in unused slots.
        valid: True where the slot holds an onset.
        end: when the episode ended [s] (NaN where it lasted to the time reached).
        peak: the largest value of the element's episode peak record over it.
        peak_time: when the solution attains it [s] (the earliest recorded point).
    """

    time: jax.Array
    value: jax.Array
    element: jax.Array
    valid: jax.Array
    end: jax.Array
    peak: jax.Array
    peak_time: jax.Array


class Contacts(eqx.Module):
    """Impact contacts, each from its onset to its end, one slot per onset (``max_onsets`` of
    `SolveOptions`, padded; read ``valid``): the `Episodes` of the `CircleContact` elements.

    Fields (each (max_onsets,)):
        time: onset times [s], NaN in unused slots.
        approach_speed: penetration rate at onset, delta_dot^(-) of Eq. 23 [m/s].
        index: which contact of ``model.contacts`` started, -1 in unused slots.
        valid: True where the slot holds an onset.
        end: when that contact ended [s]: its separation event, where the penetration has
            fallen to -1 nm (`multibody.forces.SEPARATION_OFFSET`: the force vanished 1 nm /
            separation speed before); NaN where it lasted to the time reached, and in unused
            slots.
        peak_force: the largest normal force over the contact [N], up to its end or the time
            reached.
        peak_time: when the solution attains it [s] (the earliest recorded point).
    """

    time: jax.Array
    approach_speed: jax.Array
    index: jax.Array
    valid: jax.Array
    end: jax.Array
    peak_force: jax.Array
    peak_time: jax.Array

    @property
    def count(self) -> jax.Array:
        """Number of contact onsets."""
        return jnp.sum(self.valid, axis=-1)


class FatigueStats(eqx.Module):
    """What a bearing's fatigue life (`jaxbearing.life`) reads, per interval between the
    solve's stops: the bearing joint's fatigue integral records (`multibody.BearingJoint.
    integrands`) with the intervals' times (`BearingResult.fatigue`).

    Every integrand is weighted by the relative revolutions the rings turn, w = |omega_inner -
    omega_outer| / (2 pi) [rev/s]. Loads Q are divided by `FORCE_SCALE` before their powers. The
    element powers are the bearing's raceway load–life exponent m (``raceway_exponent``: 3 for
    balls, 4 for rollers) and m e with its Weibull slope e (``weibull_slope``: m e = 10/3 for
    balls, 9/2 for rollers).

    Fields (C = number of stops):
        t_start, t_end: (C,) [s] of each interval, up to where the solve reached.
        integrals: (C, 5), the integrals over the interval of: 1 (its duration) [s], w [rev],
            w (|F| / FORCE_SCALE)^p (F the resultant, Eq. 28; p the bearing's
            ``life_exponent``, 3 for balls, 10/3 for rollers), w mean over the elements of
            (Q_r / FORCE_SCALE)^m, and of (Q_r / FORCE_SCALE)^(m e). Columns ``FAT_*``.
        inner, outer: (C, M), w (Q_k / FORCE_SCALE)^m integrated for each of M =
            `RING_POINTS_PER_BALL` x N_b points fixed in the inner and the outer ring, point k
            at 2 pi k / M in its ring body's frame (`BearingJoint.ring_point_loads`).
        valid: (C,) bool, True where the interval holds part of the solved span.
    """

    t_start: jax.Array
    t_end: jax.Array
    integrals: jax.Array
    inner: jax.Array
    outer: jax.Array
    valid: jax.Array


class BearingInstant(eqx.Module):
    """One bearing joint at one instant (`Instant.bearings`): ``ball_loads`` (N_b,) [N], ball 1
    first; ``force`` (2,) [N], the resultant on its outer-race body (Eq. 28); ``cage_angle``
    [rad]."""

    ball_loads: jax.Array
    force: jax.Array
    cage_angle: jax.Array


class ContactInstant(eqx.Module):
    """One impact contact at one instant (`Instant.contacts`): its normal ``force`` [N] and
    ``penetration`` [m] (negative when apart)."""

    force: jax.Array
    penetration: jax.Array


class Instant(eqx.Module):
    """The solution at one instant, as the solve computed it (what a metric of your own reads,
    `metrics.Peak`, `metrics.Mean`): time ``t`` [s], coordinates ``q`` and velocities ``qd``
    (n_coordinates,), and each force element's quantities there (``elements[i]``, a dict
    name -> array as the element's `observe` names them; ``element(key)`` by index or name),
    with the solve's discrete states in force. Views: ``bearings`` (a `BearingInstant` per
    bearing joint, model order) and ``contacts`` (a `ContactInstant` per impact contact)."""

    t: jax.Array
    q: jax.Array
    qd: jax.Array
    elements: tuple
    layout: Layout = eqx.field(static=True)

    def element(self, key) -> dict:
        """The quantities of the element ``key`` (an index into ``model.forces`` or a name)."""
        return self.elements[self.layout.index(key)]

    @property
    def bearings(self) -> tuple:
        return tuple(
            BearingInstant(e["element_loads"], e["force"], e["cage_angle"])
            for e in (self.elements[i] for i in self.layout.bearings)
        )

    @property
    def contacts(self) -> tuple:
        return tuple(
            ContactInstant(e["normal_force"], e["penetration"])
            for e in (self.elements[i] for i in self.layout.contacts)
        )


class AbstractRecord(eqx.Module):
    """A quantity of your own that the solve records from every accepted step (`metrics.Peak`,
    `metrics.Mean`): ``fn(model, x) -> scalar`` with ``x`` an `Instant`, over the window
    from ``t_min`` to ``t_max`` [s] (None: the model's ``window_start``, or t0 without one; t1),
    whose edges the solve stops at. ``reduction`` is "peak" (its exact maximum is recorded per
    interval) or "mean" (its integral)."""

    fn: Callable = eqx.field(static=True)
    t_min: float | None = eqx.field(static=True)
    t_max: float | None = eqx.field(static=True)
    reduction: eqx.AbstractClassVar[str]

    def at(self, model, x: Instant) -> jax.Array:
        """``fn(model, x)`` at one instant, a float64 scalar; a ValueError where it is not a
        scalar."""
        v = jnp.asarray(self.fn(model, x), jnp.float64)
        if v.shape != ():
            raise ValueError(
                f"A record's fn(model, x) must return a scalar; {self.fn!r} returned shape {v.shape}."
            )
        return v

    def edges(self) -> tuple:
        """The window edges [s] the solve stops at for this record."""
        return tuple(float(t) for t in (self.t_min, self.t_max) if t is not None)


class ElementResult(eqx.Module):
    """What a solve gives of one force element (`Solution.elements`): its ``samples``, name ->
    (T, ...) at the output times (NaN at the times a failed run did not reach), and its exact
    ``records`` (`ElementRecords`); its ``name`` (None: unnamed) and ``kind`` (class name)."""

    samples: dict
    records: ElementRecords
    name: str | None = eqx.field(static=True)
    kind: str = eqx.field(static=True)


class Elements(eqx.Module):
    """The `ElementResult` of every force element, in ``model.forces`` order: indexed by
    position or by name (``sol.elements["crank bearing"]``), iterable, sized."""

    results: tuple
    layout: Layout = eqx.field(static=True)

    def __getitem__(self, key) -> ElementResult:
        return self.results[self.layout.index(key)]

    def __iter__(self):
        return iter(self.results)

    def __len__(self) -> int:
        return len(self.results)


class BearingResult(eqx.Module):
    """What a solve gives of one bearing joint (`Solution.bearings`, in model order): its
    samples ``ball_loads`` (T, N_b) [N] (ball 1 first; "ball" names a rolling element of any
    kind), ``force`` (T, 2) [N] (the resultant on its outer-race body, Eq. 28), ``cage_angle``
    (T,) [rad], its exact ``records`` (`ElementRecords`) and its ``fatigue`` (`FatigueStats`,
    what its life reads; None where not recorded: ``SolveOptions(fatigue=False)``)."""

    ball_loads: jax.Array
    force: jax.Array
    cage_angle: jax.Array
    records: ElementRecords
    fatigue: FatigueStats | None


class Samples(eqx.Module):
    """What the solve evaluated at the output times (`Solution.samples`). Fields (T = number
    of output times; NaN at the times a run that failed did not reach):

        q, qd: (T, n_coordinates) coordinates [m, rad] and velocities; bodies in model order,
            [x, y, theta] each.
        drift: (T,) max |Phi(q, t)| [m or rad], the constraint violation.
        elements: one dict per force element (``model.forces`` order), name -> (T, ...), of
            the quantities its `observe` names.
        states: the force elements' discrete states in force at each output time (one pytree
            per element, each leaf (T, ...); zero at the times not reached), which
            `Solution.qdd` reads.
        model: the simulated model (None: samples without one, whose `Solution.qdd` raises).
    """

    q: jax.Array
    qd: jax.Array
    drift: jax.Array
    elements: tuple
    states: tuple = ()
    model: object = None


def _accelerations_at(model, ts, q, qd, states):
    """q_ddot (..., T, n) [m/s^2, rad/s^2] from Eq. 36 at each output time (ts (..., T)), with
    the discrete states in force there; NaN where q or qd is not finite. Leading axes: a
    batch (`jax.vmap` of `simulate`), whose model leaves carry them too."""

    def one(model, t, q, qd, states):
        ok = jnp.all(jnp.isfinite(q)) & jnp.all(jnp.isfinite(qd))
        safe_q, safe_qd = jnp.where(ok, q, model.q0), jnp.where(ok, qd, model.qd0)
        return jnp.where(ok, model.accelerations(t, safe_q, safe_qd, states, sparse=True), jnp.nan)

    each = eqx.filter_vmap(one, in_axes=(None, 0, 0, 0, 0))
    for _ in range(jnp.ndim(ts) - 1):
        each = eqx.filter_vmap(each)
    return each(model, ts, q, qd, states)


_accelerations_program = eqx.filter_jit(_accelerations_at)


class Records(eqx.Module):
    """What the solve recorded from every accepted step and its interpolant, whatever the
    output times (`Solution.records`), and, read as a mapping (``sol.records[name]``), the value
    of each metric of your own declared for the solve (``SolveOptions(records=...)``:
    `metrics.Peak`, `metrics.Mean`) over its window.

    Fields:
        intervals: `Intervals`, the intervals between the stops every record is kept over.
        elements: one `ElementRecords` per force element, ``model.forces`` order.
        displacement: (C, n_coordinates), the maxima of |q_c - q0_c| [m or rad] per interval
            (0 where not reached); ``displacement_times`` (C, n_coordinates) [s] when.
        own: `ElementRecords` of the metrics of your own, by their names.
        episodes: `Episodes`, the episodes of the elements that have them.
        contacts: `Contacts`, the episodes of the impact contacts (`CircleContact`).
        max_drift: the largest constraint violation max |Phi(q, t)| [m or rad] at the end of
            every accepted step (0 without joints); `simulate` warns where it exceeds the
            model's `Mechanism.drift_bound`.
        values: name -> value of each metric of your own.
        declared: the ((name, record), ...) the solve recorded (static).
    """

    intervals: Intervals
    elements: tuple
    displacement: jax.Array
    displacement_times: jax.Array
    own: ElementRecords
    episodes: Episodes
    contacts: Contacts
    max_drift: jax.Array
    values: dict
    declared: tuple = eqx.field(static=True, default=())

    def __getitem__(self, name: str) -> jax.Array:
        if name not in self.values:
            raise KeyError(
                f"No record named {name!r}: the solve recorded {sorted(self.values)} (declare "
                "yours in SolveOptions(records={name: metric}))."
            )
        return self.values[name]

    def __iter__(self):
        return iter(self.values)

    def __len__(self) -> int:
        return len(self.values)

    def __contains__(self, name) -> bool:
        return name in self.values

    def keys(self):
        return self.values.keys()

    def items(self):
        return self.values.items()


class Indexed(tuple):
    """A tuple of a model's elements of one kind (`Solution.bearings`) whose IndexError names
    the count and the indices allowed, as ``bearing=`` of a metric does."""

    def __new__(cls, items, name: str, element: str):
        self = super().__new__(cls, items)
        self.name, self.element = name, element
        return self

    def __getnewargs__(self):  # copy and pickle
        return tuple(self), self.name, self.element

    def __getitem__(self, index):
        try:
            return super().__getitem__(index)
        except IndexError:
            n = len(self)
            if not n:
                raise IndexError(f"{self.name}[{index!r}]: this model has no {self.element}.") from None
            plural = f"{n} {self.element}{'s' if n != 1 else ''}"
            raise IndexError(
                f"{self.name}[{index!r}]: this model has {plural}; index them from 0 to {n - 1} "
                "(model order)."
            ) from None


jax.tree_util.register_pytree_node(
    Indexed, lambda e: (tuple(e), (e.name, e.element)), lambda aux, items: Indexed(items, *aux)
)  # a pytree like the tuple it is


class Solution(eqx.Module):
    """Result of `simulate`, as diffrax's: the output ``ts`` and what the solve evaluated there
    (``samples``), what it recorded of every accepted step (``records``), its solver statistics
    (``stats``) and ``result``. It mirrors the model's force elements: ``sol.elements[i]`` (or
    ``sol.elements[name]``) is element i's `ElementResult`, its quantities at the output times
    and its exact records.

    Fields:
        ts: (T,) the output times [s].
        samples: `Samples` at the output times (q, qd, drift, each element's quantities and
            states; ``sol.qdd`` evaluates the accelerations from them).
        records: `Records` (intervals, each element's records, displacement peaks, episodes,
            the max drift, and ``sol.records[name]`` of each metric of your own).
        stats: solver statistics: ``num_steps``, ``num_rejected_steps`` (over all segments),
            ``num_segments`` (segments of ``segment_steps`` iterations `simulate` used; 1 for
            `simulate_one_loop`), ``num_events`` (events located: contact onsets and
            separations, ball engagements and releases, each element's own).
        result: a `RESULTS` code (successful unless a segment failed).
        t_final: time reached [s] (t1 unless the solve failed).
        t1: the final time asked for [s]; a metric's window ends there by default, and one
            that ends after ``t_final`` has no value (`metrics.reached`).
        window_start: the model's ``window_start`` [s], where the metrics' and the life's
            default window starts; None: at the start of the solve.
        layout: the model's force elements as the solution knows them (`Layout`, static).

    Views: ``sol.bearings[i]`` (a `BearingResult`: a bearing joint's samples, records and
    fatigue), ``sol.contacts`` (`Contacts`), ``sol.contact_forces``, ``sol.penetrations``,
    ``sol.approach_speed`` ((T, K), the impact contacts'); each field of `Samples`, `Records`
    and ``stats`` is also read directly (``sol.q``, ``sol.max_drift``, ``sol.num_steps``, ...).
    A model with one bearing joint or one contact reads it by the short names ``ball_loads``,
    ``bearing_force``, ``cage_angle``, ``fatigue``, ``contact_force``, ``penetration`` and
    ``target``; on a model with several they raise a `ValueError` naming ``sol.bearings[i]``
    or ``sol.contact_forces[:, j]``.
    """

    ts: jax.Array
    samples: Samples
    records: Records
    stats: dict
    result: RESULTS
    t_final: jax.Array
    t1: jax.Array
    window_start: jax.Array | None = None
    layout: Layout = eqx.field(static=True, default=Layout())

    q = property(lambda self: self.samples.q, doc="(T, n_coordinates) [m, rad] (`Samples`).")
    qd = property(lambda self: self.samples.qd, doc="(T, n_coordinates) velocities (`Samples`).")
    @property
    def qdd(self) -> jax.Array:
        """(T, n_coordinates) accelerations [m/s^2, rad/s^2] at the output times: Eq. 36 at
        ``q``, ``qd`` with the force elements' discrete states in force there, evaluated when
        read (a program of its own, compiled at the first read of a model's, so that a solve
        whose accelerations nobody reads does not compile them); NaN where ``q`` is."""
        if self.samples.model is None:
            raise ValueError("These samples hold no model (Samples.model): their accelerations cannot be evaluated.")
        a = self.samples
        return _accelerations_program(a.model, self.ts, a.q, a.qd, a.states)

    drift = property(lambda self: self.samples.drift, doc="(T,) max |Phi| [m or rad] (`Samples`).")
    intervals = property(lambda self: self.records.intervals, doc="`Intervals` (`Records`).")
    episodes = property(lambda self: self.records.episodes, doc="`Episodes` (`Records`).")
    contacts = property(lambda self: self.records.contacts, doc="`Contacts` (`Records`).")
    max_drift = property(lambda self: self.records.max_drift, doc="max |Phi| over the run (`Records`).")
    declared = property(lambda self: self.records.declared, doc="((name, record), ...) (`Records`).")
    num_steps = property(lambda self: self.stats["num_steps"], doc="Solver steps (``stats``).")
    num_rejected_steps = property(lambda self: self.stats["num_rejected_steps"], doc="Rejected steps (``stats``).")
    num_segments = property(lambda self: self.stats["num_segments"], doc="Segments used (``stats``).")
    num_events = property(lambda self: self.stats["num_events"], doc="Events located (``stats``).")
    targets = property(lambda self: self.layout.targets, doc="Each contact's target x index in q.")

    @property
    def elements(self) -> Elements:
        """Each force element's `ElementResult`, by index or name (``model.forces`` order)."""
        results = tuple(
            ElementResult(samples, records, name, kind)
            for samples, records, name, kind in zip(
                self.samples.elements, self.records.elements, self.layout.names, self.layout.kinds
            )
        )
        return Elements(results, self.layout)

    @property
    def bearings(self) -> Indexed:
        """One `BearingResult` per bearing joint, model order: its samples, records and
        fatigue (an index the model does not have raises an IndexError naming the count)."""
        return Indexed((self._bearing(i) for i in self.layout.bearings), "sol.bearings", "bearing joint")

    def _bearing(self, i: int) -> BearingResult:
        samples, records = self.samples.elements[i], self.records.elements[i]
        return BearingResult(
            samples["element_loads"], samples["force"], samples["cage_angle"], records,
            _fatigue(self.records.intervals, records),
        )  # fmt: skip

    @property
    def n_bearings(self) -> int:
        """Bearing joints of the model (B)."""
        return len(self.layout.bearings)

    @property
    def n_contacts(self) -> int:
        """Impact contacts of the model (K)."""
        return len(self.layout.contacts)

    def _contact_samples(self, name: str) -> jax.Array:
        """(T, K) of the contacts' sample ``name``."""
        columns = [self.samples.elements[i][name] for i in self.layout.contacts]
        if not columns:
            return jnp.zeros(self.ts.shape + (0,), self.ts.dtype)
        return jnp.stack(columns, axis=-1)

    @property
    def contact_forces(self) -> jax.Array:
        """(T, K) [N], the normal force of each impact contact (``model.contacts`` order)."""
        return self._contact_samples("normal_force")

    @property
    def penetrations(self) -> jax.Array:
        """(T, K) [m], the penetration of each contact (negative when apart)."""
        return self._contact_samples("penetration")

    @property
    def approach_speed(self) -> jax.Array:
        """(T, K) [m/s], the approach speed in force at each output time."""
        return self._contact_samples("approach_speed")

    def _only_bearing(self):
        """The model's one bearing joint's `BearingResult` (None without); a ValueError with
        several."""
        if self.n_bearings > 1:
            raise ValueError(
                f"This model has {self.n_bearings} bearing joints: read each as "
                f"sol.bearings[i] (i from 0 to {self.n_bearings - 1}, model order), e.g. "
                "sol.bearings[1].ball_loads."
            )
        return self._bearing(self.layout.bearings[0]) if self.n_bearings else None

    def _only_contact(self, x):
        """Column 0 of ``x`` (T, K) for a model with one contact (zeros without); a ValueError
        with several."""
        if x.shape[-1] > 1:
            raise ValueError(
                f"This model has {x.shape[-1]} impact contacts: read each as a column of "
                "sol.contact_forces or sol.penetrations (model order)."
            )
        return x[..., 0] if x.shape[-1] else jnp.zeros(x.shape[:-1], x.dtype)

    @property
    def ball_loads(self) -> jax.Array | None:
        """(T, N_b) [N] of the model's only bearing joint (None without one)."""
        only = self._only_bearing()
        return None if only is None else only.ball_loads

    @property
    def bearing_force(self) -> jax.Array | None:
        """(T, 2) [N], the only bearing's resultant on its outer-race body (Eq. 28)."""
        only = self._only_bearing()
        return None if only is None else only.force

    @property
    def cage_angle(self) -> jax.Array | None:
        """(T,) [rad] of the only bearing's cage."""
        only = self._only_bearing()
        return None if only is None else only.cage_angle

    @property
    def fatigue(self) -> FatigueStats | None:
        """`FatigueStats` of the only bearing (None without one, or not recorded)."""
        only = self._only_bearing()
        return None if only is None else only.fatigue

    @property
    def contact_force(self) -> jax.Array:
        """(T,) [N], normal force of the model's only impact contact (zeros without)."""
        return self._only_contact(self.contact_forces)

    @property
    def penetration(self) -> jax.Array:
        """(T,) [m], penetration of the model's only impact contact (zeros without)."""
        return self._only_contact(self.penetrations)

    @property
    def target(self) -> int | None:
        """Index in q of the x coordinate of the only contact's body k (None without a
        contact)."""
        if len(self.targets) > 1:
            raise ValueError(
                f"This model has {len(self.targets)} impact contacts: their targets are "
                "sol.targets (model order)."
            )
        return self.targets[0] if self.targets else None


def _fatigue(intervals: Intervals, records: ElementRecords) -> FatigueStats | None:
    """A bearing joint's `FatigueStats` from its records (None where the fatigue integrals
    were not recorded)."""
    if records is None or "fatigue" not in records.integrals:
        return None
    i = records.integrals
    return FatigueStats(
        intervals.t_start, intervals.t_end, i["fatigue"], i["inner_ring_power"], i["outer_ring_power"],
        intervals.valid,
    )  # fmt: skip


def map_per_time(fn, sol: Solution, *more: Solution) -> Solution:
    """``sol`` with ``ts`` and each array of its `Samples` x (first axis: the output times)
    replaced by ``fn(x, *the same array of each of more)``."""
    ts = fn(sol.ts, *(m.ts for m in more))
    per_time = [f.name for f in dataclasses.fields(Samples) if f.name != "model"]  # all but the model
    rows = {
        name: jax.tree_util.tree_map(fn, getattr(sol.samples, name), *(getattr(m.samples, name) for m in more))
        for name in per_time
    }
    return dataclasses.replace(sol, ts=ts, samples=dataclasses.replace(sol.samples, **rows))


@eqx.filter_jit  # the model in the samples may hold non-array leaves
def first_rows(sol: Solution, n: int) -> Solution:
    """``sol`` with its per-time fields cut to the first ``n`` output times (a solve padded its
    output times to share a compiled solve)."""
    return map_per_time(lambda x: x[:n], sol)


def raise_on_failure(sol: Solution, t1, broken: _checks.Broken, root_steps: int) -> Solution:
    """``sol``, or the error its result code stands for: a `SimulationError` saying when and what
    to change (``root_steps``: the steps the solve's root finder has to locate an event); for
    `RESULTS.invalid_input` the `ValueError` of the broken rule that the solve returned
    (``broken``), where the values are concrete. Under your own transformations (traced
    results) the same messages come from `eqx.error_if` checks after the solve."""
    failed = sol.result != RESULTS.successful
    if is_concrete(failed, broken.index) and bool(sol.result == RESULTS.invalid_input):
        _checks.raise_broken(broken)
    if is_concrete(failed, sol.t_final):
        if bool(failed):
            if bool(sol.result == RESULTS.contact_overlap):
                cause = ""  # the result says it all
            elif bool(sol.result == RESULTS.event_not_located):
                cause = f" The root finder takes at most {root_steps} steps."
            else:
                cause = (
                    " Likely cause: a step limit too low for stiff contacts (raise max_steps), more "
                    "iterations than max_segments x segment_steps (raise max_segments), tolerances float64 "
                    "cannot meet (rtol below about 1e-13), or parameters that make the model blow "
                    "up (check stiffness, clearance and masses)."
                )
            raise SimulationError(
                f"The simulation stopped at t = {float(sol.t_final):.6g} s of t1 = {float(t1):.6g} s: "
                f"{RESULTS[sol.result]}{cause} Pass throw=False to inspect the partial solution."
            )
        return sol
    # under jit/vmap/grad: the broken rule's message, else the failing member's (`RESULTS`)
    sol = _checks.enforce(sol, broken)
    return sol.result.error_if(sol, failed)

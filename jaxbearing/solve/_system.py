"""What the integrator core asks of the system it integrates (`AbstractSystem`): the engine
knows a state y, a tuple of discrete states switched at events, and episodes to log, never
what they mean (`jaxbearing.recorder.MechanismSystem` says it for a mechanism)."""

from __future__ import annotations

import abc

import equinox as eqx
import jax


class AbstractSystem(eqx.Module):
    """A system dy/dt = f(t, y, states) whose discrete ``states`` (a tuple of pytrees, one per
    element) change only at events.

    Each event value is negative until its event; the core locates the first zero crossing of
    the largest along the step's interpolant and lets `on_events` switch the states. Elements
    with episodes (a contact's contacts) say whether each is in one (`episodes`), and the core
    logs each episode's start and end with a value at its start.
    """

    @abc.abstractmethod
    def initial_states(self, t0, y0) -> tuple:
        """The discrete states at (t0, y0)."""

    @abc.abstractmethod
    def vector_field(self, t, y, states) -> jax.Array:
        """dy/dt at (t, y) with ``states`` in force."""

    @abc.abstractmethod
    def event_values(self, t, y, states) -> jax.Array:
        """Every event value, (E,), each negative until its event (E static; 0: none)."""

    @abc.abstractmethod
    def on_events(self, t, y, states, crossed) -> tuple:
        """The states after the events ``crossed`` ((E,) bool) at (t, y)."""

    @abc.abstractmethod
    def episodes(self, states) -> tuple[jax.Array, jax.Array]:
        """(in episode (K,) bool, the value each logs at an episode's start (K,)) for the K
        elements with episodes (K static; 0: none)."""

    @abc.abstractmethod
    def drift(self, t, y) -> jax.Array:
        """A scalar the core follows the maximum of over the ends of the recorded steps (a
        mechanism's constraint violation)."""

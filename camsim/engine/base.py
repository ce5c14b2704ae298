"""The stepper protocol: one way of advancing a configuration between events.

A stepper advances one configuration (a branch per switching element) from a state until
its first guard crosses or a stop time, and returns what it recorded. The event loop
(:class:`camsim.engine.integrator.Integrator`) picks the first stepper of its list that
applies to a configuration — as ``scipy.integrate.solve_ivp`` maps a method name to its
``OdeSolver`` once — and never looks inside it. The steppers:

- :class:`camsim.engine.linear.LinearStepper` — a linear configuration (every closed contact
  linear, rigid contacts as constraints): exact step maps, events on the exact solution;
- :class:`camsim.engine.nonlinear.ExponentialStepper` — one closed nonlinear contact whose law
  gives its tangent: exact propagation of a linearised law, the remainder iterated, DOP853
  across bounces;
- :class:`camsim.engine.rk.RungeKuttaStepper` — anything else (several closed nonlinear
  contacts): DOP853 with every guard as a terminal event.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Protocol

if TYPE_CHECKING:
    from camsim.engine.context import EngineContext
    from camsim.engine.state import Guard, State, Stretch
    from camsim.model.assembly import Configuration


class Stepper(Protocol):
    """One way of advancing a configuration."""

    #: Whether the stepper's solution is exact between samples (the jump watch then follows
    #: its chunks as they are computed; otherwise it watches the stretch afterwards).
    exact: bool
    #: Whether the stepper crosses the cam's breaks (joins, a law's inner kinks) inside a
    #: stretch; the driver stops the others at each.
    crosses_breaks: bool

    def applies(self, ctx: "EngineContext", config: "Configuration") -> bool:
        """Whether this stepper advances ``config``."""

    def advance(self, ctx: "EngineContext", state: "State", config: "Configuration", z0, guards: "list[Guard]",
                t_stop: float, record: bool) -> "tuple[State, Stretch | None, Guard | None]":
        """Advance from ``state`` (reduced state ``z0``) until the first guard of ``guards``
        crosses or ``t_stop``; returns the state at the end, the recorded samples (grid
        points in [state.t, end); None when ``record`` is false or none lie there) and the
        guard that fired (None at ``t_stop``)."""

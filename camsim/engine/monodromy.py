"""The derivative of a run's flow map: the monodromy matrix of a revolution (issue 42, item 5).

Between events a configuration is linear time-invariant, ż = A·z + B·u(t) + b, so the
derivative of the state at t₁ with respect to the state at t₀ inside one stretch is
e^{A·(t₁ − t₀)}, whatever the cam input. At an event whose state is continuous (a compliant
contact closing or opening, a preloaded link separating or rejoining) the event's instant
moves with the starting state, and the derivative picks up the saltation matrix

    S = I + (f⁺ − f⁻)·∇gᵀ / ġ⁻

with f^∓ the vector fields of the configurations before and after at the event's state,
∇g the gradient of the guard that fired and ġ⁻ its rate along the flow before it (Aizerman &
Gantmacher 1958; Leine & Nijmeijer, *Dynamics and Bifurcations of Non-Smooth Mechanical
Systems*, 2004, §7.1). The product of the stretches' exponentials and the events' saltation
matrices over one revolution is the monodromy matrix M = ∂y(T)/∂y(0) of the revolution's map
y ↦ F(y), y = (x, v) of the free masses: what a Newton iteration on F(y) = y needs
(camsim.run.steady).

:class:`Monodromy` accumulates it from the integrator's stretches
(:meth:`camsim.engine.integrator.Integrator.run`'s ``on_advance``). It declines — and says
why — where the derivative is not the product above: a nonlinear (power-law or numerically
integrated) configuration, a rigid contact held closed (a constrained configuration) or an
impact that maps velocities, a stuck friction pair, a contact law that remembers its impact
velocity, several branch changes at one instant, or a guard met with zero rate (a graze).
"""

from __future__ import annotations

import numpy as np

from camsim.engine.state import Guard, State
from camsim.engine.stepping import expm_balanced

__all__ = ["Declined", "Monodromy", "not_differentiable"]

#: A guard's rate at its event below this fraction of its largest term is a graze: the
#: event's instant does not move smoothly with the state there (the saltation is unbounded).
GRAZE_RATE = 1e-9


class Declined(Exception):
    """The run's derivative is not the product of exponentials and saltation matrices: the
    message says why (raised from :meth:`Monodromy.after_stretch`, which stops the run)."""


def not_differentiable(model) -> str | None:
    """Why no run of ``model`` has the derivative :class:`Monodromy` accumulates, known
    before it runs (an element with a nonlinear branch or a rigid one), or None."""
    from camsim.elements import Branch

    for i, element in enumerate(model.elements):
        options = model.branch_options(i) if i in model.switching else ()
        if Branch.STUCK in options:
            return f"element {element.name} is a rigid contact (its impacts map velocities)"
        if any(element.is_nonlinear(b) for b in Branch):
            return f"element {element.name} has a nonlinear law"
    return None


class Monodromy:
    """∂y(t)/∂y(t₀) of the integrator's run, y = (x, v) of the free masses.

    Parameters
    ----------
    ctx : EngineContext
        The integrator whose stretches are accumulated.

    Attributes
    ----------
    matrix : ndarray (2n, 2n)
        The derivative so far.
    declined : str or None
        Why the derivative cannot be accumulated on this run (None while it can).
    scale : ndarray (2n,)
        The largest |x|, |v| of each free mass at the stretches' ends [m, m/s]: the size of the
        motion, for a residual's relative measure.
    """

    def __init__(self, ctx):
        self.ctx = ctx
        n = ctx.model.n
        self.matrix = np.eye(2 * n)
        self.declined: str | None = None
        self.scale = np.zeros(2 * n)
        self.events = 0

    def _decline(self, why: str) -> Declined:
        self.declined = why
        return Declined(why)

    def _usable(self, config, state: State) -> str | None:
        """Why the derivative through ``config`` is not e^{A·t} in (x, v), or None."""
        if not config.linear:
            return "a nonlinear contact law is closed"
        if config.stuck_contacts:
            return "a rigid contact is held closed"
        if config.holds or state.holds:
            return "a friction pair sticks"
        if state.v_impacts:
            return "a contact law depends on its impact velocity"
        n = self.ctx.model.n
        if config.dim != 2 * n or np.any(config.p0) or np.any(config.p_s) \
                or not np.array_equal(config.N, np.eye(n)):
            return "a configuration has constrained coordinates"
        return None

    def after_stretch(self, start: State, end: State, guard: Guard | None, after: State) -> None:
        """Accumulate one stretch from ``start`` to ``end`` (its configuration is ``start``'s),
        and the event of ``guard`` there when it fired (``after``: the state once every event
        of that instant is resolved)."""
        model = self.ctx.model
        config = model.configuration(start.branches, start.holds)
        why = self._usable(config, start)
        if why is not None:
            raise self._decline(why)
        dt = end.t - start.t
        if dt > 0.0:
            self.matrix = expm_balanced(config.A * dt) @ self.matrix
        y = np.concatenate([end.x, end.v])
        np.maximum(self.scale, np.abs(y), out=self.scale)
        if guard is None:
            return
        self.events += 1
        if not (np.array_equal(after.x, end.x) and np.array_equal(after.v, end.v)):
            raise self._decline("an impact maps velocities")
        changed = [k for k, (a, b) in enumerate(zip(start.branches, after.branches)) if a != b]
        if len(changed) > 1:
            raise self._decline("several branches change at one instant")
        config_after = model.configuration(after.branches, after.holds)
        why = self._usable(config_after, after)
        if why is not None:
            raise self._decline(why)
        u = self.ctx.inputs(np.array([end.t]))  # (1, 4·c): continuous at an event
        z = config.state_from_input(end.x, end.v, u[0])
        f_before = config.A @ z + config.B @ u[0] + config.b
        f_after = config_after.A @ z + config_after.B @ u[0] + config_after.b
        grad = np.asarray(guard.value.Cz, dtype=float).reshape(-1)
        rate = self.ctx.guard_rate(config, guard, z, u, np.zeros((1, 0)))
        size = float(np.abs(grad * f_before).sum())
        if not np.isfinite(rate):
            raise self._decline(f"the rate of element {model.elements[guard.element].name}'s guard is not known "
                                "in closed form")
        if abs(rate) <= GRAZE_RATE * max(size, 1e-300):
            raise self._decline(f"an event at t = {end.t:.9g} s is a graze (its guard's rate is zero)")
        self.matrix = (np.eye(z.size) + np.outer(f_after - f_before, grad) / rate) @ self.matrix

"""The general route through closed nonlinear contacts: DOP853 with every guard as an event.

Several closed nonlinear contacts at once, or a law without the tangent the exponential
stepper (:mod:`camsim.engine.nonlinear`) needs: scipy's DOP853 at ``rtol_nonlinear`` on
ż = A·z + B·u + b + L·F_nl, through :func:`camsim.engine.span.dop853_span`.
"""

from __future__ import annotations

import numpy as np

from camsim.engine.context import EngineContext
from camsim.engine.span import _StepInput, dop853_span
from camsim.engine.state import State, Stretch


def advance_rk(ctx: EngineContext, state: State, config, z0, guards, t_stop: float, record: bool):
    """Advance a configuration with closed nonlinear contacts by DOP853 (rtol
    ``ctx.rtol_nonlinear``) with every guard as a terminal event: the general route (several
    closed contacts, or a law without a tangent for the exponential stepper)."""
    v_imp = state.v_impacts
    cam_input = _StepInput(ctx, state.t, t_stop)
    contacts = []
    for i in config.power_contacts:
        delta, rate = ctx._delta(config, i)
        contacts.append((i, delta.Cz[0], delta.Du[0], float(delta.e[0]), rate.Cz[0], rate.Du[0], float(rate.e[0])))
    A, B, b, L = config.A, config.B, config.b, config.L
    fn = np.zeros(len(contacts))
    force_of = [ctx.model.acting(i, config.branches).nonlinear_force_scalar for i in config.power_contacts]

    def rhs(t, z):
        u = cam_input(t)
        for k, (i, dcz, ddu, de, rcz, rdu, re) in enumerate(contacts):
            delta = dcz @ z + ddu @ u + de
            rate = rcz @ z + rdu @ u + re
            fn[k] = force_of[k](delta, rate, v_imp.get(i))
        return A @ z + B @ u + b + L @ fn

    t0 = state.t
    def forces(t, z):
        u = cam_input(t)
        out = np.empty(len(contacts))
        for k, (i, dcz, ddu, de, rcz, rdu, re) in enumerate(contacts):
            out[k] = force_of[k](dcz @ z + ddu @ u + de, rcz @ z + rdu @ u + re, v_imp.get(i))
        return out

    grid, Zs, z_end, fired, t_end = dop853_span(ctx, rhs, z0, t0, t_stop, guards, cam_input, forces=forces)
    stretch = None
    if record and grid.size:
        Us = ctx.inputs(grid)
        fn = ctx.nonlinear_forces(config, Zs, Us, v_imp)
        stretch = Stretch(state.branches, config, grid, Zs, Us, fn, dict(v_imp))
    end = ctx._state_from(config, z_end, t_end, state)
    return end, stretch, fired


class RungeKuttaStepper:
    """The general stepper of closed nonlinear contacts: :func:`advance_rk` (applies to every
    configuration; the driver tries it last)."""

    exact = False
    crosses_breaks = False

    def applies(self, ctx, config) -> bool:
        return True

    def advance(self, ctx, state, config, z0, guards, t_stop, record):
        return advance_rk(ctx, state, config, z0, guards, t_stop, record)

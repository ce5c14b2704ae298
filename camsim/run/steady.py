"""The periodic steady state found by shooting on the revolution's map (issue 42, item 5).

A cam machine is periodic: its state one revolution on, y(T) = F(y(0)) with y = (x, v) of
the free masses, and its steady state is the fixed point F(y*) = y*. Warm-up revolutions
reach it as fast as the machine's damping lets the start transient decay (a lightly damped
machine needs many); ``[simulation] steady_state = "shooting"`` solves for it instead.
For a fixed sequence of events F is affine between them and its derivative is the monodromy
matrix M (camsim.engine.monodromy: the stretches' exponentials and the events' saltation
matrices), so Newton's iteration

    y_{k+1} = y_k + (I − M_k)⁻¹·(F(y_k) − y_k)

converges in a few revolutions, quadratically once the event sequence is the steady one.
Each iteration is the revolution the recording starts with, on the recording grid (the same
map the recorded revolution integrates: its end then repeats its start to rounding). The
iteration stops when the residual |F(y_k) − y_k|, relative to the size of the motion, is at
rounding level (:data:`SHOOTING_RESIDUAL`), or when M contracts so strongly that F(y_k) is
within that of the fixed point (q/(1 − q)·|F(y_k) − y_k| with q = ‖M‖: a well-damped machine
such as the CDTM, one revolution); the recorded window then starts from F(y_k), and the run's
periodicity residual is measured on its first recorded revolution (its end against its start).

Where the derivative is not known (a nonlinear contact law, a rigid contact held closed or
an impact that maps velocities, a friction pair, a graze: camsim.engine.monodromy), where the
machine is not periodic in its angle (a load in time), or where Newton does not converge in
:data:`SHOOTING_ITERATIONS` revolutions (chatter, a jump, an event sequence that does not
settle), the run warms up its ``warmup_cycles`` revolutions instead and says so in a warning.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from camsim.engine.integrator import Integrator
from camsim.engine.monodromy import Declined, Monodromy, not_differentiable
from camsim.engine.state import State

__all__ = ["SHOOTING_ITERATIONS", "SHOOTING_RESIDUAL", "Shooting", "shoot", "not_periodic"]

#: Largest residual |F(y) − y| of the steady state, relative to each coordinate's largest
#: value over the revolution: rounding of a revolution's integration (a few 1e-14) with a margin.
SHOOTING_RESIDUAL = 1e-12
#: Most revolutions the iteration takes before it gives up (the warm-up instead).
SHOOTING_ITERATIONS = 8
#: Largest norm of the monodromy matrix (in the motion's units) for which F(y) is taken as
#: the fixed point by the contraction bound q/(1 − q)·|F(y) − y|.
CONTRACTION = 1e-3
#: Past this residual the iteration stops improving (rounding): a step that does not
#: reduce the residual below this fraction of the previous one ends it.
STAGNATION = 0.5


@dataclass
class Shooting:
    """How the steady state was found.

    Attributes
    ----------
    start, end : State or None
        The last iterate y_k (at time 0) and the state one revolution on, F(y_k); None when
        the iteration declined or did not converge.
    iterations : int
        Revolutions integrated.
    residual : float
        max |F(y_k) − y_k| / scale of the last iterate [-] (nan before the first); when
        ``contracted``, the bound q/(1 − q)·that on the distance of F(y_k) from the fixed point.
    why : str or None
        Why the warm-up was used instead (None: converged).
    contracted : bool
        Converged by the contraction bound (F(y_k) is the steady state to rounding, its
        residual is measured on the recorded revolution), not by |F(y_k) − y_k| itself.
    """

    start: State | None
    end: State | None
    iterations: int
    residual: float
    why: str | None = None
    contracted: bool = False


def not_periodic(machine) -> str | None:
    """Why shooting does not apply to ``machine`` before it runs (its motion is not periodic
    in the cam angle, or its derivative is not tracked), or None."""
    if machine.cam is None:
        return "the machine has no cam"
    if machine.camshaft is not None and machine.camshaft.model == "dynamic":
        return "a dynamic camshaft's speed varies from revolution to revolution"
    for load in machine.loads:
        if load.kind == "sine" or (load.kind == "table" and load.table is not None and load.table.over == "time"):
            return f"load {load.name} is a function of time, not of the cam angle"
    for element in machine.elements:
        if getattr(element, "type_name", None) == "friction":
            return f"element {element.name} is a friction pair (its stuck state is not differentiated)"
    return None


def shoot(integrator, state: State, t0: float, period: float, check=None, progress=None) -> Shooting:
    """Newton's iteration on the revolution's map from ``state``: the revolution from ``t0``.

    Parameters
    ----------
    integrator : Integrator
        The engine on the recording grid.
    state : State
        The first iterate (static equilibrium, or the file's [initial] state).
    t0 : float
        Where the revolution starts [s] (the recording's start: the same angle as 0).
    period : float
        One revolution [s].
    check, progress : callable, optional
        The run's physical bounds and progress channel (see Integrator.run).

    Returns
    -------
    Shooting
    """
    n = integrator.model.n
    residual = math.nan
    best = math.inf
    for k in range(SHOOTING_ITERATIONS):
        mono = Monodromy(integrator)
        integrator.events.clear()
        try:
            end, _ = integrator.run(replace(state, t=t0), t0 + period, record_from=math.inf, check=check,
                                    on_advance=mono.after_stretch, progress=progress)
        except Declined as why:
            return Shooting(None, None, k + 1, residual, str(why))
        y = np.concatenate([state.x, state.v])
        step = np.concatenate([end.x, end.v]) - y
        scale = np.maximum(mono.scale, np.abs(y))
        scale[scale == 0.0] = 1.0
        residual = float(np.max(np.abs(step) / scale)) if step.size else 0.0
        if residual <= SHOOTING_RESIDUAL:
            return Shooting(state, end, k + 1, residual)
        # A map that contracts strongly (q = ‖M‖ in the motion's units): F(y) lies within
        # q/(1 − q)·|F(y) − y| of the fixed point, so F(y) is the steady state to rounding
        # without another revolution (the CDTM: q ≈ 1e-16 after one revolution). The run
        # then measures the residual on its first recorded revolution.
        q = float(np.linalg.norm(mono.matrix * scale[None, :] / scale[:, None], 2))
        if q < CONTRACTION and q / (1.0 - q) * residual <= SHOOTING_RESIDUAL:
            return Shooting(state, end, k + 1, q / (1.0 - q) * residual, contracted=True)
        if residual > STAGNATION * best and best <= 1e-8:
            return Shooting(None, None, k + 1, residual, f"the iteration stalls at a residual of {residual:.2g}")
        best = min(best, residual)
        try:
            delta = np.linalg.solve(np.eye(2 * n) - mono.matrix, step)
        except np.linalg.LinAlgError:
            return Shooting(None, None, k + 1, residual, "the revolution's map has an eigenvalue 1 (no isolated "
                                                         "steady state)")
        y_next = y + delta
        if not np.all(np.isfinite(y_next)):
            return Shooting(None, None, k + 1, residual, "the Newton step diverged")
        # the steady state's branches at θ0 are those one revolution on
        state = replace(end, t=t0, x=y_next[:n].copy(), v=y_next[n:].copy(), v_impacts={}, holds=())
    return Shooting(None, None, SHOOTING_ITERATIONS, residual,
                    f"no convergence in {SHOOTING_ITERATIONS} revolutions (residual {residual:.2g})")


@dataclass
class Found:
    """A converged shooting: its iterate and what the recorded window inherits."""

    shooting: Shooting
    watch_last: object  # the cam contact force's sign at the revolution's end (jump rows)


def find_steady_state(machine, model, inputs, step: float, state: State, period: float, t_rec: float, bounds,
                      progress, warnings: list) -> tuple[State, Found | None]:
    """``[simulation] steady_state = "shooting"``: the state the recorded window starts from
    (at ``t_rec``) and how it was found, or (``state`` unchanged, None) with a warning saying
    why the warm-up is used instead. ``step``: the recording grid's [s] (its grid passes
    through ``t_rec``)."""
    why = not_periodic(machine) or not_differentiable(model)
    if why is None:
        engine = Integrator(model, inputs, step, t_ref=t_rec)
        found = shoot(engine, state, t_rec, period, check=bounds.check, progress=progress)
        why = found.why
        if why is None:
            return replace(found.end, t=t_rec), Found(found, engine.watch.last)
    warm = machine.simulation.warmup_cycles
    warnings.append(f"steady_state = \"shooting\": {why}; warmed up {warm} revolution{'s' if warm != 1 else ''} "
                    "instead (simulation.warmup_cycles)")
    return state, None

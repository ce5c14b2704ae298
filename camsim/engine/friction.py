"""Friction pairs at their events: the stick test, the holds, impulses (spec §10).

A friction pair (:mod:`camsim.elements.friction`) slides on a linear (or Stribeck) branch
until its sliding velocity reaches zero — its ``halt`` guard. What happens then depends on
the rest of the machine, so the engine decides it here: with the pair held at the deflection
d it has reached (a constraint, as a stuck rigid contact is one), the constraint force λ is
what it would have to carry. Its holding force f = −λ within ±F_B: it sticks (event
``stick``; the velocities are projected onto ḋ = 0, the correction being the rounding of the
located halt); beyond: it slides off at once towards the side that pushes (no row, no stuck
interval: a reversal).

A stuck pair's deflection is part of the configuration (``State.holds``,
:meth:`camsim.model.assembly.Model.configuration`).

A rigid contact's impulse (:mod:`camsim.engine.rigid`) changes velocities at an instant, which
no finite friction force can oppose: a held pair that the impulse sets moving slips (event
``slip``), and a sliding pair that it brings to rest takes the stick test (spec §10: "a rigid
impact that brings ḋ to zero is ḋ reaching zero").
"""

from __future__ import annotations

import numpy as np

from camsim.elements import Branch
from camsim.elements.affine import N_INPUT
from camsim.elements.events import EventKind
from camsim.engine.state import State

#: Relative velocity [m/s] below which an impulse has brought a pair to rest.
REST_VELOCITY = 1e-12


def is_friction(model, i: int) -> bool:
    """Whether element ``i`` is a friction pair (it has a held branch)."""
    return Branch.HELD in model.branch_options(i)


def with_hold(holds: tuple, i: int, d: float | None) -> tuple:
    """``holds`` with element ``i`` held at ``d`` (None: released), in index order."""
    kept = [(j, h) for j, h in holds if j != i]
    if d is not None:
        kept.append((i, float(d)))
    return tuple(sorted(kept))


def pruned(model, branches, holds: tuple) -> tuple:
    """The holds of the pairs still held on ``branches``."""
    return tuple((j, h) for j, h in holds if model.branch_of(branches, j) == Branch.HELD)


def holding_force(ctx, state: State, i: int) -> tuple[float, State]:
    """The force f [N] (tension-positive) that would hold pair ``i`` at its deflection now,
    and the state with it held there (velocities projected onto ḋ = 0)."""
    model = ctx.model
    pos = model.switching.index(i)
    u = ctx.inputs(np.array([state.t]))[0]
    d = float(model.deflection(i, state.x, u[0::N_INPUT]))
    branches = list(state.branches)
    branches[pos] = Branch.HELD
    branches = tuple(branches)
    holds = with_hold(state.holds, i, d)
    config = model.configuration(branches, holds)
    z = config.state_from_input(state.x, state.v, u)
    fn = ctx.nonlinear_forces(config, z[None, :], u[None, :], state.v_impacts)
    if i in config.saturated:  # held beside a stuck contact: it carries ±F_B, the contact the rest
        f = config.saturated[i]
    else:
        f = -float(config.lam(z[None, :], u[None, :], fn)[0, config.stuck_contacts.index(i)])
    x = config.x(z[None, :], u[None, :], fn)[0]
    v = config.v(z[None, :], u[None, :], fn)[0]
    v_imp = dict(state.v_impacts)
    v_imp.pop(i, None)
    return f, State(state.t, x, v, branches, v_imp, holds)


def breakaway(ctx, state: State, i: int) -> float:
    """F_B [N] of pair ``i`` at ``state.t`` (μ_s·N(t) when its normal force follows a program)."""
    element = ctx.model.elements[i]
    if not element.programmed:
        return element.holding_force
    u = ctx.inputs(np.array([state.t]))[0]
    return element.forces_at(u[ctx.model.normal_column(i)])[1]


def halt(ctx, state: State, i: int) -> State:
    """The stick test of pair ``i`` whose sliding velocity has reached zero."""
    f, held = holding_force(ctx, state, i)
    if abs(f) <= breakaway(ctx, state, i):
        ctx._record(state.t, i, EventKind.STICK, 0.0)
        return held
    return slide(ctx, state, i, 1.0 if f > 0.0 else -1.0)


def grip(ctx, state: State, i: int) -> State:
    """Pair ``i``'s programmed normal force rises above zero: sliding if its nodes move apart
    (no row), else held where it is (a ``stick`` row: the clamp grips)."""
    _, rate = ctx.relative_rate(state, i)
    if abs(rate) > REST_VELOCITY:
        return slide(ctx, state, i, 1.0 if -rate > 0 else -1.0)
    _, held = holding_force(ctx, state, i)
    ctx._record(state.t, i, EventKind.STICK, 0.0)
    return held


def slide(ctx, state: State, i: int, sign: float, event: EventKind | None = None) -> State:
    """Pair ``i`` sliding off in direction ``sign`` (+1: ḋ > 0), from ``state``."""
    model = ctx.model
    outcome = model.elements[i].sliding(sign)
    branches = list(state.branches)
    branches[model.switching.index(i)] = outcome.branch
    v_imp = dict(state.v_impacts)
    v_imp[i] = outcome.v_impact
    if event is not None:
        ctx._record(state.t, i, event, 0.0)
    return State(state.t, state.x.copy(), state.v.copy(), tuple(branches), v_imp, with_hold(state.holds, i, None))


def after_impulse(ctx, state: State) -> State:
    """Friction pairs after a rigid contact's impulse (see the module docstring)."""
    model = ctx.model
    for pos, i in enumerate(model.switching):
        if not is_friction(model, i):
            continue
        branch = state.branches[pos]
        if branch not in (Branch.HELD, Branch.SLIDING_UP, Branch.SLIDING_DOWN):
            continue
        _, rate = ctx.relative_rate(state, i)  # −ḋ
        d_rate = -rate
        if branch == Branch.HELD and abs(d_rate) > REST_VELOCITY:
            state = slide(ctx, state, i, 1.0 if d_rate > 0 else -1.0, EventKind.SLIP)
        elif branch != Branch.HELD and abs(d_rate) <= REST_VELOCITY:
            state = halt(ctx, state, i)
        elif branch != Branch.HELD and d_rate * model.elements[i].direction(branch) < 0:
            state = slide(ctx, state, i, 1.0 if d_rate > 0 else -1.0)  # the impulse reversed it
    return state


def start(ctx, state: State) -> State:
    """The friction pairs of a run's first state (spec §10): the static equilibrium is computed
    without them (their ``free`` branch); each then starts held where it is, carrying no force
    there (no ``stick`` row), or, given a sliding velocity by ``[initial]``, sliding."""
    model = ctx.model
    for pos, i in enumerate(model.switching):
        if not is_friction(model, i) or state.branches[pos] != Branch.FREE:
            continue
        if model.elements[i].programmed:  # free while its normal force is not positive
            u = ctx.inputs(np.array([state.t]))[0]
            if not u[model.normal_column(i)] > 0.0:
                continue
        _, rate = ctx.relative_rate(state, i)
        d_rate = -rate
        if abs(d_rate) > REST_VELOCITY:
            state = slide(ctx, state, i, 1.0 if d_rate > 0 else -1.0)
            continue
        u = ctx.inputs(np.array([state.t]))[0]
        d = float(model.deflection(i, state.x, u[0::N_INPUT]))
        branches = list(state.branches)
        branches[pos] = Branch.HELD
        state = State(state.t, state.x, state.v, tuple(branches), dict(state.v_impacts), with_hold(state.holds, i, d))
    return state

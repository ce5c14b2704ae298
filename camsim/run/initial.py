"""The state a run starts from: static equilibrium at the start angle, or the file's [initial].

:func:`static_equilibrium` iterates over the branches of the contacts and links until the
equilibrium they imply is the one they were assumed in; a closed power-law contact makes the
equilibrium a nonlinear equation (one scalar equation in its force for one contact, Powell's
method otherwise). :func:`initial_state` puts the machine file's ``[initial]`` values on top.
"""

from __future__ import annotations

import numpy as np

from camsim.errors import InputError
from camsim.elements.affine import N_INPUT
from camsim.elements import Branch
from camsim.engine import friction
from camsim.engine.integrator import Integrator, State
from camsim.model.assembly import Model

#: no unique solution (a mass held by nothing stiff): ask for an [initial] state instead.
#: 1e14 leaves two digits of a double for the positions.
EQUILIBRIUM_MAX_CONDITION = 1e14
#: A nonlinear (power-law) static equilibrium is accepted when its force residual is below
#: this fraction of the residual at the unloaded position (1e-6: well below any reported digit).
EQUILIBRIUM_RESIDUAL = 1e-6
#: Penetrations [m] from which Powell's method is started in turn: δ^a has no slope at
#: δ = 0, which can stall the first try (0.1 µm .. 0.1 mm spans seats from hard to soft).
EQUILIBRIUM_STARTS = (0.0, 1e-6, 1e-5, 1e-4)


# ---------------------------------------------------------------------- initial state
def static_equilibrium(model: Model, integrator: Integrator, t0: float) -> State:
    """Static equilibrium at t0 with zero velocities, iterating over branches until consistent.

    Raises
    ------
    InputError
        When no consistent equilibrium exists (e.g. a mass held by nothing but gravity).
    """
    n = model.n
    branches = tuple(
        Branch.BILATERAL if Branch.BILATERAL in model.branch_options(i) else model.branch_options(i)[0]
        for i in model.switching
    )
    u = integrator.inputs(np.array([t0]))[0]
    seen = set()
    for _ in range(4 * len(model.switching) + 8):
        if branches in seen:
            break
        seen.add(branches)
        config = model.configuration(branches)
        nq = config.dim // 2
        A21 = config.A[nq:, :nq]
        rhs = config.B[nq:] @ u + config.b[nq:]
        if not nq:  # every free mass held by stuck rigid contacts: nothing to solve
            q = np.zeros(0)
        elif config.linear or not any(model.elements[i].nonlinear_at_rest(model.branch_of(branches, i))
                                      for i in config.power_contacts):
            # linear, or every nonlinear force vanishes at rest (quadratic damping): F_nl = 0
            try:
                q = np.linalg.solve(A21, -rhs)
            except np.linalg.LinAlgError:
                q = None
            if q is not None and nq and np.linalg.cond(A21) > EQUILIBRIUM_MAX_CONDITION:
                q = None
        else:
            q = _nonlinear_static(model, integrator, config, u, t0)
        if q is None:
            raise InputError(
                f"{model.machine.source}: initial: no static equilibrium at the start (a mass is held "
                "by nothing stiff); give its position in an [initial] table"
            )
        z = np.concatenate([q, np.zeros(nq)])
        x = config.x(z[None, :], u[None, :], integrator.nonlinear_forces(config, z[None, :], u[None, :], {}))[0]
        v = np.zeros(n)
        state = State(t0, x, v, branches, {})
        new = _consistent_branches(model, integrator, state)
        if new == branches:
            return state
        branches = new
    raise InputError(
        f"{model.machine.source}: initial: the static equilibrium does not settle on one branch of "
        "the contacts and links; give the start in an [initial] table"
    )


def _nonlinear_static(model, integrator, config, u, t0):
    from scipy import optimize  # only power-law contacts need it; keeps start-up light

    nq = config.dim // 2
    # each contact's penetration at rest: δ = c·q + e (the affine maps evaluated once)
    contacts = []
    for i in config.power_contacts:
        delta, _ = integrator._delta(config, i)
        contacts.append((model.acting(i, config.branches), delta.Cz[0][:nq], float(delta.Du[0] @ u + delta.e[0])))
    A21 = config.A[nq:, :nq]
    L2 = config.L[nq:]
    base = config.B[nq:] @ u + config.b[nq:]

    def residual(q):
        fn = [element.nonlinear_force(np.array([c @ q + e]), np.zeros(1), None)[0] for element, c, e in contacts]
        return A21 @ q + base + L2 @ np.array(fn)

    def jacobian(q):
        # analytic: ∂F/∂δ of each contact at rest (Powell's method then needs no
        # finite differences, a tenth of the residual evaluations)
        J = A21.copy()
        for k, (element, c, e) in enumerate(contacts):
            kt = element.nonlinear_tangent(np.array([c @ q + e]), np.zeros(1), None)[1][0]
            J += np.outer(L2[:, k], kt * c)
        return J

    def accepted(q):
        return np.max(np.abs(residual(q))) < EQUILIBRIUM_RESIDUAL * max(1.0, np.max(np.abs(residual(np.zeros(nq)))))

    if len(contacts) == 1:
        q = _one_contact_static(A21, L2[:, 0], base, contacts[0])
        if q is not None and accepted(q):
            return q
    # Powell's hybrid method from the unloaded position, then from a few small
    # penetrations (δ^a has no slope at δ = 0, which can stall the first try).
    guess = np.zeros(nq)
    best = None
    for scale in EQUILIBRIUM_STARTS:
        sol = optimize.root(residual, guess + scale, jac=jacobian, method="hybr", options={"xtol": 1e-14})
        if sol.success and accepted(sol.x):
            best = sol.x
            break
    if best is None and len(contacts) > 1:
        best = _static_by_blocks(A21, L2, base, contacts, accepted)
    return best


def _static_by_blocks(A21, L2, base, contacts, accepted):
    """Static equilibrium of uncoupled parts solved one by one (issue 38: the stations on one
    camshaft share no coordinate): the coordinates split into the blocks that no stiffness
    and no contact couples, each solved as a machine of its own — a linear solve, the scalar
    equation of one contact, or Powell's method — where the whole system's Powell iteration
    with several contacts did not converge."""
    from scipy import optimize

    nq = A21.shape[0]
    parent = list(range(nq))

    def find(i):
        while parent[i] != i:
            parent[i] = parent[parent[i]]
            i = parent[i]
        return i

    def join(idx):
        idx = list(idx)
        for j in idx[1:]:
            parent[find(j)] = find(idx[0])

    for i, j in zip(*np.nonzero(A21)):
        join((i, j))
    for k, (_, c, _) in enumerate(contacts):
        touched = np.flatnonzero((np.abs(c) > 0) | (np.abs(L2[:, k]) > 0))
        if touched.size:
            join(touched)
    q = np.zeros(nq)
    for root in {find(i) for i in range(nq)}:
        idx = np.array([i for i in range(nq) if find(i) == root])
        mine = [k for k, (_, c, _) in enumerate(contacts) if np.any(np.abs(c[idx]) > 0) or np.any(np.abs(L2[idx, k]) > 0)]
        A, b = A21[np.ix_(idx, idx)], base[idx]
        sub = [(contacts[k][0], contacts[k][1][idx], contacts[k][2]) for k in mine]
        L = L2[np.ix_(idx, mine)] if mine else np.zeros((idx.size, 0))
        if not sub:
            try:
                q[idx] = np.linalg.solve(A, -b)
            except np.linalg.LinAlgError:
                return None
            continue
        if len(sub) == 1:
            part = _one_contact_static(A, L[:, 0], b, sub[0])
            if part is not None:
                q[idx] = part
                continue

        def residual(x, A=A, b=b, L=L, sub=sub):
            fn = [element.nonlinear_force(np.array([c @ x + e]), np.zeros(1), None)[0] for element, c, e in sub]
            return A @ x + b + L @ np.array(fn)

        done = None
        for scale in EQUILIBRIUM_STARTS:
            sol = optimize.root(residual, np.zeros(idx.size) + scale, method="hybr", options={"xtol": 1e-14})
            if sol.success:
                done = sol.x
                break
        if done is None:
            return None
        q[idx] = done
    return q if accepted(q) else None


def _one_contact_static(A21, L2, base, contact):
    """Static equilibrium with one power-law contact as a scalar equation in its force.

    With the contact force f as an input, the equilibrium A21·q + base + L2·f = 0 is
    linear: q = q0 + w·f, and the penetration δ = δ0 + s·f. Where s ≤ 0 (the force pushes
    the contact open, as any contact between a body and its support does) and F grows
    with δ, the contact's equation f = F(δ0 + s·f) has exactly one root in [0, F(δ0)],
    which Brent's method finds to rounding (a tenth of the cost of Powell's method on q).
    None where that reduction does not apply (A21 singular or ill-conditioned: a body held
    by the contact alone; s > 0; no bracket), and Powell's method on q takes over.
    """
    from scipy import optimize

    element, c, e = contact
    if A21.shape[0] == 0 or np.linalg.cond(A21) > EQUILIBRIUM_MAX_CONDITION:
        return None
    q0, w = np.linalg.solve(A21, -np.column_stack([base, L2])).T
    delta0, s = float(c @ q0 + e), float(c @ w)
    if s > 0.0:
        return None

    def excess(f):  # f − F(δ(f)): increasing in f where F increases with δ
        return f - element.nonlinear_force_scalar(delta0 + s * f, 0.0, None)

    top = -excess(0.0)
    if top <= 0.0:
        return q0  # open at rest: no force (the caller's branch check opens the contact)
    if excess(top) < 0.0:
        return None  # F not increasing with δ: no bracket
    f = optimize.brentq(excess, 0.0, top, xtol=1e-300, rtol=4 * np.finfo(float).eps)
    return q0 + w * f


def _consistent_branches(model: Model, integrator: Integrator, state: State) -> tuple[Branch, ...]:
    """Branches implied by positions at rest (static equilibrium iteration)."""
    branches = list(state.branches)
    config = model.configuration(state.branches, state.holds)
    u = integrator.inputs(np.array([state.t]))
    z = config.state_from_input(state.x, state.v, u[0])
    # the constraint forces balance the closed power-law contacts' forces too
    fn = integrator.nonlinear_forces(config, z[None, :], u, {})
    for pos, i in enumerate(model.switching):
        d = float(model.deflection(i, state.x, u[0, 0::N_INPUT]))

        def constraint_force(i=i) -> float:
            return float(config.lam(z[None, :], u, fn)[0, config.stuck_contacts.index(i)])

        branches[pos] = model.elements[i].branch_at_rest(branches[pos], d, constraint_force)
    return tuple(branches)


def initial_state(model: Model, integrator: Integrator, t0: float) -> State:
    """Static equilibrium, then the machine file's ``[initial]`` values on top."""
    machine = model.machine
    given = {ic.mass: ic for ic in machine.initial}
    try:
        state = static_equilibrium(model, integrator, t0)
    except InputError:
        missing = [name for name in model.free_names if name not in given or given[name].displacement is None]
        if missing:
            raise
        branches = tuple(model.branch_options(i)[0] for i in model.switching)
        state = State(t0, np.zeros(model.n), np.zeros(model.n), branches, {})
    if not given:
        return friction.start(integrator, state)
    x, v = state.x.copy(), state.v.copy()
    for name, ic in given.items():
        k = model.index[name]
        if ic.displacement is not None:
            x[k] = ic.displacement
        if ic.velocity is not None:
            v[k] = ic.velocity
    # Branches from the given state: links by deflection, contacts by penetration.
    branches = []
    u = integrator.inputs(np.array([t0]))[0]
    for i in model.switching:
        geo = model.geometry[i]
        d = x @ geo.G + geo.cam_term(u[0::N_INPUT])
        try:
            branches.append(model.elements[i].branch_from_state(d, model.no_impact))
        except ValueError as exc:
            raise InputError(f"{machine.source}: initial: {exc}") from None
    return friction.start(integrator, State(t0, x, v, tuple(branches), {}))

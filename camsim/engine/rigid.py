"""Rigid contacts that act together: Newton's impact law and resting forces as small LCPs.

Every rigid (``law = "restitution"``) contact that touches at an instant — the one whose
guard fired, those closing at the same instant and those already resting (stuck) — is
resolved at once (spec §3):

**Impulses.** With w the separation rate of each touching contact (w = Ġ·v + g_s·ṡ =
−δ̇, positive opening), J its rows G and W = J·M⁻¹·Jᵀ (the contacts' mutual inverse
inertia), the impulses P ≥ 0 change the rates to w⁺ = w⁻ + W·P. Newton's law per contact
with momentum conservation is the linear complementarity problem

    y = W·P + (w⁻ − e∘max(−w⁻, 0)) ≥ 0,   P ≥ 0,   Pᵀ·y = 0

(a contact either takes no impulse and separates at least as fast as Newton's law asks, or
takes an impulse and rebounds exactly at e times its approach). W is symmetric positive
definite when the contacts are independent, so the LCP has exactly one solution.

**Chatter.** A contact that rebounds with w⁺ > 0 while the rest of the machine presses it
closed (relative acceleration a < 0 with it open) would bounce in flights of
2w⁺/|a|, 2e·w⁺/|a|, … accumulating after 2w⁺/(|a|(1 − e)), the first rising w⁺²/(2|a|).
When that first flight would not rise out of the touching band (:data:`CHATTER_APEX`,
= :data:`TOUCH`, a gap the engine takes for contact anyway) it rests now: the velocities
are projected onto zero relative velocity (the plastic impulse, momentum conserved) and it
sticks (spec §4), the ``stick`` row at the chatter's Zeno limit t∞ = t + 2w⁺/(|a|(1 − e))
(= t_k + τ_k·e/(1 − e) from the flight τ_k that ended at t_k; within 1e-9 s while
|a| is steady over it). The band is decided while the flights are still resolved -- the
guards round at ~1e-16 m, their apex is 1e4 times that -- so the last bits of the state
cannot move the chatter's end by an impact (they did with the apex compared to the
rounding itself). A chatter that stays pressed less than that (its rest more than
:data:`CHATTER_SPAN` away) is followed on, and rests when its remaining time is below
:data:`ZENO_TIME` or its flight below the rounding of its own guard (:data:`APEX_RTOL`).

**Resting forces.** Contacts left at zero relative velocity carry forces λ ≥ 0 with
relative accelerations a = a_open + W·λ ≥ 0, λᵀ·a = 0 (the same W), a_open being the
accelerations with all of them open: the same LCP one derivative up. A contact with λ > 0,
or with λ = a = 0 (a plastic pair moving on together, no force needed), becomes
persistent (``stick``); one with a > 0 opens. A persistent contact opens (``release``)
when its force reaches zero (its guard in :mod:`camsim.engine.integrator`); the LCP is then solved
again for the others, the released one held open unless the machine still presses it
closed (a force above FORCE_TOL: at λ = a = 0 it opens, or its guard would fire again at the
same instant). A contact that rests is placed exactly on its constraint (the held
configuration reads the masses it joins through its reduced coordinates).

The LCPs are solved by enumeration of the active set (at most :data:`MAX_CONTACTS`
contacts at one instant: 2^r small solves, exact to rounding; for a P-matrix the first
consistent set is the solution).
"""

from __future__ import annotations

import itertools

import numpy as np

from camsim.elements import Branch
from camsim.elements.base import FORCE_TOL
from camsim.errors import SimulationError
from camsim.elements.affine import N_INPUT
from camsim.elements.events import EventKind
from camsim.engine.state import State

#: A rigid contact whose remaining chatter time is below this sticks at once [s].
ZENO_TIME = 1e-11
#: Touching: penetration above −TOUCH [m] (contacts closing at the same instant).
TOUCH = 1e-12
#: A rebound whose first flight would rise less than this, relative to the magnitude of
#: the positions that make up its penetration, sticks at once (the flight is below the
#: rounding of its own guard and cannot be resolved).
APEX_RTOL = 256 * 2.0**-52
#: A pressed rebound whose first flight would rise less than this [m] rests now, its
#: ``stick`` at the chatter's accumulation time (the touching band; far above the guards'
#: rounding, ~1e-16 m, so that the chatter's end does not hinge on the last bits).
CHATTER_APEX = TOUCH
#: Largest number of rigid contacts resolved together at one instant.
MAX_CONTACTS = 12
#: A rigid contact that has taken this many impacts within CHATTER_SPAN, its flights not
#: shrinking (the last at least half the first), takes the next one plastically (e = 0),
#: so that it rests if the machine presses it closed. A chatter whose flights shrink (e < 1
#: against a steady pressing force: a ball bouncing to rest) is left to ZENO_TIME and ends at
#: its exact accumulation time; one whose flights do not shrink -- a rigid lash rebounding
#: against a compliant contact's fast force, 2.7e-8 s per flight for as long as the run
#: lasts -- stepped forever (issue 25 item 3: tests/invariants/machines/crawl-adams-roller-rigid-stop.toml).
CHATTER_IMPACTS = 32
CHATTER_SPAN = 1e-4


def solve_lcp(W: np.ndarray, q: np.ndarray, tol: float = 0.0) -> np.ndarray:
    """x ≥ 0 with y = W·x + q ≥ 0 and xᵀ·y = 0, W a small P-matrix.

    Parameters
    ----------
    W : ndarray (r, r)
        Symmetric positive definite [any consistent units].
    q : ndarray (r,)
    tol : float
        Slack allowed on the signs (rounding).

    Returns
    -------
    ndarray (r,)
        The unique solution.
    """
    r = q.size
    if r == 0:
        return np.zeros(0)
    if r > MAX_CONTACTS:
        raise SimulationError(f"{r} rigid contacts at one instant (at most {MAX_CONTACTS} are supported)")
    if np.all(q >= -tol):
        return np.zeros(r)
    best = None
    for size in range(1, r + 1):
        for active in itertools.combinations(range(r), size):
            idx = list(active)
            x = np.zeros(r)
            try:
                x[idx] = np.linalg.solve(W[np.ix_(idx, idx)], -q[idx])
            except np.linalg.LinAlgError:
                continue
            y = W @ x + q
            y[idx] = 0.0
            violation = max(float(np.max(-x, initial=0.0)), float(np.max(-y, initial=0.0)))
            if violation <= tol:
                return x
            if best is None or violation < best[0]:
                best = (violation, x)
    return np.maximum(best[1], 0.0)


def _rows(model, indices, signs):
    # A contact on side σ of a two-sided element (a lash) has rows σ·G, σ·g_s (issue 12);
    # g_s has one column per cam.
    J = np.array([sign * model.geometry[i].G for i, sign in zip(indices, signs)]).reshape(len(indices), model.n)
    js = np.array([sign * model.geometry[i].g_s for i, sign in zip(indices, signs)]).reshape(len(indices), model.n_cams)
    return J, js


def _cam(js, u, order: int) -> np.ndarray:
    """Σ_q js[:, q]·(d^order s_q/dt^order) for rows js (r, cams) and a cam-input row u."""
    out = js[:, 0] * u[order]
    for q in range(1, js.shape[1]):
        out = out + js[:, q] * u[N_INPUT * q + order]
    return out


def _pressed_analytic(integrator, t, u, v, open_accelerations):
    """The open relative accelerations with s̈ and s⃛ from the cam law itself.

    ``integrator.inputs`` interpolates between grid points with the step's Hermite
    polynomial, whose s̈ inside a step of a few µs carries the rounding of s amplified by
    ~1/h² (1e-6 relative at 200 kHz). A release located on the exact guard (λ = 0 with the
    analytic cam law, camsim.engine.crossing) can then read as still pressed by that
    rounding and creep on in tiny steps (issue 25): a release opens when either reading
    says the machine does not press the contact outright.
    """
    u_law = u.copy()
    law = integrator.analytic_inputs(t)
    for order in (2, 3):  # every cam's s̈ and s⃛
        u_law[order::N_INPUT] = law[order::N_INPUT]
    return open_accelerations(v, u_law)[0]


def resolve(integrator, state, trigger: int, kind: str):
    """The state after every rigid contact touching at ``state.t`` is resolved.

    Parameters
    ----------
    integrator : camsim.engine.integrator.Integrator
    state : camsim.engine.integrator.State
        The state at the event (before it).
    trigger : int
        Element index whose guard fired.
    kind : str
        The guard's kind: ``"close"`` (an impact) or ``"release"`` (a persistent contact's
        force reached zero).

    Returns
    -------
    camsim.engine.integrator.State
        Velocities after the impulses, rigid branches STUCK or OPEN; events recorded
        (``impact`` per closing contact, ``stick``, ``release``).
    """

    model = integrator.model
    t = state.t
    u = integrator.inputs(np.array([t]))[0]
    branches = list(state.branches)
    rigid = [
        (pos, i) for pos, i in enumerate(model.switching)
        if Branch.STUCK in model.branch_options(i)
    ]
    touching = []
    sides = []
    for pos, i in rigid:
        delta, _ = integrator.relative_rate(state, i)
        if i == trigger or model.is_rigid(i, branches[pos]) or delta >= -TOUCH:
            touching.append((pos, i))
            d = float(model.deflection(i, state.x, u[0::N_INPUT]))
            sides.append(model.elements[i].contact_side(branches[pos], d))
    idx = [i for _, i in touching]
    J, js = _rows(model, idx, [sign for sign, _ in sides])
    minv = 1.0 / model.mass
    W = (J * minv[None, :]) @ J.T
    if idx and np.linalg.matrix_rank(W) < len(idx):
        raise SimulationError(
            "rigid contacts " + ", ".join(model.elements[i].name for i in idx)
            + f" over-constrain the masses at t = {t:.12g} s"
        )
    v = state.v.copy()
    w_minus = J @ v + _cam(js, u, 1)
    # a lash with a table per side: the restitution of the side touching
    e = np.array([0.0 if _chattering(integrator, i, t) else
                  (model.elements[i].acting(model.elements[i].stuck_branch(sign)).restitution or 0.0)
                  for i, (sign, _) in zip(idx, sides)])
    scale_v = 1.0 + float(np.max(np.abs(w_minus), initial=0.0))
    vel_tol = 1e-12 * scale_v
    closing = w_minus < -vel_tol

    # Relative accelerations with every touching contact open (for chatter and forces).
    open_branches = list(branches)
    for pos, _ in touching:
        open_branches[pos] = Branch.OPEN
    open_branches = tuple(open_branches)

    def open_accelerations(v_now, uu=u):
        config = model.configuration(open_branches, state.holds)
        z = config.state_from_input(state.x, v_now, uu)
        fn = integrator.nonlinear_forces(config, z[None, :], uu[None, :], state.v_impacts)
        acc = config.a(z[None, :], uu[None, :], fn)[0]
        return J @ acc + _cam(js, uu, 2), acc

    # ---- impulses (Newton's law per contact, one LCP)
    P = np.zeros(len(idx))
    if np.any(closing):
        q = w_minus - e * np.maximum(-w_minus, 0.0)
        P = solve_lcp(W, q, tol=1e-14 * scale_v)
        v = v + minv * (J.T @ P)
    w_plus = w_minus + W @ P
    for k, (pos, i) in enumerate(touching):
        if closing[k]:
            integrator._record(t, i, EventKind.IMPACT, -w_minus[k])

    # ---- which contacts rest: zero relative velocity, or a chatter that ends at once
    a_open, acc = open_accelerations(v)
    scale_a = 1.0 + float(np.max(np.abs(acc), initial=0.0)) + abs(model.gravity)
    acc_tol = 1e-10 * scale_a
    resting = []
    t_rest = {}  # k → when a chatter that rests now would have come to rest (its stick row)
    for k in range(len(idx)):
        if abs(w_plus[k]) <= vel_tol:
            resting.append(k)
        elif w_plus[k] > 0.0 and a_open[k] < -acc_tol:
            # Pressed closed while it rebounds: flights 2w/|a|, 2e·w/|a|, … ending after
            # 2w/(|a|(1 − e)), and the first rising w²/(2|a|). Within the touching band
            # (the chatter's Zeno limit near), unresolvable (the flight below the length
            # tolerance) or over within ZENO_TIME: it rests now.
            remaining = 2.0 * w_plus[k] / (-a_open[k] * (1.0 - min(e[k], 1.0 - 1e-16)))
            apex = w_plus[k] ** 2 / (-2.0 * a_open[k])
            scale_x = abs(sides[k][1]) + abs(float(J[k] @ state.x)) + abs(float(_cam(js[k : k + 1], u, 0)[0]))
            if apex < CHATTER_APEX and remaining <= CHATTER_SPAN:
                resting.append(k)
                t_rest[k] = t + remaining
            elif remaining < ZENO_TIME or apex < APEX_RTOL * scale_x:
                resting.append(k)
    stuck = set()
    if resting:
        candidates = list(resting)
        if kind == "release":
            # The trigger's force has just reached zero going down: it opens unless the
            # machine presses it closed outright.
            k_trig = idx.index(trigger)
            if k_trig in candidates and (a_open[k_trig] >= -acc_tol or _pressed_analytic(integrator, t, u, v, open_accelerations)[k_trig] >= -acc_tol):
                candidates.remove(k_trig)
        if candidates:
            Wc = W[np.ix_(candidates, candidates)]
            lam = solve_lcp(Wc, a_open[candidates], tol=1e-14 * scale_a * max(1.0, float(np.max(np.abs(Wc)))))
            a_after = a_open[candidates] + Wc @ lam
            for k, lk, ak in zip(candidates, lam, a_after):
                if kind == "release" and idx[k] == trigger:
                    # Its guard fired because the configuration's force on it is below
                    # -FORCE_TOL: it rests on only with a force this LCP can tell from zero.
                    # A pair moving on together without a force (λ = a = 0 to the tolerance
                    # of the accelerations) opens; kept stuck, the same guard fires again at
                    # the same instant for ever (a Zeno error at one instant).
                    if lk > FORCE_TOL:
                        stuck.add(k)
                elif lk > 0.0 or ak <= acc_tol:
                    stuck.add(k)
        # project the velocities of the persistent contacts onto zero relative velocity
        if stuck:
            S = sorted(stuck)
            Js, jss = J[S], js[S]
            residual = Js @ v + _cam(jss, u, 1)
            Ws = W[np.ix_(S, S)]
            v = v - minv * (Js.T @ np.linalg.solve(Ws, residual))

    # Penetrations left by a coarse grid (warm-up steps represent the cam input less
    # exactly than the event check evaluates it) are removed by the smallest mass-weighted
    # shift of positions (≤ nm), so that every guard holds after the event.
    # A contact that rests now is also placed exactly on its constraint when it is open by
    # less than TOUCH: the configuration that holds it reads the masses it joins through
    # its reduced coordinates, and a residual gap there (a few 1e-13 m) puts every other
    # guard through those masses that far from the value read here -- a guard at its zero
    # then stays violated after every resolution (a Zeno error at one instant).
    x = state.x.copy()
    pen = []
    for k, (pos, i) in enumerate(touching):
        delta, _ = integrator.relative_rate(state, i)
        if delta > 0.0 or (k in stuck and delta != 0.0):
            pen.append((k, delta))
    if pen:
        K = [k for k, _ in pen]
        d = np.array([dl for _, dl in pen])
        # δ = gap − (G·x + g_s·s): raise G·x by δ with the least Σ m·Δx²
        x = x + minv * (J[K].T @ np.linalg.solve(W[np.ix_(K, K)], d))
    for k, (pos, i) in enumerate(touching):
        was = branches[pos]
        was_stuck = model.is_rigid(i, was)
        now = model.elements[i].stuck_branch(sides[k][0]) if k in stuck else Branch.OPEN
        if now != Branch.OPEN and not was_stuck:
            integrator._record(t_rest.get(k, t), i, EventKind.STICK, 0.0)
        elif now == Branch.OPEN and was_stuck:
            integrator._record(t, i, EventKind.RELEASE, -w_plus[k])
        branches[pos] = now
    return State(t, x, v, tuple(branches), dict(state.v_impacts), state.holds)


def _chattering(integrator, i: int, t: float) -> bool:
    """Element i has taken CHATTER_IMPACTS − 1 impacts within CHATTER_SPAN before t and the
    flight ending now is at least half the first of them (a chatter that does not converge)."""
    times = []
    for event in reversed(integrator.events):
        if event.time < t - CHATTER_SPAN:
            return False
        if event.element_index == i and event.kind == EventKind.IMPACT:
            times.append(event.time)
            if len(times) >= CHATTER_IMPACTS - 1:
                first = times[-2] - times[-1]
                return first > 0.0 and t - times[0] >= 0.5 * first
    return False

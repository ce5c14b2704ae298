"""Closed nonlinear contacts: exact linear propagation plus an iterated remainder.

A configuration with one closed nonlinear contact (a power law, ``F = C·δ^a·(1 + χ·δ̇)``,
or Adams's IMPACT) obeys

    ż = A·z + B·u(t) + b + L·F(δ, δ̇),

δ and δ̇ affine in (z, u). Written around a linear contact law k·δ + c·δ̇,

    ż = A_J·z + B_J·u(t) + b + L·r(t),       r = F(δ, δ̇) − k·δ − c·δ̇,

where A_J, B_J hold the linear law (k, c near the tangent stiffness ∂F/∂δ and damping
∂F/∂δ̇ of the contact, which the element's ``nonlinear_tangent`` gives, on a geometric
ladder of ratio
:data:`LADDER` so that their exact step maps are built once and reused). The stiff
contact mode is then carried by the exact step map of the linear system
(:class:`camsim.engine.integrator.StepMaps`: Φ = e^{A_J·h} and the input integrals Γ_j), and only
the remainder r — smooth, and small wherever the contact stiffness changes slowly — is
iterated, as an input given on each grid step by its cubic Hermite interpolant
(r and ṙ at both ends, both exact functions of the state):

1. guess r on a window of grid steps (the value at the window's start);
2. propagate the whole window at once with the modal recurrence (numpy speed);
3. recompute r and ṙ at every node from the propagated states; repeat until r moves
   by less than :data:`RTOL` of the contact force (a fixed point: then the nodes satisfy
   the nonlinear equation up to the interpolation of r, whose error is h⁴·r⁗/384).

This is a waveform relaxation with an exponential (Lawson / Rosenbrock-type) splitting
(Hochbruck & Ostermann, Acta Numerica 19 (2010) 209). Its contraction per iteration is
about |k_t − k|/k times the dynamic amplification of the remainder, so it converges in a
few iterations while the contact rests closed and the stiffness drifts slowly — the
phase that costs a general-purpose Runge–Kutta most — and the window grows there. Where
it does not converge (the short bounces, where k_t sweeps from 0 to its peak within a
few steps) the window is handed to the adaptive Runge–Kutta (DOP853) of
:meth:`camsim.engine.integrator.Integrator._advance_nonlinear` for a few grid steps.

Events: guard values and their exact rates (with the true ż) are known at every node; a
sign change or a cubic-Hermite dip marks the step, and that step is integrated again by
DOP853 from its start node with the guards as terminal events, so events are located
exactly as before (to ~1e-12 s).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from camsim.engine.collocation import Collocation, collocation_steps
from camsim.engine.windows import INTERP_TOL, LADDER, _first_hit, _fresh
from camsim.model.assembly import N_INPUT
from camsim.engine.recurrence import linear_recurrences
from camsim.engine.state import TIME_EPS, State, Stretch
from camsim.engine.stepping import _FACT, _P, StepMaps, exact_partial, forcing_coefficients, step_input_derivatives

#: A window keeps the previous window's linear law while the tangent values stay within
#: this relative distance of it (fewer step maps to build).
HYSTERESIS = 0.12
#: Convergence: the remainder moves by less than this times the peak contact force.
#: A relative force error ε is a relative penetration error ε/a (F ∝ δ^a): 1e-10 keeps the
#: contact's penetration within about 1e-10·δ over a window, 1e-15 m for the CDTM seat
#: (δ ≈ 1e-5 m at 150 lbf), well under the absolute tolerance of the DOP853 path (1e-13 m).
#: Tighter values change no figure of bench/bench_contacts.py and cost iterations; at 1e-9
#: tests/test_nonlinear_stepper.py sees 2.4e-9 of the static penetration (its bar: 1e-9).
RTOL = 1e-10
#: Depth of the Anderson acceleration of the iteration.
ANDERSON = 3
#: A window is cut where the contact's tangent stiffness has drifted from the window's
#: linear law by more than this fraction (the iteration's contraction factor is about the
#: drift), after at least MIN_CUT steps.
DRIFT = 0.1
MIN_CUT = 8
#: A window whose penetration's Taylor polynomial (δ, δ̇, δ̈ at its start) changes by more
#: than this fraction of itself over FIRST_WINDOW steps is not tried (see advance_power).
SWEEP = 0.5
#: Most iterations per window.
MAX_ITER = 16
#: Window lengths in grid steps: the shortest (after a contact's onset, and what a window
#: that does not converge is quartered down to) and the largest (a converged window doubles).
FIRST_WINDOW = 16
MAX_WINDOW = 1024
#: The first window of a stretch with no history (a run's start, a configuration entered
#: with the contact closed) and of one after the collocation found the contact calm.
#: Long: the window is cut where the contact's tangent stiffness leaves its linear law
#: (DRIFT), so its length only bounds the cut, and the cost of a window is mostly per
#: window and per iteration, not per step (measured on cdtm-power: about 0.11 ms a
#: window and 0.08 ms an iteration). Starting at FIRST_WINDOW and doubling took six
#: windows and 28 iterations where one window takes 6 (bench/bench_contacts.py, 3.8 ms
#: of 80 per revolution).
CALM_WINDOW = MAX_WINDOW
#: Where the iteration does not converge, take exponential-collocation steps
#: (:mod:`camsim.engine.collocation`) before handing a step to DOP853.
COLLOCATION = True
#: Grid steps of DOP853 from a contact's onset before the collocation takes over.
ONSET_STEPS = 2
#: Grid steps of DOP853 before the collocation is tried again where it took no step.
COLLOC_RETRY = 8
#: Collocation from a contact's onset (after ONSET_STEPS of DOP853). Off: DOP853 then
#: carries FALLBACK_STEPS from the onset (a whole bounce of the CDTM's seat) and the
#: collocation only takes over where the iteration fails. Measured on cdtm-power
#: (bench/bench_contacts.py): on, the cost is the same, but DOP853 restarted mid-bounce
#: crosses the release with its velocity ~1e-8 m/s off (it is restarted where the
#: collocation rejects a step, and starts with a step size its history would not allow),
#: which the following bounces amplify to 6e-9 of the displacement against 4e-10 off.
ONSET_COLLOC = False
#: After the onset's DOP853 span, go on by collocation (not a window of the iteration,
#: which fails there).
AFTER_ONSET = True
#: Grid steps handed to DOP853 where the iteration does not converge.
FALLBACK_STEPS = 8
#: Grid steps per call of the collocation (solved together, camsim.engine.collocation).
COLLOC_STEPS = 8


@dataclass
class _LinearLaw:
    """A configuration-like linear system (the attributes StepMaps and exact_partial use)."""

    A: np.ndarray
    B: np.ndarray
    b: np.ndarray
    cache: dict = field(default_factory=dict)

    @property
    def dim(self) -> int:
        return self.A.shape[0]


class PowerContactStepper:
    """Per-configuration data of the iterated-remainder stepper (cached on the integrator)."""

    def __init__(self, integrator, config):

        self.integrator = integrator
        self.config = config
        model = integrator.model
        (self.index,) = config.power_contacts
        delta, rate = integrator._delta(config, self.index)
        self.dz, self.du, self.de = delta.Cz[0], delta.Du[0], float(delta.e[0])
        self.rz, self.ru, self.re = rate.Cz[0], rate.Du[0], float(rate.e[0])
        self.element = model.elements[self.index]
        self.v_impact = None
        self.L = config.L[:, 0]
        self.laws: dict[tuple[int, int], tuple[_LinearLaw, object, np.ndarray]] = {}

    # ------------------------------------------------------------------ contact law
    def chi(self, v_impacts) -> float:
        """Set the closed phase's approach speed (the law's damping may depend on it)."""
        self.v_impact = v_impacts.get(self.index)
        return 0.0

    def law(self, k: float, c: float):
        """(linear system, its StepMaps, W_L) for the ladder rungs nearest k, c."""

        ik = round(math.log(max(k, 1e-300)) / math.log(LADDER)) if k > 0 else -(10**9)
        ic = round(math.log(c) / math.log(LADDER)) if c > 0 else -(10**9)
        key = (ik, ic)
        hit = self.laws.get(key)
        if hit is None:
            kq = LADDER**ik if k > 0 else 0.0
            cq = LADDER**ic if c > 0 else 0.0
            cfg = self.config
            A = cfg.A + np.outer(self.L, kq * self.dz + cq * self.rz)
            B = cfg.B + np.outer(self.L, kq * self.du + cq * self.ru)
            b = cfg.b + self.L * (kq * self.de + cq * self.re)
            lin = _LinearLaw(A, B, b)
            maps = StepMaps(lin, self.integrator.h, series=True)
            WL = np.array([maps.Gamma[j] @ self.L for j in range(4)])  # (4, m)
            hit = (lin, maps, WL, kq, cq)
            if len(self.laws) > 512:
                self.laws.clear()
            self.laws[key] = hit
        return hit

    def force(self, z, u, chi):
        """δ, δ̇, F, ∂F/∂δ, ∂F/∂δ̇ at nodes (arrays), from the element's law."""
        d = z @ self.dz + u @ self.du + self.de
        dd = z @ self.rz + u @ self.ru + self.re
        F, kt, ct = self.element.nonlinear_tangent(d, dd, self.v_impact)
        return d, dd, F, kt, ct


def _kept_modes(maps):
    """(μ, to_modes, from_modes) of a modal StepMaps' kept modes: their multipliers, the
    projection z → w and the reconstruction w → z (weights folded in), cached on the maps."""
    modes = maps.__dict__.get("_kept_modes")
    if modes is None:
        keep = maps.keep
        modes = maps._kept_modes = (maps.mu[keep], maps.Vinv[keep].T.copy(),
                                    (maps.V[:, keep] * maps.weights[keep]).T.copy())
    return modes


def _releasing(delta, rate, h):
    """A contact unloading so fast that it releases within one collocation call at its
    present rate (the collocation would refuse the step; DOP853 goes on)."""
    return rate < 0.0 and delta + rate * COLLOC_STEPS * h < 0.0


def _propagate(maps, z0, g):
    """z_{k+1} = Φ·z_k + g_k for all k (modal recurrence when available)."""
    K = g.shape[0]
    if maps.modal:
        mu, to_modes, from_modes = _kept_modes(maps)
        W = linear_recurrences(mu, g @ to_modes, z0 @ to_modes)
        return (W @ from_modes).real
    out = np.empty((K, z0.size))
    z = z0
    for k in range(K):
        z = maps.Phi @ z + g[k]
        out[k] = z
    return out


def advance_power(integrator, state, config, z0, guards, t_stop, record):
    """Integrate a configuration with one closed power-law contact (see module docstring).

    Same contract as :meth:`camsim.engine.integrator.Integrator._advance_nonlinear`: returns the
    state at the end, the recorded stretch and the guard that fired (or None).
    """

    integ = integrator
    steppers = integ.__dict__.setdefault("_power_steppers", {})
    stepper = steppers.get(config.branches)
    if stepper is None:
        stepper = PowerContactStepper(integ, config)
        steppers[config.branches] = stepper
    h = integ.h
    chi = stepper.chi(state.v_impacts)
    A, B, b, L = config.A, config.B, config.b, stepper.L
    # δ̈ = rz·ż + ru·u̇ with ż = A·z + B·u + b + L·F, folded into vectors (one matrix-vector
    # product per node set instead of forming ż in the iteration)
    rate_A, rate_B, rate_b, rate_L = A.T @ stepper.rz, B.T @ stepper.rz, float(b @ stepper.rz), float(L @ stepper.rz)
    # δ, δ̇ and δ̈'s linear part in one product: [δ, δ̇, δ̈ − rate_L·F] = z·proj_z + u·proj_u + proj_e
    # (+ u̇·ru in the third column)
    proj_z = np.column_stack([stepper.dz, stepper.rz, rate_A])
    proj_u = np.column_stack([stepper.du, stepper.ru, rate_B])
    proj_e = np.array([stepper.de, stepper.re, rate_b])
    v_imp = state.v_impacts
    pieces: list[tuple[np.ndarray, np.ndarray, np.ndarray]] = []
    t, z = state.t, z0
    # a stretch that continues the previous one of this configuration (it stopped at a
    # cam segment join or an output stop, not at an event) starts with its window length
    hint = stepper.__dict__.get("resume")
    window = hint[1] if hint is not None and hint[0] == state.t else CALM_WINDOW
    stepper.resume = None
    first = True
    cur = state
    r_prev = None
    last_law = None
    fails = 0  # windows in a row that did not converge (the fallback span grows)
    can_collocate = COLLOCATION and getattr(stepper.element, "analytic_closed", False)
    colloc_next = False  # the next stretch goes to the collocation

    def finish(end_state, fired):
        stretch = None
        if record and pieces:
            ts = np.concatenate([p[0] for p in pieces])
            if ts.size:
                Zs = np.concatenate([p[1] for p in pieces])
                Us = np.concatenate([p[2] for p in pieces])
                fn = integ.nonlinear_forces(config, Zs, Us, v_imp)
                stretch = Stretch(state.branches, config, ts, Zs, Us, fn, dict(v_imp))
        return end_state, stretch, fired

    def collocate(t_from, z_from, n_steps, just_started):
        coll = stepper.__dict__.get("collocation")
        if coll is None:
            coll = stepper.collocation = Collocation(integ, config, stepper)
        return collocation_steps(integ, stepper, config, coll, t_from, z_from, n_steps, t_stop, guards,
                                 just_started, chi)

    def fallback(t_from, z_from, n_steps, just_started, releasing_steps=0):
        """DOP853 over n grid steps from (t_from, z_from); returns (t, z, fired, end).
        With ``releasing_steps``, the same span goes on for up to that many more grid
        steps if the contact is releasing at the n-th (see dop853_span)."""
        k_end = math.floor((t_from - integ.t_ref) / h + 1e-7) + n_steps
        t_lim = min(t_stop, integ.t_ref + k_end * h)
        t_more = min(t_stop, t_lim + releasing_steps * h) if releasing_steps else None
        gs = guards if just_started else _fresh(guards)
        t_end, z_end, stretch, fired = dop853_span(integ, t_from, cur, config, z_from, gs, t_lim, record, stepper,
                                                   releasing_to=t_more)
        if stretch is not None:
            pieces.append((stretch.t, stretch.z, stretch.u))
        # the full state only where an event needs it (elsewhere a placeholder, as below)
        end = integ._state_from(config, z_end, t_end, cur) if fired is not None else State(
            t_end, cur.x, cur.v, cur.branches, cur.v_impacts)
        return t_end, z_end, fired, end

    while True:
        if t >= t_stop - TIME_EPS:
            stepper.resume = (t_stop, window)
            return finish(integ._state_from(config, z, t_stop, cur), None)
        if colloc_next:
            # exponential collocation step by step (camsim.engine.collocation) while the contact
            # stiffness sweeps (the iteration would not converge); DOP853 for a step it does
            # not accept and for a step where a guard may cross
            colloc_next = False
            any_taken = hit = False
            d_now, dd_now = stepper.force(z[None, :], integ._node_input(t)[None, :], chi)[:2]
            # a contact unloading fast enough to release within a collocation call: the
            # collocation would refuse its singular end, so DOP853 goes on at once
            releasing = _releasing(d_now[0], dd_now[0], h)
            while not releasing:
                t_c, z_c, taken, hit, calm = collocate(t, z, COLLOC_STEPS * 2 ** min(fails, 3), first)
                if taken is None:
                    break
                any_taken = True
                if record:
                    mask = integ._on_grid(taken[0][:-1])
                    pieces.append((taken[0][:-1][mask], taken[1][:-1][mask], taken[2][:-1][mask]))
                t, z = t_c, z_c
                cur = State(t, cur.x, cur.v, cur.branches, cur.v_impacts)
                first = False
                if hit or calm or t >= t_stop - TIME_EPS:
                    break
            if any_taken and not hit:
                window = CALM_WINDOW
                r_prev = None
                continue
            t, z, fired, cur = fallback(t, z, 2 if any_taken else COLLOC_RETRY, first)
            first = False
            if fired is not None:
                return finish(cur, fired)
            colloc_next = True
            continue
        # ---- the window's nodes: t, the grid points after it, its end
        k_end = math.floor((t - integ.t_ref) / h + 1e-7) + window
        t_end = min(t_stop, integ.t_ref + k_end * h)
        k0 = math.ceil((t - integ.t_ref) / h - 1e-7)
        k1 = math.ceil((t_end - integ.t_ref) / h - 1e-7)
        if k0 < k1 and integ.t_ref + k0 * h <= t + TIME_EPS:
            k0 += 1
        if k0 < k1 and integ.t_ref + (k1 - 1) * h >= t_end - TIME_EPS:
            k1 -= 1
        nodes = np.concatenate([[t], integ.t_ref + np.arange(k0, k1) * h, [t_end]])
        steps = np.diff(nodes)
        full = np.abs(steps - h) <= 1e-9 * h
        if nodes.size < 3 or not np.all(full[1:-1]):
            # too short to iterate usefully: DOP853 to the window's end
            t, z, fired, cur = fallback(t, z, max(window, 1), first)
            first = False
            if fired is not None:
                return finish(cur, fired)
            continue
        # ---- the contact at the window's start (the window's inputs only once it is tried)
        u0 = integ._node_input(t)
        d0, dd0, F0, kt0, ct0 = stepper.force(z[None, :], u0[None, :], chi)
        if F0[0] <= 0.0 or 0.0 <= d0[0] < dd0[0] * h:
            # the contact's onset (δ = 0, or closing and less than one grid step's approach
            # deep: F ∝ δ^a is not smooth there, and no window of the iteration converges
            # across it): DOP853, then on by collocation
            onset_colloc = can_collocate and ONSET_COLLOC
            # (a contact releasing at the span's end goes on in the same span: the step
            # the collocation would hand back to DOP853 at once, without a restart)
            t, z, fired, cur = fallback(t, z, ONSET_STEPS if onset_colloc else FALLBACK_STEPS, first,
                                        0 if onset_colloc else COLLOC_RETRY)
            first = False
            if fired is not None:
                return finish(cur, fired)
            window = FIRST_WINDOW
            colloc_next = can_collocate and (onset_colloc or AFTER_ONSET)
            continue
        if can_collocate:
            # the penetration's Taylor polynomial over the first window (δ̈ from the true
            # ż): where it changes by more than SWEEP of itself (a bounce under way, or a
            # contact unloading fast), no window converges; the collocation, or DOP853
            ddd0 = float((z @ proj_z + u0 @ proj_u + proj_e)[2] + u0[1:] @ stepper.ru[:3] + F0[0] * rate_L)
            tw = FIRST_WINDOW * h
            if abs(dd0[0] * tw + 0.5 * ddd0 * tw * tw) > SWEEP * d0[0] or abs(dd0[0]) * MIN_CUT * h > d0[0]:
                colloc_next = True
                continue
        U = integ.chunk_inputs(nodes, k0, k1)
        D = step_input_derivatives(U[:-1], U[1:], steps, h)
        Udot = np.zeros_like(U)  # u̇ = [ṡ, s̈, s⃛, s⁗]; B and the guards take no s⁗
        Udot[:, :3] = U[:, 1:]
        # ---- linear law at the window's start (tangent values on the ladder)
        k_now, c_now = float(kt0[0]), float(ct0[0])
        # (as differences, not ratios: a contact at the edge of its law can have a zero
        # tangent stiffness, and k_now / 0 raised ZeroDivisionError; issue 25)
        if last_law is not None and abs(k_now - last_law[3]) <= HYSTERESIS * abs(last_law[3]) and (
            abs(c_now - last_law[4]) <= HYSTERESIS * abs(last_law[4])
        ):
            lin, maps, WL, kq, cq = last_law
        else:
            lin, maps, WL, kq, cq = last_law = stepper.law(k_now, c_now)
        g_u = D @ maps.W + maps.g0  # cam-input part of each full step's forcing
        K = steps.size
        r0 = float(F0[0] - kq * d0[0] - cq * dd0[0])
        if r_prev is not None and r_prev[2] == kq and r_prev[3] == cq:
            # continue the previous window's remainder: its value and rate at the join
            # (same linear law), extrapolated linearly
            r = r_prev[0] + r_prev[1] * (nodes - t)
            rd = np.full(K + 1, r_prev[1])
            r[0] = r0
        else:
            r = np.full(K + 1, r0)
            rd = np.zeros(K + 1)
        # ---- the window's states are linear in the remainder: the part driven by the start
        # state and the cam input (Zu) is propagated once per window, and each iteration
        # propagates only the remainder's part (from zero), projected in one product on
        # δ, δ̇ and δ̈'s linear part (Yu holds the same projection of Zu and of the input)
        first_map = _step_affine(lin, maps, WL, L, bool(full[0]), float(steps[0]), D[0], g_u[0])
        last_map = _step_affine(lin, maps, WL, L, bool(full[-1]), float(steps[-1]), D[-1], g_u[-1])
        Zu = np.empty((K + 1, z.size))
        Zu[0] = z
        Zu[1] = first_map[0] @ z + first_map[1]
        if K > 2:
            Zu[2:K] = _propagate(maps, Zu[1], g_u[1 : K - 1])
        Zu[K] = last_map[0] @ Zu[K - 1] + last_map[1]
        Yu = Zu @ proj_z + U @ proj_u + proj_e
        Yu[:, 2] += Udot @ stepper.ru
        resp = _RemainderResponse(maps, WL, proj_z, h, steps, first_map, last_map, K, z.size)
        X = np.column_stack([r, rd * h])  # the iterate: (r, h·ṙ) at each node
        ok = False
        scale = max(abs(float(F0[0])), 1e-300)
        prev_change = math.inf
        anderson = _Anderson(ANDERSON)
        for it in range(MAX_ITER):
            # the remainder's part of δ, δ̇ and δ̈'s linear part at the nodes (its cubic
            # Hermite per step as the input)
            Y = Yu + resp.project(X)
            d, dd = Y[:, 0], Y[:, 1]
            F, kt, ct = stepper.element.nonlinear_tangent(d, dd, stepper.v_impact)
            ddd = Y[:, 2] + F * rate_L  # δ̈ = rz·ż + ru·u̇
            GX = np.empty_like(X)
            r_new = GX[:, 0]
            np.subtract(F - kq * d, cq * dd, out=r_new)
            np.multiply(kt * dd + ct * ddd - kq * dd - cq * ddd, h, out=GX[:, 1])
            if K > 2 * MIN_CUT:
                # The window reaches where the contact stiffness has left its linear law by
                # more than DRIFT (or the force vanishes): the iteration would contract
                # slowly there, or not at all. The nodes before do not depend on the nodes
                # after (causality), so the window is cut there and its iterates kept.
                drift = (np.abs(kt[1:] - kq) > DRIFT * kq) | (F[1:] <= 0.0)
                far = np.flatnonzero(drift)
                if far.size and MIN_CUT <= far[0] < K - 1:
                    K = int(far[0])
                    nodes, steps, full = nodes[: K + 1], steps[:K], full[:K]
                    U, D, Udot, g_u = U[: K + 1], D[:K], Udot[: K + 1], g_u[:K]
                    X, GX, r_new, F = X[: K + 1], GX[: K + 1], r_new[: K + 1], F[: K + 1]
                    Zu, Yu = Zu[: K + 1], Yu[: K + 1]
                    last_map = _step_affine(lin, maps, WL, L, True, h, D[-1], g_u[-1])
                    resp.cut(K, last_map)
                    anderson.cut(2 * (K + 1))
                    window = K
            change = float(np.max(np.abs(r_new - X[:, 0])))
            scale = max(scale, float(np.max(np.abs(F))))
            if change <= RTOL * scale:
                X = GX
                ok = True
                break
            if it >= 5 and change > prev_change:
                break  # not contracting: too far from the linear law
            prev_change = change
            X = anderson.next(X, GX)
        r = X[:, 0]
        Zr = resp.states()
        Z = Zu + Zr
        if ok and K >= 6:  # Δ⁴ of the K − 1 inner nodes needs five of them (K = 5 raised on an empty max)
            # The remainder is carried by its cubic Hermite per step, whose error is
            # h⁴·|r⁗|/384 ≈ |Δ⁴r|/384: where that is not negligible (a bounce, the
            # stiffness sweeping within a few steps) the window goes to DOP853 instead.
            # (Δ⁴ of the K - 1 inner nodes needs K >= 6; a window cut short by the stop
            # time can have K = 5.)
            ok = float(np.max(np.abs(np.diff(r[1:-1], 4)))) / 384.0 <= INTERP_TOL * scale
        if not ok or np.any(F <= 0.0):
            r_prev = None
            if window > FIRST_WINDOW:
                window = max(FIRST_WINDOW, window // 4)
                continue
            n_fallback = FALLBACK_STEPS * 2 ** min(fails, 3)
            fails += 1
            if can_collocate:
                colloc_next = True
                continue
            t, z, fired, cur = fallback(t, z, n_fallback, first)
            first = False
            if fired is not None:
                return finish(cur, fired)
            continue
        fails = 0
        zdot = Z @ A.T + U @ B.T + b + np.outer(F, L)
        # ---- guards on the nodes: values and exact rates
        hit_step = _first_hit(guards, Z, U, zdot, Udot, F, steps, first)
        if hit_step is not None:
            keep = nodes[: hit_step + 1]
            if record:
                mask = integ._on_grid(keep[:-1]) if hit_step > 0 else np.zeros(0, bool)
                if hit_step > 0:
                    pieces.append((keep[:-1][mask], Z[:hit_step][mask], U[:hit_step][mask]))
            t_from, z_from = nodes[hit_step], Z[hit_step]
            just = first and hit_step == 0
            t, z, fired, cur = fallback(t_from, z_from, 2, just)
            first = False
            if fired is not None:
                return finish(cur, fired)
            r_prev = None
            continue
        if record:
            mask = integ._on_grid(nodes[:-1])
            pieces.append((nodes[:-1][mask], Z[:-1][mask], U[:-1][mask]))
        t, z = nodes[-1], Z[-1]
        cur = State(t, cur.x, cur.v, cur.branches, cur.v_impacts)
        first = False
        r_prev = (float(X[-1, 0]), float(X[-1, 1]) / h, kq, cq)
        window = min(window * 2, MAX_WINDOW)


class _RemainderResponse:
    """The part of a window's states driven by the remainder (from zero), given (r, h·ṙ)
    at the nodes, each step's input being r's cubic Hermite on it.

    Each iteration needs only its projection on δ, δ̇ and δ̈'s linear part (``proj_z``),
    which :meth:`project` forms in modal coordinates (the forcing is linear in the
    step's end values: one product with constant matrices per iteration, no state
    vectors); :meth:`states` builds the states of the last call once, at the end.
    """

    def __init__(self, maps, WL, proj_z, h, steps, first_map, last_map, K, n):
        self.maps, self.WL, self.proj_z, self.h = maps, WL, proj_z, h
        self.first_map, self.last_map, self.K, self.n = first_map, last_map, K, n
        self.tau_first, self.tau_last = float(steps[0]), float(steps[-1])
        self.modal = _modal_remainder(maps, WL, proj_z, h) if maps.modal else None
        self._last = None

    def cut(self, K, last_map):
        """The window now ends at node K (its last step a full one, ``last_map``)."""
        self.K, self.last_map, self.tau_last = K, last_map, self.h

    def _hermite(self, xa, xb, tau):
        """(r, ṙ, r̈, r⃛) at a step's start from (r, h·ṙ) at its ends, step length tau."""
        h = self.h
        ra, rda, rb, rdb = xa[0], xa[1] / h, xb[0], xb[1] / h
        c2 = (3.0 * (rb - ra) / tau - 2.0 * rda - rdb) / tau
        c3 = (2.0 * (ra - rb) / tau + rda + rdb) / (tau * tau)
        return np.array([ra, rda, 2.0 * c2, 6.0 * c3])

    def project(self, X):
        """(K + 1, 3): the remainder's part of [δ, δ̇, δ̈'s linear part] (the columns of
        ``proj_z``) at the nodes."""
        K = self.K
        ends = X[[0, 1, K - 1, K]].tolist()
        z1 = self._hermite(ends[0], ends[1], self.tau_first) @ self.first_map[2]
        Yr = np.zeros((K + 1, self.proj_z.shape[1]))
        Yr[1] = z1 @ self.proj_z
        if K > 2:
            if self.modal is not None:
                mu, to_modes, from_modes, H, from_proj = self.modal
                # forcing of the middle steps in modal coordinates, from the rows
                # [r_k, h·ṙ_k, r_k+1, h·ṙ_k+1] (a strided view of X, no copy)
                X = np.ascontiguousarray(X)
                pairs = np.ndarray((K - 2, 4), dtype=float, buffer=X, offset=2 * X.itemsize, strides=(2 * X.itemsize, X.itemsize))
                forcing = (pairs @ H).view(complex)
                W = linear_recurrences(mu, forcing, z1 @ to_modes)
                Yr[2:K] = W.view(float) @ from_proj
                z_before = (W[-1] @ from_modes).real
            else:
                xs = X.tolist()
                R = np.empty((K - 2, 4))
                for k in range(1, K - 1):
                    R[k - 1] = self._hermite(xs[k], xs[k + 1], self.h)
                W = _propagate(self.maps, z1, R @ self.WL)
                Yr[2:K] = W @ self.proj_z
                z_before = W[-1]
        else:
            W, z_before = None, z1
        zK = self.last_map[0] @ z_before + self._hermite(ends[2], ends[3], self.tau_last) @ self.last_map[2]
        Yr[K] = zK @ self.proj_z
        self._last = (K, z1, W, zK)
        return Yr

    def states(self):
        """(K + 1, n): the remainder's part of the states of the last :meth:`project`."""
        K, z1, W, zK = self._last
        Zr = np.zeros((K + 1, self.n))
        Zr[1] = z1
        if W is not None:
            Zr[2:K] = (W @ self.modal[2]).real if self.modal is not None else W
        Zr[K] = zK
        return Zr[: self.K + 1]  # a window cut after the last projection ends earlier


def _modal_remainder(maps, WL, proj_z, h):
    """Per linear law (cached on its maps): the kept modes' multipliers, projection and
    reconstruction, the middle steps' forcing matrix H (4, 2·modes: rows for r_k, h·ṙ_k,
    r_k+1, h·ṙ_k+1, columns the modes' real and imaginary parts interleaved, so that a real
    product viewed as complex is the modal forcing), and the reconstruction projected on
    ``proj_z`` for the interleaved real view of the modal states (2·modes, 3)."""
    hit = maps.__dict__.get("_remainder_modal")
    if hit is None:
        mu, to_modes, from_modes = _kept_modes(maps)
        WLm = WL @ to_modes  # (4, modes): r, ṙ, r̈, r⃛ at a step's start → modal forcing
        # the cubic Hermite's Taylor terms at a step's start in the end values (r, h·ṙ):
        # r̈ = (6·Δr/h − 4·ṙ_a − 2·ṙ_b)/h, r⃛ = (12·(−Δr)/h + 6·(ṙ_a + ṙ_b))/h²
        T = np.array([
            [1.0, 0.0, -6.0 / h**2, 12.0 / h**3],  # r_a
            [0.0, 1.0 / h, -4.0 / h**2, 6.0 / h**3],  # h·ṙ_a
            [0.0, 0.0, 6.0 / h**2, -12.0 / h**3],  # r_b
            [0.0, 0.0, -2.0 / h**2, 6.0 / h**3],  # h·ṙ_b
        ])
        Hc = T @ WLm
        H = np.empty((4, 2 * mu.size))
        H[:, 0::2], H[:, 1::2] = Hc.real, Hc.imag
        P = from_modes @ proj_z  # (modes, columns of proj_z)
        from_proj = np.empty((2 * mu.size, P.shape[1]))
        from_proj[0::2], from_proj[1::2] = P.real, -P.imag
        hit = maps._remainder_modal = (mu, to_modes, from_modes, H, from_proj)
    return hit


class _Anderson:
    """Anderson acceleration (type II, depth m) of a fixed point x = G(x) (Walker & Ni,
    SIAM J. Numer. Anal. 49 (2011) 1715), on the iterate's flattened values."""

    def __init__(self, depth):
        self.depth = depth
        self.dF: list[np.ndarray] = []
        self.dG: list[np.ndarray] = []
        self.prev = None

    def cut(self, size):
        """Keep the first ``size`` values of the history (a window cut short)."""
        self.dF = [v[:size] for v in self.dF]
        self.dG = [v[:size] for v in self.dG]
        if self.prev is not None:
            self.prev = (self.prev[0][:size], self.prev[1][:size])

    def next(self, X, GX):
        """The next iterate from x and G(x) (arrays of one shape)."""
        g = GX.reshape(-1)
        f = g - X.reshape(-1)
        if self.prev is not None:
            self.dF.append(f - self.prev[0])
            self.dG.append(g - self.prev[1])
            if len(self.dF) > self.depth:
                del self.dF[0], self.dG[0]
        self.prev = (f, g)
        if not self.dF:
            return GX
        dF = np.column_stack(self.dF)
        # least squares min |f − dF·γ| by its normal equations (at most `depth` unknowns;
        # a relative ridge of 1e-13 keeps nearly dependent differences harmless)
        gram = (dF.T @ np.column_stack([dF, f])).tolist()
        gamma = _solve_small([row[:-1] for row in gram], [row[-1] for row in gram], 1e-13)
        out = g.copy()
        for c, v in zip(gamma, self.dG):
            out -= c * v
        return out.reshape(GX.shape)


def _solve_small(G, b, ridge):
    """Solve (G + ridge·tr(G)·I)·x = b for a small symmetric positive semi-definite G
    (lists of floats; Cholesky, plain Python: a 3×3 system costs less than numpy's call)."""
    n = len(b)
    shift = ridge * sum(G[i][i] for i in range(n)) + 1e-300
    Lc = [[0.0] * n for _ in range(n)]
    for i in range(n):
        for j in range(i + 1):
            v = G[i][j] + (shift if i == j else 0.0) - sum(Lc[i][k] * Lc[j][k] for k in range(j))
            Lc[i][j] = math.sqrt(max(v, shift)) if i == j else v / Lc[j][j]
    y = [0.0] * n
    for i in range(n):
        y[i] = (b[i] - sum(Lc[i][k] * y[k] for k in range(i))) / Lc[i][i]
    x = [0.0] * n
    for i in reversed(range(n)):
        x[i] = (y[i] - sum(Lc[k][i] * x[k] for k in range(i + 1, n))) / Lc[i][i]
    return x


def _step_affine(lin, maps, WL, L, full, tau, D_k, g_u_k):
    """One step of a window as an affine map: (P, c, W) with z⁺ = P·z + c + R·W, R the
    remainder's Taylor terms (r, ṙ, r̈, r⃛) at the step's start. A full step uses the law's
    maps; a partial one (a window's first or last) the exact maps of its own length."""
    from camsim.engine.stepping import phi_series

    if full:
        return maps.Phi, g_u_k, WL
    E = forcing_coefficients(lin, D_k[None, :])[0]
    series = phi_series(lin.A, tau)
    if series is not None:
        Phi, Gamma = series
        return Phi, np.tensordot(Gamma, E, axes=([0, 2], [0, 1])), Gamma[:4] @ L
    # beyond the series' norm bound: the augmented expm, column by column (rare)
    n = lin.A.shape[0]
    zero = np.zeros_like(E)
    P = np.column_stack([exact_partial(lin, e, zero, tau) for e in np.eye(n)])
    W = np.empty((4, n))
    for j in range(4):
        Ej = zero.copy()
        Ej[j] = L
        W[j] = exact_partial(lin, np.zeros(n), Ej, tau)
    return P, exact_partial(lin, np.zeros(n), E, tau), W


class _FastInput:
    """u(t) = [s, ṡ, s̈, s⃛] on [t0, t1] from the grid steps' degree-7 Hermite polynomials,
    built for the whole span in one vectorised pass (a right-hand side evaluated
    thousands of times then costs one small matrix product)."""

    def __init__(self, integ, t0, t1):

        h = integ.h
        k0 = math.ceil((t0 - integ.t_ref) / h - 1e-7)
        k1 = math.floor((t1 - integ.t_ref) / h + 1e-7)
        if k0 <= k1 and integ.t_ref + k0 * h <= t0 + TIME_EPS:
            k0 += 1
        inner = integ.t_ref + np.arange(k0, k1 + 1) * h
        inner = inner[(inner > t0 + TIME_EPS) & (inner < t1 - TIME_EPS)]
        nodes = np.concatenate([[t0], inner, [t1]])
        U = np.empty((nodes.size, N_INPUT))
        U[0] = integ._node_input(t0)
        if inner.size:
            ks = np.round((inner - integ.t_ref) / h).astype(int)
            U[1:-1] = integ._grid_inputs(int(ks[0]), int(ks[-1]) + 1)
        U[-1] = integ._node_input(t1)
        if t1 in integ._joins:
            s_, v_, a_, j_ = integ.cam.svaj(np.array([t1]), side="left")
            U[-1] = [s_[0], v_[0], a_[0], j_[0]]
        D = step_input_derivatives(U[:-1], U[1:], np.diff(nodes), h)
        Dp = np.concatenate([D, np.zeros((D.shape[0], 3))], axis=1)
        fact = _FACT[: _P + 1]
        # C[k, c, j] = D_{j+c}/j!  so that u_c(τ) = Σ_j C[k, c, j]·τ^j
        self.C = np.stack([Dp[:, c : c + _P + 1] / fact for c in range(N_INPUT)], axis=1)
        self.starts = nodes[:-1]
        self.powers = np.arange(_P + 1)
        self.last = nodes.size - 2

        self.h = h
        self.t1 = float(self.starts[1]) if self.starts.size > 1 else math.inf

    def index(self, t: float) -> int:
        """The step holding t (the first from its start node on)."""
        if t < self.t1:
            return 0
        k = 1 + int((t - self.t1) / self.h)
        if k > self.last:
            return self.last
        if t < self.starts[k]:  # rounding at a node
            k -= 1
        return k

    def __call__(self, t):
        k = self.index(t)
        return self.C[k] @ ((t - self.starts[k]) ** self.powers)

    def project(self, g):
        """g·u(t) as a function of a float t, in plain floats (Horner on the projected
        polynomial of the step holding t)."""
        coeffs = [row[::-1] for row in np.einsum("c,kcj->kj", g, self.C).tolist()]
        starts, index = self.starts.tolist(), self.index

        def at(t):
            k = index(t)
            x = t - starts[k]
            y = 0.0
            for c in coeffs[k]:
                y = y * x + c
            return y

        return at


def dop853_span(integ, t0, state, config, z0, guards, t_stop, record, stepper, releasing_to=None):
    """DOP853 (rtol of the integrator) from (t0, z0) to ``t_stop`` or the first event;
    returns (t_end, z_end, the recorded stretch or None, the guard that fired or None).
    ``state`` gives the branches and approach speeds of the stretch. With
    ``releasing_to``: if at ``t_stop`` the contact is releasing (unloading so fast that
    δ + δ̇·COLLOC_STEPS·h < 0, the test advance_power applies before the collocation),
    the same solver goes on to ``releasing_to`` (its step history kept; a new span would
    start with a guessed step).

    The same method, tolerances, events and output as
    :meth:`camsim.engine.integrator.Integrator._advance_nonlinear`, with the cam input from
    :class:`_FastInput` and the one contact's force in scalar arithmetic, stepped by
    :class:`camsim.engine.dop853.OneContactDOP853` (the linear structure around the one force).
    Its first step is the one that worked last time: at an onset (δ = 0 at the start) the
    first accepted step after the last onset, elsewhere the largest accepted step of the
    last span.
    """

    from camsim.engine.dop853 import OneContactDOP853
    from camsim.elements.base import LENGTH_TOL

    v_imp = state.v_impacts
    cam_input = _FastInput(integ, t0, t_stop if releasing_to is None else max(t_stop, releasing_to))
    A, B, b, L = config.A, config.B, config.b, stepper.L
    Mz = np.vstack([stepper.dz, stepper.rz])
    Mu = np.vstack([stepper.du, stepper.ru])
    me = np.array([stepper.de, stepper.re])
    v_impact = stepper.v_impact
    # One matrix product per evaluation gives ż's linear part and the contact's δ, δ̇:
    # rows [A; Mz] on z, and per step the cam input's polynomial pushed through [B; Mu]
    # (its coefficients of τ^j) with the constants [b; me] folded into the τ^0 column.
    BMC = np.einsum("mc,kcj->kmj", np.vstack([B, Mu]), cam_input.C)
    BMC[:, :, 0] += np.concatenate([b, me])
    starts, powers = cam_input.starts, cam_input.powers.astype(float)

    def inputs(ts, t_lo, t_hi):
        """[B·u + b; Mu·u + me] at the times ts ⊂ [t_lo, t_hi]: (len(ts), n + 2)."""
        k0 = index(t_lo)
        if k0 == index(t_hi):  # the usual case: one grid step's polynomial
            return ((ts - start_list[k0])[:, None] ** powers) @ BMC[k0].T
        ks = np.searchsorted(later_starts, ts, side="right")
        return (BMC[ks] @ ((ts - starts[ks])[:, None] ** powers)[:, :, None])[:, :, 0]

    start_list, index, later_starts = starts.tolist(), cam_input.index, starts[1:]

    def input_at(t):
        k = index(t)
        return BMC[k] @ ((t - start_list[k]) ** powers)

    force = stepper.element.scalar_force(v_impact)

    # the first step: what worked last time (see the docstring)
    memory = integ.__dict__.setdefault("_dop853_first_steps", {})
    # (δ within LENGTH_TOL of zero: an impact event leaves δ at zero only to rounding)
    onset = bool(Mz[0] @ z0 + input_at(t0)[-2] <= LENGTH_TOL)
    structure = stepper.__dict__.get("dop853_structure")
    if structure is None:
        structure = stepper.dop853_structure = OneContactDOP853.structure(A, L, Mz)
    solver = OneContactDOP853(A, L, Mz, inputs, input_at, force, t0, z0, t_stop, integ.rtol_nonlinear,
                              integ.nonlinear_atol(z0.size), integ.dop853_max_step(), memory.get(onset), structure,
                              exponent=getattr(stepper.element, "exponent", 1.0), onset=onset,
                              crossing_step=memory.get(True))
    n_z = z0.size

    def forces(t, z):
        """The one contact's force F_nl at (t, z), for guards that read it (issue 25)."""
        delta, rate = (Mz @ z + input_at(t)[n_z:]).tolist()
        return np.array([force(delta, rate)])

    grid, Zs, z_end, fired, t_end = integ.dop853_span(None, z0, t0, t_stop, guards, cam_input, solver, forces=forces)
    if fired is None and releasing_to is not None and releasing_to > t_end:
        n = z0.size
        delta, rate = (Mz @ z_end + input_at(t_end)[n:]).tolist()
        if _releasing(delta, rate, integ.h):
            solver.t_bound, solver.status = float(releasing_to), "running"
            grid2, Zs2, z_end, fired, t_end = integ.dop853_span(None, z_end, t_end, releasing_to, guards, cam_input,
                                                                solver, forces=forces)
            grid, Zs = np.concatenate([grid, grid2]), np.concatenate([Zs, Zs2])
    if onset and solver.first_accepted is not None:
        memory[True] = solver.first_accepted
    elif not onset and solver.largest > 0.0:
        memory[False] = solver.largest
    stretch = None
    if record and grid.size:
        ks = np.round((grid - integ.t_ref) / integ.h).astype(int)
        Us = integ._grid_inputs(int(ks[0]), int(ks[-1]) + 1)  # exact cam values, as on every grid point
        fn = integ.nonlinear_forces(config, Zs, Us, v_imp)
        stretch = Stretch(state.branches, config, grid, Zs, Us, fn, dict(v_imp))
    return t_end, z_end, stretch, fired

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

import numpy as np

from camsim.elements.affine import input_rate, times_rate
from camsim.heartbeat import beat
from camsim.engine.bounce import COLLOC_STEPS, _releasing, bounce_span
from camsim.engine.collocation import Collocation, collocation_steps
from camsim.engine.remainder import _Anderson, _LinearLaw, _propagate, _RemainderResponse, _step_affine
from camsim.engine.state import TIME_EPS, State, Stretch
from camsim.engine.stepping import StepMaps, step_input_derivatives
from camsim.engine.windows import INTERP_TOL, LADDER, _first_hit, _fresh

#: The exponential stepper on (False: DOP853 throughout, camsim.engine.rk; the reference of
#: the stepper's tests and benchmark).
ENABLED = True

#: A window keeps the previous window's linear law while the tangent values stay within
#: this relative distance of it (fewer step maps to build).
HYSTERESIS = 0.12
#: Convergence: the remainder moves by less than this times the peak contact force.
#: A relative force error ε is a relative penetration error ε/a (F ∝ δ^a): 1e-10 keeps the
#: contact's penetration within about 1e-10·δ over a window, 1e-15 m for the CDTM seat
#: (δ ≈ 1e-5 m at 150 lbf), well under the absolute tolerance of the DOP853 path (1e-13 m).
#: Tighter values change no figure of bench/bench_contacts.py and cost iterations; at 1e-9
#: tests/test_nonlinear_stepper.py sees 2.4e-9 of the static penetration (its bar: 1e-9).
#: 3e-12 (with INTERP_TOL, the DOP853 rtol 3e-13 and its absolute tolerances 30 times
#: tighter, issue 34): the state leaving a closed phase then depends on where the grid's
#: steps fall by less than 1e-11, and the next impact's amplification stays below 1e-9 of
#: a trace between 5 and 500 kHz (at 1e-10 it reached 1.3e-7 on generated machines); the
#: CDTM with its power-law seat costs 4 % more.
RTOL = 3e-12
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


class ClosedContact:
    """Per-configuration data of the iterated-remainder stepper (cached on the integrator)."""

    def __init__(self, integrator, config):

        self.integrator = integrator
        self.config = config
        model = integrator.model
        (self.index,) = config.power_contacts
        delta, rate = integrator._delta(config, self.index)
        self.dz, self.du, self.de = delta.Cz[0], delta.Du[0], float(delta.e[0])
        self.rz, self.ru, self.re = rate.Cz[0], rate.Du[0], float(rate.e[0])
        self.element = model.acting(self.index, config.branches)
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


def advance_power(integrator, state, config, z0, guards, t_stop, record):
    """Integrate a configuration with one closed power-law contact (see module docstring).

    Same contract as :meth:`camsim.engine.integrator.Integrator._advance_nonlinear`: returns the
    state at the end, the recorded stretch and the guard that fired (or None).
    """

    integ = integrator
    steppers = integ.__dict__.setdefault("_power_steppers", {})
    stepper = steppers.get(config.key)
    if stepper is None:
        stepper = ClosedContact(integ, config)
        steppers[config.key] = stepper
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
        t_end, z_end, stretch, fired = bounce_span(integ, t_from, cur, config, z_from, gs, t_lim, record, stepper,
                                                   releasing_to=t_more)
        if stretch is not None:
            pieces.append((stretch.t, stretch.z, stretch.u))
        # the full state only where an event needs it (elsewhere a placeholder, as below)
        end = integ._state_from(config, z_end, t_end, cur) if fired is not None else State(
            t_end, cur.x, cur.v, cur.branches, cur.v_impacts, cur.holds)
        return t_end, z_end, fired, end

    while True:
        beat(t)  # issue 45: the run's progress channel and stall watchdog (camsim.run.watchdog)
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
                beat(t)
                t_c, z_c, taken, hit, calm = collocate(t, z, COLLOC_STEPS * 2 ** min(fails, 3), first)
                if taken is None:
                    break
                any_taken = True
                if record:
                    mask = integ._on_grid(taken[0][:-1])
                    pieces.append((taken[0][:-1][mask], taken[1][:-1][mask], taken[2][:-1][mask]))
                t, z = t_c, z_c
                cur = State(t, cur.x, cur.v, cur.branches, cur.v_impacts, cur.holds)
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
            ddd0 = float((z @ proj_z + u0 @ proj_u + proj_e)[2] + times_rate(stepper.ru, u0) + F0[0] * rate_L)
            tw = FIRST_WINDOW * h
            if abs(dd0[0] * tw + 0.5 * ddd0 * tw * tw) > SWEEP * d0[0] or abs(dd0[0]) * MIN_CUT * h > d0[0]:
                colloc_next = True
                continue
        U = integ.chunk_inputs(nodes, k0, k1)
        D = step_input_derivatives(U[:-1], U[1:], steps, h)
        Udot = input_rate(U)  # u̇ = [ṡ, s̈, s⃛, s⁗] per cam; B and the guards take no s⁗
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
        if ok:
            # The remainder is carried by its cubic Hermite per step, whose error is
            # h⁴·|r⁗|/384 ≈ |Δ⁴r|/384: where that is not negligible (a bounce, the
            # stiffness sweeping within a few steps) the window goes to DOP853 instead.
            # Δ⁴ of the K − 1 inner nodes needs K ≥ 6; a shorter window (cut short by the
            # stop time) cannot show its error and goes to DOP853 too: accepted unchecked,
            # such windows moved an Adams contact's release by 6.6e-10 s at a coarse grid
            # (issue 34, invariant a).
            ok = K >= 6 and float(np.max(np.abs(np.diff(r[1:-1], 4)))) / 384.0 <= INTERP_TOL * scale
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
        cur = State(t, cur.x, cur.v, cur.branches, cur.v_impacts, cur.holds)
        first = False
        r_prev = (float(X[-1, 0]), float(X[-1, 1]) / h, kq, cq)
        window = min(window * 2, MAX_WINDOW)


class ExponentialStepper:
    """The stepper of a configuration with one closed nonlinear contact whose law gives its
    tangent (``nonlinear_tangent``): :func:`advance_power`."""

    exact = False
    crosses_breaks = False

    def applies(self, ctx, config) -> bool:
        return bool(ENABLED and len(config.power_contacts) == 1 and config.dim
                    and hasattr(ctx.model.acting(config.power_contacts[0], config.branches), "nonlinear_tangent"))

    def advance(self, ctx, state, config, z0, guards, t_stop, record):
        return advance_power(ctx, state, config, z0, guards, t_stop, record)

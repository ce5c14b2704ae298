"""Exponential Lobatto collocation of one closed nonlinear contact, grid step by grid step.

Where the iterated remainder of :mod:`camsim.engine.nonlinear` does not converge — the seat
vibrating after an impact, the contact stiffness sweeping by tens of percent within a few
grid steps — a configuration with one closed nonlinear contact

    ż = A·z + B·u(t) + b + L·F(t),      F(t) = F(δ, δ̇),   δ, δ̇ affine in (z, u),

is integrated one grid step h at a time, exactly for everything but the scalar F: on each
step F is represented by its interpolating polynomial through the Chebyshev–Lobatto nodes
σ_i = c_i·h (i = 0..m, c_0 = 0, c_m = 1; F_0 is known from the step's start state), and
the linear system is propagated under that polynomial input exactly (the step maps
Φ(σ) = e^{Aσ} and input integrals Γ_j(σ) of :class:`camsim.engine.integrator.StepMaps`, built
once per configuration). The contact then acts through m scalars: δ and δ̇ at the nodes
are affine in the start state, the cam input and the node values F_1..F_m, and the m
collocation conditions F_i = F(δ_i, δ̇_i) are solved by Newton's method (an m×m system;
the element's ``nonlinear_tangent`` gives the Jacobian). This is exponential collocation
(Hochbruck & Ostermann, Acta Numerica 19 (2010) 209, §2.4); the contact's stiffness sits
in the implicit m×m solve, so the step is not limited by stability.

The steps of one call (:data:`camsim.engine.nonlinear.COLLOC_STEPS`, eight grid steps) are solved
together: step k's node values act on step j > k through exact linear maps (Φ^(j−k−1)
and the step's input integrals), so the δ, δ̇ rows of all steps are one linear map of all
node values, and Newton's method runs on the K·m conditions at once — one small dense
solve per iteration instead of a Python loop over steps (:func:`_block_steps`). Where that
Newton iteration does not converge the steps are taken one by one
(:func:`_steps_one_by_one`). Either way the steps are accepted up to the first that fails
a test below (the later ones do not affect the earlier: the maps are causal).

Error control: the defect F(δ(s), δ̇(s)) − F_poly(s) is evaluated at :data:`CHECK` points
between the nodes; the local error of the step is its response ∫ e^{A(h−s)}·L·defect(s) ds
(the defect interpolated through the nodes, where it is zero, and the check points),
accepted per component below ``atol + rtol·|z|`` with the tolerances of the DOP853 path
(:meth:`camsim.engine.integrator.Integrator._advance_nonlinear`). A step that fails the test, whose
Newton iteration does not converge, or where the force reaches zero at a node (a release
is near) is not taken: the caller hands that step to DOP853, as it does for events (guards
are checked on the steps' end nodes with :func:`camsim.engine.nonlinear._first_hit`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from camsim.engine.state import TIME_EPS
from camsim.engine.stepping import _FACT, _P, StepMaps, forcing_coefficients, step_input_derivatives, taylor_rows
from camsim.engine.windows import INTERP_TOL, LADDER, _first_hit
from camsim.elements.affine import input_rate

#: Unknown node values per step (degree of F's polynomial on a step).
NODES = 5
#: Where the defect is checked, as fractions of the step (between the nodes).
CHECK = (0.22, 0.78)
#: Newton: stop when the node values move by less than this times the step's force.
NEWTON_TOL = 1e-13
NEWTON_MAX = 8
#: Solve the steps of a call together (:func:`_block_steps`); Newton iterations allowed.
BLOCK = True
BLOCK_NEWTON_MAX = 12
#: Newton iterations with a fresh Jacobian (then chord steps with the last one).
JACOBIANS = 2
#: The local error estimate must stay below this fraction of the tolerance.
SAFETY = 1.0
#: Back to the iterated remainder when the contact's tangent stiffness over the last
#: CALM_STEPS steps spans less than CALM of its largest value.
CALM = 0.2
CALM_STEPS = 16
#: Also require the remainder's interpolation test of camsim.engine.nonlinear to pass.
CALM_REMAINDER = True


@dataclass(frozen=True)
class _Maps:
    """Φ and Γ_j of one step length (the part of StepMaps the collocation reads)."""

    Phi: np.ndarray
    Gamma: np.ndarray


class Collocation:
    """Step maps of the collocation for one configuration with one closed nonlinear contact."""

    def __init__(self, integrator, config, stepper):
        from camsim.engine.stepping import phi_series

        h = integrator.h
        m = NODES
        self.m = m
        c = (1.0 - np.cos(np.pi * np.arange(m + 1) / m)) / 2.0
        chk = np.array(CHECK)
        sig = np.concatenate([c[1:], chk]) * h  # nodes 1..m, then the check points
        # only Φ and Γ_j of each node's step are needed (not the modal form StepMaps adds)
        maps = [_Maps(*fast) if (fast := phi_series(config.A, float(s))) is not None else StepMaps(config, float(s))
                for s in sig]
        nq = len(sig)
        rows = np.stack([stepper.dz, stepper.rz])  # (2, n)
        # δ, δ̇ at each point: Pz·z0 + PE·E (cam forcing coefficients) + du·u + de + Q·F_nodes
        self.Pz = np.concatenate([rows @ mp.Phi for mp in maps])  # (2 nq, n), rows δ_q, δ̇_q interleaved
        self.PE = np.concatenate([np.einsum("rn,jnk->rjk", rows, mp.Gamma) for mp in maps])  # (2 nq, 8, n)
        vand = (h * c)[:, None] ** np.arange(m + 1)[None, :] / _FACT[: m + 1][None, :]
        vinv = np.linalg.inv(vand)  # node values → Taylor coefficients of F
        GL = np.stack([np.stack([mp.Gamma[k] @ stepper.L for k in range(m + 1)], axis=1) for mp in maps])  # (nq, n, m+1)
        self.Q = np.concatenate([rows @ GL[q] @ vinv for q in range(nq)])  # (2 nq, m+1)
        self.powers = np.stack([s ** np.arange(_P + 1) / _FACT[: _P + 1] for s in sig])  # (nq, 8)
        end = maps[m - 1]
        self.Phi = end.Phi
        self.Gamma = end.Gamma  # (8, n, n)
        self.endL = GL[m - 1] @ vinv  # (n, m+1)
        # the polynomial's values at the check points, and its extrapolation one step on
        lag = lambda x: (x[:, None] ** np.arange(m + 1)[None, :]) @ np.linalg.inv(c[:, None] ** np.arange(m + 1)[None, :])  # noqa: E731
        self.at_check = lag(chk)  # (ncheck, m+1)
        self.extrap = lag(1.0 + c[1:])  # (m, m+1)
        # local error: response at h to the defect, interpolated through nodes (zero) and checks
        allc = np.concatenate([c, chk])
        vand_all = (h * allc)[:, None] ** np.arange(allc.size)[None, :] / _FACT[: allc.size][None, :]
        cols = np.linalg.inv(vand_all)[:, m + 1 :]  # Taylor coefficients per unit defect at each check
        G_end = np.stack([end.Gamma[k] @ stepper.L for k in range(allc.size)], axis=1)  # (n, m+1+ncheck)
        self.G_err = G_end @ cols  # (n, ncheck)
        self.nq = nq
        self.rows_d = np.arange(0, 2 * nq, 2)
        self.rows_r = np.arange(1, 2 * nq, 2)


def _error_bound(lengths, rtol, z0, z1):
    """What a step's local error must stay below, per component (the DOP853 path's atol and
    rtol, times SAFETY); z0, z1 the states at the step's ends (or rows of them)."""
    return SAFETY * (lengths + rtol * np.maximum(np.abs(z0), np.abs(z1)))


def _block_matrices(coll, K):
    """MU (K·2nq, K·m + 1): the δ, δ̇ rows of K consecutive steps as linear maps of their
    node forces U = [F_0, F_{0,1..m}, F_{1,1..m}, …] (step k's polynomial is U[k·m : k·m+m+1],
    its first node being the previous step's last); cached per block length."""
    cache = coll.__dict__.setdefault("blocks", {})
    hit = cache.get(K)
    if hit is not None:
        return hit
    m, nq = coll.m, coll.nq
    rows = 2 * nq
    PPhi = [coll.Pz]
    for _ in range(K):
        PPhi.append(PPhi[-1] @ coll.Phi)
    T = [P @ coll.endL for P in PPhi]  # (2nq, m+1): step j's polynomial seen l+1 steps on
    MU = np.zeros((K * rows, K * m + 1))
    for k in range(K):
        MU[k * rows : (k + 1) * rows, k * m : k * m + m + 1] += coll.Q
        for j in range(k):
            MU[k * rows : (k + 1) * rows, j * m : j * m + m + 1] += T[k - 1 - j]
    node_d = np.array([k * rows + coll.rows_d[q] for k in range(K) for q in range(m)])
    node_r = np.array([k * rows + coll.rows_r[q] for k in range(K) for q in range(m)])
    chk_d = np.array([k * rows + coll.rows_d[m + c] for k in range(K) for c in range(nq - m)])
    chk_r = np.array([k * rows + coll.rows_r[m + c] for k in range(K) for c in range(nq - m)])
    hit = cache[K] = (MU, node_d, node_r, chk_d, chk_r)
    return hit


def _block_steps(coll, stepper, K, z, F0, pre, end_in, lengths, rtol):
    """K collocation steps solved together: Newton on all K·m node values at once (one
    K·m × K·m system; the steps' couplings are exact linear maps), then each step's local
    error as in the step-by-step loop. Returns (steps taken, Zs, Fs, δ and δ̇ at the step
    starts, the contact stiffness range per step) or None when Newton does not converge.
    """
    m, nq = coll.m, coll.nq
    nc = nq - m
    MU, node_d, node_r, chk_d, chk_r = _block_matrices(coll, K)
    n = z.size
    # states without the contact force after the first node: s_{k+1} = Φ·s_k + in_k (+ F_0's share)
    S = np.empty((K, n))
    s_k = z
    for k in range(K):
        S[k] = s_k
        s_k = coll.Phi @ s_k + end_in[k]
    Ylin = (S @ coll.Pz.T + pre).reshape(-1) + MU[:, 0] * F0
    MD, MR = MU[node_d, 1:], MU[node_r, 1:]
    YD, YR = Ylin[node_d], Ylin[node_r]
    element, v_impact = stepper.element, stepper.v_impact
    X = np.full(K * m, F0)
    eye = np.eye(K * m)
    last = math.inf
    for _ in range(BLOCK_NEWTON_MAX):
        F, kt, ct = element.nonlinear_tangent(YD + MD @ X, YR + MR @ X, v_impact)
        dX = np.linalg.solve(eye - kt[:, None] * MD - ct[:, None] * MR, X - F)
        X = X - dX
        size, tol = float(np.max(np.abs(dX))), NEWTON_TOL * max(F0, float(np.max(np.abs(X))))
        # converged: this correction was below the tolerance, or — converging
        # quadratically (the correction below 1e-6 of the force) — the next one would be,
        # |dX_k|·(|dX_k| / |dX_k−1|)² (Deuflhard, Newton Methods for Nonlinear Problems,
        # §2.1: the contraction estimate of the simplified Newton correction)
        if size <= tol or (size <= 1e-6 * tol / NEWTON_TOL and size * (size / last) ** 2 <= tol):
            break
        last = size
    else:
        return None
    U = np.concatenate([[F0], X])
    F, kt, ct = element.nonlinear_tangent(YD + MD @ X, YR + MR @ X, v_impact)
    Y_chk = Ylin + MU[:, 1:] @ X  # (Ylin holds F_0's share)
    Fc = element.nonlinear_force(Y_chk[chk_d], Y_chk[chk_r], v_impact).reshape(K, nc)
    idx = np.arange(K)[:, None] * m + np.arange(m + 1)[None, :]
    Fall = U[idx]  # (K, m+1)
    err = (Fc - Fall @ coll.at_check.T) @ coll.G_err.T  # (K, n)
    Zs = np.empty((K + 1, n))
    Zs[0] = z
    for k in range(K):
        Zs[k + 1] = coll.Phi @ Zs[k] + end_in[k] + coll.endL @ Fall[k]
    bound = _error_bound(lengths, rtol, Zs[:-1], Zs[1:])
    F_nodes = F.reshape(K, m)
    bad = np.any(np.abs(err) > bound, axis=1) | (np.min(F_nodes, axis=1) <= 0.0) | (np.min(Fc, axis=1) <= 0.0)
    taken = int(np.argmax(bad)) if bad.any() else K
    kt_nodes, ct_nodes = kt.reshape(K, m), ct.reshape(K, m)
    Fs = np.append(Fall[:, 0], Fall[-1, -1])
    d_nodes, r_nodes = (YD + MD @ X).reshape(K, m), (YR + MR @ X).reshape(K, m)
    return (taken, Zs, Fs, d_nodes, r_nodes, np.min(kt_nodes, axis=1), np.max(kt_nodes, axis=1),
            np.max(ct_nodes, axis=1))


def collocation_steps(integ, stepper, config, coll, t, z, n_steps, t_stop, guards, first, chi):
    """Up to ``n_steps`` grid steps from the grid point ``t``.

    Returns (t_end, z_end, (nodes, Z, U) of the steps taken — ``None`` if none —, hit,
    calm): ``hit`` is True when the next step must go to DOP853 (a guard may cross in it,
    or the step was not accepted); ``calm`` when the contact stiffness has settled (see
    :data:`CALM`).
    """

    h = integ.h
    k0 = round((t - integ.t_ref) / h)
    if abs(integ.t_ref + k0 * h - t) > TIME_EPS:
        return t, z, None, True, False
    K = min(n_steps, math.floor((t_stop - TIME_EPS - integ.t_ref) / h) - k0)
    if K <= 0:
        return t, z, None, True, False
    nq = coll.nq
    U = integ._grid_inputs(k0, k0 + K + 1)
    D = step_input_derivatives(U[:-1], U[1:], np.full(K, h), h)
    E = forcing_coefficients(config, D)  # (K, 8, n)
    rows = taylor_rows(D)  # (K, 4·c, 8)
    u_pts = np.stack([rows[:, ci, :] @ coll.powers.T for ci in range(rows.shape[1])], axis=2)  # (K, nq, 4·c)
    dr_u = np.stack([u_pts @ stepper.du + stepper.de, u_pts @ stepper.ru + stepper.re], axis=2).reshape(K, 2 * nq)
    pre = np.einsum("rjn,kjn->kr", coll.PE, E) + dr_u  # (K, 2 nq)
    end_in = np.einsum("jnl,kjl->kn", coll.Gamma, E)  # (K, n)
    u0 = U[:-1]
    pre0 = np.stack([u0 @ stepper.du + stepper.de, u0 @ stepper.ru + stepper.re], axis=1)
    M0 = np.stack([stepper.dz, stepper.rz])
    element, v_impact = stepper.element, stepper.v_impact
    n = z.size
    lengths = integ.nonlinear_atol(n)
    rtol = integ.rtol_nonlinear
    block = None
    if BLOCK and K >= 2:
        d0, r0 = (M0 @ z + pre0[0]).tolist()
        F0 = element.nonlinear_force_scalar(d0, r0, v_impact)
        if F0 > 0.0:
            block = _block_steps(coll, stepper, K, z, F0, pre, end_in, lengths, rtol)
    if block is not None:
        taken, Zs, Fs, d_nodes, r_nodes, kt_lo, kt_hi, ct_hi = block
        d_s = np.concatenate([[d0], d_nodes[:, -1]])
        r_s = np.concatenate([[r0], r_nodes[:, -1]])
    else:
        taken, Zs, Fs, d_s, r_s, kt_lo, kt_hi, ct_hi = _steps_one_by_one(
            coll, stepper, K, z, pre, pre0, end_in, M0, lengths, rtol)
    hit = taken < K
    if taken == 0:
        return t, Zs[0], None, True, False
    # calm: the contact stiffness of the last steps varies little (the iteration of
    # camsim.engine.nonlinear will converge again)
    last = slice(max(0, taken - CALM_STEPS), taken)
    hi = float(np.max(kt_hi[last]))
    calm = hi > 0.0 and (hi - float(np.min(kt_lo[last]))) <= CALM * hi
    if calm and CALM_REMAINDER and taken >= 8:
        # ... and the remainder about the ladder's linear law would pass the iteration's
        # interpolation test (|Δ⁴r|/384 below INTERP_TOL of the force) on the last steps

        ks = slice(taken - 8, taken)
        kq = LADDER ** round(math.log(hi) / math.log(LADDER))
        cmax = float(np.max(ct_hi[ks]))
        cq = LADDER ** round(math.log(cmax) / math.log(LADDER)) if cmax > 0 else 0.0
        r = Fs[ks] - kq * d_s[ks] - cq * r_s[ks]
        calm = float(np.max(np.abs(np.diff(r, 4)))) / 384.0 <= INTERP_TOL * float(np.max(np.abs(Fs[ks])))
    # guards on the end nodes of the steps taken (values and exact rates)
    Z = Zs[: taken + 1]
    Un = U[: taken + 1]
    Fn_nodes = stepper.force(Z, Un, chi)[2]
    zdot = Z @ config.A.T + Un @ config.B.T + config.b + np.outer(Fn_nodes, stepper.L)
    Udot = input_rate(Un)
    nodes = integ.t_ref + np.arange(k0, k0 + taken + 1) * h
    nodes[0] = t
    steps = np.full(taken, h)
    hit_step = _first_hit(guards, Z, Un, zdot, Udot, Fn_nodes, steps, first)
    if hit_step is not None:
        if hit_step == 0:
            return t, Zs[0], None, True, False
        taken = hit_step
        hit = True
    return float(nodes[taken]), Zs[taken].copy(), (nodes[: taken + 1], Zs[: taken + 1], U[: taken + 1]), hit, calm


def _steps_one_by_one(coll, stepper, K, z, pre, pre0, end_in, M0, lengths, rtol):
    """The steps one at a time (Newton on each step's m node values); see collocation_steps."""
    m, nq = coll.m, coll.nq
    # rows reordered once per call so that each Newton iteration reads slices: δ at the
    # nodes, δ̇ at the nodes, then δ and δ̇ at the check points
    order = np.concatenate([coll.rows_d[:m], coll.rows_r[:m], coll.rows_d[m:], coll.rows_r[m:]])
    Pz, pre, Q = coll.Pz[order], pre[:, order], coll.Q[order]
    Q0, Q1 = Q[:, 0], Q[:, 1:]
    Qd1, Qr1, Qn = Q1[:m], Q1[m : 2 * m], Q1[: 2 * m]
    nc = nq - m
    eye = np.eye(m)
    element, v_impact = stepper.element, stepper.v_impact
    n = z.size
    Zs = np.empty((K + 1, n))
    Zs[0] = z
    Fs = np.empty(K + 1)
    Fall = np.empty(m + 1)
    have_prev = False
    taken = 0
    kt_lo = np.full(K, np.inf)
    kt_hi = np.zeros(K)
    ct_hi = np.zeros(K)
    d_s = np.empty(K + 1)
    r_s = np.empty(K + 1)
    for k in range(K):
        d0, r0 = (M0 @ z + pre0[k]).tolist()
        F0 = element.nonlinear_force_scalar(d0, r0, v_impact)
        Fs[k] = F0
        d_s[k], r_s[k] = d0, r0
        if F0 <= 0.0:
            break
        base = Pz @ z + pre[k] + Q0 * F0
        base_n = base[: 2 * m]
        Fn = coll.extrap @ Fall if have_prev else np.full(m, F0)
        converged = False
        Jinv = None
        for it in range(NEWTON_MAX):
            y = base_n + Qn @ Fn
            F, kt, ct = element.nonlinear_tangent(y[:m], y[m:], v_impact)
            if it < JACOBIANS:
                # Newton's Jacobian on the first two iterations, then kept (chord steps)
                Jinv = np.linalg.inv(eye - kt[:, None] * Qd1 - ct[:, None] * Qr1)
            dF = Jinv @ (Fn - F)
            Fn = Fn - dF
            if np.max(np.abs(dF)) <= NEWTON_TOL * max(F0, np.max(np.abs(Fn))):
                converged = True
                break
        if not converged or np.min(F) <= 0.0:
            have_prev = False
            break
        Fall[0] = F0
        Fall[1:] = Fn
        have_prev = True
        kt_lo[k], kt_hi[k] = np.min(kt), np.max(kt)
        ct_hi[k] = np.max(ct)
        y = base[2 * m :] + Q1[2 * m :] @ Fn
        Fc = element.nonlinear_force(y[:nc], y[nc:], v_impact)
        if np.min(Fc) <= 0.0:
            have_prev = False
            break
        err = coll.G_err @ (Fc - coll.at_check @ Fall)
        z_new = coll.Phi @ z + end_in[k] + coll.endL @ Fall
        if np.any(np.abs(err) > _error_bound(lengths, rtol, z, z_new)):
            have_prev = False
            break
        z = z_new
        Zs[k + 1] = z
        taken = k + 1
    return taken, Zs, Fs, d_s, r_s, kt_lo, kt_hi, ct_hi

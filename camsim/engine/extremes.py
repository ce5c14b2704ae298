"""Extremes located on the solution, not read off the samples (spec §4).

Every peak or minimum camsim reports is found on the continuous solution, so it is the same
at any sample rate. Between events the solution is smooth, and each stepper knows it at
the nodes of its own internal grid (every grid point of a stretch, plus the stretch's two
ends, which are events, stops or the recording window's edges). For each observable q
(a mass's displacement, velocity or acceleration, an element's force, the cam force, the
camshaft torque: whatever the caller's ``observe`` computes from the state — the very code
that makes the traces, so a figure reported in two places is one number):

1. **Screen** the nodes: the largest node value and every node that is a local maximum
   within :data:`SCREEN_MARGIN` of the stretch's range below it. The internal grid has at
   least twelve steps per period of the highest natural frequency, so between two nodes a
   smooth q rises at most a few percent of its range above the higher node (1 − cos(π/12)
   = 3.4 % for a pure mode): any step that can hold the maximum is next to such a node, or
   at a stretch end (where the one-sided limit itself is a candidate).
2. **Refine** only where asked (:meth:`StretchExtremes.extreme`, lazily: a step is refined
   only when its bound could beat the best value found so far): on each candidate step the
   exact state is evaluated at :data:`CHEBYSHEV_POINTS` Chebyshev–Lobatto points — for a
   linear configuration from the Taylor series of its exact solution (z' = A·z + B·u + b with
   the step's polynomial cam input), for a closed nonlinear contact by DOP853 at rtol 1e-13
   from the step's start node — q is interpolated there (error far below 1e-12 of q's range
   for steps of at most 1/12 period) and the interpolant's maximum located by Newton's
   method on its derivative.

A maximum at a stretch end is the one-sided limit there: a damped contact's force jumps to
c·v at the instant of impact, and that value is the peak of a damping-dominated impact.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from camsim.errors import SimulationError
from camsim.elements.affine import N_INPUT
from camsim.engine.stepping import _FACT, _P, state_scale, step_input_derivatives

#: Nodes within this fraction of a stretch's range of its largest node value are screened
#: for a maximum between nodes (a smooth q resolved at twelve steps per period exceeds its
#: highest node by at most 3.4 % of its range).
SCREEN_MARGIN = 0.05
#: Chebyshev–Lobatto points per refined step (the interpolant's degree + 1).
CHEBYSHEV_POINTS = 13
#: Taylor terms of a step's exact solution are taken until the next would be below this
#: (relative to the balanced state).
TAYLOR_TOL = 1e-18
#: Largest balanced norm ‖A·h‖₁ for the Taylor series (beyond it the step is split).
TAYLOR_NORM = 4.0
#: DOP853 tolerance of a nonlinear step integrated again for its dense states.
DENSE_RTOL = 1e-13

_X = np.cos(np.pi * np.arange(CHEBYSHEV_POINTS)[::-1] / (CHEBYSHEV_POINTS - 1))  # −1 … 1
_SIGMA = 0.5 * (_X + 1.0)  # 0 … 1 along a step
_TO_COEF = np.linalg.inv(np.polynomial.chebyshev.chebvander(_X, CHEBYSHEV_POINTS - 1))
_FINE = np.linspace(-1.0, 1.0, 65)
_FINE_V = np.polynomial.chebyshev.chebvander(_FINE, CHEBYSHEV_POINTS - 1)


# ---------------------------------------------------------------------- dense states
def taylor_states(config, z0: np.ndarray, D: np.ndarray, h: np.ndarray, sigma: np.ndarray) -> np.ndarray:
    """Exact states of a linear configuration inside steps, from the Taylor series of the solution.

    Parameters
    ----------
    config : Configuration
        ż = A·z + B·u + b.
    z0 : ndarray (S, m)
        State at each step's start.
    D : ndarray (S, 8)
        The steps' cam-input derivatives d^j s/dt^j at their starts (the degree-7
        polynomial the step maps integrate, :func:`camsim.engine.stepping.step_input_derivatives`).
    h : ndarray (S,)
        Step lengths [s].
    sigma : ndarray (P,)
        Fractions of the step (0 … 1) at which the state is wanted.

    Returns
    -------
    ndarray (S, P, m)

    Notes
    -----
    In the balanced state w = T⁻¹·z (T the diagonal balancing of A) and the scaled
    coefficients e_k = w^(k)·h^k/k!, the series is e_{k+1} = h/(k+1)·(A_b·e_k + (B_b·u^(k)
    + [k = 0]·b_b)·h^k/k!), summed until ‖h·A_b‖^k/k! is below :data:`TAYLOR_TOL`: the
    exact solution to rounding, a few small products instead of an ``expm`` per point.
    Steps whose ‖h·A_b‖₁ exceeds :data:`TAYLOR_NORM` are halved recursively.
    """
    S, m = z0.shape
    P = sigma.size
    out = np.empty((S, P, m))
    if m == 0 or S == 0:
        return out
    T = state_scale(config)
    Ab = config.A * (T[None, :] / T[:, None])
    Bb = config.B / T[:, None]
    bb = config.b / T
    norm_a = float(np.linalg.norm(Ab, 1))
    h = np.asarray(h, dtype=float)
    long = h * norm_a > TAYLOR_NORM
    if np.any(long):
        # a long step (a stretch's only step between two events far apart with no grid
        # point, in a soft machine): its halves, each from its own exact start state
        for s in np.flatnonzero(long).tolist():
            out[s] = _split_states(config, z0[s], D[s], float(h[s]), sigma)
    short = np.flatnonzero(~long)
    if short.size == 0:
        return out
    hs = h[short]
    nrm = float(np.max(hs)) * norm_a
    terms = 1
    bound = 1.0
    while terms < 80:
        bound *= nrm / terms
        if bound < TAYLOR_TOL and terms > _P + 1:
            break
        terms += 1
    Dp = np.concatenate([D[short], np.zeros((short.size, terms + N_INPUT))], axis=1)
    e = z0[short] / T  # e_0 = w0
    powers = sigma[:, None] ** np.arange(terms + 1)[None, :]  # (P, K+1)
    W = powers[:, 0][None, :, None] * e[:, None, :]
    hk = np.ones_like(hs)  # h^k / k!
    for k in range(terms):
        uk = Dp[:, k : k + N_INPUT] * hk[:, None]  # û_k·h^k/k!
        forcing = uk @ Bb.T
        if k == 0:
            forcing = forcing + bb
        e = (hs / (k + 1))[:, None] * (e @ Ab.T + forcing)
        W += powers[:, k + 1][None, :, None] * e[:, None, :]
        hk = hk * hs / (k + 1)
    out[short] = W * T
    return out


def _split_states(config, z0, D, h, sigma):
    """:func:`taylor_states` of one long step, by its halves."""
    half = 0.5 * h
    D_mid = _shift_input(D, half)
    z_mid = taylor_states(config, z0[None, :], D[None, :], np.array([half]), np.array([1.0]))[0, 0]
    out = np.empty((sigma.size, z0.size))
    first = sigma <= 0.5
    if np.any(first):
        out[first] = taylor_states(config, z0[None, :], D[None, :], np.array([half]), sigma[first] * 2.0)[0]
    if np.any(~first):
        out[~first] = taylor_states(config, z_mid[None, :], D_mid[None, :], np.array([half]),
                                    sigma[~first] * 2.0 - 1.0)[0]
    return out


def _shift_input(D: np.ndarray, tau: float) -> np.ndarray:
    """The degree-7 input polynomial's derivatives at τ into its step (D at the start)."""
    out = np.zeros_like(D)
    for j in range(D.size):
        terms = D[j:]
        out[j] = float(np.sum(terms * tau ** np.arange(terms.size) / _FACT[: terms.size]))
    return out


def step_inputs(D: np.ndarray, tau: np.ndarray) -> np.ndarray:
    """[s, ṡ, s̈, s⃛] of the steps' input polynomials at offsets τ: D (S, 8), τ (S, P) → (S, P, 4)."""
    S, P = tau.shape
    Dp = np.concatenate([D, np.zeros((S, N_INPUT - 1))], axis=1)
    j = np.arange(_P + 1)
    powers = tau[:, :, None] ** j / _FACT[: _P + 1]  # (S, P, 8)
    out = np.empty((S, P, N_INPUT))
    for c in range(N_INPUT):
        out[:, :, c] = np.einsum("spj,sj->sp", powers, Dp[:, c : c + _P + 1])
    return out


# ---------------------------------------------------------------------- the record of a stretch
@dataclass
class StretchExtremes:
    """Located maxima and minima of every observable over one stretch (or its part in the
    recording window), refined on demand.

    Attributes
    ----------
    t0, t1 : float
        The interval covered [s] (simulation clock).
    node_max, node_min : ndarray (n_obs,)
        Largest and smallest node values (exact states at the nodes).
    node_tmax, node_tmin : ndarray (n_obs,)
        Their times [s].
    upper, lower : ndarray (n_obs,)
        Bounds no value between the nodes can exceed (screening; see module docstring).
    """

    t0: float
    t1: float
    node_max: np.ndarray
    node_tmax: np.ndarray
    node_min: np.ndarray
    node_tmin: np.ndarray
    upper: np.ndarray
    lower: np.ndarray
    _candidates: tuple = field(repr=False, default=())
    _dense: object = field(repr=False, default=None)
    _refined: dict = field(repr=False, default_factory=dict)

    def extreme(self, j: int, sense: int) -> tuple[float, float]:
        """(value, time) of the located maximum (``sense`` = +1) or minimum (−1) of
        observable ``j`` over this stretch."""
        key = (j, sense)
        hit = self._refined.get(key)
        if hit is None:
            hit = self._refine(j, sense)
            self._refined[key] = hit
        return hit

    def bound(self, j: int, sense: int) -> float:
        """Largest value (sense +1) or smallest (−1) the observable can take here (screening)."""
        return float(self.upper[j]) if sense > 0 else float(self.lower[j])

    def _refine(self, j: int, sense: int) -> tuple[float, float]:
        if sense > 0:
            best, t_best = float(self.node_max[j]), float(self.node_tmax[j])
        else:
            best, t_best = float(self.node_min[j]), float(self.node_tmin[j])
        steps = self._candidates[0 if sense > 0 else 1].get(j, ())
        if not steps or self._dense is None:
            return best, t_best
        t_starts, lengths, Q = self._dense(steps)  # (S,), (S,), (S, P, n_obs)
        values = sense * Q[:, :, j]  # (S, P)
        coef = values @ _TO_COEF.T  # Chebyshev coefficients per step
        fine = coef @ _FINE_V.T
        k = np.argmax(fine, axis=1)
        x = _FINE[k]
        lo = _FINE[np.maximum(k - 1, 0)]
        hi = _FINE[np.minimum(k + 1, _FINE.size - 1)]
        d1 = np.array([np.polynomial.chebyshev.chebder(c) for c in coef])
        d2 = np.array([np.polynomial.chebyshev.chebder(c, 2) for c in coef])
        for _ in range(30):
            g = _chebval_rows(x, d1)
            gg = _chebval_rows(x, d2)
            with np.errstate(divide="ignore", invalid="ignore"):
                step = np.where(gg < 0.0, g / gg, 0.0)
            x_new = np.clip(x - step, lo, hi)
            if np.all(np.abs(x_new - x) <= 1e-15):
                x = x_new
                break
            x = x_new
        vals = _chebval_rows(x, coef)
        # the interpolant's value where Newton stopped, or its best fine point
        vfine = fine[np.arange(fine.shape[0]), k]
        use = vals >= vfine
        x = np.where(use, x, _FINE[k])
        vals = np.where(use, vals, vfine)
        s = int(np.argmax(vals))
        if sense * best >= vals[s]:
            return best, t_best
        t_at = float(t_starts[s] + lengths[s] * 0.5 * (x[s] + 1.0))
        return float(sense * vals[s]), t_at


def _chebval_rows(x: np.ndarray, coef: np.ndarray) -> np.ndarray:
    """Chebyshev series coef[i] at x[i] for each row i (Clenshaw, vectorised over rows)."""
    b1 = np.zeros_like(x)
    b2 = np.zeros_like(x)
    for k in range(coef.shape[1] - 1, 0, -1):
        b1, b2 = 2.0 * x * b1 - b2 + coef[:, k], b1
    return x * b1 - b2 + coef[:, 0]


# ---------------------------------------------------------------------- building the record
def stretch_extremes(ctx, config, branches, v_impacts, exact: bool, nodes: np.ndarray, Z: np.ndarray, U: np.ndarray,
                     observe, window: tuple[float, float]) -> StretchExtremes | None:
    """Screen a stretch's nodes and prepare the refinement of its extremes.

    Parameters
    ----------
    ctx : EngineContext
    config, branches, v_impacts
        The stretch's configuration, branches and impact speeds.
    exact : bool
        True for a linear configuration (dense states from the exact solution's Taylor
        series), False for a closed nonlinear contact (DOP853 from each node).
    nodes : ndarray (N,)
        Times of the stretch's nodes [s], increasing: its start, its grid points, its end.
    Z, U : ndarray (N, m), (N, 4)
        Exact states and cam inputs there (the last node's input the limit from the left).
    observe : callable
        ``observe(config, branches, v_impacts, Z, U) -> (N, n_obs)``: the observables.
    window : (float, float)
        The recording window [s]; the part of the stretch outside it is left out.

    Returns
    -------
    StretchExtremes or None
        None when the stretch does not reach into the window.
    """
    lo, hi = window
    t0, t1 = float(nodes[0]), float(nodes[-1])
    if t1 < lo or t0 > hi or nodes.size < 2:
        return None
    D = step_input_derivatives(U[:-1], U[1:], np.diff(nodes), ctx.h) if exact else None

    def dense_states(step_index: np.ndarray, sigma: np.ndarray):
        """(S, P, m) states and (S, P, 4) inputs at fractions sigma of the given steps."""
        t_s = nodes[step_index]
        h_s = nodes[step_index + 1] - t_s
        if exact:
            Zs = taylor_states(config, Z[step_index], D[step_index], h_s, sigma)
            Us = step_inputs(D[step_index], h_s[:, None] * sigma[None, :])
        else:
            Zs, Us = _integrated_states(ctx, config, v_impacts, t_s, h_s, Z[step_index], sigma)
        return Zs, Us

    # cut the stretch to the window: its edges become nodes (exact states there)
    if t0 < lo or t1 > hi:
        nodes, Z, U, D = _clip(nodes, Z, U, D, lo, hi, dense_states)
        if nodes.size < 2:
            return None

        def dense_states(step_index, sigma, nodes=nodes, Z=Z, D=D):  # noqa: F811 - the clipped stretch's
            t_s = nodes[step_index]
            h_s = nodes[step_index + 1] - t_s
            if exact:
                return (taylor_states(config, Z[step_index], D[step_index], h_s, sigma),
                        step_inputs(D[step_index], h_s[:, None] * sigma[None, :]))
            return _integrated_states(ctx, config, v_impacts, t_s, h_s, Z[step_index], sigma)

    Q = observe(config, branches, v_impacts, Z, U)
    n_obs = Q.shape[1]
    kmax, kmin = np.argmax(Q, axis=0), np.argmin(Q, axis=0)
    cols = np.arange(n_obs)
    qmax, qmin = Q[kmax, cols], Q[kmin, cols]
    margin = SCREEN_MARGIN * (qmax - qmin) + 1e-12 * np.maximum(np.abs(qmax), np.abs(qmin))
    cands_max = _candidate_steps(Q, qmax - margin)
    cands_min = _candidate_steps(-Q, -(qmin + margin))
    cache: dict = {}

    def dense(steps):
        steps = tuple(sorted(steps))
        hit = cache.get(steps)
        if hit is None:
            idx = np.array(steps, dtype=int)
            Zs, Us = dense_states(idx, _SIGMA)
            S, P, m = Zs.shape
            Qs = observe(config, branches, v_impacts, Zs.reshape(S * P, m), Us.reshape(S * P, N_INPUT)).reshape(S, P, -1)
            hit = (nodes[idx], nodes[idx + 1] - nodes[idx], Qs)
            cache.clear()
            cache[steps] = hit
        return hit

    return StretchExtremes(
        t0=float(nodes[0]), t1=float(nodes[-1]), node_max=qmax, node_tmax=nodes[kmax], node_min=qmin,
        node_tmin=nodes[kmin], upper=qmax + margin, lower=qmin - margin,
        _candidates=(cands_max, cands_min), _dense=dense,
    )


def _candidate_steps(Q: np.ndarray, threshold: np.ndarray) -> dict[int, tuple[int, ...]]:
    """Per observable, the steps that may hold its maximum: the two steps around each node
    that is a local maximum at or above ``threshold``, and a stretch end's step when that end
    is at or above it (its value may still rise into the step)."""
    N, n_obs = Q.shape
    out: dict[int, tuple[int, ...]] = {}
    if N < 2:
        return out
    high = Q >= threshold[None, :]
    local = np.zeros_like(high)
    if N > 2:
        local[1:-1] = (Q[1:-1] >= Q[:-2]) & (Q[1:-1] >= Q[2:])
    for j in range(n_obs):
        steps: set[int] = set()
        for k in np.flatnonzero(local[:, j] & high[:, j]).tolist():
            steps.update((k - 1, k))
        if high[0, j]:
            steps.add(0)
        if high[-1, j]:
            steps.add(N - 2)
        if steps:
            out[j] = tuple(sorted(steps))
    return out


def _clip(nodes, Z, U, D, lo, hi, dense_states):
    """The stretch's nodes, states, inputs and step derivatives inside [lo, hi], its edges
    added as nodes where they fall between two (exact states there)."""
    keep = (nodes >= lo) & (nodes <= hi)
    new_t, new_Z, new_U = [], [], []
    # the left edge
    if nodes[0] < lo:
        k = int(np.searchsorted(nodes, lo, side="right")) - 1
        k = min(k, nodes.size - 2)
        sigma = np.array([(lo - nodes[k]) / (nodes[k + 1] - nodes[k])])
        z_lo, u_lo = dense_states(np.array([k]), sigma)
        new_t.append([lo])
        new_Z.append(z_lo[0])
        new_U.append(u_lo[0])
    idx = np.flatnonzero(keep)
    if idx.size:
        new_t.append(nodes[idx])
        new_Z.append(Z[idx])
        new_U.append(U[idx])
    if nodes[-1] > hi:
        k = int(np.searchsorted(nodes, hi, side="right")) - 1
        k = min(max(k, 0), nodes.size - 2)
        sigma = np.array([(hi - nodes[k]) / (nodes[k + 1] - nodes[k])])
        z_hi, u_hi = dense_states(np.array([k]), sigma)
        new_t.append([hi])
        new_Z.append(z_hi[0])
        new_U.append(u_hi[0])
    t = np.concatenate([np.asarray(a, dtype=float) for a in new_t]) if new_t else np.zeros(0)
    Zc = np.concatenate(new_Z) if new_Z else np.zeros((0, Z.shape[1]))
    Uc = np.concatenate(new_U) if new_U else np.zeros((0, U.shape[1]))
    order = np.argsort(t, kind="stable")
    t, Zc, Uc = t[order], Zc[order], Uc[order]
    distinct = np.concatenate([[True], np.diff(t) > 0.0]) if t.size else np.zeros(0, bool)
    t, Zc, Uc = t[distinct], Zc[distinct], Uc[distinct]
    Dc = None
    if D is not None and t.size >= 2:
        Dc = step_input_derivatives(Uc[:-1], Uc[1:], np.diff(t))
    return t, Zc, Uc, Dc


def _integrated_states(ctx, config, v_impacts, t_s, h_s, z_s, sigma):
    """States and inputs inside steps of a closed nonlinear contact: DOP853 at rtol
    :data:`DENSE_RTOL` from each step's start node (the cam input from its law)."""
    from scipy.integrate import solve_ivp

    A, B, b, L = config.A, config.B, config.b, config.L
    S, P, m = t_s.size, sigma.size, z_s.shape[1]
    Zs = np.empty((S, P, m))
    Us = np.empty((S, P, N_INPUT))
    atol = ctx.nonlinear_atol(m) * 1e-3
    for s in range(S):
        t_a, h = float(t_s[s]), float(h_s[s])
        t_end = t_a + h

        def rhs(t, z, t_end=t_end):
            u = ctx.analytic_inputs_at(np.array([min(t, t_end)]), t_end)
            out = A @ z + B @ u[0] + b
            if L.shape[1]:
                out = out + L @ ctx.nonlinear_forces(config, z[None, :], u, v_impacts)[0]
            return out

        times = t_a + h * sigma
        if h <= 0.0:
            Zs[s] = z_s[s]
        else:
            sol = solve_ivp(rhs, (t_a, t_end), np.asarray(z_s[s], dtype=float), method="DOP853", rtol=DENSE_RTOL,
                            atol=atol, t_eval=np.clip(times, t_a, t_end), max_step=max(h / 4, 1e-12))
            if not sol.success or sol.y.shape[1] != P:
                raise SimulationError(f"dense states of a closed contact's step at t = {t_a:.9g} s: {sol.message}")
            Zs[s] = sol.y.T
        Us[s] = ctx.analytic_inputs_at(times, t_end)
    return Zs, Us


def combine(records, j: int, sense: int, lo: float = -math.inf, hi: float = math.inf) -> tuple[float, float] | None:
    """(value, time) of the located maximum (sense +1) or minimum (−1) of observable ``j``
    over the records whose interval lies in [lo, hi]; the records' bounds skip the
    refinement of those that cannot beat the best so far. None without a record."""
    chosen = [r for r in records if r is not None and r.t1 >= lo - 1e-12 and r.t0 <= hi + 1e-12]
    if not chosen:
        return None
    # the record with the best node value first: its refined value prunes the others
    order = sorted(chosen, key=lambda r: -sense * float(r.node_max[j] if sense > 0 else r.node_min[j]))
    best = None
    for r in order:
        if best is not None and sense * r.bound(j, sense) <= sense * best[0]:
            continue
        value, t = r.extreme(j, sense)
        if best is None or sense * value > sense * best[0] or (value == best[0] and t < best[1]):
            best = (value, t)
    return best

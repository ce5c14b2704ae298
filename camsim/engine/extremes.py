"""Extremes located on the solution, not read off the samples (spec §4).

Every peak or minimum camsim reports is found on the continuous solution, so it is the same
at any sample rate. Between events the solution is smooth, and each stepper knows it at
the nodes of its own internal grid (every grid point of a stretch, plus the stretch's two
ends, which are events, stops or the recording window's edges). For each observable q
(a mass's displacement, velocity or acceleration, an element's force, the cam force, the
camshaft torque: whatever the caller's ``observe`` computes from the state — the very code
that makes the traces, so a figure reported in two places is one number):

1. **Screen** the nodes (:func:`_screen`): between two nodes a smooth q rises at most
   h²/8·|q̈| above the larger one, q̈ estimated from the nodes' divided differences (the
   internal grid has at least twelve steps per period of the highest natural frequency) and
   taken :data:`SCREEN_SAFETY` times over; the steps whose bound exceeds the largest node
   value, and the two beside that node, are the candidates; the stretch's ends are nodes
   (its one-sided limits are candidates as they are).
2. **Refine** only where asked (:meth:`StretchExtremes.extreme`, lazily: a stretch is refined
   only when a bound could beat the best value found so far): on each candidate step the
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

import numpy as np

from camsim.errors import SimulationError
from camsim.engine.stepping import _FACT, _P, step_input_derivatives, taylor_rows
from camsim.engine.taylor import taylor_states

#: The bound of a smooth q between two nodes, h²/8·|q̈|, is taken this many times over
#: (q̈ itself estimated from the nodes; see _screen).
SCREEN_SAFETY = 4.0
#: Chebyshev–Lobatto points per refined step (the interpolant's degree + 1).
CHEBYSHEV_POINTS = 13
#: A located value between nodes replaces the best node value only when it is larger by more
#: than this fraction of the values interpolated (the interpolation's rounding).
ROUNDING = 64 * np.finfo(float).eps
#: Two values of one observable closer than this fraction of its scale are one height (a
#: dwell's plateau, one peak repeated cycle after cycle): the earlier instant is reported, so
#: the instant does not hang on the last bits of the arithmetic (library versions, platforms).
TIE = 1e-12
#: Newton steps on an interpolant's derivative from its best point of a 65-point grid.
NEWTON_STEPS = 3
#: DOP853 tolerance of a nonlinear step integrated again for its dense states.
DENSE_RTOL = 1e-13

_X = np.cos(np.pi * np.arange(CHEBYSHEV_POINTS)[::-1] / (CHEBYSHEV_POINTS - 1))  # −1 … 1
_SIGMA = 0.5 * (_X + 1.0)  # 0 … 1 along a step


def _lobatto_to_chebyshev(points: int) -> np.ndarray:
    """The matrix from values at the Chebyshev–Lobatto points (ascending) to the Chebyshev
    coefficients of their interpolant, in closed form (the discrete cosine transform): an
    inverse computed by LAPACK at import would round differently with the number of BLAS
    threads, and so would every located extreme (a Dask worker's against the caller's)."""
    n = points - 1
    j = np.arange(points)
    M = (2.0 / n) * np.cos(np.pi * np.outer(j, j) / n)  # k × (index j of x_j = cos(πj/n))
    M[:, [0, n]] *= 0.5
    M[[0, n], :] *= 0.5
    return M[:, ::-1]  # the points ascending, as _X


_TO_COEF = _lobatto_to_chebyshev(CHEBYSHEV_POINTS)
_FINE = np.linspace(-1.0, 1.0, 65)
_FINE_V = np.polynomial.chebyshev.chebvander(_FINE, CHEBYSHEV_POINTS - 1)
#: The first and second derivatives of a Chebyshev series as matrices on its coefficients.
_DER1 = np.array([np.polynomial.chebyshev.chebder(e) for e in np.eye(CHEBYSHEV_POINTS)]).T
_DER2 = np.array([np.polynomial.chebyshev.chebder(e, 2) for e in np.eye(CHEBYSHEV_POINTS)]).T


# ---------------------------------------------------------------------- dense states of a stretch
class _DenseStretch:
    """The exact states inside a stretch's steps, on demand.

    A linear configuration's state anywhere in a step is its Taylor series
    (:func:`taylor_states`); a closed nonlinear contact's is DOP853's at rtol
    :data:`DENSE_RTOL` from the step's start node, integrated once per step and kept (its
    dense output then serves every later point). The cam input in a step is the step's
    degree-7 polynomial, as the steppers integrate it.
    """

    def __init__(self, ctx, config, branches, v_impacts, exact: bool, nodes, Z, U, observe):
        self.ctx, self.config, self.branches, self.v_impacts = ctx, config, branches, v_impacts
        self.exact, self.nodes, self.Z, self.U, self.observe = exact, nodes, Z, U, observe
        self.h = np.diff(nodes)
        self.D = step_input_derivatives(U[:-1], U[1:], self.h, ctx.h)
        self._solutions: dict[int, object] = {}

    def states(self, steps: np.ndarray, sigma: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(S, P, m) states and (S, P, 4·c) inputs at fractions ``sigma`` ((P,) or (S, P)) of ``steps``."""
        steps = np.asarray(steps, dtype=int)
        S = steps.size
        sigma = np.broadcast_to(np.asarray(sigma, dtype=float), (S, np.shape(sigma)[-1]))
        h = self.h[steps]
        D = self.D[steps]
        # the cam input from its law: inside a short step, the step's degree-7 polynomial
        # carries the rounding of s amplified into s̈ (7.5e-7 m/s², 6e-8 of the CDTM cam's
        # peak acceleration, in a 20 µs step), and a driven mass's acceleration *is* s̈
        times = self.nodes[steps][:, None] + h[:, None] * sigma
        ends = np.broadcast_to(self.nodes[steps + 1][:, None], times.shape)
        # one evaluation of the law for every point (the limit from the left at a step's end)
        Us = self.ctx.analytic_inputs_at(times.reshape(-1), ends.reshape(-1)).reshape(times.shape + (self.ctx.n_input,))
        if self.exact:
            return taylor_states(self.config, self.Z[steps], D, h, sigma), Us
        Zs = np.empty((S, sigma.shape[1], self.Z.shape[1]))
        for r, k in enumerate(steps.tolist()):
            sol = self._solution(k)
            Zs[r] = sol(self.nodes[k] + h[r] * sigma[r]).T if h[r] > 0.0 else self.Z[k]
        return Zs, Us

    def values(self, steps, sigma) -> np.ndarray:
        """The observables at fractions ``sigma`` of ``steps``: (S, P, n_obs)."""
        Zs, Us = self.states(steps, sigma)
        S, P, m = Zs.shape
        return self.observe(self.config, self.branches, self.v_impacts, Zs.reshape(S * P, m),
                            Us.reshape(S * P, -1)).reshape(S, P, -1)

    def _solution(self, k: int):
        sol = self._solutions.get(k)
        if sol is None:
            sol = self._solutions[k] = _integrate_step(self.ctx, self.config, self.v_impacts, float(self.nodes[k]),
                                                       float(self.h[k]), self.Z[k], self.D[k])
        return sol


def _integrate_step(ctx, config, v_impacts, t_a: float, h: float, z0: np.ndarray, Dk: np.ndarray):
    """DOP853 (rtol :data:`DENSE_RTOL`) over one step of a closed nonlinear contact from its
    start node, the cam input the step's polynomial; returns the dense solution."""
    from scipy.integrate import solve_ivp

    A, B, b, L = config.A, config.B, config.b, config.L
    contacts = []
    for k, i in enumerate(config.power_contacts):
        delta, rate = ctx._delta(config, i)
        contacts.append((L[:, k], delta.Cz[0], delta.Du[0], float(delta.e[0]), rate.Cz[0], rate.Du[0], float(rate.e[0]),
                         ctx.model.elements[i].nonlinear_force_scalar, v_impacts.get(i)))
    # u_c(τ) = Σ_j D[j + c]·τ^j/j! (per cam): the coefficient matrix of τ^j per channel
    C = taylor_rows(Dk) / _FACT[: _P + 1]
    powers = np.arange(_P + 1)

    def rhs(t, z):
        u = C @ ((t - t_a) ** powers)
        out = A @ z + B @ u + b
        for Lk, dz, du, de, rz, ru, re, force, v in contacts:
            out = out + Lk * force(float(dz @ z + du @ u + de), float(rz @ z + ru @ u + re), v)
        return out

    sol = solve_ivp(rhs, (t_a, t_a + h), np.asarray(z0, dtype=float), method="DOP853", rtol=DENSE_RTOL,
                    atol=ctx.nonlinear_atol(z0.size) * 1e-3, dense_output=True)
    if not sol.success:
        raise SimulationError(f"dense states of a closed contact's step at t = {t_a:.9g} s: {sol.message}")
    return sol.sol


# ---------------------------------------------------------------------- the record of a stretch
#: Zoom levels of a closed nonlinear contact's refinement, the width of each (a fraction of
#: the previous interval) around the maximum found on the previous one: a contact's force
#: is not smooth at its ends (F ∝ δ^a), where the interpolant of a whole step is rough.
ZOOM = (1.0 / 16.0, 1.0 / 64.0)


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

    def __init__(self, dense: _DenseStretch, Q: np.ndarray):
        nodes = dense.nodes
        self.t0, self.t1 = float(nodes[0]), float(nodes[-1])
        n_obs = Q.shape[1]
        cols = np.arange(n_obs)
        kmax, kmin = np.argmax(Q, axis=0), np.argmin(Q, axis=0)
        self.node_max, self.node_min = Q[kmax, cols], Q[kmin, cols]
        self.node_tmax, self.node_tmin = nodes[kmax], nodes[kmin]
        cands_max, self.upper, cands_min, self.lower = _screen(nodes, Q)
        self._candidates = {1: cands_max, -1: cands_min}
        self._Q = Q
        self._dense = dense
        self._level1: dict[int, np.ndarray] = {}  # step → observables at the Chebyshev points
        self._refined: dict[tuple[int, int], tuple[float, float]] = {}

    def bound(self, j: int, sense: int) -> float:
        """Largest value (sense +1) or smallest (−1) the observable can take here (screening)."""
        return float(self.upper[j]) if sense > 0 else float(self.lower[j])

    def extreme(self, j: int, sense: int, tie: float = 0.0) -> tuple[float, float]:
        """(value, time) of the located maximum (``sense`` = +1) or minimum (−1) of
        observable ``j`` over this stretch; values within ``tie`` of it are one height, and
        the earliest of them is returned (a plateau's first node)."""
        key = (j, sense, tie)
        hit = self._refined.get(key)
        if hit is None:
            hit = self._refined[key] = self._refine(j, sense, tie)
        return hit

    def _refine(self, j: int, sense: int, tie: float) -> tuple[float, float]:
        q = sense * self._Q[:, j]
        k = int(np.argmax(q >= q.max() - tie))  # the first node of the best node value's height
        best = (float(self._Q[k, j]), float(self._dense.nodes[k]))
        steps = np.array(self._candidates[sense].get(j, ()), dtype=int)
        if steps.size == 0:
            return best
        dense = self._dense
        if dense.exact and not self._level1:
            # the first refinement of a linear stretch evaluates every candidate step of every
            # observable at once (one Taylor series, one call of the observables)
            union = sorted({k for cands in self._candidates.values() for ks in cands.values() for k in ks})
            for k, q in zip(union, dense.values(np.array(union), _SIGMA)):
                self._level1[k] = q
        missing = [k for k in steps.tolist() if k not in self._level1]
        if missing:
            for k, q in zip(missing, dense.values(np.array(missing), _SIGMA)):
                self._level1[k] = q
        values = sense * np.array([self._level1[k][:, j] for k in steps.tolist()])  # (S, P)
        lo = np.zeros(steps.size)
        width = np.ones(steps.size)
        x = _maximise(values)
        # (a linear configuration's step is smooth: its interpolant is exact to rounding)
        for zoom in (() if dense.exact else ZOOM):
            # the maximum again on a narrower interval around the last one (the interpolant
            # of a whole step may be rough where a contact's force is not smooth: its ends)
            centre = lo + width * 0.5 * (x + 1.0)
            width = width * 2.0 * zoom
            lo = np.clip(centre - 0.5 * width, 0.0, 1.0 - width)
            sigma = lo[:, None] + width[:, None] * _SIGMA[None, :]
            values = sense * dense.values(steps, sigma)[:, :, j]
            x = _maximise(values)
        coef = values @ _TO_COEF.T
        vals = _chebval_rows(x, coef)
        sigma_at = lo + width * 0.5 * (x + 1.0)
        times = dense.nodes[steps] + dense.h[steps] * sigma_at
        # a value between nodes wins only when it beats the best node by more than the
        # interpolation's rounding and the tie (a dwell's plateau would otherwise read a few
        # ulps high, differently at each sample rate)
        noise = np.maximum(ROUNDING * np.max(np.abs(values), axis=1), tie)
        for r in np.argsort(times, kind="stable"):
            if vals[r] > sense * best[0] + noise[r]:
                best = (float(sense * vals[r]), float(times[r]))
        return best


def _maximise(values: np.ndarray) -> np.ndarray:
    """Where on [−1, 1] each row's Chebyshev interpolant (values at the Chebyshev–Lobatto
    points) is largest: its best point on a fine grid, polished by Newton on its derivative."""
    coef = values @ _TO_COEF.T
    fine = coef @ _FINE_V.T
    k = np.argmax(fine, axis=1)
    x = _FINE[k]
    lo = _FINE[np.maximum(k - 1, 0)]
    hi = _FINE[np.minimum(k + 1, _FINE.size - 1)]
    d1, d2 = coef @ _DER1.T, coef @ _DER2.T
    # from a point within 1/64 of the maximum, three Newton steps on the derivative reach it
    # to rounding (quadratic convergence: 1e-2, 1e-4, 1e-8, 1e-16 in x; the value's error is
    # the square of x's)
    for _ in range(NEWTON_STEPS):
        g = _chebval_rows(x, d1)
        gg = _chebval_rows(x, d2)
        with np.errstate(divide="ignore", invalid="ignore"):
            step = np.where(gg < 0.0, g / gg, 0.0)
        x = np.clip(x - step, lo, hi)
    better = _chebval_rows(x, coef) >= fine[np.arange(fine.shape[0]), k]
    return np.where(better, x, _FINE[k])


def _chebval_rows(x: np.ndarray, coef: np.ndarray) -> np.ndarray:
    """Chebyshev series coef[i] at x[i] ∈ [−1, 1] for each row i: T_k(x) = cos(k·arccos x)."""
    T = np.cos(np.arccos(np.clip(x, -1.0, 1.0))[:, None] * np.arange(coef.shape[1]))
    return np.einsum("rk,rk->r", coef, T)


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
    Z, U : ndarray (N, m), (N, 4·c)
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
    dense = _DenseStretch(ctx, config, branches, v_impacts, exact, nodes, Z, U, observe)
    if t0 < lo or t1 > hi:
        # cut to the window: its edges become nodes (the exact states there)
        nodes, Z, U = _clip(dense, lo, hi)
        if nodes.size < 2:
            return None
        dense = _DenseStretch(ctx, config, branches, v_impacts, exact, nodes, Z, U, observe)
    return StretchExtremes(dense, observe(config, branches, v_impacts, Z, U))


def _screen(nodes: np.ndarray, Q: np.ndarray):
    """Per observable, the steps that may hold a value beyond its largest (and its smallest)
    node value, and the bounds of the values between nodes.

    Between two nodes a smooth q exceeds the larger node value by at most h²/8·|q̈|; q̈ is
    estimated at each node by the divided second difference of its neighbours (exact to
    about (ω·h)²/12 for a mode resolved at twelve steps per period) and taken
    :data:`SCREEN_SAFETY` times over. A step is a candidate when its bound exceeds the largest
    node value, or when it ends at that node (the maximum may sit just beside it). With two
    nodes (a stretch between two events and no grid point) the one step is a candidate. The
    minimum is screened alike (the same excess below the smaller node value).

    Returns
    -------
    (dict, ndarray, dict, ndarray)
        For the maxima: observable → candidate step indices, the upper bound of each
        observable (n_obs,); the same for the minima with the lower bound.
    """
    N, n_obs = Q.shape
    kbest, kworst = np.argmax(Q, axis=0), np.argmin(Q, axis=0)
    cols = np.arange(n_obs)
    top, bottom = Q[kbest, cols], Q[kworst, cols]
    if N == 2:
        span = np.abs(Q[1] - Q[0])
        every = {j: (0,) for j in range(n_obs)}
        return every, top + span + 1e-12 * np.abs(top), dict(every), bottom - span - 1e-12 * np.abs(bottom)
    h = np.diff(nodes)
    dQ = np.diff(Q, axis=0)
    slopes = dQ / h[:, None]  # (N − 1, n_obs)
    curv = np.empty((N, n_obs))
    curv[1:-1] = np.abs(np.diff(slopes, axis=0)) * (2.0 / (h[:-1] + h[1:]))[:, None]
    curv[0], curv[-1] = curv[1], curv[-2]
    excess = (SCREEN_SAFETY / 8.0 * h * h)[:, None] * np.maximum(curv[:-1], curv[1:])
    # a stretch's first and last steps: their end node has no neighbour beyond it, so the
    # curvature there is the next node's: their bound also takes the slope across the step
    excess[0] += 0.5 * np.abs(dQ[0])
    excess[-1] += 0.5 * np.abs(dQ[-1])
    upper = np.maximum(Q[:-1], Q[1:]) + excess  # (N − 1, n_obs)
    lower = np.minimum(Q[:-1], Q[1:]) - excess
    scale = np.maximum(np.abs(top), np.abs(bottom))
    above = upper > (top + 1e-13 * scale)[None, :]
    below = lower < (bottom - 1e-13 * scale)[None, :]
    out = []
    for flags, best in ((above, kbest), (below, kworst)):
        cands: dict[int, tuple[int, ...]] = {}
        rows, js = np.nonzero(flags)
        per = {j: [] for j in range(n_obs)}
        for r, j in zip(rows.tolist(), js.tolist()):
            per[j].append(r)
        for j in range(n_obs):
            steps = set(per[j])
            k = int(best[j])
            steps.update(s for s in (k - 1, k) if 0 <= s < N - 1)
            cands[j] = tuple(sorted(steps))
        out.append(cands)
    return out[0], np.maximum(top, np.max(upper, axis=0)), out[1], np.minimum(bottom, np.min(lower, axis=0))


def _clip(dense: _DenseStretch, lo: float, hi: float):
    """The stretch's nodes, states and inputs inside [lo, hi], with the window's edges as
    nodes where they fall between two (the exact states there)."""
    nodes, Z, U = dense.nodes, dense.Z, dense.U
    keep = (nodes >= lo) & (nodes <= hi)
    ts, Zs, Us = [nodes[keep]], [Z[keep]], [U[keep]]
    for edge in (lo, hi):
        if nodes[0] < edge < nodes[-1] and not np.any(nodes == edge):
            k = min(int(np.searchsorted(nodes, edge, side="right")) - 1, nodes.size - 2)
            z_e, u_e = dense.states(np.array([k]), np.array([(edge - nodes[k]) / (nodes[k + 1] - nodes[k])]))
            ts.append(np.array([edge]))
            Zs.append(z_e[0])
            Us.append(u_e[0])
    t = np.concatenate(ts)
    order = np.argsort(t, kind="stable")
    return t[order], np.concatenate(Zs)[order], np.concatenate(Us)[order]

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

from camsim.engine.dense import _SIGMA, _TO_COEF, CHEBYSHEV_POINTS, DenseStretch, batch_values, chebval_rows, maximise  # noqa: F401

#: The bound of a smooth q between two nodes, h²/8·|q̈|, is taken this many times over
#: (q̈ itself estimated from the nodes; see _screen).
SCREEN_SAFETY = 4.0
#: A located value between nodes replaces the best node value only when it is larger by more
#: than this fraction of the values interpolated (the interpolation's rounding).
ROUNDING = 64 * np.finfo(float).eps
#: Two values of one observable closer than this fraction of its scale are one height (a
#: dwell's plateau, one peak repeated cycle after cycle): the earlier instant is reported, so
#: the instant does not hang on the last bits of the arithmetic (library versions, platforms).
TIE = 1e-12

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

    def __init__(self, dense: DenseStretch, Q: np.ndarray):
        nodes = dense.nodes
        self.t0, self.t1 = float(nodes[0]), float(nodes[-1])
        n_obs = Q.shape[1]
        cols = np.arange(n_obs)
        kmax, kmin = np.argmax(Q, axis=0), np.argmin(Q, axis=0)
        self.node_max, self.node_min = Q[kmax, cols], Q[kmin, cols]
        self.node_tmax, self.node_tmin = nodes[kmax], nodes[kmin]
        self._excess = _excess_bound(Q)
        #: Loose bounds for every observable at once (the node extremes widened by the
        #: largest excess a step can have, :func:`_excess_bound`); :meth:`bound` is tighter.
        self.upper = self.node_max + self._excess
        self.lower = self.node_min - self._excess
        self._scale = np.maximum(np.abs(self.node_max), np.abs(self.node_min))
        self._Q = Q
        self._dense = dense
        self._screened: dict[tuple[int, int], tuple[np.ndarray, float]] = {}
        self._level1: dict[int, np.ndarray] = {}  # step → observables at the Chebyshev points
        self._refined: dict[tuple[int, int], tuple[float, float]] = {}

    def loose_bound(self, j: int, sense: int) -> float:
        """A bound of observable ``j`` here (largest value for ``sense`` +1, smallest for −1)
        known without screening its steps."""
        return float(self.upper[j]) if sense > 0 else float(self.lower[j])

    def bound(self, j: int, sense: int) -> float:
        """Largest value (sense +1) or smallest (−1) the observable can take here (screening)."""
        return float(sense * self._screen(j, sense)[1])

    def _screen(self, j: int, sense: int) -> tuple[np.ndarray, float]:
        """(candidate steps, bound of sense·q) of observable ``j`` (:func:`_screen_column`)."""
        key = (j, sense)
        hit = self._screened.get(key)
        if hit is None:
            hit = self._screened[key] = _screen_column(self._dense.nodes, self._dense.h, sense * self._Q[:, j],
                                                       float(self._excess[j]), 1e-13 * float(self._scale[j]))
        return hit

    def extreme(self, j: int, sense: int, tie: float = 0.0) -> tuple[float, float]:
        """(value, time) of the located maximum (``sense`` = +1) or minimum (−1) of
        observable ``j`` over this stretch; values within ``tie`` of it are one height, and
        the earliest of them is returned (a plateau's first node)."""
        return refine_requests([(self, j, sense, tie)])[0]

    def _node_best(self, j: int, sense: int, tie: float) -> tuple[float, float]:
        """(value, time) of the first node of the best node value's height."""
        q = sense * self._Q[:, j]
        k = int(np.argmax(q >= q.max() - tie))
        return float(self._Q[k, j]), float(self._dense.nodes[k])


def refine_requests(requests) -> list[tuple[float, float]]:
    """Located extremes of many (record, observable, sense, tie) requests at once.

    Each request's candidate steps (:meth:`StretchExtremes._screen`) are evaluated at the
    Chebyshev points — every linear record's steps in one batch (:func:`batch_values`), a
    nonlinear one's from its DOP853 solution — and the interpolants' maxima located in one
    call (:func:`maximise`; a nonlinear record's zoomed in twice around each). A value
    between nodes replaces the best node value only when it beats it by more than the
    interpolation's rounding and the tie (a dwell's plateau would otherwise read a few ulps
    high, differently at each sample rate).

    Returns
    -------
    list of (float, float)
        (value, time) per request, in its order (cached on the record).
    """
    out: list = [None] * len(requests)
    todo = []
    for i, (rec, j, sense, tie) in enumerate(requests):
        hit = rec._refined.get((j, sense, tie))
        if hit is not None:
            out[i] = hit
            continue
        steps = rec._screen(j, sense)[0]
        if steps.size == 0:
            out[i] = rec._refined[(j, sense, tie)] = rec._node_best(j, sense, tie)
            continue
        todo.append((i, rec, j, sense, tie, steps))
    if not todo:
        return out
    # the Chebyshev values of every step still missing, record by record, evaluated together
    wanted: dict[int, tuple] = {}
    for _, rec, _, _, _, steps in todo:
        entry = wanted.setdefault(id(rec), (rec, set()))
        entry[1].update(k for k in steps.tolist() if k not in rec._level1)
    items = [(rec, np.array(sorted(ks), dtype=int)) for rec, ks in wanted.values() if ks]
    for (rec, steps), values in zip(items, batch_values([(rec._dense, steps) for rec, steps in items])):
        for k, q in zip(steps.tolist(), values):
            rec._level1[k] = q
    exact = [t for t in todo if t[1]._dense.exact]
    if exact:
        rows = [t[3] * np.array([t[1]._level1[k][:, t[2]] for k in t[5].tolist()]) for t in exact]
        stacked = np.concatenate(rows)
        xs = maximise(stacked)
        vals = chebval_rows(xs, stacked @ _TO_COEF.T)
        k = 0
        for t, values in zip(exact, rows):
            n = values.shape[0]
            lo, width = np.zeros(n), np.ones(n)
            out[t[0]] = _settle(t, values, lo, width, xs[k : k + n], vals[k : k + n])
            k += n
    for t in todo:
        if not t[1]._dense.exact:
            out[t[0]] = _refine_nonlinear(t)
    return out


def _settle(request, values, lo, width, x, vals) -> tuple[float, float]:
    """A request's located extreme from its candidate steps' interpolated maxima (``x`` on
    [−1, 1] of the sub-interval [lo, lo + width] of each step, ``vals`` there)."""
    i, rec, j, sense, tie, steps = request
    best = rec._node_best(j, sense, tie)
    dense = rec._dense
    sigma_at = lo + width * 0.5 * (x + 1.0)
    times = dense.nodes[steps] + dense.h[steps] * sigma_at
    noise = np.maximum(ROUNDING * np.max(np.abs(values), axis=1), tie)
    for r in np.argsort(times, kind="stable"):
        if vals[r] > sense * best[0] + noise[r]:
            best = (float(sense * vals[r]), float(times[r]))
    rec._refined[(j, sense, tie)] = best
    return best


def _refine_nonlinear(request) -> tuple[float, float]:
    """A closed nonlinear contact's request: the interpolant of a whole step may be rough
    where the contact's force is not smooth (its ends), so the maximum is located again on
    narrower intervals around the last one (:data:`ZOOM`)."""
    i, rec, j, sense, tie, steps = request
    dense = rec._dense
    values = sense * np.array([rec._level1[k][:, j] for k in steps.tolist()])  # (S, P)
    lo = np.zeros(steps.size)
    width = np.ones(steps.size)
    x = maximise(values)
    for zoom in ZOOM:
        centre = lo + width * 0.5 * (x + 1.0)
        width = width * 2.0 * zoom
        lo = np.clip(centre - 0.5 * width, 0.0, 1.0 - width)
        sigma = lo[:, None] + width[:, None] * _SIGMA[None, :]
        values = sense * dense.values(steps, sigma)[:, :, j]
        x = maximise(values)
    vals = chebval_rows(x, values @ _TO_COEF.T)
    return _settle(request, values, lo, width, x, vals)


# ---------------------------------------------------------------------- building the record
def stretch_extremes(ctx, stretch, Q: np.ndarray, observe, window: tuple[float, float]) -> list[StretchExtremes]:
    """Screen a stretch's nodes and prepare the refinement of its extremes: one record per
    smooth piece of it (between the cam's breaks).

    Parameters
    ----------
    ctx : EngineContext
    stretch : camsim.engine.state.Stretch
        The stretch with every node of its solution (its start, grid points, break pairs,
        end); ``exact`` says how its states between nodes are found (the linear
        configuration's Taylor series, or DOP853 from the node before).
    Q : ndarray (N, n_obs)
        The observables at its nodes (the caller has them: they are the traces' columns).
    observe : callable
        ``observe(config, branches, v_impacts, Z, U) -> (N, n_obs)``: the observables at
        other states (the refinement's, the window's edges).
    window : (float, float)
        The recording window [s]; the part of the stretch outside it is left out.

    Returns
    -------
    list of StretchExtremes
        In time order; empty when the stretch does not reach into the window. A piece is a
        record of its own, as a stretch that ended at each break was: a value repeated in
        two pieces (a cam's rise and its fall) is one height reported at its first instant
        by the fold (:func:`camsim.run.extremes.fold`), and a plateau that starts at a
        break is reported there, whatever the grid.
    """
    lo, hi = window
    nodes = stretch.t
    t0, t1 = float(nodes[0]), float(nodes[-1])
    if t1 < lo or t0 > hi or nodes.size < 2 or t1 - t0 <= 0.0:
        return []
    config, branches, v_impacts, exact = stretch.config, stretch.branches, stretch.v_impacts, stretch.exact
    cuts = np.flatnonzero(np.diff(nodes) <= 0.0) + 1  # a break: its right node starts a piece
    out = []
    for a, b in zip([0, *cuts.tolist()], [*cuts.tolist(), nodes.size]):
        if b - a < 2 or nodes[b - 1] < lo or nodes[a] > hi:
            continue
        piece_nodes, Z, U, Qp = nodes[a:b], stretch.z[a:b], stretch.u[a:b], Q[a:b]
        dense = DenseStretch(ctx, config, branches, v_impacts, exact, piece_nodes, Z, U, observe)
        if piece_nodes[0] < lo or piece_nodes[-1] > hi:
            # cut to the window: its edges become nodes (the exact states there)
            piece_nodes, Z, U, Qp = _clip(dense, lo, hi, Qp)
            if piece_nodes.size < 2 or piece_nodes[-1] <= piece_nodes[0]:
                continue
            dense = DenseStretch(ctx, config, branches, v_impacts, exact, piece_nodes, Z, U, observe)
        out.append(StretchExtremes(dense, Qp))
    return out


def _excess_bound(Q: np.ndarray) -> np.ndarray:
    """Per observable, a bound of how far any step of a smooth piece rises above its larger
    node: SAFETY/8·h²·|q̈| ≤ SAFETY/8·max|Δ²q| over the piece's uniform grid steps (every
    step but the first and the last, which :func:`_screen_column` bounds one by one)."""
    if Q.shape[0] == 2:
        # one step and no node inside it: nothing bounds what happens between its ends (a
        # short contact's force is zero at both and positive between): always refined
        return np.full(Q.shape[1], np.inf)
    if Q.shape[0] <= 4:
        return np.zeros(Q.shape[1])
    d2 = Q[3:-1] - 2.0 * Q[2:-2]
    d2 += Q[1:-3]
    return (SCREEN_SAFETY / 8.0) * np.max(np.abs(d2), axis=0)


def _screen_column(nodes: np.ndarray, h: np.ndarray, q: np.ndarray, excess: float, tol: float):
    """The steps of one observable q (times its sense: the maximum is screened) that may
    hold a value beyond its largest node value, and the bound of its values between nodes.

    Between two nodes a smooth q exceeds the larger node value by at most h²/8·|q̈|; q̈ is
    estimated at each node by the divided second difference of its neighbours (exact to
    about (ω·h)²/12 for a mode resolved at twelve steps per period) and taken
    :data:`SCREEN_SAFETY` times over. A step is a candidate when its bound exceeds the largest
    node value by more than ``tol``, or when it ends at that node (the maximum may sit just
    beside it). The first and last steps (whose end node has no neighbour beyond it) take
    the curvature of the node inside and half the slope across the step as well; a record
    of one step (two events with no grid point between) has no bound and is always refined
    (its span is none: a short contact's force is zero at both ends).

    Only the steps that touch a node within ``excess`` (:func:`_excess_bound`) of the best
    are bounded one by one: no other step can rise above it (issue 42: the nodes are
    scanned three times for every observable at once, not thirty).

    Returns
    -------
    (ndarray, float)
        The candidate steps, ascending, and the bound of q over the record.
    """
    N = q.size
    best = int(np.argmax(q))
    q_best = float(q[best])
    if N == 2:
        return np.array([0]), np.inf  # see _excess_bound
    near = np.flatnonzero(q > q_best - excess - tol)
    rows = np.concatenate([near, [0, 1, N - 2, N - 1]])
    steps = np.unique(np.concatenate([rows - 1, rows]))
    steps = steps[(steps >= 0) & (steps < N - 1)]
    k0, k1 = np.clip(steps, 1, N - 2), np.clip(steps + 1, 1, N - 2)  # a piece's end node: its neighbour's curvature

    def curvature(k):
        left, right = q[k] - q[k - 1], q[k + 1] - q[k]
        hl, hr = h[k - 1], h[k]
        return np.abs(right / hr - left / hl) * (2.0 / (hl + hr))

    q0, q1 = q[steps], q[steps + 1]
    local = (SCREEN_SAFETY / 8.0) * h[steps] ** 2 * np.maximum(curvature(k0), curvature(k1))
    local = local + np.where((steps == 0) | (steps == N - 2), 0.5 * np.abs(q1 - q0), 0.0)
    local = np.maximum(q0, q1) + local
    chosen = (local > q_best + tol) | (steps == best - 1) | (steps == best)
    return steps[chosen], max(q_best, float(np.max(local)))


def _clip(dense: DenseStretch, lo: float, hi: float, Q: np.ndarray):
    """The stretch's nodes, states, inputs and observables inside [lo, hi], with the
    window's edges as nodes where they fall between two (the exact states there)."""
    nodes, Z, U = dense.nodes, dense.Z, dense.U
    keep = (nodes >= lo) & (nodes <= hi)
    ts, Zs, Us, Qs = [nodes[keep]], [Z[keep]], [U[keep]], [Q[keep]]
    for edge in (lo, hi):
        if nodes[0] < edge < nodes[-1] and not np.any(nodes == edge):
            k = min(int(np.searchsorted(nodes, edge, side="right")) - 1, nodes.size - 2)
            if nodes[k + 1] <= nodes[k]:
                continue  # a break at the edge: its nodes are there already
            z_e, u_e = dense.states(np.array([k]), np.array([(edge - nodes[k]) / (nodes[k + 1] - nodes[k])]))
            ts.append(np.array([edge]))
            Zs.append(z_e[0])
            Us.append(u_e[0])
            Qs.append(dense.observe(dense.config, dense.branches, dense.v_impacts, z_e[0], u_e[0]))
    t = np.concatenate(ts)
    order = np.argsort(t, kind="stable")
    return t[order], np.concatenate(Zs)[order], np.concatenate(Us)[order], np.concatenate(Qs)[order]

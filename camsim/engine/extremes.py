"""Extremes located on the solution, not read off the samples (spec §4).

Every peak or minimum camsim reports is found on the continuous solution, so it is the same
at any sample rate. Between events the solution is smooth but for the cam's breaks (its
joins and a law's inner kinks, where its acceleration or jerk may jump), and a stretch knows
it at every node of its own (its start, its grid points, each break as a pair of nodes — the
limits from the left and from the right — and its end). For each observable q (a mass's
displacement, velocity or acceleration, an element's force, the cam force, the camshaft
torque: whatever the caller's ``observe`` computes from the state — the very code that
makes the traces, so a figure reported in two places is one number):

1. **Screen** the nodes (:func:`~camsim.engine.screen.screen_rows`): between two nodes a
   smooth q rises at most h²/8·|q̈| above the larger one, q̈ estimated from the nodes' divided
   differences (the internal grid has at least twelve steps per period of the highest natural
   frequency) and taken :data:`SCREEN_SAFETY` times over; the steps whose bound exceeds the
   largest node value, and the two beside that node, are the candidates; a stretch's ends
   and a break's nodes are nodes (the one-sided limits there are candidates as they are).
   The whole stretch is scanned three times for every observable at once
   (:func:`~camsim.engine.screen.excess_bound`: the largest second difference bounds every
   step); only the steps near the best node are bounded one by one, lazily, for the
   observables asked — all the columns a fold asks of a record in one pass.
2. **Refine** only where asked (:func:`refine_requests`: a stretch is refined only where its
   bound can reach the best value there is): on each candidate step the exact state is
   evaluated at :data:`~camsim.engine.dense.CHEBYSHEV_POINTS` Chebyshev–Lobatto points — for a
   linear configuration from the Taylor series of its exact solution, for a closed nonlinear
   contact by DOP853 at rtol 1e-13 from the step's start node — q is interpolated there and
   the interpolant's maximum located by Newton's method on its derivative
   (:mod:`camsim.engine.dense`), for every request of a fold in one batch.

A maximum at a stretch end is the one-sided limit there: a damped contact's force jumps to
c·v at the instant of impact, and that value is the peak of a damping-dominated impact.

Values within a tie (:data:`TIE` of the quantity's scale) are one height, reported at its
first instant. The smooth pieces of a stretch (between its breaks) are the units of that
rule, as they are across stretches: a value repeated in two pieces (a cam's rise and its
fall) is reported at the first, and a plateau that starts at a break is reported there,
whatever the grid.
"""

from __future__ import annotations

from bisect import bisect_right

import numpy as np

from camsim.heartbeat import working
from camsim.engine.dense import _SIGMA, _TO_COEF, DenseStretch, batch_values, chebval_rows, maximise, row_products
from camsim.engine.screen import SCREEN_SAFETY, excess_bound, screen_rows, step_excess

#: A located value between nodes replaces the best node value only when it is larger by more
#: than this fraction of the values interpolated (the interpolation's rounding).
ROUNDING = 64 * np.finfo(float).eps
#: Two values of one observable closer than this fraction of its scale are one height (a
#: dwell's plateau, one peak repeated cycle after cycle): the earlier instant is reported, so
#: the instant does not hang on the last bits of the arithmetic (library versions, platforms).
TIE = 1e-12
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
        Loose bounds no value between the nodes can exceed, for every observable at once
        (the node extremes widened by the largest excess a step can have); :meth:`bound`
        is the screened, tighter one.
    """

    def __init__(self, dense: DenseStretch, QT: np.ndarray):
        nodes = dense.nodes
        self.t0, self.t1 = float(nodes[0]), float(nodes[-1])
        QT = np.ascontiguousarray(QT)  # rows end to end: the screen reads it flat (a window's cut is a view)
        self._QT = QT
        self._dense = dense
        n_obs, N = QT.shape
        h = dense.h
        moving = h > 0.0
        #: first node of each smooth piece (a break's right node starts one)
        self._starts = np.concatenate([[0], np.flatnonzero(~moving) + 1])
        # each piece's largest and smallest node value, every observable (n_obs, pieces): the
        # refinement's tie rule works piece by piece
        self._piece_max = np.maximum.reduceat(QT, self._starts, axis=1)
        self._piece_min = np.minimum.reduceat(QT, self._starts, axis=1)
        rows = np.arange(n_obs)
        # the first node of each row's extreme (argmax and argmin return the first: it lies
        # in the first piece that holds the extreme, as the tie rule wants)
        kmax, kmin = np.argmax(QT, axis=1), np.argmin(QT, axis=1)
        self.node_max, self.node_min = QT[rows, kmax], QT[rows, kmin]
        self.node_tmax, self.node_tmin = nodes[kmax], nodes[kmin]
        ends = np.concatenate([self._starts[1:] - 1, [N - 1]])  # last node of each piece
        self._piece_ends = ends
        #: each piece's first node and the one after its last, as Python ints (the refinement's scalars)
        self._piece_spans = (self._starts.tolist(), (ends + 1).tolist())
        # the node whose curvature each node takes (a piece's end node: its neighbour's),
        # -1 where a piece has one step only (nothing bounds it: always refined)
        cnode = np.arange(N)
        cnode[self._starts] = self._starts + 1
        cnode[ends] = ends - 1
        single = ends - self._starts == 1
        cnode[self._starts[single]] = -1
        cnode[ends[single]] = -1
        self._cnode = cnode
        # the steps whose bound is taken one by one whatever q does: each piece's first two
        # and last two (non-uniform lengths, one-sided curvatures)
        self._forced = np.unique(np.concatenate([self._starts, self._starts + 1, ends - 1, ends - 2]))
        self._forced = self._forced[(self._forced >= 0) & (self._forced < N - 1)]
        self._forced = self._forced[moving[self._forced]]
        #: steps that start or end a piece (their bound takes half their slope as well)
        self._end_step = np.zeros(N - 1, dtype=bool)
        self._end_step[self._starts[self._starts < N - 1]] = True
        self._end_step[ends[ends > 0] - 1] = True
        self._end_step &= moving
        self._moving = moving
        self._excess, self._d2 = excess_bound(QT, moving, bool(np.any(single)))
        self.upper = self.node_max + self._excess
        self.lower = self.node_min - self._excess
        self._scale = np.maximum(np.abs(self.node_max), np.abs(self.node_min))
        self._screened: dict[tuple[int, int], tuple[np.ndarray, float]] = {}
        self._forced_cache = None
        self._loose_cache = None
        self._kmax, self._kmin = kmax, kmin
        self._level1: dict[int, np.ndarray] = {}  # step → observables at the Chebyshev points
        self._refined: dict[tuple[int, int, float], tuple[float, float]] = {}

    def loose_bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """(largest, smallest) value every observable can take here (n_obs each), known
        without screening a column: the node extremes widened by the interior steps' excess
        (``upper``, ``lower``) and the bounds of the steps next to each piece's ends, which that
        excess leaves out (:meth:`_forced_bounds`). Without the latter a record of four nodes
        or fewer (every step next to an end, no interior excess) read its largest node as its
        bound, and a fold passed over it: an impact's peak between two seat impacts was
        reported 0.6 % low at 10 kHz (found by invariant (g)). Computed once per record."""
        hit = self._loose_cache
        if hit is None:
            steps, hi, lo = self._forced_bounds()
            up, low = self.upper, self.lower
            if steps.size:
                up, low = np.maximum(up, np.max(hi, axis=1)), np.minimum(low, np.min(lo, axis=1))
            hit = self._loose_cache = (up, low)
        return hit

    def loose_bound(self, j: int, sense: int) -> float:
        """A bound of observable ``j`` here (largest value for ``sense`` +1, smallest for −1)
        known without screening its steps (:meth:`loose_bounds`)."""
        up, low = self.loose_bounds()
        return float(up[j]) if sense > 0 else float(low[j])

    def bound(self, j: int, sense: int) -> float:
        """Largest value (sense +1) or smallest (−1) the observable can take here (screening)."""
        return float(sense * self._screen(j, sense)[1])

    def _screen(self, j: int, sense: int) -> tuple[np.ndarray, float]:
        """(candidate steps, bound of sense·q) of observable ``j`` (:func:`~camsim.engine.screen.screen_rows`)."""
        hit = self._screened.get((j, sense))
        if hit is None:
            self.screen([(j, sense)])
            hit = self._screened[(j, sense)]
        return hit

    def screen(self, queries) -> None:
        """Screen the (observable, sense) ``queries`` in one pass (those not screened yet;
        the results are kept for :meth:`bound` and the refinement)."""
        todo = [q for q in queries if q not in self._screened]
        if todo:
            js = np.array([j for j, _ in todo], dtype=np.intp)
            senses = np.array([sense for _, sense in todo])
            for q, hit in zip(todo, screen_rows(self, js, senses)):
                self._screened[q] = hit

    def _forced_bounds(self):
        """(steps, upper, lower): the steps next to each piece's ends and, for every
        observable at once, the largest and smallest value each may reach (n_obs, steps);
        computed once per record."""
        hit = self._forced_cache
        if hit is None:
            steps = self._forced
            n_obs, N = self._QT.shape
            exc = step_excess(self, self._QT.reshape(-1), (np.arange(n_obs) * N)[:, None], steps[None, :])
            q0, q1 = self._QT[:, steps], self._QT[:, steps + 1]
            hit = self._forced_cache = (steps, np.maximum(q0, q1) + exc, np.minimum(q0, q1) - exc)
        return hit

    def extreme(self, j: int, sense: int, tie: float = 0.0) -> tuple[float, float]:
        """(value, time) of the located maximum (``sense`` = +1) or minimum (−1) of
        observable ``j`` over this stretch; values within ``tie`` of it are one height, and
        the earliest of them is returned (a plateau's first node)."""
        return refine_requests([(self, j, sense, tie)])[0]


# ---------------------------------------------------------------------- refinement
def refine_requests(requests) -> list[tuple[float, float]]:
    """Located extremes of many (record, observable, sense, tie) requests at once.

    Each request's candidate steps (:func:`~camsim.engine.screen.screen_rows`) are evaluated at the Chebyshev
    points — every linear record's steps in one batch (:func:`~camsim.engine.dense.batch_values`),
    a nonlinear one's from its DOP853 solution — and the interpolants' maxima located in one
    call (:func:`~camsim.engine.dense.maximise`; a nonlinear record's zoomed in twice around
    each). Within each smooth piece, a value between nodes replaces the piece's best node
    value only when it beats it by more than the interpolation's rounding and the tie (a
    dwell's plateau would otherwise read a few ulps high, differently at each sample rate);
    the pieces' values within the tie of the best are one height, reported at its first
    instant.

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
            out[i] = _settle(rec, j, sense, tie, steps, None)
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
        # every exact request's candidate steps located in one batch, and the instants and
        # rounding allowances of their maxima with them (row by row: the same bits as
        # request by request)
        rows = [t[3] * np.array([t[1]._level1[k][:, t[2]] for k in t[5].tolist()]) for t in exact]
        stacked = np.concatenate(rows)
        n = stacked.shape[0]
        xs = maximise(stacked)
        vals = chebval_rows(xs, stacked @ _TO_COEF.T)
        t0 = np.concatenate([t[1]._dense.nodes[t[5]] for t in exact])
        h = np.concatenate([t[1]._dense.h[t[5]] for t in exact])
        ties = np.repeat(np.array([t[4] for t in exact]), [t[5].size for t in exact])
        found = _found(stacked, np.zeros(n), np.ones(n), xs, vals, t0, h, ties)
        k = 0
        for t in exact:
            m = t[5].size
            out[t[0]] = _settle(*t[1:], tuple(f[k : k + m] for f in found))
            k += m
    nonlinear = [t for t in todo if not t[1]._dense.exact]
    if nonlinear:
        for t, result in zip(nonlinear, _refine_nonlinear(nonlinear)):
            out[t[0]] = result
    return out


def _found(values, lo, width, x, vals, t0, h, tie) -> tuple[list, list, list]:
    """The interpolated maxima of candidate steps as lists (value, time, rounding allowance)
    for :func:`_settle`: ``x`` on [−1, 1] of the sub-interval [lo, lo + width] of each step
    (start ``t0``, length ``h``), ``vals`` there; ``values`` the interpolated ones (a row a
    step); ``tie`` per row or one for all."""
    sigma_at = lo + width * 0.5 * (x + 1.0)
    times = t0 + h * sigma_at
    noise = np.maximum(ROUNDING * np.max(np.abs(values), axis=1), tie)
    return vals.tolist(), times.tolist(), noise.tolist()


def _settle(rec, j: int, sense: int, tie: float, steps: np.ndarray, found) -> tuple[float, float]:
    """A request's located extreme from its candidate steps' interpolated maxima (``found``:
    :func:`_found`'s lists, a step each in the order of ``steps``; None: no candidate),
    piece by piece (see :func:`refine_requests`). Scalars in Python: a request has a few
    candidates in one or two pieces, where numpy's per-call cost was most of the work."""
    qj = rec._QT[j]
    nodes = rec._dense.nodes
    starts, stops = rec._piece_spans
    piece_max = rec._piece_max[j] if sense > 0 else -rec._piece_min[j]
    pm = piece_max.tolist()
    floor = float(np.max(piece_max)) - tie
    S = steps.size
    if len(starts) == 1:
        pid = [0] * S
    else:
        pid = [bisect_right(starts, k) - 1 for k in steps.tolist()]
    pieces = sorted({p for p, v in enumerate(pm) if v >= floor} | set(pid))
    if found is not None:
        vals, times, noise = found
        ordered = all(t == t for t in times)  # no NaN: Python's stable sort is numpy's
    heights = []
    for p in pieces:
        a, b = starts[p], stops[p]
        seg = qj[a:b] if sense > 0 else -qj[a:b]
        k = a + int(np.argmax(seg >= pm[p] - tie))  # the first node of the piece's best height
        v = float(qj[k])
        best = (v if sense > 0 else -v, float(nodes[k]))
        if found is not None:
            mine = [r for r in range(S) if pid[r] == p]
            if len(mine) > 1:
                mine = (sorted(mine, key=times.__getitem__) if ordered
                        else [mine[q] for q in np.argsort(np.array(times)[mine], kind="stable").tolist()])
            for r in mine:
                if vals[r] > best[0] + noise[r]:
                    best = (vals[r], times[r])
        heights.append(best)
    top = max(v for v, _ in heights)
    value, when = min(((v, t) for v, t in heights if v >= top - tie), key=lambda h: h[1])
    result = (sense * value, when)
    rec._refined[(j, sense, tie)] = result
    return result


def _refine_nonlinear(requests) -> list[tuple[float, float]]:
    """Closed nonlinear contacts' requests: the interpolant of a whole step may be rough
    where the contact's force is not smooth (its ends), so the maximum is located again on
    narrower intervals around the last one (:data:`ZOOM`).

    All requests zoom together: each level's states are one evaluation per record (its
    dense output called once per step, :meth:`~camsim.engine.dense.DenseStretch.states`),
    each level's maxima one batch. Row by row this is the arithmetic of a request alone; a
    request of one step keeps the products of a lone row
    (:func:`~camsim.engine.dense.row_products`)."""
    sizes = [t[5].size for t in requests]
    steps = np.concatenate([t[5] for t in requests])
    values = np.concatenate([t[3] * np.array([t[1]._level1[k][:, t[2]] for k in t[5].tolist()]) for t in requests])
    lone = np.repeat(np.array([n == 1 for n in sizes]), sizes)  # (rows,): rows of one-step requests
    # each record's rows, the observable and sense of each
    groups: dict[int, tuple] = {}
    first = 0
    for t, n in zip(requests, sizes):
        entry = groups.setdefault(id(t[1]), (t[1], [], [], []))
        entry[1].extend(range(first, first + n))
        entry[2].extend([t[2]] * n)
        entry[3].extend([t[3]] * n)
        first += n
    groups = [(rec, np.array(rows), np.array(cols), np.array(senses)) for rec, rows, cols, senses in groups.values()]
    lo = np.zeros(steps.size)
    width = np.ones(steps.size)
    x = _maximise_rows(values, lone)
    for zoom in ZOOM:
        centre = lo + width * 0.5 * (x + 1.0)
        width = width * 2.0 * zoom
        lo = np.clip(centre - 0.5 * width, 0.0, 1.0 - width)
        sigma = lo[:, None] + width[:, None] * _SIGMA[None, :]
        values = np.empty_like(values)
        for rec, rows, cols, senses in groups:
            level = rec._dense.values(steps[rows], sigma[rows])  # (rows, P, n_obs)
            values[rows] = senses[:, None] * level[np.arange(rows.size), :, cols]
        x = _maximise_rows(values, lone)
    vals = np.empty(steps.size)
    for mask in (lone, ~lone):
        if np.any(mask):
            vals[mask] = chebval_rows(x[mask], row_products(values[mask], _TO_COEF, mask is lone))
    t0 = np.concatenate([t[1]._dense.nodes[t[5]] for t in requests])
    h = np.concatenate([t[1]._dense.h[t[5]] for t in requests])
    ties = np.repeat(np.array([t[4] for t in requests]), sizes)
    found = _found(values, lo, width, x, vals, t0, h, ties)
    out, k = [], 0
    for t, n in zip(requests, sizes):
        out.append(_settle(*t[1:], tuple(f[k : k + n] for f in found)))
        k += n
        working()  # a chattering revolution refines thousands: the stall watchdog sees them advance
    return out


def _maximise_rows(values: np.ndarray, lone: np.ndarray) -> np.ndarray:
    """:func:`~camsim.engine.dense.maximise` of every row, the rows of one-step requests
    (``lone``) with a lone row's products."""
    x = np.empty(values.shape[0])
    for mask in (lone, ~lone):
        if np.any(mask):
            x[mask] = maximise(values[mask], lone=mask is lone)
    return x


# ---------------------------------------------------------------------- building the record
def stretch_extremes(ctx, stretch, QT: np.ndarray, observe, window: tuple[float, float]) -> StretchExtremes | None:
    """Prepare the located extremes of a stretch (its screening is lazy: :class:`StretchExtremes`).

    Parameters
    ----------
    ctx : EngineContext
    stretch : camsim.engine.state.Stretch
        The stretch with every node of its solution (its start, grid points, break pairs,
        end); ``exact`` says how its states between nodes are found (the linear
        configuration's Taylor series, or DOP853 from the node before).
    QT : ndarray (n_obs, N)
        The observables at its nodes, one row each (the caller has them: they are the
        traces' columns).
    observe : callable
        ``observe(config, branches, v_impacts, Z, U) -> (N, n_obs)``: the observables at
        other states (the refinement's, the window's edges).
    window : (float, float)
        The recording window [s]; the part of the stretch outside it is left out.

    Returns
    -------
    StretchExtremes or None
        None when the stretch does not reach into the window.
    """
    lo, hi = window
    nodes = stretch.t
    t0, t1 = float(nodes[0]), float(nodes[-1])
    if t1 < lo or t0 > hi or nodes.size < 2 or t1 - t0 <= 0.0:
        return None
    config, branches, v_impacts, exact = stretch.config, stretch.branches, stretch.v_impacts, stretch.exact
    Z, U = stretch.z, stretch.u
    dense = DenseStretch(ctx, config, branches, v_impacts, exact, nodes, Z, U, observe)
    if t0 < lo or t1 > hi:
        # cut to the window: its edges become nodes (the exact states there)
        nodes, Z, U, QT = _clip(dense, lo, hi, QT)
        if nodes.size < 2 or nodes[-1] <= nodes[0]:
            return None
        dense = DenseStretch(ctx, config, branches, v_impacts, exact, nodes, Z, U, observe)
    return StretchExtremes(dense, QT)


def _clip(dense: DenseStretch, lo: float, hi: float, QT: np.ndarray):
    """The stretch's nodes, states, inputs and observables inside [lo, hi], with the
    window's edges as nodes where they fall between two (the exact states there); a node
    pair of one time at either end (a break on the edge) keeps only its inner node."""
    nodes, Z, U = dense.nodes, dense.Z, dense.U
    i0 = int(np.searchsorted(nodes, lo, side="left"))
    i1 = int(np.searchsorted(nodes, hi, side="right"))
    parts_t, parts_z, parts_u, parts_q = [nodes[i0:i1]], [Z[i0:i1]], [U[i0:i1]], [QT[:, i0:i1]]
    for edge, where in ((lo, 0), (hi, 1)):
        if nodes[0] < edge < nodes[-1] and not (i0 < i1 and nodes[i0 if where == 0 else i1 - 1] == edge):
            k = min(int(np.searchsorted(nodes, edge, side="right")) - 1, nodes.size - 2)
            z_e, u_e = dense.states(np.array([k]), np.array([(edge - nodes[k]) / (nodes[k + 1] - nodes[k])]))
            q_e = dense.observe(dense.config, dense.branches, dense.v_impacts, z_e[0], u_e[0]).T
            for parts, value in ((parts_t, np.array([edge])), (parts_z, z_e[0]), (parts_u, u_e[0]), (parts_q, q_e)):
                parts.insert(0 if where == 0 else len(parts), value)
    if len(parts_t) == 1:  # no edge node added: views, no copies
        t, Z, U, Q = parts_t[0], parts_z[0], parts_u[0], parts_q[0]
    else:
        t = np.concatenate(parts_t)
        Z, U, Q = np.concatenate(parts_z), np.concatenate(parts_u), np.concatenate(parts_q, axis=1)
    # a break on an edge: the node outside the window (its limit from beyond) goes
    first, last = 0, t.size
    if t.size > 2 and t[1] == t[0]:
        first = 1
    if t.size > 2 and t[-2] == t[-1]:
        last = t.size - 1
    return t[first:last], Z[first:last], U[first:last], Q[:, first:last]

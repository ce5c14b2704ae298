"""The screen of a stretch's located extremes: which steps may hold a value beyond the nodes.

Step 1 of :mod:`camsim.engine.extremes` (whose docstring states the algorithm and its
guarantees). Between two nodes a smooth q rises at most h²/8·|q̈| above the larger one, q̈
estimated from the nodes' divided differences and taken :data:`SCREEN_SAFETY` times over.
The functions here bound those rises; they are written for many observables and many steps
at once (issue 42 again: a revolution screens a hundred columns, and one small numpy call
per column and step cost more than the arithmetic):

- :func:`excess_bound`: every observable's largest rise over its interior uniform steps,
  from the largest second difference (three passes over the whole stretch);
- :func:`step_excess`: the rise of given (observable, step) pairs, one by one;
- :func:`screen_rows`: the candidate steps and the bound of several observables of one
  record, for one sense, in one pass — the steps that touch a node within the excess of
  the best, those next to a piece's end, and the best node's two are bounded one by one,
  all columns together.

Every bound is computed element by element by one formula, whatever the batch: a step
bounded here has the value it had when each column was screened on its own (the results
are the same bits).
"""

from __future__ import annotations

import numpy as np

#: The bound of a smooth q between two nodes, h²/8·|q̈|, is taken this many times over
#: (q̈ itself estimated from the nodes; see screen_rows).
SCREEN_SAFETY = 4.0
#: Above this many nodes near the best value (a plateau), a column is screened in full
#: from the stored second differences rather than step by step.
NEAR_MAX = 256


def excess_bound(QT: np.ndarray, moving: np.ndarray, single: bool) -> tuple[np.ndarray, np.ndarray | None]:
    """Per observable, a bound of how far any step rises above its larger node:
    SAFETY/8·h²·|q̈| ≤ SAFETY/8·max|Δ²q| over the uniform grid steps inside the pieces
    (the steps next to a piece's ends, which :func:`screen_rows` bounds one by one, and
    the breaks left out); infinite when a piece has a single step (two events with no grid
    point between: nothing bounds it, a short contact's force is zero at both ends).

    Returns the bounds (n_obs,) and |Δ²q| at the interior nodes 2 … N − 3 (n_obs, N − 4;
    zero where the triplet is not of uniform steps inside a piece), or None."""
    n_obs, N = QT.shape
    if single:
        return np.full(n_obs, np.inf), None
    if N <= 4:
        return np.zeros(n_obs), None
    d2 = QT[:, 3:-1] + QT[:, 1:-3]  # interior nodes 2 … N − 3
    middle = QT[:, 2:-2]
    d2 -= middle
    d2 -= middle
    np.abs(d2, out=d2)
    if not np.all(moving):
        # a triplet that straddles a break is no second difference of a smooth q
        ok = moving[1:-2] & moving[2:-1] & moving[:-3] & moving[3:]
        d2[:, ~ok] = 0.0
    return (SCREEN_SAFETY / 8.0) * np.max(d2, axis=1), d2


def step_excess(rec, flat: np.ndarray, base: np.ndarray, steps: np.ndarray) -> np.ndarray:
    """How far q may rise above the larger node of each step (independent of the sense):
    SAFETY/8·h²·|q̈| at the step's ends (a piece's end node takes its neighbour's), plus half
    the slope across a piece's first or last step; infinite for a piece of one step.

    ``flat`` holds rows of N node values end to end (an observable each); the value of node
    ``k`` of a pair is ``flat[base + k]``. ``base`` and ``steps`` broadcast together: one
    entry per (observable, step) pair, in any shape."""
    h = rec._dense.h
    N = h.size + 1
    a, b = rec._cnode[steps], rec._cnode[steps + 1]
    unbounded = (a < 0) | (b < 0)

    def curvature(k):
        k = np.clip(np.where(k < 0, 1, k), 1, N - 2)
        at = base + k
        mid = flat[at]
        left, right = mid - flat[at - 1], flat[at + 1] - mid
        hl, hr = h[k - 1], h[k]
        with np.errstate(divide="ignore", invalid="ignore"):
            out = np.abs(right / hr - left / hl) * (2.0 / (hl + hr))
        return np.where(np.isfinite(out), out, 0.0)

    at = base + steps
    exc = (SCREEN_SAFETY / 8.0) * h[steps] ** 2 * np.maximum(curvature(a), curvature(b))
    exc = exc + np.where(rec._end_step[steps], 0.5 * np.abs(flat[at + 1] - flat[at]), 0.0)
    return np.where(unbounded, np.inf, exc)


def screen_rows(rec, js: np.ndarray, senses: np.ndarray) -> list[tuple[np.ndarray, float]]:
    """The steps of observables ``js`` of one record (each times its sense, ``senses`` ±1:
    the maximum is screened) that may hold a value beyond their largest node value, and the
    bound of their values between nodes, every column in one pass.

    Between two nodes a smooth q exceeds the larger node value by at most h²/8·|q̈|; q̈ is
    estimated at each node by the divided second difference of its neighbours (exact to
    about (ω·h)²/12 for a mode resolved at twelve steps per period) and taken
    :data:`SCREEN_SAFETY` times over. A step is a candidate when its bound exceeds the largest
    node value by more than 1e-13 of the observable's scale, or when it ends at that node
    (the maximum may sit just beside it). A piece's first and last steps (whose end node has
    no neighbour beyond it) take the curvature of the node inside and half the slope across
    the step as well; a piece of one step has no bound and is always a candidate. A break (a
    step of length zero) is never one: both its nodes are nodes.

    Only the steps that touch a node within the record's excess (:func:`excess_bound`) of
    the best, those next to a piece's ends and the best node's two are bounded one by one:
    no other step can rise above it. A column with more than :data:`NEAR_MAX` such nodes (a
    plateau) bounds its interior steps from the stored second differences at once instead.

    Returns
    -------
    list of (ndarray, float)
        Per row of ``js``: the candidate steps, ascending, and the bound of sense·q over the
        record.
    """
    QT = rec._QT
    N = QT.shape[1]
    js = np.asarray(js, dtype=np.intp)
    senses = np.asarray(senses)
    M = js.size
    # the maxima's rows first, then the minima's: each block compared in place
    order = np.argsort(-senses, kind="stable")
    js, senses = js[order], senses[order]
    n_up = int(np.count_nonzero(senses > 0))
    Q = QT[js]  # (M, N), contiguous: one row per column screened
    tol = 1e-13 * rec._scale[js]
    best = np.concatenate([rec._kmax[js[:n_up]], rec._kmin[js[n_up:]]])
    near = np.empty(Q.shape, dtype=bool)
    up, down = js[:n_up], js[n_up:]
    np.greater(Q[:n_up], (rec.node_max[up] - rec._excess[up] - tol[:n_up])[:, None], out=near[:n_up])
    np.less(Q[n_up:], (rec.node_min[down] + rec._excess[down] + tol[n_up:])[:, None], out=near[n_up:])
    rows = np.arange(M)
    # the nodes near the best (sparse: a peak's few), then the steps that touch them
    rn, n = np.nonzero(near)
    plateau = np.zeros(0, dtype=np.intp)
    if rec._d2 is not None and N > NEAR_MAX:
        plateau = np.flatnonzero(np.bincount(rn, minlength=M) > NEAR_MAX)
        if plateau.size:  # bounded from the second differences below
            keep = ~np.isin(rn, plateau)
            rn, n = rn[keep], n[keep]
    forced = rec._forced
    rs = np.concatenate([rn, rn, rows, rows, np.repeat(rows, forced.size)])
    ks = np.concatenate([n - 1, n, best - 1, best, np.tile(forced, M)])
    ok = (ks >= 0) & (ks < N - 1)
    rs, ks = rs[ok], ks[ok]
    ok = rec._moving[ks]  # never a break
    key = np.unique(rs[ok] * (N - 1) + ks[ok])  # each (row, step) once, row-major
    r, k = key // (N - 1), key % (N - 1)
    flat = Q.reshape(-1)
    base = r * N
    exc = step_excess(rec, flat, base, k)
    sign = senses[r].astype(float)  # ±1: sense·q exactly
    local = np.maximum(sign * flat[base + k], sign * flat[base + k + 1]) + exc
    q_best = senses * Q[rows, best]
    b = best[r]
    chosen = (local > (q_best + tol)[r]) | (k == b - 1) | (k == b)
    cuts = np.searchsorted(r, np.arange(1, M))
    cands = np.split(k[chosen], np.searchsorted(r[chosen], np.arange(1, M)))
    # each row's largest local bound (rows without a bounded step keep the best node's)
    top = np.full(M, -np.inf)
    filled = np.flatnonzero(np.diff(np.concatenate([[0], cuts, [r.size]])) > 0)
    if filled.size:
        top[filled] = np.maximum.reduceat(local, np.concatenate([[0], cuts])[filled])
    out = [(cands[i], max(float(q_best[i]), float(top[i]))) for i in range(M)]
    for i in plateau.tolist():
        # a plateau: every interior step's bound from the second differences at once
        q = senses[i] * Q[i]
        ad = rec._d2[js[i]]  # |Δ²q| at nodes 2 … N − 3 (zero near a break: those steps are forced)
        upper = np.maximum(q[2 : N - 3], q[3 : N - 2]) + (SCREEN_SAFETY / 8.0) * np.maximum(ad[:-1], ad[1:])
        steps = np.flatnonzero(upper > q_best[i] + tol[i]) + 2
        limit = max(out[i][1], float(np.max(upper)) if upper.size else -np.inf)
        out[i] = (np.union1d(out[i][0], steps), limit)
    back = [None] * M
    for i, o in enumerate(order.tolist()):
        back[o] = out[i]
    return back

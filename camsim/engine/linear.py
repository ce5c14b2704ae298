"""Exact advance of a linear configuration: step maps over the grid, guards on the exact solution.

Between events a configuration is linear time-invariant with a cam input; its exact step
maps (:mod:`camsim.engine.stepping`) carry whole chunks of the grid at numpy speed. Every
guard's value and exact time derivative is known at each node, so a cubic Hermite bound
per step reveals crossings that sign changes alone miss (a graze that crosses and re-crosses
inside one step); each candidate is located on the exact solution
(:func:`camsim.engine.roots.refine`) and polished on the analytic cam law
(:func:`camsim.engine.crossing.polish_crossing`).
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from camsim.engine.context import GRID_SNAP, EngineContext
from camsim.engine.crossing import grazes, polish_crossing
from camsim.engine.roots import refine
from camsim.elements.affine import Affine
from camsim.engine.state import TIME_EPS, Guard, State, Stretch, cubic_root, leaving_zero
from camsim.engine.stepping import exact_partial, forcing_coefficients, step_input_derivatives


def advance_linear(ctx: EngineContext, state: State, config, z0, guards, t_stop: float, record: bool):
    """Advance a linear configuration exactly from ``state`` until its first event or ``t_stop``.

    The cam's break times (segment joins, the inner kinks of a law) inside the stretch do
    not end it (issue 42): each is a node pair in the chunk that holds it — the state is
    continuous, the input's limits from the left and from the right differ — joined by a
    step of length zero, where the guard screen restarts as at a stretch's start (no step
    carries the input across it; a guard that jumps below zero there fires at that
    instant, one at its zero is lifted as just crossed: :func:`first_crossing`). Chunks of
    the grid are propagated by the cached step maps (modal recurrences), every guard is
    screened on the chunk's nodes with its exact rate, and the first crossing is located
    on the exact solution. Returns (the state at the end, the stretch with every node when
    ``record``, else None, the guard that fired or None).
    """
    maps = ctx.maps(config)
    h = ctx.h
    predicted = ctx.chunk_steps(state.t)
    chunk = predicted if predicted is not None else ctx._chunk
    parts: list[tuple] = []  # (nodes, Z, U, kind) per chunk, for the record
    z_start, t_start = z0, state.t
    restart = True  # the chunk starts the stretch
    while True:
        # Chunk ends on a grid point computed from its index, t_ref + k·h, so that a
        # sample's time (and the cam input there) is the same whatever the history.
        k_end = math.floor((t_start - ctx.t_ref) / h + GRID_SNAP) + chunk
        t_chunk_end = min(t_stop, ctx.t_ref + k_end * h)
        nodes, U, pairs, at_break = ctx.chunk_nodes(t_start, t_chunk_end)
        steps = np.diff(nodes)
        D = step_input_derivatives(U[:-1], U[1:], steps, h)
        Z = np.empty((nodes.size, config.dim))
        Z[0] = z_start
        # A grid step's computed length differs from h by the rounding of t (an ulp of t
        # grows with it: beyond t ≈ 500 s, 1e-9·h alone sent every step through expm,
        # 7x slower; long runs, camsim.run.stream).
        full = np.abs(steps - h) <= max(1e-9 * h, 4.0 * float(np.spacing(abs(nodes[-1]))))
        # Runs of full steps go through the cached maps, the others (a chunk's first and
        # last, the two beside each break) through an exact map of their own length; a
        # break's step of length zero carries the state over.
        k = 0
        for p in [*np.flatnonzero(~full).tolist(), steps.size]:
            if p > k:
                Z[k + 1 : p + 1] = maps.propagate(Z[k], D[k:p])
            if p < steps.size:
                if steps[p] > 0.0:
                    Z[p + 1] = exact_partial(config, Z[p], forcing_coefficients(config, D[p : p + 1])[0], steps[p])
                else:
                    Z[p + 1] = Z[p]
            k = p + 1
        restarts = ([0] if restart else []) + [q + 1 for q in pairs]
        hit = first_crossing(ctx, config, guards, nodes, Z, U, D, restarts)
        if hit is not None:
            ctx._chunk = 512  # events come in clusters: look ahead a little after one
            t_event, z_event, guard, index = hit
            ctx.watch.linear_chunk(config, nodes, Z, U, D, t_cut=t_event, z_cut=z_event, index=index)
            end = ctx._state_from(config, z_event, t_event, state)
            if record:
                parts.append((nodes[: index + 1], Z[: index + 1], U[: index + 1], _ALL, pairs))
                parts.append((np.array([t_event]), z_event[None, :], ctx.input_left(t_event)[None, :], _END, ()))
            return end, _full_stretch(ctx, state, config, parts) if record else None, guard
        ctx.watch.linear_chunk(config, nodes, Z, U, D)
        if record:
            # a chunk that ends on a break keeps its last node (the limit from the left);
            # the next chunk's first node is the break's right node
            parts.append((nodes, Z, U, _END if at_break else _CHUNK, pairs))
        t_start, z_start = nodes[-1], Z[-1]
        restart = at_break
        if t_start >= t_stop - TIME_EPS:
            break
        chunk = min(max(chunk * 2, 512), 16384)
        ctx._chunk = chunk
    end = ctx._state_from(config, z_start, t_stop, state)
    if record:
        parts.append((np.array([t_stop]), z_start[None, :], ctx.input_left(t_stop)[None, :], _END, ()))
    return end, _full_stretch(ctx, state, config, parts) if record else None, None


#: How a chunk's nodes enter a stretch's record (_full_stretch): all but its last (the next
#: chunk's first); all (the nodes before an event); all, its last no sample (the stretch's
#: end: the next stretch's start is that sample).
_CHUNK, _ALL, _END = 0, 1, 2


def _full_stretch(ctx: EngineContext, state: State, config, parts) -> Stretch:
    """The stretch's record from its chunks (see :data:`_CHUNK`); the samples are the grid
    points among the nodes, a break's left node excepted (its right node is the sample)."""
    ts, zs, us, flags = [], [], [], []
    for nodes, Z, U, kind, pairs in parts:
        n = nodes.size - 1 if kind == _CHUNK else nodes.size
        ts.append(nodes[:n])
        zs.append(Z[:n])
        us.append(U[:n])
        f = np.ones(n, dtype=bool)
        if kind == _END and n:
            f[-1] = False
        for q in pairs:
            if q < n:
                f[q] = False  # a break's left node
        flags.append(f)
    t = np.concatenate(ts)
    z = np.concatenate(zs)
    u = np.concatenate(us)
    samples = np.concatenate(flags) & ctx._on_grid(t)
    fn = np.zeros((t.size, 0))
    return Stretch(state.branches, config, t, z, u, fn, dict(state.v_impacts), samples=samples, exact=True)


def first_crossing(ctx: EngineContext, config, guards, nodes, Z, U, D, restarts):
    """Earliest guard crossing in the chunk: (t, z, guard, step index) or None.

    ``restarts`` are the nodes where the screen restarts as at a stretch's start: the
    chunk's first when it starts the stretch, and a break's right node (the break's step,
    of length zero, is never screened: the guards' jumps there are read at the restart).
    At a restart a guard below −tol (and not leaving zero) fires at once; one at its zero
    is the one just crossed, lifted until it has risen above its tolerance.
    """
    if not guards:
        return None
    steps = np.diff(nodes)[:, None]
    # All guards at once: values and exact time derivatives at every node.
    Cz, Du, e, Cz_d, Du_d, e_d, tol = ctx.stacked_guards(guards)
    G = Z @ Cz + U @ Du + e
    Gd = Z @ Cz_d + U @ Du_d + e_d
    g0 = G[:-1]
    g1 = G[1:]
    if restarts:
        g0, g1 = g0.copy(), g1.copy()  # the restarts raise some of them
    n_steps = g0.shape[0]
    lift = None
    now_at: dict[int, int] = {}  # restart node -> the guard that fires there at once
    seg_of_restart = sorted(restarts)
    bounds = seg_of_restart + [n_steps]
    for r, r_next in zip(seg_of_restart, bounds[1:]):
        # A guard at its zero and leaving it on the valid side is the one just crossed (or
        # its mirror in the new branches: a released contact's lifted guard), whatever the
        # sign of its value there; state.leaving_zero.
        leaving = leaving_zero(G[r], Gd[r], tol)
        now = np.flatnonzero((G[r] < -tol) & ~leaving)
        if now.size:
            now_at[r] = int(now[0])
            continue
        just = (np.abs(G[r]) <= tol) | leaving
        if np.any(just) and r < n_steps:
            # The guard just crossed sits at its zero to rounding and may stay there for a
            # step or two (a rigid contact released with zero relative speed separates as
            # ½·a·t²: after a 1e-8 s step its gap is still −9e-19 m of rounding). Until it
            # has first risen above its tolerance it counts as crossing again only below
            # −tol (issue 34: a seat released, stuck and released again at one instant at
            # 200 kHz only; camsim.engine.span.dop853_span lifts such a guard for its whole
            # span, without the two limits below).
            seg = slice(r, r_next)
            above = G[r + 1 : r_next + 1, just] > tol[just]
            risen = np.where(above.any(axis=0), above.argmax(axis=0), above.shape[0])
            if lift is None:
                lift = np.zeros_like(g0)
            # ... and only while it is not approaching: a step that ends with the guard
            # falling is a real return (a rigid bounce whose apex stays below the tolerance
            # lands after 2·v/a, as it would with no tolerance; lifted, it landed only at −tol,
            # and at a speed that no longer decayed: 38 bounces instead of 11 before sticking)
            early = np.arange(r_next - r)[:, None] < risen[None, :]
            lift[seg][:, just] = np.where(early & (Gd[r + 1 : r_next + 1, just] >= 0.0), tol[just], 0.0)
            g0[seg] += lift[seg]
            g1[seg] += lift[seg]
        if r < n_steps:
            g0[r, just] = np.maximum(g0[r, just], tol[just])  # just crossed: do not find it again
    hits = screen_steps(g0, g1, Gd, steps[:, 0])
    if not now_at and not hits.any():
        return None  # most chunks: no guard can reach zero in any step
    restart_set = set(restarts)
    seg_starts = sorted({0, *restarts})
    for r, r_next in zip(seg_starts, [*seg_starts[1:], n_steps]):
        if r in now_at:  # a guard below zero at a restart: the event is there, at once
            return nodes[r], Z[r], guards[now_at[r]], r
        best = _locate_in(ctx, config, guards, nodes, Z, D, steps, hits[r:r_next], r, lift, g0, g1, Gd, restart_set)
        if best is not None:
            return best
    return None


def screen_steps(g0: np.ndarray, g1: np.ndarray, Gd: np.ndarray, steps: np.ndarray) -> np.ndarray:
    """The steps where guards may reach zero: (N − 1, n_guards) flags.

    ``g0``, ``g1`` are each guard's values at the steps' starts and ends, ``Gd`` its exact
    rates at every node, ``steps`` the step lengths (a break's, zero, is never flagged). A
    cubic Hermite interpolant stays above min(g0, g1) − 4/27·(|ġ0| + |ġ1|)·h: only the steps
    where that bound is not positive can hold a crossing (g0 > 0 ≥ g1) or hide a dip below
    zero, and only those are looked at further (a sign change, or the cubic's interior
    minimum at or below zero).
    """
    rates = np.abs(Gd)
    reach = rates[:-1] + rates[1:]
    reach *= ((4.0 / 27.0) * steps)[:, None]
    low = np.minimum(g0, g1)
    low -= reach
    maybe = low <= 0.0
    maybe &= (steps > 0.0)[:, None]
    hits = np.zeros(maybe.shape, dtype=bool)
    if not maybe.any():
        return hits
    k_idx, j_idx = np.nonzero(maybe)
    a0, a1 = g0[k_idx, j_idx], g1[k_idx, j_idx]
    crossing = (a1 <= 0.0) & (a0 > 0.0)
    hits[k_idx[crossing], j_idx[crossing]] = True
    # the others: a dip to zero at an interior minimum of the cubic (the same arithmetic,
    # element by element, whatever else is screened: the same flags)
    rest = np.flatnonzero(~crossing)
    if not rest.size:
        return hits
    k_idx, j_idx, a0, a1 = k_idx[rest], j_idx[rest], a0[rest], a1[rest]
    h = steps[k_idx]
    b0, b1 = Gd[k_idx, j_idx] * h, Gd[k_idx + 1, j_idx] * h
    c2 = 3 * (a1 - a0) - 2 * b0 - b1
    c3 = 2 * (a0 - a1) + b0 + b1
    qa, qb, qc = 3 * c3, 2 * c2, b0
    disc = qb * qb - 4 * qa * qc
    real = np.flatnonzero(disc >= 0)
    if not real.size:
        return hits
    k_idx, j_idx, a0, b0, c2, c3 = k_idx[real], j_idx[real], a0[real], b0[real], c2[real], c3[real]
    qa, qb, qc, disc = qa[real], qb[real], qc[real], disc[real]
    found = np.zeros(real.size, dtype=bool)
    with np.errstate(divide="ignore", invalid="ignore"):
        sq = np.sqrt(disc)
        for sign in (-1.0, 1.0):
            sig = np.where(np.abs(qa) > 1e-300, (-qb + sign * sq) / (2 * qa), -qc / qb)
            ok = (sig > 0) & (sig < 1) & np.isfinite(sig)
            val = a0 + b0 * sig + c2 * sig**2 + c3 * sig**3
            found |= ok & (val <= 0.0)
    hits[k_idx[found], j_idx[found]] = True
    return hits


def _locate_in(ctx, config, guards, nodes, Z, D, steps, hits, offset, lift, g0, g1, Gd, restarts):
    """The earliest located crossing among the screen's hits of one segment (steps
    ``offset`` …): (t, z, guard, step) or None."""
    if not hits.any():
        return None
    candidates = []
    for j, guard in enumerate(guards):
        for k in (np.flatnonzero(hits[:, j])[:4] + offset).tolist():  # the earliest few; false alarms are rare
            shift = float(lift[k, j]) if lift is not None else 0.0
            searched = guard if shift == 0.0 else lifted(guard, shift)
            candidates.append((nodes[k], int(k), searched, guard, (g0[k, j], g1[k, j], Gd[k, j], Gd[k + 1, j])))
    if not candidates:
        return None
    candidates.sort(key=lambda c: (c[0], c[1]))
    # Several guards may cross inside one step: every candidate of the earliest step
    # that holds a crossing is located and the earliest root wins (sorting by step
    # alone handled them in guard order; issue 25: a seat impact 8.6e-5 s before a
    # rider's inside one 10 kHz step was found only after it, as a penetration).
    best = None
    for t_k, k, guard, original, ends in candidates:
        if best is not None and k != best[3]:
            break
        Ek = forcing_coefficients(config, D[k : k + 1])[0]
        hk = float(steps[k, 0])
        root = refine(config, guard, Z[k], D[k], Ek, hk, k in restarts, ends)
        if root is None:
            # The exact values at the step's ends bracket a crossing that the step's polynomial
            # missed (its Hermite cam input carries the rounding of s amplified by 1/h^k: a
            # constant-velocity belt at 50 kHz read D5…D7 of 1e9…1e19; a friction pair's slip
            # was lost and it held 155 N against F_B = 15 N). The crossing is there: start from
            # the root of the ends' cubic Hermite and polish it on the analytic cam law below.
            g_a, g_b, d_a, d_b = ends
            if k in restarts:
                g_a = max(g_a, guard.tol)
            if g_a > 0.0 and g_b <= 0.0:
                sigma = cubic_root(g_a, g_b, d_a * hk, d_b * hk)
                root = (sigma * hk, exact_partial(config, Z[k], Ek, sigma * hk) if sigma > 0 else Z[k])
        if root is not None:
            tau, z = root
            # issue 12 hook: polish on the analytic cam law to a 1e-10 s bracket; issue 25:
            # over the whole step on the exact state when the step's input polynomial
            # misplaced the root (None: no crossing in this step after all)
            z_k = Z[k]
            polished = polish_crossing(ctx, config, guard, nodes[k], hk, tau, z, D[k],
                                       state_at=lambda t, z_k=z_k, Ek=Ek: exact_partial(config, z_k, Ek, t) if t > 0 else z_k)
            if polished is None:
                continue
            tau, z = polished
            if grazes(ctx.cam, config, guard, nodes[k] + tau, nodes[k] + float(steps[k, 0]), z):
                continue  # a touch within the guard's tolerance: no event (issue 34)
            if best is None or nodes[k] + tau < best[0]:
                best = (nodes[k] + tau, z, original, k)
    return best


def lifted(guard: Guard, shift: float) -> Guard:
    """The guard raised by ``shift`` (its value + shift; the same rate, element and kind)."""
    value = guard.value
    return replace(guard, value=Affine(value.Cz, value.Du, value.Fn, value.e + shift))


class LinearStepper:
    """The stepper of a linear configuration: :func:`advance_linear`."""

    exact = True
    crosses_breaks = True

    def applies(self, ctx, config) -> bool:
        return config.linear

    def advance(self, ctx, state, config, z0, guards, t_stop, record):
        return advance_linear(ctx, state, config, z0, guards, t_stop, record)

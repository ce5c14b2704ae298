"""What the compliant-contact steppers share: the law ladder, the interpolation bound, and the
search for the first step of a window on which a guard may cross zero.

:mod:`camsim.engine.nonlinear` (the iterated remainder) and :mod:`camsim.engine.collocation`
(exponential Lobatto collocation) both step windows of grid steps of one closed nonlinear
contact and stop at the first step whose guard may cross; both read these from here.
"""

from __future__ import annotations

import numpy as np

#: Ratio of the stiffness / damping ladder of the reference linear laws.
LADDER = 1.05
#: Largest interpolation error of the remainder, relative to the peak contact force (the
#: same reasoning as camsim.engine.nonlinear.RTOL, and its value).
INTERP_TOL = 3e-12

def _fresh(guards):
    """The guards as they are (DOP853 handles a guard at zero at its start itself)."""
    return guards


#: The guards of a stretch stacked into one affine map, by the id of the guard list (the
#: list is kept with its entry, so the id cannot be reused while the entry lives).
_GUARD_STACKS: dict[int, tuple] = {}


def _guard_stack(guards):
    """(guards, Cz, Du, Fn, e, tol) of all guards at once: (g, m), (g, 4), (g, p), (g,), (g,)."""
    hit = _GUARD_STACKS.get(id(guards))
    if hit is None or hit[0] is not guards:
        values = [g.value for g in guards]
        hit = (guards, np.vstack([v.Cz for v in values]), np.vstack([v.Du for v in values]),
               np.vstack([v.Fn for v in values]), np.concatenate([v.e for v in values]), np.array([g.tol for g in guards]))
        if len(_GUARD_STACKS) > 64:
            _GUARD_STACKS.clear()
        _GUARD_STACKS[id(guards)] = hit
    return hit


def _first_hit(guards, Z, U, zdot, Udot, F, steps, first):
    """Index of the first step whose guard may cross zero (sign change or Hermite dip)."""
    if not guards:
        return None
    _, Cz, Du, Fn, e, tol = _guard_stack(guards)
    G = Z @ Cz.T + U @ Du.T + e
    if Fn.shape[1]:
        G = G + F[:, None] @ Fn.T
    Gd = zdot @ Cz.T + Udot @ Du.T
    g0 = G[:-1].copy()
    if first:
        just = np.abs(g0[0]) <= tol
        g0[0, just] = tol[just]
    g1 = G[1:]
    d0 = Gd[:-1] * steps[:, None]
    d1 = Gd[1:] * steps[:, None]
    crossing = (g1 <= 0.0) & (g0 > 0.0)
    maybe = np.minimum(g0, g1) - (4.0 / 27.0) * (np.abs(d0) + np.abs(d1)) <= 0.0
    bad = crossing | maybe | (g0 <= 0.0)
    rows = np.flatnonzero(np.any(bad, axis=1))
    return int(rows[0]) if rows.size else None

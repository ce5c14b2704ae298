"""The remainder iteration of the exponential stepper: its linear response, acceleration, maps.

Pieces of :mod:`camsim.engine.nonlinear`: the linear law around which a closed contact is
written (:class:`_LinearLaw`), the part of a window's states driven by the remainder
(:class:`_RemainderResponse`, in modal coordinates), Anderson acceleration of the fixed point
(:class:`_Anderson`), and the affine map of a window's first or last (partial) step.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from camsim.engine.recurrence import linear_recurrences
from camsim.engine.stepping import exact_partial, forcing_coefficients


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


def _kept_modes(maps):
    """(μ, to_modes, from_modes) of a modal StepMaps' kept modes: their multipliers, the
    projection z → w and the reconstruction w → z (weights folded in), cached on the maps."""
    modes = maps.__dict__.get("_kept_modes")
    if modes is None:
        keep = maps.keep
        modes = maps._kept_modes = (maps.mu[keep], maps.Vinv[keep].T.copy(),
                                    (maps.V[:, keep] * maps.weights[keep]).T.copy())
    return modes


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

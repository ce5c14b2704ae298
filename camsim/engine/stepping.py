"""Exact steps of a linear configuration with a polynomial cam input.

Between events a configuration is linear time-invariant with a cam input
(ż = A·z + B·u(t) + b, see :mod:`camsim.model.assembly`). Over each step each cam's
displacement is replaced by the degree-7 Hermite polynomial that matches s, ṡ, s̈, s⃛ at both ends
(error ~ (h/β)^8, far below 1e-9 relative; steps are split at cam segment joins, where
derivatives jump), and the step map is then exact:

    z(t+h) = Φ·z(t) + Σ_j Γ_j·E_j,    Φ = e^{Ah},  Γ_j = ∫₀ʰ e^{A(h−σ)} σ^j/j! dσ

with Φ and Γ_j from one matrix exponential of a block chain (Van Loan 1978), cached per
configuration (:class:`StepMaps`). With c cams (u = [s₁, ṡ₁, s̈₁, s⃛₁, s₂, …]) the
derivatives D of a step are laid out cam by cam too, (K, 8·c): D[:, 8q + j] = d^j s_q/dt^j
at the step's start; E_j and W sum over the cams. The recurrence over a uniform grid runs in modal
coordinates as blocked cumulative sums (:mod:`camsim.engine.recurrence`): numpy speed, no Python
loop per step. :func:`exact_partial` is the same map for one step of any length.
"""

from __future__ import annotations

import math
import warnings

import numpy as np
import scipy.linalg
from scipy.linalg.lapack import dgebal as _dgebal

from camsim.elements.affine import N_INPUT, n_cams
from camsim.model.assembly import Configuration
from camsim.engine.recurrence import linear_recurrences

#: Degree of the per-step Hermite representation of the cam input.
HERMITE_DEGREE = 7
_P = HERMITE_DEGREE
_FACT = np.array([math.factorial(j) for j in range(_P + 4)], dtype=float)
#: Steps whose length differs from the grid step by more than this fraction of it get a
#: Hermite map of their own (grid steps differ by rounding only, ~1e-16·t).
STEP_LENGTH_RTOL = 1e-9


def balance(M: np.ndarray) -> tuple[np.ndarray, np.ndarray] | None:
    """(T⁻¹·M·T, diag(T)) of the diagonal balancing of M by powers of two (an exact
    similarity), or None when the scaling is degenerate.

    A finite real M goes to LAPACK's ``dgebal`` directly — what ``scipy.linalg.matrix_balance``
    calls, with the same result, without its 20 µs of argument checking (the power-law
    stepper balances a few dozen small matrices a revolution); anything else through
    ``matrix_balance``.
    """
    if M.dtype == np.float64 and M.ndim == 2 and M.shape[0] == M.shape[1] and M.size and np.isfinite(M).all():
        balanced, _, _, scale, info = _dgebal(M, scale=1, permute=0)
        if info != 0:
            return None
    else:
        with np.errstate(all="ignore"), warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)
            balanced, (scale, _) = scipy.linalg.matrix_balance(M, permute=False, separate=True)
    if not np.all(np.isfinite(scale)) or not np.all(scale > 0):
        return None
    return balanced, scale


def expm_balanced(M: np.ndarray) -> np.ndarray:
    """e^M after a diagonal balancing by powers of two (exact similarity).

    Mechanical state matrices are badly scaled in first-order form (ω²·h beside h); the
    balanced matrix has a norm near ω·h, so ``expm`` needs fewer squarings and keeps more
    digits.
    """
    balanced = balance(M)
    if balanced is None:
        return scipy.linalg.expm(M)
    B, scale = balanced
    return (scale[:, None] * scipy.linalg.expm(B)) / scale[None, :]


def _hermite_matrix() -> np.ndarray:
    """Map [f(0), f'(0), f''(0), f'''(0), f(1), f'(1), f''(1), f'''(1)] → monomial coefficients."""
    n = _P + 1
    M = np.zeros((n, n))
    for k in range(4):
        M[k, k] = math.factorial(k)
        for j in range(k, n):
            M[4 + k, j] = math.factorial(j) / math.factorial(j - k)
    return np.linalg.inv(M)


_HERMITE = _hermite_matrix()


def hermite_derivatives(u0: np.ndarray, u1: np.ndarray, P0: np.ndarray, P1: np.ndarray) -> np.ndarray:
    """D = u0·P0 + u1·P1 cam by cam: the cam input at a step's ends (..., 4·c) → the
    derivatives of each cam's displacement at its start (..., 8·c)."""
    if u0.shape[-1] == N_INPUT:
        return u0 @ P0 + u1 @ P1
    lead = u0.shape[:-1]
    D = u0.reshape(-1, N_INPUT) @ P0 + u1.reshape(-1, N_INPUT) @ P1
    return D.reshape(*lead, -1)


def taylor_rows(D: np.ndarray) -> np.ndarray:
    """Per input channel, the Taylor coefficients of its step polynomial: (..., 8·c) →
    (..., 4·c, 8), row 4q + d holding D_{8q+d}, …, D_{8q+7} then zeros, so that channel
    d of cam q is Σ_j row[j]·τ^j/j! (a copy: the values are D's own)."""
    n = _P + 1
    lead = D.shape[:-1]
    Dq = D.reshape(*lead, -1, n)
    Dp = np.concatenate([Dq, np.zeros((*lead, Dq.shape[-2], N_INPUT - 1))], axis=-1)
    idx = np.arange(N_INPUT)[:, None] + np.arange(n)[None, :]
    return Dp[..., idx].reshape(*lead, -1, n)


def step_input_derivatives(u0: np.ndarray, u1: np.ndarray, h: np.ndarray, grid_step: float | None = None) -> np.ndarray:
    """Derivatives D_j (j = 0..7) of each cam's displacement at step starts.

    Parameters
    ----------
    u0, u1 : ndarray (K, 4·c)
        The cam input ([s, ṡ, s̈, s⃛] per cam) at the start and end of each step [SI].
    h : ndarray (K,)
        Step lengths [s].
    grid_step : float, optional
        The step most of them have (default: their median).

    Returns
    -------
    ndarray (K, 8·c)
        d^j s_q/dt^j at each step start for the degree-7 Hermite interpolant, cam by cam.
    """
    h = np.asarray(h, dtype=float).reshape(-1)
    if h.size == 0:
        return np.zeros((0, (_P + 1) * n_cams(np.shape(u0)[-1])))
    # Most steps share one length (the grid step): two small matrix products for all of
    # them; the few others (partial steps at stretch ends) one by one.
    common = float(grid_step) if grid_step is not None else float(np.median(h))
    P0, P1 = _hermite_maps(common)
    out = hermite_derivatives(u0, u1, P0, P1)
    # (grid steps differ from one another by rounding only: |Δh| ~ 1e-16·t)
    for k in np.flatnonzero(np.abs(h - common) > STEP_LENGTH_RTOL * common):
        P0, P1 = _hermite_maps(float(h[k]))
        out[k] = hermite_derivatives(u0[k], u1[k], P0, P1)
    return out


_HERMITE_MAPS: dict[float, tuple[np.ndarray, np.ndarray]] = {}


def _hermite_maps(h: float) -> tuple[np.ndarray, np.ndarray]:
    """(P0, P1) with D = u0·P0 + u1·P1 for steps of length h (cached per h)."""
    hit = _HERMITE_MAPS.get(h)
    if hit is None:
        k = np.arange(4)
        j = np.arange(_P + 1)
        with np.errstate(over="ignore", divide="ignore", invalid="ignore"):
            # D_j = j!/h^j · Σ_i H[j, i]·data_i, data = [u0·h^k, u1·h^k]
            scale = _FACT[: _P + 1] / h**j
            P0 = (h**k)[:, None] * _HERMITE[:, :4].T * scale[None, :]
            P1 = (h**k)[:, None] * _HERMITE[:, 4:].T * scale[None, :]
        P0[~np.isfinite(P0)] = 0.0
        P1[~np.isfinite(P1)] = 0.0
        # The first four derivatives are the data at the step start, exactly.
        P0[:, :4] = np.eye(4)
        P1[:, :4] = 0.0
        hit = (P0, P1)
        if len(_HERMITE_MAPS) > 4096:
            _HERMITE_MAPS.clear()
        _HERMITE_MAPS[h] = hit
    return hit


def forcing_coefficients(config: Configuration, D: np.ndarray) -> np.ndarray:
    """E_j = Σ_q B_q·[D_{q,j}, D_{q,j+1}, D_{q,j+2}, D_{q,j+3}] (+ b for j = 0): (K, 8, m),
    B_q the four columns of cam q."""
    K = D.shape[0]
    if D.shape[1] == _P + 1:
        Dp = np.concatenate([D, np.zeros((K, 3))], axis=1)
        # stacked[k, j, c] = D_{j+c}
        idx = np.arange(_P + 1)[:, None] + np.arange(N_INPUT)[None, :]
        stacked = Dp[:, idx]
    else:
        # stacked[k, j, 4q + c] = D_{q, j+c}: the rows of taylor_rows, transposed
        stacked = np.swapaxes(taylor_rows(D), 1, 2)
    E = stacked @ config.B.T  # (K, 8, m)
    E[:, 0, :] += config.b
    return E


def input_at(D: np.ndarray, tau: float, channels: int = N_INPUT) -> np.ndarray:
    """The cam input ([s, ṡ, s̈, s⃛] per cam) at τ into a step from its Taylor derivatives
    D (8·c,); with ``channels`` < 4 only each cam's first few (s alone: 1), the others NaN."""
    n = _P + 1
    out = np.full(N_INPUT * (D.size // n), np.nan)
    for q in range(D.size // n):
        Dq = D[q * n : (q + 1) * n]
        for c in range(channels):
            terms = Dq[c:]
            out[N_INPUT * q + c] = np.sum(terms * tau ** np.arange(terms.size) / _FACT[: terms.size])
    return out


#: Smallest condition s_i = |y_i·x_i|/(‖y_i‖‖x_i‖) of an eigenvalue of the balanced Φ for
#: the modal recurrence. An eigenvalue comes out of ``eig`` with an error near ε/s_i, and
#: the recurrence raises it to the K-th power: K·ε/s_i relative after K steps. A Jordan
#: block (two free bodies in contact: the rigid-body mode; a critically damped mode) has
#: s_i ~ 1e-5 after rounding, which loses 1e-7 over 3·10⁴ steps; the machines' own modes
#: have s_i ≥ 1e-2. Below this, the plain recurrence z ← Φ·z + g (rounding ε per step).
EIGEN_CONDITION_MIN = 1e-3


def state_scale(config) -> np.ndarray:
    """The diagonal balancing T of the configuration's A by powers of two (cached in
    ``config.cache``): the state's natural units, positions against velocities."""
    scale = config.cache.get("balance")
    if scale is None:
        balanced = balance(config.A)
        scale = config.cache["balance"] = np.ones(config.dim) if balanced is None else balanced[1]
    return scale


def eigenvalues_well_conditioned(V: np.ndarray, Vinv: np.ndarray, scale: np.ndarray) -> bool:
    """Whether every eigenvalue of Φ = V·diag(μ)·V⁻¹ has condition ≥ :data:`EIGEN_CONDITION_MIN`
    in the balanced state T⁻¹z (T = diag(``scale``), the balancing of A, which balances
    Φ = e^{Ah} as well as LAPACK's ``geev`` does before computing μ)."""
    right = np.linalg.norm(V / scale[:, None], axis=0)  # eigenvectors of T⁻¹ΦT: T⁻¹V
    left = np.linalg.norm(Vinv * scale[None, :], axis=1)  # its left ones: V⁻¹T (y_i·x_i = 1)
    return bool(np.all(right * left <= 1.0 / EIGEN_CONDITION_MIN))


#: Largest 1-norm of the balanced A·h on which the Taylor series of :func:`phi_series`
#: runs (a larger A·h is halved that many times first, then doubled back).
PHI_SERIES_NORM = 1.0
#: Most halvings :func:`phi_series` takes (beyond, it declines: ``expm`` instead).
PHI_SERIES_SQUARINGS = 6
#: Terms of the Taylor series of φ_{P+1} (the last term is below 1/20! ≈ 4e-19 of the first
#: when the norm is at most PHI_SERIES_NORM).
PHI_SERIES_TERMS = 12
_INV_FACT = [1.0 / math.factorial(j) for j in range(PHI_SERIES_TERMS + _P + 2)]
#: The doubling of φ_0 … φ_{P+1}: φ_k(2X) = 2^−k·(φ_0(X)·φ_k(X) + Σ_{j=1..k} φ_j(X)/(k−j)!)
#: (Skaflestad & Wright, Appl. Numer. Math. 59 (2009) 783), the sum as one
#: matrix [k, j] and the weights 2^−k.
_DOUBLING_SUM = np.array([[_INV_FACT[k - j] if 1 <= j <= k else 0.0 for j in range(_P + 2)] for k in range(_P + 2)])
_DOUBLING_WEIGHT = 2.0 ** -np.arange(_P + 2)


def phi_series(A: np.ndarray, h: float) -> tuple[np.ndarray, np.ndarray] | None:
    """(Φ, Γ) of :func:`_phi_series_balanced`, or None where it declines."""
    out = _phi_series_balanced(A, h)
    return None if out is None else out[:2]


def _phi_series_balanced(A: np.ndarray, h: float) -> tuple[np.ndarray, np.ndarray, np.ndarray] | None:
    """(Φ, Γ) as :class:`StepMaps` holds them — Φ = e^{Ah}, Γ_j = h^{j+1}·φ_{j+1}(Ah) — from
    the Taylor series of φ_{P+1}(X) = Σ_i X^i/(i+P+1)! on the balanced X = A·h and the
    recurrence φ_{k−1}(X) = X·φ_k(X) + I/(k−1)!, which loses nothing while ‖X‖ ≤ 1.

    A larger X is halved s times until its norm is at most :data:`PHI_SERIES_NORM`, and
    the series' φ_0 … φ_{P+1} of X/2^s are doubled back s times (scaling and squaring of
    the φ-functions, as ``expm`` does for e^X alone).

    About 20 small matrix products (and three batched products per doubling) instead of
    ``expm`` of the (P+2)·n augmented matrix: a third to half of the time, and accurate to
    rounding on every Γ_j (the augmented ``expm`` carries the high Γ_j, many orders below
    its largest block, to 1e-12 … 1e-6 of themselves for a stiff seat at h = 20 µs;
    tests/test_stepping.py). Returns (Φ, Γ, T) with T the diagonal balancing of A·h (that
    of A: balancing is blind to a scalar factor), or None when the balancing fails or more
    than :data:`PHI_SERIES_SQUARINGS` halvings would be needed (then use the augmented
    ``expm``).
    """
    m = A.shape[0]
    balanced = balance(A * h)
    if balanced is None:
        return None
    X, scale = balanced
    norm = float(np.linalg.norm(X, 1)) if X.size else 0.0  # numpy < 2: no norm of a 0×0 matrix
    if not math.isfinite(norm):
        return None
    squarings = math.ceil(math.log2(norm / PHI_SERIES_NORM)) if norm > PHI_SERIES_NORM else 0
    if squarings > PHI_SERIES_SQUARINGS:
        return None
    if squarings:
        X = X * 0.5**squarings  # exact: a power of two
    p = _P + 1
    diag = slice(None, None, m + 1)  # the diagonal of an m×m matrix, flattened
    S = np.zeros((m, m))
    S.flat[diag] = _INV_FACT[PHI_SERIES_TERMS + p]
    for i in range(PHI_SERIES_TERMS - 1, -1, -1):
        S = X @ S
        S.flat[diag] += _INV_FACT[i + p]
    phis = [S]  # φ_p, then φ_{p−1} … φ_0
    for k in range(p, 0, -1):
        S = X @ S
        S.flat[diag] += _INV_FACT[k - 1]
        phis.append(S)
    phis = np.array(phis[::-1])  # φ_0 … φ_p
    for _ in range(squarings):
        phis = (phis[0] @ phis + np.tensordot(_DOUBLING_SUM, phis, axes=1)) * _DOUBLING_WEIGHT[:, None, None]
    back = scale[:, None] / scale[None, :]  # T·φ·T⁻¹ with T = diag(scale)
    Phi = phis[0] * back
    Gamma = phis[1:] * back * (h ** np.arange(1, _P + 2))[:, None, None]
    return Phi, Gamma, scale


class StepMaps:
    """Cached exact step maps of one linear configuration for a fixed step h.

    ``series``: build Φ and Γ with :func:`phi_series` where it applies (the power-law
    stepper's many linear laws); the default, the augmented ``expm``, keeps the linear
    path's numbers as they were.
    """

    def __init__(self, config: Configuration, h: float, series: bool = False):
        m = config.dim
        self.h = h
        fast = _phi_series_balanced(config.A, h) if (series and m) else None
        if fast is not None:
            self.Phi, self.Gamma, scale = fast
            config.cache.setdefault("balance", scale)
        else:
            nb = _P + 2
            big = np.zeros((m * nb, m * nb))
            big[:m, :m] = config.A
            for j in range(nb - 1):
                big[m * j : m * (j + 1), m * (j + 1) : m * (j + 2)] = np.eye(m)
            if m:
                expo = expm_balanced(big * h)
            else:
                expo = np.zeros((0, 0))
            self.Phi = expo[:m, :m]
            self.Gamma = np.stack([expo[:m, m * (j + 1) : m * (j + 2)] for j in range(_P + 1)]) if m else np.zeros((_P + 1, 0, 0))
        # The step's input term Σ_j Γ_j·E_j with E_j = B·[D_j..D_{j+3}] (+ b for j = 0)
        # regrouped by input derivative: g = D·W + g0, one small matrix product per chunk
        # (rows 8q … 8q + 7 for cam q).
        cams = n_cams(config.B.shape[1])
        self.W = np.zeros(((_P + 1) * cams, m))
        for q in range(cams):
            for i in range(_P + 1):
                for c in range(N_INPUT):
                    if 0 <= i - c <= _P:
                        self.W[q * (_P + 1) + i] += self.Gamma[i - c] @ config.B[:, N_INPUT * q + c]
        self.g0 = self.Gamma[0] @ config.b if m else np.zeros(0)
        # Modal form for the recurrence; of each complex-conjugate pair of modes only one
        # is run (the state is real, so the other is its conjugate).
        self.modal = False
        if m:
            lam, V = np.linalg.eig(self.Phi)
            cond = np.linalg.cond(V)
            Vinv = np.linalg.inv(V) if np.isfinite(cond) and cond < 1e7 else None
            if Vinv is not None and eigenvalues_well_conditioned(V, Vinv, state_scale(config)):
                self.modal = True
                self.mu = lam
                self.V = V
                self.Vinv = Vinv
                self.weights = np.ones(m)
                keep = []
                used = np.zeros(m, dtype=bool)
                for i in range(m):
                    if used[i]:
                        continue
                    used[i] = True
                    if abs(lam[i].imag) > 1e-14 * max(1.0, abs(lam[i])):
                        partner = np.flatnonzero(~used & (np.abs(lam - np.conj(lam[i])) <= 1e-12 * max(1.0, abs(lam[i]))))
                        if partner.size:
                            used[partner[0]] = True
                            self.weights[i] = 2.0
                    keep.append(i)
                self.keep = np.array(keep, dtype=int)

    def with_constant(self, config: Configuration) -> "StepMaps":
        """These maps for a configuration that differs from theirs only in its constant term
        b (a stuck friction pair held at another deflection): Φ, Γ, W and the modal form are
        shared, g0 = Γ₀·b is its own."""
        import copy

        out = copy.copy(self)
        out.g0 = self.Gamma[0] @ config.b if config.dim else np.zeros(0)
        return out

    def propagate(self, z0: np.ndarray, D: np.ndarray) -> np.ndarray:
        """States after each full step: z_{k+1} = Φ z_k + Σ_j Γ_j E_kj; returns (K, m).

        ``D`` (K, 8·c) holds the cam-input derivatives at each step start.
        """
        K = D.shape[0]
        m = z0.size
        if m == 0:
            return np.zeros((K, 0))
        g = D @ self.W + self.g0
        if self.modal:
            keep = self.keep
            gm = g @ self.Vinv[keep].T  # (K, modes kept) modal forcing
            w0 = self.Vinv[keep] @ z0
            W = linear_recurrences(self.mu[keep], gm, w0)  # every mode at once (issue 42)
            return np.real(W @ (self.V[:, keep] * self.weights[keep]).T)
        out = np.empty((K, m))
        z = z0
        for k in range(K):
            z = self.Phi @ z + g[k]
            out[k] = z
        return out


def exact_partial(config: Configuration, z0: np.ndarray, E: np.ndarray, tau: float) -> np.ndarray:
    """Exact state after τ from z0 under the polynomial forcing Σ E_j σ^j/j! (E: (8, m)).

    The augmented matrix is built in the scaled time σ/τ so that its norm stays near
    ‖A‖·τ (the raw forcing coefficients reach 1e13 for stiff contacts, and ``expm`` would
    square its way through them), and the state block is balanced with the
    configuration's cached diagonal scaling (positions against velocities).
    """
    m = config.dim
    if m == 0:
        return np.zeros(0)
    scale = state_scale(config)
    n_aug = m + _P + 1
    M = np.zeros((n_aug, n_aug))
    # D⁻¹·M·D with D = diag(scale, 1, …, 1): exact similarity by powers of two.
    M[:m, :m] = config.A * tau * (scale[None, :] / scale[:, None])
    M[:m, m:] = (E * (tau ** np.arange(1, _P + 2))[:, None]).T / scale[:, None]
    for j in range(1, _P + 1):
        M[m + j, m + j - 1] = 1.0
    start = np.zeros(n_aug)
    start[:m] = z0 / scale
    start[m] = 1.0
    return (scipy.linalg.expm(M) @ start)[:m] * scale

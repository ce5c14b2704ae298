"""The exact solution inside one step as a polynomial: the Taylor series of a linear configuration.

Over a step of length h from state z₀, with the cam input the step's degree-7 polynomial
(:func:`camsim.engine.stepping.step_input_derivatives`), a linear configuration
ż = A·z + B·u + b has the solution z(τ) = Σ_k z⁽ᵏ⁾(0)·τ^k/k!, z⁽ᵏ⁺¹⁾ = A·z⁽ᵏ⁾ + B·u⁽ᵏ⁾ (+ b
for k = 0). In the balanced state w = T⁻¹·z (T the diagonal balancing of A) and the scaled
coefficients e_k = w⁽ᵏ⁾·h^k/k!, the series in σ = τ/h is e_{k+1} = h/(k+1)·(A_b·e_k +
(B_b·u⁽ᵏ⁾ + [k = 0]·b_b)·h^k/k!), summed until ‖h·A_b‖^k/k! is below :data:`TAYLOR_TOL`:
the exact solution to rounding where ‖h·A_b‖₁ ≤ :data:`TAYLOR_NORM` (the grid has at least
twelve steps per period of the highest natural frequency: ‖h·A_b‖ is about 0.5).

Every guard and every observable is affine in (z, u), so inside a step each is a scalar
polynomial in σ whose coefficients are one product away: event roots and extrema are
polynomial roots (:mod:`camsim.engine.roots`, :mod:`camsim.engine.extremes`), a few
microseconds each, where a matrix exponential per evaluated point cost tens.
"""

from __future__ import annotations

import numpy as np

from camsim.engine.stepping import _FACT, _P, state_scale, taylor_rows

#: Taylor terms are taken until the next would be below this (relative to the balanced state).
TAYLOR_TOL = 1e-18
#: Largest balanced norm ‖A·h‖₁ for the Taylor series (a longer step is split, or declined).
TAYLOR_NORM = 4.0


def _balanced(config):
    """(T, A_b, B_b, b_b, ‖A_b‖₁) of a configuration, cached on it."""
    hit = config.cache.get("taylor")
    if hit is None:
        T = state_scale(config)
        Ab = config.A * (T[None, :] / T[:, None])
        # numpy < 2 refuses the norm of a 0×0 matrix (every mass held: no coordinate left)
        norm = float(np.linalg.norm(Ab, 1)) if Ab.size else 0.0
        hit = config.cache["taylor"] = (T, Ab, config.B / T[:, None], config.b / T, norm)
    return hit


def _terms(norm: float) -> int:
    """Taylor terms for a step of balanced norm ``norm``."""
    terms, bound = 1, 1.0
    while terms < 80:
        bound *= norm / terms
        if bound < TAYLOR_TOL and terms > _P + 1:
            break
        terms += 1
    return terms


def taylor_coefficients(config, z0: np.ndarray, D: np.ndarray, h: np.ndarray) -> np.ndarray:
    """Coefficients c_k (S, K + 1, m) with z(σ·h) = Σ_k c_k·σ^k on each step (original
    coordinates); the steps must have ‖h·A_b‖₁ ≤ :data:`TAYLOR_NORM`."""
    T, Ab, Bb, bb, norm_a = _balanced(config)
    S = z0.shape[0]
    h = np.asarray(h, dtype=float)
    terms = _terms(float(np.max(h)) * norm_a if h.size else 0.0)
    rows = taylor_rows(D)  # (S, 4·c, 8): row 4q + d gives channel d of cam q
    n_in = rows.shape[2]
    out = np.empty((S, terms + 1, z0.shape[1]))
    e = z0 / T  # e_0 = w0
    out[:, 0] = e
    # the input's terms B_b·û_k·h^k/k!, all at once (zero beyond the input's degree)
    hk = np.cumprod(np.concatenate([np.ones((S, 1)), h[:, None] / np.arange(1, n_in)[None, :]], axis=1), axis=1)
    forcing = np.einsum("sck,sk,mc->skm", rows, hk, Bb)  # (S, n_in, m)
    forcing[:, 0] += bb
    AbT = Ab.T
    steps = (h[None, :] / np.arange(1, terms + 1, dtype=float)[:, None])[:, :, None]  # h/(k+1), (terms, S, 1)
    for k in range(terms):
        e = e @ AbT
        if k < n_in:
            e += forcing[:, k]
        e *= steps[k]
        out[:, k + 1] = e
    return out * T


def taylor_states(config, z0: np.ndarray, D: np.ndarray, h: np.ndarray, sigma: np.ndarray) -> np.ndarray:
    """Exact states of a linear configuration inside steps.

    Parameters
    ----------
    config : Configuration
        ż = A·z + B·u + b.
    z0 : ndarray (S, m)
        State at each step's start.
    D : ndarray (S, 8·c)
        The steps' cam-input derivatives d^j s/dt^j at their starts, cam by cam.
    h : ndarray (S,)
        Step lengths [s].
    sigma : ndarray (P,) or (S, P)
        Fractions of the step (0 … 1) at which the state is wanted (the same for every
        step, or per step).

    Returns
    -------
    ndarray (S, P, m)
        Steps whose ‖h·A_b‖₁ exceeds :data:`TAYLOR_NORM` are halved recursively.
    """
    S, m = z0.shape
    sigma = np.broadcast_to(np.asarray(sigma, dtype=float), (S, np.shape(sigma)[-1]))
    P = sigma.shape[1]
    out = np.empty((S, P, m))
    if m == 0 or S == 0:
        return out
    norm_a = _balanced(config)[4]
    h = np.asarray(h, dtype=float)
    long = h * norm_a > TAYLOR_NORM
    for s in np.flatnonzero(long).tolist():
        # a long step (a stretch's only step between two events far apart with no grid
        # point, in a soft machine): its halves, each from its own exact start state
        out[s] = _split_states(config, z0[s], D[s], float(h[s]), sigma[s])
    short = np.flatnonzero(~long)
    if short.size:
        C = taylor_coefficients(config, z0[short], D[short], h[short])
        powers = sigma[short][:, :, None] ** np.arange(C.shape[1])  # (S, P, K+1)
        out[short] = np.einsum("spk,skm->spm", powers, C)
    return out


def _split_states(config, z0, D, h, sigma):
    """:func:`taylor_states` of one long step, by its halves."""
    half = 0.5 * h
    D_mid = shift_input(D, half)
    z_mid = taylor_states(config, z0[None, :], D[None, :], np.array([half]), np.array([1.0]))[0, 0]
    out = np.empty((sigma.size, z0.size))
    first = sigma <= 0.5
    if np.any(first):
        out[first] = taylor_states(config, z0[None, :], D[None, :], np.array([half]), sigma[first] * 2.0)[0]
    if np.any(~first):
        out[~first] = taylor_states(config, z_mid[None, :], D_mid[None, :], np.array([half]),
                                    sigma[~first] * 2.0 - 1.0)[0]
    return out


def shift_input(D: np.ndarray, tau: float) -> np.ndarray:
    """The degree-7 input polynomials' derivatives at τ into their step (D (8·c,) at the
    start, cam by cam)."""
    out = np.zeros_like(D)
    n = _P + 1
    for q in range(D.size // n):
        Dq = D[q * n : (q + 1) * n]
        for j in range(n):
            terms = Dq[j:]
            out[q * n + j] = float(np.sum(terms * tau ** np.arange(terms.size) / _FACT[: terms.size]))
    return out


def step_inputs(D: np.ndarray, tau: np.ndarray) -> np.ndarray:
    """The input channels ([s, ṡ, s̈, s⃛] per cam) of the steps' input polynomials at
    offsets τ: D (S, 8·c), τ (S, P) → (S, P, 4·c)."""
    S, P = tau.shape
    rows = taylor_rows(D)  # (S, 4·c, 8)
    j = np.arange(_P + 1)
    powers = tau[:, :, None] ** j / _FACT[: _P + 1]  # (S, P, 8)
    out = np.empty((S, P, rows.shape[1]))
    for c in range(rows.shape[1]):
        out[:, :, c] = np.einsum("spj,sj->sp", powers, rows[:, c])
    return out


class StepPolynomial:
    """The exact state of one step of a linear configuration as a polynomial in σ = τ/h.

    Parameters
    ----------
    config : Configuration
    z0 : ndarray (m,)
        The state at the step's start.
    Dk : ndarray (8·c,)
        The step's cam-input derivatives at its start, cam by cam.
    h : float
        The step's length [s].

    Attributes
    ----------
    ok : bool
        False when the step is too long for the series (‖h·A_b‖₁ > :data:`TAYLOR_NORM`):
        then the caller uses the exact matrix exponential instead.
    """

    def __init__(self, config, z0: np.ndarray, Dk: np.ndarray, h: float):
        self.h = float(h)
        self.ok = config.dim == 0 or self.h * _balanced(config)[4] <= TAYLOR_NORM
        if config.dim and self.ok:
            self.C = taylor_coefficients(config, z0[None, :], Dk[None, :], np.array([self.h]))[0]  # (K+1, m)
        else:
            self.C = z0[None, :].copy()
        # the input channels' coefficients in σ: u_c(σh) = Σ_j D[j + c]·h^j/j!·σ^j (per cam)
        scale = self.h ** np.arange(_P + 1) / _FACT[: _P + 1]
        self.U = (taylor_rows(Dk) * scale).T  # (8, 4·c)

    def state(self, sigma: float) -> np.ndarray:
        """z at σ·h."""
        out = self.C[-1].copy()
        for c in self.C[-2::-1]:
            out = out * sigma + c
        return out

    def inputs(self, sigma: float) -> np.ndarray:
        """The input channels ([s, ṡ, s̈, s⃛] per cam) of the step's input polynomials at σ·h."""
        out = self.U[-1].copy()
        for c in self.U[-2::-1]:
            out = out * sigma + c
        return out

    def affine(self, value) -> np.ndarray:
        """Coefficients (low to high) of an affine map q = Cz·z + Du·u + e (one row) in σ."""
        K = max(self.C.shape[0], self.U.shape[0])
        out = np.zeros(K)
        out[: self.C.shape[0]] += self.C @ value.Cz[0]
        out[: self.U.shape[0]] += self.U @ value.Du[0]
        out[0] += float(value.e[0])
        return out


def poly_value(coef, x: float) -> float:
    """Σ coef[k]·x^k (Horner, plain floats)."""
    y = 0.0
    for c in reversed(coef):
        y = y * x + c
    return y


def poly_value_and_slope(coef, x: float) -> tuple[float, float]:
    """(p(x), p′(x)) by Horner."""
    y = d = 0.0
    for c in reversed(coef):
        d = d * x + y
        y = y * x + c
    return y, d

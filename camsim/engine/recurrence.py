"""First-order linear recurrences w[k] = μ·w[k−1] + f[k], vectorised with numpy.

This is what ``scipy.signal.lfilter([1], [1, -μ], f)`` computes, without importing
``scipy.signal`` (almost a second of start-up for a command-line tool). The sequence is
cut into blocks of L steps inside which the recurrence is a scaled cumulative sum,

    w[b·L + i] = μ^(i+1)·w_prev + μ^i · Σ_{j≤i} μ^(−j)·f[b·L + j],

with L chosen so that |μ|^(−L) ≤ 1e2 (at most two digits of the cumulative sum are
lost to the scaling); the block ends are then chained by the same recurrence with μ^L.
Strongly damped modes (|μ| < 0.5, memory of a few steps) use a truncated convolution.
"""

from __future__ import annotations

import math

import numpy as np

#: Largest growth |μ|^(−L) accepted inside one block.
_MAX_GROWTH = 1e2


def linear_recurrence(mu: complex, f: np.ndarray, w0: complex) -> np.ndarray:
    """Return w[0..K−1] with w[k] = μ·w[k−1] + f[k] and w[−1] = w0.

    Parameters
    ----------
    mu : complex
        The multiplier (a mode's e^{λh}).
    f : ndarray (K,)
        Forcing sequence (complex or real).
    w0 : complex
        The value before the first element.

    Returns
    -------
    ndarray (K,), complex
    """
    f = np.asarray(f, dtype=complex)
    K = f.size
    if K == 0:
        return f.copy()
    r = abs(mu)
    if r == 0.0:
        return f.copy()
    if r < 0.5:
        # Memory shorter than ~60 steps: truncated convolution to below 1e-18.
        terms = min(K, int(math.ceil(math.log(1e-18) / math.log(r))) + 1)
        out = f.copy()
        power = 1.0 + 0j
        for j in range(1, terms):
            power = power * mu
            out[j:] += power * f[:-j]
        out += mu ** np.arange(1, K + 1) * w0
        return out
    L = min(_block_length(r), K)
    nb = -(-K // L)
    padded = np.zeros(nb * L, dtype=complex)
    padded[:K] = f
    blocks = padded.reshape(nb, L)
    up, down, up1 = _powers(complex(mu), L)
    local = np.cumsum(blocks * down, axis=1) * up  # response to the block's own forcing
    # Chain the block ends: e[b] = μ^L·e[b−1] + local[b, L−1].
    muL = mu**L
    ends = np.empty(nb, dtype=complex)
    prev = w0
    last = local[:, -1]
    for b in range(nb):
        prev = muL * prev + last[b]
        ends[b] = prev
    starts = np.concatenate([[w0], ends[:-1]])
    out = local + starts[:, None] * up1
    return out.reshape(-1)[:K]


def _block_length(r: float) -> int:
    """Block length L for a mode of modulus r: |μ|^(−L) ≤ _MAX_GROWTH (64 undamped, 512 at
    most)."""
    if r == 1.0:
        return 64
    return max(1, min(512, int(math.log(_MAX_GROWTH) / abs(math.log(r)))))


_POWERS: dict[tuple[complex, int], tuple[np.ndarray, np.ndarray, np.ndarray]] = {}


def _powers(mu: complex, L: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """μ^i, μ^(−i) and μ^(i+1) for i < L, cached (the same modes recur chunk after chunk)."""
    key = (mu, L)
    hit = _POWERS.get(key)
    if hit is None:
        i = np.arange(L, dtype=float)
        up = mu**i
        hit = (up, 1.0 / up, up * mu)
        if len(_POWERS) > 256:
            _POWERS.clear()
        _POWERS[key] = hit
    return hit


def linear_recurrences(mu: np.ndarray, f: np.ndarray, w0: np.ndarray) -> np.ndarray:
    """Several recurrences at once: column i is ``linear_recurrence(mu[i], f[:, i], w0[i])``.

    Up to :data:`SCAN_LENGTH` steps (or with a strongly damped mode), a prefix scan by
    recursive doubling over all columns together (Hillis & Steele, CACM 29 (1986) 1170):
    after pass s, w[k] holds Σ_{j<2^s} μ^j·f[k−j], so ⌈log₂K⌉ vectorised passes, then the
    start value's μ^(k+1)·w0. Every multiplier is a power of |μ| ≤ 1, so nothing is scaled
    up and strongly damped modes need no special case. Longer sequences use the blocked
    cumulative sum of :func:`linear_recurrence` on all columns at once. The
    iterated-remainder stepper (:mod:`camsim.engine.nonlinear`) propagates its modes a few
    hundred times per revolution; per-call overhead, not arithmetic, was its cost.

    Parameters
    ----------
    mu : ndarray (m,), complex
        The multipliers (|μ| ≤ 1).
    f : ndarray (K, m)
        Forcing sequences, one per column.
    w0 : ndarray (m,)
        The values before the first element.

    Returns
    -------
    ndarray (K, m), complex
    """
    mu = np.asarray(mu, dtype=complex)
    w = np.array(f, dtype=complex)
    K = w.shape[0]
    if K == 0:
        return w
    r = np.abs(mu)
    if K > SCAN_LENGTH and r.size and float(r.min()) >= 0.5:
        return _blocked(mu, r, w, np.asarray(w0, dtype=complex))
    power = mu
    span = 1
    while span < K:
        w[span:] += power * w[:-span]
        power = power * power
        span *= 2
    return w + _start_powers(mu, K) * np.asarray(w0, dtype=complex)


#: Longest sequence done by the doubling scan; longer ones (with no strongly damped mode)
#: by the blocked cumulative sum, whose cost grows as K rather than K·log₂K (measured:
#: the two cross near 150 steps for the CDTM seat's two modes).
SCAN_LENGTH = 128


def _blocked(mu: np.ndarray, r: np.ndarray, f: np.ndarray, w0: np.ndarray) -> np.ndarray:
    """:func:`linear_recurrence`'s blocked cumulative sum on all columns at once (one block
    length, the shortest any column needs; |μ| ≥ 0.5)."""
    K, m = f.shape
    L = min(min(_block_length(ri) for ri in r.tolist()), K)
    nb = -(-K // L)
    if nb * L == K:
        blocks = f.reshape(nb, L, m)
    else:
        padded = np.zeros((nb * L, m), dtype=complex)
        padded[:K] = f
        blocks = padded.reshape(nb, L, m)
    up, down, up1 = _powers_many(mu, L)
    local = np.cumsum(blocks * down, axis=1) * up  # each block's response to its own forcing
    # chain the block ends, e[b] = μ^L·e[b−1] + local[b, L−1], by the same doubling scan
    # over the blocks (a few passes instead of a Python loop over them)
    muL = mu**L
    starts = np.empty((nb, m), dtype=complex)
    starts[0] = w0
    if nb > 1:
        ends = local[:-1, -1].copy()
        power, span = muL, 1
        while span < nb - 1:
            ends[span:] += power * ends[:-span]
            power = power * power
            span *= 2
        starts[1:] = ends + muL ** np.arange(1, nb, dtype=float)[:, None] * w0
    out = local + starts[:, None, :] * up1
    return out.reshape(nb * L, m)[:K]


_POWERS_MANY: dict[tuple, tuple[np.ndarray, np.ndarray, np.ndarray]] = {}


def _powers_many(mu: np.ndarray, L: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Columns μ_i^k, μ_i^(−k), μ_i^(k+1) for k < L, cached as :func:`_powers`."""
    key = (mu.tobytes(), L)
    hit = _POWERS_MANY.get(key)
    if hit is None:
        up = mu[None, :] ** np.arange(L, dtype=float)[:, None]
        hit = (up, 1.0 / up, up * mu)
        if len(_POWERS_MANY) > 256:
            _POWERS_MANY.clear()
        _POWERS_MANY[key] = hit
    return hit


_START_POWERS: dict[bytes, np.ndarray] = {}


def _start_powers(mu: np.ndarray, K: int) -> np.ndarray:
    """Rows μ^(k+1), k < K (cached per μ, extended as needed)."""
    key = mu.tobytes()
    hit = _START_POWERS.get(key)
    if hit is None or hit.shape[0] < K:
        n = max(K, 1024)
        hit = mu[None, :] ** np.arange(1, n + 1, dtype=float)[:, None]
        if len(_START_POWERS) > 256:
            _START_POWERS.clear()
        _START_POWERS[key] = hit
    return hit[:K]

"""camsim.engine.recurrence.linear_recurrences: several first-order recurrences w[k] = μ·w[k−1] + f[k].

References:

* The defining recurrence run as a plain Python loop (complex floats, one step at a
  time): to 1e-13 of each column's max|w| (measured: below 1e-14 up to K = 3000; the
  loop's own rounding is of the same order).
* For a constant forcing f, the geometric sum w_k = μ^(k+1)·w0 + f·(1 − μ^(k+1))/(1 − μ)
  (w_k = w0 + (k + 1)·f at μ = 1), with μ^(k+1) from Python's complex power (exp/log,
  a different route from any running product): to 1e-12 relative, element by element.
* The single-mode :func:`camsim.engine.recurrence.linear_recurrence` (a separate code path:
  its own block length per mode, a truncated convolution for |μ| < 0.5), column by
  column: to 1e-13 of the column's max|w|.

Both paths of ``linear_recurrences`` are exercised whatever the default switch-over
(``SCAN_LENGTH``): the doubling scan (K ≤ SCAN_LENGTH, or a mode with |μ| < 0.5) and the
blocked cumulative sum ``_blocked``, spied on to check which one ran.
"""

from __future__ import annotations

import cmath

import numpy as np
import pytest

from camsim.engine import recurrence
from camsim.engine.recurrence import linear_recurrence, linear_recurrences

#: Lightly damped modes only (|μ| ≥ 0.5: long sequences take the blocked path), one of
#: them undamped (exactly 1), one close to 1 in modulus and angle.
WEAK = np.array([0.999 * cmath.exp(0.45j), 0.99995 * cmath.exp(0.01j), 1.0])
#: The same with strongly damped modes mixed in (|0.3 + 0.2j| < 0.5: always the scan).
MIXED = np.array([0.999 * cmath.exp(0.45j), 0.3 + 0.2j, 0.99995 * cmath.exp(0.01j), 1.0, 0.6 - 0.1j])
LENGTHS = [1, 2, 3, 17, 128, 129, 1000, 3000]


def loop(mu, f, w0):
    """The defining recurrence, one step at a time in Python complex floats."""
    K, m = f.shape
    out = np.empty((K, m), dtype=complex)
    for i in range(m):
        w, mi = complex(w0[i]), complex(mu[i])
        for k in range(K):
            w = mi * w + complex(f[k, i])
            out[k, i] = w
    return out


def random_case(mu, K, seed):
    """Complex standard-normal forcing (K, m) and start values (m,) from a seeded Generator."""
    rng = np.random.default_rng(seed)
    m = mu.size
    f = rng.standard_normal((K, m)) + 1j * rng.standard_normal((K, m))
    w0 = rng.standard_normal(m) + 1j * rng.standard_normal(m)
    return f, w0


def assert_columns_close(w, ref, tol):
    """|w − ref| ≤ tol·max|ref| in every column."""
    assert w.shape == ref.shape
    scale = np.max(np.abs(ref), axis=0)
    err = np.max(np.abs(w - ref), axis=0)
    assert np.all(err <= tol * scale), err / scale


@pytest.fixture
def blocked_calls(monkeypatch):
    """Record each call of recurrence._blocked (the spy still computes the result)."""
    calls = []
    original = recurrence._blocked

    def spy(mu, r, f, w0):
        calls.append(f.shape)
        return original(mu, r, f, w0)

    monkeypatch.setattr(recurrence, "_blocked", spy)
    return calls


@pytest.mark.parametrize("K", LENGTHS)
@pytest.mark.parametrize("modes", ["weak", "mixed"])
def test_matches_the_loop(K, modes, blocked_calls):
    """Against the plain loop, to 1e-13 of max|w|; the blocked path runs exactly when
    K > SCAN_LENGTH and no mode is strongly damped."""
    mu = WEAK if modes == "weak" else MIXED
    f, w0 = random_case(mu, K, seed=K)
    assert_columns_close(linear_recurrences(mu, f, w0), loop(mu, f, w0), 1e-13)
    assert bool(blocked_calls) == (modes == "weak" and K > recurrence.SCAN_LENGTH)


def test_real_forcing_and_start_values():
    """Real (float) f and w0 are taken as complex: the loop to 1e-13 of max|w|."""
    rng = np.random.default_rng(7)
    f, w0 = rng.standard_normal((300, WEAK.size)), rng.standard_normal(WEAK.size)
    w = linear_recurrences(WEAK, f, w0)
    assert w.dtype == complex
    assert_columns_close(w, loop(WEAK, f.astype(complex), w0.astype(complex)), 1e-13)


def geometric(mu, f, w0, K):
    """w_k = μ^(k+1)·w0 + f·(1 − μ^(k+1))/(1 − μ) (w0 + (k+1)·f at μ = 1)."""
    mu, f, w0 = complex(mu), complex(f), complex(w0)
    out = np.empty(K, dtype=complex)
    for k in range(K):
        power = mu ** (k + 1)
        out[k] = w0 + (k + 1) * f if mu == 1 else power * w0 + f * (1 - power) / (1 - mu)
    return out


@pytest.mark.parametrize("K, blocked", [(100, False), (2000, True)])
def test_constant_forcing_closed_form(K, blocked, blocked_calls):
    """Constant forcing: the geometric sum, to 1e-12 relative element by element, on the
    scan (K = 100) and the blocked path (K = 2000)."""
    mu = WEAK
    fc = np.array([0.7 - 0.2j, -0.3 + 1.1j, 0.05 + 0.0j])
    w0 = np.array([1.0 + 0.5j, -0.4 + 0.2j, 2.0 - 1.0j])
    w = linear_recurrences(mu, np.tile(fc, (K, 1)), w0)
    assert bool(blocked_calls) == blocked
    for i in range(mu.size):
        ref = geometric(mu[i], fc[i], w0[i], K)
        np.testing.assert_allclose(w[:, i], ref, rtol=1e-12, atol=0, err_msg=f"column {i}")


@pytest.mark.parametrize("K", [1, 17, 128, 129, 1000, 3000])
def test_columns_match_single_mode(K):
    """Column i agrees with linear_recurrence(mu[i], f[:, i], w0[i]) to 1e-13 of max|w|."""
    f, w0 = random_case(MIXED, K, seed=100 + K)
    many = linear_recurrences(MIXED, f, w0)
    single = np.column_stack([linear_recurrence(complex(m), f[:, i], complex(w0[i])) for i, m in enumerate(MIXED)])
    assert_columns_close(many, single, 1e-13)
    f, w0 = random_case(WEAK, K, seed=200 + K)
    many = linear_recurrences(WEAK, f, w0)
    single = np.column_stack([linear_recurrence(complex(m), f[:, i], complex(w0[i])) for i, m in enumerate(WEAK)])
    assert_columns_close(many, single, 1e-13)


def test_empty_sequence():
    """K = 0: an empty (0, m) complex array (the definition: no elements)."""
    w = linear_recurrences(WEAK, np.zeros((0, WEAK.size)), np.ones(WEAK.size))
    assert w.shape == (0, WEAK.size)
    assert w.dtype == complex


@pytest.mark.parametrize("K", [5, 17, 64, 65, 129, 1000])
def test_blocked_path_with_a_short_switch_over(K, monkeypatch, blocked_calls):
    """SCAN_LENGTH = 4: the blocked sum on short and ragged lengths (K not a multiple of
    the block), against the loop to 1e-13 of max|w|."""
    monkeypatch.setattr(recurrence, "SCAN_LENGTH", 4)
    f, w0 = random_case(WEAK, K, seed=300 + K)
    assert_columns_close(linear_recurrences(WEAK, f, w0), loop(WEAK, f, w0), 1e-13)
    assert blocked_calls == [(K, WEAK.size)]


@pytest.mark.parametrize("K", [129, 1000, 3000])
def test_scan_path_on_long_sequences(K, monkeypatch, blocked_calls):
    """SCAN_LENGTH beyond K: the doubling scan on long weakly damped sequences (its
    repeated squaring of μ), against the loop to 1e-13 of max|w|."""
    monkeypatch.setattr(recurrence, "SCAN_LENGTH", 10**9)
    f, w0 = random_case(WEAK, K, seed=400 + K)
    assert_columns_close(linear_recurrences(WEAK, f, w0), loop(WEAK, f, w0), 1e-13)
    assert blocked_calls == []

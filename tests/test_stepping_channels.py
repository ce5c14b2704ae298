"""Several cam inputs in the exact step maps (issue 38): every cam-input operation of the
engine on c cams equals the sum of the same operation on each cam alone.

Reference: linearity. A configuration driven by two cams, ż = A·z + B₁·u₁ + B₂·u₂ + b, is
the superposition of the two one-cam configurations (the second without b); the step maps,
forcing coefficients and Hermite input of the two-cam layout must reproduce that sum to
rounding (1e-13 relative), and the per-cam pieces (Taylor rows, input at τ) must be the
one-cam pieces side by side, bit for bit.
"""

from __future__ import annotations

import numpy as np

from camsim.elements.affine import N_INPUT, input_rate, shift_rate, times_rate
from camsim.engine.remainder import _LinearLaw  # the configuration-like system StepMaps reads
from camsim.engine.stepping import (
    StepMaps,
    _hermite_maps,
    forcing_coefficients,
    hermite_derivatives,
    input_at,
    step_input_derivatives,
    taylor_rows,
)


def _system(seed=1, m=4, cams=2):
    rng = np.random.default_rng(seed)
    n = m // 2
    K = np.diag(rng.uniform(1e4, 4e4, n))
    C = np.diag(rng.uniform(1.0, 5.0, n))
    A = np.zeros((m, m))
    A[:n, n:] = np.eye(n)
    A[n:, :n] = -K
    A[n:, n:] = -C
    B = np.zeros((m, N_INPUT * cams))
    B[n:, :] = rng.normal(size=(n, N_INPUT * cams)) * 1e3
    for q in range(cams):
        B[:, N_INPUT * q + 3] = 0.0  # the jerk carries no weight
    b = np.zeros(m)
    b[n:] = rng.normal(size=n)
    return A, B, b


def _inputs(rng, K, cams):
    return rng.normal(size=(K, N_INPUT * cams))


def test_hermite_and_taylor_rows_are_per_cam():
    rng = np.random.default_rng(3)
    u0, u1 = _inputs(rng, 5, 3), _inputs(rng, 5, 3)
    P0, P1 = _hermite_maps(1e-4)
    D = hermite_derivatives(u0, u1, P0, P1)
    assert D.shape == (5, 24)
    for q in range(3):
        cols = slice(N_INPUT * q, N_INPUT * (q + 1))
        np.testing.assert_array_equal(D[:, 8 * q : 8 * (q + 1)], u0[:, cols] @ P0 + u1[:, cols] @ P1)
    rows = taylor_rows(D)
    assert rows.shape == (5, 12, 8)
    for q in range(3):
        Dq = np.concatenate([D[:, 8 * q : 8 * (q + 1)], np.zeros((5, 3))], axis=1)
        for c in range(N_INPUT):
            np.testing.assert_array_equal(rows[:, N_INPUT * q + c], Dq[:, c : c + 8])
    tau = 3e-5
    u = input_at(D[2], tau)
    for q in range(3):
        np.testing.assert_array_equal(u[N_INPUT * q : N_INPUT * (q + 1)], input_at(D[2, 8 * q : 8 * (q + 1)], tau))


def test_rates_shift_each_cam():
    rng = np.random.default_rng(4)
    u = rng.normal(size=8)
    udot = input_rate(u)
    np.testing.assert_array_equal(udot, [u[1], u[2], u[3], 0.0, u[5], u[6], u[7], 0.0])
    M = rng.normal(size=(3, 8))
    M[:, 3::4] = 0.0
    np.testing.assert_allclose(times_rate(M, u), M @ udot, rtol=1e-14)
    Du = rng.normal(size=(2, 8))
    Du[:, 3::4] = 0.0
    out = np.zeros((2, 8))
    shift_rate(Du, out)
    np.testing.assert_array_equal(out[:, [1, 2, 3, 5, 6, 7]], Du[:, [0, 1, 2, 4, 5, 6]])
    assert not out[:, [0, 4]].any()


def test_two_cam_step_maps_are_the_superposition_of_one_cam_maps():
    A, B, b = _system()
    h = 2e-4
    both = _LinearLaw(A, B, b)
    first = _LinearLaw(A, B[:, :N_INPUT], b)
    second = _LinearLaw(A, B[:, N_INPUT:], np.zeros_like(b))
    K = 40
    t = np.arange(K + 1) * h
    # two smooth cam motions: s_q = a_q·sin(w_q·t + p_q) and its derivatives
    cols = []
    for a, w, p in ((3e-3, 60.0, 0.3), (5e-3, 90.0, 1.1)):
        ph = w * t + p
        cols += [a * np.sin(ph), a * w * np.cos(ph), -a * w**2 * np.sin(ph), -a * w**3 * np.cos(ph)]
    U = np.column_stack(cols)
    D = step_input_derivatives(U[:-1], U[1:], np.full(K, h), h)
    D1, D2 = D[:, :8], D[:, 8:]
    E = forcing_coefficients(both, D)
    np.testing.assert_allclose(E, forcing_coefficients(first, D1) + forcing_coefficients(second, D2), rtol=1e-13,
                               atol=1e-13 * np.max(np.abs(E)))
    maps, m1, m2 = StepMaps(both, h), StepMaps(first, h), StepMaps(second, h)
    np.testing.assert_array_equal(maps.W[:8], m1.W)
    np.testing.assert_array_equal(maps.W[8:], m2.W)
    z0 = np.array([1e-4, -2e-4, 0.01, 0.03])
    Z = maps.propagate(z0, D)
    ref = m1.propagate(z0, D1) + m2.propagate(np.zeros(4), D2)
    np.testing.assert_allclose(Z, ref, rtol=0, atol=1e-12 * np.max(np.abs(ref)))

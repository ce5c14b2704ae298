"""Step maps of a linear configuration (camsim.engine.stepping): the φ-function series.

Reference: the defining integrals Γ_j(h) = ∫₀ʰ e^{A(h−s)}·s^j/j! ds evaluated by adaptive
quadrature (``scipy.integrate.quad_vec``, Gauss–Kronrod, epsrel 1e-14) of
``scipy.linalg.expm`` at each node, and Φ = ``expm(A·h)`` — independent of both ways
camsim builds them. The test system is a two-mass chain with a stiff seat (ω·h from 0.05
to 0.6, lightly damped, as in the power-law stepper's linear laws; up to 40 for the
scaling and squaring). Tolerance: 1e-12 of
each matrix's largest entry (the quadrature's own error is ~1e-15).
"""

from __future__ import annotations

import math
from types import SimpleNamespace

import numpy as np
import pytest
from scipy.integrate import quad_vec
from scipy.linalg import expm

from camsim.engine.stepping import PHI_SERIES_NORM, StepMaps, phi_series


def chain(k_seat: float) -> np.ndarray:
    """State matrix of two 1 kg masses: ground–k_seat–M1–1e5 N/m–M2, 0.1 % damping."""
    K = np.array([[k_seat + 1e5, -1e5], [-1e5, 1e5]])
    C = 1e-3 * K / math.sqrt(k_seat)
    return np.block([[np.zeros((2, 2)), np.eye(2)], [-K, -C]])


def linear_system(A: np.ndarray) -> SimpleNamespace:
    """A configuration-like system with state matrix A and no input (what StepMaps reads)."""
    n = A.shape[0]
    return SimpleNamespace(A=A, B=np.zeros((n, 4)), b=np.zeros(n), dim=n, cache={})


def gamma_reference(A: np.ndarray, h: float, j: int) -> np.ndarray:
    value, _ = quad_vec(lambda s: expm(A * (h - s)) * s**j / math.factorial(j), 0.0, h, epsabs=0.0, epsrel=1e-14)
    return value


@pytest.mark.parametrize("k_seat", [1e7, 1e8, 5e8])
def test_phi_series_against_quadrature(k_seat):
    A, h = chain(k_seat), 2e-5
    maps = phi_series(A, h)
    assert maps is not None
    Phi, Gamma = maps
    assert np.max(np.abs(Phi - expm(A * h))) <= 1e-12 * np.max(np.abs(Phi))
    assert Gamma.shape[0] == 8
    for j in range(8):
        ref = gamma_reference(A, h, j)
        assert np.max(np.abs(Gamma[j] - ref)) <= 1e-12 * np.max(np.abs(ref)), j


def test_step_maps_from_the_series():
    """StepMaps(series=True) holds the series' maps; the augmented expm agrees with them."""
    A, h = chain(1e8), 2e-5
    Phi, Gamma = phi_series(A, h)

    series, augmented = StepMaps(linear_system(A), h, series=True), StepMaps(linear_system(A), h)
    assert np.array_equal(series.Phi, Phi) and np.array_equal(series.Gamma, Gamma)
    # the augmented-matrix expm (the linear path's maps) agrees to its own accuracy, which
    # falls with j (here 7e-13 at j = 3, 5e-12 at j = 4, 1e-6 at j = 7, relative to each
    # Γ_j; the quadrature test above is the reference)
    assert np.max(np.abs(series.Phi - augmented.Phi)) <= 1e-13 * np.max(np.abs(Phi))
    for j in range(5):
        assert np.max(np.abs(series.Gamma[j] - augmented.Gamma[j])) <= 1e-10 * np.max(np.abs(series.Gamma[j])), j


@pytest.mark.parametrize("omega_h", [2.0, 10.0, 40.0])
def test_phi_series_scaling_and_squaring_against_quadrature(omega_h):
    """Beyond the series' norm bound (ω·h = 2 … 40: 2 to 6 halvings) the halved series
    doubled back matches the quadrature to the same 1e-12 of each matrix."""
    A = chain(1e8)  # ω ≈ 1e4 rad/s
    h = omega_h / 1e4
    Phi, Gamma = phi_series(A, h)
    assert np.max(np.abs(Phi - expm(A * h))) <= 1e-12 * np.max(np.abs(Phi))
    for j in range(8):
        ref = gamma_reference(A, h, j)
        assert np.max(np.abs(Gamma[j] - ref)) <= 1e-12 * np.max(np.abs(ref)), j


def test_phi_series_declines_very_large_steps():
    """Beyond PHI_SERIES_SQUARINGS halvings the series is not used (StepMaps falls back
    to expm)."""
    A = chain(1e8)
    h = 400 * PHI_SERIES_NORM / 1e4  # ω·h ≈ 400: more than 2^6 times the norm bound
    assert phi_series(A, h) is None

    maps = StepMaps(linear_system(A), h, series=True)
    assert np.max(np.abs(maps.Phi - expm(A * h))) <= 1e-10 * np.max(np.abs(maps.Phi))


def test_free_pair_in_contact_propagates_without_drift():
    """Two free 1 kg masses joined by a 1e6 N/m spring (the closed contact of a free pair):
    Φ has the rigid-body Jordan block, whose eigenvalues ``eig`` returns split by ~1e-11;
    raised to the 30 000th power in the modal recurrence they lost 1e-7 of the motion.
    StepMaps must fall back to the plain recurrence there (EIGEN_CONDITION_MIN), and the
    states after 30 000 steps of 1 µs match the closed form — centre of mass in uniform
    motion, relative coordinate a harmonic oscillator at ω = √(2k/m) — to 1e-12 of their
    scale; a lightly damped two-mass chain (distinct, well-conditioned modes) stays modal."""
    k, h, K = 1e6, 1e-6, 30_000
    A = np.zeros((4, 4))
    A[:2, 2:] = np.eye(2)
    A[2:, :2] = [[-k, k], [k, -k]]

    maps = StepMaps(linear_system(A), h)
    assert not maps.modal
    z0 = np.array([0.0, 0.0, 3.0, -1.0])  # together, closing at 4 m/s
    z = maps.propagate(z0, np.zeros((K, 8)))[-1]
    t, omega = K * h, math.sqrt(2 * k)
    centre, v_centre = 1.0 * t, 1.0  # (3 − 1)/2 m/s
    rel, v_rel = -4.0 / omega * math.sin(omega * t), -4.0 * math.cos(omega * t)  # x2 − x1
    expected = np.array([centre - rel / 2, centre + rel / 2, v_centre - v_rel / 2, v_centre + v_rel / 2])
    scale = np.array([t, t, 4.0, 4.0])
    assert np.max(np.abs(z - expected) / scale) <= 1e-12

    assert StepMaps(linear_system(chain(1e8)), 2e-5).modal

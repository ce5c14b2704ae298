"""Numbers of ``camsim.analyses.fit`` against references.

* Linear case: the cam contact force of a driven mass is linear in the spring's preload
  and stiffness (tests/fit/machines.py: Fc = m·s̈ + P + k·s with the cam's closed-form
  s(t)). Least squares is then ordinary linear regression; its closed-form answer
  (normal equations), standard errors s²(XᵀX)⁻¹ with s² = RSS/(m − 2), and Student-t
  intervals are the reference. Tolerances: values to 1e-6 of their standard error,
  standard errors to 1e-4 relative (finite differences of a linear model are exact up to
  rounding).
* Coverage: seeded Gaussian noise on a one-mass oscillator's acceleration; the reported
  95 % interval must contain the truth in at least 90 of 100 repetitions (slow), and in
  at least 8 of 10 with a spread of the estimates that matches the reported standard
  error within a factor 2 (fast).
* The noise estimator recovers a known sigma within 5 % on 5000 samples.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from machines import H, K_TRUE, MASS, OMEGA, OSC_K, OSC_ZETA, OSCILLATOR, P_TRUE
from scipy import stats

from camsim.analyses.fit import fit
from camsim.analyses.fit.measured import write_measured
from camsim.analyses.fit.objective import estimate_sigma
from camsim.machine.loader import load_machine_text
from camsim.run.simulation import simulate


def _closed_form_force(t):
    s = H / 2 * (1 - np.cos(OMEGA * t))
    a = H / 2 * OMEGA**2 * np.cos(OMEGA * t)
    return s, a, MASS * a + P_TRUE + K_TRUE * s


def test_linear_case_matches_the_normal_equations(driven, tmp_path):
    t = np.arange(0, 501) / 1000.0  # the run's own 1 kHz grid over one 0.5 s revolution
    s, a, force = _closed_form_force(t)
    rng = np.random.default_rng(11)
    y = force + rng.normal(0.0, 0.5, t.size)
    csv = write_measured(tmp_path / "m.csv", t, {"cam_contact/force": (y, "N")})
    result = fit(driven, csv, ["element.K.preload=0:100N", "element.K.stiffness=1000:10000:3000"])
    assert result.converged
    # reference: y - m·a = P + k·s, ordinary least squares
    X = np.column_stack([np.ones_like(s), s])
    beta, rss, *_ = np.linalg.lstsq(X, y - MASS * a, rcond=None)
    dof = t.size - 2
    s2 = float(rss[0]) / dof
    cov = s2 * np.linalg.inv(X.T @ X)
    se = np.sqrt(np.diag(cov))
    assert result.keys == ["element.K.preload", "element.K.stiffness"]
    np.testing.assert_allclose(result.values, beta, rtol=0, atol=1e-6 * se.min())
    np.testing.assert_allclose(result.stderr, se, rtol=1e-4)
    tq = stats.t.ppf(0.975, dof)
    np.testing.assert_allclose(result.ci95[:, 0], beta - tq * se, rtol=1e-6)
    np.testing.assert_allclose(result.ci95[:, 1], beta + tq * se, rtol=1e-6)
    corr = cov[0, 1] / math.sqrt(cov[0, 0] * cov[1, 1])
    assert result.correlation[0, 1] == pytest.approx(corr, abs=1e-4)
    assert result.rms_residual["cam_contact/force"] == pytest.approx(math.sqrt(float(rss[0]) / t.size), rel=1e-6)
    assert result.cost == pytest.approx(0.5 * float(rss[0]) / result.sigma["cam_contact/force"] ** 2, rel=1e-6)
    assert result.warnings == []
    # the noise level only weights channels: with one channel the answer does not depend on it
    again = fit(driven, csv, ["element.K.preload=0:100N", "element.K.stiffness=1000:10000:3000"], sigma={"cam_contact/force": 3.0})
    np.testing.assert_allclose(again.values, result.values, rtol=1e-9)
    np.testing.assert_allclose(again.stderr, result.stderr, rtol=1e-6)


def test_noise_estimator_recovers_sigma():
    t = np.linspace(0, 1, 5000)
    signal = 30 * np.sin(2 * np.pi * 3 * t) + 5 * np.cos(2 * np.pi * 11 * t)
    noise = np.random.default_rng(5).normal(0, 0.7, t.size)
    assert estimate_sigma(signal + noise) == pytest.approx(0.7, rel=0.05)


def _coverage(oscillator, tmp_path, reps: int):
    machine = load_machine_text(OSCILLATOR)
    truth = simulate(machine)
    acc = truth.masses["M"]["acceleration"]
    sigma = 0.05 * float(np.max(np.abs(acc)))
    hits = np.zeros(2, dtype=int)
    estimates, stderrs = [], []
    for seed in range(reps):
        rng = np.random.default_rng(1000 + seed)
        y = acc + rng.normal(0.0, sigma, acc.size)
        csv = write_measured(tmp_path / f"m{seed}.csv", truth.time, {"masses/M/acceleration": (y, "m/s^2")})
        r = fit(oscillator, csv, ["element.K.stiffness=1e4:4e4", "element.K.damping_ratio=0.01:0.2"])
        assert r.converged
        (klo, khi), (zlo, zhi) = r.ci95
        hits += [int(klo <= OSC_K <= khi), int(zlo <= OSC_ZETA <= zhi)]
        estimates.append(r.values)
        stderrs.append(r.stderr)
    return hits, np.array(estimates), np.array(stderrs)


def test_intervals_are_honest_fast(oscillator, tmp_path):
    hits, est, se = _coverage(oscillator, tmp_path, 5)
    assert hits.sum() >= 8  # of 10 intervals (5 repetitions x 2 parameters)
    spread = est.std(axis=0, ddof=1)
    assert np.all(spread < 2.0 * se.mean(axis=0)) and np.all(spread > 0.25 * se.mean(axis=0))
    assert np.all(np.abs(est.mean(axis=0) - [OSC_K, OSC_ZETA]) < 3 * se.mean(axis=0))


@pytest.mark.full  # before a release (CAMSIM_FULL=1): .ci/run's 15 minutes
def test_intervals_are_honest_100_repetitions(oscillator, tmp_path):
    hits, est, se = _coverage(oscillator, tmp_path, 100)
    assert np.all(hits >= 90), hits  # each parameter's interval holds the truth in >= 90 of 100


def _linear_data(tmp_path, seed=21):
    t = np.arange(0, 501) / 1000.0
    s, a, force = _closed_form_force(t)
    y = force + np.random.default_rng(seed).normal(0.0, 0.5, t.size)
    return t, s, a, y, write_measured(tmp_path / "m.csv", t, {"cam_contact/force": (y, "N")})


def test_window_compares_only_its_samples(driven, tmp_path):
    t, s, a, y, csv = _linear_data(tmp_path)
    r = fit(driven, csv, ["element.K.preload=0:100N", "element.K.stiffness=1000:10000"], window="100:300ms")
    keep = (t >= 0.1) & (t <= 0.3)
    X = np.column_stack([np.ones(keep.sum()), s[keep]])
    beta, *_ = np.linalg.lstsq(X, (y - MASS * a)[keep], rcond=None)
    np.testing.assert_allclose(r.values, beta, rtol=1e-6)
    assert r.dof == keep.sum() - 2


def test_workers_log_scale_and_multistart_reach_the_same_optimum(driven, tmp_path):
    # the closed-form optimum again, reached with a process pool, a log-scale stiffness
    # and three starts (two of them Latin-hypercube points)
    t, s, a, y, csv = _linear_data(tmp_path)
    X = np.column_stack([np.ones_like(s), s])
    beta, *_ = np.linalg.lstsq(X, y - MASS * a, rcond=None)
    params = ["element.K.preload=0:100N", "element.K.stiffness=1000:10000"]
    r = fit(driven, csv, params, log=["element.K.stiffness"], workers=2, starts=3, seed=4)
    np.testing.assert_allclose(r.values, beta, rtol=1e-6)
    assert len(r.starts) == 3 and all(st["converged"] for st in r.starts)
    starts = np.array([st["start"] for st in r.starts])
    assert starts[0].tolist() == [40.0, 5000.0]  # the file's values come first
    assert np.all((starts[1:, 0] > 0) & (starts[1:, 0] < 100) & (starts[1:, 1] > 1000) & (starts[1:, 1] < 10000))
    again = fit(driven, csv, params, log=["element.K.stiffness"], starts=3, seed=4)
    assert [st["start"] for st in again.starts] == [st["start"] for st in r.starts]  # seeded
    # log scale: the interval of ln k mapped back, so it is wider above than below
    lo, hi = r.ci95[1]
    assert lo < beta[1] < hi and hi - r.values[1] > r.values[1] - lo

"""Probability that a constraint is violated, from the runs of one candidate on common random numbers.

A robust constraint ``EXPR<=LIMIT`` is "P(EXPR > LIMIT) ≤ p_max" over the machines as
built (the ``--dist`` tolerances). Every candidate is run on the *same* N draws (common
random numbers), so two candidates differ only by the design, and the estimate moves
smoothly with the variables.

Two estimates of the violation probability from the N margins m_i (≤ 0: satisfied):

* the **normal-tail estimate** p = 1 − Φ(−μ/σ) with μ, σ the sample mean and standard
  deviation of the margins: smooth in the design and able to resolve p ≪ 1/N (a count
  cannot); exact when the response is linear in normal inputs, an approximation otherwise.
  The solver sees the equivalent quantile form μ + z σ ≤ 0 with z = Φ⁻¹(1 − p_max), which
  is as smooth as μ and σ. Its 95 % interval is a seeded percentile bootstrap (999
  resamples of the N margins);
* the **count** k/N of runs that violate, with the exact Clopper–Pearson 95 % interval
  (used as *the* estimate for 0/1 quantities such as ``jump``, where a normal fit means
  nothing).
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ["quantile_margin", "violation_probability", "N_BOOT", "is_binary"]

#: Bootstrap resamples of the normal-tail estimate.
N_BOOT = 999


def is_binary(values: np.ndarray) -> bool:
    """A 0/1 quantity (``jump``), for which only the count is meaningful."""
    v = np.asarray(values, dtype=float)
    v = v[np.isfinite(v)]
    return v.size > 0 and bool(np.all((v == 0.0) | (v == 1.0)))


def quantile_margin(margins: np.ndarray, p_max: float, binary: bool) -> float:
    """The solver's robust constraint value (≤ 0: violation probability ≤ ``p_max``).

    Normal tail: μ + z σ with z = Φ⁻¹(1 − p_max) [the margins' unit]; for a 0/1
    quantity the count fraction minus ``p_max``.
    """
    from scipy.stats import norm

    m = np.asarray(margins, dtype=float)
    if m.size == 0 or not np.all(np.isfinite(m)):
        return math.inf
    if binary:
        return float(np.mean(m > 0)) - p_max
    sigma = float(np.std(m, ddof=1)) if m.size > 1 else 0.0
    return float(np.mean(m) + norm.isf(p_max) * sigma)


def violation_probability(margins: np.ndarray, binary: bool, seed: int) -> dict:
    """Violation probability of one constraint at one speed, with 95 % intervals.

    Returns
    -------
    dict
        ``probability`` (the estimate the constraint uses), ``ci95`` [lo, hi] (its
        interval), ``method`` (``"normal"`` or ``"count"``), ``violated`` (count),
        ``n``, ``count_ci95`` (Clopper–Pearson of the count).
    """
    from scipy.stats import binomtest, norm

    m = np.asarray(margins, dtype=float)
    m = m[np.isfinite(m)]
    n = int(m.size)
    k = int(np.count_nonzero(m > 0))
    if n == 0:
        return {"probability": math.nan, "ci95": [math.nan, math.nan], "method": "count", "violated": 0, "n": 0,
                "count_ci95": [math.nan, math.nan]}
    ci = binomtest(k, n).proportion_ci(confidence_level=0.95, method="exact")
    count_ci = [float(ci.low), float(ci.high)]
    if binary or n < 3 or np.ptp(m) == 0:
        return {"probability": k / n, "ci95": count_ci, "method": "count", "violated": k, "n": n, "count_ci95": count_ci}

    def tail(x, axis=-1):
        return norm.sf(-np.mean(x, axis=axis) / np.std(x, axis=axis, ddof=1))

    p = float(tail(m))
    from scipy.stats import bootstrap

    res = bootstrap((m,), tail, n_resamples=N_BOOT, method="percentile", vectorized=True,
                    rng=np.random.default_rng(seed))
    return {"probability": p, "ci95": [float(res.confidence_interval.low), float(res.confidence_interval.high)],
            "method": "normal", "violated": k, "n": n, "count_ci95": count_ci}

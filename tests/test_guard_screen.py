"""The linear stepper's guard screen (camsim.engine.linear.screen_steps) against dense sampling.

Reference: each step's cubic Hermite of the guard (values and exact rates at its ends)
sampled at 4001 points. Every step where the samples reach 1e-9 below zero (the guard's
scale is 1) from above zero at its start must be flagged — a crossing, or a dip that comes back inside the step — and a
flagged step must hold a value at or below 1e-12 (a crossing, or the cubic's interior
minimum); a step of length zero (a cam break) is never flagged.
"""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from camsim.engine.linear import screen_steps

SIGMA = np.linspace(0.0, 1.0, 4001)


def hermite(g0, g1, d0, d1):
    """The cubic Hermite on [0, 1] with values g0, g1 and slopes d0, d1 (per unit σ) at SIGMA."""
    s = SIGMA[:, None]
    h00, h10, h01, h11 = 2 * s**3 - 3 * s**2 + 1, s**3 - 2 * s**2 + s, -2 * s**3 + 3 * s**2, s**3 - s**2
    return h00 * g0 + h10 * d0 + h01 * g1 + h11 * d1


@settings(max_examples=60, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), n=st.integers(2, 40), guards=st.integers(1, 4))
def test_screen_flags_every_step_that_reaches_zero(seed, n, guards):
    rng = np.random.default_rng(seed)
    nodes = np.cumsum(np.r_[0.0, rng.uniform(0.5, 1.5, n - 1)])
    nodes[rng.integers(1, n, 1)] = nodes[rng.integers(1, n, 1) - 1]  # maybe a break (a step of length zero)
    nodes = np.maximum.accumulate(nodes)
    steps = np.diff(nodes)
    G = rng.uniform(-0.3, 1.0, (n, guards))
    Gd = rng.normal(0.0, 2.0, (n, guards))
    hits = screen_steps(G[:-1], G[1:], Gd, steps)
    for k in range(n - 1):
        for j in range(guards):
            if steps[k] == 0.0:
                assert not hits[k, j]
                continue
            q = hermite(G[k, j], G[k + 1, j], Gd[k, j] * steps[k], Gd[k + 1, j] * steps[k])[:, 0]
            # a guard at or below zero at a step's start was found at an earlier step
            reaches = G[k, j] > 0.0 and (G[k + 1, j] <= 0.0 or q.min() < -1e-9)
            if reaches:
                assert hits[k, j], (k, j, q.min())
            if hits[k, j]:
                assert q.min() <= 1e-12 + 1e-6 * np.ptp(q), (k, j, q.min())

"""The min/max display envelope: every block's extremes kept, so no peak is lost.

Reference: a plain Python loop over the same blocks (the numpy-free definition) and the
global extremes of the signal; exact equality (indices, values).
"""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from camsim.reports.envelope import envelope, envelope_indices


def _loop_reference(y, columns):
    n = len(y)
    edges = [int(e) for e in np.linspace(0, n, columns + 1).astype(np.int64)]
    keep = set()
    for a, b in zip(edges[:-1], edges[1:]):
        block = list(y[a:b])
        keep.add(a + block.index(min(block)))
        keep.add(a + block.index(max(block)))
    return sorted(keep)


@settings(max_examples=60, deadline=None)
@given(n=st.integers(50, 3000), columns=st.integers(3, 40), seed=st.integers(0, 2**31 - 1))
def test_envelope_equals_block_loop(n, columns, seed):
    """Indices equal the loop's block minima and maxima (first occurrence), for random data."""
    y = np.random.default_rng(seed).standard_normal(n)
    idx = envelope_indices(y, columns)
    if n <= 2 * columns:
        np.testing.assert_array_equal(idx, np.arange(n))
    else:
        assert idx.tolist() == _loop_reference(y, columns)


def test_single_sample_spike_survives():
    """A one-sample spike (an impact) in a million samples is kept with its exact height."""
    t = np.linspace(0.0, 1.0, 1_000_001)
    y = np.sin(2 * np.pi * 3 * t)
    y[123_457] = 50.0
    y[876_543] = -40.0
    x, yy, reduced = envelope(t, y, 2000)
    assert reduced and yy.size <= 4000
    assert yy.max() == 50.0 and x[np.argmax(yy)] == t[123_457]
    assert yy.min() == -40.0 and x[np.argmin(yy)] == t[876_543]
    assert np.all(np.diff(x) > 0)

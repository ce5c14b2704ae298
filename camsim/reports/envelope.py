"""Min/max envelope of a long trace for display: peaks are never lost.

A screen shows a few thousand columns; a 100-revolution run has millions of samples. The
envelope keeps, for each of ``columns`` consecutive blocks of samples, the sample with the
smallest and the one with the largest value, in time order. Every local extreme that is
the extreme of its block survives, in particular the global maximum and minimum, so a
plotted peak has its true height (a decimation by striding would drop it).
"""

from __future__ import annotations

import numpy as np

#: Screen columns of a trace plot (about twice the width of a full-HD plot area).
DEFAULT_COLUMNS = 2000


def envelope_indices(y: np.ndarray, columns: int = DEFAULT_COLUMNS) -> np.ndarray:
    """Indices of the min/max envelope of ``y``, ascending.

    Parameters
    ----------
    y : ndarray (N,)
        Samples (NaN are ignored within a block; a block of NaN keeps its first index).
    columns : int
        Number of blocks; at most ``2 * columns`` indices are returned.

    Returns
    -------
    ndarray of int
        All indices ``0..N-1`` when ``N <= 2 * columns``, else the block minima and
        maxima (each block's first and last sample are not kept unless extreme).
    """
    y = np.asarray(y, dtype=float)
    n = y.shape[0]
    if n <= 2 * columns:
        return np.arange(n)
    # Block edges as evenly as integers allow; the blocks differ in length by at most one.
    edges = np.linspace(0, n, columns + 1).astype(np.int64)
    width = int(np.max(np.diff(edges)))
    # A (columns, width) view padded with the block's own first value keeps argmin/argmax
    # vectorised without letting the padding win (it equals a real sample of the block).
    starts = edges[:-1]
    lengths = np.diff(edges)
    offsets = np.arange(width)
    idx = starts[:, None] + np.minimum(offsets[None, :], lengths[:, None] - 1)
    block = y[idx]
    finite = np.isfinite(block)
    lo = np.argmin(np.where(finite, block, np.inf), axis=1)
    hi = np.argmax(np.where(finite, block, -np.inf), axis=1)
    picks = np.stack([starts + lo, starts + hi], axis=1)
    picks.sort(axis=1)
    return np.unique(picks.ravel())


def envelope(x: np.ndarray, y: np.ndarray, columns: int = DEFAULT_COLUMNS) -> tuple[np.ndarray, np.ndarray, bool]:
    """The envelope of ``y(x)``: reduced ``x``, ``y`` and whether anything was dropped."""
    idx = envelope_indices(y, columns)
    reduced = idx.shape[0] < np.asarray(y).shape[0]
    return np.asarray(x)[idx], np.asarray(y)[idx], reduced

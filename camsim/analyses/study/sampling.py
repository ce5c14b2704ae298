"""Drawing the input samples of a study: Monte Carlo, Latin hypercube, scrambled Sobol'.

All samples are drawn up front in the parent process from ``--seed``, so the rows are
the same whatever the number of workers that run them. Points are drawn on the unit
hypercube (:func:`unit_sample`), optionally coupled by a Gaussian copula
(:func:`apply_copula`, ``--correlate KEY1,KEY2=RHO``), then mapped through each input's
inverse CDF (:func:`to_values`).

For Sobol' sensitivity analysis, :func:`saltelli_design` builds Saltelli's matrices
A, B and AB_i (A with column i taken from B) from a 2d-dimensional point set, as
:func:`scipy.stats.sobol_indices` does.
"""

from __future__ import annotations

import re
import warnings
from collections.abc import Sequence

import numpy as np

from camsim.errors import InputError

__all__ = [
    "METHODS",
    "unit_sample",
    "parse_correlate",
    "correlation_matrix",
    "apply_copula",
    "to_values",
    "saltelli_design",
    "is_power_of_two",
]

#: ``--method`` values: plain Monte Carlo, Latin hypercube, scrambled Sobol'.
METHODS = ("mc", "lhs", "sobol")
#: Unit-cube points are kept this far from 0 and 1 so that unbounded inverse CDFs stay finite.
_EDGE = 1e-12


def is_power_of_two(n: int) -> bool:
    """True for 1, 2, 4, 8, ..."""
    return n >= 1 and (n & (n - 1)) == 0


def unit_sample(n: int, d: int, method: str, seed: int, warn: list[str] | None = None) -> np.ndarray:
    """``n`` points in the unit hypercube of dimension ``d``.

    Parameters
    ----------
    n, d : int
        Number of points and of dimensions.
    method : str
        ``mc`` (``numpy.random.default_rng(seed).random``), ``lhs``
        (:class:`scipy.stats.qmc.LatinHypercube`) or ``sobol``
        (:class:`scipy.stats.qmc.Sobol`, scrambled).
    seed : int
        Seed of the generator: the same seed gives the same points, bit for bit.
    warn : list of str, optional
        Receives a warning when a Sobol' count is not a power of two (its balance
        properties are lost).

    Returns
    -------
    ndarray (n, d)
        Points in [1e-12, 1 - 1e-12].
    """
    from scipy.stats import qmc

    if method not in METHODS:
        raise InputError(f"--method {method}: unknown sampling method (one of {', '.join(METHODS)})")
    if n < 1:
        raise InputError(f"--samples {n}: needs at least 1 sample")
    if method == "mc":
        u = np.random.default_rng(seed).random((n, d))
    elif method == "lhs":
        u = qmc.LatinHypercube(d=d, rng=np.random.default_rng(seed)).random(n)
    else:
        if not is_power_of_two(n) and warn is not None:
            warn.append(f"--samples {n} is not a power of two: scrambled Sobol' points lose their balance properties (use {1 << max(0, n - 1).bit_length()})")
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", UserWarning)  # the power-of-two warning, reported above
            u = qmc.Sobol(d=d, scramble=True, rng=np.random.default_rng(seed)).random(n)
    return np.clip(u, _EDGE, 1.0 - _EDGE)


_CORRELATE = re.compile(r"^\s*([^,=]+?)\s*,\s*([^,=]+?)\s*=\s*(.+?)\s*$")


def parse_correlate(text: str, keys: Sequence[str]) -> tuple[int, int, float]:
    """Parse ``KEY1,KEY2=RHO`` into the two inputs' positions and the correlation.

    Raises
    ------
    InputError
        Malformed text, a key that is not a ``--dist`` input, the same key twice, or
        RHO outside (-1, 1).
    """
    where = f"--correlate {text}"
    m = _CORRELATE.match(text)
    if not m:
        raise InputError(f"{where}: expected KEY1,KEY2=RHO, e.g. element.K12.stiffness,element.K23.push_stiffness=0.5")
    a, b, rho_text = m.groups()
    for k in (a, b):
        if k not in keys:
            raise InputError(f"{where}: {k} is not one of the --dist inputs")
    if a == b:
        raise InputError(f"{where}: a key cannot be correlated with itself")
    try:
        rho = float(rho_text)
    except ValueError:
        raise InputError(f"{where}: RHO '{rho_text}' is not a number") from None
    if not (-1.0 < rho < 1.0):
        raise InputError(f"{where}: RHO must lie strictly between -1 and 1")
    return list(keys).index(a), list(keys).index(b), rho


def correlation_matrix(pairs: Sequence[tuple[int, int, float]], d: int, texts: Sequence[str] = ()) -> np.ndarray:
    """The copula's correlation matrix; InputError if it is not positive definite."""
    r = np.eye(d)
    for k, (i, j, rho) in enumerate(pairs):
        if r[i, j] != 0.0:
            raise InputError(f"--correlate {texts[k] if k < len(texts) else ''}: this pair is given twice".replace("  ", " "))
        r[i, j] = r[j, i] = rho
    try:
        np.linalg.cholesky(r)
    except np.linalg.LinAlgError:
        raise InputError(f"--correlate {', '.join(texts)}: these correlations are inconsistent (the matrix is not positive definite)") from None
    return r


def apply_copula(u: np.ndarray, corr: np.ndarray) -> np.ndarray:
    """Couple independent unit-cube points by a Gaussian copula with correlation ``corr``.

    ``z = Φ⁻¹(u)``, ``z' = z Lᵀ`` with ``L Lᵀ = corr`` (Cholesky), ``u' = Φ(z')``: each
    marginal stays uniform, and the normal scores of the inputs have correlation
    ``corr``.
    """
    from scipy.stats import norm

    if np.array_equal(corr, np.eye(corr.shape[0])):
        return u
    z = norm.ppf(u) @ np.linalg.cholesky(corr).T
    return np.clip(norm.cdf(z), _EDGE, 1.0 - _EDGE)


def to_values(u: np.ndarray, dists: Sequence) -> np.ndarray:
    """Map unit-cube points (n, d) to input values [SI] through each inverse CDF."""
    out = np.empty_like(u)
    for j, dist in enumerate(dists):
        out[:, j] = dist.ppf(u[:, j])
    return out


def saltelli_design(n: int, d: int, method: str, seed: int, warn: list[str] | None = None) -> np.ndarray:
    """Saltelli's matrices for Sobol' indices, stacked: A, B, AB_0, ..., AB_{d-1}.

    A and B are the two halves of ``n`` points of a 2d-dimensional set (``method``);
    AB_i is A with column i replaced by B's.

    Returns
    -------
    ndarray (n (d + 2), d)
        Unit-cube points; rows ``k n`` to ``(k + 1) n - 1`` are block k.
    """
    if not is_power_of_two(n):
        raise InputError(f"--samples {n}: --sensitivity needs a power of two (Saltelli's estimator on Sobol' points), e.g. {1 << max(0, n - 1).bit_length()}")
    base = unit_sample(n, 2 * d, method, seed, warn)
    a, b = base[:, :d], base[:, d:]
    blocks = [a, b]
    for i in range(d):
        ab = a.copy()
        ab[:, i] = b[:, i]
        blocks.append(ab)
    return np.vstack(blocks)


def n_runs(n: int, d: int, sensitivity: bool) -> int:
    """Runs a study needs: ``n``, or ``n (d + 2)`` for Sobol' indices."""
    return n * (d + 2) if sensitivity else n


def block_names(keys: Sequence[str]) -> list[str]:
    """Design labels of the blocks of :func:`saltelli_design`: ``A``, ``B``, ``AB:<key>``."""
    return ["A", "B"] + [f"AB:{k}" for k in keys]


"""Statistics of a study's outputs and probabilities of crossing limits.

For every output: mean, standard deviation (ddof = 1), percentiles 1, 5, 50, 95, 99
(linear interpolation, :func:`numpy.percentile`), min and max, with 95 % bootstrap
intervals of the mean, the standard deviation and the percentiles
(:func:`scipy.stats.bootstrap`, percentile method, 999 resamples, generator seeded from
the study's seed so the intervals are reproducible).

A limit ``"min_cam_contact_force<0N"`` is crossed by a run whose output satisfies the
comparison. Its probability is the fraction of runs that cross it, with the exact
Clopper–Pearson 95 % interval (:meth:`scipy.stats.binomtest` ``proportion_ci(method=
"exact")``), which stays honest when no run or every run crosses it; the expected count
per million machines is the probability × 10⁶. Both treat the runs as independent
draws: exact for ``--method mc``, conservative for Latin hypercube and Sobol' points.
"""

from __future__ import annotations

import math
import operator
import re
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from camsim.errors import InputError

__all__ = ["PERCENTILES", "Limit", "parse_limit", "describe", "limit_probability", "N_RESAMPLES", "varies"]

#: Percentiles reported for every output.
PERCENTILES = (1, 5, 50, 95, 99)
#: Bootstrap resamples of the output statistics.
N_RESAMPLES = 999

_OPS = {"<": operator.lt, "<=": operator.le, ">": operator.gt, ">=": operator.ge}
_LIMIT = re.compile(r"^\s*([^<>=]+?)\s*(<=|>=|<|>)\s*(.+?)\s*$")
_NUMBER = re.compile(r"^\s*([-+]?(?:\d+(?:\.\d*)?|\.\d+)(?:[eE][-+]?\d+)?)\s*(.*?)\s*$")


@dataclass(frozen=True)
class Limit:
    """A limit on one output: crossed when ``value OP threshold``.

    Attributes
    ----------
    expr : str
        As written, e.g. ``"min_cam_contact_force<0N"``.
    quantity : str
        Output column.
    op : str
        ``<``, ``<=``, ``>`` or ``>=``.
    threshold : float
        In the output's SI unit.
    """

    expr: str
    quantity: str
    op: str
    threshold: float

    def crossed(self, values: np.ndarray) -> np.ndarray:
        """Boolean mask of the values that cross the limit."""
        return _OPS[self.op](np.asarray(values, dtype=float), self.threshold)


def parse_limit(text: str, units: Mapping[str, str]) -> Limit:
    """Parse ``QUANTITY OP VALUE[UNIT]`` against the study's output columns.

    Parameters
    ----------
    text : str
        e.g. ``"min_cam_contact_force<0N"``, ``"peak_transducer_force>=148lbf"``.
    units : mapping
        Output column -> SI unit.

    Raises
    ------
    InputError
        Malformed text, an unknown quantity, a unit that does not fit it.
    """
    where = f"--limit {text}"
    m = _LIMIT.match(text)
    if not m:
        raise InputError(f"{where}: expected QUANTITY<VALUE (or <=, >, >=), e.g. min_cam_contact_force<0N")
    quantity, op, value = m.groups()
    if quantity not in units:
        import difflib

        close = difflib.get_close_matches(quantity, list(units), n=1)
        hint = f"; did you mean {close[0]}?" if close else ""
        raise InputError(f"{where}: unknown quantity '{quantity}'{hint}")
    n = _NUMBER.match(value)
    if not n:
        raise InputError(f"{where}: '{value}' is not a number (with an optional unit)")
    number, unit = float(n.group(1)), n.group(2).replace(" ", "")
    target = units[quantity]
    if unit:
        import pint

        from camsim.units import ureg

        try:
            q = ureg.Quantity(number, unit)
            number = float(q.to(target).magnitude) if target else float(q.to("").magnitude)
        except pint.DimensionalityError:
            raise InputError(f"{where}: unit '{unit}' does not fit {quantity} (SI unit {target or 'none'})") from None
        except Exception:  # noqa: BLE001 - unknown unit
            raise InputError(f"{where}: unknown unit '{unit}'") from None
    return Limit(expr=text.strip(), quantity=quantity, op=op, threshold=number)


def _stat_vector(x: np.ndarray, axis: int = -1) -> np.ndarray:
    return np.concatenate(
        [
            np.mean(x, axis=axis)[None],
            np.std(x, axis=axis, ddof=1)[None],
            np.percentile(x, PERCENTILES, axis=axis),
        ],
        axis=0,
    )


def describe(values: np.ndarray, seed: int) -> dict:
    """Statistics of one output over the finished runs (NaN values are left out).

    Parameters
    ----------
    values : ndarray
        The output of each run [SI]; booleans count as 0/1.
    seed : int
        Seed of the bootstrap's generator.

    Returns
    -------
    dict
        ``n``, ``mean``, ``std``, ``min``, ``max``, ``percentiles`` {"1": ..., "99": ...},
        ``ci95`` {"mean": [lo, hi], "std": [lo, hi], "p1": [lo, hi], ...}. NaN (null in
        JSON) where undefined (no run; the std of a single run).
    """
    x = np.asarray(values, dtype=float)
    x = x[np.isfinite(x)]
    nan = float("nan")
    keys = ["mean", "std"] + [f"p{p}" for p in PERCENTILES]
    if x.size == 0:
        return {"n": 0, "mean": nan, "std": nan, "min": nan, "max": nan,
                "percentiles": {str(p): nan for p in PERCENTILES}, "ci95": {k: [nan, nan] for k in keys}}
    point = _stat_vector(x) if x.size > 1 else np.array([x[0], nan] + [x[0]] * len(PERCENTILES))
    if x.size > 2 and np.ptp(x) > 0:
        from scipy.stats import bootstrap

        res = bootstrap((x,), _stat_vector, n_resamples=N_RESAMPLES, method="percentile", vectorized=True,
                        batch=max(1, 2_000_000 // x.size), rng=np.random.default_rng(seed))
        low, high = res.confidence_interval.low, res.confidence_interval.high
    elif x.size > 1:  # every run gave the same value: no spread to resample
        low = high = point
    else:
        low = high = np.full(point.shape, nan)
    return {
        "n": int(x.size),
        "mean": float(point[0]),
        "std": float(point[1]),
        "min": float(np.min(x)),
        "max": float(np.max(x)),
        "percentiles": {str(p): float(v) for p, v in zip(PERCENTILES, point[2:])},
        "ci95": {k: [float(lo), float(hi)] for k, lo, hi in zip(keys, low, high)},
    }


def limit_probability(limit: Limit, values: np.ndarray) -> dict:
    """Probability that a run crosses ``limit``, its Clopper–Pearson 95 % interval, per million.

    Runs whose output is NaN (failed runs) are left out.

    Returns
    -------
    dict
        ``expr``, ``probability``, ``ci95`` [lo, hi], ``per_million``, ``crossed``
        (count), ``n`` (runs counted).
    """
    from scipy.stats import binomtest

    x = np.asarray(values, dtype=float)
    x = x[~np.isnan(x)]
    n = int(x.size)
    k = int(np.count_nonzero(limit.crossed(x)))
    if n == 0:
        p, ci = math.nan, [math.nan, math.nan]
    else:
        p = k / n
        interval = binomtest(k, n).proportion_ci(confidence_level=0.95, method="exact")
        ci = [float(interval.low), float(interval.high)]
    return {"expr": limit.expr, "probability": p, "ci95": ci, "per_million": p * 1e6, "crossed": k, "n": n}


def summarize(columns: Mapping[str, np.ndarray], names: Sequence[str], seed: int) -> dict[str, dict]:
    """:func:`describe` of each named output column (bootstrap seeds ``seed + i``)."""
    return {name: describe(columns[name], seed + i) for i, name in enumerate(names)}


def varies(values) -> bool:
    """Whether an output varies over the runs: its finite values spread by more than 1e-9 of their
    size (a constant output's float noise, 1e-14 of it, is no spread: no histogram, issue 44)."""
    x = np.asarray(values, dtype=float)
    x = x[np.isfinite(x)]
    return bool(x.size) and float(np.ptp(x)) > 1e-9 * max(float(np.max(np.abs(x))), 1e-300)

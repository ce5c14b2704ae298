"""Variance-based (Sobol') sensitivity indices of a study's outputs to its inputs.

The runs of Saltelli's design (:func:`camsim.analyses.study.sampling.saltelli_design`: blocks A,
B and AB_i of ``n`` runs each, ``n (d + 2)`` runs for ``d`` inputs) give each output's
values ``f_A``, ``f_B`` and ``f_AB``; :func:`scipy.stats.sobol_indices` turns them into
first-order indices S_i (the share of the output's variance due to input i alone) and
total indices S_Ti (its share including every interaction), with the estimators of
Saltelli et al. (2010). The 95 % intervals come from :func:`scipy.stats.bootstrap`
(percentile method) over the ``n`` rows of the design, resampled together, with a seeded
generator.

Sobol' indices assume independent inputs: a study with ``--correlate`` cannot have them.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

__all__ = ["sobol_from_outputs", "rank_inputs", "N_RESAMPLES"]

#: Bootstrap resamples of the indices.
N_RESAMPLES = 999


def _indices(f_a: np.ndarray, f_b: np.ndarray, f_ab: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    from scipy.stats import sobol_indices

    res = sobol_indices(func={"f_A": f_a, "f_B": f_b, "f_AB": f_ab}, n=f_a.shape[-1])
    d, s = f_ab.shape[0], f_a.shape[0]
    return np.reshape(res.first_order, (s, d)), np.reshape(res.total_order, (s, d))


def sobol_from_outputs(
    f_a: np.ndarray,
    f_b: np.ndarray,
    f_ab: np.ndarray,
    keys: Sequence[str],
    names: Sequence[str],
    seed: int,
    n_resamples: int = N_RESAMPLES,
) -> tuple[dict[str, dict[str, dict] | None], list[str]]:
    """First-order and total Sobol' indices with bootstrap intervals.

    Parameters
    ----------
    f_a, f_b : ndarray (s, n)
        Outputs of blocks A and B (``n`` a power of two).
    f_ab : ndarray (d, s, n)
        Outputs of the blocks AB_i.
    keys : sequence of str
        The ``d`` inputs.
    names : sequence of str
        The ``s`` outputs.
    seed : int
        Seed of the bootstrap's generator.
    n_resamples : int

    Returns
    -------
    indices : dict
        output -> input -> {"first", "total", "first_ci95": [lo, hi], "total_ci95": [lo, hi]};
        None for an output with a non-finite value in some run (a failed run) or no
        variance (constant over the design: nothing to share out).
    notes : list of str
        Why an output has no indices.
    """
    from scipy.stats import bootstrap

    f_a, f_b, f_ab = (np.asarray(v, dtype=float) for v in (f_a, f_b, f_ab))
    s, n = f_a.shape
    d = f_ab.shape[0]
    out: dict[str, dict[str, dict] | None] = {}
    notes: list[str] = []
    good = []
    for j, name in enumerate(names):
        allv = np.concatenate([f_a[j], f_b[j], f_ab[:, j, :].ravel()])
        if not np.all(np.isfinite(allv)):
            out[name] = None
            notes.append(f"{name}: no Sobol' indices (some runs failed or gave no value)")
        elif np.ptp(allv) == 0:
            out[name] = None
            notes.append(f"{name}: no Sobol' indices (the same value in every run)")
        else:
            good.append(j)
    if not good:
        return out, notes
    ga, gb, gab = f_a[good], f_b[good], f_ab[:, good, :]
    first, total = _indices(ga, gb, gab)

    def statistic(idx):
        idx = np.asarray(idx, dtype=int)
        fi, ti = _indices(ga[:, idx], gb[:, idx], gab[:, :, idx])
        return np.concatenate([fi.ravel(), ti.ravel()])

    with np.errstate(divide="ignore", invalid="ignore"):
        res = bootstrap((np.arange(n),), statistic, n_resamples=n_resamples, method="percentile", vectorized=False,
                        rng=np.random.default_rng(seed))
    lo = res.confidence_interval.low.reshape(2, len(good), d)
    hi = res.confidence_interval.high.reshape(2, len(good), d)
    for g, j in enumerate(good):
        out[names[j]] = {
            key: {
                "first": float(first[g, i]),
                "total": float(total[g, i]),
                "first_ci95": [float(lo[0, g, i]), float(hi[0, g, i])],
                "total_ci95": [float(lo[1, g, i]), float(hi[1, g, i])],
            }
            for i, key in enumerate(keys)
        }
    return {name: out[name] for name in names}, notes


def rank_inputs(indices: dict[str, dict[str, dict] | None], outputs: Sequence[str] | None = None) -> list[tuple[str, float]]:
    """Inputs ranked by the tolerance to tighten first: largest total index first.

    Parameters
    ----------
    indices : dict
        As returned by :func:`sobol_from_outputs`.
    outputs : sequence of str, optional
        The outputs that matter (e.g. those with a ``--limit``); default every output.

    Returns
    -------
    list of (str, float)
        (input, its largest total index over those outputs), descending; ties keep the
        input order.
    """
    names = [o for o in (outputs or list(indices)) if indices.get(o)]
    if not names:
        return []
    keys = list(indices[names[0]])
    score = {k: max(indices[o][k]["total"] for o in names) for k in keys}
    return sorted(score.items(), key=lambda kv: -kv[1])

"""The rows of a study and what is concluded from them: statistics, limit probabilities,
Sobol' indices (:func:`analyse`), and the stored form of one run (:func:`stored_row`).

Split from :mod:`camsim.analyses.study.runner`, which runs the samples.
"""

from __future__ import annotations

from typing import Any

import numpy as np

__all__ = ["analyse", "stored_row", "complete_row", "typed"]


def analyse(frame, output_names, limits, keys, samples: int, sensitivity: bool, seed: int):
    """Statistics, limit probabilities and Sobol' indices of the finished rows.

    Failed runs are left out; with ``sensitivity`` the statistics and limits use blocks A
    and B of Saltelli's design (the first 2N rows: 2N points of the input distribution).
    """
    from camsim.analyses.study.statistics import limit_probability, summarize

    ok = (frame["status"] == "ok").to_numpy()
    stats_mask = ok.copy()
    if sensitivity:
        stats_mask[2 * samples:] = False
    cols = {q: frame[q].to_numpy(dtype=float) for q in output_names}
    notes: list[str] = []
    described = [q for q in output_names if np.any(np.isfinite(cols[q][stats_mask]))]
    for q in output_names:
        if q not in described:
            notes.append(f"{q}: no value in any run (left out of the statistics)")
    stats = summarize({q: cols[q][stats_mask] for q in described}, described, seed)
    limit_rows = [limit_probability(lim, cols[lim.quantity][stats_mask]) for lim in limits]
    sens = None
    ranking: list[tuple[str, float]] = []
    if sensitivity:
        from camsim.analyses.study.sensitivity import rank_inputs, sobol_from_outputs

        n, d = samples, len(keys)
        y = np.array([np.where(ok, cols[q], np.nan) for q in described])  # (outputs, runs)
        f_a, f_b = y[:, :n], y[:, n:2 * n]
        f_ab = np.stack([y[:, (2 + i) * n:(3 + i) * n] for i in range(d)])
        sens, sens_notes = sobol_from_outputs(f_a, f_b, f_ab, keys, described, seed)
        notes += sens_notes
        ranking = rank_inputs(sens, [lim.quantity for lim in limits] or None)
    failed = int((~ok).sum())
    if failed:
        notes.append(f"{failed} of {len(ok)} runs failed (their rows hold the reason in 'status'; left out of the statistics)")
        pool = np.arange(ok.size) < (2 * samples if sensitivity else ok.size)  # the rows the limits are taken over
        counted, lost = int(pool.sum()), int((pool & ~ok).sum())
        for row in limit_rows if lost else ():
            # A failed run may be exactly one that crosses the limit: no probability is
            # concluded from the runs that did not fail (issue 26); the bounds are exact.
            low, high = row["crossed"] / counted, (row["crossed"] + lost) / counted
            row.update(probability=None, per_million=None, ci95=[None, None],
                       reason=f"{lost} of {counted} runs failed: P is between {low:.4g} and {high:.4g} "
                              f"({row['crossed']} crossed among the {row['n']} that ran)")
    return stats, limit_rows, sens, ranking, notes


def stored_row(index: int, design: str, keys, values, row: dict, names: set[str]) -> dict:
    """The stored form of one run: run, design, SI inputs, then the run's columns (others dropped)."""
    out: dict[str, Any] = {"run": int(index), "design": design}
    for k, v in zip(keys, values):
        out[f"param:{k}"] = float(v)
    for c, v in row.items():
        if c in names:
            out[c] = v.item() if isinstance(v, np.generic) else v
    return out


def complete_row(row: dict, columns) -> dict:
    from camsim.run.result import missing_scalar

    return {name: row[name] if name in row else missing_scalar(name) for name, _ in columns}


def typed(frame):
    """Column dtypes: run/impacts int64, jump bool, status/design str, the rest float64."""
    for name in frame.columns:
        if name in ("run", "impacts"):
            frame[name] = frame[name].astype(np.int64)
        elif name == "jump":
            frame[name] = frame[name].astype(bool)
        elif name in ("status", "design"):
            frame[name] = frame[name].astype(object)
        elif frame[name].dtype == object:
            try:
                frame[name] = frame[name].astype(float)
            except (TypeError, ValueError):
                pass
    return frame

"""The figure of a study (``camsim study --plot study.png``).

One figure, three kinds of panel:

* a histogram of each output, with its limits drawn as vertical red lines;
* a scatter of the most influential input (largest total Sobol' index; without
  sensitivity, the largest absolute Spearman rank correlation) against each output;
* with sensitivity, a bar chart of the first-order and total Sobol' indices of each input
  for each output (with their bootstrap 95 % intervals).

Outputs that are the same in every run (e.g. ``impacts`` of a machine without impacts)
are left out. Rendering is deterministic (Agg, no timestamps in the file).
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

__all__ = ["plot_study", "save_study_plot", "plotted_outputs"]

#: At most this many outputs get panels (those with limits first, then in column order).
MAX_OUTPUTS = 8


def plotted_outputs(result) -> list[str]:
    """The outputs that get panels: varying, limited ones first, at most :data:`MAX_OUTPUTS`."""
    from camsim.analyses.study.statistics import varies

    ok = (result.rows["status"] == "ok").to_numpy()
    varying = []
    for q in result.stats:
        if varies(result.rows[q].to_numpy(dtype=float)[ok]):
            varying.append(q)
    limited = [lim["expr"] for lim in result.limits]
    first = [q for q in varying if any(e.startswith(q) and e[len(q):len(q) + 1] in "<>" for e in limited)]
    return (first + [q for q in varying if q not in first])[:MAX_OUTPUTS]


def _influential(result, q: str, ok: np.ndarray) -> str:
    keys = [d.key for d in result.dists]
    if result.sensitivity and result.sensitivity.get(q):
        return max(keys, key=lambda k: result.sensitivity[q][k]["total"])
    from scipy.stats import spearmanr

    y = result.rows[q].to_numpy(dtype=float)[ok]
    best, score = keys[0], -1.0
    for k in keys:
        x = result.rows[f"param:{k}"].to_numpy(dtype=float)[ok]
        if np.ptp(x) == 0 or np.ptp(y) == 0:
            continue
        rho = abs(float(spearmanr(x, y).statistic))
        if rho > score:
            best, score = k, rho
    return best


def plot_study(result, outputs: list[str] | None = None, units=None):
    """Build the study figure (a :class:`matplotlib.figure.Figure`, not shown).

    Parameters
    ----------
    result : StudyResult
    outputs : list of str, optional
        The outputs to show, in order (default :func:`plotted_outputs`).
    units : DisplayUnits, optional
        Units drawn in (default the machine file's).
    """
    import matplotlib

    matplotlib.use("Agg", force=False)
    from matplotlib.figure import Figure

    from camsim.figures.style import _STYLE, displayed

    display = units if units is not None else getattr(result.machine, "display_units", None)

    units = dict(result.columns)
    outputs = plotted_outputs(result) if outputs is None else list(outputs)
    sens = bool(result.sensitivity) and any(result.sensitivity.get(q) for q in outputs)
    ncols = 3 if sens else 2
    nrows = max(1, len(outputs))
    with matplotlib.rc_context(_STYLE):
        fig = Figure(figsize=(4.0 * ncols, 2.6 * nrows + 0.6), layout="constrained")
        axes = fig.subplots(nrows, ncols, squeeze=False)
        rows = result.rows
        ok = (rows["status"] == "ok").to_numpy()
        if result.sensitivity is not None:
            ok = ok & np.isin(rows["design"].to_numpy(), ["A", "B"])
        for r, q in enumerate(outputs):
            unit = units.get(q, "")
            q_label, q_scale = displayed(q, unit, display)
            y = rows[q].to_numpy(dtype=float)[ok] * q_scale
            ax = axes[r][0]
            ax.hist(y[np.isfinite(y)], bins=min(50, max(10, int(np.sqrt(y.size)))), color="#4477aa")
            ax.set_xlabel(q_label)
            ax.set_ylabel("runs")
            finite = y[np.isfinite(y)]
            lo, hi = (float(finite.min()), float(finite.max())) if finite.size else (0.0, 1.0)
            span = hi - lo
            off_scale = []
            for lim in result.limits:
                text = lim["expr"]
                if text.startswith(q) and text[len(q):len(q) + 1] in "<>":
                    from camsim.analyses.study.statistics import parse_limit

                    threshold = parse_limit(text, {q: unit}).threshold * q_scale
                    label = f"{text[len(q):]}: P = {lim['probability']:.3g}"
                    if lo - 0.5 * span <= threshold <= hi + 0.5 * span:
                        ax.axvline(threshold, color="#cc3311", lw=1.5)
                        ax.text(threshold, ax.get_ylim()[1] * 0.95, f" {label}", color="#cc3311", va="top", fontsize=8)
                    else:
                        off_scale.append(f"{label} (limit off scale)")
            if off_scale:
                ax.text(0.02, 0.95, "\n".join(off_scale), transform=ax.transAxes, color="#cc3311", va="top", fontsize=8)
            k = _influential(result, q, ok)
            ax = axes[r][1]
            k_label, k_scale = displayed(k, units.get(f"param:{k}", ""), display)
            x = rows[f"param:{k}"].to_numpy(dtype=float)[ok] * k_scale
            ax.plot(x, y, ".", ms=2.5, color="#4477aa", rasterized=True)
            ax.set_xlabel(k_label)
            ax.set_ylabel(q_label)
            if sens:
                ax = axes[r][2]
                s = result.sensitivity.get(q)
                keys = [d.key for d in result.dists]
                pos = np.arange(len(keys))
                if s:
                    first = np.array([s[kk]["first"] for kk in keys])
                    total = np.array([s[kk]["total"] for kk in keys])
                    f_err = np.abs(np.array([s[kk]["first_ci95"] for kk in keys]).T - first)
                    t_err = np.abs(np.array([s[kk]["total_ci95"] for kk in keys]).T - total)
                    ax.barh(pos - 0.2, first, 0.4, xerr=f_err, label="first order", color="#66ccee")
                    ax.barh(pos + 0.2, total, 0.4, xerr=t_err, label="total", color="#228833")
                    # beside the bars, never over them (issue 44: it covered the lowest input's bars)
                    ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), borderaxespad=0.0, fontsize=8, frameon=False)
                ax.set_yticks(pos, [kk.split(".", 1)[-1] for kk in keys])
                ax.set_xlim(-0.05, 1.05)
                ax.set_xlabel("Sobol' index")
                ax.set_title(q, fontsize=9)
        if not outputs:
            axes[0][0].text(0.5, 0.5, "no output varies", ha="center", va="center")
        fig.suptitle(f"{result.machine.name}: {result.n_runs} runs ({result.method}, seed {result.seed})")
    return fig


def save_study_plot(result, path: str | os.PathLike[str], dpi: float = 120.0, outputs: list[str] | None = None,
                    units=None) -> Path:
    """Write the study figure to ``path`` (format from the suffix: png, svg, pdf) through the output policy, in ``units``."""
    from camsim.errors import InputError
    from camsim.figures.style import _METADATA, save_figure

    target = Path(path)
    fmt = target.suffix.lstrip(".").lower()
    if fmt not in _METADATA:
        raise InputError(f"--plot {path}: unknown format '{fmt}' (png, svg or pdf)")
    fig = plot_study(result, outputs, units=units)
    return save_figure(fig, target, fmt, dpi=dpi)

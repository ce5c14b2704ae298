"""The fit's figure (``camsim fit --report fit.png``): measured vs fitted, with residuals.

One pair of axes per measured channel: the measured samples and the fitted simulation at
the same times (moved by the fitted time shift), and below them the residual
(fitted − measured) with ±2σ of the noise level used for the weighting. Values in display
units (the machine file's by default). Built with the object-oriented Matplotlib API like :mod:`camsim.figures.plots`
and written with the same fixed metadata, so the same fit gives the same bytes.
"""

from __future__ import annotations

import os
from pathlib import Path

from camsim.errors import InputError

__all__ = ["plot_fit", "write_report", "REPORT_FORMATS"]

#: Figure formats (from the file name's suffix).
REPORT_FORMATS = ("png", "svg", "pdf")


def plot_fit(result, title: str = "", units=None):
    """Figure of measured vs fitted traces and residuals of a :class:`FitResult`, in ``units`` (default SI).

    Returns
    -------
    matplotlib.figure.Figure
    """
    import matplotlib
    from matplotlib.figure import Figure

    from camsim.analyses.fit.measured import _QUANTITY_UNITS
    from camsim.figures.style import _STYLE, _WIDTH, displayed, shown as shown_unit

    channels = result.channels
    n = max(1, len(channels))
    with matplotlib.rc_context(_STYLE):
        fig = Figure(figsize=(_WIDTH, 3.2 * n), layout="constrained")
        grid = fig.add_gridspec(2 * n, 1, height_ratios=[3, 1] * n)
        for k, (path, t, y, sim) in enumerate(channels):
            ax = fig.add_subplot(grid[2 * k])
            axr = fig.add_subplot(grid[2 * k + 1], sharex=ax)
            si_unit = _QUANTITY_UNITS.get(path.rsplit("/", 1)[-1], "")
            label, k_ = displayed(" ".join(path.split("/")[-2:]), si_unit, units)
            unit = shown_unit(si_unit, units)[0]
            y, sim = y * k_, sim * k_
            ax.plot(t, y, ".", markersize=1.5, color="0.55", label="measured")
            ax.plot(t, sim, "-", color="C0", linewidth=1.0, label="fitted")
            ax.set_ylabel(label)
            ax.legend(loc="upper right")
            ax.tick_params(labelbottom=False)
            res = sim - y
            axr.plot(t, res, "-", color="C3", linewidth=0.6)
            s = result.sigma.get(path)
            if s is not None:
                s = s * k_
                axr.axhline(2 * s, color="0.4", linestyle="--", linewidth=0.7)
                axr.axhline(-2 * s, color="0.4", linestyle="--", linewidth=0.7)
            axr.set_ylabel(f"resid. [{unit}]")
            if k == n - 1:
                axr.set_xlabel("measured time [s]")
        if not channels:
            ax = fig.add_subplot(grid[0])
            ax.text(0.5, 0.5, "no measured traces (scalar targets only)", ha="center", va="center")
        shown = ", ".join(f"{key} = {shown_unit(u or '', units)[1] * v:.5g}" + (f" {shown_unit(u, units)[0]}" if u else "")
                          for key, v, u in zip(result.keys, result.values, result.units))
        fig.suptitle((title + "\n" if title else "") + shown, fontsize=9)
    return fig


def write_report(path: str | os.PathLike[str], result, title: str = "", units=None) -> Path:
    """Draw :func:`plot_fit` and write it to ``path`` (format from the suffix), atomically.

    Raises
    ------
    InputError
        A suffix that is not png, svg or pdf.
    """
    from camsim.figures.style import save_figure

    target = Path(path)
    fmt = target.suffix.lstrip(".").lower()
    if fmt not in REPORT_FORMATS:
        raise InputError(f"--report {path}: unknown figure format '{target.suffix}' (use .png, .svg or .pdf)")
    fig = plot_fit(result, title, units=units)
    return save_figure(fig, target, fmt, dpi=150)

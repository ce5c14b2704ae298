"""What every camsim figure shares: the style, the sample windows, the axis labels.

Values are drawn in display units (:mod:`camsim.display`: the machine file's own by default,
issue 36): :func:`displayed` gives an axis label with its unit and the factor from SI.

The figure modules (:mod:`camsim.figures.plots`, :mod:`camsim.figures.cam`,
:mod:`camsim.figures.study`, :mod:`camsim.figures.fit`) all read these from here.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import h5py
import numpy as np

from camsim.errors import InputError, ResultFileError
from camsim.io.results import require

if TYPE_CHECKING:
    from camsim.display import DisplayUnits

#: Style for figures readable at report size (≈ 16 cm wide).
_STYLE = {
    "font.size": 10.0,
    "axes.titlesize": 10.0,
    "axes.labelsize": 10.0,
    "legend.fontsize": 9.0,
    "xtick.labelsize": 9.0,
    "ytick.labelsize": 9.0,
    "axes.grid": True,
    "grid.alpha": 0.35,
    "lines.linewidth": 1.2,
    "svg.hashsalt": "camsim",
    "axes.formatter.useoffset": False,
    "axes.formatter.limits": (-3, 4),
}
_WIDTH = 6.5  # [in]

#: Metadata left out of saved figures so that the same figure gives the same bytes.
_METADATA = {"png": {"Software": None}, "svg": {"Date": None}, "pdf": {"CreationDate": None, "Producer": None}}


def save_figure(fig, path, fmt: str | None = None, dpi: float = 150.0):
    """Write ``fig`` to ``path`` through the output policy (:func:`camsim.io.outputs.writing`).

    Parameters
    ----------
    fig : matplotlib.figure.Figure
    path : path
        The image; its format is ``fmt`` or, by default, its suffix (png, svg, pdf).
    dpi : float
        Resolution of raster output [dots per inch].

    Returns
    -------
    Path
        ``path``. The same figure gives the same bytes (no dates, a fixed SVG hash salt).
    """
    from pathlib import Path

    import matplotlib

    from camsim.io.outputs import FIGURES, output_format, writing

    target = Path(path)
    fmt = fmt or output_format(target, FIGURES)
    with matplotlib.rc_context({"svg.hashsalt": "camsim"}), writing(target, fmt, owner="figure") as out:
        with out.binary() as fh:
            fig.savefig(fh, format=fmt, dpi=dpi, metadata=_METADATA[fmt])
    return target


def _in(values: np.ndarray, window: tuple[float | None, float | None] | None) -> np.ndarray:
    mask = np.ones(values.shape, dtype=bool)
    if window is None:
        return mask
    lo, hi = window
    if lo is not None:
        mask &= values >= lo
    if hi is not None:
        mask &= values <= hi
    return mask


def _window_text(time_window, angle_window) -> str:
    if time_window is not None:
        lo, hi = time_window
        return f"--time {'' if lo is None else f'{lo:g}'}:{'' if hi is None else f'{hi:g}'} s"
    lo, hi = angle_window
    return f"--angle {'' if lo is None else f'{lo:g}'}:{'' if hi is None else f'{hi:g}'} deg"


def _sample_mask(group: h5py.Group, time_window, angle_window, angle_source: h5py.Group | None = None) -> np.ndarray:
    """Which samples of ``group``'s time base lie in the window (all of them without one).

    ``angle_source`` provides ``cam/angle`` when ``group`` has none (the difference group
    of a comparison), interpolated onto ``group``'s time.
    """
    t = require(group, "time")[()]
    if time_window is not None:
        mask = _in(t, time_window)
    elif angle_window is not None:
        if "cam/angle" in group:
            angle = group["cam/angle"][()]
        elif angle_source is not None and "cam/angle" in angle_source:
            angle = np.interp(t, angle_source["time"][()], angle_source["cam/angle"][()])
        else:
            raise ResultFileError(f"{group.file.filename}: {group.name.rstrip('/')}/cam/angle: not in the file (needed by --angle)")
        mask = _in(angle, angle_window)
    else:
        return np.ones(t.shape, dtype=bool)
    if not mask.any():
        raise InputError(
            f"{group.file.filename}: {_window_text(time_window, angle_window)}: no samples in the window "
            f"(the file covers t = {t[0]:g} .. {t[-1]:g} s)"
        )
    return mask


def pretty_units(units: str) -> str:
    """Display form of a unit text: ``m/s^2`` -> ``m/s²`` (:func:`camsim.display.typographic`)."""
    from camsim.display import typographic

    return typographic(units)


def axis_label(name: str, units: str) -> str:
    """``name [units]`` (``name`` alone for dimensionless quantities)."""
    return f"{name} [{pretty_units(units)}]" if units not in ("", "1") else name


def shown(si_unit: str, units: DisplayUnits | None) -> tuple[str, float]:
    """(unit shown, factor from SI) of values stored in ``si_unit``; as stored (SI, factor 1)
    when ``units`` is None (a figure function called on its own from Python), but speeds in
    rpm and angles in deg even then."""
    if units is None:
        if si_unit in ("rad/s", "rad"):
            from camsim.display import system_units

            return system_units("si").shown(si_unit)
        return pretty_units(si_unit), 1.0
    return units.shown(si_unit)


def displayed(name: str, si_unit: str, units: DisplayUnits | None) -> tuple[str, float]:
    """(axis label with the display unit, factor from SI): ``("force [lbf]", 0.2248)``."""
    unit, scale = shown(si_unit, units)
    return axis_label(name, unit), scale

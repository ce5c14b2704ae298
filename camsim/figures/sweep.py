"""Figures of sweep files: peaks and summary columns against the first swept key.

Values are drawn in display units (:mod:`camsim.display`; speeds in rpm, angles in deg).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING

import h5py
import matplotlib
import numpy as np
from matplotlib.figure import Figure

from camsim.errors import ResultFileError
from camsim.figures.style import _STYLE, _WIDTH, displayed
from camsim.io.results import require, table_units

if TYPE_CHECKING:
    from camsim.display import DisplayUnits

#: Mass quantities of a sweep's peak columns.
QUANTITIES = ("displacement", "velocity", "acceleration")


def _new_figure(height: float, nrows: int = 1) -> tuple[Figure, list]:
    fig = Figure(figsize=(_WIDTH, height), layout="constrained")
    axes = fig.subplots(nrows, 1, sharex=True, squeeze=False)[:, 0]
    return fig, list(axes)


def _sweep_table(f: h5py.Group) -> tuple[dict[str, np.ndarray], dict[str, str], str]:
    from camsim.io.hdf5 import read_table

    ds = require(f, "sweep/summary", "sweep table")
    table = read_table(ds)
    units = table_units(ds)
    params = [c for c in table if c.startswith("param:")]
    if not params:
        raise ResultFileError(f"{f.file.filename}: /sweep/summary: no param:<key> column")
    ok = np.ones(len(table[params[0]]), dtype=bool)
    if "status" in table:
        ok = np.array([str(s) == "ok" for s in table["status"]], dtype=bool)
    if not ok.any():
        raise ResultFileError(f"{f.file.filename}: /sweep/summary: no point has status ok, nothing to plot")
    table = {k: v[ok] for k, v in table.items()}
    return table, units, params[0]


def _sweep_figure(table, units, xcol: str, columns: Sequence[str], title: str, display: DisplayUnits | None = None) -> Figure:
    x_label, x_scale = displayed(xcol.removeprefix("param:"), units.get(xcol, ""), display)
    x = np.asarray(table[xcol], dtype=float) * x_scale
    order = np.argsort(x, kind="stable")
    with matplotlib.rc_context(_STYLE):
        fig, axes = _new_figure(max(2.4 * len(columns), 3.6), len(columns))
        for ax, col in zip(axes, columns):
            label, scale = displayed(col.replace("_", " ").replace(":", " "), units.get(col, ""), display)
            ax.plot(x[order], np.asarray(table[col], dtype=float)[order] * scale, marker="o", markersize=4, color="tab:blue")
            ax.set_ylabel(label, fontsize=9)
        axes[-1].set_xlabel(x_label)
        fig.suptitle(title)
    return fig


def plot_sweep_mass(f: h5py.Group, mass: str, quantities: Sequence[str] = QUANTITIES, units: DisplayUnits | None = None) -> Figure:
    """Peak displacement/velocity/acceleration of one mass against the first swept parameter.

    Points whose ``status`` is not ``"ok"`` are left out.
    """
    display = units
    table, units, xcol = _sweep_table(f)
    cols = []
    for q in quantities:
        col = f"peak_{q}:{mass}"
        if col not in table:
            raise ResultFileError(f"{f.file.filename}: /sweep/summary: no column {col}")
        cols.append(col)
    return _sweep_figure(table, units, xcol, cols, f"peaks of {mass}", display)


def sweep_masses(f: h5py.Group) -> list[str]:
    """Masses with peak columns in a sweep table."""
    ds = require(f, "sweep/summary")
    names = []
    for col in ds.dtype.names or ():
        if col.startswith("peak_displacement:"):
            names.append(col.split(":", 1)[1])
    return names


def plot_sweep_columns(f: h5py.Group, columns: Sequence[str], title: str, units: DisplayUnits | None = None) -> Figure | None:
    """The given summary columns (those present and not all NaN) against the first parameter."""
    display = units
    table, units, xcol = _sweep_table(f)
    cols = [c for c in columns if c in table and np.any(np.isfinite(np.asarray(table[c], dtype=float)))]
    if not cols:
        return None
    return _sweep_figure(table, units, xcol, cols, title, display)

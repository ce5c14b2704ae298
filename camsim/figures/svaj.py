"""SVAJ figure of one or more cam programs against cam angle (``camsim cam --plot``, issue 27).

Object-oriented matplotlib (``Figure()``, never pyplot), as in :mod:`camsim.figures.cam`.
With dynamic compensation it overlays the wanted output motion and the compensated cam.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np
from matplotlib.figure import Figure

from camsim.figures.cam import _STYLE
from camsim.cam.program import CamProgram

if TYPE_CHECKING:
    from camsim.display import DisplayUnits

__all__ = ["plot_svaj"]

_PANELS = (("s", "m"), ("v", "m/s"), ("a", "m/s^2"), ("j", "m/s^3"))


def plot_svaj(curves: list[tuple[str, CamProgram]], title: str = "", points: int = 3601,
              units: DisplayUnits | None = None) -> Figure:
    """Four stacked panels s, v, a, j (model axis) against cam angle [deg], in ``units`` (default SI).

    Parameters
    ----------
    curves : list of (label, CamProgram)
        Each program is sampled over one revolution at its own speed.
    title : str
        Figure title.
    points : int
        Samples over the revolution.
    units : DisplayUnits, optional
        Units drawn in (the machine file's for ``camsim cam --plot``).
    """
    from camsim.figures.style import displayed

    import matplotlib

    with matplotlib.rc_context(_STYLE):
        fig = Figure(figsize=(7.0, 7.5), layout="constrained")
        axes = fig.subplots(4, 1, sharex=True)
        for label, program in curves:
            theta = np.linspace(0.0, 2.0 * math.pi, points)
            t = (theta - program.start_angle) / program.speed
            values = program.svaj(t, side="left")
            for ax, (name, si_unit), v in zip(axes, _PANELS, values):
                y_label, k = displayed(name, si_unit, units)
                ax.plot(np.degrees(theta), k * v, label=label)
                ax.set_ylabel(y_label)
        axes[-1].set_xlabel("cam angle [deg]")
        axes[-1].set_xlim(0.0, 360.0)
        axes[-1].set_xticks(np.arange(0, 361, 45))
        if len(curves) > 1:
            axes[0].legend(loc="best")
        if title:
            fig.suptitle(title)
    return fig

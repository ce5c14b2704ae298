"""The timing diagram of several cams on one shaft (``camsim cam --plot``, issue 38).

Every cam's follower motion on the model axis against the shaft's angle over one
revolution, on one axis, as the designer of a multi-station machine lays them out; below
it, the distance of each ``[[clearance]]`` pair a cam prescribes, with its smallest value
marked. Object-oriented matplotlib (``Figure()``, never pyplot), as the other cam figures.
"""

from __future__ import annotations

import numpy as np
from matplotlib.figure import Figure

from camsim.cam.timing import kinematic_clearances, kinematic_position, timing_samples
from camsim.figures.cam import _STYLE

__all__ = ["plot_timing"]


def plot_timing(machine, title: str = "", points: int = 3601, units=None) -> Figure:
    """The timing diagram: s of every cam against the shaft angle [deg]; the clearances
    (kinematic ones) in a second panel; lengths in the display units ``units`` (default: the
    machine file's)."""
    import matplotlib

    length, k = (units if units is not None else machine.display_units).shown("m")
    data = timing_samples(machine, points)
    angle = data["angle"] - data["angle"][0]
    clearances = [c for c in kinematic_clearances(machine) if c["minimum_distance"] is not None]
    with matplotlib.rc_context(_STYLE):
        fig = Figure(figsize=(7.5, 6.0 if clearances else 4.0), layout="constrained")
        axes = fig.subplots(2 if clearances else 1, 1, sharex=True, squeeze=False)[:, 0]
        ax = axes[0]
        for cam in machine.cams:
            phase = np.degrees(cam.phase)
            label = f"{cam.name} (phase {phase:g}°" + (f", drives {cam.drives})" if cam.drives else ")")
            ax.plot(angle, k * data[cam.name], label=label)
        ax.set_ylabel(f"follower displacement s [{length}]")
        ax.legend(loc="best", fontsize="small")
        ax.grid(True, alpha=0.3)
        if clearances:
            ax2 = axes[1]
            start = np.radians(data["angle"][0])
            theta = np.radians(data["angle"])
            for c in clearances:
                spec = next(x for x in machine.clearances if x.name == c["name"])
                xa, xb = kinematic_position(machine, spec.a.node), kinematic_position(machine, spec.b.node)
                d = (xb(theta) + spec.b.offset) - (xa(theta) + spec.a.offset)
                line, = ax2.plot(angle, k * d, label=f"{c['name']}: {c['between'][0]} – {c['between'][1]}")
                at = (c["shaft_angle_deg"] - np.degrees(start)) % 360.0
                ax2.plot([at], [k * c["minimum_distance"]], "o", color=line.get_color())
                ax2.axhline(k * spec.minimum, color=line.get_color(), linestyle=":", linewidth=0.8)
            ax2.set_ylabel(f"clearance [{length}]")
            ax2.legend(loc="best", fontsize="small")
            ax2.grid(True, alpha=0.3)
        axes[-1].set_xlabel("shaft angle from its start angle [deg]")
        axes[-1].set_xlim(0.0, 360.0)
        axes[-1].set_xticks(np.arange(0, 361, 45))
        if title:
            fig.suptitle(title)
    return fig

"""Cam design figures: SVAJ with pressure angle and curvature, the cam drawn to scale.

Object-oriented matplotlib (``Figure()``, never pyplot), as in :mod:`camsim.figures.plots`.
:func:`plot_cam_design` draws from a machine's geometry and cam program (``camsim cam
--plot``); :func:`plot_design_file` draws the design datasets of a result file
(``camsim plot --what design``).
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import matplotlib
import numpy as np
from matplotlib.figure import Figure

from camsim.cam.geometry import (
    CamGeometry,
    arm_setup,
    design_grid,
    pitch_radius,
    pressure_angle,
    roller_side_motion,
)
from camsim.cam.profile import profile_points
from camsim.figures.style import displayed, shown

if TYPE_CHECKING:
    from camsim.display import DisplayUnits

__all__ = ["draw_cam", "plot_cam_design", "plot_design_file"]

_STYLE = {
    "font.size": 9.0,
    "axes.titlesize": 9.0,
    "axes.labelsize": 9.0,
    "legend.fontsize": 8.0,
    "xtick.labelsize": 8.0,
    "ytick.labelsize": 8.0,
    "axes.grid": True,
    "grid.alpha": 0.35,
    "lines.linewidth": 1.1,
    "svg.hashsalt": "camsim",
    "axes.formatter.useoffset": False,
}


def draw_cam(ax, geometry: CamGeometry, program, tolerance: float = 5e-6, units: DisplayUnits | None = None) -> None:
    """Draw the cam to scale in its frame at θ = 0 with the follower in place (lengths in ``units``, default mm).

    Surface (filled), pitch curve (dashed, roller followers), base and prime circles,
    the centre, the follower (roller and stem, flat face, or arm and pivot) and an
    arrow for the sense of rotation.
    """
    pts = profile_points(geometry, program, tolerance)
    length, k = shown("m", units)
    surf = np.vstack([pts["surface"], pts["surface"][:1]]) * k
    ax.fill(surf[:, 0], surf[:, 1], color="0.85", zorder=1)
    ax.plot(surf[:, 0], surf[:, 1], color="k", lw=1.2, label="cam surface", zorder=3)
    circle = np.linspace(0.0, 2 * math.pi, 361)
    rb = geometry.base_radius * k
    ax.plot(rb * np.cos(circle), rb * np.sin(circle), color="tab:blue", lw=0.8, ls=":", label="base circle Rb")
    if geometry.is_roller:
        pitch = np.vstack([pts["pitch"], pts["pitch"][:1]]) * k
        ax.plot(pitch[:, 0], pitch[:, 1], color="tab:green", lw=0.9, ls="--", label="pitch curve")
        rp = geometry.prime_radius * k
        ax.plot(rp * np.cos(circle), rp * np.sin(circle), color="tab:green", lw=0.6, ls=":", label="prime circle Rp")
    ax.plot([0.0], [0.0], marker="+", color="k", ms=10, zorder=4)
    s, s1, _, _ = (float(np.asarray(v).reshape(-1)[0]) for v in roller_side_motion(program, np.array([0.0])))
    sigma = geometry.sense
    size = max(geometry.prime_radius, geometry.base_radius) * k
    if geometry.follower == "translating-roller":
        d = math.sqrt(geometry.prime_radius**2 - geometry.offset**2) * k
        x, y = sigma * geometry.offset * k, d + s * k
        rr = geometry.roller_radius * k
        ax.add_patch(matplotlib.patches.Circle((x, y), rr, fill=False, color="tab:red", lw=1.2, zorder=5))
        ax.plot([x, x], [y, y + 0.8 * size], color="tab:red", lw=2.0, label="follower", zorder=5)
    elif geometry.follower == "translating-flat":
        y = (geometry.base_radius + s) * k
        half = 0.6 * size
        x0 = sigma * geometry.offset * k
        ax.plot([x0 - half, x0 + half], [y, y], color="tab:red", lw=2.0, label="follower face", zorder=5)
        ax.plot([x0, x0], [y, y + 0.8 * size], color="tab:red", lw=2.0, zorder=5)
    else:
        psi0, gamma = arm_setup(geometry)
        c, length = geometry.pivot_distance * k, geometry.arm_length * k
        psi = psi0 + s / geometry.arm_length
        turn = np.array([[math.cos(gamma), -math.sin(gamma)], [math.sin(gamma), math.cos(gamma)]])
        pivot = turn @ np.array([c, 0.0])
        roller = turn @ np.array([c - length * math.cos(psi), length * math.sin(psi)])
        rr = geometry.roller_radius * k
        ax.add_patch(matplotlib.patches.Circle(tuple(roller), rr, fill=False, color="tab:red", lw=1.2, zorder=5))
        ax.plot([pivot[0], roller[0]], [pivot[1], roller[1]], color="tab:red", lw=2.0, label="follower arm", zorder=5)
        ax.plot([pivot[0]], [pivot[1]], marker="o", color="tab:red", ms=6, zorder=5)
    # sense of rotation: an arc near the centre
    r = 0.35 * geometry.base_radius * k
    arc = np.linspace(0.2, 1.4, 30) * sigma + (math.pi if sigma < 0 else 0.0)
    ax.plot(r * np.cos(arc), r * np.sin(arc), color="0.3", lw=1.0)
    ax.annotate("", xy=(r * math.cos(arc[-1]), r * math.sin(arc[-1])),
                xytext=(r * math.cos(arc[-3]), r * math.sin(arc[-3])),
                arrowprops={"arrowstyle": "->", "color": "0.3"})
    ax.text(0.0, -0.55 * r, geometry.rotation, ha="center", va="top", fontsize=8, color="0.3")
    ax.set_aspect("equal")
    ax.set_xlabel(f"x [{length}]")
    ax.set_ylabel(f"y [{length}]")
    ax.legend(loc="lower left", fontsize=7)


def plot_cam_design(geometry: CamGeometry, program, title: str = "", units: DisplayUnits | None = None) -> Figure:
    """SVAJ at the roller, pressure angle and radii of curvature against cam angle, and the cam.

    Left: roller-side lift, velocity, acceleration, jerk at the cam's speed; pressure angle
    [deg] with the ± limit; pitch and surface radius of curvature (left out beyond ±4·Rp,
    where ρ passes through infinity on a nearly straight stretch, so that those do not
    flatten the rest). Right: :func:`draw_cam`. Values in ``units`` (default SI, lengths in mm).
    """
    length, lk = shown("m", units)
    theta, left = design_grid(program, 4)
    s, s1, s2, s3 = (np.array(v) for v in roller_side_motion(program, theta))
    if np.any(left):
        for arr, val in zip((s, s1, s2, s3), roller_side_motion(program, theta[left], "left")):
            arr[left] = val
    w = program.speed
    deg = np.degrees(theta)
    phi = np.degrees(pressure_angle(geometry, s, s1))
    rho = pitch_radius(geometry, s, s1, s2, s3) * lk
    limit = math.degrees(geometry.pressure_angle_limit)
    with matplotlib.rc_context(_STYLE):
        fig = Figure(figsize=(11.0, 8.0))
        grid = fig.add_gridspec(6, 2, width_ratios=(1.0, 1.0), left=0.07, right=0.98, bottom=0.06, top=0.94,
                                wspace=0.18, hspace=0.12)
        axes = [fig.add_subplot(grid[0, 0])]
        for i in range(1, 6):
            axes.append(fig.add_subplot(grid[i, 0], sharex=axes[0]))
        panels = (
            (s, "lift s", "m"),
            (s1 * w, "velocity", "m/s"),
            (s2 * w * w, "accel.", "m/s^2"),
            (s3 * w**3, "jerk", "m/s^3"),
        )
        for ax, (y, name, si_unit) in zip(axes, panels):
            label, k = displayed(name, si_unit, units)
            ax.plot(deg, y * k, color="tab:blue")
            ax.set_ylabel(label)
        ax = axes[4]
        ax.plot(deg, phi, color="tab:purple")
        if geometry.is_roller:
            ax.axhline(limit, color="tab:red", ls="--", lw=0.8)
            ax.axhline(-limit, color="tab:red", ls="--", lw=0.8)
        ax.set_ylabel("press. angle [deg]")
        ax = axes[5]
        cap = 4.0 * geometry.prime_radius * lk
        clip = lambda y: np.where(np.abs(y) > cap, np.nan, y)  # noqa: E731 - gaps where ρ passes through ∞
        ax.plot(deg, clip(rho), color="tab:green", label="pitch" if geometry.is_roller else "surface")
        if geometry.is_roller:
            ax.plot(deg, clip(rho - geometry.roller_radius * lk), color="k", lw=0.9, label="surface")
            ax.axhline(geometry.roller_radius * lk, color="tab:red", ls="--", lw=0.8, label="Rr")
        ax.axhline(0.0, color="0.4", lw=0.6)
        ax.set_ylabel(f"ρ [{length}]")
        ax.set_ylim(-cap, cap)
        ax.legend(loc="lower right", ncols=3)
        ax.set_xlabel("cam angle [deg]")
        for a in axes[:-1]:
            a.tick_params(labelbottom=False)
        draw_cam(fig.add_subplot(grid[:, 1]), geometry, program, units=units)
        fig.suptitle(title or f"cam design: {geometry.follower}, {geometry.rotation}")
    return fig


def plot_design_file(group, time_window=None, angle_window=None, title: str = "", units: DisplayUnits | None = None) -> Figure:
    """The design datasets of a result file against time (run) or cam angle (cam file).

    Panels, as present: ``cam/pressure_angle`` [deg], ``cam/surface_radius_of_curvature``,
    ``cam_contact/normal_force``, ``cam_contact/hertz_stress``, ``camshaft/torque``, in
    ``units`` (default SI: mm, N, MPa, N·m).
    """
    from camsim.figures.style import _in, _sample_mask  # the window helpers of camsim plot

    panels = []
    for path, name, si_unit in (("cam/pressure_angle", "pressure angle", "deg"),
                                ("cam/surface_radius_of_curvature", "surface ρ", "m"),
                                ("cam_contact/normal_force", "normal force", "N"),
                                ("cam_contact/hertz_stress", "Hertz stress", "Pa"),
                                ("camshaft/torque", "torque", "N*m")):
        label, scale = displayed(name, si_unit, units)
        panels.append((path, scale, label))
    panels = [p for p in panels if p[0] in group]
    run = "cam_contact/normal_force" in group
    if run and "time" in group:
        x_all = group["time"][()]
        mask = _sample_mask(group, time_window, angle_window)
        xlabel = "time [s]"
    else:
        x_all = group["cam/angle"][()]
        mask = _in(x_all, angle_window)
        xlabel = "cam angle [deg]"
    x = x_all[mask]
    with matplotlib.rc_context(_STYLE):
        fig = Figure(figsize=(6.5, 1.6 * len(panels) + 0.8), layout="constrained")
        axes = fig.subplots(len(panels), 1, sharex=True, squeeze=False)[:, 0]
        for ax, (path, scale, label) in zip(axes, panels):
            y = group[path][()][mask] * scale
            if path == "cam/surface_radius_of_curvature":
                finite = y[np.isfinite(y)]
                if finite.size:
                    cap = 4.0 * float(np.median(np.abs(finite)))
                    y = np.clip(y, -cap, cap)
            ax.plot(x, y, color="tab:blue")
            ax.set_ylabel(label)
        axes[-1].set_xlabel(xlabel)
        fig.suptitle(title or "cam design")
    return fig

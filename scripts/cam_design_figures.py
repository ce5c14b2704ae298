"""Figures of docs/cam-design.md: sign conventions, the CDTM cam, the base-radius design chart.

    python scripts/cam_design_figures.py            # writes docs/figures/cam-design-*.png

* ``cam-design-conventions.png``: the frames and signs of camsim.cam.geometry, drawn from
  the library itself (a translating roller with offset, a flat face and an oscillating
  roller, each at θ = 0 and at a cam angle on the rise, with φ, ε, Rb, Rp, Rr labelled);
* ``cam-design-cdtm.png``: ``camsim cam machines/cdtm-geometry.toml --plot``;
* ``cam-design-chart.png``: largest |pressure angle| and smallest surface radius of the
  CDTM cam against base radius (oscillating roller as in machines/cdtm-geometry.toml, and
  a radial translating roller for comparison), Rr = 0.5 in.
Deterministic: the same library gives the same images.
"""

from __future__ import annotations

import math
import sys
from pathlib import Path

import matplotlib
import numpy as np
from matplotlib.figure import Figure

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from camsim.cam import CamProgram  # noqa: E402
from camsim.cam import geometry as G  # noqa: E402
from camsim.figures.cam import plot_cam_design  # noqa: E402
from camsim.cam.profile import profile_points  # noqa: E402
from camsim.machine.loader import load_machine, load_machine_text  # noqa: E402

OUT = ROOT / "docs" / "figures"
INCH = 0.0254

DEMO = """\
schema = 1
[machine]
name = "demo"
[cam]
speed = "60 rpm"
segments = [
  { motion = "rise",  law = "cycloidal", duration = "120 deg", lift = "18 mm" },
  { motion = "dwell", duration = "60 deg" },
  { motion = "fall",  law = "cycloidal", duration = "120 deg", lift = "18 mm" },
  { motion = "dwell", duration = "60 deg" },
]
[[mass]]
name = "M1"
mass = "1 kg"
[[element]]
name = "k"
type = "spring"
between = ["cam", "M1"]
stiffness = "1e6 N/m"
"""


def _rot(a):
    return np.array([[math.cos(a), -math.sin(a)], [math.sin(a), math.cos(a)]])


def _panel(ax, geometry, program, theta_deg: float, title: str) -> None:
    """The cam turned to cam angle θ in the ground frame, the follower and the labels."""
    theta = math.radians(theta_deg)
    sigma = geometry.sense
    pts = profile_points(geometry, program, 2e-5)
    turn = _rot(sigma * theta)  # cam frame -> ground frame at angle θ
    surf = np.vstack([pts["surface"], pts["surface"][:1]]) @ turn.T * 1e3
    ax.fill(surf[:, 0], surf[:, 1], color="0.88")
    ax.plot(surf[:, 0], surf[:, 1], color="k", lw=1.0)
    c = np.linspace(0, 2 * math.pi, 200)
    rb = geometry.base_radius * 1e3
    ax.plot(rb * np.cos(c), rb * np.sin(c), ":", color="tab:blue", lw=0.8)
    ax.plot(0, 0, "+", color="k", ms=8)
    ax.annotate("", xy=(rb * math.cos(2.4), rb * math.sin(2.4)), xytext=(0, 0),
                arrowprops={"arrowstyle": "->", "color": "tab:blue", "lw": 0.8})
    ax.text(0.5 * rb * math.cos(2.4) - 2, 0.5 * rb * math.sin(2.4) + 1, "Rb", color="tab:blue", fontsize=8)
    s, s1, _, _ = (float(np.asarray(v).reshape(-1)[0]) for v in G.roller_side_motion(program, np.array([theta])))
    point, normal = G.contact_points(geometry, s, s1)
    point, normal = point[0] * 1e3, normal[0]
    phi = math.degrees(float(G.pressure_angle(geometry, s, s1)[0]))
    if geometry.follower == "translating-roller":
        d = math.sqrt(geometry.prime_radius**2 - geometry.offset**2)
        x, y = sigma * geometry.offset * 1e3, (d + s) * 1e3
        rr = geometry.roller_radius * 1e3
        ax.add_patch(matplotlib.patches.Circle((x, y), rr, fill=False, color="tab:red", lw=1.2))
        ax.plot([x, x], [y, y + 35], color="tab:red", lw=2)
        ax.plot([x, x], [-5, y], "--", color="tab:red", lw=0.6)
        ax.annotate("", xy=(x, -3), xytext=(0, -3), arrowprops={"arrowstyle": "<->", "lw": 0.8})
        ax.text(x / 2, 3, "ε > 0", ha="center", fontsize=8)
        ax.annotate("", xy=(x, y + 30), xytext=(x, y + 12), arrowprops={"arrowstyle": "->", "color": "tab:red"})
        ax.text(x + 2, y + 24, "e (rise)", color="tab:red", fontsize=8)
        n_end = np.array([x, y]) + 22 * normal
        ax.annotate("", xy=tuple(n_end), xytext=(x, y), arrowprops={"arrowstyle": "->", "color": "tab:purple"})
        ax.text(n_end[0] - 14, n_end[1], f"n, φ = {phi:.1f}°", color="tab:purple", fontsize=8)
        ax.text(x + rr + 1, y - 2, "Rr", color="tab:red", fontsize=8)
    elif geometry.follower == "translating-flat":
        y = (geometry.base_radius + s) * 1e3
        ax.plot([-30, 30], [y, y], color="tab:red", lw=2)
        ax.plot([0, 0], [y, y + 30], color="tab:red", lw=2)
        ax.plot(point[0], point[1], "o", color="tab:purple", ms=4)
        ax.annotate("", xy=(point[0], y + 6), xytext=(0, y + 6), arrowprops={"arrowstyle": "<->", "lw": 0.8})
        ax.text(point[0] / 2, y + 8, "σ·s′", ha="center", fontsize=8)
        ax.text(-30, y + 3, "face at Rb + s", color="tab:red", fontsize=8)
    else:
        psi0, gamma = G.arm_setup(geometry)
        psi = psi0 + s / geometry.arm_length
        t = _rot(gamma)
        pivot = t @ np.array([geometry.pivot_distance, 0.0]) * 1e3
        roller = t @ np.array([geometry.pivot_distance - geometry.arm_length * math.cos(psi),
                               geometry.arm_length * math.sin(psi)]) * 1e3
        rr = geometry.roller_radius * 1e3
        ax.add_patch(matplotlib.patches.Circle(tuple(roller), rr, fill=False, color="tab:red", lw=1.2))
        ax.plot([pivot[0], roller[0]], [pivot[1], roller[1]], color="tab:red", lw=2)
        ax.plot(*pivot, "o", color="tab:red", ms=5)
        ax.text(pivot[0] + 2, pivot[1] + 2, "pivot", color="tab:red", fontsize=8)
        ax.plot([0, pivot[0]], [0, pivot[1]], "--", color="0.5", lw=0.6)
        ax.text(pivot[0] / 2, pivot[1] / 2 - 6, "pivot_distance", color="0.4", fontsize=7, ha="center")
        e = t @ np.array([math.sin(psi), math.cos(psi)])
        ax.annotate("", xy=tuple(roller + 20 * e), xytext=tuple(roller), arrowprops={"arrowstyle": "->", "color": "tab:red"})
        ax.text(*(roller + 21 * e), "e (normal to arm)", color="tab:red", fontsize=8)
        ax.plot(*(roller + 30 * e), alpha=0.0)  # make room for the arrows
        n_end = roller + 22 * normal
        ax.annotate("", xy=tuple(n_end), xytext=tuple(roller), arrowprops={"arrowstyle": "->", "color": "tab:purple"})
        ax.text(n_end[0] - 16, n_end[1] + 2, f"n, φ = {phi:.1f}°", color="tab:purple", fontsize=8)
    r = 0.35 * rb
    arc = np.linspace(0.3, 1.5, 30) * sigma + (math.pi if sigma < 0 else 0.0)
    ax.plot(r * np.cos(arc), r * np.sin(arc), color="0.3", lw=0.9)
    ax.annotate("", xy=(r * math.cos(arc[-1]), r * math.sin(arc[-1])), xytext=(r * math.cos(arc[-3]), r * math.sin(arc[-3])),
                arrowprops={"arrowstyle": "->", "color": "0.3"})
    ax.text(0, -1.2 * r, f"{geometry.rotation}, θ = {theta_deg:g}°", ha="center", va="top", fontsize=7, color="0.3")
    ax.set_title(title, fontsize=9)
    ax.set_aspect("equal")
    ax.set_xlabel("x [mm]", fontsize=8)
    ax.set_ylabel("y [mm]", fontsize=8)
    ax.tick_params(labelsize=7)


def conventions(path: Path) -> None:
    program = CamProgram(load_machine_text(DEMO).cam)
    cases = [
        (G.CamGeometry("translating-roller", 0.030, 0.010, offset=0.008), 50.0,
         "translating roller, offset ε\nφ = atan((s′ − ε)/(s + d))"),
        (G.CamGeometry("translating-flat", 0.040), 50.0, "translating flat face\nφ = 0, ρ = Rb + s + s″"),
        (G.CamGeometry("oscillating-roller", 0.030, 0.010, pivot_distance=0.080, arm_length=0.070), 50.0,
         "oscillating roller\npivot to the right"),
    ]
    with matplotlib.rc_context({"svg.hashsalt": "camsim", "font.size": 8}):
        fig = Figure(figsize=(12.0, 4.8))
        axes = fig.subplots(1, 3)
        for ax, (geometry, angle, title) in zip(axes, cases):
            _panel(ax, geometry, program, angle, title)
        fig.suptitle("camsim cam geometry: ground frame x right, y up; follower above the cam at θ = 0; "
                     "ccw cam (σ = +1); the cam drawn at θ = 50° on the rise", fontsize=9)
        fig.subplots_adjust(left=0.05, right=0.98, bottom=0.1, top=0.84, wspace=0.25)
        fig.savefig(path, dpi=130, metadata={"Software": None})


def cdtm(path: Path) -> None:
    machine = load_machine(ROOT / "machines" / "cdtm-geometry.toml")
    fig = plot_cam_design(machine.cam.geometry, CamProgram(machine.cam), title=f"{machine.name}: cam design")
    fig.savefig(path, dpi=110, metadata={"Software": None})


def chart(path: Path) -> list[tuple[float, float, float, float]]:
    machine = load_machine(ROOT / "machines" / "cdtm-geometry.toml")
    program = CamProgram(machine.cam)
    geometry = machine.cam.geometry
    radii = np.arange(1.0, 2.51, 0.125) * INCH
    rows = []
    for rb in radii:
        osc = G.geometry_summary(G.CamGeometry("oscillating-roller", rb, geometry.roller_radius,
                                               pivot_distance=geometry.pivot_distance,
                                               arm_length=geometry.arm_length), program)
        tr = G.geometry_summary(G.CamGeometry("translating-roller", rb, geometry.roller_radius), program)
        rows.append((rb, osc["max_pressure_angle"], tr["max_pressure_angle"], osc["min_surface_radius"]))
    data = np.array(rows)
    with matplotlib.rc_context({"font.size": 9, "axes.grid": True, "grid.alpha": 0.35}):
        fig = Figure(figsize=(6.5, 5.0))
        ax1, ax2 = fig.subplots(2, 1, sharex=True)
        ax1.plot(data[:, 0] / INCH, data[:, 1], "o-", label="oscillating roller (pivot 7 in, arm 6.5 in)")
        ax1.plot(data[:, 0] / INCH, data[:, 2], "s--", label="radial translating roller")
        ax1.axhline(30, color="tab:red", lw=0.8)
        ax1.set_ylabel("max |pressure angle| [deg]")
        ax1.legend(fontsize=8)
        ax2.plot(data[:, 0] / INCH, data[:, 3] * 1e3, "o-")
        ax2.axhline(0, color="tab:red", lw=0.8)
        ax2.set_ylabel("min surface radius [mm]")
        ax2.set_xlabel("base radius Rb [in] (Rr = 0.5 in)")
        fig.suptitle("CDTM cam (thesis table 2): pressure angle and curvature against base radius")
        fig.subplots_adjust(left=0.12, right=0.97, top=0.92, bottom=0.1, hspace=0.1)
        fig.savefig(path, dpi=110, metadata={"Software": None})
    return rows


def main() -> None:
    OUT.mkdir(parents=True, exist_ok=True)
    conventions(OUT / "cam-design-conventions.png")
    cdtm(OUT / "cam-design-cdtm.png")
    for rb, osc, tr, smin in chart(OUT / "cam-design-chart.png"):
        print(f"Rb {rb / INCH:.3f} in ({rb * 1e3:.2f} mm): oscillating {osc:.2f} deg, translating {tr:.2f} deg, "
              f"min surface radius {smin * 1e3:.2f} mm")


if __name__ == "__main__":
    main()

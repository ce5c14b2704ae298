"""Cam profile export: the surface and pitch curve at a chordal tolerance, as CSV or DXF.

:func:`profile_points` samples the closed contour adaptively: it starts from one point
per degree (and every segment join), then halves every interval whose midpoint lies more
than half the tolerance off the chord of its ends, on the surface or on the pitch curve,
until none does. Half, because the deepest point of a short arc that is not symmetric
about the midpoint can sit a little off it; with the halved test the chordal deviation
of the polyline stays below ``tolerance`` (tests/cam/test_profile.py checks it against
the closed-form surface).

Coordinates are in the cam frame of :mod:`camsim.cam.geometry` (origin at the cam
centre, θ = 0 of the program at the top); a flat-faced follower has no separate pitch
curve, so both curves are the surface.
"""

from __future__ import annotations

import math
import os
from pathlib import Path

import numpy as np

from camsim.cam.geometry import CamGeometry, pitch_curve, roller_side_motion, surface_points
from camsim.errors import InputError
from camsim.io.outputs import writing

__all__ = ["UNITS", "profile_points", "write_profile_csv", "write_profile_dxf"]

#: Output units: name → (metres per unit, DXF $INSUNITS code, DXF $MEASUREMENT).
UNITS = {"mm": (1e-3, 4, 1), "in": (0.0254, 1, 0)}
#: Refuse to produce more points than this (a tolerance far too fine for the cam).
MAX_POINTS = 2_000_000
#: DXF layer names.
LAYERS = {
    "surface": "CAM_PROFILE",
    "pitch": "CAM_PITCH_CURVE",
    "base": "CAM_BASE_CIRCLE",
    "centre": "CAM_CENTRE",
}


def _curves(geometry: CamGeometry, program, theta: np.ndarray):
    s, s1, _, _ = roller_side_motion(program, theta)
    return surface_points(geometry, theta, s, s1), pitch_curve(geometry, theta, s, s1)


def _deviation(a: np.ndarray, b: np.ndarray, m: np.ndarray) -> np.ndarray:
    """Distance of points m from the chords a–b (all (N, 2))."""
    chord = b - a
    length = np.hypot(chord[:, 0], chord[:, 1])
    rel = m - a
    cross = np.abs(chord[:, 0] * rel[:, 1] - chord[:, 1] * rel[:, 0])
    with np.errstate(divide="ignore", invalid="ignore"):
        d = np.where(length > 0, cross / length, np.hypot(rel[:, 0], rel[:, 1]))
    return d


def profile_points(geometry: CamGeometry, program, tolerance: float = 1e-6) -> dict[str, np.ndarray]:
    """Sample the cam surface and pitch curve as closed contours at a chordal tolerance.

    Parameters
    ----------
    geometry : CamGeometry
    program : CamProgram
    tolerance : float
        Largest distance between the polyline and the true curve [m], > 0.

    Returns
    -------
    dict
        ``theta`` [rad] (N,), increasing from 0, the first point not repeated;
        ``surface`` and ``pitch`` (N, 2) [m] in the cam frame.

    Raises
    ------
    InputError
        For a non-positive tolerance, or one that would need more than
        :data:`MAX_POINTS` points.
    """
    if not (tolerance > 0 and math.isfinite(tolerance)):
        raise InputError(f"--tolerance: must be positive, got {tolerance:g} m")
    nodes = np.linspace(0.0, 2 * math.pi, 361)
    if program.kind == "segments":
        nodes = np.union1d(nodes, np.append(program.boundary_angles(), 2 * math.pi))
    surf, pitch = _curves(geometry, program, nodes)
    # the last node (2π) is the first point again: the contour is closed
    while True:
        mid = 0.5 * (nodes[:-1] + nodes[1:])
        ms, mp = _curves(geometry, program, mid)
        dev = np.maximum(_deviation(surf[:-1], surf[1:], ms), _deviation(pitch[:-1], pitch[1:], mp))
        split = dev > 0.5 * tolerance
        if not np.any(split):
            break
        if nodes.size + int(split.sum()) > MAX_POINTS:
            raise InputError(f"--tolerance {tolerance:g} m: needs more than {MAX_POINTS} points; use a coarser tolerance")
        order = np.argsort(np.concatenate([nodes, mid[split]]), kind="stable")
        nodes = np.concatenate([nodes, mid[split]])[order]
        surf = np.concatenate([surf, ms[split]])[order]
        pitch = np.concatenate([pitch, mp[split]])[order]
    return {"theta": nodes[:-1], "surface": surf[:-1], "pitch": pitch[:-1]}


def _unit(unit: str) -> float:
    if unit not in UNITS:
        raise InputError(f"--unit: unknown unit {unit!r}; use mm or in")
    return UNITS[unit][0]


def write_profile_csv(path: str | os.PathLike[str], points: dict[str, np.ndarray], unit: str = "mm") -> Path:
    """Write the contour as CSV: cam angle and x, y of the surface and of the pitch curve.

    Columns ``angle [deg],surface_x [<unit>],surface_y [<unit>],pitch_x [<unit>],pitch_y
    [<unit>]``, 12 significant digits; the last row repeats the first at 360° so the
    contour is closed. Written atomically.
    """
    scale = 1.0 / _unit(unit)
    theta = np.append(points["theta"], 2 * math.pi)
    surf = np.vstack([points["surface"], points["surface"][:1]]) * scale
    pitch = np.vstack([points["pitch"], points["pitch"][:1]]) * scale
    header = ",".join(["angle [deg]"] + [f"{c} [{unit}]" for c in ("surface_x", "surface_y", "pitch_x", "pitch_y")])
    data = np.column_stack([np.degrees(theta), surf, pitch]) + 0.0
    with writing(path, "csv", owner="csv", option="--profile") as target, target.text() as fh:
        np.savetxt(fh, data, fmt="%.12g", delimiter=",", header=header, comments="")
    return Path(path)


def write_profile_dxf(
    path: str | os.PathLike[str], points: dict[str, np.ndarray], geometry: CamGeometry, unit: str = "mm"
) -> Path:
    """Write the cam as a DXF drawing (R2010) through ezdxf.

    Layers: ``CAM_PROFILE`` (the surface, a closed LWPOLYLINE of the tolerance points),
    ``CAM_PITCH_CURVE`` (roller followers: the pitch curve, closed LWPOLYLINE),
    ``CAM_BASE_CIRCLE`` (circle of radius Rb), ``CAM_CENTRE`` (a POINT at the centre and a
    cross of two lines, Rb/5 long). ``$INSUNITS`` is 4 (mm) or 1 (in) and ``$MEASUREMENT``
    1 or 0. The metadata (dates, GUIDs) is fixed, so the same cam gives the same bytes.
    Written atomically.
    """
    import ezdxf

    scale = 1.0 / _unit(unit)
    _, insunits, measurement = UNITS[unit]
    previous = ezdxf.options.write_fixed_meta_data_for_testing
    ezdxf.options.write_fixed_meta_data_for_testing = True  # fixed dates, GUIDs: reproducible bytes
    try:
        return _write_dxf(ezdxf, path, points, geometry, scale, insunits, measurement)
    finally:
        ezdxf.options.write_fixed_meta_data_for_testing = previous


def _write_dxf(ezdxf, path, points, geometry, scale, insunits, measurement) -> Path:
    doc = ezdxf.new("R2010")
    doc.header["$INSUNITS"] = insunits
    doc.header["$MEASUREMENT"] = measurement
    for key, color in (("surface", 7), ("pitch", 3), ("base", 5), ("centre", 1)):
        doc.layers.add(LAYERS[key], color=color)
    msp = doc.modelspace()
    msp.add_lwpolyline((points["surface"] * scale).tolist(), close=True, dxfattribs={"layer": LAYERS["surface"]})
    if geometry.is_roller:
        msp.add_lwpolyline((points["pitch"] * scale).tolist(), close=True, dxfattribs={"layer": LAYERS["pitch"]})
    rb = geometry.base_radius * scale
    msp.add_circle((0.0, 0.0), rb, dxfattribs={"layer": LAYERS["base"]})
    msp.add_point((0.0, 0.0), dxfattribs={"layer": LAYERS["centre"]})
    arm = rb / 10.0
    msp.add_line((-arm, 0.0), (arm, 0.0), dxfattribs={"layer": LAYERS["centre"]})
    msp.add_line((0.0, -arm), (0.0, arm), dxfattribs={"layer": LAYERS["centre"]})
    with writing(path, "dxf", owner="dxf", option="--dxf") as target, target.text() as fh:
        doc.write(fh)
    return Path(path)

"""Profile export: chordal tolerance, closed contour, CSV and DXF against the closed-form surface.

Reference: the surface of a radial translating roller follower written out here by hand,
pitch point P(θ) = Rot(−θ)·(0, Rp + s) for a ccw cam and surface P − Rr·n, n the outward
unit normal of the pitch curve from its analytic derivative (Norton, *Design of Machinery*
§8.6), with s, s′ of a cycloidal rise and fall written out from the law formula.
Tolerances: vertices on the closed form to 1e-12 m (1 nm in the 12-digit CSV); the
polyline within the requested chordal tolerance of 200 000 closed-form points.
"""

from __future__ import annotations

import hashlib
import math

import ezdxf
import numpy as np
import pytest

from camsim.cam import CamProgram
from camsim.cam.profile import profile_points, write_profile_csv, write_profile_dxf
from camsim.machine.loader import load_machine_text

RB, RR, H, BETA = 0.040, 0.010, 0.015, math.radians(120)

MACHINE = """\
schema = 1
[machine]
name = "cycloidal rise-dwell-fall-dwell"
[cam]
speed = "100 rpm"
drives = "M1"
segments = [
  { motion = "rise",  law = "cycloidal", duration = "120 deg", lift = "15 mm" },
  { motion = "dwell", duration = "60 deg" },
  { motion = "fall",  law = "cycloidal", duration = "120 deg", lift = "15 mm" },
  { motion = "dwell", duration = "60 deg" },
]
[cam.geometry]
follower = "translating-roller"
base_radius = "40 mm"
roller_radius = "10 mm"
[[mass]]
name = "M1"
mass = "1 kg"
"""


def closed_form_surface(theta: np.ndarray) -> np.ndarray:
    """Surface points [m] of the test cam at cam angles θ [rad], by hand."""
    theta = np.mod(theta, 2 * math.pi)
    w = 2 * math.pi
    s = np.zeros_like(theta)
    s1 = np.zeros_like(theta)
    r = theta < BETA
    u = theta[r] / BETA
    s[r], s1[r] = H * (u - np.sin(w * u) / w), H / BETA * (1 - np.cos(w * u))
    s[(theta >= BETA) & (theta < BETA + math.pi / 3)] = H
    f = (theta >= BETA + math.pi / 3) & (theta < 2 * BETA + math.pi / 3)
    u = (theta[f] - BETA - math.pi / 3) / BETA
    s[f], s1[f] = H - H * (u - np.sin(w * u) / w), -H / BETA * (1 - np.cos(w * u))
    r_ = RB + RR + s
    # P(θ) = r·(sin θ, cos θ) (ccw cam: Rot(−θ)·(0, r)); P′ = s′·(sin, cos) + r·(cos, −sin)
    px, py = r_ * np.sin(theta), r_ * np.cos(theta)
    dx, dy = s1 * np.sin(theta) + r_ * np.cos(theta), s1 * np.cos(theta) - r_ * np.sin(theta)
    norm = np.hypot(dx, dy)
    nx, ny = -dy / norm, dx / norm  # P′ turned by +90°: outward for a clockwise-running curve
    return np.stack([px - RR * nx, py - RR * ny], axis=-1)


@pytest.fixture(scope="module")
def cam():
    machine = load_machine_text(MACHINE)
    return machine.cam.geometry, CamProgram(machine.cam)


def _polyline_deviation(vertices: np.ndarray, theta_v: np.ndarray, dense_theta: np.ndarray) -> float:
    """Largest distance of closed-form points from the polyline's chord over their angle."""
    dense = closed_form_surface(dense_theta)
    closed_v = np.vstack([vertices, vertices[:1]])
    closed_t = np.append(theta_v, 2 * math.pi)
    k = np.searchsorted(closed_t, dense_theta, side="right") - 1
    a, b = closed_v[k], closed_v[k + 1]
    chord = b - a
    rel = dense - a
    return float(np.max(np.abs(chord[:, 0] * rel[:, 1] - chord[:, 1] * rel[:, 0]) / np.hypot(chord[:, 0], chord[:, 1])))


@pytest.mark.parametrize("tolerance", [1e-6, 1e-5])
def test_points_on_closed_form_within_chordal_tolerance(cam, tolerance):
    geometry, program = cam
    pts = profile_points(geometry, program, tolerance)
    np.testing.assert_allclose(pts["surface"], closed_form_surface(pts["theta"]), rtol=0, atol=1e-12)
    dense_theta = np.linspace(0.0, 2 * math.pi, 200_000, endpoint=False)
    assert _polyline_deviation(pts["surface"], pts["theta"], dense_theta) <= tolerance
    # adaptive, not a fixed step: the points are denser where the surface bends more
    assert pts["theta"][0] == 0.0 and np.all(np.diff(pts["theta"]) > 0) and pts["theta"][-1] < 2 * math.pi
    steps = np.diff(pts["theta"])
    assert steps.max() > 2 * steps.min()


def test_csv_closed_contour_in_mm_and_inches(cam, tmp_path):
    geometry, program = cam
    pts = profile_points(geometry, program, 1e-6)
    for unit, scale in (("mm", 1e3), ("in", 1 / 0.0254)):
        path = tmp_path / f"cam_{unit}.csv"
        write_profile_csv(path, pts, unit)
        header = path.read_text().splitlines()[0]
        assert header == f"angle [deg],surface_x [{unit}],surface_y [{unit}],pitch_x [{unit}],pitch_y [{unit}]"
        data = np.loadtxt(path, delimiter=",", skiprows=1)
        assert data.shape == (pts["theta"].size + 1, 5)
        np.testing.assert_array_equal(data[-1, 1:], data[0, 1:])  # closed
        assert data[-1, 0] == 360.0
        expected = closed_form_surface(np.radians(data[:, 0])) * scale
        np.testing.assert_allclose(data[:, 1:3], expected, rtol=0, atol=1e-9 * scale)  # 1 nm
        pitch_r = np.hypot(data[:, 3], data[:, 4])
        assert pitch_r.min() == pytest.approx((RB + RR) * scale, rel=1e-11)


@pytest.mark.parametrize("unit,insunits", [("mm", 4), ("in", 1)])
def test_dxf_round_trip_against_closed_form(cam, tmp_path, unit, insunits):
    """Read the DXF back with ezdxf: closed profile on its layer, points on the closed form."""
    geometry, program = cam
    pts = profile_points(geometry, program, 1e-6)
    path = tmp_path / "cam.dxf"
    write_profile_dxf(path, pts, geometry, unit)
    doc = ezdxf.readfile(path)
    assert doc.header["$INSUNITS"] == insunits
    scale = 1e3 if unit == "mm" else 1 / 0.0254
    msp = doc.modelspace()
    (profile,) = msp.query('LWPOLYLINE[layer=="CAM_PROFILE"]')
    assert profile.closed
    xy = np.array([(x, y) for x, y, *_ in profile.get_points()]) / scale
    np.testing.assert_allclose(xy, closed_form_surface(pts["theta"]), rtol=0, atol=1e-12)
    (pitch,) = msp.query('LWPOLYLINE[layer=="CAM_PITCH_CURVE"]')
    assert pitch.closed and len(pitch) == len(profile)
    (circle,) = msp.query('CIRCLE[layer=="CAM_BASE_CIRCLE"]')
    assert circle.dxf.radius == pytest.approx(RB * scale, rel=1e-12)
    assert tuple(circle.dxf.center)[:2] == (0.0, 0.0)
    assert len(msp.query('POINT[layer=="CAM_CENTRE"]')) == 1
    # the base circle touches the profile on the dwell at s = 0 (closed form: radius Rb)
    assert np.min(np.hypot(xy[:, 0], xy[:, 1])) == pytest.approx(RB, rel=1e-9)


def test_dxf_is_deterministic(cam, tmp_path):
    geometry, program = cam
    pts = profile_points(geometry, program, 1e-5)
    digests = []
    for name in ("a.dxf", "b.dxf"):
        write_profile_dxf(tmp_path / name, pts, geometry)
        digests.append(hashlib.sha256((tmp_path / name).read_bytes()).hexdigest())
    assert digests[0] == digests[1]

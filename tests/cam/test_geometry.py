"""Cam geometry against closed forms and an independent numerical construction.

References:
* translating roller, offset ε: Norton, *Design of Machinery* §8.6 / *Cam Design and
  Manufacturing Handbook* ch. 7-8, as written in spec §2: φ = atan((s′ − ε)/(s + d)),
  d = √(Rp² − ε²), and ρ = (y² + (s′ − ε)²)^{3/2} / (y² + (s′ − ε)(2s′ − ε) − y·s″),
  y = d + s; the motion s, s′, s″ of cycloidal and harmonic segments is written out
  here by hand from the law formulas (not taken from camsim's law code);
* translating flat face: ρ = Rb + s + s″ (Norton), and the envelope conditions of the
  face line;
* oscillating roller: the pitch curve built here from the arm's kinematics, its
  curvature and tangent by 6th-order central finite differences.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from camsim.cam import CamProgram
from camsim.cam import geometry as G
from camsim.machine.loader import load_machine_text

H = 0.020  # lift [m]
BETA = math.pi / 2  # every segment 90 deg

MACHINE = """\
schema = 1
[machine]
name = "cycloidal rise, harmonic fall"
[cam]
speed = "60 rpm"
drives = "M1"
segments = [
  {{ motion = "rise",  law = "cycloidal", duration = "90 deg", lift = "20 mm" }},
  {{ motion = "dwell", duration = "90 deg" }},
  {{ motion = "fall",  law = "harmonic", duration = "90 deg", lift = "20 mm" }},
  {{ motion = "dwell", duration = "90 deg" }},
]
[cam.geometry]
{geometry}
[[mass]]
name = "M1"
mass = "1 kg"
"""


def hand_motion(theta: np.ndarray):
    """s, s′, s″, s‴ of the test cam, written out from the law formulas [m, m/rad^k]."""
    s = np.zeros_like(theta)
    s1, s2, s3 = s.copy(), s.copy(), s.copy()
    rise = theta < BETA
    u = theta[rise] / BETA
    w = 2 * math.pi
    s[rise] = H * (u - np.sin(w * u) / w)
    s1[rise] = H / BETA * (1 - np.cos(w * u))
    s2[rise] = H / BETA**2 * w * np.sin(w * u)
    s3[rise] = H / BETA**3 * w * w * np.cos(w * u)
    top = (theta >= BETA) & (theta < 2 * BETA)
    s[top] = H
    fall = (theta >= 2 * BETA) & (theta < 3 * BETA)
    u = (theta[fall] - 2 * BETA) / BETA
    s[fall] = H * (1 + np.cos(math.pi * u)) / 2
    s1[fall] = -H / BETA * (math.pi / 2) * np.sin(math.pi * u)
    s2[fall] = -H / BETA**2 * (math.pi**2 / 2) * np.cos(math.pi * u)
    s3[fall] = H / BETA**3 * (math.pi**3 / 2) * np.sin(math.pi * u)
    return s, s1, s2, s3


def off_joins(n: int = 2001) -> np.ndarray:
    """Cam angles [rad] over a revolution, none on a segment join."""
    theta = np.linspace(0.0, 2 * math.pi, n, endpoint=False) + 1e-3
    joins = np.arange(5) * BETA
    keep = np.min(np.abs(theta[:, None] - joins[None, :]), axis=1) > 1e-6
    return theta[keep]


def load(geometry: str):
    machine = load_machine_text(MACHINE.format(geometry=geometry))
    return machine.cam.geometry, CamProgram(machine.cam)


@pytest.mark.parametrize("offset_mm", [0.0, 5.0, -3.0])
@pytest.mark.parametrize("rotation", ["ccw", "cw"])
def test_translating_roller_against_norton_closed_form(offset_mm, rotation):
    """φ and ρ of cycloidal and harmonic segments: closed forms (spec §2), 1e-6 deg / 1e-6 of peak."""
    geom, program = load(
        f'follower = "translating-roller"\nbase_radius = "40 mm"\nroller_radius = "10 mm"\n'
        f'offset = "{offset_mm} mm"\nrotation = "{rotation}"'
    )
    theta = off_joins()
    trace = G.evaluate_program(geom, program, theta)
    s, s1, s2, _ = hand_motion(theta)
    eps = offset_mm * 1e-3
    d = math.sqrt(0.05**2 - eps**2)
    y = d + s
    phi = np.degrees(np.arctan((s1 - eps) / y))
    rho = (y**2 + (s1 - eps) ** 2) ** 1.5 / (y**2 + (s1 - eps) * (2 * s1 - eps) - y * s2)
    np.testing.assert_allclose(np.degrees(trace.pressure_angle), phi, rtol=0, atol=1e-6)
    np.testing.assert_allclose(trace.pitch_radius, rho, rtol=0, atol=1e-6 * np.max(np.abs(rho)))
    np.testing.assert_allclose(trace.surface_radius, rho - 0.010, rtol=0, atol=1e-6 * np.max(np.abs(rho)))


def test_radial_roller_special_case():
    """ε = 0: ρ = ((Rp + s)² + s′²)^{3/2}/((Rp + s)² + 2s′² − (Rp + s)s″) (spec §2), 1e-6 of peak."""
    geom, program = load('follower = "translating-roller"\nbase_radius = "30 mm"\nroller_radius = "8 mm"')
    theta = off_joins()
    s, s1, s2, _ = hand_motion(theta)
    rp = 0.038
    rho = ((rp + s) ** 2 + s1**2) ** 1.5 / ((rp + s) ** 2 + 2 * s1**2 - (rp + s) * s2)
    got = G.pitch_radius(geom, s, s1, s2)
    np.testing.assert_allclose(got, rho, rtol=0, atol=1e-6 * np.max(np.abs(rho)))
    np.testing.assert_allclose(G.pressure_angle(geom, s, s1), np.arctan(s1 / (rp + s)), rtol=0, atol=1e-12)


@pytest.mark.parametrize("rotation", ["ccw", "cw"])
def test_flat_face_radius_and_envelope(rotation):
    """Flat face: ρ = Rb + s + s″ to 1e-9 m; surface points satisfy the envelope conditions."""
    geom, program = load(f'follower = "translating-flat"\nbase_radius = "60 mm"\nrotation = "{rotation}"')
    theta = off_joins()
    trace = G.evaluate_program(geom, program, theta)
    s, s1, s2, _ = hand_motion(theta)
    np.testing.assert_allclose(trace.surface_radius, 0.060 + s + s2, rtol=0, atol=1e-9)
    np.testing.assert_array_equal(trace.pressure_angle, 0.0)
    # Envelope of the face lines n(θ)·p = Rb + s, n(θ) the follower axis in the cam frame:
    # the point lies on the line and n′(θ)·p = s′ (tangency).
    sigma = 1.0 if rotation == "ccw" else -1.0
    n = np.stack([sigma * np.sin(theta), np.cos(theta)], axis=-1)  # Rot(−σθ)·(0, 1)
    dn = np.stack([sigma * np.cos(theta), -np.sin(theta)], axis=-1)
    np.testing.assert_allclose(np.sum(n * trace.surface, axis=1), 0.060 + s, rtol=0, atol=1e-12)
    np.testing.assert_allclose(np.sum(dn * trace.surface, axis=1), s1, rtol=0, atol=1e-12)


def _fd(f, x, h):
    """First and second derivatives by 6th-order central differences."""
    c1 = np.array([-1, 9, -45, 0, 45, -9, 1]) / 60.0
    c2 = np.array([2, -27, 270, -490, 270, -27, 2]) / 180.0
    vals = np.stack([f(x + k * h) for k in range(-3, 4)])
    d1 = np.tensordot(c1, vals, axes=1) / h
    d2 = np.tensordot(c2, vals, axes=1) / h**2
    return d1, d2


@pytest.mark.parametrize("rotation", ["ccw", "cw"])
def test_oscillating_roller_against_numerical_pitch_curve(rotation):
    """Oscillating roller: ρ and φ against finite differences of an independent pitch curve, 1e-6."""
    C, L, rb, rr = 0.120, 0.100, 0.040, 0.012
    geom, program = load(
        f'follower = "oscillating-roller"\nbase_radius = "{rb} m"\nroller_radius = "{rr} m"\n'
        f'pivot_distance = "{C} m"\narm_length = "{L} m"\nrotation = "{rotation}"'
    )
    sigma = 1.0 if rotation == "ccw" else -1.0
    rp = rb + rr
    psi0 = math.acos((C * C + L * L - rp * rp) / (2 * C * L))

    def roller_ground(theta):
        psi = psi0 + hand_motion(theta)[0] / L
        return np.stack([C - L * np.cos(psi), L * np.sin(psi)], axis=-1), psi

    def pitch(theta):
        R, _ = roller_ground(theta)
        c, s = np.cos(sigma * theta), np.sin(sigma * theta)
        return np.stack([c * R[:, 0] + s * R[:, 1], -s * R[:, 0] + c * R[:, 1]], axis=-1)

    theta = off_joins(1201)
    h = 1e-3
    joins = np.arange(5) * BETA
    theta = theta[np.min(np.abs(theta[:, None] - joins[None, :]), axis=1) > 4 * h]
    d1, d2 = _fd(pitch, theta, h)
    cross = d1[:, 0] * d2[:, 1] - d1[:, 1] * d2[:, 0]
    speed = np.hypot(d1[:, 0], d1[:, 1])
    rho_fd = -sigma * speed**3 / cross  # a ccw cam's pitch curve runs clockwise: convex ⇔ cross < 0
    trace = G.evaluate_program(geom, program, theta)
    scale = np.max(np.abs(rho_fd))
    np.testing.assert_allclose(trace.pitch_radius, rho_fd, rtol=0, atol=1e-6 * scale)
    # pressure angle: sin φ = (unit tangent)·(roller's direction of motion), both in the cam frame
    _, psi = roller_ground(theta)
    e = np.stack([np.sin(psi), np.cos(psi)], axis=-1)
    c, s = np.cos(sigma * theta), np.sin(sigma * theta)
    e_cam = np.stack([c * e[:, 0] + s * e[:, 1], -s * e[:, 0] + c * e[:, 1]], axis=-1)
    sin_phi = np.sum(d1 * e_cam, axis=1) / speed
    np.testing.assert_allclose(np.sin(trace.pressure_angle), sin_phi, rtol=0, atol=1e-6)
    # the pitch curve is the same curve up to the frame turn γ (docs: roller at s = 0 above O)
    _, gamma = G.arm_setup(geom)
    turned = pitch(theta) @ np.array([[math.cos(gamma), -math.sin(gamma)], [math.sin(gamma), math.cos(gamma)]]).T
    np.testing.assert_allclose(trace.pitch_curve, turned, rtol=0, atol=1e-12)


@pytest.mark.parametrize("follower", ["translating-roller", "oscillating-roller"])
def test_surface_is_roller_radius_along_the_normal(follower):
    """Surface points lie exactly Rr from the pitch curve along its (finite-difference) normal."""
    extra = 'offset = "4 mm"' if follower == "translating-roller" else 'pivot_distance = "120 mm"\narm_length = "100 mm"'
    geom, program = load(f'follower = "{follower}"\nbase_radius = "40 mm"\nroller_radius = "12 mm"\n{extra}')
    theta = off_joins(801)
    trace = G.evaluate_program(geom, program, theta)
    gap = trace.pitch_curve - trace.surface
    np.testing.assert_allclose(np.hypot(gap[:, 0], gap[:, 1]), 0.012, rtol=0, atol=1e-12)

    def pitch(t):
        s, s1, _, _ = program.lift(t)
        return G.pitch_curve(geom, t, s, s1)

    d1, _ = _fd(pitch, theta, 1e-4)
    tangent = d1 / np.hypot(d1[:, 0], d1[:, 1])[:, None]
    assert np.max(np.abs(np.sum(tangent * gap, axis=1))) < 1e-9  # along the normal: ⟂ to the tangent
    # inward: the surface is nearer the cam centre than the pitch curve on the base circle
    assert np.hypot(*trace.surface[-1]) < np.hypot(*trace.pitch_curve[-1])


STEEP = """\
schema = 1
[machine]
name = "steep cycloidal double dwell"
[cam]
speed = "60 rpm"
drives = "M1"
segments = [
  { motion = "rise",  law = "cycloidal", duration = "45 deg", lift = "30 mm" },
  { motion = "dwell", duration = "135 deg" },
  { motion = "fall",  law = "cycloidal", duration = "45 deg", lift = "30 mm" },
  { motion = "dwell", duration = "135 deg" },
]
[[mass]]
name = "M1"
mass = "1 kg"
"""


def _steep_motion(theta):
    """s, s′, s″ of STEEP written out by hand (cycloidal, h = 30 mm, β = 45°)."""
    h, beta, w = 0.030, math.pi / 4, 2 * math.pi
    s, s1, s2 = (np.zeros_like(theta) for _ in range(3))
    for start, sign, base in ((0.0, 1.0, 0.0), (math.pi, -1.0, h)):
        m = (theta >= start) & (theta < start + beta)
        u = (theta[m] - start) / beta
        s[m] = base + sign * h * (u - np.sin(w * u) / w)
        s1[m] = sign * h / beta * (1 - np.cos(w * u))
        s2[m] = sign * h / beta**2 * w * np.sin(w * u)
    s[(theta >= math.pi / 4) & (theta < math.pi)] = h
    return s, s1, s2


@pytest.mark.parametrize("follower", ["translating-roller", "translating-flat"])
def test_defects_named_by_angle(follower):
    """Undercut (convex pitch ρ ≤ Rr) and cusp (Rb + s + s″ ≤ 0) at the hand-computed angles, ±0.2°."""
    program = CamProgram(load_machine_text(STEEP).cam)
    theta = np.linspace(0.0, 2 * math.pi, 72001)
    s, s1, s2 = _steep_motion(theta)
    if follower == "translating-roller":
        rb, rr = 0.020, 0.015
        geom = G.CamGeometry(follower, base_radius=rb, roller_radius=rr)
        y = rb + rr + s
        rho = (y**2 + s1**2) ** 1.5 / (y**2 + 2 * s1**2 - y * s2)
        bad = (rho > 0) & (rho <= rr)
    else:
        geom = G.CamGeometry(follower, base_radius=0.030)
        bad = (0.030 + s + s2) <= 0
    defects = G.geometry_summary(geom, program)["defects"]
    deg = np.degrees(theta)
    runs = np.split(np.flatnonzero(bad), np.flatnonzero(np.diff(np.flatnonzero(bad)) > 1) + 1)
    assert len(defects) == len(runs) == 2
    for d, run in zip(defects, runs):
        assert d.kind == ("undercut" if follower == "translating-roller" else "cusp")
        assert abs(d.start_deg - deg[run[0]]) < 0.2 and abs(d.end_deg - deg[run[-1]]) < 0.2
        assert "cam angles" in d.describe(geom)


def test_summary_extremes_refined():
    """Largest |φ| of the radial cycloidal rise: Brent-refined against a 1e6-point scan, 1e-9 deg."""
    geom, program = load('follower = "translating-roller"\nbase_radius = "40 mm"\nroller_radius = "10 mm"')
    summary = G.geometry_summary(geom, program)
    theta = np.linspace(0.0, 2 * math.pi, 1_000_001)
    s, s1, _, _ = hand_motion(theta)
    phi = np.degrees(np.arctan(np.abs(s1) / (0.05 + s)))
    assert summary["max_pressure_angle"] == pytest.approx(phi.max(), abs=1e-7)
    assert summary["max_pressure_angle_at"] == pytest.approx(math.degrees(theta[np.argmax(phi)]), abs=1e-3)


def test_face_width_from_the_range_of_s1():
    """Flat face: contact from min(s′) − ε to max(s′) − ε; cycloidal 2h/β, harmonic πh/(2β)."""
    geom, program = load('follower = "translating-flat"\nbase_radius = "60 mm"\noffset = "2 mm"')
    summary = G.geometry_summary(geom, program)
    assert summary["face_max_contact"] == pytest.approx(2 * H / BETA - 0.002, abs=1e-9)
    assert summary["face_min_contact"] == pytest.approx(-math.pi * H / (2 * BETA) - 0.002, abs=1e-9)
    assert summary["face_width"] == pytest.approx(2 * H / BETA + math.pi * H / (2 * BETA), abs=1e-9)


def test_table_cam_through_its_spline(tmp_path):
    """A table cam: geometry from the periodic spline. Table of s = h(1 − cos θ)/2 at 1° steps;
    against the closed form of that s (spec §2 formulas), 1e-6 deg and 1e-6 of the peak ρ
    (the quintic spline's interpolation error at 1° is ~1e-10 of h)."""
    from camsim.machine.loader import load_machine

    h = 0.012
    deg = np.arange(360.0)
    rows = "\n".join(f"{a:g},{1e3 * h * (1 - math.cos(math.radians(a))) / 2:.15g}" for a in deg)
    (tmp_path / "cam.csv").write_text("angle [deg],displacement [mm]\n" + rows + "\n")
    text = MACHINE.format(geometry='follower = "translating-roller"\nbase_radius = "30 mm"\nroller_radius = "6 mm"\n'
                                   'offset = "2 mm"')
    start, end = text.index("segments = ["), text.index("]\n[cam.geometry]") + 2
    text = text[:start] + 'table = "cam.csv"\n' + text[end:]
    (tmp_path / "m.toml").write_text(text)
    machine = load_machine(tmp_path / "m.toml")
    program = CamProgram(machine.cam)
    theta = np.linspace(0.0, 2 * math.pi, 1000, endpoint=False)
    trace = G.evaluate_program(machine.cam.geometry, program, theta)
    s, s1, s2 = h * (1 - np.cos(theta)) / 2, h * np.sin(theta) / 2, h * np.cos(theta) / 2
    eps, d = 0.002, math.sqrt(0.036**2 - 0.002**2)
    y = d + s
    rho = (y**2 + (s1 - eps) ** 2) ** 1.5 / (y**2 + (s1 - eps) * (2 * s1 - eps) - y * s2)
    np.testing.assert_allclose(np.degrees(trace.pressure_angle), np.degrees(np.arctan((s1 - eps) / y)), rtol=0, atol=1e-6)
    np.testing.assert_allclose(trace.pitch_radius, rho, rtol=0, atol=1e-6 * np.max(np.abs(rho)))

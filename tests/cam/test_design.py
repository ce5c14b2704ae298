"""Dynamic design quantities against independent constructions.

References:
* camshaft torque: the moment about the cam centre of the contact normal force, built
  here from the offset roller's closed-form geometry (Norton, *Design of Machinery* §8.6:
  φ = atan((s′ − ε)/(s + d)), the normal through the roller centre), against camsim's
  power balance T = Fc·ṡ/ω — to 1e-9 of the peak;
* a conservative machine (a driven mass on an undamped preloaded spring): the work per
  revolution is zero, and the energy fluctuation is the swing of ½mv² + P·s + ½ks²
  (exact mechanical energy; Norton §11.11's ΔE with T_avg = 0) — 1e-9 and 1e-6;
* Hertz line contact in Norton's half-width form (*Machine Design*, §7.10:
  a = √(2F/(πL)·(m1 + m2)/B), B = ½(1/R1 + 1/R2), m = (1 − ν²)/E, p_max = 2F/(πaL)) —
  1e-9 relative.
The cam motion s, s′, s″ is written out from the cycloidal law, not taken from camsim.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from camsim.cam.design import design_summary, design_traces, flywheel_inertia
from camsim.machine.loader import load_machine_text
from camsim import simulate  # the public API (not the submodule: see tests/test_api.py)

H, RATIO, M, K, P = 0.020, 0.5, 2.0, 3000.0, 40.0
RB, RR, EPS, WIDTH = 0.040, 0.012, 0.004, 0.008
E1, NU1, E2, NU2 = 206.8e9, 0.28, 110e9, 0.33

MACHINE = """\
schema = 1
[machine]
name = "driven follower on an undamped spring"
[cam]
speed = "60 rpm"
ratio = {ratio}
drives = "M1"
segments = [
  {{ motion = "rise", law = "cycloidal", duration = "180 deg", lift = "20 mm" }},
  {{ motion = "fall", law = "cycloidal", duration = "180 deg", lift = "20 mm" }},
]
[cam.geometry]
{geometry}
width = "8 mm"
follower_material = {{ youngs_modulus = "110 GPa", poisson_ratio = 0.33 }}
[[mass]]
name = "M1"
mass = "{m} kg"
[[element]]
name = "spring"
type = "spring"
between = ["ground", "M1"]
stiffness = "{k} N/m"
preload = "{p} N"
[simulation]
cycles = 1
warmup_cycles = 0
sample_rate = "10 kHz"
"""

ROLLER = f'follower = "translating-roller"\nbase_radius = "{RB} m"\nroller_radius = "{RR} m"\noffset = "{EPS} m"'
FLAT = f'follower = "translating-flat"\nbase_radius = "{RB} m"'


def run(geometry: str):
    machine = load_machine_text(MACHINE.format(ratio=RATIO, geometry=geometry, m=M, k=K, p=P))
    return simulate(machine)


def hand_motion(theta):
    """Roller s, s′, s″ [m, m/rad, m/rad²] of the rise-fall cycloidal cam."""
    theta = np.mod(theta, 2 * math.pi)
    beta, w = math.pi, 2 * math.pi
    rise = theta < beta
    u = np.where(rise, theta, theta - beta) / beta
    sign = np.where(rise, 1.0, -1.0)
    base = np.where(rise, 0.0, H)
    s = base + sign * H * (u - np.sin(w * u) / w)
    s1 = sign * H / beta * (1 - np.cos(w * u))
    s2 = sign * H / beta**2 * w * np.sin(w * u)
    return s, s1, s2


@pytest.fixture(scope="module")
def roller_run():
    return run(ROLLER)


def test_torque_is_the_moment_of_the_normal_force(roller_run):
    result = roller_run
    traces = design_traces(result)
    theta = np.radians(result.cam["angle"])
    s, s1, _ = hand_motion(theta)
    fc = result.cam_contact_force
    torque = traces["camshaft/torque"][0]
    omega = 2 * math.pi
    # power balance, as the spec states it
    np.testing.assert_allclose(torque * omega, fc * result.cam["velocity"], rtol=0, atol=1e-9 * np.max(np.abs(torque)))
    # moment about the cam centre of the normal force through the roller centre (ccw cam)
    d = math.sqrt((RB + RR) ** 2 - EPS**2)
    R = np.stack([np.full_like(s, EPS), d + s], axis=-1)
    q = np.stack([d + s, s1 - EPS], axis=-1)
    n = np.stack([-(s1 - EPS), d + s], axis=-1) / np.hypot(q[:, 0], q[:, 1])[:, None]
    phi = np.arctan((s1 - EPS) / (d + s))
    fn = RATIO * fc / np.cos(phi)
    moment = fn * (R[:, 0] * n[:, 1] - R[:, 1] * n[:, 0])
    np.testing.assert_allclose(torque, moment, rtol=0, atol=1e-9 * np.max(np.abs(torque)))
    np.testing.assert_allclose(traces["cam_contact/normal_force"][0], fn, rtol=1e-12, atol=0)
    np.testing.assert_allclose(traces["cam_contact/side_load"][0], RATIO * fc * np.tan(phi), rtol=0,
                               atol=1e-12 * np.max(np.abs(fn)))
    assert traces["camshaft/torque"][1] == "N*m" and traces["cam/pressure_angle"][1] == "deg"
    # the run result (the hub) carries them, with their units
    np.testing.assert_array_equal(result.trace("camshaft/torque"), torque)
    assert result.units("camshaft/torque") == "N*m" and result.units("peak_hertz_stress") == "Pa"
    # the peak is located on the solution (spec §4): the samples' largest |T| is not above it
    # and within the sampling's reach of it
    peak = result.scalars()["peak_torque"]
    assert peak == result.extreme("camshaft/torque", "abs")[0]
    assert np.max(np.abs(torque)) <= peak == pytest.approx(np.max(np.abs(torque)), rel=1e-6)


def test_zero_net_work_and_energy_fluctuation_of_a_conservative_machine(roller_run):
    result = roller_run
    summary = design_summary(result, cs=0.05)
    assert result.time[-1] == pytest.approx(1.0)  # one revolution at 60 rpm, closed
    scale = 2 * math.pi * summary["peak_torque"]
    assert abs(summary["cycle_work"]) < 1e-9 * scale
    # ΔE: the swing of the follower's mechanical energy on the model axis (T_avg = 0)
    x, v = result.cam["displacement"], result.cam["velocity"]
    energy = 0.5 * M * v**2 + P * x + 0.5 * K * x**2
    assert summary["energy_fluctuation"] == pytest.approx(np.ptp(energy), rel=1e-6)
    assert summary["flywheel_inertia"] == pytest.approx(summary["energy_fluctuation"] / (0.05 * (2 * math.pi) ** 2), rel=1e-15)
    assert flywheel_inertia(10.0, 0.02, 100.0) == pytest.approx(10.0 / (0.02 * 1e4))
    torque = design_traces(result)["camshaft/torque"][0]
    assert summary["rms_torque"] == pytest.approx(math.sqrt(np.mean(torque**2)), rel=1e-12)
    assert summary["peak_torque"] == result.extreme("camshaft/torque", "abs")[0]  # located (spec §4)
    assert np.max(np.abs(torque)) <= summary["peak_torque"] == pytest.approx(np.max(np.abs(torque)), rel=1e-6)


def _norton_hertz(force, r1, r2):
    m1, m2 = (1 - NU1**2) / E1, (1 - NU2**2) / E2
    b = 0.5 * (1 / r1 + (0.0 if r2 is None else 1 / r2))
    a = np.sqrt(2 * force / (math.pi * WIDTH) * (m1 + m2) / b)
    return 2 * force / (math.pi * a * WIDTH)


def test_hertz_against_norton_line_contact(roller_run):
    result = roller_run
    stress = design_traces(result)["cam_contact/hertz_stress"][0]
    theta = np.radians(result.cam["angle"])
    s, s1, s2 = hand_motion(theta)
    y = math.sqrt((RB + RR) ** 2 - EPS**2) + s
    rho = (y**2 + (s1 - EPS) ** 2) ** 1.5 / (y**2 + (s1 - EPS) * (2 * s1 - EPS) - y * s2)
    fn = RATIO * result.cam_contact_force / np.cos(np.arctan((s1 - EPS) / y))
    expected = _norton_hertz(fn, rho - RR, RR)
    np.testing.assert_allclose(stress, expected, rtol=1e-9)
    summary = design_summary(result)
    assert summary["peak_hertz_stress"] == pytest.approx(np.max(expected), rel=1e-9)


def test_flat_face_hertz_and_no_side_load():
    result = run(FLAT)
    traces = design_traces(result)
    theta = np.radians(result.cam["angle"])
    s, _, s2 = hand_motion(theta)
    fn = RATIO * result.cam_contact_force  # φ = 0
    np.testing.assert_allclose(traces["cam_contact/normal_force"][0], fn, rtol=1e-15)
    np.testing.assert_array_equal(traces["cam_contact/side_load"][0], 0.0)
    np.testing.assert_allclose(traces["cam_contact/hertz_stress"][0], _norton_hertz(fn, RB + s + s2, None), rtol=1e-9)


def test_no_geometry_no_design():
    text = MACHINE.format(ratio=RATIO, geometry=ROLLER, m=M, k=K, p=P)
    start = text.index("[cam.geometry]")
    text = text[:start] + text[text.index("[[mass]]"):]
    result = simulate(load_machine_text(text))
    assert design_traces(result) == {}
    assert design_summary(result) is None
    assert "design" not in result.summary() and "peak_torque" not in result.scalars()


def _datasets(path):
    import h5py

    out = {}
    with h5py.File(path) as f:
        f.visititems(lambda name, obj: out.__setitem__(name, obj[()]) if isinstance(obj, h5py.Dataset) else None)
    return out


def test_geometry_changes_no_existing_trace(tmp_path):
    """Adding [cam.geometry] adds datasets and changes none of the others (bit for bit)."""
    from camsim.run.runfile import write_run

    with_geometry = MACHINE.format(ratio=RATIO, geometry=ROLLER, m=M, k=K, p=P)
    start = with_geometry.index("[cam.geometry]")
    without = with_geometry[:start] + with_geometry[with_geometry.index("[[mass]]"):]
    write_run(simulate(load_machine_text(with_geometry)), tmp_path / "a.h5")
    write_run(simulate(load_machine_text(without)), tmp_path / "b.h5")
    a, b = _datasets(tmp_path / "a.h5"), _datasets(tmp_path / "b.h5")
    added = set(a) - set(b)
    assert added == {"cam/pressure_angle", "cam/pitch_radius_of_curvature", "cam/surface_radius_of_curvature",
                     "cam/pitch_curve", "cam/surface", "cam_contact/normal_force", "cam_contact/side_load",
                     "cam_contact/hertz_stress", "camshaft/torque"}
    assert set(b) <= set(a)
    for name in b:
        if name == "extremes":  # geometry adds the camshaft torque's row; the others are the same
            def rows(table):
                return {r["quantity"]: tuple(float(r[c]).hex() for c in ("max", "max_time", "min", "min_time"))
                        for r in table}

            rows_a = rows(a[name])
            assert rows(b[name]).items() <= rows_a.items()
            assert set(rows_a) - {r["quantity"] for r in b[name]} == {b"camshaft/torque"}
            continue
        assert a[name].tobytes() == b[name].tobytes(), name


@pytest.mark.slow  # two runs of the thesis machine
def test_cdtm_geometry_has_the_traces_of_cdtm():
    """machines/cdtm-geometry.toml runs exactly like machines/cdtm.toml (its numbers are unchanged)."""
    from pathlib import Path

    from camsim.machine.loader import load_machine

    root = Path(__file__).resolve().parents[2] / "machines"
    a = simulate(load_machine(root / "cdtm-geometry.toml"), cycles=1, warmup_cycles=0, sample_rate=10_000.0)
    b = simulate(load_machine(root / "cdtm.toml"), cycles=1, warmup_cycles=0, sample_rate=10_000.0)
    for name in b.masses:
        for q in ("displacement", "velocity", "acceleration"):
            np.testing.assert_array_equal(a.masses[name][q], b.masses[name][q])
    for name in b.elements:
        np.testing.assert_array_equal(a.elements[name], b.elements[name])
    np.testing.assert_array_equal(a.cam_contact_force, b.cam_contact_force)
    assert design_summary(a)["defects"] == []

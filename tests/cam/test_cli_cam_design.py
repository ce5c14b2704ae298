"""``camsim cam``/``run``/``compare``/``sweep`` with ``[cam.geometry]``: outputs, warnings, bad input.

Bad input (undercut, cusp, missing or wrong keys, Rr ≥ Rb, zero width): exit 2, one line
naming the file and the key or the cam angles, and nothing written. The numbers behind
the outputs are checked against closed forms in test_geometry.py, test_profile.py and
test_design.py; here the expected pressure angle is the radial-roller closed form
φmax = max atan(s′/(Rp + s)) of a cycloidal rise (Norton), found by a dense scan.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import h5py
import numpy as np
import pytest
from typer.testing import CliRunner

from camsim.cli import app

ROOT = Path(__file__).resolve().parents[2]

MACHINE = """\
schema = 1
[machine]
name = "steep cycloidal double dwell"
[cam]
speed = "60 rpm"
drives = "M1"
segments = [
  {{ motion = "rise",  law = "cycloidal", duration = "45 deg", lift = "30 mm" }},
  {{ motion = "dwell", duration = "135 deg" }},
  {{ motion = "fall",  law = "cycloidal", duration = "45 deg", lift = "30 mm" }},
  {{ motion = "dwell", duration = "135 deg" }},
]
[cam.geometry]
{geometry}
[[mass]]
name = "M1"
mass = "1 kg"
[[element]]
name = "spring"
type = "spring"
between = ["ground", "M1"]
stiffness = "2000 N/m"
preload = "30 N"
[simulation]
cycles = 1
warmup_cycles = 0
sample_rate = "5 kHz"
"""

GOOD = 'follower = "translating-roller"\nbase_radius = "60 mm"\nroller_radius = "10 mm"\nwidth = "10 mm"'


def invoke(args):
    return CliRunner().invoke(app, [str(a) for a in args])


def write(tmp_path, geometry: str) -> Path:
    path = tmp_path / "m.toml"
    path.write_text(MACHINE.format(geometry=geometry))
    return path


def phi_max_closed_form(rp: float) -> float:
    """Largest |φ| [deg] of the cycloidal rise (h = 30 mm, β = 45°) on a radial roller, by scan."""
    h, beta = 0.030, math.pi / 4
    u = np.linspace(0.0, 1.0, 2_000_001)
    s = h * (u - np.sin(2 * math.pi * u) / (2 * math.pi))
    s1 = h / beta * (1 - np.cos(2 * math.pi * u))
    return float(np.degrees(np.max(np.arctan(s1 / (rp + s)))))


def test_cam_outputs(tmp_path):
    machine = write(tmp_path, GOOD)
    out, csv, dxf = tmp_path / "cam.h5", tmp_path / "p.csv", tmp_path / "p.dxf"
    r = invoke(["cam", machine, "-o", out, "--profile", csv, "--dxf", dxf, "--json", "--unit", "in",
                "--tolerance", "2um"])
    assert r.exit_code == 0, r.output
    payload = json.loads(r.stdout)
    geo = payload["geometry"]
    assert geo["max_pressure_angle"] == pytest.approx(phi_max_closed_form(0.070), abs=1e-6)
    assert geo["follower"] == "translating-roller" and geo["pressure_angle_limit"] == pytest.approx(30.0)
    assert 0 < geo["max_pressure_angle_at"] < 45
    with h5py.File(out) as f:
        assert f["cam/pressure_angle"].attrs["units"] == "deg"
        assert f["cam/surface"].shape == (3600, 2) and f["cam/surface"].attrs["units"] == "m"
        for name in ("pitch_radius_of_curvature", "surface_radius_of_curvature", "pitch_curve"):
            assert f[f"cam/{name}"].attrs["units"] == "m"
        assert np.max(np.abs(f["cam/pressure_angle"][()])) <= geo["max_pressure_angle"] + 1e-9
    assert csv.read_text().splitlines()[0].endswith("pitch_y [in]")
    assert dxf.stat().st_size > 0


@pytest.mark.slow  # matplotlib: a few seconds on a busy machine
def test_cam_plot(tmp_path):
    machine = write(tmp_path, GOOD)
    png = tmp_path / "cam.png"
    r = invoke(["cam", machine, "--plot", png])
    assert r.exit_code == 0, r.output
    assert png.read_bytes()[:4] == b"\x89PNG" and f"wrote {png}" in r.output


def test_pressure_angle_warning_and_set(tmp_path):
    machine = write(tmp_path, GOOD)
    r = invoke(["cam", machine, "--set", "cam.geometry.max_pressure_angle=10", "--set", "cam.geometry.base_radius=40mm"])
    assert r.exit_code == 0, r.output
    expected = phi_max_closed_form(0.050)
    assert "exceeds max_pressure_angle 10 deg" in r.output
    assert f"{expected:.4g}" in r.output


BAD = {
    "undercut": ('follower = "translating-roller"\nbase_radius = "20 mm"\nroller_radius = "15 mm"',
                 "cam.geometry: the follower cannot follow the cam: undercut at cam angles"),
    "cusp": ('follower = "translating-flat"\nbase_radius = "30 mm"', "cusp at cam angles"),
    "missing base_radius": ('follower = "translating-roller"\nroller_radius = "10 mm"',
                            "cam.geometry.base_radius: missing required key"),
    "missing follower": ('base_radius = "40 mm"', "cam.geometry.follower: missing required key"),
    "roller not smaller": ('follower = "translating-roller"\nbase_radius = "20 mm"\nroller_radius = "20 mm"',
                           "cam.geometry.roller_radius: must be smaller than base_radius"),
    "zero width": (GOOD.replace('"10 mm"\nwidth = "10 mm"', '"10 mm"\nwidth = "0 mm"'),
                   "cam.geometry.width: must be greater than 0"),
    "unknown key": ('follower = "translating-roller"\nbase_radus = "40 mm"', "did you mean 'base_radius'?"),
    "wrong dimension": ('follower = "translating-flat"\nbase_radius = "3 kg"', "cam.geometry.base_radius: expected [length]"),
    "no arm": ('follower = "oscillating-roller"\nbase_radius = "40 mm"\nroller_radius = "10 mm"\npivot_distance = "100 mm"',
               "cam.geometry.arm_length: missing required key"),
    "offset on an arm": ('follower = "oscillating-roller"\noffset = "1 mm"', 'cam.geometry.offset: not used by a follower'),
    "bad material": (GOOD + '\ncam_material = { youngs_modulus = "200 GPa", poisson = 0.3 }',
                     "cam.geometry.cam_material.poisson: unknown key"),
}


@pytest.mark.parametrize("case", sorted(BAD))
def test_bad_geometry_exit_2_nothing_written(tmp_path, case):
    geometry, message = BAD[case]
    machine = write(tmp_path, geometry)
    targets = [tmp_path / n for n in ("cam.h5", "p.csv", "p.dxf", "cam.png", "run.h5")]
    r = invoke(["cam", machine, "-o", targets[0], "--profile", targets[1], "--dxf", targets[2], "--plot", targets[3]])
    assert r.exit_code == 2, r.output
    assert message in r.output and str(machine) in r.output
    assert "Traceback" not in r.output and len(r.output.strip().splitlines()) == 1
    r = invoke(["run", machine, "-o", targets[4]])
    assert r.exit_code == 2 and message in r.output
    assert not any(t.exists() for t in targets)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["m.toml"]


def test_bad_override_key(tmp_path):
    machine = write(tmp_path, GOOD)
    r = invoke(["cam", machine, "--set", "cam.geometry.base_radiu=40mm"])
    assert r.exit_code == 2 and "did you mean 'base_radius'?" in r.output
    r = invoke(["cam", machine, "--set", "cam.geometry.base_radius=40kg"])
    assert r.exit_code == 2 and "cam.geometry.base_radius" in r.output and "--set" in r.output


@pytest.mark.parametrize("option,value,message", [
    ("--unit", "cm", "--unit: unknown unit 'cm'; use mm or in"),
    ("--tolerance", "0 um", "--tolerance: must be positive"),
    ("--tolerance", "1 kg", "--tolerance: expected [length]"),
])
def test_bad_export_options(tmp_path, option, value, message):
    machine = write(tmp_path, GOOD)
    r = invoke(["cam", machine, "--profile", tmp_path / "p.csv", option, value])
    assert r.exit_code == 2 and message in r.output
    assert not (tmp_path / "p.csv").exists()


def test_profile_needs_geometry(tmp_path):
    text = MACHINE.format(geometry="")
    text = text.replace("[cam.geometry]\n", "")
    machine = tmp_path / "m.toml"
    machine.write_text(text)
    r = invoke(["cam", machine, "--dxf", tmp_path / "c.dxf"])
    assert r.exit_code == 2 and "cam.geometry: --dxf needs" in r.output
    r = invoke(["run", machine, "--cs", "0.05", "-o", tmp_path / "r.h5"])
    assert r.exit_code == 2 and "--cs" in r.output
    assert sorted(p.name for p in tmp_path.iterdir()) == ["m.toml"]


def test_run_writes_design_traces_and_summary(tmp_path):
    machine = write(tmp_path, GOOD)
    out = tmp_path / "r.h5"
    r = invoke(["run", machine, "-o", out, "--cs", "0.05", "--json"])
    assert r.exit_code == 0, r.output
    design = json.loads(r.stdout)["design"]
    assert design["cs"] == 0.05 and design["flywheel_inertia"] > 0
    with h5py.File(out) as f:
        for path, units in (("cam_contact/normal_force", "N"), ("cam_contact/side_load", "N"),
                            ("cam_contact/hertz_stress", "Pa"), ("camshaft/torque", "N*m"),
                            ("cam/pressure_angle", "deg"), ("cam/pitch_curve", "m")):
            assert f[path].attrs["units"] == units
            assert f[path].shape[0] == f["time"].shape[0]
        assert design["peak_hertz_stress"] == pytest.approx(np.nanmax(f["cam_contact/hertz_stress"][()]))


@pytest.mark.slow  # matplotlib
def test_plot_design_of_a_run(tmp_path):
    machine = write(tmp_path, GOOD)
    out = tmp_path / "r.h5"
    assert invoke(["run", machine, "-o", out]).exit_code == 0
    r = invoke(["plot", out, "--what", "design", "-o", tmp_path / "plots"])
    assert r.exit_code == 0, r.output
    assert (tmp_path / "plots" / "r_cam_design.png").exists()


def test_compare_stress_and_torque_with_and_without_impact(tmp_path):
    """The Barkan follower jumps at 500 rpm: impacts change the torque (side by side)."""
    sets = ['cam.speed="500 rpm"', "cam.geometry.follower=translating-roller", "cam.geometry.base_radius=40mm",
            "cam.geometry.roller_radius=10mm", "cam.geometry.width=10mm"]
    args = ["compare", ROOT / "machines" / "barkan-follower.toml", "-o", tmp_path / "c.h5", "--json", "--cycles", "1"]
    for s in sets:
        args += ["--set", s]
    r = invoke(args)
    assert r.exit_code == 0, r.output
    rows = {row["quantity"]: row for row in json.loads(r.stdout)["design"]}
    assert set(rows) == {"peak_normal_force", "peak_hertz_stress", "peak_torque", "rms_torque", "energy_fluctuation"}
    assert rows["rms_torque"]["impact"] != rows["rms_torque"]["no_impact"]
    assert rows["rms_torque"]["change_percent"] == pytest.approx(
        100 * (rows["rms_torque"]["impact"] - rows["rms_torque"]["no_impact"]) / rows["rms_torque"]["no_impact"])


def test_sweep_base_radius_design_chart(tmp_path):
    from camsim.analyses.sweep.runner import run_sweep

    machine = write(tmp_path, GOOD)
    result = run_sweep(machine, vary=["cam.geometry.base_radius=40:60:10mm"], workers=1)
    assert [r["status"] for r in result.rows] == ["ok"] * 3
    np.testing.assert_allclose(result.column("param:cam.geometry.base_radius"), [0.04, 0.05, 0.06])
    assert dict(result.columns)["param:cam.geometry.base_radius"] == "m"
    phi = result.column("max_pressure_angle")
    expected = [phi_max_closed_form(rb + 0.010) for rb in (0.04, 0.05, 0.06)]
    np.testing.assert_allclose(phi, expected, atol=1e-6)
    assert np.all(np.diff(result.column("peak_hertz_stress")) < 0)

"""The ``camsim cam`` command: table, warnings, JSON, HDF5 and CSV output, errors."""

from __future__ import annotations

import hashlib
import json
import math

import h5py
import numpy as np
import pytest
from typer.testing import CliRunner

pytest.importorskip("camsim.machine.loader")

from camsim.cli import app  # noqa: E402

MACHINE = """\
schema = 1

[machine]
name = "harmonic double dwell"

[cam]
speed = "60 rpm"
ratio = 0.5
drives = "M1"
segments = [
  { motion = "rise",  law = "harmonic", duration = "90 deg", lift = "10 mm" },
  { motion = "dwell", duration = "90 deg" },
  { motion = "fall",  law = "cycloidal", duration = "90 deg", lift = "10 mm" },
  { motion = "dwell", duration = "90 deg" },
]

[[mass]]
name = "M1"
mass = "1 kg"
"""

# Hand computation: ω = 2π rad/s, β = π/2, ω/β = 4 1/s, h = 0.5 × 10 mm = 5 mm on the model
# axis. Harmonic: |v| = (π/2)·h·4 = 0.0314159 m/s, |a| = (π²/2)·h·16 = 0.394784 m/s².
# Cycloidal: |v| = 2·h·4 = 0.04 m/s, |a| = 2π·h·16 = 0.502655 m/s².


@pytest.fixture
def machine_file(tmp_path):
    path = tmp_path / "m.toml"
    path.write_text(MACHINE)
    return path


def run(*args):
    return CliRunner().invoke(app, ["cam", *map(str, args)])


def test_json_peaks_and_warnings(machine_file):
    result = run(machine_file, "--json")
    assert result.exit_code == 0, result.output
    payload = json.loads(result.stdout)
    rows = payload["segments"]
    assert [r["law"] for r in rows] == ["harmonic", None, "cycloidal", None]
    assert rows[0]["peak_velocity"] == pytest.approx(math.pi / 2 * 0.005 * 4, rel=1e-9)
    assert rows[0]["peak_acceleration"] == pytest.approx(math.pi**2 / 2 * 0.005 * 16, rel=1e-9)
    assert rows[2]["peak_velocity"] == pytest.approx(0.04, rel=1e-9)
    assert rows[2]["peak_acceleration"] == pytest.approx(2 * math.pi * 0.005 * 16, rel=1e-9)
    # The harmonic rise jumps in acceleration at both of its ends; the cycloid does not.
    assert len(payload["warnings"]) == 2
    assert "at 90 deg (segment 1 harmonic rise -> segment 2 dwell)" in payload["warnings"][0]
    assert "camsim: warning: acceleration jumps" in result.stderr


def test_table_on_stderr(machine_file):
    result = run(machine_file)
    assert result.exit_code == 0
    assert result.stdout == ""
    assert "rise harmonic" in result.stderr and "|a| [m/s²]" in result.stderr
    assert "0.3948" in result.stderr  # harmonic peak |a|, see the hand computation


def test_set_override(machine_file):
    """--set cam.speed doubles ω: peak |a| of the cycloid goes up 4×."""
    result = run(machine_file, "--json", "--set", "cam.speed=120 rpm")
    assert result.exit_code == 0, result.output
    rows = json.loads(result.stdout)["segments"]
    assert rows[2]["peak_acceleration"] == pytest.approx(4 * 2 * math.pi * 0.005 * 16, rel=1e-9)


def test_hdf5_output(machine_file, tmp_path):
    out = tmp_path / "svaj.h5"
    result = run(machine_file, "-o", out, "--points", 360)
    assert result.exit_code == 0, result.output
    with h5py.File(out, "r") as f:
        assert f.attrs["schema"] == 1 and f.attrs["units_system"] == "SI"
        assert f.attrs["machine_name"] == "harmonic double dwell"
        assert f.attrs["machine_toml"] == MACHINE
        assert f.attrs["machine_sha256"] == hashlib.sha256(MACHINE.encode()).hexdigest()
        t = f["time"][()]
        assert t.shape == (360,) and t[1] == pytest.approx(1.0 / 360, rel=1e-12)  # T = 1 s
        units = {name: f[f"cam/{name}"].attrs["units"] for name in ("angle", "displacement", "velocity", "acceleration", "jerk")}
        assert units == {"angle": "deg", "displacement": "m", "velocity": "m/s", "acceleration": "m/s^2", "jerk": "m/s^3"}
        assert f["cam/velocity"].dims[0][0] == f["time"]
        np.testing.assert_allclose(f["cam/angle"][()], np.arange(360.0), atol=1e-9)
        s = f["cam/displacement"][()]
        # At 45°, half way up the harmonic rise: s = h/2 = 2.5 mm.
        assert s[45] == pytest.approx(0.0025, rel=1e-12)
        np.testing.assert_allclose(f["cam/boundaries_deg"][()], [0, 90, 180, 270], atol=1e-9)


def test_csv_output(machine_file, tmp_path):
    out = tmp_path / "svaj.csv"
    result = run(machine_file, "-o", out, "--points", 36)
    assert result.exit_code == 0, result.output
    lines = out.read_text().splitlines()
    assert lines[0] == "time [s],angle [deg],displacement [m],velocity [m/s],acceleration [m/s^2],jerk [m/s^3]"
    data = np.loadtxt(out, delimiter=",", skiprows=1)
    assert data.shape == (36, 6)
    assert data[9, 2] == pytest.approx(0.005, rel=1e-11)  # 90°: top of the rise, h = 5 mm


def test_bad_output_type_and_no_cam(machine_file, tmp_path):
    out = tmp_path / "svaj.txt"
    result = run(machine_file, "-o", out)
    assert result.exit_code == 2
    assert "unknown output format '.txt'" in result.stderr
    assert not out.exists()
    no_cam = tmp_path / "nocam.toml"
    no_cam.write_text(
        'schema = 1\n[machine]\nname = "x"\n[[mass]]\nname = "M1"\nmass = "1 kg"\n'
        '[[element]]\nname = "K"\ntype = "spring"\nbetween = ["ground", "M1"]\nstiffness = "100 N/m"\n'
        '[simulation]\nduration = "1 s"\n'
    )
    result = run(no_cam, "-o", tmp_path / "x.h5")
    assert result.exit_code == 2
    assert "cam: the machine has no cam" in result.stderr
    assert not (tmp_path / "x.h5").exists()

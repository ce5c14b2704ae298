"""Tests of ``camsim validate`` (issue 2 item 3): exit codes, one-line errors, --json.

Expected values: figure 6.7 of the thesis converted by hand (1 lb = 0.45359237 kg);
relative tolerance 1e-6.
"""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest
from typer.testing import CliRunner

from camsim.cli import app

runner = CliRunner()
MACHINES = Path(__file__).resolve().parents[2] / "machines"


def _bad(args: list[str]) -> str:
    result = runner.invoke(app, ["validate", *args])
    assert result.exit_code == 2, (result.stdout, result.stderr)
    assert result.stdout == ""
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1, result.stderr
    assert "Traceback" not in result.stderr
    assert result.exception is None or isinstance(result.exception, SystemExit)
    return lines[0]


@pytest.mark.parametrize(
    "name", ["cdtm.toml", "cdtm-power.toml", "dynacam-2mass.toml", "barkan-follower.toml", "ball-drop.toml"]
)
def test_validate_shipped_machines_exit_0(name):
    result = runner.invoke(app, ["validate", str(MACHINES / name)])
    assert result.exit_code == 0, result.stderr
    assert result.stdout == ""  # human output goes to stderr
    assert "valid" in result.stderr


def test_validate_prints_damping_coefficients():
    result = runner.invoke(app, ["validate", str(MACHINES / "cdtm.toml")])
    assert "c_push" in result.stderr and "c_pull" in result.stderr
    assert "120 rpm" in result.stderr


def test_validate_json_only_json_on_stdout():
    result = runner.invoke(app, ["validate", str(MACHINES / "cdtm.toml"), "--json", "--set", "mass.M2.mass=2 kg"])
    assert result.exit_code == 0, result.stderr
    data = json.loads(result.stdout)
    masses = {m["name"]: m["mass"] for m in data["masses"]}
    assert masses["M1"] == pytest.approx(16.351 * 0.45359237, rel=1e-6)
    assert masses["M2"] == 2.0  # the override
    assert data["units"]["mass"] == "kg"


def test_validate_missing_file(tmp_path):
    line = _bad([str(tmp_path / "absent.toml")])
    assert line == f"camsim: error: {tmp_path / 'absent.toml'}: no such machine file"


def test_validate_bad_unit_one_line(tmp_path):
    text = (MACHINES / "cdtm.toml").read_text().replace('stiffness = "9051 lbf/in"', 'stiffness = "25 lbf"')
    path = tmp_path / "bad.toml"
    path.write_text(text)
    line = _bad([str(path)])
    assert line == f'camsim: error: {path}: element[1].stiffness: expected [force]/[length], got "25 lbf"'


def test_validate_invalid_toml(tmp_path):
    path = tmp_path / "bad.toml"
    path.write_text("schema = 1\n[machine\nname = 'x'\n")
    line = _bad([str(path)])
    assert "invalid TOML" in line and "line 2" in line


def test_validate_unknown_set_key():
    line = _bad([str(MACHINES / "cdtm.toml"), "--set", "element.seat.stifness=1e7"])
    assert "element.seat.stifness: unknown key; did you mean 'element.seat.stiffness'?" in line


def test_validate_real_process_no_traceback(tmp_path):
    """The installed entry point, as a user runs it: exit 2, one stderr line."""
    path = tmp_path / "neg.toml"
    path.write_text((MACHINES / "cdtm.toml").read_text().replace('mass = "0.3854 lb"', 'mass = "-0.3854 lb"'))
    proc = subprocess.run([sys.executable, "-m", "camsim", "validate", str(path)], capture_output=True, text=True)
    assert proc.returncode == 2
    assert proc.stdout == ""
    assert proc.stderr.strip().splitlines() == [
        f'camsim: error: {path}: mass[2].mass: must be greater than 0, got "-0.3854 lb"'
    ]

"""``camsim cam`` with synthesised segments and compensation (issue 27): output and bad input."""

from __future__ import annotations

import math

import h5py
import numpy as np
import pytest
from typer.testing import CliRunner

from camsim.cli import app

BASE = """\
schema = 1

[machine]
name = "polydyne"

[cam]
speed = "60 rpm"
segments = [
  {{ motion = "dwell", duration = "45 deg" }},
  {{ motion = "rise", law = "polynomial", continuity = {c}, duration = "90 deg", lift = "10 mm"{extra} }},
  {{ motion = "dwell", duration = "90 deg" }},
  {{ motion = "fall", law = "polynomial", continuity = {c}, duration = "90 deg", lift = "10 mm" }},
  {{ motion = "dwell", duration = "45 deg" }},
]

[cam.compensation]
output = "{output}"

[[mass]]
name = "M"
mass = "2 kg"

[[element]]
name = "K"
type = "{kind}"
between = ["cam", "M"]
{law}
"""
SPRING = 'stiffness = "2e4 N/m"'
POWER = 'law = "power"\ncoefficient = 1e9\nexponent = 1.5'


def write(tmp_path, c=4, extra="", output="M", kind="spring", law=SPRING):
    path = tmp_path / "m.toml"
    path.write_text(BASE.format(c=c, extra=extra, output=output, kind=kind, law=law))
    return path


def run(*args):
    return CliRunner().invoke(app, ["cam", *map(str, args)])


def test_output_program_written_and_both_tables(tmp_path):
    """Reference: the compensated cam of one undamped mass is s = y + (m/k)·ÿ (closed form);
    /cam/output_program holds y, v, a; /cam/displacement holds s. 1e-12 of the lift."""
    out = tmp_path / "cam.h5"
    result = run(write(tmp_path), "-o", out)
    assert result.exit_code == 0, result.output
    assert "wanted motion of M" in result.stderr and "compensated cam" in result.stderr
    with h5py.File(out) as f:
        y = f["cam/output_program/displacement"][:]
        a = f["cam/output_program/acceleration"][:]
        s = f["cam/displacement"][:]
        assert f["cam/output_program/velocity"].attrs["units"] == "m/s"
    assert np.max(np.abs(s - (y + 2.0 / 2e4 * a))) <= 1e-12 * 10e-3


@pytest.mark.parametrize("case, key", [
    (dict(c=3), "cam.segments[1]"),
    (dict(kind="contact", law=POWER), "element[0]"),
    (dict(output="Q"), "cam.compensation.output"),
    (dict(extra=', points = [{ at = "100 deg", s = "5 mm" }]'), "cam.segments[1].points[0].at"),
    (dict(extra=', points = [{ at = "40 deg", s = "5 mm" }, { at = "40.0000000001 deg", s = "5 mm", v = "1 m/s" }]'),
     "cam.segments[1]"),
])
def test_bad_input_exit_2_one_line_nothing_written(tmp_path, case, key):
    """Bad input: exit 2, one line on stderr naming the file and the key, nothing written."""
    out = tmp_path / "cam.h5"
    result = run(write(tmp_path, **case), "-o", out)
    assert result.exit_code == 2, result.output
    lines = [line for line in result.stderr.splitlines() if line.strip()]
    assert len(lines) == 1
    assert key in lines[0] and "m.toml" in lines[0]
    assert not out.exists()

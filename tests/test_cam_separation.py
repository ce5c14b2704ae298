"""Issue 26: ``cam_separation`` (largest gap between the follower and the cam [m]) and
``cam_separation_angle`` (largest cam-angle span off the cam [deg]) in RunResult.scalars().

Reference (closed form): a free follower of mass m resting on a cam under gravity g alone (it starts at rest on the base circle)
(no spring), with a rigid contact (e = 0). During the cycloidal rise it leaves the cam where
s̈(t) = −g (brentq on the cam law), then flies ballistically, x(t) = s_r + ṡ_r·τ − g·τ²/2,
until it lands on the following dwell. The gap is max(x − s) over the flight, the span
ω·(t_land − t_release). The rise's peak deceleration is 3 g and the (slower) fall's 0.48 g,
so the follower leaves the cam once per revolution. Tolerances: the gap within 1 % (samples
at 50 kHz), the span within 0.2 deg (event times are exact; the reference's landing time is
found on a 1 µs grid).
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.optimize import brentq

from camsim.cam import CamProgram
from camsim.machine.loader import load_machine_text
from camsim.run.simulation import simulate

G = 9.80665
MACHINE = """
schema = 1
[machine]
name = "follower thrown off a cam"
[cam]
speed = "220 rpm"
segments = [
  { motion = "rise",  law = "cycloidal", duration = "60 deg",  lift = "10 mm" },
  { motion = "dwell",                     duration = "120 deg" },
  { motion = "fall",  law = "cycloidal", duration = "150 deg", lift = "10 mm" },
  { motion = "dwell",                     duration = "30 deg" },
]
[[mass]]
name = "F"
mass = "0.5 kg"
[[element]]
name = "roller"
type = "contact"
between = ["cam", "F"]
law = "restitution"
restitution = 0.0
[initial.F]
displacement = "0 m"
velocity = "0 m/s"
[simulation]
gravity = true
cycles = 1
warmup_cycles = 0
sample_rate = "50 kHz"
"""


def _reference(machine) -> tuple[float, float]:
    program = CamProgram(machine.cam)
    beta = math.radians(60.0) / program.speed  # rise duration [s]

    def sdd(t):
        return program.svaj(np.array([t]))[2][0]

    t_r = brentq(lambda t: sdd(t) + G, beta / 2 + 1e-9, 0.75 * beta)  # s̈ falls to its minimum at 3/4 of the rise
    s_r, v_r = (float(q[0]) for q in program.svaj(np.array([t_r]))[:2])
    t = np.arange(t_r, program.period, 1e-6)
    x = s_r + v_r * (t - t_r) - 0.5 * G * (t - t_r) ** 2
    gap = x - program.svaj(t)[0]
    landed = np.flatnonzero(gap[10:] < 0)
    t_land = t[10 + landed[0]]
    assert t_land < math.radians(180.0) / program.speed  # lands on the dwell, before the fall
    return float(gap[: 10 + landed[0]].max()), math.degrees(program.speed * (t_land - t_r))


def test_cam_separation_matches_ballistic_flight():
    machine = load_machine_text(MACHINE)
    scalars = simulate(machine).scalars()
    gap, span = _reference(machine)
    assert scalars["jump"] is True
    assert scalars["cam_separation"] == pytest.approx(gap, rel=1e-2)
    assert scalars["cam_separation_angle"] == pytest.approx(span, abs=0.2)


def test_follower_on_the_cam_has_zero_separation():
    """Below the throw-off speed (peak deceleration 0.75 g) the follower never leaves: 0 and 0."""
    machine = load_machine_text(MACHINE, overrides=["cam.speed=110 rpm"])
    scalars = simulate(machine).scalars()
    assert scalars["jump"] is False
    assert scalars["cam_separation"] == pytest.approx(0.0, abs=1e-9)
    assert scalars["cam_separation_angle"] == 0.0


def test_driven_mass_has_no_separation_and_says_why():
    """A driven mass cannot leave the cam: NaN in scalars, a reason naming min_cam_contact_force."""
    from pathlib import Path

    from camsim.machine.loader import load_machine

    machine = load_machine(Path(__file__).resolve().parents[1] / "machines" / "dynacam-2mass.toml")
    result = simulate(machine, cycles=1, warmup_cycles=0, sample_rate=5000.0)
    assert math.isnan(result.scalars()["cam_separation"])
    assert "min_cam_contact_force" in result.missing_reasons()["cam_separation"]


def test_limit_that_cannot_fire_is_a_warning(tmp_path):
    """Issue 26: for a cam acting through a contact element, "min_cam_contact_force<0N"
    reported P = 0 while the follower jumped. Now a warning names cam_separation / jump."""
    from typer.testing import CliRunner

    from camsim.cli import app

    path = tmp_path / "m.toml"
    path.write_text(MACHINE)
    result = CliRunner().invoke(app, ["study", str(path), "--dist", "cam.speed=uniform:100:120rpm", "-n", "2",
                                      "--limit", "min_cam_contact_force<0N", "--workers", "1", "-o", str(tmp_path / "s.h5"),
                                      "--sample-rate", "5 kHz"])
    assert result.exit_code == 0, result.stderr
    warning = next(line for line in result.stderr.splitlines() if line.startswith("warning: min_cam_contact_force"))
    assert "cam_separation" in warning and "jump" in warning

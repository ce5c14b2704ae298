"""Issue 26: the cam design's energy quantities over exactly one revolution, at any speed.

Reference (closed form): a cam driving one mass m held by a spring k with preload F0 and no
damping needs the force Fc = m·s̈ + k·s + F0, so the camshaft's work from the start of the
revolution is E(θ) = ∫ Fc ds = ½ m ṡ² + ½ k s² + F0 s (the follower's energy): the work per
revolution is 0 and ΔE = max E − min E over the revolution, with s, ṡ of the cam law
(camsim.cam.CamProgram, the input of the run) on a fine grid. At 130 rpm with 20 kHz
samples the period (0.4615 s) is not a multiple of the sample spacing: before the fix the
last sample fell short of it and the three quantities printed "–".
Tolerances: |work| < 1e-4 of ΔE (the trapezoidal rule over 9230 samples); ΔE within 1e-4.
"""

from __future__ import annotations

import numpy as np
import pytest

from camsim.cam import CamProgram
from camsim.machine.loader import load_machine_text
from camsim.run.simulation import simulate

M, K, F0 = 2.0, 5000.0, 50.0
MACHINE = f"""
schema = 1
[machine]
name = "driven mass on a spring"
[cam]
speed = "130 rpm"
drives = "M1"
segments = [
  {{ motion = "rise", law = "cycloidal", duration = "120 deg", lift = "10 mm" }},
  {{ motion = "dwell", duration = "60 deg" }},
  {{ motion = "fall", law = "cycloidal", duration = "120 deg", lift = "10 mm" }},
  {{ motion = "dwell", duration = "60 deg" }},
]
[cam.geometry]
follower = "translating-roller"
roller_radius = "10 mm"
base_radius = "40 mm"
width = "10 mm"
[[mass]]
name = "M1"
mass = "{M} kg"
[[element]]
name = "K"
type = "spring"
between = ["ground", "M1"]
stiffness = "{K} N/m"
preload = "{F0} N"
[simulation]
cycles = 1
warmup_cycles = 0
sample_rate = "20 kHz"
"""


def _closed_form(machine) -> float:
    program = CamProgram(machine.cam)
    t = np.linspace(0.0, program.period, 400_001)
    s, sd, _, _ = program.svaj(t)
    energy = 0.5 * M * sd**2 + 0.5 * K * s**2 + F0 * s
    return float(energy.max() - energy.min())


@pytest.mark.parametrize("rpm", [130.0, 120.0])
def test_energy_over_exactly_one_revolution(rpm):
    machine = load_machine_text(MACHINE, overrides=[f"cam.speed={rpm} rpm"])
    design = simulate(machine).design_summary(cs=0.05)
    reference = _closed_form(machine)
    assert design["energy_fluctuation"] is not None, design.get("reasons")
    assert design["energy_fluctuation"] == pytest.approx(reference, rel=1e-4)
    assert abs(design["cycle_work"]) < 1e-4 * reference
    omega = rpm * 2 * np.pi / 60
    assert design["flywheel_inertia"] == pytest.approx(reference / (0.05 * omega**2), rel=1e-4)


def test_missing_energy_says_why():
    """Less than a revolution recorded: None with a reason, never a bare dash."""
    machine = load_machine_text(MACHINE.replace("cycles = 1\n", "duration = \"0.2 s\"\n"))
    design = simulate(machine).design_summary()
    assert design["cycle_work"] is None and "revolution" in design["reasons"]["cycle_work"]
    assert "--cs" in design["reasons"]["flywheel_inertia"]

"""The exponential collocation of a vibrating closed power-law contact (issue 12).

Reference: an independent solve_ivp (DOP853, rtol 1e-12, atol 1e-16 m) of the same
equation written out here — the pressed Hertz contact of tests/test_nonlinear_stepper.py
(1 kg under gravity on F = C·(−x)^1.5, C = 1e9 N/m^1.5, a spring-damper k = 1e4 N/m,
c = 20 N·s/m to a harmonic cam), started from its static equilibrium with a downward
velocity of 4 mm/s: the contact then rings at about 285 Hz with ±45 % of its static
penetration and stays closed, its tangent stiffness sweeping by a factor of ~2.5 every
period — the case where the iterated remainder does not converge and
:mod:`camsim.collocation` carries the phase. Tolerances: displacement 1e-9 of the static
penetration, contact force 1e-9 of its peak.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.optimize import brentq

import camsim.collocation as collocation
import camsim.nonlinear as nonlinear
from camsim.loader import load_machine_text
from camsim import simulate

M, G, C, K, CD, H, RPM, V0 = 1.0, 9.80665, 1.0e9, 1.0e4, 20.0, 0.5e-3, 600.0, -4.0e-3

TEXT = f"""
schema = 1
[machine]
name = "ringing Hertz contact"
[cam]
speed = "{RPM} rpm"
segments = [
  {{ motion = "rise", law = "harmonic", duration = "180 deg", lift = "{H} m" }},
  {{ motion = "fall", law = "harmonic", duration = "180 deg", lift = "{H} m" }},
]
[[mass]]
name = "M"
mass = "{M} kg"
[[element]]
name = "contact"
type = "contact"
between = ["ground", "M"]
law = "power"
coefficient = "{C} N/m**1.5"
exponent = 1.5
[[element]]
name = "press"
type = "spring"
between = ["cam", "M"]
stiffness = "{K} N/m"
damping = "{CD} N*s/m"
[initial.M]
velocity = "{V0} m/s"
[simulation]
gravity = true
cycles = 1
warmup_cycles = 0
sample_rate = "20 kHz"
"""


def reference(t):
    w = RPM * 2 * math.pi / 60

    def rhs(_t, y):
        x, v = y
        s = 0.5 * H * (1 - math.cos(w * _t))
        sd = 0.5 * H * w * math.sin(w * _t)
        f = C * max(-x, 0.0) ** 1.5
        return [v, (-M * G + f - K * (x - s) - CD * (v - sd)) / M]

    # static equilibrium at θ = 0 (s = 0): −m·g + C·(−x)^1.5 − k·x = 0
    x0 = brentq(lambda x: -M * G + C * (-x) ** 1.5 - K * x, -1e-4, -1e-9, xtol=1e-22, rtol=1e-15)
    sol = solve_ivp(rhs, (0, t[-1]), [x0, V0], method="DOP853", rtol=1e-12, atol=[1e-16, 1e-13], t_eval=t)
    return sol.y[0], C * np.maximum(-sol.y[0], 0) ** 1.5, x0


@pytest.mark.parametrize("block", [True, False], ids=["steps-together", "one-by-one"])
def test_collocation_against_independent_solver(block, monkeypatch):
    """Both ways of solving the collocation conditions: the steps of a call together (one
    Newton system) and step by step (the fall-back when that Newton does not converge)."""
    monkeypatch.setattr(collocation, "BLOCK", block)
    steps = {"n": 0}
    original = nonlinear.collocation_steps

    def counting(*args):
        out = original(*args)
        if out[2] is not None:
            steps["n"] += len(out[2][0]) - 1
        return out

    nonlinear.collocation_steps = counting
    try:
        result = simulate(load_machine_text(TEXT))
    finally:
        nonlinear.collocation_steps = original
    n_grid = result.time.size
    assert steps["n"] > 0.9 * n_grid, f"collocation carried {steps['n']} of {n_grid} steps"
    assert [e.kind for e in result.events] == []
    x_ref, f_ref, x0 = reference(result.time)
    assert np.min(f_ref) > 0.1 * M * G  # the contact never opens
    assert np.max(np.abs(result.masses["M"]["displacement"] - x_ref)) < 1e-9 * abs(x0)
    assert np.max(np.abs(result.elements["contact"] - f_ref)) < 1e-9 * np.max(f_ref)


def test_collocation_error_control_rejects_a_coarse_step():
    """The local error estimate is not blind: at a tolerance far below what one grid step
    of the polynomial can reach, no step is accepted (DOP853 carries the phase)."""
    text = TEXT.replace('sample_rate = "20 kHz"', 'sample_rate = "500 Hz"')
    steps = {"n": 0}
    original = nonlinear.collocation_steps

    def counting(*args):
        out = original(*args)
        if out[2] is not None:
            steps["n"] += len(out[2][0]) - 1
        return out

    nonlinear.collocation_steps = counting
    try:
        result = simulate(load_machine_text(text))
    finally:
        nonlinear.collocation_steps = original
    # a 2 ms step spans more than half a period of the ringing: the degree-5 polynomial
    # cannot carry it to 1e-11, so every step goes to DOP853 (rtol 1e-11, whose error
    # over the 28 periods of the revolution is ~1e-7 of the static penetration)
    assert steps["n"] == 0
    x_ref, _, x0 = reference(result.time)
    assert np.max(np.abs(result.masses["M"]["displacement"] - x_ref)) < 1e-6 * abs(x0)
    assert collocation.NODES == 5

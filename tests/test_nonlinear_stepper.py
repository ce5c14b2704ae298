"""The iterated-remainder stepper of closed power-law contacts (issue 12).

Reference: an independent solve_ivp (DOP853, rtol 1e-12, atol 1e-16 m) of the same
equation written out here — a 1 kg mass resting under gravity on a Hertz contact
F = C·(−x)^1.5 (C = 1e9 N/m^1.5, about 4.6 µm of static penetration), pressed and relieved
by a spring-damper (k = 1e4 N/m, c = 20 N·s/m) to a cam that moves s = h/2·(1 − cos ωt)
(harmonic rise then fall of h = 0.5 mm over one revolution at 600 rpm). The contact stays
closed for the whole revolution while its stiffness drifts by ~40 %: the phase the
stepper's windows carry. Tolerances: displacement 1e-9 of the static penetration, contact
force 1e-9 of the weight.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.integrate import solve_ivp

import camsim.integrate as integrate
import camsim.nonlinear as nonlinear
from camsim.loader import load_machine_text
from camsim import simulate

M, G, C, K, CD, H, RPM = 1.0, 9.80665, 1.0e9, 1.0e4, 20.0, 0.5e-3, 600.0

TEXT = f"""
schema = 1
[machine]
name = "pressed Hertz contact"
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

    from scipy.optimize import brentq

    # static equilibrium at θ = 0 (s = 0): −m·g + C·(−x)^1.5 − k·x = 0
    x0 = brentq(lambda x: -M * G + C * (-x) ** 1.5 - K * x, -1e-4, -1e-9, xtol=1e-22, rtol=1e-15)
    sol = solve_ivp(rhs, (0, t[-1]), [x0, 0.0], method="DOP853", rtol=1e-12, atol=[1e-16, 1e-13],
                    t_eval=t)
    return sol.y[0], C * np.maximum(-sol.y[0], 0) ** 1.5, x0


def test_stepper_against_independent_solver():
    calls = {"windows": 0}
    original = nonlinear._propagate

    def counting(*args):
        calls["windows"] += 1
        return original(*args)

    nonlinear._propagate = counting
    try:
        assert integrate.NONLINEAR_STEPPER
        result = simulate(load_machine_text(TEXT))
    finally:
        nonlinear._propagate = original
    assert calls["windows"] > 0, "the stepper's windows were not used"
    assert [e.kind for e in result.events] == []
    x_ref, f_ref, x0 = reference(result.time)
    assert np.max(np.abs(result.masses["M"]["displacement"] - x_ref)) < 1e-9 * abs(x0)
    assert np.max(np.abs(result.elements["contact"] - f_ref)) < 1e-9 * M * G

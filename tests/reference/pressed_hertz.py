"""The pressed Hertz contact of the power-law stepper and collocation tests (issue 12).

A 1 kg mass under gravity on a Hertz contact F = C·(−x)^1.5 (C = 1e9 N/m^1.5, about 4.6 µm
of static penetration), pressed and relieved by a spring-damper (k = 1e4 N/m, c = 20 N·s/m)
to a cam that moves s = h/2·(1 − cos ωt) (harmonic rise then fall of h = 0.5 mm over one
revolution at 600 rpm), started from its static equilibrium with a given velocity — as a
camsim machine file, and as the same equation written out here for an independent
solve_ivp (DOP853, rtol 1e-12, atol 1e-16 m).
"""

from __future__ import annotations

import math

import numpy as np
from scipy.integrate import solve_ivp
from scipy.optimize import brentq

M, G, C, K, CD, H, RPM = 1.0, 9.80665, 1.0e9, 1.0e4, 20.0, 0.5e-3, 600.0


def machine_text(name: str, v0: float = 0.0) -> str:
    """The machine file; ``v0`` [m/s] the mass's velocity at the start (0: at rest)."""
    initial = f'[initial.M]\nvelocity = "{v0} m/s"\n' if v0 else ""
    return f"""
schema = 1
[machine]
name = "{name}"
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
{initial}[simulation]
gravity = true
cycles = 1
warmup_cycles = 0
sample_rate = "20 kHz"
"""


def reference(t: np.ndarray, v0: float = 0.0) -> tuple[np.ndarray, np.ndarray, float]:
    """(x, contact force, static x) on the samples t, from the written-out equation."""
    w = RPM * 2 * math.pi / 60

    def rhs(_t, y):
        x, v = y
        s = 0.5 * H * (1 - math.cos(w * _t))
        sd = 0.5 * H * w * math.sin(w * _t)
        f = C * max(-x, 0.0) ** 1.5
        return [v, (-M * G + f - K * (x - s) - CD * (v - sd)) / M]

    # static equilibrium at θ = 0 (s = 0): −m·g + C·(−x)^1.5 − k·x = 0
    x0 = brentq(lambda x: -M * G + C * (-x) ** 1.5 - K * x, -1e-4, -1e-9, xtol=1e-22, rtol=1e-15)
    sol = solve_ivp(rhs, (0, t[-1]), [x0, v0], method="DOP853", rtol=1e-12, atol=[1e-16, 1e-13], t_eval=t)
    return sol.y[0], C * np.maximum(-sol.y[0], 0) ** 1.5, x0

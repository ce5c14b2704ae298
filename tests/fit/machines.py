"""Small machines for the fit tests, as TOML text with the closed forms they obey.

``DRIVEN``: one mass M driven by a harmonic cam, s(t) = (h/2)(1 − cos ωt) exactly (a
harmonic rise over 180° followed by a harmonic fall over 180° is that one cosine), with
an undamped spring K to ground. The cam contact force is (spec §3, tension-positive
element force f = P + k·s acting −f on M):

    Fc(t) = m·s̈ + P + k·s,   s̈ = (h/2) ω² cos ωt

so it is linear in the preload P and the stiffness k: least squares on it is ordinary
linear regression, with the closed-form answer of the normal equations.

``OSCILLATOR``: one free mass M on a spring K to the cam (same cam), damped by ζ; the
mass's acceleration depends non-linearly on k and ζ.
"""

from __future__ import annotations

import math

#: Driven machine: cam lift h [m], speed [rad/s], mass [kg], spring truth.
H = 0.01
OMEGA = 4.0 * math.pi  # 120 rpm
MASS = 2.0
K_TRUE = 5000.0  # [N/m]
P_TRUE = 40.0  # [N]
DRIVEN = f"""\
schema = 1

[machine]
name = "driven one-mass test machine"

[cam]
speed = "120 rpm"
drives = "M"
segments = [
  {{ motion = "rise", law = "harmonic", duration = "180 deg", lift = "{H * 1000:g} mm" }},
  {{ motion = "fall", law = "harmonic", duration = "180 deg", lift = "{H * 1000:g} mm" }},
]

[[mass]]
name = "M"
mass = "{MASS:g} kg"

[[element]]
name = "K"
type = "spring"
between = ["ground", "M"]
stiffness = "5 N/mm"     # the truth of the linear case
preload = "40 N"
damping = 0

[simulation]
cycles = 1
warmup_cycles = 0
sample_rate = "1 kHz"
"""

#: Oscillator: mass [kg], spring truth [N/m], damping ratio truth.
OSC_MASS = 0.5
OSC_K = 2.0e4
OSC_ZETA = 0.05
OSCILLATOR = f"""\
# A one-mass oscillator driven through a spring by a harmonic cam.
schema = 1

[machine]
name = "one-mass oscillator"

[cam]
speed = "600 rpm"   # 10 Hz; the natural frequency is ~32 Hz
segments = [
  {{ motion = "rise", law = "harmonic", duration = "180 deg", lift = "10 mm" }},
  {{ motion = "fall", law = "harmonic", duration = "180 deg", lift = "10 mm" }},
]

[[mass]]
name = "M"
mass = "{OSC_MASS:g} kg"

[[element]]
name = "K"
type = "spring"
between = ["cam", "M"]
stiffness = "20 N/mm"        # spring to the cam
damping_ratio = {OSC_ZETA!r}

[simulation]
cycles = 1
warmup_cycles = 2
sample_rate = "2 kHz"
"""

#: The same driven machine with lifts given as follower-arm angles: s = ratio · arm · angle.
PRODUCT = DRIVEN.replace('drives = "M"', 'drives = "M"\nratio = 0.5\narm = "100 mm"').replace(
    f'lift = "{H * 1000:g} mm"', 'lift = "11.459156 deg"'
)

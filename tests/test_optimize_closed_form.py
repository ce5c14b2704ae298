"""``camsim.optimize`` against closed forms (issue 28).

Each test names its reference and tolerance. The machines are small (one mass) and the
budgets small, so that the default suite stays cheap; the Pareto front is marked slow.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.optimize import brentq, minimize_scalar
from scipy.stats import norm

import camsim

# --------------------------------------------------------------------------------------
# A rigid force-closed follower on a harmonic double-dwell cam (Barkan)
# --------------------------------------------------------------------------------------
H = 0.010  # lift [m]
BETA = math.pi / 2  # rise and fall [rad]
MASS = 0.5  # [kg]
K = 2000.0  # closure spring [N/m]
RPM = 720.0
OMEGA = RPM * 2 * math.pi / 60

DRIVEN = f"""\
schema = 1
[machine]
name = "driven follower on a harmonic double-dwell cam"
[cam]
speed = "{RPM:g} rpm"
drives = "F"
segments = [
  {{ motion = "rise",  law = "harmonic", duration = "90 deg", lift = "10 mm" }},
  {{ motion = "dwell", duration = "90 deg" }},
  {{ motion = "fall",  law = "harmonic", duration = "90 deg", lift = "10 mm" }},
  {{ motion = "dwell", duration = "90 deg" }},
]
[[mass]]
name = "F"
mass = "0.5 kg"
[[element]]
name = "closure"
type = "spring"
between = ["ground", "F"]
stiffness = "2000 N/m"
preload = "20 N"
[simulation]
cycles = 1
warmup_cycles = 0
sample_rate = "4.8 kHz"   # 400 samples per revolution at 720 rpm: one at the end of the rise
"""


def _write(tmp_path, name, text):
    path = tmp_path / name
    path.write_text(text)
    return path


def _barkan_least_preload(margin: float) -> float:
    """P* = margin + m c − k h (derivation in test_minimum_closure_preload)."""
    c = OMEGA**2 * H / 2 * (math.pi / BETA) ** 2
    return margin + MASS * c - K * H


def test_minimum_closure_preload(tmp_path):
    """Least closure preload keeping the cam contact force ≥ 5 N, within 0.05 N of Barkan's closed form.

    Reference (Barkan 1953; Norton, *Cam Design and Manufacturing Handbook*, ch. 10): while a
    rigid follower of mass m rides the cam, the contact force is Fc(θ) = m ω² s''(θ) + P + k s(θ).
    For the harmonic rise s = h/2 (1 − cos πθ/β), s'' ω² = c cos(πθ/β) with
    c = ω² h/2 (π/β)², so Fc = P + k h/2 + (m c − k h/2) cos(πθ/β): when m c > k h/2 it is
    smallest at the end of the rise (cos = −1), min Fc = P + k h − m c; in the bottom dwell
    Fc = P. At 720 rpm (above the jump onset of the 20 N preload, about 604 rpm, where
    P + k h − m c = 0) the least P with min Fc ≥ margin is P* = margin + m c − k h
    (38.85 N for a 5 N margin), which also keeps Fc = P* ≥ margin in the dwell.
    """
    machine = _write(tmp_path, "driven.toml", DRIVEN)
    res = camsim.optimize(machine, ["element.closure.preload=0:100N"], minimize="param:element.closure.preload",
                          constraints=["min_cam_contact_force>=5N"], method="local", budget=40, workers=1)
    assert res.status == "optimal"
    assert res.values["element.closure.preload"] == pytest.approx(_barkan_least_preload(5.0), abs=0.05)
    assert res.active() == ["min_cam_contact_force>=5N"]


# --------------------------------------------------------------------------------------
# Zero residual vibration of a one-mass follower driven through a spring
# --------------------------------------------------------------------------------------
FN = 20.0  # natural frequency [Hz]
M1 = 1.0
K1 = (2 * math.pi * FN) ** 2 * M1
SPRING = f"""\
schema = 1
[machine]
name = "undamped one-mass follower driven through a spring"
[cam]
speed = "140 rpm"
segments = [
  {{ motion = "rise",  law = "cycloidal", duration = "90 deg", lift = "10 mm" }},
  {{ motion = "dwell", duration = "90 deg" }},
  {{ motion = "fall",  law = "cycloidal", duration = "90 deg", lift = "10 mm" }},
  {{ motion = "dwell", duration = "90 deg" }},
]
[[mass]]
name = "M"
mass = "{M1!r} kg"
[[element]]
name = "K"
type = "spring"
between = ["cam", "M"]
stiffness = "{K1!r} N/m"
[simulation]
cycles = 1
warmup_cycles = 0
sample_rate = "20 kHz"
"""


def test_zero_residual_vibration(tmp_path):
    """The cam speed with no residual vibration in the dwell after a cycloidal rise, to 1e-3 relative.

    Reference (Koster 1974; Norton, *Cam Design and Manufacturing Handbook*, §8): an undamped
    mass on a spring of natural period Tn, driven through the spring by a cycloidal rise of
    duration t_r from rest, is left with residual amplitude proportional to
    |sin(π τ)| / (τ (τ² − 1)), τ = t_r / Tn: zero at every whole τ ≥ 2. With β = 90° and
    fn = 20 Hz, τ = 2 at ω = β / (2 Tn) = π fn / 4 = 15.708 rad/s = 150 rpm. The speed
    bounds 130–175 rpm hold only this zero (τ from 2.31 to 1.71).
    """
    machine = _write(tmp_path, "spring.toml", SPRING)
    res = camsim.optimize(machine, ["cam.speed=130:175rpm"], minimize="rms:masses/M/acceleration@95:175deg",
                          method="local", budget=60, workers=1)
    expected = (math.pi / 2) / (2.0 / FN)  # rad/s
    assert res.values["cam.speed"] == pytest.approx(expected, rel=1e-3)


# --------------------------------------------------------------------------------------
# Minimum base radius under a pressure-angle limit
# --------------------------------------------------------------------------------------
RR = 0.010  # roller radius [m]
H3 = 0.020
BETA3 = math.radians(60.0)
GEOMETRY = f"""\
schema = 1
[machine]
name = "translating roller follower, cycloidal rise"
[cam]
speed = "60 rpm"
drives = "F"
segments = [
  {{ motion = "rise",  law = "cycloidal", duration = "60 deg", lift = "20 mm" }},
  {{ motion = "dwell", duration = "120 deg" }},
  {{ motion = "fall",  law = "cycloidal", duration = "60 deg", lift = "20 mm" }},
  {{ motion = "dwell", duration = "120 deg" }},
]
[cam.geometry]
follower = "translating-roller"
base_radius = "60 mm"
roller_radius = "10 mm"
[[mass]]
name = "F"
mass = "0.5 kg"
[[element]]
name = "closure"
type = "spring"
between = ["ground", "F"]
stiffness = "2000 N/m"
preload = "20 N"
[simulation]
cycles = 1
warmup_cycles = 0
sample_rate = "2 kHz"
"""


def _least_base_radius(limit_deg: float) -> float:
    """Rb* = max over the rise of s'/tan φ − s, minus the roller radius (test docstring)."""
    t = math.tan(math.radians(limit_deg))

    def need(u):  # prime-circle radius that puts the pressure angle exactly at the limit
        s = H3 * (u - math.sin(2 * math.pi * u) / (2 * math.pi))
        s1 = H3 / BETA3 * (1 - math.cos(2 * math.pi * u))
        return s1 / t - s

    u = np.linspace(0, 1, 20001)
    k = int(np.argmax([need(x) for x in u]))
    best = minimize_scalar(lambda x: -need(x), bounds=(u[max(k - 1, 0)], u[min(k + 1, len(u) - 1)]), method="bounded",
                           options={"xatol": 1e-12})
    return -best.fun - RR


def test_minimum_base_radius(tmp_path):
    """Least base radius with |pressure angle| ≤ 30°, within 0.01 mm of the closed form.

    Reference: the pressure angle of a translating roller follower without offset is
    tan φ = s'(θ) / (Rp + s(θ)) (Norton, *Cam Design and Manufacturing Handbook*, eq. 7.1;
    docs/cam-design.md), Rp = Rb + Rr the prime circle. |φ| ≤ φmax everywhere needs
    Rp ≥ max_θ (s'/tan φmax − s); for the cycloidal rise s = h (u − sin 2πu / 2π),
    s' = h/β (1 − cos 2πu), the maximum over u is found here with numpy and bounded Brent
    (xatol 1e-12), independently of camsim. The fall mirrors the rise.
    """
    machine = _write(tmp_path, "geometry.toml", GEOMETRY)
    res = camsim.optimize(machine, ["cam.geometry.base_radius=15:100mm"], minimize="param:cam.geometry.base_radius",
                          constraints=["max_pressure_angle<=30deg"], method="local", budget=60, workers=1)
    assert res.status == "optimal"
    assert res.values["cam.geometry.base_radius"] == pytest.approx(_least_base_radius(30.0), abs=1e-5)


# --------------------------------------------------------------------------------------
# Pareto front: throughput against peak acceleration
# --------------------------------------------------------------------------------------
CYCLOIDAL = """\
schema = 1
[machine]
name = "rigidly driven follower, cycloidal rise"
[cam]
speed = "120 rpm"
drives = "F"
segments = [
  { motion = "rise",  law = "cycloidal", duration = "90 deg", lift = "10 mm" },
  { motion = "dwell", duration = "90 deg" },
  { motion = "fall",  law = "cycloidal", duration = "90 deg", lift = "10 mm" },
  { motion = "dwell", duration = "90 deg" },
]
[[mass]]
name = "F"
mass = "0.5 kg"
[simulation]
cycles = 1
warmup_cycles = 0
sample_rate = "20 kHz"
"""


@pytest.mark.slow
def test_pareto_front_throughput_against_acceleration(tmp_path):
    """Every point of the front lies within 1e-3 (relative) of a_max = 2π h ω² / β², spread over the bounds.

    Reference: the cycloidal law y'' = 2π sin(2πu) / β² · h has its largest magnitude
    2π h / β² (Norton, *Cam Design and Manufacturing Handbook*, table 3-1), so a rigidly
    driven follower at cam speed ω peaks at a_max = 2π h ω² / β². Throughput (ω, maximised)
    and a_max (minimised) conflict along that curve: every speed in the bounds is
    Pareto-optimal, so the front is the curve itself, from 60 to 600 rpm.
    """
    machine = _write(tmp_path, "cycloidal.toml", CYCLOIDAL)
    res = camsim.optimize(machine, ["cam.speed=60:600rpm"], maximize="param:cam.speed",
                          minimize="maxabs:masses/F/acceleration", method="pareto", points=7, budget=120, workers=1)
    assert res.status == "optimal"
    speeds = np.array([c.values["cam.speed"] for c in res.front])
    k = [g.text for g in res.problem.goals].index("maxabs:masses/F/acceleration")
    accel = np.array([c.objectives[k] for c in res.front])
    curve = 2 * math.pi * H * speeds**2 / BETA**2
    assert np.all(np.abs(accel / curve - 1) < 1e-3)
    lo, hi = 60 * 2 * math.pi / 60, 600 * 2 * math.pi / 60
    assert len(res.front) >= 5
    assert speeds.min() < lo + 0.01 * (hi - lo) and speeds.max() > hi - 0.01 * (hi - lo)
    gaps = np.diff(np.sort(speeds))
    assert gaps.max() < 0.35 * (hi - lo)  # spread over the bounds, not bunched at one end


# --------------------------------------------------------------------------------------
# A robust constraint with a closed-form violation probability
# --------------------------------------------------------------------------------------
@pytest.mark.slow  # the default pytest's 3 minutes: CI runs it
def test_robust_constraint_probability_in_interval(tmp_path):
    """The true violation probability at the robust optimum lies in the reported 95 % interval.

    Reference: with the preload drawn as P = P_design + δ, δ ~ N(0, σ²) (a normal input),
    the minimum cam contact force of the rigid follower above is linear in it,
    min Fc = P + k h − m c (test_minimum_closure_preload), so the probability that it falls
    below the margin is exactly Φ((P* − P_design) / σ), P* Barkan's least preload. The
    optimiser asks for the least P_design with an estimated probability ≤ 1 %; at the
    design it returns, the exact probability must lie in the interval it reports.
    """
    machine = _write(tmp_path, "driven.toml", DRIVEN)
    sigma = 2.0
    res = camsim.optimize(machine, ["element.closure.preload=0:100N"], minimize="param:element.closure.preload",
                          constraints=["min_cam_contact_force>=5N"], robust=True,
                          dists=[f"element.closure.preload=normal:0:{sigma}N"], samples=64, max_probability=0.01,
                          method="local", budget=40, workers=1, seed=1)
    assert res.status == "optimal"
    design = res.values["element.closure.preload"]
    exact = norm.cdf((_barkan_least_preload(5.0) - design) / sigma)
    entry = res.best.per_speed[0]["constraints"][0]
    assert entry["method"] == "normal"
    lo, hi = entry["ci95"]
    assert lo <= exact <= hi
    assert entry["probability"] == pytest.approx(0.01, rel=1e-3)  # the solver sits on the limit

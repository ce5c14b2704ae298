"""The camshaft's own dynamics (``[camshaft] model = "dynamic"``, issue 38, spec §9).

References (spec §9 and the issue):

* a two-inertia torsional section's natural frequency is √(k_t·(1/J0 + 1/J)): the shaft's
  own matrix to 1e-9 (undamped section, a motor with a negligible slope), and the twist's
  oscillation in a run's dwell (zero crossings, damped ζ = 0.02) to 1 %;
* J0 → ∞ gives the rigid case: a station on a drive of 10⁶ kg·m² equals its rigid-shaft
  run to 1e-7 of each trace's peak;
* a flywheel sized by the rule I = E_k/(C_s·ω̄²) (Norton, Design of Machinery §11.11),
  run dynamically, gives (ω_max − ω_min)/ω̄ within 5 % of C_s, for C_s = 0.02 and 0.05;
* an independent monolithic integration of a one-station shaft (the shaft angle and the
  free mass as one ODE, DOP853 at rtol 1e-12) gives the same speed to 1e-7 of ω̄ at 20 kHz
  (measured 1.1e-8; second order in the output step);
* energy balance: in a periodic steady state the drive's work per cycle equals the energy
  dissipated per cycle, in the stations (the camshaft's work, ∮ Σ F·ṡ dt) and in the
  drive's damper (∮ c_d·(ω̄ − ω)² dt), to 1e-3.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.integrate import trapezoid  # numpy 1.26 has no np.trapezoid
import pytest
from scipy.integrate import solve_ivp

from camsim import simulate
from camsim.cam.program import CamProgram
from camsim.machine.loader import load_machine_text
from camsim.run.shaft import ShaftModel

from .stations import multi_toml

STATION = """schema = 1
[machine]
name = "one station on a dynamic shaft"
[camshaft]
speed = "200 rpm"
{shaft}
[[cam]]
name = "lobe"
drives = "M"
segments = [
  {{ motion = "rise", law = "poly345", duration = "100 deg", lift = "20 mm" }},
  {{ motion = "dwell", duration = "80 deg" }},
  {{ motion = "fall", law = "modified-sine", duration = "100 deg", lift = "20 mm" }},
  {{ motion = "dwell", duration = "80 deg" }},
]
[[mass]]
name = "M"
mass = "3 kg"
[[mass]]
name = "N"
mass = "1 kg"
[[element]]
name = "return"
type = "spring"
between = ["ground", "M"]
stiffness = "4e3 N/m"
preload = "50 N"
{damping}
[[element]]
name = "link"
type = "spring"
between = ["M", "N"]
stiffness = "2e5 N/m"
damping_ratio = 0.05
[[element]]
name = "hold"
type = "spring"
between = ["ground", "N"]
stiffness = "1e3 N/m"
damping_ratio = 0.05
[simulation]
cycles = 1
warmup_cycles = {warm}
sample_rate = "{rate}"
"""


def station(shaft: str, rate: str = "10 kHz", warm: int = 1, damping: str = "") -> str:
    return STATION.format(shaft=shaft, rate=rate, warm=warm, damping=damping)


def test_two_inertia_section_natural_frequency_of_the_shaft_model():
    j0, j, k = 0.05, 0.01, 2000.0
    machine = load_machine_text(station(f'''model = "dynamic"
inertia = "{j0} kg*m^2"
drive = "motor"
stall_torque = "1e-3 N*m"
no_load_speed = "1e4 rad/s"
[[camshaft.section]]
cam = "lobe"
stiffness = "{k} N*m/rad"
inertia = "{j} kg*m^2"
'''))
    (w,) = ShaftModel(machine).natural_frequencies()
    assert w == pytest.approx(math.sqrt(k * (1 / j0 + 1 / j)), rel=1e-9)


def test_the_twist_rings_at_the_sections_frequency_in_a_run():
    j0, j, k, zeta = 0.05, 0.01, 2000.0, 0.02
    result = simulate(load_machine_text(station(f'''model = "dynamic"
inertia = "{j0} kg*m^2"
drive = "motor"
stall_torque = "5 N*m"
no_load_speed = "210 rpm"
[[camshaft.section]]
cam = "lobe"
stiffness = "{k} N*m/rad"
inertia = "{j} kg*m^2"
damping_ratio = {zeta}
''', rate="20 kHz")))
    twist = np.radians(result.trace("camshaft/angle") - result.trace("cams/lobe/angle"))
    angle = np.mod(result.trace("camshaft/angle"), 360.0)
    dwell = (angle > 102.0) & (angle < 178.0)  # after the rise, before the fall: free ringing
    t, x = result.time[dwell], twist[dwell]
    t = t - t[0]
    # a damped sine on a slow drift (the motor's speed settling), fitted by least squares
    from scipy.optimize import curve_fit

    def model(t, a, b, zw, w, c0, c1, c2):
        return np.exp(-zw * t) * (a * np.cos(w * t) + b * np.sin(w * t)) + c0 + c1 * t + c2 * t * t

    spectrum = np.abs(np.fft.rfft(x - x.mean(), 16 * x.size))
    guess = 2 * np.pi * np.fft.rfftfreq(16 * x.size, t[1] - t[0])[int(np.argmax(spectrum[1:])) + 1]
    p, _ = curve_fit(model, t, x, p0=[np.ptp(x) / 2, 0.0, 1.0, guess, x.mean(), 0.0, 0.0], maxfev=20000)
    damped, decay = abs(p[3]), p[2]
    undamped = math.sqrt(k * (1 / j0 + 1 / j))
    assert math.hypot(damped, decay) == pytest.approx(undamped, rel=0.01)


def test_a_huge_drive_inertia_is_the_rigid_shaft():
    rigid = simulate(load_machine_text(station("")))
    heavy = simulate(load_machine_text(station('''model = "dynamic"
inertia = "1e6 kg*m^2"
drive = "speed"
drive_stiffness = "1e9 N*m/rad"
drive_damping = "1e6 N*m*s/rad"
''')))
    for name in ("M", "N"):
        for quantity, ref in rigid.masses[name].items():
            got = heavy.masses[name][quantity]
            assert np.max(np.abs(got - ref)) <= 1e-7 * np.max(np.abs(ref)), (name, quantity)
    speed = heavy.trace("camshaft/speed")  # E_k/(J0·ω̄²) = 3.4e-9: a rigid shaft to rounding
    assert np.max(np.abs(speed - speed.mean())) <= 1e-8 * speed.mean()


@pytest.mark.parametrize("cs", [0.02, 0.05])
def test_a_flywheel_sized_by_the_rule_keeps_the_speed_fluctuation(cs):
    """The station on a rigid shaft gives E_k and its mean torque T̄; a drive of
    I = E_k/(C_s·ω̄²) with a motor that runs at ω̄ under T̄ and stalls at 10·T̄ (its line's
    time constant J·ω_0/T_stall is many revolutions: over one it supplies Norton's constant
    mean torque) fluctuates by C_s."""
    rigid = simulate(load_machine_text(station(f"speed_fluctuation = {cs}")))
    summary = rigid.camshaft_summary()
    inertia = summary["flywheel_inertia"]
    omega = 200 * 2 * math.pi / 60
    mean_torque = summary["cycle_work"] / (2 * math.pi)
    assert mean_torque > 0
    dynamic = simulate(load_machine_text(station(f'''model = "dynamic"
speed_fluctuation = {cs}
flywheel = "{inertia} kg*m^2"
drive = "motor"
stall_torque = "{10 * mean_torque} N*m"
no_load_speed = "{omega / 0.9} rad/s"
''', warm=1)))
    fluctuation = dynamic.camshaft_summary()["speed_fluctuation"]
    assert fluctuation == pytest.approx(cs, rel=0.05)


def test_against_a_monolithic_integration():
    """feed (a driven mass, a spring, a preloaded return spring) on a speed-driven shaft:
    the same machine as one ODE in (θ, θ̇, x2, ẋ2)."""
    shaft = '''model = "dynamic"
inertia = "0.02 kg*m^2"
drive = "speed"
drive_stiffness = "2e3 N*m/rad"
drive_damping = "5 N*m*s/rad"
'''
    sim = '\n[simulation]\ncycles = 1\nwarmup_cycles = 1\nsample_rate = "20 kHz"\n'
    result = simulate(load_machine_text(multi_toml(stations=("feed",), camshaft=shaft, sim=sim)))
    machine = result.machine
    program = CamProgram(machine.cams[0])
    w, J0, kd, cd = machine.camshaft.speed, 0.02, 2e3, 5.0
    m1, m2 = 1.0, 0.5
    kA, cA = 1e5, 2 * 0.05 * math.sqrt(1e5 * 0.5)
    gk, P, gc = 2e3, 20.0, 2 * 0.05 * math.sqrt(2e3 * 0.5)
    t_rec = 2 * math.pi / w

    def rhs(t, y):
        th, om, x2, v2 = y
        lift = program.lift(np.array([th]))
        s, s1, s2 = lift[0][0], lift[1][0], lift[2][0]
        torque = kd * (w * (t + t_rec) - th) + cd * (w - om)
        f = kA * (x2 - s) + cA * (v2 - s1 * om)  # the spring's force on A1
        alpha = (torque - (m1 * s2 * om * om - f) * s1) / (J0 + m1 * s1 * s1)
        return [om, alpha, v2, (-f - (P + gk * x2 + gc * v2)) / m2]

    # from camsim's state at the start of the record (after the warm-up)
    y0 = [math.radians(result.trace("camshaft/angle")[0]) + 2 * math.pi, result.trace("camshaft/speed")[0],
          result.masses["A2"]["displacement"][0], result.masses["A2"]["velocity"][0]]
    sol = solve_ivp(rhs, (0.0, result.time[-1]), y0, method="DOP853", rtol=1e-12, atol=1e-13, t_eval=result.time,
                    max_step=1e-4)
    speed = result.trace("camshaft/speed")
    assert np.max(np.abs(sol.y[1] - speed)) <= 1e-7 * w
    assert (speed.max() - speed.min()) / w > 1e-3  # the shaft does fluctuate
    a2 = result.masses["A2"]["displacement"]
    assert np.max(np.abs(sol.y[2] - a2)) <= 1e-7 * np.max(np.abs(a2))


def test_drive_work_per_cycle_equals_the_energy_dissipated():
    c_d = 3.0
    result = simulate(load_machine_text(station(f'''model = "dynamic"
inertia = "0.2 kg*m^2"
drive = "speed"
drive_stiffness = "500 N*m/rad"
drive_damping = "{c_d} N*m*s/rad"
''', warm=6, rate="20 kHz", damping="damping_ratio = 0.1")))
    summary = result.camshaft_summary()
    t = result.time
    omega = result.machine.camshaft.speed
    one = t <= 2 * math.pi / omega * (1 + 1e-9)
    shaft_loss = trapezoid(c_d * (omega - result.trace("camshaft/speed")[one]) ** 2, t[one])
    stations = summary["cycle_work"]
    assert stations > 0
    assert summary["drive_work"] == pytest.approx(stations + shaft_loss, rel=1e-3)

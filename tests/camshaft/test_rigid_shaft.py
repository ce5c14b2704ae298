"""Several cams on a rigid shaft at constant speed (issue 38, spec §9).

References:

* a rigid shaft couples nothing: each station of a three-cam machine equals the same
  station run alone, as a one-cam file whose start angle is the cam's phase (spec §9) —
  traces to 1e-9 of their peak (rounding: the combined machine steps on its own grid),
  events to 1e-9 s;
* the torque a cam takes is T = F·ds/dθ, F the force it exerts on its follower: for the
  driven mass A1, F = m1·s̈ − f_kA (Newton on A1), for the roller contact its force, with
  ds/dθ = ratio·d(lift)/dθ from the cam laws at the cam's angle (θ_shaft + phase) — to
  1e-9 of the peak; the shaft's torque is their sum;
* the work per cycle in a periodic steady state equals the energy the dampers dissipate,
  ∮ Σ c·ḋ² dt, to 1e-4 (both trapezoidal on the 20 kHz samples);
* extremes are located on the solution (spec §4): each station's largest and smallest cam
  force equal the station alone's located ones (value to 1e-9 of it, instant to 1e-9 s),
  and the shaft's peak torque is the same at 5 and 20 kHz (1e-9) and no smaller than
  any sample;
* the energy excursion of a conservative one-cam station (a driven mass on a preloaded
  spring to ground, no damping) is max − min of E(θ) = ½·m·(ω·s′)² + ½·k·s² + P·s, the
  work T·dθ stores (closed form on the cam law, 2·10⁵ points), to 1e-6; the flywheel is
  I = E_k/(C_s·ω̄²) (Norton, Design of Machinery §11.11).
"""

from __future__ import annotations

import math

import numpy as np
from scipy.integrate import trapezoid  # numpy 1.26 has no np.trapezoid
import pytest

from camsim import simulate
from camsim.cam.program import CamProgram
from camsim.machine.loader import load_machine_text

from .stations import SIM, alone_toml, multi_toml

PHASES = {"feed": 0.0, "clamp": 120.0, "press": 240.0}


@pytest.fixture(scope="module")
def three():
    return simulate(load_machine_text(multi_toml(phases=PHASES)))


@pytest.mark.parametrize("station", ["feed", "clamp", "press"])
def test_each_station_equals_the_station_alone_with_its_phase(three, station):
    alone = simulate(load_machine_text(alone_toml(station, PHASES[station])))
    np.testing.assert_array_equal(three.time, alone.time)
    for name, traces in alone.masses.items():
        for quantity, ref in traces.items():
            got = three.masses[name][quantity]
            assert np.max(np.abs(got - ref)) <= 1e-9 * np.max(np.abs(ref)), (name, quantity)
    for name, ref in alone.elements.items():
        assert np.max(np.abs(three.elements[name] - ref)) <= 1e-9 * max(np.max(np.abs(ref)), 1e-300), name
    for quantity in ("angle", "displacement", "velocity", "acceleration", "jerk"):
        ref = alone.cam[quantity]
        assert np.max(np.abs(three.cams[station][quantity] - ref)) <= 1e-9 * np.max(np.abs(ref)), quantity
    if alone.cam_contact_force is not None:
        ref = alone.cam_contact_force
        got = three.cam_contact_forces[station]
        assert np.max(np.abs(got - ref)) <= 1e-9 * np.max(np.abs(ref))
    elements = {e.name for e in load_machine_text(alone_toml(station, 0.0)).elements}
    mine = [e for e in three.events if e.element in elements or e.element == station]
    assert [e.kind for e in mine] == [e.kind for e in alone.events]
    for a, b in zip(mine, alone.events):
        assert abs(a.time - b.time) <= 1e-9


def test_cam_angles_are_the_shaft_angle_plus_phase(three):
    shaft = three.trace("camshaft/angle")
    np.testing.assert_allclose(shaft, np.degrees(31.41592653589793 * three.time), rtol=0, atol=1e-9)
    for name, phase in PHASES.items():
        np.testing.assert_allclose(three.trace(f"cams/{name}/angle"), shaft + phase, rtol=0, atol=1e-9)


def test_torque_is_the_sum_of_each_cams_force_times_ds_dtheta(three):
    machine = three.machine
    torques = {}
    for cam in machine.cams:
        program = CamProgram(cam)
        theta = np.radians(three.cams[cam.name]["angle"])
        ds_dtheta = cam.ratio * program.lift(theta)[1]
        if cam.name == "feed":  # Newton on the driven A1: F = m1·s̈ − (force of kA on A1)
            force = 1.0 * three.cams["feed"]["acceleration"] - three.elements["kA"]
        elif cam.name == "clamp":  # the roller contact pushes B up: the cam supplies its force
            force = three.elements["rollB"]
        else:
            force = 0.8 * three.cams["press"]["acceleration"] - three.elements["kP"]
        torques[cam.name] = force * ds_dtheta
        got = three.trace(f"cams/{cam.name}/torque")
        assert np.max(np.abs(got - torques[cam.name])) <= 1e-9 * np.max(np.abs(torques[cam.name])), cam.name
    total = sum(torques.values())
    assert np.max(np.abs(three.trace("camshaft/torque") - total)) <= 1e-9 * np.max(np.abs(total))


@pytest.mark.parametrize("station", ["feed", "clamp", "press"])
def test_station_force_extremes_are_located_as_the_station_alone(three, station):
    alone = simulate(load_machine_text(alone_toml(station, PHASES[station])))
    entry = three.summary()["camshaft"]["cams"][station]
    for which, key in (("max", "max_contact_force"), ("min", "min_contact_force")):
        ref, t_ref = alone.extreme("cam_force", which)
        hit = three.located[f"cams/{station}/contact_force"][which]
        assert abs(hit.value - ref) <= 1e-9 * abs(ref), which
        assert abs(hit.time - t_ref) <= 1e-9, which
        assert entry[key] == hit.value
    low = min(three.located[f"cams/{name}/contact_force"]["min"].value for name in PHASES)
    assert three.scalars()["min_cam_contact_force"] == low


def test_peak_torque_is_located_at_any_sample_rate(three):
    coarse = simulate(three.machine, sample_rate=5000.0)
    peaks = [r.summary()["camshaft"]["peak_torque"] for r in (three, coarse)]
    assert abs(peaks[0] - peaks[1]) <= 1e-9 * peaks[0]
    assert peaks[0] >= np.max(np.abs(three.trace("camshaft/torque")))
    for name in PHASES:
        cams = [r.summary()["camshaft"]["cams"][name]["peak_torque"] for r in (three, coarse)]
        assert abs(cams[0] - cams[1]) <= 1e-9 * cams[0], name


def test_work_per_cycle_is_the_energy_dissipated_in_steady_state():
    """feed and clamp (linear, damped, no impact) after 6 warm-up revolutions."""
    sim = SIM.replace("warmup_cycles = 1", "warmup_cycles = 6")
    result = simulate(load_machine_text(multi_toml(stations=("feed", "clamp"), phases=PHASES, sim=sim)))
    from camsim.machine.loader import damping_coefficients

    machine = result.machine
    t = result.time
    period = 2 * math.pi / machine.cams[0].speed
    one = t <= period * (1 + 1e-9)
    power = np.zeros(t.size)

    def velocity(node):
        if node == "ground":
            return np.zeros(t.size)
        if node in result.masses:
            return result.masses[node]["velocity"]
        return result.cams[node]["velocity"]

    for e in machine.elements:
        c = damping_coefficients(machine, e)["c"]
        rate = velocity(e.upper) - velocity(e.lower)
        power += c * rate**2
    dissipated = trapezoid(power[one], t[one])
    work = result.camshaft_summary()["cycle_work"]
    assert work > 0
    assert abs(work - dissipated) <= 1e-4 * dissipated


CONSERVATIVE = """schema = 1
[machine]
name = "one conservative station"
[camshaft]
speed = "200 rpm"
speed_fluctuation = 0.03
[[cam]]
name = "lobe"
phase = "30 deg"
drives = "M"
ratio = 0.8
segments = [
  { motion = "rise", law = "poly345", duration = "100 deg", lift = "20 mm" },
  { motion = "dwell", duration = "80 deg" },
  { motion = "fall", law = "modified-sine", duration = "100 deg", lift = "20 mm" },
  { motion = "dwell", duration = "80 deg" },
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
[[element]]
name = "other"
type = "spring"
between = ["ground", "N"]
stiffness = "1e3 N/m"
[simulation]
cycles = 1
warmup_cycles = 0
sample_rate = "50 kHz"
"""


def test_energy_excursion_and_flywheel_of_a_conservative_station():
    result = simulate(load_machine_text(CONSERVATIVE))
    summary = result.camshaft_summary()
    cam = result.machine.cams[0]
    program = CamProgram(cam)
    omega = cam.speed
    theta = cam.start_angle + cam.phase + np.linspace(0.0, 2 * math.pi, 200_001)
    lift, d1 = program.lift(theta)[:2]
    s, s1 = cam.ratio * lift, cam.ratio * d1
    energy = 0.5 * 3.0 * (omega * s1) ** 2 + 0.5 * 4e3 * s**2 + 50.0 * s
    e_k = float(np.max(energy) - np.min(energy))
    assert abs(summary["energy_excursion"] - e_k) <= 1e-6 * e_k
    assert abs(summary["cycle_work"]) <= 1e-9 * e_k
    assert summary["flywheel_inertia"] == pytest.approx(summary["energy_excursion"] / (0.03 * omega**2), rel=1e-15)
    assert result.scalars()["flywheel_inertia"] == pytest.approx(summary["flywheel_inertia"], rel=1e-15)

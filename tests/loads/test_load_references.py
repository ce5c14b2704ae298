"""Process loads (issue 43, spec §10) against closed forms.

Each test builds a small machine from TOML text, runs :func:`camsim.simulate` and compares
with a solution derived by hand (in the docstrings); none of the expected values comes from
camsim's model or engine. The engine integrates a load exactly like the cam's motion (an input
of four channels, exact between its break times), so the piecewise-linear motions here hold
to 1e-9 of their peak (spec §10: "each to 1e-9 where the motion is piecewise linear").
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.optimize import brentq

from camsim.machine.loader import load_machine_text
from camsim.run.simulation import simulate

M, K = 2.0, 8000.0          # [kg], [N/m]: ω_n = √(k/m) = 63.2456 rad/s
W_N = math.sqrt(K / M)


def _spring_mass(load: str, simulation: str, initial: str = "", extra: str = "") -> str:
    return f"""
schema = 1
[machine]
name = "spring-mass with a load"
[[mass]]
name = "M"
mass = "{M!r} kg"
[[element]]
name = "k"
type = "spring"
between = ["ground", "M"]
stiffness = "{K!r} N/m"
{extra}
[[load]]
name = "F"
on = "M"
{load}
[simulation]
{simulation}
{initial}
"""


# ---------------------------------------------------------------------- forced resonance
def test_undamped_spring_mass_at_resonance_grows_as_the_closed_form():
    """Spec §10: an undamped spring–mass at rest driven by F0·sin(ω_n·t) has
    x(t) = F0/(2·m·ω_n)·(sin(ω_n·t)/ω_n − t·cos(ω_n·t)) (the resonant particular solution plus
    the homogeneous one that starts it from rest). Held to 1e-9 of the peak over ten periods,
    the velocity too (its derivative, F0·t·sin(ω_n·t)/(2m)); the load's work over the record
    is the energy it put in, ½m·v² + ½k·x² at the end."""
    f0 = 25.0
    text = _spring_mass(f'sine = {{ amplitude = "{f0} N", frequency = "{W_N / (2 * math.pi)!r} Hz" }}',
                        'duration = "1 s"\nsample_rate = "2 kHz"')
    r = simulate(load_machine_text(text))
    t, x, v = r.time, r.masses["M"]["displacement"], r.masses["M"]["velocity"]
    exact = f0 / (2 * M * W_N) * (np.sin(W_N * t) / W_N - t * np.cos(W_N * t))
    exact_v = f0 * t * np.sin(W_N * t) / (2 * M)
    assert np.max(np.abs(x - exact)) <= 1e-9 * np.max(np.abs(exact))
    assert np.max(np.abs(v - exact_v)) <= 1e-9 * np.max(np.abs(exact_v))
    assert np.max(np.abs(r.loads["F"] - f0 * np.sin(W_N * t))) <= 1e-12 * f0
    energy = 0.5 * M * exact_v[-1] ** 2 + 0.5 * K * exact[-1] ** 2
    assert r.summary()["loads"]["F"]["work_over"] == "record"
    assert abs(r.load_work["F"] - energy) <= 1e-9 * energy


# ---------------------------------------------------------------------- constant load
def test_constant_load_static_deflection_and_step_response():
    """A constant load F on a spring–mass: the static equilibrium the run starts from is
    x = F/k (held to rounding over the record); started at rest at x = 0 instead ([initial]),
    the step response x(t) = F/k·(1 − cos ω_n·t), to 1e-9 of its peak 2F/k."""
    force = 150.0
    static = simulate(load_machine_text(_spring_mass(f'force = "{force} N"', 'duration = "0.2 s"\nsample_rate = "5 kHz"')))
    x = static.masses["M"]["displacement"]
    assert np.max(np.abs(x - force / K)) <= 1e-12 * force / K
    step = simulate(load_machine_text(_spring_mass(f'force = "{force} N"', 'duration = "0.5 s"\nsample_rate = "5 kHz"',
                                                   '[initial.M]\ndisplacement = "0 m"')))
    t = step.time
    exact = force / K * (1 - np.cos(W_N * t))
    assert np.max(np.abs(step.masses["M"]["displacement"] - exact)) <= 1e-9 * 2 * force / K


# ---------------------------------------------------------------------- a time table: ramp and step
def test_time_table_ramp_and_step_against_the_closed_form(tmp_path):
    """A time table written with a ramp (0 N until t1, linear to F1 at t2), a hold and a step
    (F1 to F2 at t3, the time written twice) on an undamped spring–mass at rest at x = 0. By
    superposition of the responses of ẍ + ω²x = f(t)/m from rest to a ramp of slope r from τ,
    r/k·((t − τ) − sin(ω(t − τ))/ω), and to a step S at τ, S/k·(1 − cos ω(t − τ)):
    x = r/k·[R(t − t1) − R(t − t2)] + (F2 − F1)/k·(1 − cos ω(t − t3))·H(t − t3) with
    R(s) = (s − sin(ωs)/ω)·H(s), r = F1/(t2 − t1). Held to 1e-9 of the peak."""
    t1, t2, t3, f1, f2 = 0.05, 0.12, 0.2, 40.0, -25.0
    (tmp_path / "ramp.csv").write_text(f"time [ms], force [N]\n0, 0\n{t1 * 1e3}, 0\n{t2 * 1e3}, {f1}\n{t3 * 1e3}, {f1}\n"
                                       f"{t3 * 1e3}, {f2}\n400, {f2}\n")
    text = _spring_mass('table = "ramp.csv"', 'duration = "0.5 s"\nsample_rate = "4 kHz"', '[initial.M]\ndisplacement = "0 m"')
    machine = load_machine_text(text, base_dir=tmp_path)
    r = simulate(machine)
    t = r.time

    def ramp(s):
        return np.where(s > 0, s - np.sin(W_N * s) / W_N, 0.0)

    slope = f1 / (t2 - t1)
    exact = slope / K * (ramp(t - t1) - ramp(t - t2)) + np.where(t >= t3, (f2 - f1) / K * (1 - np.cos(W_N * (t - t3))), 0.0)
    assert np.max(np.abs(r.masses["M"]["displacement"] - exact)) <= 1e-9 * np.max(np.abs(exact))
    load = np.interp(t, [0, t1, t2, t3], [0, 0, f1, f1])
    load = np.where(t >= t3, f2, load)
    assert np.max(np.abs(r.loads["F"] - load)) <= 1e-9 * f1


# ---------------------------------------------------------------------- a driven follower
LIFT, RPM = 0.012, 300.0
OMEGA = RPM * 2 * math.pi / 60
M1, KR, PRELOAD = 1.5, 3000.0, 150.0


def _driven(load: str) -> str:
    """A follower the cam drives (x = s), held down by a preloaded spring to ground, and a load."""
    return f"""
schema = 1
[machine]
name = "driven follower with a load"
[cam]
speed = "{RPM} rpm"
drives = "M1"
segments = [
  {{ motion = "rise", law = "harmonic", duration = "180 deg", lift = "{LIFT} m" }},
  {{ motion = "fall", law = "harmonic", duration = "180 deg", lift = "{LIFT} m" }},
]
[[mass]]
name = "M1"
mass = "{M1} kg"
[[element]]
name = "ret"
type = "spring"
between = ["ground", "M1"]
stiffness = "{KR} N/m"
preload = "{PRELOAD} N"
{load}
[simulation]
cycles = 1
warmup_cycles = 0
sample_rate = "20 kHz"
"""


def _cam(theta):
    """The harmonic rise and fall: s = h/2·(1 − cos θ) over the whole revolution, and s̈."""
    return LIFT / 2 * (1 - np.cos(theta)), LIFT / 2 * OMEGA**2 * np.cos(theta)


PRESS = """
[[load]]
name = "press"
on = "M1"
base = "20 N"
segments = [
  { motion = "rise", law = "harmonic", duration = "90 deg", change = "400 N" },
  { motion = "dwell", duration = "90 deg" },
  { motion = "fall", law = "harmonic", duration = "90 deg", change = "400 N" },
  { motion = "dwell", duration = "90 deg" },
]
"""


def _press(theta):
    """The segment load above: 20 N + 400 N·sin²θ on [0, 90°], 420 N to 180°, 20 + 400·cos²θ to
    270°, 20 N after (a harmonic rise over 90°: C/2·(1 − cos 2θ) = C·sin²θ)."""
    phi = np.mod(theta, 2 * np.pi)
    c = 400.0
    return 20.0 + np.select([phi < np.pi / 2, phi < np.pi, phi < 1.5 * np.pi],
                            [c * np.sin(phi) ** 2, c, c * np.cos(phi) ** 2], 0.0)


def test_cam_contact_force_with_a_segment_load_sample_by_sample():
    """Spec §10: the cam contact force of a driven mass is m·s̈ − Σ element forces − load. Here
    every term is a function of the cam angle: the return spring (ground → M1, tension
    P + k·s) pushes M1 by −(P + k·s), so F_c = m·s̈ + P + k·s − F(θ), with s, s̈ of the harmonic
    cam and F(θ) of the harmonic load program in closed form. Sample by sample to 1e-9 N; the
    jump row, where F_c turns negative, at the root of that closed form to 1e-9 s."""
    r = simulate(load_machine_text(_driven(PRESS)))
    theta = OMEGA * r.time
    s, a = _cam(theta)
    exact = M1 * a + PRELOAD + KR * s - _press(theta)
    assert np.max(np.abs(r.cam_contact_force - exact)) <= 1e-9
    assert np.max(np.abs(r.loads["press"] - _press(theta))) <= 1e-9

    def fc(t):
        th = OMEGA * t
        return M1 * LIFT / 2 * OMEGA**2 * np.cos(th) + PRELOAD + KR * LIFT / 2 * (1 - np.cos(th)) - _press(th)

    jumps = [e for e in r.events if e.kind == "jump"]
    assert len(jumps) == 1
    k = int(np.flatnonzero((exact[:-1] >= 0) & (exact[1:] < 0))[0])
    root = brentq(fc, r.time[k], r.time[k + 1], xtol=1e-15)
    assert abs(jumps[0].time - root) <= 1e-9
    low = r.summary()["min_cam_contact_force"]  # located on the solution: the closed form's minimum
    phi = np.linspace(0.0, 2 * np.pi, 2_000_001)
    assert abs(low["value"] - np.min(fc(phi / OMEGA))) <= 1e-6


def test_cam_contact_force_with_a_table_load_sample_by_sample(tmp_path):
    """The same driven follower with an angle table (lbf in the header) instead: linear between
    its rows, a step where an angle is written twice. F_c = m·s̈ + P + k·s − F(θ), F(θ) by
    linear interpolation of the rows (the step's right value from the angle on), to 1e-9 N."""
    (tmp_path / "press.csv").write_text("angle [deg], force [lbf]\n0, 0\n100, 0\n120, 20\n150, 20\n150, 5\n200, 0\n360, 0\n")
    load = '\n[[load]]\nname = "tool"\non = "M1"\ntable = "press.csv"\n'
    r = simulate(load_machine_text(_driven(load), base_dir=tmp_path))
    theta = OMEGA * r.time
    deg = np.degrees(theta)
    lbf = 0.45359237 * 9.80665
    table = np.where(deg < 150, np.interp(deg, [0, 100, 120, 150], [0, 0, 20, 20]),
                     np.interp(deg, [150, 200, 360], [5, 0, 0])) * lbf
    s, a = _cam(theta)
    assert np.max(np.abs(r.loads["tool"] - table)) <= 1e-9
    assert np.max(np.abs(r.cam_contact_force - (M1 * a + PRELOAD + KR * s - table))) <= 1e-9


# ---------------------------------------------------------------------- work per cycle
def test_work_per_cycle_of_loads_on_a_driven_mass_against_the_closed_form():
    """W = ∮ F·ṡ dt = ∮ F(θ)·s′(θ) dθ with s′ = h/2·sin θ (the harmonic cam above):

    * a constant load does no work over a revolution (s returns to its start): 0 J;
    * the segment load: 20 N·∮ds = 0, and 400 N·h/2·(∫₀^{π/2} sin³θ dθ + ∫_{π/2}^{π} sin θ dθ +
      ∫_π^{3π/2} cos²θ·sin θ dθ) = 400·h/2·(2/3 + 1 − 1/3) = 400·h·2/3 J.

    Integrated on the engine's solution (Gauss–Legendre on every step, camsim.run.loads), so
    to 1e-12 relative at any sample rate (the two rates here)."""
    both = PRESS + '\n[[load]]\nname = "hold"\non = "M1"\nforce = "-35 N"\n'
    for rate in ("20 kHz", "3 kHz"):
        r = simulate(load_machine_text(_driven(both).replace('"20 kHz"', f'"{rate}"')))
        assert r.summary()["loads"]["press"]["work_over"] == "revolution"
        assert abs(r.load_work["press"] - 400.0 * LIFT * 2.0 / 3.0) <= 1e-12 * 400.0 * LIFT
        assert abs(r.load_work["hold"]) <= 1e-12 * 35.0 * LIFT
        assert r.scalars()["load_work:press"] == r.load_work["press"]


def _base_with_loads() -> str:
    """A cam driving a free mass through a damped spring, the segment load and a sine on it."""
    return f"""
schema = 1
[machine]
name = "base excitation with loads"
[cam]
speed = "120 rpm"
segments = [
  {{ motion = "rise", law = "cycloidal", duration = "150 deg", lift = "10 mm" }},
  {{ motion = "dwell", duration = "30 deg" }},
  {{ motion = "fall", law = "poly345", duration = "150 deg", lift = "10 mm" }},
  {{ motion = "dwell", duration = "30 deg" }},
]
[[mass]]
name = "M"
mass = "1 kg"
[[element]]
name = "k"
type = "spring"
between = ["cam", "M"]
stiffness = "4e4 N/m"
damping_ratio = 0.03
{PRESS.replace('"M1"', '"M"')}
[[load]]
name = "shake"
on = "M"
sine = {{ amplitude = "30 N", frequency = "7.3 Hz", phase = "20 deg", offset = "5 N" }}
[simulation]
cycles = 1
warmup_cycles = 1
"""


def test_work_per_cycle_is_sample_rate_independent_on_free_masses():
    """A segment load on a free mass that a cam drives through a damped spring (a linear
    configuration) and a sine load on it: each one's work per cycle at 2 kHz and at 37 kHz
    (different internal grids) agrees to 1e-10 relative — an integral on the solution, not a
    trapezoid on the samples (which is 2e-6 off here, checked as well)."""
    text = _base_with_loads()
    runs = [simulate(load_machine_text(text), sample_rate=rate) for rate in (2000.0, 37000.0)]
    for name in ("press", "shake"):
        a, b = (r.load_work[name] for r in runs)
        assert abs(a - b) <= 1e-10 * abs(b), (name, a, b)
    coarse = runs[0]
    n = int(round(0.5 * 2000.0)) + 1  # the samples of the first revolution (0.5 s at 2 kHz)
    g = coarse.loads["press"][:n] * coarse.masses["M"]["velocity"][:n]
    trapezoid = float(np.sum(0.5 * (g[1:] + g[:-1]) * np.diff(coarse.time[:n])))
    assert abs(trapezoid - runs[1].load_work["press"]) > 1e-7 * abs(runs[1].load_work["press"])


def test_work_per_cycle_through_a_closed_power_law_contact_is_sample_rate_independent():
    """The free mass of the test above landing on a power-law stop (its closed phases are
    nonlinear stretches, integrated to the engine's tolerance): each load's work per cycle at
    20 and 50 kHz agrees to 1e-8 relative (the nodes' order-six Hermite rule there; measured
    1.2e-9), and the stop's phases are really in the revolution (impacts)."""
    text = _base_with_loads().replace("[simulation]", """[[element]]
name = "stop"
type = "contact"
law = "power"
between = ["ground", "M"]
gap = "0.3 mm"
coefficient = "3e9 N/m^1.5"
exponent = 1.5
restitution = 0.8
[simulation]""")
    runs = [simulate(load_machine_text(text), sample_rate=rate) for rate in (20000.0, 50000.0)]
    assert len(runs[0].impacts()) >= 2
    for name in ("press", "shake"):
        a, b = (r.load_work[name] for r in runs)
        assert abs(a - b) <= 1e-8 * abs(b), (name, a, b)


# ---------------------------------------------------------------------- programs
def test_a_synthesised_law_in_a_load_program_is_the_cam_law():
    """Every cam law may be used, synthesised ones included (the program is the cam's code):
    a ``polynomial`` rise with continuity 3 between dwells is the 4-5-6-7 polynomial (spec §2),
    so the two programs give the same force and the same cam contact force, to 1e-9 N."""
    def program(law: str) -> str:
        extra = ", continuity = 3" if law == "polynomial" else ""
        return PRESS.replace('law = "harmonic", duration = "90 deg", change = "400 N" }',
                             f'law = "{law}", duration = "90 deg", change = "400 N"{extra} }}')
    a, b = (simulate(load_machine_text(_driven(program(law)))) for law in ("poly4567", "polynomial"))
    assert np.max(np.abs(a.loads["press"] - b.loads["press"])) <= 1e-9
    assert np.max(np.abs(a.cam_contact_force - b.cam_contact_force)) <= 1e-9
    assert np.ptp(a.loads["press"]) > 399.0


def test_a_load_follows_the_angle_of_the_cam_it_names():
    """``cam = "<name>"`` on a machine with [[cam]] tables: the load's program runs over that
    cam's angle, the shaft's plus its phase (60°): F(t) = program(θ0 + 60° + ω·t); without
    ``cam`` over the shaft's angle θ0 + ω·t. Both against the closed form of the program."""
    on_b = PRESS.replace('name = "press"', 'name = "onb"\ncam = "b"').replace('"M1"', '"M2"')
    on_shaft = PRESS.replace('name = "press"', 'name = "shaft"')
    text = f"""
schema = 1
[machine]
name = "two cams"
[camshaft]
speed = "{RPM} rpm"
[[cam]]
name = "a"
drives = "M1"
segments = [
  {{ motion = "rise", law = "harmonic", duration = "180 deg", lift = "{LIFT} m" }},
  {{ motion = "fall", law = "harmonic", duration = "180 deg", lift = "{LIFT} m" }},
]
[[cam]]
name = "b"
phase = "60 deg"
drives = "M2"
segments = [
  {{ motion = "rise", law = "cycloidal", duration = "180 deg", lift = "5 mm" }},
  {{ motion = "fall", law = "cycloidal", duration = "180 deg", lift = "5 mm" }},
]
[[mass]]
name = "M1"
mass = "1 kg"
[[mass]]
name = "M2"
mass = "1 kg"
{on_b}
{on_shaft}
[simulation]
cycles = 1
warmup_cycles = 0
sample_rate = "10 kHz"
"""
    r = simulate(load_machine_text(text))
    theta = OMEGA * r.time
    assert np.max(np.abs(r.loads["onb"] - _press(theta + np.radians(60.0)))) <= 1e-9
    assert np.max(np.abs(r.loads["shaft"] - _press(theta))) <= 1e-9
    s_a, a_a = _cam(theta)
    # cam a's follower: no element, so F_c = m·s̈ − F (the load along +x is carried by the cam)
    assert np.max(np.abs(r.cam_contact_forces["a"] - (1.0 * a_a - _press(theta)))) <= 1e-9


@pytest.mark.parametrize("start", [0.0, 0.13])
def test_a_sine_is_zero_before_its_start(start):
    """``sine.start``: F = offset + A·sin(2πf·(t − start) + φ) from ``start`` on, 0 before (on the
    result's time base); the response of the spring–mass to it from rest at x = 0 is the
    closed form of a suddenly applied harmonic force (checked against the Duhamel integral
    x(t) = 1/(m·ω)·∫ F(τ)·sin ω(t − τ) dτ in closed form, to 1e-9 of the peak)."""
    amp, freq, phase, offset = 12.0, 4.0, math.radians(30.0), 3.0
    text = _spring_mass(f'sine = {{ amplitude = "{amp} N", frequency = "{freq} Hz", phase = "30 deg", offset = "{offset} N", '
                        f'start = "{start} s" }}', 'duration = "0.6 s"\nsample_rate = "5 kHz"',
                        '[initial.M]\ndisplacement = "0 m"')
    r = simulate(load_machine_text(text))
    t = r.time
    w = 2 * math.pi * freq
    s = np.maximum(t - start, 0.0)
    force = np.where(t >= start, offset + amp * np.sin(w * s + phase), 0.0)
    assert np.max(np.abs(r.loads["F"] - force)) <= 1e-9 * amp
    # Duhamel: the step of the offset, and A·sin(w·s + φ) applied from s = 0
    wn = W_N
    x_off = offset / K * (1 - np.cos(wn * s))
    # particular + homogeneous of ẍ + wn²x = A/m·sin(w s + φ), x(0) = ẋ(0) = 0
    c = amp / (M * (wn**2 - w**2))
    x_sin = c * (np.sin(w * s + phase) - np.sin(phase) * np.cos(wn * s) - w / wn * np.cos(phase) * np.sin(wn * s))
    exact = np.where(t >= start, x_off + x_sin, 0.0)
    assert np.max(np.abs(r.masses["M"]["displacement"] - exact)) <= 1e-9 * np.max(np.abs(exact))


# ---------------------------------------------------------------------- through a stuck rigid contact
def test_a_load_lifts_a_mass_off_a_rigid_seat_at_the_closed_form_instant(tmp_path):
    """A mass pressed on a rigid seat (law = "restitution", e = 0) by a preloaded spring (force
    −(P + k·x) on it) and pulled up by a load ramping at r = F1/T1 from 0: while it rests the
    seat carries λ = P − r·t (the load enters the constraint force through the null space, like
    gravity but in time); it releases when λ = 0, at t* = P/r, and then, with τ = t − t*,
    m·ẍ + k·x = r·τ from rest: x = r/k·(τ − sin(ω_n·τ)/ω_n). Release instant to 1e-9 s, the seat's
    force and the motion to 1e-9 of their peaks."""
    preload, f1, t1 = 30.0, 120.0, 0.2
    rate = f1 / t1
    (tmp_path / "pull.csv").write_text(f"time [s], force [N]\n0, 0\n{t1}, {f1}\n")
    seat = '[[element]]\nname = "seat"\ntype = "contact"\nlaw = "restitution"\nrestitution = 0.0\n' \
           'between = ["ground", "M"]\ngap = "0 m"\n'
    text = _spring_mass('table = "pull.csv"', 'duration = "0.15 s"\nsample_rate = "10 kHz"', extra=seat)
    text = text.replace(f'stiffness = "{K!r} N/m"', f'stiffness = "{K!r} N/m"\npreload = "{preload} N"')
    r = simulate(load_machine_text(text, base_dir=tmp_path))
    t_star = preload / rate
    releases = [e for e in r.events if e.kind == "release"]
    assert len(releases) == 1 and abs(releases[0].time - t_star) <= 1e-9
    t = r.time
    before = t < t_star
    assert np.max(np.abs(r.elements["seat"][before] - (preload - rate * t[before]))) <= 1e-9 * preload
    tau = np.maximum(t - t_star, 0.0)
    exact = rate / K * (tau - np.sin(W_N * tau) / W_N)
    assert np.max(np.abs(r.masses["M"]["displacement"] - exact)) <= 1e-9 * np.max(np.abs(exact))


def test_work_per_cycle_on_a_mass_held_on_the_cam_by_a_rigid_contact():
    """The follower of the driven test above, not driven but held on the cam by a rigid
    contact (law = "restitution", e = 0) and its preloaded spring: while the contact rests its
    motion is the cam's, ẋ = ṡ, through the constraint (the velocity reads the cam input, not
    only the state), so the segment load's work per cycle is the same closed form,
    400 N·h·2/3, and the contact never opens (no release)."""
    text = _driven(PRESS).replace('drives = "M1"\n', "").replace("[simulation]", """[[element]]
name = "roller"
type = "contact"
law = "restitution"
restitution = 0.0
between = ["cam", "M1"]
gap = "0 m"
[simulation]""").replace(f'preload = "{PRELOAD} N"', 'preload = "900 N"')
    r = simulate(load_machine_text(text))
    assert not [e for e in r.events if e.kind == "release"]
    theta = OMEGA * r.time
    assert np.max(np.abs(r.masses["M1"]["displacement"] - _cam(theta)[0])) <= 1e-12
    assert abs(r.load_work["press"] - 400.0 * LIFT * 2.0 / 3.0) <= 1e-12 * 400.0 * LIFT


@pytest.mark.full  # before a release (CAMSIM_FULL=1): .ci/run's 15 minutes
def test_an_angle_load_on_a_dynamic_camshaft_follows_its_cams_own_angle():
    """On a dynamic camshaft (machines/camshaft-line-dynamic.toml, issue 38) a cam's angle is the
    shaft's solution θ(t), not θ0 + ω·t: a load over the feeder's angle is its program at the
    feeder's recorded angle (``/cams/feeder/angle``), the chain rule giving its rates, to 1e-9 N
    (about 20 s: the waveform relaxation of the shaft)."""
    from pathlib import Path

    from camsim.cam.program import CamProgram
    from camsim.cam.description import Cam

    root = Path(__file__).resolve().parents[2]
    text = (root / "machines" / "camshaft-line-dynamic.toml").read_text() + PRESS.replace(
        'name = "press"', 'name = "push"\ncam = "feeder"').replace('"M1"', '"F1"')
    machine = load_machine_text(text, base_dir=root / "machines", overrides=['simulation.sample_rate="5 kHz"'])
    r = simulate(machine)
    theta = np.radians(r.cams["feeder"]["angle"])
    program = CamProgram(Cam(speed=machine.cams[0].speed, segments=machine.load("push").segments))
    assert np.max(np.abs(r.loads["push"] - (20.0 + program.lift(theta)[0]))) <= 1e-9
    assert np.max(np.abs(r.loads["push"] - _press(theta))) <= 1e-9

"""Tests of camsim.machine.loader: shipped machines, SI values, and every bad-input message.

Expected SI values are converted by hand from the thesis's inch-pound figures with the
exact definitions 1 lb = 0.45359237 kg, 1 lbf = 4.4482216152605 N, 1 in = 0.0254 m
(so 1 lbf/in = 175.126835 N/m); tolerances are relative 1e-6 unless stated.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import pytest

from camsim.errors import MachineFileError
from camsim.machine.loader import (
    apply_override,
    damping_coefficients,
    load_machine,
    load_machine_text,
    machine_to_dict,
    override_keys,
)
from camsim.machine.description import STANDARD_GRAVITY, Contact, PreloadedLink, Spring

MACHINES = Path(__file__).resolve().parents[1] / "machines"
SHIPPED = ("cdtm.toml", "cdtm-power.toml", "dynacam-2mass.toml", "barkan-follower.toml", "ball-drop.toml")

LB = 0.45359237  # kg
LBF = 4.4482216152605  # N
INCH = 0.0254  # m
LBF_PER_IN = LBF / INCH  # N/m

#: A small valid machine used as the base of the error cases.
BASE = """\
schema = 1

[machine]
name = "two masses"

[cam]
speed = "120 rpm"
drives = "M1"
segments = [
  { motion = "rise",  law = "cycloidal", duration = "90 deg", lift = "10 mm" },
  { motion = "dwell", duration = "90 deg" },
  { motion = "fall",  law = "poly345", duration = "90 deg", lift = "10 mm" },
  { motion = "dwell", duration = 90 },
]

[[mass]]
name = "M1"
mass = "2 kg"

[[mass]]
name = "M2"
mass = "1 kg"

[[element]]
name = "K12"
type = "spring"
between = ["M1", "M2"]
stiffness = "1e5 N/m"
damping_ratio = 0.05

[[element]]
name = "seat"
type = "contact"
between = ["ground", "M2"]
gap = "1 mm"
stiffness = "1e7 N/m"

[simulation]
cycles = 2
"""


def _error(text: str, overrides=(), source: str = "m.toml", base_dir: Path = Path(".")) -> MachineFileError:
    with pytest.raises(MachineFileError) as info:
        load_machine_text(text, source=source, base_dir=base_dir, overrides=overrides)
    exc = info.value
    message = str(exc)
    assert "\n" not in message, "error messages are one line"
    assert message.startswith(f"{source}: ")
    return exc


def _check(exc: MachineFileError, key: str, *fragments: str) -> None:
    assert exc.key == key, str(exc)
    assert str(exc).startswith(f"m.toml: {key}: ") if key else True
    for fragment in fragments:
        assert fragment in exc.message, str(exc)


# --------------------------------------------------------------------------------------
# shipped machines
# --------------------------------------------------------------------------------------
@pytest.mark.parametrize("name", SHIPPED)
def test_shipped_machine_loads(name):
    machine = load_machine(MACHINES / name)
    assert machine.masses and machine.elements
    assert machine.source.endswith(name)
    json.dumps(machine_to_dict(machine), allow_nan=False)  # JSON-able


def test_base_loads():
    machine = load_machine_text(BASE)
    assert machine.cam.drives == "M1"
    assert [s.motion for s in machine.cam.segments] == ["rise", "dwell", "fall", "dwell"]
    # bare duration 90 means degrees
    assert machine.cam.segments[3].duration == pytest.approx(math.pi / 2, rel=1e-12)
    assert machine.simulation.cycles == 2


def test_cdtm_values_match_figure_6_7():
    """cdtm.toml in SI against thesis figure 6.7 (p. 48), converted by hand."""
    m = load_machine(MACHINES / "cdtm.toml")
    rel = 1e-6
    assert m.cam.speed == pytest.approx(120 * 2 * math.pi / 60, rel=1e-12)  # 120 rpm, thesis §4
    assert m.cam.ratio == pytest.approx((13.5 / 6.5) * (2.375 / 7.75), rel=1e-5)  # spec §2
    assert m.cam.drives == "M1"
    assert m.mass_of("M1") == pytest.approx(7.416689, rel=rel)  # 16.351 lb x 0.45359237 kg/lb
    assert m.mass_of("M2") == pytest.approx(1.6388 * LB, rel=rel)  # 0.743347 kg
    assert m.mass_of("M3") == pytest.approx(0.3854 * LB, rel=rel)  # 0.174814 kg
    k12 = m.element("K12")
    assert isinstance(k12, Spring) and (k12.lower, k12.upper) == ("M1", "M2")
    assert k12.stiffness == pytest.approx(9051 * LBF_PER_IN, rel=rel)  # 1,585,073 N/m (app. F)
    assert k12.stiffness == pytest.approx(1_585_073, rel=1e-6)
    k23 = m.element("K23")
    assert isinstance(k23, PreloadedLink) and (k23.lower, k23.upper) == ("M2", "M3")
    assert k23.push_stiffness == pytest.approx(1_426_233, rel=1e-6)  # thesis p. 59
    assert k23.pull_stiffness == pytest.approx(38_353, rel=1e-5)  # thesis p. 59
    assert k23.preload == pytest.approx(125.1, rel=1e-3)  # thesis p. 56: 125.1 N
    seat = m.element("seat")
    assert isinstance(seat, Contact) and (seat.lower, seat.upper) == ("ground", "M3")
    assert seat.law == "linear" and seat.transducer
    assert seat.gap == pytest.approx(0.0625 * INCH, rel=1e-12)  # OTD 0.0625 in = 1.5875 mm
    assert seat.stiffness == 8_597_740.0
    k01 = m.element("K01")
    assert (k01.lower, k01.upper) == ("ground", "M1")
    assert k01.stiffness == pytest.approx(25.62 * LBF_PER_IN, rel=rel)
    for e in m.elements:
        assert e.damping.ratio == 0.06  # Norton's 6 %, thesis p. 49
    assert m.simulation.gravity == 0.0
    assert (m.simulation.cycles, m.simulation.warmup_cycles, m.simulation.sample_rate) == (1, 1, 50_000.0)
    # table 2: 8 segments, 0.5 in lift at the roller, durations 50/40 deg
    segs = m.cam.segments
    assert [s.law for s in segs[::2]] == ["poly4567", "poly345", "modified-trapezoid", "modified-sine"]
    assert all(s.lift == pytest.approx(0.0127, rel=1e-12) for s in segs[::2])
    assert math.degrees(sum(s.duration for s in segs)) == pytest.approx(360.0, abs=1e-9)


def test_cdtm_damping_coefficients():
    """c = 2*zeta*sqrt(k*m_ref) (spec §3) with the figure-6.7 values, by hand."""
    m = load_machine(MACHINES / "cdtm.toml")
    c = damping_coefficients(m, m.element("K12"))["c"]
    assert c == pytest.approx(2 * 0.06 * math.sqrt(9051 * LBF_PER_IN * 1.6388 * LB), rel=1e-9)
    cc = damping_coefficients(m, m.element("K23"))
    assert cc["c_push"] == pytest.approx(2 * 0.06 * math.sqrt(8144 * LBF_PER_IN * 0.3854 * LB), rel=1e-9)
    assert cc["c_pull"] == pytest.approx(2 * 0.06 * math.sqrt(219 * LBF_PER_IN * 0.3854 * LB), rel=1e-9)


def test_cdtm_power_seat():
    seat = load_machine(MACHINES / "cdtm-power.toml").element("seat")
    assert seat.law == "power" and seat.exponent == 1.425
    # C = 1.11e7 lbf/in^1.425 (thesis eq. 7.1) in N/m^1.425
    assert seat.coefficient == pytest.approx(1.11e7 * LBF / INCH**1.425, rel=1e-9)
    assert 0.0 <= seat.restitution <= 1.0


def test_ball_drop():
    m = load_machine(MACHINES / "ball-drop.toml")
    assert m.cam is None
    assert m.simulation.gravity == STANDARD_GRAVITY
    # 2.029e-5 lbf*s^2/in (thesis p. 105) = 3.553 g; a 7850 kg/m^3 ball of 0.375 in: 3.552 g
    assert m.mass_of("ball") == pytest.approx(7850 * math.pi / 6 * (0.375 * INCH) ** 3, rel=1e-3)
    (ic,) = m.initial
    assert (ic.mass, ic.displacement, ic.velocity) == ("ball", pytest.approx(INCH), 0.0)
    stop = m.element("stop")
    # Hertz sphere on flat, C = 0.518*E*sqrt(D), E = 2.9e7 psi, D = 0.375 in (eq. C.10): 9.2e6 lbf/in^1.5
    assert 0.518 * 2.9e7 * math.sqrt(0.375) == pytest.approx(9.2e6, rel=2e-3)
    assert stop.coefficient == pytest.approx(9.2e6 * LBF / INCH**1.5, rel=1e-9)
    moved = load_machine(MACHINES / "ball-drop.toml", overrides=["initial.ball.displacement=2.25 in"])
    assert moved.initial[0].displacement == pytest.approx(2.25 * INCH)


def test_barkan_onset_comment_matches_independent_bisection():
    """The jump speed in barkan-follower.toml's comment, recomputed independently.

    Rigid follower on a cycloidal cam leaves it when m*w^2*s'' + P + k*s < 0; the minimum
    over the second half of the rise is found on a fine grid, and w by bisection.
    """
    m = load_machine(MACHINES / "barkan-follower.toml")
    mass = m.mass_of("F")
    spring = m.element("closure")
    rise = m.cam.segments[0]
    h, beta = rise.lift, rise.duration
    n = 20001

    def min_force(w):
        best = math.inf
        for i in range(n):
            u = 0.5 + 0.5 * i / (n - 1)
            s = h * (u - math.sin(2 * math.pi * u) / (2 * math.pi))
            a = w**2 * 2 * math.pi * h / beta**2 * math.sin(2 * math.pi * u)
            best = min(best, mass * a + spring.preload + spring.stiffness * s)
        return best

    lo, hi = 1.0, 200.0
    for _ in range(40):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if min_force(mid) > 0 else (lo, mid)
    onset_rpm = lo * 60 / (2 * math.pi)
    text = (MACHINES / "barkan-follower.toml").read_text()
    assert "447.6 rpm" in text
    assert onset_rpm == pytest.approx(447.6, abs=0.05)
    assert m.cam.speed * 60 / (2 * math.pi) < onset_rpm  # shipped below the onset


def test_dynacam_values_appendix_b():
    m = load_machine(MACHINES / "dynacam-2mass.toml")
    assert m.mass_of("m1") == 4.0 and m.mass_of("m2") == 4.0
    k01, k12 = m.element("k01"), m.element("k12")
    assert (k01.lower, k01.upper, k01.stiffness, k01.preload) == ("ground", "m1", 10_000.0, 100.0)
    assert (k12.lower, k12.upper, k12.stiffness) == ("m1", "m2", 600_000.0)
    assert k01.damping.ratio == k12.damping.ratio == 0.05


# --------------------------------------------------------------------------------------
# bad input: file, TOML, keys, units
# --------------------------------------------------------------------------------------
def test_missing_file(tmp_path):
    path = tmp_path / "nope.toml"
    with pytest.raises(MachineFileError) as info:
        load_machine(path)
    assert info.value.key == ""
    assert str(info.value) == f"{path}: no such machine file"


def test_invalid_toml_names_line_and_column():
    exc = _error(BASE.replace('name = "two masses"', "name = two masses"))
    _check(exc, "", "invalid TOML", "line 4", "column")


def test_unknown_top_key():
    _check(_error(BASE + "\n[simulaton]\ncycles = 1\n"), "simulaton", "unknown key", "did you mean 'simulation'?")


def test_unknown_element_key_did_you_mean():
    exc = _error(BASE.replace('stiffness = "1e5 N/m"', 'stifness = "1e5 N/m"'))
    _check(exc, "element[0].stifness", "unknown key", "did you mean 'stiffness'?")


def test_key_of_another_element_type_is_unknown():
    exc = _error(BASE.replace('stiffness = "1e5 N/m"', 'stiffness = "1e5 N/m"\ngap = "1 mm"'))
    _check(exc, "element[0].gap", "unknown key for a spring element")


def test_wrong_dimension():
    exc = _error(BASE.replace('stiffness = "1e5 N/m"', 'stiffness = "25 lbf"'))
    assert str(exc) == 'm.toml: element[0].stiffness: expected [force]/[length], got "25 lbf"'


@pytest.mark.parametrize("speed", ['"2 Hz"', '"2 1/s"'])
def test_speed_without_angle_unit_rejected(speed):
    """pint treats the radian as dimensionless: "2 Hz" would silently become 2 rad/s."""
    _check(_error(BASE.replace('speed = "120 rpm"', f"speed = {speed}")), "cam.speed", "angular speed")


def test_mil_rejected_for_a_length():
    exc = _error(BASE.replace('gap = "1 mm"', 'gap = "40 mil"'))
    _check(exc, "element[1].gap", '"mil" is ambiguous')


@pytest.mark.parametrize("value", ['"-1 kg"', "0", '"0 lb"'])
def test_nonpositive_mass(value):
    exc = _error(BASE.replace('mass = "1 kg"', f"mass = {value}"))
    _check(exc, "mass[1].mass", "must be greater than 0")


def test_missing_required_keys():
    _check(_error(BASE.replace("schema = 1\n", "")), "schema", "missing required key")
    _check(_error(BASE.replace('speed = "120 rpm"\n', "")), "cam.speed", "missing required key")
    _check(_error(BASE.replace('mass = "2 kg"\n', "")), "mass[0].mass", "missing required key")
    _check(_error(BASE.replace('type = "spring"\n', "")), "element[0].type", "missing required key")
    _check(_error(BASE.replace('between = ["M1", "M2"]\n', "")), "element[0].between", "missing required key")


def test_durations_not_360():
    exc = _error(BASE.replace("duration = 90 }", "duration = 80 }"))
    _check(exc, "cam.segments", "durations add up to 350 deg", "not 360")


def test_fall_larger_than_lift():
    text = BASE.replace('law = "poly345", duration = "90 deg", lift = "10 mm"',
                        'law = "poly345", duration = "90 deg", lift = "12 mm"')
    _check(_error(text), "cam.segments[2].lift", "a fall larger than the preceding lift")


def test_net_lift_not_zero_names_rows():
    text = BASE.replace('law = "poly345", duration = "90 deg", lift = "10 mm"',
                        'law = "poly345", duration = "90 deg", lift = "8 mm"')
    _check(_error(text), "cam.segments", "net lift", "rows 0", "rows 2")


def test_unknown_law():
    exc = _error(BASE.replace('law = "cycloidal"', 'law = "cycloid"'))
    _check(exc, "cam.segments[0].law", 'unknown law "cycloid"', "did you mean 'cycloidal'?")


def test_dwell_with_law():
    exc = _error(BASE.replace('{ motion = "dwell", duration = "90 deg" }',
                              '{ motion = "dwell", law = "cycloidal", duration = "90 deg" }'))
    _check(exc, "cam.segments[1].law", "a dwell has no law")


def test_duration_units():
    """Bare numbers are degrees; "rad" stays radians (pint's radian is dimensionless)."""
    text = BASE.replace('duration = "90 deg" }', 'duration = "1.5707963267948966 rad" }')
    assert load_machine_text(text).cam.segments[1].duration == pytest.approx(math.pi / 2, rel=1e-15)
    text = BASE.replace("duration = 90 }", 'duration = "90" }')
    assert load_machine_text(text).cam.segments[3].duration == pytest.approx(math.pi / 2, rel=1e-15)


def test_angular_lift_needs_arm_and_uses_it():
    text = BASE.replace('"10 mm"', '"4.4 deg"')
    _check(_error(text), "cam.segments[0].lift", "needs cam.arm")
    machine = load_machine_text(text.replace('drives = "M1"', 'drives = "M1"\narm = "6.5 in"'))
    assert machine.cam.segments[0].lift == pytest.approx(6.5 * INCH * math.radians(4.4), rel=1e-12)


@pytest.mark.parametrize(
    ("between", "fragment"),
    [('["M1", "M9"]', 'unknown node "M9"'), ('["M2", "M2"]', "two different nodes"),
     ('["ground", "cam"]', "at least one end must be a mass")],
)
def test_element_nodes(between, fragment):
    _check(_error(BASE.replace('between = ["M1", "M2"]', f"between = {between}")), "element[0].between", fragment)


def test_unknown_node_did_you_mean():
    exc = _error(BASE.replace('between = ["M1", "M2"]', 'between = ["M1", "grund"]'))
    _check(exc, "element[0].between", "did you mean 'ground'?")


def test_drives_not_a_mass():
    _check(_error(BASE.replace('drives = "M1"', 'drives = "M7"')), "cam.drives", "not a mass")


def test_driven_mass_with_initial_condition():
    exc = _error(BASE + '\n[initial.M1]\nvelocity = "1 m/s"\n')
    _check(exc, "initial.M1", "driven by the cam", "prescribed")


def test_driven_mass_in_contact_with_cam():
    text = BASE.replace('between = ["ground", "M2"]', 'between = ["cam", "M1"]')
    _check(_error(text), "element[1].between", "driven by the cam", "could never close or open")


def test_free_mass_connected_to_nothing():
    text = BASE + '\n[[mass]]\nname = "M4"\nmass = "1 kg"\n'
    _check(_error(text), "mass[2]", "M4 is connected to no element")


def test_negative_gap_is_an_interference():
    """A gap may have either sign (spec §10): -1 mm is a contact closed at zero deflection."""
    machine = load_machine_text(BASE.replace('gap = "1 mm"', 'gap = "-1 mm"'))
    assert machine.elements[1].gap == pytest.approx(-1e-3, rel=1e-15)


@pytest.mark.parametrize("e", ["1.2", "-0.1"])
def test_restitution_out_of_range(e):
    text = BASE.replace('stiffness = "1e7 N/m"', f'law = "restitution"\nrestitution = {e}')
    exc = _error(text)
    _check(exc, "element[1].restitution")


def test_power_contact_rejects_damping_ratio():
    text = BASE.replace('stiffness = "1e7 N/m"', 'law = "power"\ncoefficient = "1e10 N/m**1.5"\n'
                        'exponent = 1.5\ndamping_ratio = 0.1')
    _check(_error(text), "element[1].damping_ratio", 'not used by a contact with law = "power"', "Hunt-Crossley")


def test_power_coefficient_dimension_follows_exponent():
    text = BASE.replace('stiffness = "1e7 N/m"', 'law = "power"\ncoefficient = "1e7 lbf/in**1.5"\nexponent = 1.425')
    _check(_error(text), "element[1].coefficient", "expected [force]/[length]^1.425")


def test_damping_and_ratio_both():
    text = BASE.replace("damping_ratio = 0.05", 'damping_ratio = 0.05\ndamping = "10 N*s/m"')
    _check(_error(text), "element[0].damping_ratio", "not both")


def test_duplicate_and_reserved_names():
    _check(_error(BASE.replace('name = "M2"', 'name = "M1"')), "mass[1].name", "duplicate")
    _check(_error(BASE.replace('name = "M2"', 'name = "ground"')), "mass[1].name", "reserved")


def test_no_cam_requires_duration():
    start, end = BASE.index("[cam]"), BASE.index("[[mass]]")
    text = BASE[:start] + BASE[end:]
    _check(_error(text), "simulation.duration", "without [cam]")
    machine = load_machine_text(text.replace("cycles = 2", 'duration = "10 ms"'))
    assert machine.cam is None and machine.simulation.duration == pytest.approx(0.01)


def test_gravity_forms():
    assert load_machine_text(BASE + "gravity = true\n").simulation.gravity == STANDARD_GRAVITY
    assert load_machine_text(BASE + "gravity = false\n").simulation.gravity == 0.0
    assert load_machine_text(BASE + 'gravity = "32.174 ft/s^2"\n').simulation.gravity == pytest.approx(9.80665, rel=1e-5)
    _check(_error(BASE + 'gravity = "9.81 m"\n'), "simulation.gravity", "expected [length]/[time]^2")


def test_cycles_must_be_whole():
    _check(_error(BASE.replace("cycles = 2", "cycles = 1.5")), "simulation.cycles", "whole number")
    _check(_error(BASE.replace("cycles = 2", "cycles = 0")), "simulation.cycles", "at least 1")


# --------------------------------------------------------------------------------------
# cam table CSV
# --------------------------------------------------------------------------------------
def _table_machine(tmp_path: Path, csv_text: str) -> tuple[str, Path]:
    (tmp_path / "profile.csv").write_text(csv_text)
    start = BASE.index("segments = [")
    end = BASE.index("]\n", BASE.index("duration = 90 }")) + 2
    text = BASE[:start] + 'table = "profile.csv"\n' + BASE[end:]
    return text, tmp_path


def test_table_cam_units(tmp_path):
    csv_text = "angle [deg],displacement [in],velocity [in/s]\n0,0,0\n90,0.5,1\n180,0.25,0\n270,0.1,-1\n"
    text, base = _table_machine(tmp_path, csv_text)
    table = load_machine_text(text, base_dir=base).cam.table
    assert table.angle == pytest.approx((0, math.pi / 2, math.pi, 1.5 * math.pi), rel=1e-12)
    assert table.displacement == pytest.approx((0, 0.0127, 0.00635, 0.00254), rel=1e-12)
    assert table.velocity == pytest.approx((0, 0.0254, 0, -0.0254), rel=1e-12)
    assert table.acceleration is None and table.source == "profile.csv"


def test_table_cam_bare_columns(tmp_path):
    text, base = _table_machine(tmp_path, "angle,displacement\n0,0\n90,0.01\n180,0.005\n270,0.001\n")
    table = load_machine_text(text, base_dir=base).cam.table
    assert table.angle[1] == pytest.approx(math.pi / 2)  # bare angle column: degrees
    assert table.displacement[1] == 0.01  # bare displacement: metres


def test_table_cam_angular_displacement_needs_arm(tmp_path):
    text, base = _table_machine(tmp_path, "angle [deg],displacement [deg]\n0,0\n90,4\n180,2\n270,1\n")
    _check(_error(text, base_dir=base), "cam.table", "set cam.arm")
    text = text.replace('drives = "M1"', 'drives = "M1"\narm = "0.5 m"')
    assert load_machine_text(text, base_dir=base).cam.table.displacement[1] == pytest.approx(0.5 * math.radians(4))


def test_table_cam_non_monotonic(tmp_path):
    text, base = _table_machine(tmp_path, "angle [deg],displacement [mm]\n0,0\n90,1\n80,2\n270,1\n")
    _check(_error(text, base_dir=base), "cam.table", "profile.csv line 4", "must increase strictly")


def test_table_cam_missing_column(tmp_path):
    text, base = _table_machine(tmp_path, "angle [deg],velocity [mm/s]\n0,0\n90,1\n180,2\n270,1\n")
    _check(_error(text, base_dir=base), "cam.table", "missing column 'displacement'")


def test_table_cam_full_revolution(tmp_path):
    text, base = _table_machine(tmp_path, "angle,displacement\n0,0\n90,1e-3\n180,2e-3\n360,0\n")
    _check(_error(text, base_dir=base), "cam.table", "span 360 deg")


def test_table_cam_missing_file(tmp_path):
    text, base = _table_machine(tmp_path, "")
    _check(_error(text.replace("profile.csv", "other.csv"), base_dir=base), "cam.table", "no such file")


def test_table_and_segments_both(tmp_path):
    text = BASE.replace('drives = "M1"', 'drives = "M1"\ntable = "x.csv"')
    _check(_error(text), "cam.table", "not both")


# --------------------------------------------------------------------------------------
# overrides
# --------------------------------------------------------------------------------------
def test_overrides_apply_before_validation():
    m = load_machine_text(
        BASE,
        overrides=[
            "cam.speed=150 rpm",
            "cam.segments[2].lift=10 mm",
            "mass.M2.mass=1.7 lb",
            "element.seat.stiffness=9e6",
            "simulation.cycles=3",
            "initial.M2.velocity=-0.2 m/s",
            'machine.name="renamed"',
        ],
    )
    assert m.cam.speed == pytest.approx(150 * math.pi / 30)
    assert m.mass_of("M2") == pytest.approx(1.7 * LB)
    assert m.element("seat").stiffness == 9e6
    assert m.simulation.cycles == 3
    assert m.initial[0].mass == "M2" and m.initial[0].velocity == -0.2
    assert m.name == "renamed"
    assert "--set cam.speed=150 rpm" in m.text  # the stored text reproduces the overridden machine
    assert load_machine_text(m.text).cam.speed == m.cam.speed


def test_override_unknown_key_did_you_mean():
    _check(_error(BASE, overrides=["cam.sped=100 rpm"]), "cam.sped", "unknown key", "did you mean 'cam.speed'?")
    _check(_error(BASE, overrides=["element.seat.stifness=1"]), "element.seat.stifness", "did you mean 'element.seat.stiffness'?")
    _check(_error(BASE, overrides=["mass.M22.mass=1 kg"]), "mass.M22.mass", "no mass named 'M22'", "did you mean 'M2'?")
    _check(_error(BASE, overrides=["mass.X.mass=1 kg"]), "mass.X.mass", "no mass named 'X'", "valid: M1, M2")
    _check(_error(BASE, overrides=["cam.segments[9].lift=1 mm"]), "cam.segments[9].lift", "no segment 9")
    _check(_error(BASE, overrides=["simulaton.cycles=1"]), "simulaton.cycles", "did you mean 'simulation'?")
    _check(_error(BASE, overrides=["cam.speed"]), "cam.speed", "KEY=VALUE")


def test_override_bad_value_names_key_and_override():
    exc = _error(BASE, overrides=["element.K12.stiffness=25 lbf"])
    _check(exc, "element[0].stiffness", "expected [force]/[length]", "from --set element.K12.stiffness=25 lbf")


def test_override_key_absent_from_file_may_be_set():
    m = load_machine_text(BASE, overrides=["element.seat.transducer=true", "simulation.gravity=true"])
    assert m.element("seat").transducer and m.simulation.gravity == STANDARD_GRAVITY


def test_apply_override_and_override_keys():
    import tomllib

    doc = tomllib.loads(BASE)
    apply_override(doc, "mass.M1.mass=3 kg", "m.toml")
    assert doc["mass"][0]["mass"] == "3 kg"
    apply_override(doc, "simulation.cycles=4", "m.toml")
    assert doc["simulation"]["cycles"] == 4  # parsed as TOML: an integer
    keys = override_keys(doc)
    for key in ("cam.speed", "cam.segments[3].duration", "mass.M2.mass", "element.seat.gap",
                "element.K12.stiffness", "simulation.sample_rate", "initial.M2.displacement"):
        assert key in keys
    assert "initial.M1.velocity" not in keys  # M1 is driven
    assert "element.K12.gap" not in keys  # not a spring key
    for key in keys:  # every listed key is accepted by apply_override
        apply_override(tomllib.loads(BASE), f"{key}=1", "m.toml")


def test_machine_to_dict_units_and_damping():
    d = machine_to_dict(load_machine_text(BASE))
    assert d["units"]["stiffness"] == "N/m" and d["units"]["c"] == "N*s/m"
    k12 = d["elements"][0]
    assert k12["c"] == pytest.approx(2 * 0.05 * math.sqrt(1e5 * 1.0), rel=1e-12)  # m_ref = M2 (upper)
    assert d["masses"][0]["driven"] is True


def test_table_cam_below_its_base_circle_warns(tmp_path):
    """Issue 26: a table cam whose lift goes below 0 (below the base circle) got no warning.

    Reference: the table's own rows (-0.5 mm at 270 deg is below 0, so the lowest lift is at
    most that); a table with every row
    at or above 0 and a gentle shape gets no such warning."""
    from camsim.cam import CamProgram

    text, base = _table_machine(tmp_path, "angle [deg],displacement [mm]\n0,0\n90,10\n180,5\n270,-0.5\n")
    program = CamProgram(load_machine_text(text, base_dir=base).cam)
    (warning,) = [w for w in program.warnings if "base circle" in w]
    assert "1 rows are below 0" in warning
    assert float(warning.split("(lift 0): ")[1].split(" m")[0]) <= -0.0005  # at least the row's dip
    text, base = _table_machine(tmp_path, "angle [deg],displacement [mm]\n0,0\n90,10\n180,20\n270,10\n")
    assert not [w for w in CamProgram(load_machine_text(text, base_dir=base).cam).warnings if "base circle" in w]


# ---------------------------------------------------------------------------------------
# Issue 42: a file is parsed once per process; its bare-number notes are computed once per text
# ---------------------------------------------------------------------------------------
def _bare_text() -> str:
    import re

    text = (Path(__file__).resolve().parents[1] / "machines" / "cdtm.toml").read_text()
    text = re.sub(r'preload = "[^"]*"', "preload = 125", text, count=1)  # bare numbers in a file with units
    return re.sub(r'gap = "[^"]*"', "gap = 0.0016", text, count=1)


@pytest.mark.parametrize("overrides", [
    [], ["element.K23.preload=28 lbf"], ["element.seat.gap=0.06 in"], ["element.seat.stiffness=8e6"],
    ["element.K01.preload=30"], ["cam.speed=100 rpm", "simulation.cycles=2"],
])
def test_bare_number_notes_as_from_the_overridden_document(overrides):
    """Reference: camsim.machine.notes.bare_number_notes walking the overridden document itself
    (what every load did before the file's rows were kept per text)."""
    from camsim.display import option_quantities, written_units
    from camsim.machine import loader, notes

    text = _bare_text()
    doc = loader._parsed(text, "x.toml")
    origin = {loader._apply_override(doc, a, "x.toml"): a for a in overrides}
    shown = written_units(text, option_quantities(overrides))
    assert loader._document_notes(doc, text, shown, origin) == notes.bare_number_notes(doc, shown, skip=origin)


def test_a_parsed_file_is_not_changed_by_an_earlier_loads_overrides():
    text = _bare_text()
    bent = load_machine_text(text, "x.toml", overrides=["element.K01.preload=300 N", "simulation.cycles=3"])
    plain = load_machine_text(text, "x.toml")
    assert bent.simulation.cycles == 3 and plain.simulation.cycles != 3
    assert [e.preload for e in plain.elements if e.name == "K01"] == [125.0]

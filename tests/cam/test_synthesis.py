"""Motion synthesis (issue 27): polynomial, constant-velocity and spline segments."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.interpolate import make_interp_spline

from camsim.cam import CamProgram
from camsim.errors import MachineFileError
from camsim.machine.loader import load_machine

OMEGA = 2 * math.pi  # 60 rpm
MM = 1e-3


def machine(segments, speed="60 rpm"):
    return load_machine({
        "schema": 1, "machine": {"name": "synthesis"},
        "cam": {"speed": speed, "drives": "M1", "segments": segments},
        "mass": [{"name": "M1", "mass": "1 kg"}],
    })


def double_dwell(rise_law, fall_law="poly345", **rise_keys):
    rise = {"motion": "rise", "law": rise_law, "duration": "90 deg", "lift": "10 mm", **rise_keys}
    return [rise, {"motion": "dwell", "duration": "90 deg"},
            {"motion": "fall", "law": fall_law, "duration": "90 deg", "lift": "10 mm"},
            {"motion": "dwell", "duration": "90 deg"}]


@pytest.mark.parametrize("continuity, law", [(2, "poly345"), (3, "poly4567")])
def test_polynomial_between_dwells_is_the_standard_polynomial(continuity, law):
    """Reference: the closed-form 3-4-5 and 4-5-6-7 laws (camsim.cam.laws, checked against
    Norton's factors in test_cam_laws). Tolerance 1e-12 of each trace's peak, at 4001 samples."""
    a = CamProgram(machine(double_dwell("polynomial", continuity=continuity)).cam)
    b = CamProgram(machine(double_dwell(law)).cam)
    t = np.linspace(0.0, a.period, 4001)
    for x, y in zip(a.svaj(t), b.svaj(t)):
        assert np.max(np.abs(x - y)) <= 1e-12 * np.max(np.abs(y))


def test_velocity_matching_rise_closed_form():
    """A rise from a dwell into a constant-velocity stretch (conveyor match), continuity 2.

    Reference: the quintic derived by hand for y(0) = y'(0) = y''(0) = 0, y(1) = 1, y'(1) = m,
    y''(1) = 0 (m = V·β/(ω·h), the normalised end slope): y = (10 − 4m)u³ + (7m − 15)u⁴ +
    (6 − 3m)u⁵ (it reduces to 3-4-5 at m = 0). Norton's printed velocity-matching
    coefficients were not available to us; this closed form replaces them. Tolerance 1e-12
    of the lift (s) and of each derivative's peak."""
    v_match = 0.2  # m/s at the roller, 60 rpm
    segs = [{"motion": "dwell", "duration": "90 deg"},
            {"motion": "rise", "law": "polynomial", "continuity": 2, "duration": "60 deg", "lift": "12 mm"},
            {"motion": "rise", "law": "constant-velocity", "duration": "30 deg", "velocity": "200 mm/s"},
            {"motion": "dwell", "duration": "90 deg"}]
    cv_lift = v_match * math.radians(30) / OMEGA
    segs.append({"motion": "fall", "law": "cycloidal", "duration": "90 deg", "lift": f"{12 + cv_lift * 1e3!r} mm"})
    program = CamProgram(machine(segs).cam)
    beta, h = math.radians(60), 12 * MM
    m = v_match * beta / (OMEGA * h)
    c = {3: 10 - 4 * m, 4: 7 * m - 15, 5: 6 - 3 * m}
    u = np.linspace(0.0, 1.0, 501)[1:]  # (0, 1]: the jerk jumps at u = 0 (continuity 2)
    theta = math.radians(90) + beta * u
    got = program.lift_derivatives(theta, 3, side="left")  # u = 1 from inside the segment
    for n in range(4):
        want = h * sum(cn * math.perm(p, n) * u ** (p - n) for p, cn in c.items() if p >= n) / beta**n
        assert np.max(np.abs(got[n] - want)) <= 1e-12 * np.max(np.abs(want))


def test_boundary_conditions_hold_in_the_given_units():
    """Explicit start/end values (v, a, j in mm/s^k at cam.speed) are met at the ends to 1e-10
    relative, in the units given (reference: the values written in the file)."""
    rise = {"motion": "rise", "law": "polynomial", "duration": "80 deg", "lift": "10 mm",
            "start": {"v": "50 mm/s", "a": "2 m/s^2", "j": "-30 m/s^3"}, "end": {"v": "-40 mm/s", "a": "1 m/s^2"}}
    segs = [rise, {"motion": "fall", "law": "polynomial", "duration": "100 deg", "lift": "10 mm"},
            {"motion": "dwell", "duration": "180 deg"}]
    program = CamProgram(machine(segs).cam)
    t0 = 0.0
    t1 = math.radians(80) / OMEGA
    s0, v0, a0, j0 = (float(x) for x in program.svaj(t0))
    s1, v1, a1, _ = (float(x) for x in program.svaj(t1, side="left"))
    assert v0 / MM == pytest.approx(50, rel=1e-10)
    assert a0 == pytest.approx(2, rel=1e-10)
    assert j0 == pytest.approx(-30, rel=1e-10)
    assert s1 / MM == pytest.approx(10, rel=1e-10)
    assert v1 / MM == pytest.approx(-40, rel=1e-10)
    assert a1 == pytest.approx(1, rel=1e-10)
    # the fall's defaults: the rise's given end values, and zeros at the dwell
    d_left = program.lift_derivatives(np.array([math.radians(80)]), 3, side="left")[:, 0]
    d_right = program.lift_derivatives(np.array([math.radians(80)]), 3, side="right")[:, 0]
    assert np.allclose(d_right, d_left, rtol=1e-10, atol=1e-12 * np.abs(d_left).max())


def test_polynomial_neighbours_join_smoothly_and_points_are_hit():
    """Two polynomial rises that leave their shared join to default are solved together and
    join with continuity up to 2·continuity (the join values are the system's unknowns);
    an interior point is hit. Reference: left and right one-sided derivatives computed
    independently from each segment's own polynomial; the written point value. 1e-9
    relative."""
    segs = [{"motion": "dwell", "duration": "60 deg"},
            {"motion": "rise", "law": "polynomial", "duration": "60 deg", "lift": "10 mm",
             "points": [{"at": "20 deg", "s": "2 mm"}]},
            {"motion": "rise", "law": "polynomial", "duration": "40 deg", "lift": "8 mm"},
            {"motion": "dwell", "duration": "100 deg"},
            {"motion": "fall", "law": "poly4567", "duration": "100 deg", "lift": "18 mm"}]
    program = CamProgram(machine(segs).cam)
    join = np.array([math.radians(120)])
    left = program.lift_derivatives(join, 6, side="left")[:, 0]
    right = program.lift_derivatives(join, 6, side="right")[:, 0]
    scale = np.maximum(np.abs(left), np.abs(right)).max()
    assert np.all(np.abs(left - right) <= 1e-9 * scale)
    assert program.lift(np.radians(80.0))[0] == pytest.approx(2 * MM, rel=1e-9)


def test_spline_matches_scipy_and_finite_differences():
    """Reference: scipy.interpolate.make_interp_spline built here from the same points and
    end derivatives (zero next to dwells), in normalised u; 1e-12 of the lift. Derivatives
    against central finite differences of s (step 1e-4 rad): 1e-6 relative."""
    pts = [("20 deg", 2.0), ("45 deg", 6.5), ("70 deg", 9.0)]
    segs = double_dwell("spline", points=[{"at": a, "s": f"{s} mm"} for a, s in pts])
    program = CamProgram(machine(segs).cam)
    x = np.array([0.0] + [float(a.split()[0]) / 90 for a, _ in pts] + [1.0])
    y = np.array([0.0] + [s for _, s in pts] + [10.0]) * MM
    ref = make_interp_spline(x, y, k=5, bc_type=([(1, 0.0), (2, 0.0)], [(1, 0.0), (2, 0.0)]))
    u = np.linspace(0, 1, 777)
    theta = math.radians(90) * u
    got = program.lift(theta, side="left")
    assert np.max(np.abs(got[0] - ref(u))) <= 1e-12 * 10 * MM
    step = 1e-4
    lo = program.lift(theta[1:-1] - step)
    hi = program.lift(theta[1:-1] + step)
    for n in (1, 2, 3):
        fd = (hi[n - 1] - lo[n - 1]) / (2 * step)
        assert np.max(np.abs(fd - got[n][1:-1])) <= 1e-6 * np.max(np.abs(got[n]))


def test_constant_velocity_with_velocity_sets_the_lift():
    """Reference: lift = V·β/ω by hand (200 mm/s for 30° at 60 rpm = 16.667 mm), v = V
    inside the segment, to 1e-12 relative."""
    segs = [{"motion": "rise", "law": "constant-velocity", "duration": "30 deg", "velocity": "200 mm/s"},
            {"motion": "dwell", "duration": "150 deg"},
            {"motion": "fall", "law": "constant-velocity", "duration": "180 deg", "lift": f"{200 / 12!r} mm"}]
    m = machine(segs)
    assert m.cam.segments[0].lift == pytest.approx(0.2 * math.radians(30) / OMEGA, rel=1e-12)
    program = CamProgram(m.cam)
    v = program.svaj(0.01)[1]
    assert float(v) == pytest.approx(0.2, rel=1e-12)
    assert any("velocity jumps" in w for w in program.warnings)


@pytest.mark.parametrize("rise, key, words", [
    ({"points": [{"at": "95 deg", "s": "2 mm"}]}, "cam.segments[0].points[0].at", "outside the segment"),
    ({"points": [{"at": "30 deg", "s": "2 mm"}, {"at": "30 deg", "s": "3 mm"}]}, "cam.segments[0].points[1].at",
     "increasing"),
    ({"points": [{"at": "30 deg", "s": "2 mm", "v": "1 m/s"}, {"at": "30.0000000001 deg", "s": "2 mm"}]},
     "cam.segments[0]", "singular"),
    ({"velocity": "1 m/s"}, "cam.segments[0].velocity", "constant-velocity"),
])
def test_bad_conditions_name_the_segment(rise, key, words):
    """Bad input names the segment key (one MachineFileError)."""
    with pytest.raises(MachineFileError) as info:
        machine(double_dwell("polynomial", **rise))
    assert info.value.key == key
    assert words in str(info.value)


def test_spline_overdetermined_end_is_an_error():
    with pytest.raises(MachineFileError) as info:
        machine(double_dwell("spline", degree=3, end={"a": "1 m/s^2"}, points=[{"at": "45 deg", "s": "5 mm"}]))
    assert info.value.key == "cam.segments[0].end"
    assert "overdetermined" in str(info.value)


def test_wild_overshoot_is_a_warning():
    """A point far above the segment's lift makes the polynomial leave its end range by more
    than its lift: a warning, not an error."""
    program = CamProgram(machine(double_dwell("polynomial", points=[{"at": "45 deg", "s": "40 mm"}])).cam)
    assert any("overshoots" in w for w in program.warnings)


def test_set_reaches_the_new_keys():
    """--set grammar: cam.segments[i].end.v, cam.segments[i].points[k].s, cam.compensation.speed
    (reference: the value written on the command line, converted by hand)."""
    segs = double_dwell("polynomial", points=[{"at": "45 deg", "s": "5 mm"}])
    doc = {"schema": 1, "machine": {"name": "synthesis"},
           "cam": {"speed": "60 rpm", "drives": "M1", "segments": segs},
           "mass": [{"name": "M1", "mass": "1 kg"}]}
    m = load_machine(doc, {"cam.segments[0].end.v": "-3 mm/s", "cam.segments[0].points[0].s": "6 mm"})
    assert m.cam.segments[0].end == ((1, pytest.approx(-3e-3)),)
    assert m.cam.segments[0].points[0].s == pytest.approx(6e-3)
    with pytest.raises(MachineFileError) as info:
        load_machine(doc, {"cam.segments[0].end.q": 1})
    assert "unknown key" in str(info.value)
    from camsim.machine.keys import unit as key_unit

    assert key_unit("cam.segments[2].end.a") == "m/s^2"
    assert key_unit("cam.compensation.speed") == "rad/s"

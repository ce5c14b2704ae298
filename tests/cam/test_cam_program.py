"""The segment cam program: thesis cam peaks, joins, warnings, boundary times, wrap."""

from __future__ import annotations

import math

import numpy as np
import pytest

from camsim.cam.peaks import sample_revolution
from camsim.cam.program import CamProgram
from camsim.machine.description import LAWS, Cam, Segment

INCH = 0.0254
RATIO = 0.63648  # spec §2: (13.5/6.5)·(2.375/7.75)
OMEGA_120RPM = 4 * math.pi  # 120 rpm [rad/s]


def deg(x: float) -> float:
    return math.radians(x)


def thesis_cam(start_angle: float = 0.0) -> Cam:
    """Thesis table 2 (CDTM): 120 rpm, 0.5 in lift at the roller, ratio 0.63648."""
    lift = 0.5 * INCH
    rows = [
        ("rise", "poly4567"),
        ("dwell", None),
        ("fall", "poly345"),
        ("dwell", None),
        ("rise", "modified-trapezoid"),
        ("dwell", None),
        ("fall", "modified-sine"),
        ("dwell", None),
    ]
    segments = tuple(
        Segment(motion, law, deg(50 if law else 40), lift if law else 0.0) for motion, law in rows
    )
    return Cam(speed=OMEGA_120RPM, segments=segments, ratio=RATIO, start_angle=start_angle)


def double_dwell(law: str, speed: float = 10.0, lift: float = 0.01, ratio: float = 1.0) -> Cam:
    """Rise 90°, dwell 90°, fall 90°, dwell 90° with one law."""
    return Cam(
        speed=speed,
        segments=(
            Segment("rise", law, deg(90), lift),
            Segment("dwell", None, deg(90), 0.0),
            Segment("fall", law, deg(90), lift),
            Segment("dwell", None, deg(90), 0.0),
        ),
        ratio=ratio,
    )


# Hand computation for the thesis cam, every rise/fall has h = 0.5 in × 0.63648 =
# 0.008083296 m on the model axis and ω/β = 4π / (50π/180) = 14.4 1/s, so
# h·ω/β = 0.1163994624 m/s and h·(ω/β)² = 1.676152258560 m/s². Norton's coefficients
# (Design of Machinery, table 8-2) then give the peaks below; 0.1 % tolerance (Norton's
# 4-5-6-7 Ca = 7.5107 is 0.033 % below the exact 7.5132).
H_V = 0.1163994624
H_A = 1.676152258560
THESIS_PEAKS = {
    1: (2.1875 * H_V, 7.5107 * H_A),  # poly4567 rise
    3: (1.875 * H_V, 5.7735 * H_A),  # poly345 fall
    5: (2.0 * H_V, 4.8881 * H_A),  # modified trapezoid rise
    7: (1.7596 * H_V, 5.5280 * H_A),  # modified sine fall
}


def test_thesis_cam_peaks_against_hand_computation():
    program = CamProgram(thesis_cam())
    peaks = program.segment_peaks()
    assert [p["index"] for p in peaks] == list(range(1, 9))
    for p in peaks:
        assert p["duration_deg"] == pytest.approx(50 if p["law"] else 40, rel=1e-12)
        if p["index"] in THESIS_PEAKS:
            v, a = THESIS_PEAKS[p["index"]]
            assert p["lift_m"] == pytest.approx(0.008083296, rel=1e-12)
            assert p["peak_velocity"] == pytest.approx(v, rel=1e-3)
            assert p["peak_acceleration"] == pytest.approx(a, rel=1e-3)
        else:
            assert p["lift_m"] == 0.0 and p["peak_velocity"] == 0.0 and p["peak_acceleration_deg"] is None
    assert program.warnings == []
    # Peak velocity of each rise/fall at mid-segment (all four laws are symmetric).
    assert [peaks[i]["peak_velocity_deg"] for i in (0, 2, 4, 6)] == pytest.approx([25, 115, 205, 295])


def test_thesis_cam_svaj_reaches_the_reported_peaks():
    """svaj sampled every 0.01° over a revolution: its max |v|, |a| per segment equal the
    reported peaks to 1e-6 (sampling), and s spans 0 … 8.083296 mm."""
    program = CamProgram(thesis_cam())
    t = np.linspace(0, program.period, 36_001)
    s, v, a, _ = program.svaj(t)
    assert s.min() == pytest.approx(0.0, abs=1e-15)
    assert s.max() == pytest.approx(0.008083296, rel=1e-12)
    theta = np.degrees(program.angle(t))
    for p in program.segment_peaks():
        inside = (theta >= p["start_deg"]) & (theta <= p["start_deg"] + p["duration_deg"])
        assert np.max(np.abs(v[inside])) == pytest.approx(p["peak_velocity"], rel=1e-6, abs=1e-15)
        assert np.max(np.abs(a[inside])) == pytest.approx(p["peak_acceleration"], rel=1e-6, abs=1e-12)


def test_velocity_and_acceleration_are_time_derivatives():
    """v, a, j against a 4th-order central difference in time of s, v, a (step 1e-6 s):
    agree to 1e-6 of the peak, away from the joins (where j jumps)."""
    program = CamProgram(thesis_cam(start_angle=deg(17)))
    dt = 1e-6
    t = np.linspace(0, program.period, 2001)
    theta = np.mod(np.degrees(program.angle(t)), 360)
    joins = np.array([0, 50, 90, 140, 180, 230, 270, 320, 360])
    t = t[np.min(np.abs(theta[:, None] - joins[None, :]), axis=1) > 0.01]

    def fd(k):
        f = lambda x: program.svaj(x)[k]  # noqa: E731
        return (f(t - 2 * dt) - 8 * f(t - dt) + 8 * f(t + dt) - f(t + 2 * dt)) / (12 * dt)

    s, v, a, j = program.svaj(t)
    for k, exact in ((0, v), (1, a), (2, j)):
        assert np.max(np.abs(fd(k) - exact)) < 1e-6 * np.max(np.abs(exact))


@pytest.mark.parametrize("law", LAWS)
def test_continuity_at_dwell_joins(law):
    """s and v are continuous at every join for every law (to 1e-12 of their peak);
    a too, except for the harmonic law, whose jump is h·(π²/2)·(ω/β)² (hand formula)."""
    speed, lift, ratio = 10.0, 0.01, 0.5
    program = CamProgram(double_dwell(law, speed, lift, ratio))
    peak_s, peak_v = ratio * lift, max(p["peak_velocity"] for p in program.segment_peaks())
    peak_a = max(p["peak_acceleration"] for p in program.segment_peaks())
    for join in (0.0, 90.0, 180.0, 270.0):
        th = deg(join)
        before = program.lift(np.array([th - 1e-9 if join else 2 * math.pi - 1e-9]))
        after = program.lift(np.array([th]))
        ds = ratio * abs(after[0][0] - before[0][0])
        dv = ratio * speed * abs(after[1][0] - before[1][0])
        da = ratio * speed**2 * abs(after[2][0] - before[2][0])
        assert ds < 1e-9 * peak_s  # 1e-9 rad away: s moves by at most v·1e-9
        assert dv < 1e-7 * peak_v
        if law == "harmonic":
            assert da == pytest.approx(ratio * lift * np.pi**2 / 2 * (speed / deg(90)) ** 2, rel=1e-6)
        else:
            assert da < 1e-6 * peak_a
    if law == "harmonic":
        assert len(program.warnings) == 4
        assert all(w.startswith("acceleration jumps by ") for w in program.warnings)
        assert "at 90 deg (segment 1 harmonic rise -> segment 2 dwell)" in program.warnings[0]
        assert "at 0 deg (segment 4 dwell -> segment 1 harmonic rise)" in program.warnings[-1]
    else:
        assert program.warnings == []


def test_harmonic_rise_into_harmonic_fall_does_not_warn():
    """Equal harmonic rise and fall meet with equal accelerations: no jump, no warning.
    (The warnings come from the values, not from a list of laws.)"""
    cam = Cam(
        speed=5.0,
        segments=(
            Segment("rise", "harmonic", deg(180), 0.01),
            Segment("fall", "harmonic", deg(180), 0.01),
        ),
    )
    assert CamProgram(cam).warnings == []


def test_lift_that_does_not_return_warns_of_a_displacement_jump():
    cam = Cam(speed=5.0, segments=(Segment("rise", "cycloidal", deg(180), 0.01), Segment("dwell", None, deg(180), 0)))
    (message,) = CamProgram(cam).warnings
    assert message == "displacement jumps by -0.01 m at 0 deg (segment 2 dwell -> segment 1 cycloidal rise)"


def test_boundary_times_over_two_revolutions():
    """θ0 = 30°, 120 rpm = 720 °/s: the joins 50, 90, …, 720° lie in (0, 2T) = (0, 1 s),
    at t = (θ − 30°)/(720 °/s) (hand computation)."""
    program = CamProgram(thesis_cam(start_angle=deg(30)))
    assert program.period == pytest.approx(0.5, rel=1e-15)
    joins = [50, 90, 140, 180, 230, 270, 320, 360]
    expected = np.array([(j + 360 * k - 30) / 720 for k in (0, 1) for j in joins])
    got = program.boundary_times(0.0, 2 * program.period)
    np.testing.assert_allclose(got, expected, rtol=0, atol=1e-14)
    # Open interval: starting exactly on a boundary excludes it.
    got2 = program.boundary_times(got[0], got[3])
    np.testing.assert_array_equal(got2, got[1:3])
    assert program.boundary_times(0.2, 0.2).size == 0


def test_boundary_time_samples_the_segment_that_starts_there():
    """At a boundary time, as computed, svaj gives the new segment's value: a harmonic rise
    starting at 0° has a = ratio·h·(π²/2)·(ω/β)² at u = 0, where the dwell before has 0."""
    speed, lift = 10.0, 0.01
    program = CamProgram(double_dwell("harmonic", speed, lift))
    times = program.boundary_times(0.0, 3 * program.period)
    theta = np.mod(np.degrees(program.angle(times)), 360)
    starts_rise = np.isclose(theta, 0.0, atol=1e-9) | np.isclose(theta, 360.0, atol=1e-9)
    assert starts_rise.sum() == 2  # at 1·T and 2·T
    a = program.svaj(times)[2]
    a0 = lift * np.pi**2 / 2 * (speed / deg(90)) ** 2
    np.testing.assert_allclose(a[starts_rise], a0, rtol=1e-12)
    starts_dwell = np.isclose(theta, 90.0) | np.isclose(theta, 270.0)
    np.testing.assert_array_equal(a[starts_dwell], 0.0)


def test_svaj_scalar_like_and_across_the_wrap():
    program = CamProgram(thesis_cam(start_angle=deg(350)))
    s, v, a, j = program.svaj(0.0)
    assert all(np.ndim(x) == 0 for x in (s, v, a, j))
    assert float(s) == 0.0  # 350° is in the last dwell, height 0
    s1 = program.svaj(np.array([0.0]))[0]
    assert s1.shape == (1,)
    # Across the wrap 360° -> 0° (10° after t = 0): s and v continuous, poly4567 rise starts.
    t_wrap = deg(10) / program.speed
    eps = 1e-7
    s, v, a, _ = program.svaj(np.array([t_wrap - eps, t_wrap, t_wrap + eps]))
    assert s[0] == 0.0 and v[0] == 0.0
    assert s[1] == pytest.approx(0.0, abs=1e-15)
    # poly4567: s ≈ 35 h u⁴ just after the start; u = ω·eps/β.
    u = program.speed * eps / deg(50)
    assert s[2] == pytest.approx(RATIO * 0.5 * INCH * 35 * u**4, rel=1e-5)
    # A second revolution gives the same values.
    t = np.linspace(0, program.period, 1001)
    np.testing.assert_allclose(program.svaj(t + program.period)[0], program.svaj(t)[0], rtol=0, atol=1e-15)


def test_no_cam():
    program = CamProgram(None)
    assert program.speed == 0.0 and program.period == math.inf
    for x in program.svaj(np.linspace(0, 1, 5)):
        np.testing.assert_array_equal(x, 0.0)
    assert program.boundary_times(0, 10).size == 0
    assert program.segment_peaks() == [] and program.warnings == []
    with pytest.raises(ValueError, match="no cam"):
        sample_revolution(program)


def test_durations_must_add_up_to_a_revolution():
    cam = Cam(speed=1.0, segments=(Segment("rise", "cycloidal", deg(180), 0.01), Segment("fall", "cycloidal", deg(170), 0.01)))
    with pytest.raises(ValueError, match="add up to 350 deg"):
        CamProgram(cam)


def test_sample_revolution():
    program = CamProgram(thesis_cam(start_angle=deg(30)))
    data = sample_revolution(program, 720)
    assert data["time"].shape == (720,)
    assert data["time"][1] == pytest.approx(0.5 / 720, rel=1e-14)
    assert data["angle"][0] == pytest.approx(30.0) and data["angle"][-1] == pytest.approx(30 + 359.5)

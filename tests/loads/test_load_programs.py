"""Load programs (camsim.loads.programs) as the engine reads them: [F, Ḟ, F̈, F⃛] and break times.

References: each derivative channel against a central difference of the channel below it
(an independent check of the exact derivatives, away from the break times, 1e-6 relative with
a step of 1e-6 of the program's time scale); the break times against the instants the program
is written with (segment joins, the modified trapezoid's inner kinks at 1/8, 3/8, 5/8, 7/8 of
its segment, a table's rows, a sine's start); one instant (``channels_at``) equal to the array
path (``channels``) to 1e-15 relative, on both sides of every break.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from camsim.cam.program import CamProgram
from camsim.cam.description import Cam, Segment
from camsim.loads.description import Load, LoadTable, Sine
from camsim.loads.inputs import LoadedInput, engine_input
from camsim.loads.programs import AngleLoad, AngleTable, SineLoad, TimeTable, load_program

OMEGA = 2 * math.pi * 4.0  # 240 rpm
DEG = math.pi / 180.0


class _Machine:
    """The little of a machine a load program reads: its cams (speed, start angle, phase)."""

    def __init__(self, cams):
        self.cams = cams


SEGMENTS = (Segment("dwell", None, 60 * DEG, 0.0), Segment("rise", "modified-trapezoid", 80 * DEG, 90.0),
            Segment("dwell", None, 40 * DEG, 0.0), Segment("fall", "cycloidal", 100 * DEG, 90.0),
            Segment("dwell", None, 80 * DEG, 0.0))
CAM = Cam(speed=OMEGA, segments=(Segment("rise", "cycloidal", math.pi, 0.01), Segment("fall", "cycloidal", math.pi, 0.01)),
          start_angle=10 * DEG)


def _programs():
    machine = _Machine((CAM,))
    return {
        "segments": load_program(Load("p", "M", "segments", segments=SEGMENTS, base=-10.0), machine),
        "angle table": load_program(Load("t", "M", "table", table=LoadTable("angle", tuple(np.radians(
            [0, 100, 130, 130, 200, 360])), (0.0, 0.0, 40.0, 10.0, 0.0, 0.0))), machine),
        "time table": load_program(Load("u", "M", "table", table=LoadTable("time", (-1.0, 0.02, 0.04, 0.09, 0.09, 0.2),
                                                                           (0.0, 0.0, 15.0, 15.0, -5.0, 0.0))), machine, 0.05),
        "sine": load_program(Load("s", "M", "sine", sine=Sine(6.0, 31.0, 15 * DEG, 1.0, 0.05)), machine, 0.05),
    }


def _expected_breaks(name: str) -> np.ndarray:
    """The instants in (0, 0.25 s) where each program is written not smooth."""
    theta0 = CAM.start_angle
    if name == "segments":
        joins = np.array([0.0, 60.0, 140.0, 180.0, 280.0]) * DEG
        inner = (60.0 + 80.0 * np.array([1, 3, 5, 7]) / 8.0) * DEG
        angles = np.concatenate([joins, joins + 2 * math.pi, inner, inner + 2 * math.pi])
    elif name == "angle table":
        rows = np.radians([0.0, 100.0, 130.0, 200.0])
        angles = np.concatenate([rows, rows + 2 * math.pi])
    elif name == "time table":
        times = np.array([0.02, 0.04, 0.09, 0.2]) + 0.05
        return np.sort(times[(times > 0) & (times < 0.25)])
    else:
        return np.array([0.1])
    times = (angles - theta0) / OMEGA
    return np.sort(times[(times > 0) & (times < 0.25)])


@pytest.mark.parametrize("name", ["segments", "angle table", "time table", "sine"])
def test_break_times_are_the_instants_the_program_is_written_with(name):
    program = _programs()[name]
    assert np.allclose(program.break_times(0.0, 0.25), _expected_breaks(name), rtol=0, atol=1e-14)


@pytest.mark.parametrize("name", ["segments", "angle table", "time table", "sine"])
def test_each_channel_is_the_derivative_of_the_one_before(name):
    """Away from the breaks, channel d + 1 is the central difference of channel d (step
    1e-6 s), to 1e-6 of the channel's scale."""
    program = _programs()[name]
    breaks = _expected_breaks(name)
    t = np.linspace(0.001, 0.249, 997)
    t = t[np.min(np.abs(t[:, None] - breaks[None, :]), axis=1) > 1e-4] if breaks.size else t
    h = 1e-6
    U = program.channels(t)
    D = (program.channels(t + h) - program.channels(t - h)) / (2 * h)
    for d in range(3):
        scale = max(np.max(np.abs(U[:, d + 1])), np.max(np.abs(U[:, d])) / 0.01, 1e-300)
        assert np.max(np.abs(D[:, d] - U[:, d + 1])) <= 1e-6 * scale, (name, d)


@pytest.mark.parametrize("name", ["segments", "angle table", "time table", "sine"])
def test_one_instant_is_the_array_path_on_both_sides_of_every_break(name):
    program = _programs()[name]
    t = np.concatenate([np.linspace(0.0, 0.25, 301), _expected_breaks(name)])
    for side in ("left", "right"):
        A = program.channels(t, side)
        B = np.array([program.channels_at(float(x), side) for x in t])
        assert np.max(np.abs(A - B) / (1.0 + np.abs(A))) <= 1e-15


def test_steps_take_the_limit_from_each_side():
    """A table's abscissa written twice, a sine's start and a row at 360° different from 0°: the
    value before (left) and after (right) the instant."""
    table = TimeTable(LoadTable("time", (0.0, 0.1, 0.1, 0.3), (0.0, 5.0, -2.0, 0.0)))
    assert table.channels_at(0.1, "left")[0] == 5.0 and table.channels_at(0.1, "right")[0] == -2.0
    assert table.channels_at(0.05)[1] == pytest.approx(50.0) and table.channels_at(0.2)[1] == pytest.approx(10.0)
    assert table.channels_at(7.0)[0] == 0.0 and table.channels_at(-3.0)[0] == 0.0  # held before and after
    sine = SineLoad(Sine(2.0, 5.0, math.pi / 2, 1.0, 0.2))
    assert sine.channels_at(0.2, "left")[0] == 0.0 and sine.channels_at(0.2, "right")[0] == pytest.approx(3.0)
    wrap = AngleLoad(AngleTable(LoadTable("angle", (0.0, math.pi, 2 * math.pi), (4.0, 0.0, 1.0))), 0.0, OMEGA)
    period = 2 * math.pi / OMEGA
    assert wrap.channels_at(period, "left")[0] == pytest.approx(1.0) and wrap.channels_at(period, "right")[0] == 4.0
    assert wrap.break_times(0.0, 1.5 * period) == pytest.approx([0.5 * period, period])


def test_the_engine_input_stacks_the_loads_after_the_cams():
    """The cams' 4·c columns, then [F, Ḟ, F̈, F⃛] per load; break times merged, two a rounding
    apart one (a load's join on a cam's join); without loads the cam input itself."""
    cam = CamProgram(CAM)
    programs = _programs()
    stacked = engine_input(cam, list(programs.values()))
    assert isinstance(stacked, LoadedInput) and engine_input(cam, []) is cam
    t = np.linspace(0.0, 0.25, 11)
    U = stacked.channels(t)
    assert U.shape == (11, 4 * (1 + 4))
    assert np.array_equal(U[:, :4], cam.channels(t))
    for k, program in enumerate(programs.values()):
        assert np.array_equal(U[:, 4 * (k + 1): 4 * (k + 2)], program.channels(t))
    assert np.array_equal(stacked.channels_at(0.1), np.concatenate([cam.channels_at(0.1)]
                                                                    + [p.channels_at(0.1) for p in programs.values()]))
    merged = stacked.break_times(0.0, 0.25)
    assert np.all(np.diff(merged) > 1e-12 * cam.period)
    every = np.concatenate([cam.break_times(0.0, 0.25)] + [p.break_times(0.0, 0.25) for p in programs.values()])
    assert np.all(np.min(np.abs(every[:, None] - merged[None, :]), axis=1) <= 1e-12 * cam.period)
    assert stacked.speed == cam.speed and stacked.period == cam.period  # the rest is the cam input's

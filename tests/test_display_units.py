"""Display units (issue 36): the choices, the rule that picks the units a file was written in,
and the rewriting of SI quantities in messages.

References: every conversion factor is checked against pint's own definitions (an
independent implementation of the units; 1e-12 relative), the rule of docs/units.md against
small machine documents written for each of its cases.
"""

from __future__ import annotations

import json
import math

import pytest

from camsim.display import (
    SI,
    US,
    DisplayUnits,
    display_units,
    engineering,
    in_units,
    option_quantities,
    system_units,
    typographic,
    written_units,
)
from camsim.display.units import pint_text
from camsim.units import registry

UREG = registry()

#: SI unit text of each dimension (what camsim's code and files write).
SI_OF = {
    "length": "m", "velocity": "m/s", "acceleration": "m/s**2", "jerk": "m/s**3", "length/time^4": "m/s**4",
    "length/time^5": "m/s**5", "length/time^6": "m/s**6", "force": "N", "stiffness": "N/m", "damping": "N*s/m", "quadratic_damping": "N*s**2/m**2",
    "mass": "kg", "pressure": "Pa", "torque": "N*m", "energy": "J", "angle": "rad", "angular_speed": "rad/s",
    "inertia": "kg*m**2", "density": "kg/m**3", "area": "m**2", "slowness": "s/m",
}


def pint_size(text: str, si: str) -> float:
    """Size of the display unit ``text`` in ``si`` by pint (the reference)."""
    return float(UREG.Quantity(1.0, pint_text(text)).to(si).magnitude)


@pytest.mark.parametrize("table", [SI, US], ids=["si", "us"])
def test_fixed_choices_match_pint(table):
    assert set(table) == set(SI_OF)
    for dimension, unit in table.items():
        assert unit.size == pytest.approx(pint_size(unit.text, SI_OF[dimension]), rel=1e-12), dimension


def test_shown_converts_the_code_unit_texts():
    us = system_units("us")
    assert us.shown("N") == ("lbf", pytest.approx(1 / 4.4482216152605, rel=1e-14))
    assert us.shown("m/s^2") == ("in/s²", pytest.approx(1 / 0.0254, rel=1e-14))
    assert us.shown("deg") == ("deg", 1.0)
    assert us.shown("rad")[0] == "deg" and us.shown("rad")[1] == pytest.approx(180 / math.pi, rel=1e-14)
    assert us.shown("rad/s")[0] == "rpm" and us.shown("rad/s")[1] == pytest.approx(30 / math.pi, rel=1e-14)
    assert us.shown("s") == ("s", 1.0) and us.shown("Hz") == ("Hz", 1.0) and us.shown("") == ("", 1.0)
    assert system_units("si").shown("m") == ("mm", 1000.0)
    assert system_units("si").shown("m/s^3")[0] == "m/s³"  # one typographic form
    assert us.quantity(4.4482216152605, "N") == "1 lbf"
    assert us.header("force", "N") == "force [lbf]" and us.header("impacts", "") == "impacts"


def test_json_round_trip_is_exact_and_deterministic():
    cdtm = written_units(CDTM)
    again = DisplayUnits.from_json(cdtm.to_json())
    assert again == cdtm and again.to_json() == cdtm.to_json()
    assert json.loads(cdtm.to_json())["units"]["force"] == ["lbf", pytest.approx(4.4482216152605, rel=1e-14)]
    with pytest.raises(ValueError):
        DisplayUnits.from_json('{"units": {"force": ["lbf", -1.0]}}')


CDTM = """
schema = 1
[machine]
name = "m"
description = "4 kg + 4 kg at 120 rpm"
[cam]
speed = "120 rpm"
arm = "6.5 in"
segments = [{ motion = "rise", law = "cycloidal", duration = "180 deg", lift = "0.5 in" },
            { motion = "fall", law = "cycloidal", duration = "180 deg", lift = "0.5 in" }]
[[mass]]
name = "m"
mass = "0.3854 lb"
[[element]]
name = "k"
stiffness = "25.62 lbf/in"
preload = "223.5 lbf"
[[element]]
name = "seat"
stiffness = "8597740 N/m"
gap = "0.0625 in"
"""


def units_of(doc: str, *options: str) -> dict[str, str]:
    return {d: u.text for d, u in written_units(doc, option_quantities(options)).units}


def test_units_written_in_the_file_per_dimension():
    """The rule of docs/units.md on the CDTM's mix (5 of 6 stiffnesses... here 1 of 2 in lbf/in,
    the first written), lengths and forces taken from what the file writes."""
    u = units_of(CDTM)
    assert (u["length"], u["force"], u["mass"], u["angle"], u["angular_speed"]) == ("in", "lbf", "lb", "deg", "rpm")
    # derived from in and lbf
    assert (u["velocity"], u["acceleration"], u["jerk"], u["damping"], u["pressure"], u["torque"]) == (
        "in/s", "in/s²", "in/s³", "lbf·s/in", "psi", "lbf·in")
    # stiffness written twice, once in each unit: the tie goes to the first written
    assert u["stiffness"] == "lbf/in"
    assert units_of(CDTM.replace('"25.62 lbf/in"', '"4486.75 N/m"'))["stiffness"] == "N/m"


def test_most_frequent_unit_wins_and_names_do_not_count():
    doc = """
[[mass]]
name = "m"
mass = "1 kg"
[[mass]]
name = "F"
mass = "2 lb"
[[mass]]
name = "g"
mass = "3 lb"
"""
    # the mass names "m", "F" and "g" are no quantities (they do not start with a number)
    u = units_of(doc)
    assert u["mass"] == "lb" and u["length"] == "mm" and u["force"] == "N"


def test_compound_units_give_a_base_dimension_never_written_alone():
    u = units_of('[x]\nstiffness = "25 lbf/in"\nk2 = "30 lbf/in"\n')
    assert u["force"] == "lbf" and u["length"] == "in" and u["velocity"] == "in/s"
    # a length written on its own wins over the compounds' lengths
    u = units_of('[x]\nstiffness = "25 N/m"\nk2 = "30 N/m"\nlift = "20 mm"\n')
    assert u["length"] == "mm" and u["stiffness"] == "N/m" and u["velocity"] == "m/s"


def test_metric_and_mixed_files():
    assert units_of('[x]\nlift = "20 mm"\nk = "2000 N/m"\nm = "0.5 kg"\n')["acceleration"] == "m/s²"
    # N with inch lengths: force/length units in the force's system, never N·s/in
    u = units_of('[x]\nlift = "1 in"\nk = "1e4 N/m"\np = "100 N"\nm = "4 kg"\n')
    assert (u["length"], u["velocity"], u["stiffness"], u["damping"], u["pressure"], u["torque"]) == (
        "in", "in/s", "N/m", "N·s/m", "MPa", "N·m")
    # a velocity written directly is shown as written
    assert units_of('[x]\nlift = "20 mm"\nv = "200 mm/s"\n')["velocity"] == "mm/s"
    # nothing written: the si choice
    assert units_of("") == {d: u.text for d, u in SI.items()}


def test_command_line_units_come_first():
    assert option_quantities(["element.K23.preload=20,28.12lbf", "cam.speed=100:600:10rpm",
                              "peak_transducer_force>52lbf", "element.K23.preload=tol:28.12:3lbf",
                              "element.seat.stiffness=4e6:1.2e7N/m", "simulation.cycles=3"]) == [
        "28.12 lbf", "10 rpm", "52 lbf", "3 lbf", "1.2e7 N/m"]
    si_doc = '[x]\nlift = "20 mm"\np = "20 N"\nk = "2000 N/m"\n'
    u = units_of(si_doc, "element.closure.preload=20:40lbf")
    assert u["force"] == "lbf" and u["stiffness"] == "N/m"  # the file wrote its stiffness in N/m
    assert display_units("file", si_doc, ["x=1:2lbf"]).unit("force").text == "lbf"
    assert display_units("si", CDTM).unit("force").text == "N"
    assert display_units("us", si_doc).unit("length").text == "in"


def test_messages_in_display_units():
    us = system_units("us")
    text = 'the cam contact force turns negative (-12.5 N) at 0.002 m; got "0.002 m"; a = 9.80665 m/s^2; 0.5 rad'
    shown = in_units(text, us)
    # at least the digits written (4 at least): 12.5 N = 2.81013 lbf, 9.80665 m/s² = 386.0886 in/s²
    assert "-2.81 lbf" in shown and "0.07874 in" in shown and '"0.002 m"' in shown  # the user's text stays
    assert "386.089 in/s²" in shown and "28.65 deg" in shown and " N)" not in shown
    # si: lengths in mm, acceleration in the one typographic form
    assert in_units("0.002 m and 9.8 m/s^2", system_units("si")) == "2 mm and 9.8 m/s²"
    assert in_units("50 Hz in 3 s", us) == "50 Hz in 3 s"


def test_engineering_prefixes():
    assert engineering(50000, "Hz") == "50 kHz"
    assert engineering(2e6, "Hz") == "2 MHz"
    assert engineering(0.0021, "s") == "2.1 ms"
    assert engineering(999.99995, "Hz") == "1 kHz"
    assert engineering(0.0, "Hz") == "0 Hz"


def test_typographic_form():
    assert typographic("m/s^2") == typographic("m/s**2") == "m/s²"
    assert typographic("N*s/m") == "N·s/m"
    assert pint_text("lbf·s²/in") == "lbf*s**2/in"

"""Issue 44, item 4: one module owns the key-path grammar; a bare number is SI and says so.

References: the conversions in the expected warnings are exact unit definitions (1 rpm =
2π/60 rad/s, so 120 rad/s = 1145.9 rpm; 1 lb = 0.45359237 kg, so 0.3854 kg = 0.8497 lb);
pint, an independent unit library, recomputes them here.
"""

from __future__ import annotations

import re
import tomllib
from dataclasses import dataclass
from pathlib import Path
from typing import ClassVar

import pint
import pytest
from typer.testing import CliRunner

from camsim.cli import app
from camsim.elements import Param
from camsim.errors import InputError, MachineFileError
from camsim.machine import keys
from camsim.machine.loader import load_machine, load_machine_text

ROOT = Path(__file__).resolve().parents[1]
CDTM = ROOT / "machines" / "cdtm.toml"
UREG = pint.UnitRegistry()
runner = CliRunner()


def test_no_module_but_keys_parses_key_paths():
    """The grammar ``name[index]`` joined by dots was parsed in four places (machine/schema,
    machine/overrides, analyses/fit/tomledit, analyses/sweep/runner); only camsim/machine/keys.py
    may hold it now (its framework module, keypath.py)."""
    pattern = re.compile(r"\(\?:\\\[\(\\d\+\)\\\]\)\?")  # the regex text (?:\[(\d+)\])?
    holders = [str(p.relative_to(ROOT)) for p in (ROOT / "camsim").rglob("*.py") if pattern.search(p.read_text())]
    assert holders == ["camsim/machine/keypath.py"]


@pytest.mark.parametrize("key, unit", [
    ("cam.speed", "rad/s"), ("cam.segments[2].lift", "m"), ("mass.M2.mass", "kg"), ("mass[1].mass", "kg"),
    ("element.seat.stiffness", "N/m"), ("element[3].gap", "m"), ("initial.M3.velocity", "m/s"),
    ("simulation.cycles", ""), ("cam.geometry.base_radius", "m"), ("cam.geometry.cam_material.youngs_modulus", "Pa"),
    ("cam.segments[1].end.a", "m/s^2"), ("cam.compensation.speed", "rad/s"), ("clearance.jaw.minimum", "m"),
    ("camshaft.section.feed.stiffness", "N*m/rad"), ("cam.feed.phase", "rad"),
])
def test_one_unit_per_key_path(key, unit):
    """Each path's SI unit is its schema key's (the keys of docs/machine-file.md)."""
    assert keys.unit(key) == unit


def test_the_consumers_agree_on_where_a_key_lands():
    """--set, the fitted-file editor and the sweep's value of a key address the same value."""
    from camsim.analyses.fit.tomledit import edited_text
    from camsim.analyses.sweep.runner import machine_value

    text = CDTM.read_text()
    machine = load_machine_text(text, overrides=["element.K23.preload=100", "simulation.cycles=2", "mass[2].mass=0.2"])
    assert machine_value(machine, "element.K23.preload") == 100.0
    assert machine_value(machine, "simulation.cycles") == 2
    assert machine_value(machine, "mass.M3.mass") == 0.2
    edited = edited_text(text, [("element.K23.preload", 100.0, "N", None, lambda *a: "fitted"),
                                ("mass.M3.mass", 0.2, "kg", None, lambda *a: "fitted")])
    assert '"0.4409245 lb" # fitted' in edited  # written in the unit the file used
    again = load_machine_text(edited)
    assert machine_value(again, "element.K23.preload") == pytest.approx(100.0, rel=1e-6)
    assert machine_value(again, "mass.M3.mass") == pytest.approx(0.2, rel=1e-6)


def test_a_new_table_kind_is_one_class():
    """The coming ``[[load]]`` table (``load.<name>.force``): one TableKind registered in keys
    gives --set, the unit of a sweep column, the value in a description and the paths of a
    document, with the usual errors."""

    @dataclass
    class _Load(keys.TableKind):
        head: ClassVar[str] = "load"
        example: ClassVar[str] = 'load.press.force="20 N"'
        PARAMS: ClassVar[tuple] = (Param("name", "string", ""), Param("force", "force", "the load"))

        def address(self, ctx, parts):
            rows = {r["name"]: r for r in ctx.doc.get("load", [])}
            if len(parts) != 3 or parts[1][0] not in rows or parts[2][0] != "force":
                raise ctx.error("address a load as load.<name>.force")
            return keys.Address(rows[parts[1][0]], "force", f"load.{parts[1][0]}.force")

        def param(self, parts):
            return self.PARAMS[1] if parts[-1][0] == "force" else None

        def value(self, machine, parts):
            return next(r for r in machine["loads"] if r["name"] == parts[1][0])["force"]

        def paths(self, doc):
            return [f"load.{r['name']}.force" for r in doc.get("load", [])]

    keys.register(_Load)
    try:
        doc = {"load": [{"name": "press", "force": "10 N"}]}
        assert keys.address(doc, "load.press.force").set("30 N") == "load.press.force"
        assert doc["load"][0]["force"] == "30 N"
        assert keys.unit("load.press.force") == "N"
        assert keys.machine_value({"loads": [{"name": "press", "force": 30.0}]}, "load.press.force") == 30.0
        assert "load.press.force" in keys.document_paths(doc)
        with pytest.raises(MachineFileError, match="address a load as load.<name>.force"):
            keys.address(doc, "load.nope.force")
    finally:
        del keys.KINDS["load"]


# ---------------------------------------------------------------------- bare numbers
def _rpm(rad_s: float) -> float:
    return UREG.Quantity(rad_s, "rad/s").to("rpm").magnitude


def test_a_bare_speed_in_an_inch_file_says_so():
    """The issue's case: ``speed = "120"`` in CDTM ran at 1146 rpm with 6 jumps and exit 0,
    silently; it is read as SI still (the file format), with one warning line."""
    text = CDTM.read_text().replace('speed = "120 rpm"', 'speed = "120"')
    machine = load_machine_text(text, source="bare.toml")
    assert machine.cam.speed == 120.0
    expected = f"cam.speed = 120 → 120 rad/s = {_rpm(120):.4g} rpm"
    assert expected == "cam.speed = 120 → 120 rad/s = 1146 rpm"
    assert [n for n in machine.notes if n.startswith(expected)], machine.notes


def test_a_bare_mass_in_a_pound_file_says_so():
    text = CDTM.read_text().replace('mass = "0.3854 lb"', 'mass = "0.3854"')
    assert 'mass = "0.3854"' in text
    machine = load_machine_text(text)
    pounds = UREG.Quantity(0.3854, "kg").to("lb").magnitude
    assert any(n.startswith(f"mass.M3.mass = 0.3854 → 0.3854 kg = {pounds:.4g} lb") for n in machine.notes), machine.notes


def test_a_file_without_units_and_zeros_give_no_note():
    """A file written in bare SI throughout (the format's own convention) gets no warning, nor
    a bare 0 (zero in every unit) nor a bare angle (degrees, documented)."""
    doc = tomllib.loads(CDTM.read_text())
    assert load_machine(CDTM).notes == ()
    bare = {"schema": 1, "machine": {"name": "bare"}, "mass": [{"name": "M", "mass": 0.5}],
            "element": [{"name": "stop", "type": "contact", "between": ["ground", "M"], "stiffness": 2e5, "gap": 0}],
            "initial": {"M": {"displacement": 1e-3, "velocity": -0.4}},
            "simulation": {"duration": 0.01, "sample_rate": 1e5}}
    assert load_machine(bare).notes == ()
    assert doc["cam"]["segments"][0]["duration"]  # written with units in CDTM; bare angles are degrees anyway


@pytest.mark.parametrize("args, expected", [
    (["validate", str(CDTM), "--set", "cam.speed=120"], "--set cam.speed = 120 → 120 rad/s = 1146 rpm"),
    (["impact", "--mass", "0.3854", "--velocity", "7 in/s", "--stiffness", "49094 lbf/in"], "--mass 0.3854 → 0.3854 kg"),
])
def test_a_bare_number_on_the_command_line_says_so(args, expected):
    r = runner.invoke(app, args)
    assert r.exit_code == 0, r.output
    lines = [line for line in r.output.splitlines() if "warning:" in line and "bare number" in line]
    assert len(lines) == 1 and expected in lines[0], r.output


def test_a_bare_sweep_range_says_so(tmp_path):
    """``--vary cam.speed=60:600:10`` swept 573-5730 rpm without a word."""
    from camsim.analyses.sweep.runner import run_sweep

    said: list[str] = []
    run_sweep(CDTM, ["cam.speed=60:60:1"], fixed=["simulation.sample_rate=2000", "simulation.warmup_cycles=0"],
              workers=1, warn=said.append)
    assert said == ['--vary cam.speed = 60:60:1 → 60 rad/s = 573 rpm (a bare number is read as SI; write the unit: '
                    '"60:60:1 rpm" if you meant rpm)']


def test_a_unit_on_a_count_is_refused():
    """``optimize --constraint "jump<=0N"`` accepted a force unit on a count; exit 2 now."""
    from camsim.analyses.optimize.problem import parse_constraint

    with pytest.raises(InputError, match="does not fit"):
        parse_constraint("jump<=0N", {"jump": ""})
    with pytest.raises(InputError, match="does not fit"):
        parse_constraint("impacts<=2lbf", {"impacts": ""})
    assert parse_constraint("impacts<=2", {"impacts": ""}).limit == 2.0

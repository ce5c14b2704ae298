"""Malformed contact parameters (issue 12): one line naming file and key, exit 2, no output.

Reference: the project's error contract (conventions: ``file: key: message``, exit 2,
nothing written) and the parameter ranges of spec §3.
"""

from __future__ import annotations

import pytest
from typer.testing import CliRunner

from camsim.cli import app

BASE = """
schema = 1
[machine]
name = "drop"
[[mass]]
name = "ball"
mass = "0.01 kg"
[[element]]
name = "stop"
type = "contact"
between = ["ground", "ball"]
gap = 0
{contact}
[initial.ball]
displacement = "1 mm"
velocity = "0 m/s"
[simulation]
gravity = true
duration = "20 ms"
warmup_cycles = 0
sample_rate = "10 kHz"
"""

POWER = 'law = "power"\ncoefficient = "1e9 N/m**1.5"\nexponent = 1.5\n'


@pytest.mark.parametrize(
    ("contact", "key"),
    [
        (POWER + "restitution = 0", "element[0].restitution"),
        (POWER + "restitution = 1.2", "element[0].restitution"),
        (POWER + "restitution = -0.5", "element[0].restitution"),
        (POWER + 'restitution = 0.5\nhysteresis_damping = "0.3 s/m"', "element[0].hysteresis_damping"),
        (POWER + 'restitution = 0.5\ndamping_model = "hunt"', "element[0].damping_model"),
        (POWER + 'hysteresis_damping = "-1 s/m"', "element[0].hysteresis_damping"),
        (POWER + 'hysteresis_damping = "2 N"', "element[0].hysteresis_damping"),
        ('law = "power"\ncoefficient = "1e9 N/m**1.5"\nexponent = -1.5', "element[0].exponent"),
        ('law = "linear"\nstiffness = "1e5 N/m"\ndamping_model = "exact"', "element[0].damping_model"),
        ('law = "restitution"\nrestitution = 1.5', "element[0].restitution"),
        ('law = "adams-impact"\nexponent = -1.5\nstiffness = "1e8 N/m**1.5"\nmax_damping = "10 N*s/m"\n'
         'penetration_depth = "0.1 mm"', "element[0].exponent"),
        ('law = "adams-impact"\nexponent = 1.5\nstiffness = "1e8 N/m**1.5"\nmax_damping = "10 N*s/m"\n'
         'penetration_depth = "-0.1 mm"', "element[0].penetration_depth"),
        ('law = "adams-impact"\nexponent = 1.5\nstiffness = "1e8 N/m**1.5"\nmax_damping = "10 N*s/m"\n'
         'penetration_depth = "0 mm"', "element[0].penetration_depth"),
        ('law = "adams-impact"\nexponent = 1.5\nstiffness = "1e8 N/m"\nmax_damping = "10 N*s/m"\n'
         'penetration_depth = "0.1 mm"', "element[0].stiffness"),
        ('law = "adams-impact"\nexponent = 1.5\nstiffness = "1e8 N/m**1.5"\nmax_damping = "-10 N*s/m"\n'
         'penetration_depth = "0.1 mm"', "element[0].max_damping"),
        ('law = "linear"\nstiffness = "1e5 N/m"\nrestitution = 0.5\ndamping_ratio = 0.1', "element[0].restitution"),
        ('law = "linear"\nstiffness = "1e5 N/m"\nrestitution = 0', "element[0].restitution"),
    ],
)
def test_malformed_contact_parameters(tmp_path, contact, key):
    machine = tmp_path / "m.toml"
    machine.write_text(BASE.replace("{contact}", contact), encoding="utf-8")
    out = tmp_path / "out.h5"
    result = CliRunner().invoke(app, ["run", str(machine), "-o", str(out)])
    assert result.exit_code == 2, result.output
    lines = [line for line in result.output.splitlines() if line.strip()]
    assert len(lines) == 1, result.output
    assert str(machine) in lines[0] and key in lines[0], lines[0]
    assert "Traceback" not in result.output
    assert not out.exists()


LASH = """
schema = 1
[machine]
name = "lash"
[[mass]]
name = "M"
mass = "0.5 kg"
[[element]]
name = "slot"
type = "lash"
between = ["ground", "M"]
{lash}
[simulation]
duration = "10 ms"
warmup_cycles = 0
sample_rate = "10 kHz"
"""


LASH_GAP = 'clearance = "1 mm"\nlaw = "elastogap"\n'
SIDE_LOW = 'lower = { law = "linear", stiffness = "1e6 N/m" }\n'
SIDE_UP = 'upper = { law = "elastogap", stiffness = "2e6 N/m", restitution = 0.6 }\n'
LASH_POWER = 'clearance = "1 mm"\nlaw = "power"\ncoefficient = "1e9 N/m**1.5"\nexponent = 1.5\n'
LASH_ADAMS = ('clearance = "1 mm"\nlaw = "adams-impact"\nexponent = {n}\nstiffness = "1e8 N/m**1.5"\n'
              'max_damping = {c}\npenetration_depth = {d}')


@pytest.mark.parametrize(
    ("lash", "key"),
    [
        ('clearance = "-1 mm"\nstiffness = "1e6 N/m"', "element[0].clearance"),
        ('clearance = "1 mm"\nstiffness = "1e6 N/m"\nlaw = "hertz"', "element[0].law"),
        ('clearance = "1 mm"\nstiffness = "1e6 N/m"\nlaw = "power"', "element[0].stiffness"),
        # power law
        (LASH_POWER + "restitution = 0", "element[0].restitution"),
        (LASH_POWER + "restitution = 1.2", "element[0].restitution"),
        (LASH_POWER + 'restitution = 0.5\nhysteresis_damping = "0.3 s/m"', "element[0].hysteresis_damping"),
        (LASH_POWER + 'restitution = 0.5\ndamping_model = "hunt"', "element[0].damping_model"),
        (LASH_POWER + 'hysteresis_damping = "-1 s/m"', "element[0].hysteresis_damping"),
        (LASH_POWER + 'damping = "3 N*s/m"', "element[0].damping"),
        ('clearance = "1 mm"\nlaw = "power"\ncoefficient = "1e9 N/m**1.5"\nexponent = -1.5', "element[0].exponent"),
        ('clearance = "1 mm"\nlaw = "power"\ncoefficient = "1e9 N/m"\nexponent = 1.5', "element[0].coefficient"),
        ('clearance = "1 mm"\nlaw = "power"\nexponent = 1.5', "element[0].coefficient"),
        # adams-impact
        (LASH_ADAMS.format(n="-1.5", d='"0.1 mm"', c='"10 N*s/m"'), "element[0].exponent"),
        (LASH_ADAMS.format(n="1.5", d='"-0.1 mm"', c='"10 N*s/m"'), "element[0].penetration_depth"),
        (LASH_ADAMS.format(n="1.5", d='"0 mm"', c='"10 N*s/m"'), "element[0].penetration_depth"),
        (LASH_ADAMS.format(n="1.5", d='"0.1 mm"', c='"-10 N*s/m"'), "element[0].max_damping"),
        (LASH_ADAMS.format(n="1.5", d='"0.1 mm"', c='"10 N*s/m"') + "\nclamp = 1", "element[0].clamp"),
        # restitution (rigid)
        ('clearance = "1 mm"\nlaw = "restitution"\nrestitution = 1.5', "element[0].restitution"),
        ('clearance = "1 mm"\nlaw = "restitution"', "element[0].restitution"),
        ('clearance = "0 mm"\nlaw = "restitution"\nrestitution = 0.5', "element[0].clearance"),
        ('clearance = "1 mm"\nlaw = "restitution"\nrestitution = 0.5\nstiffness = "1e6 N/m"', "element[0].stiffness"),
        ('clearance = "1 mm"\nlaw = "restitution"\nrestitution = 0.5\ngap = "1 mm"', "element[0].gap"),
        ('clearance = "1 mm"\nstiffness = "-1e6 N/m"', "element[0].stiffness"),
        ('clearance = "1 mm"\nstiffness = "1e6 N/m"\nrestitution = 0.5\ndamping = "3 N*s/m"', "element[0].restitution"),
        ('stiffness = "1e6 N/m"', "element[0].clearance"),
        # elastogap (spec §10)
        (LASH_GAP + 'exponent = 1.5\nstiffness = "2e9 N/m^1.5"\ndamping_ratio = 0.1', "element[0].damping_ratio"),
        (LASH_GAP + 'exponent = 1.5\nstiffness = "2e9 N/m^1.5"\nrestitution = 0.5', "element[0].restitution"),
        (LASH_GAP + 'stiffness = "1e6 N/m"\nrestitution = 0.5\ndamping = "3 N*s/m"', "element[0].restitution"),
        (LASH_GAP + 'stiffness = "1e6 N/m"\nrestitution = 0', "element[0].restitution"),
        (LASH_GAP + 'stiffness = "1e6 N/m"\nmax_damping = "3 N*s/m"', "element[0].max_damping"),
        # a table per side (spec §10)
        ('clearance = "1 mm"\n' + SIDE_LOW, "element[0].upper"),
        ('clearance = "1 mm"\nlower = 3\n' + SIDE_UP, "element[0].lower"),
        ('clearance = "1 mm"\nstiffness = "1e6 N/m"\n' + SIDE_LOW + SIDE_UP, "element[0].stiffness"),
        ('clearance = "1 mm"\nlaw = "linear"\n' + SIDE_LOW + SIDE_UP, "element[0].law"),
        ('clearance = "1 mm"\nlower = { law = "linear", stiffness = "1e6 N/m", clearance = "1 mm" }\n' + SIDE_UP,
         "element[0].lower.clearance"),
        ('clearance = "1 mm"\nlower = { law = "linear", stifness = "1e6 N/m" }\n' + SIDE_UP, "element[0].lower.stifness"),
        ('clearance = "1 mm"\nlower = { law = "linear", stiffness = "-1e6 N/m" }\n' + SIDE_UP,
         "element[0].lower.stiffness"),
        ('clearance = "1 mm"\nlower = { law = "linear", coefficient = "1e9 N/m**1.5" }\n' + SIDE_UP,
         "element[0].lower.coefficient"),
        ('clearance = "1 mm"\nlower = { law = "hertz", stiffness = "1e6 N/m" }\n' + SIDE_UP, "element[0].lower.law"),
        ('clearance = "1 mm"\nlower = { law = "linear" }\n' + SIDE_UP, "element[0].lower.stiffness"),
        ('clearance = "1 mm"\nlower = { law = "elastogap", exponent = 1.5, stiffness = "2e9 N/m^1.5", '
         'damping_ratio = 0.1 }\n' + SIDE_UP, "element[0].lower.damping_ratio"),
        ('clearance = "1 mm"\nlower = { stiffness = "1e6 N/m", damping_ratio = 0.1, reference_mass = "X" }\n' + SIDE_UP,
         "element[0].lower.reference_mass"),
        ('clearance = "1 mm"\nlower = { law = "restitution", restitution = 0.5 }\n' + SIDE_UP, "element[0].lower"),
        ('clearance = "0 mm"\nlower = { law = "restitution", restitution = 0.5 }\n'
         'upper = { law = "restitution", restitution = 0.5 }', "element[0].clearance"),
    ],
)
def test_malformed_lash_parameters(tmp_path, lash, key):
    machine = tmp_path / "m.toml"
    machine.write_text(LASH.replace("{lash}", lash), encoding="utf-8")
    out = tmp_path / "out.h5"
    result = CliRunner().invoke(app, ["run", str(machine), "-o", str(out)])
    assert result.exit_code == 2, result.output
    lines = [line for line in result.output.splitlines() if line.strip()]
    assert len(lines) == 1 and key in lines[0] and str(machine) in lines[0], result.output
    assert not out.exists()


@pytest.mark.parametrize("lash", [
    'clearance = "1 mm"\nlaw = "elastogap"\nstiffness = "1e6 N/m"\nrestitution = 0.6',
    'clearance = "1 mm"\n' + SIDE_LOW + SIDE_UP,
    'clearance = "1 mm"\nlower = { law = "restitution", restitution = 0.5 }\nupper = { law = "restitution", '
    'restitution = 0.9 }',
])
def test_well_formed_lashes_run(tmp_path, lash):
    """The elastogap lash and tables per side (spec §10) load and run: exit 0, the file written."""
    machine = tmp_path / "m.toml"
    start = '[initial.M]\ndisplacement = "0 m"\nvelocity = "0.3 m/s"\n[simulation]'
    text = LASH.replace("{lash}", lash).replace("[simulation]", start)
    machine.write_text(text, encoding="utf-8")
    out = tmp_path / "out.h5"
    result = CliRunner().invoke(app, ["run", str(machine), "-o", str(out)])
    assert result.exit_code == 0, result.output
    assert out.exists()

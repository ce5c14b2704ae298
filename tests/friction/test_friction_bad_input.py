"""Bad friction keys through the command line (spec §10, §6): ``camsim validate FILE`` and
``camsim run FILE`` exit 2 with one line on stderr naming the file and the key
(``element[1].<key>``), no traceback, nothing on stdout, and nothing written next to the
machine file. Reference: the rules of spec §10 (F_C ≥ 0, F_B ≥ F_C, v_S > 0, c_v ≥ 0,
``coulomb_force`` or ``coefficient`` with ``normal_force``, μ_s ≥ μ, no friction between the
cam node and the mass the cam drives) and the CLI's error contract (tests/cli/test_run_cli.py).
"""

from __future__ import annotations

import pytest
from typer.testing import CliRunner

from camsim.cli import app

from friction_machines import belt, spring_mass

BASE = spring_mass(fb=15.0)
FRICTION = 'coulomb_force = "10.0 N"\nbreakaway_force = "15.0 N"'
assert FRICTION in BASE


def _with(keys: str) -> str:
    return BASE.replace(FRICTION, keys)


DRIVEN = belt().replace("[cam]\n", '[cam]\ndrives = "m"\n')

CASES = {
    # name: (machine text, the key the line names, a phrase of the message)
    "breakaway below coulomb": (_with('coulomb_force = "10 N"\nbreakaway_force = "5 N"'), "breakaway_force",
                                "at least the Coulomb force"),
    "stribeck velocity zero": (_with(FRICTION + '\nstribeck_velocity = "0 m/s"'), "stribeck_velocity",
                               "greater than 0"),
    "stribeck velocity negative": (_with(FRICTION + '\nstribeck_velocity = "-0.1 m/s"'), "stribeck_velocity",
                                   "greater than 0"),
    "negative coulomb force": (_with('coulomb_force = "-10 N"'), "coulomb_force", "negative"),
    "negative viscous": (_with(FRICTION + '\nviscous = "-1 N*s/m"'), "viscous", "negative"),
    "coefficient without normal force": (_with("coefficient = 0.3"), "normal_force", "missing"),
    "normal force without coefficient": (_with(FRICTION + '\nnormal_force = "20 N"'), "normal_force",
                                         "coefficient"),
    "coulomb force and coefficient": (_with(FRICTION + '\ncoefficient = 0.3\nnormal_force = "20 N"'),
                                      "coulomb_force", "exactly one"),
    "static below kinetic coefficient": (_with('coefficient = 0.5\nnormal_force = "20 N"\nstatic_coefficient = 0.4'),
                                         "static_coefficient", "at least coefficient"),
    "static coefficient and breakaway force": (
        _with('coefficient = 0.5\nnormal_force = "20 N"\nstatic_coefficient = 0.6\nbreakaway_force = "15 N"'),
        "static_coefficient", "not both"),
    "a pair that does nothing": (_with('coulomb_force = "0 N"'), "coulomb_force", "does nothing"),
    "a force in metres": (_with('coulomb_force = "10 m"'), "coulomb_force", "expected [force]"),
    "an unknown key": (_with(FRICTION + '\nstatic_force = "3 N"'), "static_force", "unknown key"),
    "friction between the cam and the mass it drives": (DRIVEN, "between", "driven by the cam"),
    "the same, listed the other way round": (
        DRIVEN.replace('between = ["cam", "m"]\ncoulomb', 'between = ["m", "cam"]\ncoulomb'), "between",
        "driven by the cam"),
}


@pytest.mark.parametrize("command", ["validate", "run"])
@pytest.mark.parametrize("case", sorted(CASES))
def test_bad_friction_input_is_one_line_exit_2_nothing_written(case, command, tmp_path):
    """The line is ``camsim: error: <file>: element[1].<key>: <message>`` (exit 2, nothing on
    stdout, no traceback, the folder unchanged: no result, no temporary file)."""
    text, key, phrase = CASES[case]
    path = tmp_path / "machine.toml"
    path.write_text(text)
    before = sorted(tmp_path.iterdir())
    result = CliRunner().invoke(app, [command, str(path)])
    assert result.exit_code == 2, (result.stdout, result.stderr)
    assert result.stdout == ""
    lines = [line for line in result.stderr.splitlines() if line.strip()]
    assert len(lines) == 1, result.stderr
    assert lines[0].startswith(f"camsim: error: {path}: element[1].{key}: "), lines[0]
    assert phrase in lines[0], lines[0]
    assert "Traceback" not in result.stderr
    assert result.exception is None or isinstance(result.exception, SystemExit)
    assert sorted(tmp_path.iterdir()) == before


def test_breakaway_above_coulomb_without_stribeck_velocity_is_accepted(tmp_path):
    """F_B > F_C without ``stribeck_velocity`` is the classic stick–slip law (the force drops
    from F_B to F_C as soon as the pair slides: camsim/elements/friction.py, and the
    stick–slip oscillator of spec §10's references): ``camsim validate`` exits 0."""
    path = tmp_path / "ok.toml"
    path.write_text(BASE)
    result = CliRunner().invoke(app, ["validate", str(path)])
    assert result.exit_code == 0, result.stderr

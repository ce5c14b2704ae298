"""``camsim impact --materials`` and :func:`camsim.analyses.materials.rank_materials` (issue 39).

Reference: the ball drop (machines/ball-drop-hertz.toml, undamped) stops the ball with a
Hertz sphere, whose peak is Johnson's upper bound F = C^(1/2.5)·(1.25·m·v²)^(0.6) with
C = (4/3)·E*·√R written out here from the library's E and ν (Johnson 1985 eq. 4.23); the
simulated peak at 1 MHz is within 0.2 % of it (the parabola through the samples; as
tests/test_validation.py). Ranking rule: pairs below first yield first, then by peak force.
"""

from __future__ import annotations

import json
import math

import pytest
from typer.testing import CliRunner

from camsim.analyses.materials import candidate_pairs, rank_materials
from camsim.cli.app import app
from camsim.machine.loader import load_machine
from camsim.physics.materials import LIBRARY

MACHINE = "machines/ball-drop-hertz.toml"
PAIRS = [("steel", "steel"), ("acetal", "acetal"), ("steel", "bronze")]


def hertz_peak(a: str, b: str, mass: float, v: float, radius: float) -> float:
    inv = sum((1 - LIBRARY[n].poisson_ratio**2) / LIBRARY[n].youngs_modulus for n in (a, b))
    c = 4.0 / 3.0 / inv * math.sqrt(radius)
    return c ** (1 / 2.5) * (1.25 * mass * v * v) ** 0.6


@pytest.fixture(scope="module")
def ranking():
    return rank_materials(load_machine(MACHINE), pairs=PAIRS)


def test_ranking_order_and_values(ranking):
    rows = ranking.rows
    assert [r.materials for r in rows] == [("acetal", "acetal"), ("steel", "bronze"), ("steel", "steel")]
    assert not rows[0].yields and rows[1].yields and rows[2].yields
    machine = load_machine(MACHINE)
    mass, radius = machine.mass_of("ball"), machine.element("stop").radius
    for r in rows:
        assert r.status == "ok" and r.impacts == 1
        assert r.approach_velocity == pytest.approx(math.sqrt(2 * 9.80665 * 0.0254), rel=1e-6)
        assert r.peak_force == pytest.approx(hertz_peak(*r.materials, mass, r.approach_velocity, radius), rel=2e-3)
        assert r.rebound == pytest.approx(1.0, rel=1e-6)  # undamped: the ball leaves at its arrival speed
    assert rows[0].pressure_ratio == pytest.approx(rows[0].peak_pressure / (1.60 * 72e6))


def test_candidate_pairs():
    assert len(candidate_pairs()) == len(LIBRARY) * (len(LIBRARY) + 1) // 2
    assert candidate_pairs(["a", "b"]) == [("a", "a"), ("a", "b"), ("b", "b")]


def test_cli_json():
    result = CliRunner().invoke(app, ["impact", "--materials", "--machine", MACHINE, "--pair", "acetal,acetal",
                                      "--set", "element.stop.restitution=0.8", "--json"])
    assert result.exit_code == 0, result.output
    payload = json.loads(result.stdout)
    (row,) = payload["ranking"]
    assert payload["contact"] == "stop" and row["materials"] == ["acetal", "acetal"] and row["rank"] == 1
    # the exact Hunt–Crossley restitution; gravity takes g·τ = 3.5e-4 m/s off during the 36 µs contact
    assert row["rebound"] == pytest.approx(0.8, rel=1e-3)


@pytest.mark.parametrize(("args", "fragment"), [
    (["impact", "--materials"], "--machine"),
    (["impact", "--materials", "--machine", MACHINE, "--contact", "nope"], "no such element"),
    (["impact", "--materials", "--machine", MACHINE, "--pair", "steel"], "two material names"),
    (["impact", "--materials", "--machine", MACHINE, "--pair", "steel,unobtainium"], "unknown material"),
    (["impact", "--materials", "--machine", MACHINE, "--mass", "1 kg"], "calculator option"),
    (["impact", "--machine", MACHINE], "go with --materials"),
    (["impact", "--materials", "--machine", "machines/cdtm.toml"], "law = \"hertz\""),
])
def test_cli_errors(args, fragment):
    result = CliRunner().invoke(app, args)
    assert result.exit_code == 2, result.output
    assert fragment in result.output
    assert "Traceback" not in result.output

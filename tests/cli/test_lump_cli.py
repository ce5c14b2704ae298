"""The ``camsim lump`` command: exit codes, stdout/stderr discipline, atomic output.

Expected numbers: thesis fig 6.4 (M1 16.351 lb = 7.4169 kg, ±½ digit of the thesis).
"""

from __future__ import annotations

import json
import tomllib
from pathlib import Path

import pytest
from typer.testing import CliRunner

from camsim.cli import app

CDTM_PARTS = Path(__file__).resolve().parents[2] / "machines" / "cdtm-parts.toml"
runner = CliRunner()


def test_lump_writes_machine_and_table(tmp_path):
    out = tmp_path / "cdtm.toml"
    result = runner.invoke(app, ["lump", str(CDTM_PARTS), "-o", str(out)])
    assert result.exit_code == 0, result.stderr
    assert result.stdout == ""  # human output goes to stderr
    assert "mass.M1.mass" in result.stderr and "16.35138 lb" in result.stderr
    doc = tomllib.loads(out.read_text())
    assert doc["mass"][0] == {"name": "M1", "mass": "16.35138 lb"}
    assert not [p for p in tmp_path.iterdir() if p.name != "cdtm.toml"]  # no temporary left


def test_lump_json_is_only_json_in_si():
    result = runner.invoke(app, ["lump", str(CDTM_PARTS), "--json"])
    assert result.exit_code == 0, result.stderr
    payload = json.loads(result.stdout)
    values = {v["key"]: v for v in payload["values"]}
    # 16.351 lb = 7.41679 kg; half a digit of the thesis is 0.0005 lb = 2.3e-4 kg
    assert values["mass.M1.mass"]["unit"] == "kg"
    assert values["mass.M1.mass"]["value"] == pytest.approx(7.41679, abs=2.3e-4)
    assert values["mass.M1.mass"]["provenance"].startswith("M1 = (m_la + m_cr)*(7.75 in/2.375 in)^2")
    assert {p["name"] for p in payload["parts"]} >= {"k_cs", "m_la", "k_cr"}


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ('schema = 1\n[lever.r]\nfrom_arm = "0 in"\nto_arm = "1 in"\n', "bad.toml: lever.r.from_arm: lever arm of zero"),
        ('schema = 1\n[part.m]\ntype = "mass"\nmass = "1 N"\n[[mass]]\nname = "A"\nparts = ["m"]\n', "bad.toml: part.m.mass: expected [mass]"),
        ('schema = 1\n[part.m]\ntype = "mass"\nmass = "1 kg"\n[[mass]]\nname = "A"\nparts = ["n"]\n', "bad.toml: mass[0].parts: no part named 'n'"),
    ],
)
def test_lump_bad_input_exit_2_one_line_nothing_written(tmp_path, text, message):
    parts = tmp_path / "bad.toml"
    parts.write_text(text)
    out = tmp_path / "out.toml"
    import os

    cwd = os.getcwd()
    os.chdir(tmp_path)
    try:
        result = runner.invoke(app, ["lump", "bad.toml", "-o", str(out)])
    finally:
        os.chdir(cwd)
    assert result.exit_code == 2
    assert result.stdout == ""
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1, result.stderr
    assert message in lines[0]
    assert not out.exists()


def test_lump_missing_file_and_bad_units(tmp_path):
    result = runner.invoke(app, ["lump", str(tmp_path / "nope.toml")])
    assert result.exit_code == 2 and "no such file" in result.stderr
    result = runner.invoke(app, ["lump", str(CDTM_PARTS), "--units", "imperial"])
    assert result.exit_code == 2 and "--units" in result.stderr


def test_lump_help_mentions_units():
    result = runner.invoke(app, ["lump", "--help"])
    assert result.exit_code == 0
    assert "lbf/in" in result.stdout

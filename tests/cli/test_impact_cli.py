"""Tests of ``camsim impact`` and ``camsim impact fit`` (spec §5, issue 4).

Expected numbers: thesis appendix C table 6 (to 0.2 %), and power laws whose samples
the tests write themselves.
"""

from __future__ import annotations

import json
import math

import pytest
from typer.testing import CliRunner

from camsim.cli import app

runner = CliRunner()

INCH = 0.0254  # m
LBF = 4.4482216152605  # N

HEIGHTS = ["1 in", "1.25 in", "1.75 in", "2.25 in"]
TABLE6_COMMON_VELOCITY_LBF = [57.66, 65.93, 80.67, 93.8]
TABLE6_DEFLECTION_CORRECTION_LBF = [30.88, 34.53, 40.85, 46.32]

# The documented reproduction of thesis table 6 (docs/impact.md): the 0.375 in steel ball of
# appendix C (m = 2.029e-5 lbf*s^2/in, E = 2.9e7 psi) dropped on the 60 800 lbf/in hard stop.
BALL = [
    "--mass", "2.029e-5 lbf*s**2/in",
    "--sphere-diameter", "0.375 in",
    "--modulus", "2.9e7 psi",
    "--stiffness", "60800 lbf/in",
]  # fmt: skip


def _json(args):
    result = runner.invoke(app, ["impact", *args, "--json"])
    assert result.exit_code == 0, result.stderr
    return json.loads(result.stdout)


@pytest.mark.parametrize("gravity", [[], ["--gravity", "386.4 in/s**2"]], ids=["standard_g", "thesis_g"])
@pytest.mark.parametrize("index", range(4))
def test_table6_through_cli(index, gravity):
    """Thesis table 6 at each drop height, to 0.2 %: 'Common Velocity' is Johnson's power-law
    bound (fixed target: lower == upper), 'D&C Factor' is Burr with eta = 1."""
    out = _json([*BALL, "--drop-height", HEIGHTS[index], *gravity])
    assert out["johnson_law"] == "power"
    assert out["johnson_upper_lbf"] == pytest.approx(TABLE6_COMMON_VELOCITY_LBF[index], rel=2e-3)
    assert out["johnson_lower_lbf"] == pytest.approx(out["johnson_upper_lbf"], rel=1e-12)
    assert out["johnson_upper_N"] == pytest.approx(out["johnson_upper_lbf"] * LBF, rel=1e-12)
    assert out["burr_lbf"] == pytest.approx(TABLE6_DEFLECTION_CORRECTION_LBF[index], rel=2e-3)
    assert out["wave_N"] is None
    assert out["inputs"]["eta"] == 1.0
    assert out["inputs"]["target_mass_kg"] is None


def test_table6_with_the_thesis_rounded_coefficient():
    """The same with C = 9.2e6 lbf/in^1.5 as printed in appendix C (1 in drop, 0.2 %)."""
    args = ["--mass", "2.029e-5 lbf*s**2/in", "--drop-height", "1 in"]
    out = _json([*args, "--coefficient", "9.2e6 lbf/in**1.5", "--exponent", "1.5"])
    assert out["johnson_upper_lbf"] == pytest.approx(57.66, rel=2e-3)
    assert out["burr_N"] is None


def test_inputs_are_reported_in_si():
    """--json echoes the inputs in SI: 1 in = 0.0254 m, 60800 lbf/in = 60800 * 4.448.../0.0254 N/m."""
    out = _json([*BALL, "--drop-height", "1 in"])
    inputs = out["inputs"]
    assert inputs["drop_height_m"] == pytest.approx(INCH, rel=1e-15)
    assert inputs["stiffness_N_per_m"] == pytest.approx(60800 * LBF / INCH, rel=1e-12)
    assert inputs["mass_kg"] == pytest.approx(2.029e-5 * LBF / INCH, rel=1e-12)
    assert inputs["velocity_m_per_s"] == pytest.approx(math.sqrt(2 * 9.80665 * INCH), rel=1e-12)
    assert inputs["exponent"] == 1.5


def test_linear_finite_target_and_wave():
    """m = 1 kg at 2 m/s, k = 1e6 N/m, target 3 kg (hand): lower = 2 sqrt(1e6 * 0.75) =
    1732.05 N, upper = 2 sqrt(1e6 * 1) = 2000 N, eta = 1/(1 + 1) = 0.5,
    Burr = 9.80665 (1 + sqrt(1 + 0.5 * 4 * 1e6 / 9.80665^2)) = 1424.054 N.
    Wave: steel bar 1 cm^2 x 0.1 m (beta = 0.0785): sigma0 A = 7924.645 N,
    F = 7924.645 (1 + sqrt(12.73885 + 2/3)) = 36939.58 N."""
    out = _json(
        [
            "--mass", "1 kg", "--velocity", "2 m/s", "--target-mass", "3 kg", "--stiffness", "1e6 N/m",
            "--bar-area", "1 cm**2", "--bar-length", "0.1 m", "--modulus", "200 GPa", "--density", "7850 kg/m**3",
        ]
    )  # fmt: skip
    assert out["johnson_law"] == "linear"
    assert out["johnson_lower_N"] == pytest.approx(1732.0508, rel=1e-7)
    assert out["johnson_upper_N"] == pytest.approx(2000.0, rel=1e-12)
    assert out["inputs"]["eta"] == pytest.approx(0.5, rel=1e-15)
    assert out["burr_N"] == pytest.approx(1424.054, rel=1e-6)
    assert out["wave_N"] == pytest.approx(36939.58, rel=1e-6)


def test_human_table_on_stderr_only():
    result = runner.invoke(app, ["impact", *BALL, "--drop-height", "1 in"])
    assert result.exit_code == 0
    assert result.stdout == ""
    assert "Johnson upper" in result.stderr
    assert "[lbf]" in result.stderr  # the unit in the header is not eaten as rich markup
    assert "57.6" in result.stderr  # lbf column
    assert "needs --bar-area" in result.stderr and "--density" in result.stderr


def test_help():
    for args in (["impact", "--help"], ["impact", "-h"], ["impact", "fit", "--help"]):
        result = runner.invoke(app, args)
        assert result.exit_code == 0
    text = runner.invoke(app, ["impact", "--help"]).stdout
    assert "--drop-height" in text and "fit" in text and "lbf/in" in text


@pytest.mark.parametrize(
    "args,message",
    [
        (["--mass", "-1 lb", "--velocity", "1 m/s", "--stiffness", "1 N/m"], "--mass must be positive"),
        (["--mass", "1 lb", "--velocity", "-1 m/s", "--stiffness", "1 N/m"], "--velocity must be positive"),
        (["--mass", "1 lb", "--velocity", "0 m/s", "--stiffness", "1 N/m"], "--velocity must be positive"),
        (["--mass", "1 lb", "--drop-height", "-1 in", "--stiffness", "1 N/m"], "--drop-height must be positive"),
        (["--mass", "1 lb", "--velocity", "1 m/s"], "no estimate possible: give --stiffness"),
        (["--velocity", "1 m/s", "--stiffness", "1 N/m"], "--mass is required"),
        (["--mass", "1 lb", "--stiffness", "1 N/m"], "exactly one of --velocity and --drop-height"),
        (["--mass", "1 lb", "--velocity", "1 m/s", "--coefficient", "1e7 lbf/in**1.5"], "--coefficient needs --exponent"),
        (["--mass", "1 lb", "--velocity", "1 m/s", "--exponent", "1.5"], "--exponent needs --coefficient"),
        (
            ["--mass", "1 lb", "--velocity", "1 m/s", "--coefficient", "1e7 lbf/in**1.5", "--exponent", "0"],
            "--exponent must be positive",
        ),
        (
            ["--mass", "1 lb", "--velocity", "1 m/s", "--coefficient", "1e7 lbf/in**1.5", "--exponent", "1.4"],
            "--coefficient: expected [force]/[length]^1.4",
        ),
        (["--mass", "1 lb", "--velocity", "1 m/s", "--bar-area", "1 in**2"], "wave estimate needs --bar-length"),
        (["--mass", "1 lb", "--velocity", "1 m/s", "--sphere-diameter", "1 in"], "--sphere-diameter needs --modulus"),
        (["--mass", "1 lb", "--velocity", "1 m", "--stiffness", "1 N/m"], "--velocity: expected [length]/[time]"),
        (["--mass", "1 lb", "--velocity", "1 m/s", "--stiffness", "1 N/m", "--eta", "1.5"], "--eta must be in (0, 1]"),
        (["--mass", "1 lb", "--velocity", "1 m/s", "--stiffness", "1 N/m", "--exponent", "x"], "--exponent: expected a number"),
        (["--mass", "1 lb", "--velocity", "1 m/s", "--target-mass", "-2 kg", "--stiffness", "1 N/m"], "--target-mass must be positive"),
    ],
)
def test_bad_input_is_one_line_exit_2(args, message):
    result = runner.invoke(app, ["impact", *args, "--json"])
    assert result.exit_code == 2
    assert result.stdout == ""
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1, result.stderr
    assert message in lines[0]


# ------------------------------------------------------------------------------ fit


def _write(tmp_path, text, name="data.csv"):
    path = tmp_path / name
    path.write_text(text)
    return path


def test_fit_recovers_power_law_in_file_units(tmp_path):
    """Exact samples of F = 1.11e7 d^1.425 [lbf, in] (thesis eq. 7.1): C, a back to 1e-9,
    R^2 = 1; C in SI = 1.11e7 * 4.4482216152605 / 0.0254^1.425 N/m^1.425."""
    c, a = 1.11e7, 1.425
    deflections = [1e-5 * 1.7**i for i in range(8)]
    rows = "\n".join(f"{d!r},{c * d**a!r}" for d in deflections)
    path = _write(tmp_path, "deflection [in],force [lbf]\n" + rows + "\n")
    result = runner.invoke(app, ["impact", "fit", str(path), "--json"])
    assert result.exit_code == 0, result.stderr
    out = json.loads(result.stdout)
    assert out["exponent"] == pytest.approx(a, rel=1e-9)
    assert out["coefficient_in_file_units"] == pytest.approx(c, rel=1e-9)
    assert out["coefficient_N_per_m_pow_a"] == pytest.approx(c * LBF / INCH**a, rel=1e-9)
    assert out["r_squared"] == pytest.approx(1.0, abs=1e-12)
    assert out["points"] == 8


def test_fit_column_order_and_human_output(tmp_path):
    """Columns in any order; F = 2e6 N/m * d (a = 1) in mm and N: C = 2000 N/mm in the file's
    units (the default, issue 36), 2e6 N/m with --units si."""
    rows = "\n".join(f"{2000.0 * d!r},{d!r}" for d in (0.1, 0.2, 0.5, 1.0))
    path = _write(tmp_path, "force [N],deflection [mm]\n" + rows + "\n")
    result = runner.invoke(app, ["impact", "fit", str(path)])
    assert result.exit_code == 0, result.stderr
    assert result.stdout == ""
    assert "2000" in result.stderr and "N/mm^1" in result.stderr and "2e+06" not in result.stderr
    result = runner.invoke(app, ["impact", "fit", str(path), "--units", "si"])
    assert result.exit_code == 0, result.stderr
    assert "2e+06" in result.stderr and "N/m^1" in result.stderr


@pytest.mark.parametrize(
    "text,message",
    [
        ("deflection [in],force [lbf]\n1,2\n2,3\n", "at least 3 points"),
        ("deflection [in],force [lbf]\n1,2\n2,-3\n3,4\n", "line 3: force must be positive"),
        ("deflection [in],force [lbf]\n0,2\n2,3\n3,4\n", "line 2: deflection must be positive"),
        ("deflection,force [lbf]\n1,2\n2,3\n3,4\n", 'column "deflection" needs its unit in brackets'),
        ("x [in],force [lbf]\n1,2\n2,3\n3,4\n", 'no "deflection" column'),
        ("deflection [in],force [psi]\n1,2\n2,3\n3,4\n", "force unit: expected [force]"),
        ("deflection [in],force [lbf]\n1,2\n2,x\n3,4\n", 'line 3: force: expected a number, got "x"'),
        ("", "empty file"),
    ],
)
def test_fit_bad_data_is_one_line_exit_2(tmp_path, text, message):
    path = _write(tmp_path, text)
    result = runner.invoke(app, ["impact", "fit", str(path), "--json"])
    assert result.exit_code == 2
    assert result.stdout == ""
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1, result.stderr
    assert message in lines[0] and "data.csv" in lines[0]


def test_fit_missing_file(tmp_path):
    result = runner.invoke(app, ["impact", "fit", str(tmp_path / "nope.csv")])
    assert result.exit_code == 2
    assert "cannot read" in result.stderr


def test_calculator_options_rejected_with_fit(tmp_path):
    path = _write(tmp_path, "deflection [in],force [lbf]\n1,2\n2,3\n3,4\n")
    result = runner.invoke(app, ["impact", "--mass", "1 lb", "fit", str(path)])
    assert result.exit_code == 2
    assert "--mass is a calculator option" in result.stderr

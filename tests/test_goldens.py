"""Regression: the shipped machines against their golden result files.

The goldens (tests/data/golden/*.h5) were written by ``python tests/data/make_goldens.py``
with the settings listed there; each test reruns the same command and checks every trace
and the event table with ``camsim check``'s rule (|Δ| ≤ 1e-6·peak of each golden trace).
A failure means a change moved the simulated numbers: find out why before regenerating.
"""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).parent / "data"))
from make_goldens import GOLDENS, ROOT  # noqa: E402

from camsim.analyses.check import check_files  # noqa: E402
from camsim.cli import app  # noqa: E402
from typer.testing import CliRunner  # noqa: E402


@pytest.mark.parametrize("name", sorted(GOLDENS))
def test_machine_matches_golden(name, tmp_path, monkeypatch):
    monkeypatch.chdir(ROOT)
    out = tmp_path / f"{name}.h5"
    golden = ROOT / "tests" / "data" / "golden" / f"{name}.h5"
    result = CliRunner().invoke(app, ["run", *GOLDENS[name], "-o", str(out), "--json"])
    assert result.exit_code == 0, result.output
    report = check_files(out, golden, rtol=1e-6, atol=1e-12)
    assert report.passed, [d.path for d in report.failures]


def test_run_check_against_golden_in_one_step(tmp_path, monkeypatch):
    """`camsim run ... --check-against GOLDEN` passes (exit 0) for an unchanged machine."""
    monkeypatch.chdir(ROOT)
    golden = ROOT / "tests" / "data" / "golden" / "dynacam-2mass.h5"
    out = tmp_path / "d.h5"
    result = CliRunner().invoke(app, ["run", *GOLDENS["dynacam-2mass"], "-o", str(out), "--check-against", str(golden)])
    assert result.exit_code == 0, result.output


def test_run_check_against_detects_a_change(tmp_path, monkeypatch):
    """A changed stiffness is a regression: exit 1."""
    monkeypatch.chdir(ROOT)
    golden = ROOT / "tests" / "data" / "golden" / "dynacam-2mass.h5"
    out = tmp_path / "d.h5"
    args = [*GOLDENS["dynacam-2mass"], "--set", "element.k12.stiffness=610000"]
    result = CliRunner().invoke(app, ["run", *args, "-o", str(out), "--check-against", str(golden)])
    assert result.exit_code == 1, result.output
    assert "masses/m2" in result.output


def test_ci_check_script_passes(tmp_path):
    """scripts/ci-check.sh (the README's CI recipe) runs every golden machine and passes."""
    import shutil
    import subprocess

    if shutil.which("camsim") is None:
        pytest.skip("the camsim command is not on PATH (package not installed)")
    out = subprocess.run(["sh", str(ROOT / "scripts" / "ci-check.sh"), str(tmp_path)], capture_output=True, text=True)
    assert out.returncode == 0, out.stderr
    assert out.stdout.count("ok ") == len(GOLDENS)

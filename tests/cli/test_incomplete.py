"""Issue 26, "success means success": a sweep or study with rows that did not run exits 1,
says so in its file and JSON, and concludes nothing from the rows that did not run.

References: the documented exit codes (README "Exit codes"), and for the jump onset the
logic of the case itself: a failed row below the lowest jumping speed may be the onset,
so no speed can be claimed. The failing rows are made by a value the loader refuses
(a negative speed, a negative mass), so which rows fail is known without running camsim.
"""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import h5py
import pytest
from typer.testing import CliRunner

from camsim.cli import app

MACHINES = Path(__file__).resolve().parents[2] / "machines"
FAST = ["--cycles", "1", "--warmup", "0", "--sample-rate", "2 kHz", "--workers", "1"]
runner = CliRunner()


@pytest.fixture
def barkan(tmp_path) -> Path:
    path = tmp_path / "barkan.toml"
    shutil.copy(MACHINES / "barkan-follower.toml", path)
    return path


def test_sweep_with_a_failed_row_exits_1_and_claims_no_onset(barkan):
    """The follower jumps at 480 rpm and not at 420 (tests/cli/test_sweep_cli.py: onset 450);
    the -5 rpm row fails to load. Before: exit 0 and "lowest swept speed at which the follower
    jumps: 480 rpm". Now: exit 1, incomplete in the file and the JSON, no onset claimed."""
    out = barkan.parent / "s.h5"
    result = runner.invoke(app, ["sweep", str(barkan), "--values", "cam.speed=420rpm,-5rpm,480rpm", "-o", str(out),
                                 "--json", *FAST])
    assert result.exit_code == 1, result.stderr
    payload = json.loads(result.stdout)
    assert payload["incomplete"] is True and payload["not_run"] == 1
    assert payload["first_jump_rpm"] is None
    assert any("lower speeds did not run" in n for n in payload["notes"])
    assert "incomplete" in result.stderr.strip().splitlines()[-1]
    with h5py.File(out) as f:
        assert bool(f["sweep"].attrs["incomplete"]) is True


def test_sweep_that_ran_every_row_is_complete(barkan):
    """The same grid without the failing row: exit 0, incomplete False, onset claimed (480 rpm)."""
    out = barkan.parent / "s.h5"
    result = runner.invoke(app, ["sweep", str(barkan), "--values", "cam.speed=420rpm,480rpm", "-o", str(out), "--json", *FAST])
    assert result.exit_code == 0, result.stderr
    payload = json.loads(result.stdout)
    assert payload["incomplete"] is False and payload["first_jump_rpm"] == pytest.approx(480.0)
    with h5py.File(out) as f:
        assert bool(f["sweep"].attrs["incomplete"]) is False and bool(f["sweep"].attrs["interrupted"]) is False


def test_study_with_failed_runs_exits_1_without_probabilities(barkan):
    """A mass drawn from normal(0.2 kg, 0.3 kg) is negative in some runs (seed 0: 2 of 8), which
    the loader refuses. Before: exit 0 and a probability over the runs that ran. Now: exit 1,
    incomplete in the file and JSON, the probability null with its reason and exact bounds."""
    out = barkan.parent / "st.h5"
    result = runner.invoke(app, ["study", str(barkan), "--dist", "mass.F.mass=normal:0.2:0.3kg", "-n", "8",
                                 "--limit", "min_cam_contact_force<0N", "-o", str(out), "--json", *FAST])
    assert result.exit_code == 1, result.stderr
    payload = json.loads(result.stdout)
    assert payload["incomplete"] is True and payload["failed"] >= 1
    (limit,) = payload["limits"]
    assert limit["probability"] is None and "failed" in limit["reason"]
    with h5py.File(out) as f:
        assert bool(f["study"].attrs["incomplete"]) is True

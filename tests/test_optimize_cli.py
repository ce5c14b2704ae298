"""``camsim optimize`` on the command line: bad input, infeasible problems, files, resume (issue 28).

The machine is ``tests/study/driven_follower.toml`` (a rigid follower whose minimum cam
contact force is P + k h − m c, derivation in its header) run at 720 rpm.
"""

from __future__ import annotations

import json
import math
import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import h5py
import pytest
from typer.testing import CliRunner

from camsim.cli import app

HERE = Path(__file__).parent
MACHINE = HERE / "study" / "driven_follower.toml"
runner = CliRunner()
FAST = ["--set", "cam.speed=720rpm", "--set", "simulation.sample_rate=4.8kHz", "--workers", "1"]
PRELOAD = ["--var", "element.closure.preload=0:100N", "--minimize", "param:element.closure.preload"]


@pytest.fixture
def machine(tmp_path):
    path = tmp_path / "m.toml"
    shutil.copy(MACHINE, path)
    return path


def _run(args):
    return runner.invoke(app, ["optimize", *map(str, args)])


@pytest.mark.parametrize(
    "args, words",
    [
        (["--var", "element.closur.preload=0:100N", "--minimize", "peak_transducer_force"], "no element named 'closur'"),
        (["--var", "element.closure.preload=50:10N", "--minimize", "min_cam_contact_force"], "empty bounds"),
        (["--var", "element.closure.preload=0:10:20N", "--minimize", "min_cam_contact_force"], "START (20) lies outside the bounds"),
        ([*PRELOAD, "--constraint", "min_cam_contact_forse>=5N"], "min_cam_contact_forse: unknown run scalar; this machine's runs have:"),
        ([*PRELOAD, "--constraint", "median:masses/F/acceleration<=5m/s^2"], "unknown reduction 'median'"),
        ([*PRELOAD, "--constraint", "max:masses/F/acceleration@300:400deg<=5m/s^2"], "must lie within 0-360 deg"),
        ([*PRELOAD, "--constraint", "max:masses/G/acceleration<=5m/s^2"], "the run has no trace 'masses/G/acceleration'"),
        ([*PRELOAD, "--constraint", "min_cam_contact_force>=5"], "the limit needs a unit (min_cam_contact_force is in N)"),
        ([*PRELOAD, "--constraint", "min_cam_contact_force>=5m"], "unit 'm' does not fit"),
        (["--var", "element.closure.preload=0:100N", "--minimize", "param:mass.F.mass"], "mass.F.mass is not an optimised key"),
        ([*PRELOAD, "--method", "nsga"], "--method nsga: unknown method"),
        ([*PRELOAD, "--budget", "0"], "--budget 0"),
        ([*PRELOAD, "--absorb", "cam.segments[9].duration"], "--absorb cam.segments[9].duration: no segment 9"),
        ([*PRELOAD, "--speeds", "140:100:10rpm"], "--speeds 140:100:10rpm"),
        ([*PRELOAD, "--robust"], "--robust: give the tolerances as --dist"),
        ([*PRELOAD, "--choice", "cam.segments[0].law=harmonic,cycloidal", "--method", "local"], "--choice: needs --method de"),
        ([*PRELOAD, "-o", "out.txt"], "out.txt: -o: unknown output format '.txt'"),
        (["--var", "element.closure.preload=30:40N", "--minimize", "param:element.closure.preload", "--method", "local"],
         "--method local: the file's values lie outside the --var bounds"),
    ],
)
def test_bad_input_exit_2_one_line_nothing_written(machine, tmp_path, monkeypatch, args, words):
    """Each bad input of the issue's list: exit 2, one line naming it, nothing written."""
    monkeypatch.chdir(tmp_path)
    before = sorted(p.name for p in tmp_path.iterdir())
    res = _run([machine, *args, *FAST, "-o", "opt.toml", "-r", "hist.h5"] if "-o" not in args else [machine, *args, *FAST])
    assert res.exit_code == 2, res.output
    lines = [x for x in res.output.strip().splitlines() if x.strip()]
    assert len(lines) == 1 and words in lines[0], res.output
    assert "Traceback" not in res.output
    assert sorted(p.name for p in tmp_path.iterdir()) == before


def test_output_over_the_input_is_refused(machine, tmp_path):
    """``-o`` naming the machine file itself: exit 2, the file unchanged."""
    text = machine.read_text()
    res = _run([machine, *PRELOAD, *FAST, "-o", machine])
    assert res.exit_code == 2 and "would write over the machine file" in res.output
    assert machine.read_text() == text


def test_absorbing_duration_below_zero_is_infeasible_not_a_crash(machine, tmp_path):
    """A segment duration that leaves the absorbing dwell ≤ 0 is an infeasible candidate, not a crash.

    Reference: the file's four segments are 90° each; with segment 0 in 60–200° the
    absorbing dwell (segment 1) is 180° − duration, ≤ 0 above 180°: those candidates are
    infeasible and the optimum, minimising the dwell's negated duration (i.e. the rise's
    duration), sits just below 180° (the least rise duration keeping the dwell positive).
    """
    res = _run([machine, "--var", "cam.segments[0].duration=60:200deg", "--absorb", "cam.segments[1].duration",
                "--maximize", "param:cam.segments[0].duration", *FAST, "--method", "de", "--budget", "40", "--json",
                "-o", tmp_path / "opt.toml"])
    assert res.exit_code == 0, res.output
    out = json.loads(res.stdout)
    assert math.degrees(out["absorb"]["value"]) > 0
    assert 150 < math.degrees(out["variables"][0]["value"]) < 180
    text = (tmp_path / "opt.toml").read_text()
    assert '# optimised: was "90 deg"' in text


def test_infeasible_problem_reports_least_violating_exit_1(machine, tmp_path):
    """No preload in 0–10 N keeps the contact force ≥ 5 N at 720 rpm (it needs 38.85 N):
    exit 1, the least-violating candidate (the largest preload, 10 N) reported, no OPTIMISED.toml."""
    out = tmp_path / "opt.toml"
    res = _run([machine, "--var", "element.closure.preload=0:10:5N", "--minimize", "param:element.closure.preload",
                "--constraint", "min_cam_contact_force>=5N", *FAST, "--method", "local", "--budget", "20", "--json", "-o", out])
    assert res.exit_code == 1, res.output
    payload = json.loads(res.stdout)
    assert payload["status"] == "infeasible"
    assert payload["optimum"]["values"]["element.closure.preload"] == pytest.approx(10.0, abs=1e-6)
    assert not out.exists()


def test_files_json_history_and_optimised_toml(machine, tmp_path):
    """OPTIMISED.toml has the optimum in the file's unit with the old value commented; the
    history holds every run and candidate; --json follows the documented schema."""
    out, hist = tmp_path / "opt.toml", tmp_path / "hist.h5"
    res = _run([machine, *PRELOAD, "--constraint", "min_cam_contact_force>=5N", *FAST, "--method", "local",
                "--budget", "30", "--json", "-o", out, "-r", hist])
    assert res.exit_code == 0, res.output
    payload = json.loads(res.stdout)
    for key in ("status", "method", "evaluations", "runs", "variables", "objectives", "constraints", "active",
                "optimum", "initial", "front", "speeds_rpm"):
        assert key in payload
    value = payload["optimum"]["values"]["element.closure.preload"]
    line = next(x for x in out.read_text().splitlines() if x.startswith("preload"))
    assert line.startswith(f'preload = "{value:.7g} N"') and '# optimised: was "20 N"' in line
    with h5py.File(hist) as f:
        assert f["optimize/candidates"].shape[0] == payload["evaluations"]
        assert f["optimize/runs"].shape[0] == payload["runs"]
    assert not hist.with_name(hist.name + ".journal").exists()


SCRIPT = """
import sys
from camsim.cli import main
sys.argv = ["camsim", "optimize", *sys.argv[1:]]
main()
"""


def _command(machine, hist, *extra):
    return [sys.executable, "-c", SCRIPT, str(machine), "--var", "element.closure.preload=0:100N", "--var",
            "element.closure.stiffness=1000:4000N/m", "--minimize", "peak_acceleration:F", "--constraint",
            "min_cam_contact_force>=5N", *FAST, "--method", "de", "--budget", "40", "--json", "-r", str(hist), *extra]


@pytest.mark.slow
def test_resume_after_sigkill_loses_and_repeats_nothing(machine, tmp_path):
    """SIGKILL in the middle, then --resume: the same optimum as an uninterrupted job, and
    the runs of the two parts add up to the uninterrupted job's runs (none lost, none repeated)."""
    ref = subprocess.run(_command(machine, tmp_path / "ref.h5"), capture_output=True, text=True, check=True)
    reference = json.loads(ref.stdout)
    hist = tmp_path / "hist.h5"
    journal = hist.with_name(hist.name + ".journal")
    proc = subprocess.Popen(_command(machine, hist), stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    deadline = time.monotonic() + 120
    while time.monotonic() < deadline:
        if journal.exists() and len(journal.read_bytes().splitlines()) > 15:
            break
        time.sleep(0.05)
    os.kill(proc.pid, signal.SIGKILL)
    proc.wait()
    stored = len(journal.read_bytes().splitlines()) - 1  # header line
    assert 0 < stored < reference["runs"]
    again = subprocess.run(_command(machine, hist), capture_output=True, text=True)
    assert again.returncode == 2 and "--resume" in again.stderr and "--fresh" in again.stderr
    resumed = subprocess.run(_command(machine, hist, "--resume"), capture_output=True, text=True, check=True)
    payload = json.loads(resumed.stdout)
    assert payload["runs_reused"] >= stored
    assert payload["runs"] == reference["runs"]
    assert payload["optimum"]["values"] == reference["optimum"]["values"]
    assert payload["evaluations"] == reference["evaluations"]

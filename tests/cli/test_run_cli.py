"""`camsim run` and `camsim modes` from the command line: outputs, layout, errors.

Expected numbers come from closed forms stated in each test; the run file layout is
spec §7.
"""

from __future__ import annotations

import hashlib
import json
import math
from pathlib import Path

import h5py
import numpy as np
import pytest
from typer.testing import CliRunner

from camsim.cli import app
from camsim.errors import SimulationError

ROOT = Path(__file__).resolve().parents[2]
MACHINES = ROOT / "machines"

#: One mass on a spring to the cam, no contacts: a base-excited oscillator.
OSCILLATOR = """
schema = 1
[machine]
name = "oscillator"
[cam]
speed = "300 rpm"
segments = [
  { motion = "rise", law = "cycloidal", duration = "90 deg", lift = "10 mm" },
  { motion = "dwell", duration = "90 deg" },
  { motion = "fall", law = "cycloidal", duration = "90 deg", lift = "10 mm" },
  { motion = "dwell", duration = "90 deg" },
]
[[mass]]
name = "m"
mass = "2 kg"
[[element]]
name = "k"
type = "spring"
between = ["cam", "m"]
stiffness = "20000 N/m"
damping_ratio = 0.05
[simulation]
cycles = 1
warmup_cycles = 0
sample_rate = "5 kHz"
"""


def run(args):
    return CliRunner().invoke(app, args)


@pytest.fixture
def oscillator(tmp_path) -> Path:
    path = tmp_path / "osc.toml"
    path.write_text(OSCILLATOR)
    return path


def test_default_output_next_to_the_input(oscillator):
    result = run(["run", str(oscillator)])
    assert result.exit_code == 0, result.output
    assert (oscillator.parent / "osc.h5").exists()


def test_json_is_the_only_stdout(oscillator, tmp_path):
    result = CliRunner().invoke(app, ["run", str(oscillator), "-o", str(tmp_path / "o.h5"), "--json"])
    assert result.exit_code == 0
    payload = json.loads(result.stdout)
    assert payload["machine"] == "oscillator"
    assert set(payload["masses"]["m"]) == {"displacement", "velocity", "acceleration"}
    assert payload["impacts"] == []


def test_layout_units_and_dimension_scale(oscillator, tmp_path):
    """Spec §7: every trace carries units and long_name and has /time attached."""
    out = tmp_path / "o.h5"
    assert run(["run", str(oscillator), "-o", str(out)]).exit_code == 0
    with h5py.File(out) as f:
        assert f.attrs["schema"] == 1 and f.attrs["units_system"] == "SI"
        assert f.attrs["machine_sha256"] == hashlib.sha256(f.attrs["machine_toml"].encode()).hexdigest()
        time = f["time"]
        assert time.attrs["units"] == "s"
        # 300 rpm: one revolution = 0.2 s at 5 kHz -> 1001 samples including both ends
        assert time.shape == (1001,)
        assert time[0] == 0.0 and time[-1] == pytest.approx(0.2, abs=1e-12)
        paths = [
            "cam/angle", "cam/displacement", "cam/velocity", "cam/acceleration", "cam/jerk",
            "masses/m/displacement", "masses/m/velocity", "masses/m/acceleration", "elements/k/force",
        ]
        for path in paths:
            dset = f[path]
            assert dset.attrs["units"] and dset.attrs["long_name"], path
            assert dset.dims[0][0].name == "/time", path
        assert f["cam/angle"][-1] == pytest.approx(360.0)
        assert "events" in f and f["events"].shape == (0,)


def test_same_input_same_bytes(oscillator, tmp_path):
    a, b = tmp_path / "a.h5", tmp_path / "b.h5"
    assert run(["run", str(oscillator), "-o", str(a)]).exit_code == 0
    assert run(["run", str(oscillator), "-o", str(b)]).exit_code == 0
    assert a.read_bytes() == b.read_bytes()


def test_set_override_changes_the_run(oscillator, tmp_path):
    """Doubling the stiffness: the spring force at the top dwell is unchanged (static),
    and the run records the override in the stored machine text."""
    out = tmp_path / "o.h5"
    result = run(["run", str(oscillator), "-o", str(out), "--set", "element.k.stiffness=40000 N/m"])
    assert result.exit_code == 0, result.output
    with h5py.File(out) as f:
        assert "40000" in f.attrs["machine_toml"]


@pytest.mark.parametrize(
    "args, needle",
    [
        (["run", "missing.toml"], "missing.toml"),
        (["run", "{machine}", "--set", "element.k.stifness=1"], "stifness"),
        (["run", "{machine}", "--set", "element.k.stiffness=3 kg"], "element"),
        (["run", "{machine}", "--sample-rate", "3 m"], "--sample-rate"),
        (["run", "{machine}", "-o", "/nonexistent-dir/x.h5"], "/nonexistent-dir"),
    ],
)
def test_bad_input_one_line_exit_2_nothing_written(oscillator, tmp_path, args, needle):
    args = [a.replace("{machine}", str(oscillator)) for a in args]
    before = set(tmp_path.iterdir())
    result = run(args)
    assert result.exit_code == 2, result.output
    lines = [line for line in result.output.splitlines() if line.strip()]
    assert len(lines) == 1 and needle in lines[0], result.output
    assert "Traceback" not in result.output
    assert set(tmp_path.iterdir()) == before


def test_interrupted_run_leaves_no_file(oscillator, tmp_path, monkeypatch):
    import camsim.run.stream

    def interrupted(*args, **kwargs):
        raise KeyboardInterrupt  # while the run streams into its temporary file

    monkeypatch.setattr(camsim.run.stream, "_simulate", interrupted)
    out = tmp_path / "o.h5"
    result = run(["run", str(oscillator), "-o", str(out)])
    assert result.exit_code == 130
    assert list(tmp_path.iterdir()) == [oscillator]


def test_failed_run_exit_1(oscillator, tmp_path, monkeypatch):
    import camsim.run.stream

    def diverges(*args, **kwargs):
        raise SimulationError("the run diverged before t = 0.1 s (non-finite state)")

    monkeypatch.setattr(camsim.run.stream, "_simulate", diverges)
    result = run(["run", str(oscillator), "-o", str(tmp_path / "o.h5")])
    assert result.exit_code == 1
    assert "diverged" in result.output
    assert list(tmp_path.iterdir()) == [oscillator]  # no result, no temporary file


def test_low_sample_rate_warns(oscillator, tmp_path):
    """f_n = √(k/m)/2π = √(20000/2)/2π = 15.9 Hz: 20 Hz sampling is below 2·f_n."""
    result = run(["run", str(oscillator), "-o", str(tmp_path / "o.h5"), "--sample-rate", "20 Hz", "--json"])
    assert result.exit_code == 0, result.output
    payload = json.loads(result.stdout)
    assert any("below twice the highest natural frequency" in w for w in payload["warnings"])


def test_modes_single_oscillator(oscillator):
    """Closed form: ω_n = √(k/m) = 100 rad/s → 15.915 Hz, ζ = 0.05 (c = 2ζ√(k·m))."""
    result = CliRunner().invoke(app, ["modes", str(oscillator), "--json"])
    assert result.exit_code == 0, result.output
    (config,) = json.loads(result.stdout)
    assert config["frequencies_hz"] == pytest.approx([100 / (2 * math.pi)], rel=1e-12)
    assert config["damping_ratios"] == pytest.approx([0.05], rel=1e-12)


def test_modes_cdtm_has_four_configurations():
    """K23 joined/separated × seat open/closed; with the seat closed and the link joined the
    highest mode involves M3 on the seat: above √(k_seat/M3)/2π = 1.1 kHz."""
    result = CliRunner().invoke(app, ["modes", str(MACHINES / "cdtm.toml"), "--json"])
    assert result.exit_code == 0
    configs = json.loads(result.stdout)
    assert len(configs) == 4
    seat_only = math.sqrt(8597740 / (0.3854 * 0.45359237)) / (2 * math.pi)
    closed = [c for c in configs if c["branches"]["seat"] == "closed"]
    assert all(max(c["frequencies_hz"]) > seat_only for c in closed)


def test_no_impact_run_has_no_contact_events(tmp_path):
    out = tmp_path / "c.h5"
    result = run(["run", str(MACHINES / "cdtm.toml"), "-o", str(out), "--no-impact", "--sample-rate", "2 kHz", "--json"])
    assert result.exit_code == 0, result.output
    payload = json.loads(result.stdout)
    assert payload["no_impact"] is True and payload["impacts"] == []
    with h5py.File(out) as f:
        assert "elements/seat/force" not in f


def test_version_and_module_entry():
    import subprocess
    import sys

    out = subprocess.run([sys.executable, "-m", "camsim", "--version"], capture_output=True, text=True, check=True)
    assert out.stdout.startswith("camsim ")


def test_rigid_stop_json_has_null_bounds(tmp_path):
    """Above the jump onset (447.6 rpm, machine comments) the follower lands on the cam again:
    a rigid (restitution) impact, whose Johnson bound is unbounded — null in JSON, ∞ in HDF5."""
    out = tmp_path / "b.h5"
    result = run(["run", str(MACHINES / "barkan-follower.toml"), "-o", str(out), "--set", "cam.speed=480 rpm", "--json"])
    assert result.exit_code == 0, result.output
    payload = json.loads(result.stdout)
    assert payload["jump"] is True
    assert payload["impacts"] and all(i["johnson_upper"] is None for i in payload["impacts"])
    with h5py.File(out) as f:
        kinds = [k.decode() if isinstance(k, bytes) else k for k in f["events"]["kind"]]
        assert "release" in kinds and "impact" in kinds
        assert np.isinf(f["events"]["johnson_upper"][kinds.index("impact")])


DRIVEN = """
schema = 1
[machine]
name = "driven follower"
[cam]
speed = "600 rpm"
drives = "F"
segments = [
  { motion = "rise", law = "cycloidal", duration = "90 deg", lift = "20 mm" },
  { motion = "dwell", duration = "90 deg" },
  { motion = "fall", law = "cycloidal", duration = "90 deg", lift = "20 mm" },
  { motion = "dwell", duration = "90 deg" },
]
[[mass]]
name = "F"
mass = "1 kg"
[[mass]]
name = "B"
mass = "0.5 kg"
[[element]]
name = "closure"
type = "spring"
between = ["ground", "F"]
stiffness = "1000 N/m"
preload = "50 N"
[[element]]
name = "body"
type = "spring"
between = ["F", "B"]
stiffness = "1e5 N/m"
damping_ratio = 0.05
[simulation]
cycles = 1
warmup_cycles = 0
sample_rate = "20 kHz"
"""


def test_cam_contact_force_and_jump_rows(tmp_path):
    """With a rigid body B on F the cam must push m_F·s̈ + (forces of the springs on F);
    at 600 rpm the cycloidal deceleration 2π·h·(ω/β)² = 2π·0.02·400 = 50.3 m/s² times
    1.5 kg (F and B move together, slowly vibrating) exceeds the 50 N preload: the cam
    contact force turns negative near the middle of the rise, and a `jump` row marks it."""
    path = tmp_path / "driven.toml"
    path.write_text(DRIVEN)
    out = tmp_path / "d.h5"
    result = run(["run", str(path), "-o", str(out), "--json"])
    assert result.exit_code == 0, result.output
    payload = json.loads(result.stdout)
    assert payload["jump"] is True
    assert payload["min_cam_contact_force"]["value"] < 0
    with h5py.File(out) as f:
        fc = f["cam_contact/force"][:]
        t = f["time"][:]
        kinds = [k.decode() if isinstance(k, bytes) else k for k in f["events"]["kind"]]
        jump_times = f["events"]["time"][[k == "jump" for k in kinds]]
    crossings = np.flatnonzero((fc[1:] < 0) & (fc[:-1] >= 0))
    assert len(jump_times) == len(crossings) >= 1
    for k, tj in zip(crossings, jump_times):
        assert t[k] <= tj <= t[k + 1]
    assert any("goes negative" in w for w in payload["warnings"])

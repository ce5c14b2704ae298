"""Bad input to ``camsim study``: exit 2, one line on stderr naming the culprit, nothing written (issue 15)."""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest
from typer.testing import CliRunner

from camsim.cli import app

HERE = Path(__file__).parent
runner = CliRunner()
GOOD = "element.closure.preload=tol:20:3N"


@pytest.mark.parametrize(
    "args, words",
    [
        (["--dist", "element.closure.preload=weibull:1:2N"], "--dist element.closure.preload=weibull:1:2N: unknown distribution 'weibull'"),
        (["--dist", "element.closure.preload=normal:20:0N"], "--dist element.closure.preload=normal:20:0N: STD must be > 0"),
        (["--dist", "element.closure.preload=normal:20:-1N"], "STD must be > 0"),
        (["--dist", "element.closure.preload=uniform:21:19N"], "--dist element.closure.preload=uniform:21:19N: LOW must be below HIGH"),
        (["--dist", "element.closure.preload=truncnormal:20:1:25:22N"], "LOW must be below HIGH"),
        (["--dist", "element.closure.preload=tol:20:+2:+1N"], "--dist element.closure.preload=tol:20:+2:+1N: the nominal 20 lies outside its own tolerance"),
        (["--dist", "element.closur.stiffness=tol:2000:100N/m"], "element.closur.stiffness: no element named 'closur'; did you mean 'closure'? (--dist element.closur.stiffness=tol:2000:100N/m)"),
        (["--dist", "mass.F.mas=normal:0.5:0.01kg"], "--dist mass.F.mas=normal:0.5:0.01kg"),
        (["--dist", GOOD, "--limit", "min_cam_contact_forse<0N"], "--limit min_cam_contact_forse<0N: unknown quantity 'min_cam_contact_forse'; did you mean min_cam_contact_force?"),
        (["--dist", GOOD, "--limit", "min_cam_contact_force<0m"], "--limit min_cam_contact_force<0m: unit 'm' does not fit"),
        (["--dist", GOOD, "--limit", "min_cam_contact_force=0N"], "--limit min_cam_contact_force=0N: expected QUANTITY<VALUE"),
        (["--dist", GOOD, "-n", "0"], "--samples 0"),
        (["--dist", GOOD, "-n", "100", "--sensitivity"], "--samples 100: --sensitivity needs a power of two"),
        (["--dist", GOOD, "--method", "halton"], "--method halton: unknown sampling method"),
        (["--dist", GOOD, "--reduce", "max:masses/F/jerk"], "--reduce max:masses/F/jerk: the run has no trace 'masses/F/jerk'"),
        (["--dist", GOOD, "--reduce", "median:transducer/force"], "--reduce median:transducer/force: unknown reduction 'median'"),
        (["--dist", GOOD, "--dist", "mass.F.mass=normal:0.5:0.01kg", "--correlate", "mass.F.mass,element.closure.preload=0.5", "--sensitivity", "-n", "8"], "--sensitivity: Sobol' indices need independent inputs"),
        (["--dist", GOOD, "--correlate", "mass.F.mass,element.closure.preload=0.5"], "--correlate mass.F.mass,element.closure.preload=0.5: mass.F.mass is not one of the --dist inputs"),
        (["--dist", GOOD, "--dist", GOOD], "--dist: key element.closure.preload is given twice"),
        (["--dist", GOOD, "--set", "element.closure.preload=21N"], "also fixed by --set"),
        (["--dist", GOOD, "--tol-sigma", "0"], "--tol-sigma 0.0: must be a positive number"),
        (["--dist", GOOD, "--plot", "x.bmp"], "--plot: unknown figure format '.bmp'"),
        (["--dist", GOOD, "--sample-rate", "3 m"], "--sample-rate"),
        ([], "give at least one --dist KEY=SPEC"),
        (["--dist", GOOD, "--units", "metric"], "--units metric: expected one of file, si, us"),
    ],
)
def test_bad_input_exit_2_one_line_nothing_written(tmp_path, args, words):
    machine = tmp_path / "m.toml"
    shutil.copy(HERE / "driven_follower.toml", machine)
    r = runner.invoke(app, ["study", str(machine), *args, "-o", str(tmp_path / "s.h5"), "--workers", "1"])
    assert r.exit_code == 2, r.stderr
    assert r.stdout == ""
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("camsim: error: ") and words in lines[0], r.stderr
    assert sorted(p.name for p in tmp_path.iterdir()) == ["m.toml"]  # nothing written


def test_unreachable_scheduler_leaves_nothing(tmp_path):
    import socket

    s = socket.socket()
    s.bind(("127.0.0.1", 0))
    port = s.getsockname()[1]
    s.close()
    r = runner.invoke(app, ["study", str(HERE / "driven_follower.toml"), "--dist", GOOD, "-n", "4", "-o", str(tmp_path / "s.h5"), "--scheduler", f"tcp://127.0.0.1:{port}"])
    assert r.exit_code == 2 and f"--scheduler tcp://127.0.0.1:{port}" in r.stderr
    assert list(tmp_path.iterdir()) == []

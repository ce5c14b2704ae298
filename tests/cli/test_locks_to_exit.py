"""Every output locked from the check to the process's exit (issue 45, item 4).

References: the issue's concurrent writers, reproduced with two real processes. Before the
fix an output that did not exist yet was claimed only when written (two ``optimize -o o.toml``
at once both exited 0; ``x.h5`` and ``x.hdf5`` sweeps both wrote ``x.csv``; ``export -o x.csv``
ran beside a sweep that would write ``x.csv``), and ``run`` released its lock about a second
before its process ended.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
from typer.testing import CliRunner

from camsim.cli import app
from camsim.io.locks import is_locked, lock_path_for

ROOT = Path(__file__).resolve().parents[2]
CDTM = str(ROOT / "machines" / "cdtm.toml")
ENV = {**os.environ, "PYTHONPATH": str(ROOT), "PYTHONWARNINGS": "ignore"}
runner = CliRunner()


def _start(args, cwd):
    return subprocess.Popen([sys.executable, "-m", "camsim", *args], cwd=cwd, env=ENV, stdout=subprocess.DEVNULL,
                            stderr=subprocess.PIPE)


def _wait_locked(path: Path, proc, timeout: float = 30.0) -> int:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        pid = is_locked(path)
        if pid:
            return pid
        assert proc.poll() is None, proc.stderr.read().decode()
        time.sleep(0.01)
    raise AssertionError(f"{path} never locked")


def _stop(proc) -> None:
    if proc.poll() is None:
        proc.send_signal(signal.SIGKILL)
    proc.wait()


def test_run_holds_its_lock_until_its_process_ends(tmp_path):
    """The lock of `run -o r.h5` is free only when the process is gone (it was free ~1 s before)."""
    out = tmp_path / "r.h5"
    proc = _start(["run", str(ROOT / "machines" / "barkan-follower.toml"), "-o", str(out), "-q"], tmp_path)
    try:
        _wait_locked(out, proc)
        while is_locked(out):
            time.sleep(0.002)
        freed = time.monotonic()
        while proc.poll() is None and time.monotonic() - freed < 5:
            time.sleep(0.002)
        gap = time.monotonic() - freed
    finally:
        _stop(proc)
    assert proc.returncode == 0, proc.stderr.read().decode()
    assert gap < 0.08, f"the lock was free {gap:.2f} s before the process ended"
    assert out.exists() and not lock_path_for(out).exists()


@pytest.mark.parametrize("second", [["sweep", CDTM, "--vary", "cam.speed=100:120:20rpm", "--workers", "1", "-q",
                                     "-o", "{dir}/x.hdf5"],
                                    ["export", "{run}", "-o", "{dir}/x.csv"]],
                         ids=["sweep-x.hdf5", "export-x.csv"])
def test_a_companion_is_locked_while_its_sweep_runs(second, tmp_path):
    """`sweep -o x.h5` claims x.csv when it starts: a sweep to x.hdf5 (whose CSV is x.csv too) and
    `export -o x.csv` are refused, exit 2 naming its PID."""
    run = tmp_path / "run.h5"
    r = runner.invoke(app, ["run", str(ROOT / "machines" / "barkan-follower.toml"), "-o", str(run), "-q"])
    assert r.exit_code == 0, r.stderr
    first = _start(["sweep", CDTM, "--vary", "cam.speed=60:600:5rpm", "--workers", "1", "-q", "-o",
                    str(tmp_path / "x.h5")], tmp_path)
    try:
        pid = _wait_locked(tmp_path / "x.csv", first)
        assert pid == first.pid
        args = [a.replace("{dir}", str(tmp_path)).replace("{run}", str(run)) for a in second]
        r = runner.invoke(app, args)
        assert first.poll() is None
    finally:
        _stop(first)
    assert r.exit_code == 2, r.stderr
    assert f"PID {first.pid}" in r.stderr and "x.csv" in r.stderr, r.stderr
    assert not (tmp_path / "x.hdf5").exists()

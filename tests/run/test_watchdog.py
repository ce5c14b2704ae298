"""Never silent: every engine route reports progress through one channel, and a run that makes
no progress stops with one line (issue 45, item 3).

References: the issue's reproducers. Before the fix ``camsim run machines/cdtm-power.toml --set
element.seat.gap="62500.0 in"`` printed nothing for 600 s (the DOP853 fallback inside
``engine/nonlinear.advance_power`` never returned to the integrator's loop, the only place that
reported progress), and ``machines/cdtm-rod.toml --set element.seat.gap="62.5 in"`` printed
"about 3 s left" and then nothing until stopped at 600 s (the extremes' location after the
integration). The watchdog's wall time is set small for the tests (``CAMSIM_STALL_SECONDS``);
the channel's own logic is checked on a fake clock.
"""

from __future__ import annotations

import os
import subprocess
import sys
import time
from pathlib import Path

import pytest

import camsim.engine.nonlinear as nonlinear
import camsim.engine.span as span
from camsim import heartbeat
from camsim.machine.loader import load_machine
from camsim.run import simulation
from camsim.run.simulation import simulate
from camsim.run.watchdog import RunClock, StallError, watching

ROOT = Path(__file__).resolve().parents[2]
MACHINES = ROOT / "machines"


class FakeClock:
    def __init__(self):
        self.now = 0.0

    def __call__(self):
        return self.now


def test_the_channel_reports_and_stops_a_stalled_run():
    wall = FakeClock()
    reported = []
    clock = RunClock(reported.append, quantum=1e-3, source="m.toml", stall_after=5.0, clock=wall)
    for k in range(10):  # progress: one sample of simulated time per beat
        wall.now += 1.0
        clock(k * 1e-3)
    wall.now += 4.0
    clock(9.5e-3)  # less than a sample, within the limit: no error
    assert reported and reported[-1] == 9.5e-3
    clock(0.0)  # back to the start: a new pass of the relaxation, not a stall
    assert clock.passes == 1
    wall.now += 4.9
    clock(0.5e-3)
    wall.now += 0.2
    with pytest.raises(StallError, match=r"m\.toml: the run stalled at t = 0\.0006 s: no progress in simulated time "
                                         r"for 5 s of wall time .*CAMSIM_STALL_SECONDS"):
        clock(0.6e-3)


def test_a_phase_without_beats_is_watched_by_the_timer(monkeypatch):
    """The timer's tick stops a run stuck where nothing beats (here: a result assembly that sleeps)."""
    machine = load_machine(MACHINES / "barkan-follower.toml")
    monkeypatch.setenv("CAMSIM_STALL_SECONDS", "1")
    real = simulation._assemble

    def stuck(run, stretches):
        time.sleep(30)
        return real(run, stretches)

    monkeypatch.setattr(simulation, "_assemble", stuck)
    started = time.monotonic()
    with pytest.raises(StallError, match="stalled while locating the extremes"):
        simulate(machine, cycles=1, warmup_cycles=0, sample_rate=1000.0)
    assert time.monotonic() - started < 10


def test_an_assembly_that_works_on_is_not_a_stall(monkeypatch):
    """The extremes of a chattering revolution take minutes on a loaded machine (thousands of
    refinements after the integration): each refinement tells the channel it advanced
    (``heartbeat.working``), so only an assembly that does nothing for the limit is a stall.
    Here an assembly of 3 s that works every 0.1 s passes a limit of 1 s; the same assembly
    silent is stopped (the test above)."""
    machine = load_machine(MACHINES / "barkan-follower.toml")
    monkeypatch.setenv("CAMSIM_STALL_SECONDS", "1")
    real = simulation._assemble

    def slow_but_working(run, stretches):
        for _ in range(30):
            time.sleep(0.1)
            heartbeat.working()
        return real(run, stretches)

    monkeypatch.setattr(simulation, "_assemble", slow_but_working)
    result = simulate(machine, cycles=1, warmup_cycles=0, sample_rate=1000.0)
    assert result.time.size > 0


def test_the_clock_counts_work_outside_simulated_time_as_progress_only():
    wall = FakeClock()
    clock = RunClock(None, quantum=1e-3, source="m.toml", stall_after=5.0, clock=wall)
    clock(0.02)
    for _ in range(10):  # 40 s of assembly, working every 4 s
        wall.now += 4.0
        clock.beat(None)
        clock.tick()
    assert clock.t == 0.02 and clock.passes == 0  # neither a simulated time nor a new pass
    wall.now += 5.1
    with pytest.raises(StallError):
        clock.tick()


def test_every_engine_route_beats_through_the_channel(monkeypatch):
    """The power-law contact's windows and the DOP853 spans report to the run's channel (before,
    only the integrator's loop reported)."""
    seen: dict[str, int] = {"nonlinear": 0, "span": 0}

    def counting(module, name):
        def beat(t):
            seen[name] += 1
            heartbeat.beat(t)
        monkeypatch.setattr(module, "beat", beat)

    counting(nonlinear, "nonlinear")
    counting(span, "span")
    machine = load_machine(MACHINES / "cdtm-power.toml")
    fractions = []
    simulate(machine, cycles=1, warmup_cycles=0, sample_rate=10000.0, progress=fractions.append)
    assert seen["nonlinear"] > 0 and seen["span"] > 0, seen
    assert fractions and fractions[-1] == 1.0


def test_watching_nests_into_the_outer_run():
    """A camshaft relaxation's passes report to the run that started them."""
    outer = RunClock(None, 1e-3, "a")
    with watching(outer) as active:
        assert active is outer
        with watching(RunClock(None, 1e-3, "b")) as inner:
            assert inner is outer
    assert heartbeat.listener() is None


def _run(args, stall: str, timeout: float):
    env = {**os.environ, "PYTHONPATH": str(ROOT), "CAMSIM_STALL_SECONDS": stall}
    return subprocess.run([sys.executable, "-m", "camsim", *args], capture_output=True, text=True, env=env,
                          timeout=timeout)


@pytest.mark.full  # before a release (CAMSIM_FULL=1): .ci/run's 15 minutes
def test_a_stalled_run_stops_with_one_line(tmp_path):
    """cdtm-rod with a 62.5 in seat gap: exit 1, one line naming the stall (it was silent to 600 s)."""
    out = tmp_path / "r.h5"
    r = _run(["run", str(MACHINES / "cdtm-rod.toml"), "--set", 'element.seat.gap=62.5 in', "-q", "-o", str(out)],
             "3", 300)
    assert r.returncode == 1, r.stderr
    lines = [line for line in r.stderr.splitlines() if line.strip()]
    assert len(lines) == 1 and "cdtm-rod.toml: the run stalled" in lines[0], r.stderr
    assert not out.exists()


@pytest.mark.full  # before a release (CAMSIM_FULL=1): .ci/run's 15 minutes
def test_the_dop853_fallback_prints_a_line_every_10_s(tmp_path):
    """cdtm-power with a 62500 in seat gap: progress lines off a terminal (it printed nothing for 600 s)."""
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    proc = subprocess.Popen([sys.executable, "-m", "camsim", "run", str(MACHINES / "cdtm-power.toml"), "--set",
                             'element.seat.gap=62500.0 in', "-o", str(tmp_path / "p.h5")], stderr=subprocess.PIPE,
                            stdout=subprocess.DEVNULL, env=env, text=True)
    try:
        time.sleep(32)
    finally:
        proc.terminate()
        _, err = proc.communicate(timeout=30)
    lines = [line for line in err.splitlines() if line.startswith("run: ")]
    assert len(lines) >= 2, err

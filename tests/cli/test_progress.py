"""Progress of long commands (issue 34): a line every LINE_INTERVAL seconds on stderr when
it is not a terminal, nothing with --quiet, stdout untouched (camsim.cli.progress)."""

from __future__ import annotations

import json
import sys
from pathlib import Path

import pytest
from typer.testing import CliRunner

import camsim.cli.progress as progress
from camsim.cli import app
from camsim.cli.progress import Bar, FractionBar, Lines

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "tests"))
from cli.test_run_cli import OSCILLATOR  # noqa: E402 - one mass on a spring to the cam, one revolution


@pytest.fixture
def every_call(monkeypatch):
    """A line at every call (the interval set to zero); the clock starts at t = 0 and
    advances 2 s per reading, so the rates and times left are known."""
    ticks = iter(range(0, 10_000, 2))
    monkeypatch.setattr(progress, "LINE_INTERVAL", 0.0)
    monkeypatch.setattr(progress.time, "monotonic", lambda: float(next(ticks)))


def test_bar_lines_give_done_total_rate_and_time_left(every_call, capsys):
    """Not a terminal (pytest captures stderr): the clock starts at 0, the call reads it
    at 2 s with 3 of 12 variants done: 1.5 variants/s, 9 left → 6 s."""
    bar = Bar("sweep", "variants")
    bar.start(12, "2 workers")
    bar(3, 12)
    bar.close()
    bar(4, 12)  # closed: silent
    err = capsys.readouterr().err.splitlines()
    assert err == ["sweep (2 workers): 3/12 variants (25 %), 1.5 variants/s, about 6 s left"]


def test_fraction_bar_and_note(every_call, capsys):
    bar = FractionBar("run", "rev", 3.0)
    bar(0.5, note="best: 1.2 N")
    assert capsys.readouterr().err.strip() == "run: 1.5/3 rev (50 %), 0.75 rev/s, about 2 s left, best: 1.2 N"


def test_quiet_and_terminal_print_no_lines(every_call, capsys, monkeypatch):
    bar = Bar("run", "rev", quiet=True)
    bar.start(2)
    bar(1, 2)
    Lines(quiet=True)("iteration 1")
    assert capsys.readouterr().err == ""


def test_lines_keep_the_latest_every_interval(monkeypatch, capsys):
    """The fit's iteration lines off a terminal: the first after LINE_INTERVAL, then one
    per interval (the clock reads 0, 4, 8, 12 … s; interval 10 s)."""
    ticks = iter(range(0, 10_000, 4))
    monkeypatch.setattr(progress.time, "monotonic", lambda: float(next(ticks)))
    lines = Lines()
    for k in range(1, 8):
        lines(f"iteration {k}")
    # start 0; readings at 4, 8 (not due), 12 (due: next at 22), 16, 20 (not), 24 (due), 28
    assert capsys.readouterr().err.splitlines() == ["iteration 3", "iteration 6"]


def test_run_off_a_terminal_prints_progress_lines_and_keeps_stdout_json(every_call, tmp_path: Path):
    """`camsim run --json` off a terminal: progress lines on stderr ("run: …/1 rev"), the JSON
    alone on stdout; with -q no progress line."""
    path = tmp_path / "osc.toml"
    path.write_text(OSCILLATOR)
    runner = CliRunner()
    result = runner.invoke(app, ["run", str(path), "-o", str(tmp_path / "o.h5"), "--json"])
    assert result.exit_code == 0, result.output
    json.loads(result.stdout)
    lines = [ln for ln in result.stderr.splitlines() if ln.startswith("run: ")]
    assert lines and all("/1 rev (" in ln for ln in lines)
    quiet = runner.invoke(app, ["run", str(path), "-o", str(tmp_path / "q.h5"), "--json", "-q"])
    assert quiet.exit_code == 0, quiet.output
    assert not [ln for ln in quiet.stderr.splitlines() if ln.startswith("run: ")]


def test_lines_go_on_while_nothing_finishes(monkeypatch, capsys):
    """Issue 45: off a terminal a line every LINE_INTERVAL even while no unit finishes (a
    sweep's slow variant in a worker process: the bar was called only when a variant ended)."""
    monkeypatch.setattr(progress, "LINE_INTERVAL", 0.4)
    bar = Bar("sweep", "variants")
    bar.enabled, bar.lines = False, True
    bar.start(10)
    bar(1, 10)
    import time

    time.sleep(2.0)  # nothing finishes meanwhile
    bar.close()
    lines = [line for line in capsys.readouterr().err.splitlines() if line.startswith("sweep: 1/10 variants")]
    assert len(lines) >= 2, lines

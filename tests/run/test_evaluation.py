"""The design evaluation (issue 42 item 2): a run's summary without its traces.

Reference: the full run, :func:`camsim.run.simulation.simulate`, on the same machine and
settings. :func:`camsim.run.evaluation.evaluate` integrates on the same grid with the same
code, so every summary scalar, every event and every located extreme must be the same to
the bit (NaN where the full run has NaN); a machine whose scalars read samples is run in
full (:func:`camsim.run.evaluation.reads_samples`), so its scalars are the full run's too.
"""

from __future__ import annotations

import math
from pathlib import Path

import pytest

from camsim.machine.loader import load_machine
from camsim.run.evaluation import evaluate, reads_samples
from camsim.run.simulation import simulate

ROOT = Path(__file__).resolve().parents[2]
FAST = ["cdtm", "dynacam-2mass", "ball-drop", "ball-drop-hertz", "cdtm-compensated"]
SLOW = ["cdtm-power", pytest.param("cdtm-rod", marks=pytest.mark.full), "barkan-follower", "cdtm-geometry",
        "camshaft-line", "conveyor-match"]  # cdtm-rod: 25 s, before a release (CAMSIM_FULL=1; .ci/run's 15 minutes)


def _same(a, b) -> bool:
    if isinstance(a, float) and isinstance(b, float) and math.isnan(a) and math.isnan(b):
        return True
    return a == b


def _check(name: str, no_impact: bool) -> None:
    machine = load_machine(ROOT / "machines" / f"{name}.toml")
    full, summary = simulate(machine, no_impact=no_impact), evaluate(machine, no_impact=no_impact)
    a, b = full.scalars(), summary.scalars()
    assert set(a) == set(b)
    assert [k for k in a if not _same(a[k], b[k])] == []
    assert [(e.time, e.element, e.kind, e.peak_force) for e in full.events] == \
           [(e.time, e.element, e.kind, e.peak_force) for e in summary.events]
    assert full.located == summary.located
    assert full.warnings == summary.warnings
    if not reads_samples(machine):
        assert summary.time.size == 0  # no trace was assembled


@pytest.mark.parametrize("no_impact", [False, True])
@pytest.mark.parametrize("name", FAST)
def test_the_summary_is_the_full_runs(name, no_impact):
    _check(name, no_impact)


@pytest.mark.slow
@pytest.mark.parametrize("name", SLOW)
def test_the_summary_is_the_full_runs_slow(name):
    _check(name, False)


def test_a_machine_whose_scalars_read_samples_is_run_in_full():
    """A cam with geometry (torque RMS, energy fluctuation from the samples) and a camshaft
    (its accumulators) are run in full; the CDTM's scalars are all located or from events."""
    assert reads_samples(load_machine(ROOT / "machines" / "cdtm-geometry.toml"))
    assert reads_samples(load_machine(ROOT / "machines" / "camshaft-line.toml"))
    assert not reads_samples(load_machine(ROOT / "machines" / "cdtm.toml"))

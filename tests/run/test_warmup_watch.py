"""A warm-up's cam contact force watch keeps only F_c's sign at its end (issue 42).

The warm-up's events are not reported, so its watch no longer locates jumps; the recording
reads its last F_c to tell whether a negative F_c at the window's start is a jump (spec §7).
Reference: the same runs with a warm-up that locates every jump (the watch as it was), event
for event and bit for bit, for a follower that jumps twice a revolution, its recording
starting where F_c is negative (no jump row there) and where it is positive.
"""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

from camsim.engine.watch import CamForceWatch
from camsim.machine.loader import load_machine_text
from camsim.run.evaluation import evaluate
from camsim.run.simulation import simulate

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # tests/: the driven followers of test_event_grid
from test_event_grid import _driven  # noqa: E402


class _AlwaysLocating(CamForceWatch):
    """The watch as before issue 42's change: it locates in the warm-up too."""

    @property
    def locating(self):
        return True

    @locating.setter
    def locating(self, value):
        pass


def _rows(run):
    return [(e.time, e.element, str(e.kind), e.masses) for e in run.events]


@pytest.mark.parametrize("start_deg", [60.0, 0.0])
def test_recorded_jumps_as_with_a_warm_up_that_locates_them(start_deg, monkeypatch):
    # a driven follower with a body on a spring, jumping twice a revolution at 600 rpm
    machine = load_machine_text(_driven(20.0, True, start_deg=start_deg, warmup=2, cycles=1))
    fast = simulate(machine)
    fast_eval = evaluate(machine)
    monkeypatch.setattr("camsim.engine.integrator.CamForceWatch", _AlwaysLocating)
    reference = simulate(machine)
    assert [r for r in _rows(reference) if r[2] == "jump"], "the follower must jump in the window"
    assert _rows(fast) == _rows(reference)
    assert _rows(fast_eval) == _rows(reference)
    ours, theirs = fast.scalars(), reference.scalars()
    assert ours.keys() == theirs.keys()
    for key, value in ours.items():
        assert value == theirs[key] or (value != value and theirs[key] != theirs[key]), key  # NaN is NaN

"""Chunks sized by the events of the period before (issue 42, EngineContext.chunk_steps).

A prediction only moves where the linear stepper's chunks end; every grid step is screened
whatever they are. Reference: the same runs with no prediction (the chunks doubling from 512
steps after each event, as before): the same events, their times within 1e-12 s, and the
same located scalars within 1e-12 of each (the chunks' ends move the modal recurrences'
rounding only). And the predictor itself: nothing is predicted before a whole period has been
seen, then a chunk reaches a little past the next event one period on.
"""

from __future__ import annotations

import math
from pathlib import Path

import pytest

from camsim.engine.context import EngineContext
from camsim.machine.loader import load_machine
from camsim.model.assembly import Model
from camsim.cam.camshaft import cam_input
from camsim.run.evaluation import evaluate
from camsim.run.simulation import simulate

ROOT = Path(__file__).resolve().parents[2]
CDTM = ROOT / "machines" / "cdtm.toml"


def _context(period=1.0, h=1e-3):
    machine = load_machine(CDTM)
    ctx = EngineContext(Model(machine), cam_input(machine), h)
    ctx.period = period
    return ctx


def _steps(t_event, t_start, h=1e-3):
    """The chunk the predictor should give: to the predicted event, 8 steps and 1/64 of the
    gap beyond it."""
    gap = (t_event - t_start) / h
    return math.ceil(gap) + 8 + int(gap) // 64


def test_no_prediction_before_a_whole_period_is_seen():
    ctx = _context()
    ctx.noting_from(0.0)
    ctx.note_event(0.2)
    ctx.note_event(0.7)
    assert ctx.chunk_steps(0.25) is None  # an event may come before 1.2 s: nothing seen of it
    assert ctx.chunk_steps(0.99) is None
    # one period after the start: the next event predicted is 1.2 s, then 1.7 s
    assert ctx.chunk_steps(1.0) == _steps(0.2 + 1.0, 1.0) == 211
    assert ctx.chunk_steps(1.2) == _steps(0.7 + 1.0, 1.2)
    assert ctx.chunk_steps(1.75) is None  # none after 1.7 s yet (2.2 s comes with the events of this period)
    ctx.note_event(1.2)
    assert ctx.chunk_steps(1.75) == _steps(1.2 + 1.0, 1.75)


def test_a_recording_takes_the_warm_ups_predictions():
    warm, rec = _context(), _context()
    warm.noting_from(0.0)
    warm.note_event(0.4)
    rec.predict_from(warm)
    assert rec.chunk_steps(1.0) == _steps(0.4 + 1.0, 1.0)


def _unpredicted(monkeypatch):
    monkeypatch.setattr(EngineContext, "chunk_steps", lambda self, t: None)


def _compare(ours, reference):
    assert [(e.element, str(e.kind)) for e in ours.events] == [(e.element, str(e.kind)) for e in reference.events]
    for a, b in zip(ours.events, reference.events):
        assert abs(a.time - b.time) <= 1e-12, (a, b)
    theirs = reference.scalars()
    for key, value in ours.scalars().items():
        other = theirs[key]
        if isinstance(value, float) and isinstance(other, float):
            if math.isnan(value):
                assert math.isnan(other), key
            else:
                assert abs(value - other) <= 1e-12 * max(abs(other), 1e-300), (key, value, other)
        else:
            assert value == other, key


@pytest.mark.parametrize("cycles, warm", [(3, 0), (1, 1)])
def test_predicted_chunks_give_the_unpredicted_run(cycles, warm, monkeypatch):
    machine = load_machine(CDTM)
    ours = simulate(machine, cycles=cycles, warmup_cycles=warm)
    ours_eval = evaluate(machine, cycles=cycles, warmup_cycles=warm)
    _unpredicted(monkeypatch)
    reference = simulate(machine, cycles=cycles, warmup_cycles=warm)
    _compare(ours, reference)
    _compare(ours_eval, reference)

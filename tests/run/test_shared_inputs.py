"""A worker's runs share their cam's program and the cam input it gave on the grid (issue 42).

Reference: the same run in a fresh process state (every shared program and store dropped);
invariant: a run's numbers do not depend on what the process ran before it — bit for bit,
events, located extremes and traces alike.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np

from camsim.cam.camshaft import cam_input, shared_program
from camsim.engine import context
from camsim.machine.loader import load_machine
from camsim.run.evaluation import evaluate
from camsim.run.simulation import simulate

ROOT = Path(__file__).resolve().parents[2]
CDTM = ROOT / "machines" / "cdtm.toml"


def _cold() -> None:
    """Forget every shared program and input store, as a new worker would start."""
    shared_program.cache_clear()
    context._INPUT_STORES.clear()


def _snapshot(run) -> dict:
    out = {"scalars": run.scalars(), "events": [(e.time, e.element, str(e.kind)) for e in run.events]}
    out["traces"] = {k: np.asarray(v.data).copy() for k, v in run.traces().items()}
    return out


def _same(a: dict, b: dict) -> None:
    assert a["events"] == b["events"]
    for key, value in a["scalars"].items():
        other = b["scalars"][key]
        if isinstance(value, float) and np.isnan(value):
            assert np.isnan(other), key
        else:
            assert value == other, key
    assert a["traces"].keys() == b["traces"].keys()
    for key in a["traces"]:
        np.testing.assert_array_equal(a["traces"][key], b["traces"][key], err_msg=key)


def test_equal_descriptions_share_one_program():
    a, b = load_machine(CDTM), load_machine(CDTM)
    assert a.cam == b.cam
    assert cam_input(a) is cam_input(b)
    assert cam_input(a, shared=False) is not cam_input(a)  # a caller that sets attributes gets its own


def test_a_run_is_the_same_bits_after_other_runs_on_the_same_cam():
    machine = load_machine(CDTM)
    _cold()
    cold_full = _snapshot(simulate(machine, cycles=1, warmup_cycles=1))
    _cold()
    cold_eval = _snapshot(evaluate(machine))
    # from a fresh state, other runs first: another sample rate (the same program, another
    # grid), another speed (another program) and the same cam on a stiffer seat (the same
    # program and grids, other events)
    _cold()
    simulate(machine, cycles=1, warmup_cycles=1, sample_rate=20e3)
    faster = dataclasses.replace(machine, cam=dataclasses.replace(machine.cam, speed=machine.cam.speed * 1.1))
    evaluate(faster)
    stiff = load_machine(CDTM, overrides=["element.seat.stiffness=1.2e7 N/m"])
    evaluate(stiff)
    _same(_snapshot(simulate(machine, cycles=1, warmup_cycles=1)), cold_full)
    _same(_snapshot(evaluate(machine)), cold_eval)

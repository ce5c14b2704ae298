"""Invariant (e): random linear machines against an independent reference solver (slow, CI).

Reference: ``tests/reference/reference_solver.py`` — written from the model contract
(spec §3-§4) only, not from camsim's model or engine code: the piecewise-linear equations
m·ẍ = Σ f, f = a + k·d + c·ḋ per branch, integrated by ``scipy.integrate.solve_ivp``
(DOP853, rtol 1e-12, atol 1e-15 m and 1e-12 m/s, max step a tenth of the shortest
period), restarted at every branch change, which solve_ivp's terminal event functions
locate on its dense output (its own accuracy is checked against closed forms in
tests/test_engine_reference.py). It takes the cam motion from
:class:`camsim.cam.program.CamProgram`, which has its own closed-form tests.

Machines: :func:`machine_gen.machine_specs` with ``linear=True`` — springs, preloaded
links, linear contacts (cam driving the first mass or acting through a linear contact),
gravity on and off, ``[initial]``. Tolerances (what a rtol-1e-12 reference supports on a
revolution with impacts, measured on the CI profile's machines): branch-change events the
same sequence and within 1e-8 s; displacements and velocities within 1e-7 of their
peak, accelerations within 1e-6 (an acceleration sample next to an event sees the
event-time difference through a force jump).
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, note, settings

from invariant_checks import compare_events, load
from machine_gen import machine_specs, render

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "reference"))
from reference_solver import reference_run  # noqa: E402

from camsim.run.simulation import simulate  # noqa: E402

#: Half the profile's examples: a reference run costs several camsim runs.
PROFILE = settings(settings.get_profile("camsim-invariants"),
                   max_examples=max(2, settings.get_profile("camsim-invariants").max_examples // 2))
BRANCH_KINDS = ("impact", "release", "separation", "rejoin")
#: Event times [s] and traces (fraction of peak) against the reference.
EVENT_TOL = 1e-8
TRACE_TOL = {"displacement": 1e-7, "velocity": 1e-7, "acceleration": 1e-6}


def check_reference(text: str) -> list[str]:
    """camsim against the reference on the same 20 kHz grid; list of discrepancies."""
    machine = load(text)
    rate = 20_000.0
    sim = machine.simulation
    run = simulate(machine, sample_rate=rate)
    ref = reference_run(machine, warmup_cycles=sim.warmup_cycles, cycles=sim.cycles, sample_rate=rate)
    problems = compare_events(
        [(e.time, e.element, str(e.kind)) for e in run.events if str(e.kind) in BRANCH_KINDS],
        [(t, name, kind) for t, name, kind, _ in ref.events],
        EVENT_TOL,
    )
    n = min(len(run.time), len(ref.time))
    if np.max(np.abs(run.time[:n] - ref.time[:n])) > 1e-12:
        problems.append("time grids differ")
    for name, quantities in ref.masses.items():
        for q, tol in TRACE_TOL.items():
            a, b = run.masses[name][q][:n], quantities[q][:n]
            peak = max(np.max(np.abs(b)), 1e-300)
            err = np.max(np.abs(a - b)) / peak
            if not err <= tol:
                k = int(np.argmax(np.abs(a - b)))
                problems.append(f"masses/{name}/{q}: {err:.3g} of peak {peak:.4g} at t = {run.time[k]:.9g} s")
    return problems


@pytest.mark.slow
@PROFILE
@given(spec=machine_specs(linear=True, max_masses=3))
def test_e_linear_machines_agree_with_the_reference_solver(spec):
    """(e) Random linear machines: events 1e-8 s, traces 1e-7 (accelerations 1e-6) of peak."""
    text = render(spec)
    note(f"machine file:\n{text}")
    problems = check_reference(text)
    assert not problems, "invariant e-reference fails:\n  " + "\n  ".join(problems) + "\nmachine file:\n" + text

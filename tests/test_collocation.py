"""The exponential collocation of a vibrating closed power-law contact (issue 12).

Reference: an independent solve_ivp (DOP853, rtol 1e-12, atol 1e-16 m) of the same
equation written out in tests/reference/pressed_hertz.py — the pressed Hertz contact of
tests/test_nonlinear_stepper.py (1 kg under gravity on F = C·(−x)^1.5, C = 1e9 N/m^1.5, a
spring-damper k = 1e4 N/m, c = 20 N·s/m to a harmonic cam), started from its static equilibrium with a downward
velocity of 4 mm/s: the contact then rings at about 285 Hz with ±45 % of its static
penetration and stays closed, its tangent stiffness sweeping by a factor of ~2.5 every
period — the case where the iterated remainder does not converge and
:mod:`camsim.engine.collocation` carries the phase. Tolerances: displacement 1e-9 of the static
penetration, contact force 1e-9 of its peak.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

import camsim.engine.collocation as collocation
import camsim.engine.nonlinear as nonlinear
from camsim.machine.loader import load_machine_text
from camsim import simulate

sys.path.insert(0, str(Path(__file__).parent / "reference"))
from pressed_hertz import G, M, machine_text, reference  # noqa: E402

V0 = -4.0e-3  # [m/s] downward at the start: the contact rings

TEXT = machine_text("ringing Hertz contact", V0)


def simulate_counting(text, monkeypatch):
    """Run the machine ``text``; (result, grid steps the collocation carried)."""
    steps = {"n": 0}
    original = nonlinear.collocation_steps

    def counting(*args):
        out = original(*args)
        if out[2] is not None:
            steps["n"] += len(out[2][0]) - 1
        return out

    monkeypatch.setattr(nonlinear, "collocation_steps", counting)
    return simulate(load_machine_text(text)), steps["n"]


@pytest.mark.parametrize("block", [True, False], ids=["steps-together", "one-by-one"])
def test_collocation_against_independent_solver(block, monkeypatch):
    """Both ways of solving the collocation conditions: the steps of a call together (one
    Newton system) and step by step (the fall-back when that Newton does not converge)."""
    monkeypatch.setattr(collocation, "BLOCK", block)
    result, collocated = simulate_counting(TEXT, monkeypatch)
    n_grid = result.time.size
    assert collocated > 0.9 * n_grid, f"collocation carried {collocated} of {n_grid} steps"
    assert [e.kind for e in result.events] == []
    x_ref, f_ref, x0 = reference(result.time, V0)
    assert np.min(f_ref) > 0.1 * M * G  # the contact never opens
    assert np.max(np.abs(result.masses["M"]["displacement"] - x_ref)) < 1e-9 * abs(x0)
    assert np.max(np.abs(result.elements["contact"] - f_ref)) < 1e-9 * np.max(f_ref)


def test_collocation_error_control_rejects_a_coarse_step(monkeypatch):
    """The local error estimate is not blind: at a tolerance far below what one grid step
    of the polynomial can reach, no step is accepted (DOP853 carries the phase)."""
    text = TEXT.replace('sample_rate = "20 kHz"', 'sample_rate = "500 Hz"')
    # the 2 ms grid step itself, not the finer one the cam's motions would ask for
    from camsim.run import simulation

    monkeypatch.setattr(simulation, "cam_input_step", lambda machine: float("inf"))
    result, collocated = simulate_counting(text, monkeypatch)
    # a 2 ms step spans more than half a period of the ringing: the degree-5 polynomial
    # cannot carry it to 1e-11, so every step goes to DOP853 (rtol 1e-11, whose error
    # over the 28 periods of the revolution is ~1e-7 of the static penetration)
    assert collocated == 0
    x_ref, _, x0 = reference(result.time, V0)
    assert np.max(np.abs(result.masses["M"]["displacement"] - x_ref)) < 1e-6 * abs(x0)
    assert collocation.NODES == 5

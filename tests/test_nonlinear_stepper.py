"""The iterated-remainder stepper of closed power-law contacts (issue 12).

Reference: an independent solve_ivp (DOP853, rtol 1e-12, atol 1e-16 m) of the same
equation written out in tests/reference/pressed_hertz.py — a 1 kg mass resting under gravity on a Hertz contact
F = C·(−x)^1.5 (C = 1e9 N/m^1.5, about 4.6 µm of static penetration), pressed and relieved
by a spring-damper (k = 1e4 N/m, c = 20 N·s/m) to a cam that moves s = h/2·(1 − cos ωt)
(harmonic rise then fall of h = 0.5 mm over one revolution at 600 rpm). The contact stays
closed for the whole revolution while its stiffness drifts by ~40 %: the phase the
stepper's windows carry. Tolerances: displacement 1e-9 of the static penetration, contact
force 1e-9 of the weight.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

import camsim.integrate as integrate
import camsim.nonlinear as nonlinear
from camsim.loader import load_machine_text
from camsim import simulate

sys.path.insert(0, str(Path(__file__).parent / "reference"))
from pressed_hertz import G, M, machine_text, reference  # noqa: E402

TEXT = machine_text("pressed Hertz contact")


def test_stepper_against_independent_solver():
    calls = {"windows": 0}
    original = nonlinear._propagate

    def counting(*args):
        calls["windows"] += 1
        return original(*args)

    nonlinear._propagate = counting
    try:
        assert integrate.NONLINEAR_STEPPER
        result = simulate(load_machine_text(TEXT))
    finally:
        nonlinear._propagate = original
    assert calls["windows"] > 0, "the stepper's windows were not used"
    assert [e.kind for e in result.events] == []
    x_ref, f_ref, x0 = reference(result.time)
    assert np.max(np.abs(result.masses["M"]["displacement"] - x_ref)) < 1e-9 * abs(x0)
    assert np.max(np.abs(result.elements["contact"] - f_ref)) < 1e-9 * M * G

"""The static equilibrium a run starts from (camsim.run.simulation), with a power-law contact.

Reference: the pressed Hertz contact of tests/reference/pressed_hertz.py (a 1 kg mass under
gravity on F = C·(−x)^1.5, C = 1e9 N/m^1.5, and a 1e4 N/m spring to the cam at s = 0), whose
equilibrium −m·g + C·(−x)^1.5 − k·x = 0 that module solves by Brent's method to 1e-15.
Tolerance: 1e-12 of the static penetration (about 4.6 µm), both by the one-contact scalar
solve and by Powell's method on the positions (the general path).
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

import camsim.run.initial as simulation  # the initial state (camsim.run.initial)
from camsim.machine.loader import load_machine_text
from camsim import simulate

sys.path.insert(0, str(Path(__file__).parent / "reference"))
from pressed_hertz import C, G, K, M, machine_text, reference  # noqa: E402

TEXT = machine_text("pressed Hertz contact at rest")


def static_position(monkeypatch, scalar: bool) -> float:
    """M's displacement at t = 0 [m], with or without the one-contact scalar solve."""
    calls = {"scalar": 0}
    original = simulation._one_contact_static

    def counted(*args):
        calls["scalar"] += 1
        return original(*args) if scalar else None

    monkeypatch.setattr(simulation, "_one_contact_static", counted)
    result = simulate(load_machine_text(TEXT), cycles=1, warmup_cycles=0, sample_rate=2000.0)
    assert calls["scalar"] > 0, "the one-contact solve was not tried"
    return float(result.masses["M"]["displacement"][0])


@pytest.mark.parametrize("scalar", [True, False], ids=["scalar solve", "Powell"])
def test_static_penetration_against_brent(monkeypatch, scalar):
    x0 = reference(np.array([0.0, 1e-3]))[2]
    assert abs(static_position(monkeypatch, scalar) - x0) < 1e-12 * abs(x0)


def test_scalar_solve_is_the_equation_it_reduces():
    # the reduction itself, on the same numbers: q = x, A21 = −k/m, base = −g, the
    # contact force acting up (L2 = 1/m), δ = −x
    element = load_machine_text(TEXT).elements[0]
    A21, L2, base = np.array([[-K / M]]), np.array([1.0 / M]), np.array([-G])
    q = simulation._one_contact_static(A21, L2, base, (element, np.array([-1.0]), 0.0))
    assert abs(-M * G + C * (-q[0]) ** 1.5 - K * q[0]) < 1e-12 * M * G


def test_scalar_solve_declines_a_body_held_by_the_contact_alone():
    # no spring: A21 = 0, the positions do not follow from the force; Powell's method
    # on the positions (tried next) handles it
    element = load_machine_text(TEXT).elements[0]
    assert simulation._one_contact_static(np.zeros((1, 1)), np.array([1.0]), np.array([-G]),
                                          (element, np.array([-1.0]), 0.0)) is None

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


def test_partial_step_maps_against_quadrature(monkeypatch):
    """A window's partial first/last step as an affine map of the state and the remainder's
    Taylor terms (camsim.nonlinear._step_affine), by the φ-series and by the augmented
    matrix exponential (the fall-back beyond the series' norm bound).

    Reference: solve_ivp DOP853 (rtol 1e-13) of the same linear ODE
    ż = A·z + B·u(σ) + b + L·r(σ), u_c(σ) = Σ_j D_{j+c}·σ^j/j!, r(σ) = Σ_j R_j·σ^j/j!
    over one partial step and one full step; tolerance 1e-10 of each state component (the
    remainder's part is about a tenth of the state, so its map is checked to ~1e-9).
    """
    import math

    from scipy.integrate import solve_ivp

    import camsim.stepping as stepping
    from camsim.stepping import StepMaps

    rng = np.random.default_rng(12)
    n = 4
    # a stiff, lightly damped two-mass train (frequencies ~1e3 and ~2.4e4 rad/s)
    A = np.zeros((n, n))
    A[:2, 2:] = np.eye(2)
    A[2:, :2] = [[-1.2e6, 2.0e5], [1.1e6, -5.8e8]]
    A[2:, 2:] = [[-40.0, 4.0], [5.0, -900.0]]
    B = np.vstack([np.zeros((2, 4)), rng.normal(size=(2, 4)) * 1e5])  # the cam input acts on the accelerations
    b = np.array([0.0, 0.0, -9.81, 3.0])
    L = np.array([0.0, 0.0, 0.0, -1.0 / 0.175])
    lin = nonlinear._LinearLaw(A, B, b)
    h = 2e-5
    maps = StepMaps(lin, h, series=True)
    WL = np.array([maps.Gamma[j] @ L for j in range(4)])
    D_k = rng.normal(size=8) * np.array([1e-3, 1e-1, 1e1, 1e3, 1e5, 1e7, 1e9, 1e11])
    R = np.array([3e5, -2e9, 4e13, -3e17])
    z0 = np.array([1e-3, 2e-5, 0.1, -0.02])
    tau = 0.37 * h
    g_u = (D_k[None, :] @ maps.W + maps.g0)[0]

    def rhs(s, z):
        u = [sum(D_k[j + c] * s**j / math.factorial(j) for j in range(8 - c)) for c in range(4)]
        r = sum(R[j] * s**j / math.factorial(j) for j in range(4))
        return A @ z + B @ np.array(u) + b + L * r

    ref = solve_ivp(rhs, (0.0, tau), z0, method="DOP853", rtol=1e-13, atol=1e-20).y[:, -1]
    ref_full = solve_ivp(rhs, (0.0, h), z0, method="DOP853", rtol=1e-13, atol=1e-20).y[:, -1]

    def error(P, c, W, reference):
        return np.max(np.abs(P @ z0 + c + R @ W - reference) / np.abs(reference))

    assert abs(R @ nonlinear._step_affine(lin, maps, WL, L, False, tau, D_k, g_u)[2] / ref).max() > 0.01
    assert error(*nonlinear._step_affine(lin, maps, WL, L, False, tau, D_k, g_u), ref) < 1e-10
    assert error(*nonlinear._step_affine(lin, maps, WL, L, True, h, D_k, g_u), ref_full) < 1e-10
    monkeypatch.setattr(stepping, "phi_series", lambda A, h: None)  # force the augmented expm
    assert error(*nonlinear._step_affine(lin, maps, WL, L, False, tau, D_k, g_u), ref) < 1e-10


def test_cdtm_power_against_tight_dop853(monkeypatch):
    """One revolution of machines/cdtm-power.toml (the thesis's power-law seat, eight
    bounces, the seat's ringing and resting phases) by the stepper, against the same
    machine integrated by the general nonlinear path: scipy's DOP853 stepped on the full
    right-hand side at rtol 1e-13 (a different integrator of the same equations; the
    reference of bench/bench_contacts.py). Tolerances: the former DOP853-only path's own
    errors at its rtol 1e-11 (displacement 4.1e-9 of the peak, seat force 4.7e-6 of the
    peak, events 2.1e-10 s) — the stepper must be at least as accurate (measured: 2.9e-10,
    1.4e-6, 5e-11 s)."""
    from camsim.loader import load_machine

    machine = load_machine(Path(__file__).resolve().parents[1] / "machines" / "cdtm-power.toml")
    run = simulate(machine, cycles=1, warmup_cycles=0)
    original = integrate.Integrator.__init__

    def tight(self, *args, **kwargs):
        original(self, *args, **kwargs)
        self.rtol_nonlinear = 1e-13

    monkeypatch.setattr(integrate.Integrator, "__init__", tight)
    monkeypatch.setattr(integrate, "NONLINEAR_STEPPER", False)
    ref = simulate(machine, cycles=1, warmup_cycles=0)
    assert [e.kind for e in run.events] == [e.kind for e in ref.events]
    assert len(ref.events) >= 16
    assert max(abs(a.time - b.time) for a, b in zip(run.events, ref.events)) < 2.1e-10
    for mass in ("M2", "M3"):
        x, x_ref = run.masses[mass]["displacement"], ref.masses[mass]["displacement"]
        assert np.max(np.abs(x - x_ref)) < 4.1e-9 * np.max(np.abs(x_ref))
    seat, seat_ref = run.elements["seat"], ref.elements["seat"]
    assert np.max(np.abs(seat - seat_ref)) < 4.7e-6 * np.max(seat_ref)

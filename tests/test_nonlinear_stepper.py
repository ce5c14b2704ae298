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

import pytest
import sys
from pathlib import Path

import numpy as np

import camsim.engine.integrator as integrate
import camsim.engine.nonlinear as nonlinear
from camsim.machine.loader import load_machine_text
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
        assert nonlinear.ENABLED
        result = simulate(load_machine_text(TEXT))
    finally:
        nonlinear._propagate = original
    assert calls["windows"] > 0, "the stepper's windows were not used"
    assert [e.kind for e in result.events] == []
    x_ref, f_ref, x0 = reference(result.time)
    assert np.max(np.abs(result.masses["M"]["displacement"] - x_ref)) < 1e-9 * abs(x0)
    assert np.max(np.abs(result.elements["contact"] - f_ref)) < 1e-9 * M * G


def stiff_train():
    """(A, L) of a stiff, lightly damped two-mass train (frequencies ~1e3 and ~2.4e4 rad/s;
    state x1, x2, v1, v2), the contact force acting on the second mass (0.175 kg)."""
    A = np.zeros((4, 4))
    A[:2, 2:] = np.eye(2)
    A[2:, :2] = [[-1.2e6, 2.0e5], [1.1e6, -5.8e8]]
    A[2:, 2:] = [[-40.0, 4.0], [5.0, -900.0]]
    return A, np.array([0.0, 0.0, 0.0, -1.0 / 0.175])


def test_partial_step_maps_against_quadrature(monkeypatch):
    """A window's partial first/last step as an affine map of the state and the remainder's
    Taylor terms (camsim.engine.nonlinear._step_affine), by the φ-series and by the augmented
    matrix exponential (the fall-back beyond the series' norm bound).

    Reference: solve_ivp DOP853 (rtol 1e-13) of the same linear ODE
    ż = A·z + B·u(σ) + b + L·r(σ), u_c(σ) = Σ_j D_{j+c}·σ^j/j!, r(σ) = Σ_j R_j·σ^j/j!
    over one partial step and one full step; tolerance 1e-10 of each state component (the
    remainder's part is about a tenth of the state, so its map is checked to ~1e-9).
    """
    import math

    from scipy.integrate import solve_ivp

    import camsim.engine.stepping as stepping
    from camsim.engine.stepping import StepMaps

    rng = np.random.default_rng(12)
    A, L = stiff_train()
    n = A.shape[0]
    B = np.vstack([np.zeros((2, 4)), rng.normal(size=(2, 4)) * 1e5])  # the cam input acts on the accelerations
    b = np.array([0.0, 0.0, -9.81, 3.0])
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


@pytest.mark.slow  # the default pytest's 3 minutes: CI runs it
def test_cdtm_power_against_tight_dop853(monkeypatch):
    """One revolution of machines/cdtm-power.toml (the thesis's power-law seat, eight
    bounces, the seat's ringing and resting phases) by the stepper, against the same
    machine integrated by the general nonlinear path: scipy's DOP853 stepped on the full
    right-hand side at rtol 1e-13 (a different integrator of the same equations; the
    reference of bench/bench_contacts.py). Tolerances: the former DOP853-only path's own
    errors at its rtol 1e-11 (displacement 4.1e-9 of the peak, seat force 4.7e-6 of the
    peak, events 2.1e-10 s) — the stepper must be at least as accurate (measured: 2.9e-10,
    1.4e-6, 5e-11 s)."""
    from camsim.machine.loader import load_machine

    machine = load_machine(Path(__file__).resolve().parents[1] / "machines" / "cdtm-power.toml")
    run = simulate(machine, cycles=1, warmup_cycles=0)
    original = integrate.Integrator.__init__

    def tight(self, *args, **kwargs):
        original(self, *args, **kwargs)
        self.rtol_nonlinear = 1e-13

    monkeypatch.setattr(integrate.Integrator, "__init__", tight)
    monkeypatch.setattr(nonlinear, "ENABLED", False)
    ref = simulate(machine, cycles=1, warmup_cycles=0)
    assert [e.kind for e in run.events] == [e.kind for e in ref.events]
    assert len(ref.events) >= 16
    assert max(abs(a.time - b.time) for a, b in zip(run.events, ref.events)) < 2.1e-10
    for mass in ("M2", "M3"):
        x, x_ref = run.masses[mass]["displacement"], ref.masses[mass]["displacement"]
        assert np.max(np.abs(x - x_ref)) < 4.1e-9 * np.max(np.abs(x_ref))
    seat, seat_ref = run.elements["seat"], ref.elements["seat"]
    assert np.max(np.abs(seat - seat_ref)) < 4.7e-6 * np.max(seat_ref)


def test_remainder_response_against_a_plain_loop():
    """_RemainderResponse.project (modal, the forcing linear in the nodes' (r, h·ṙ)) against
    the plain recurrence z_{k+1} = Φ·z_k + R_k·W_L with each step's cubic-Hermite Taylor
    terms R_k = (r, ṙ, r̈, r⃛) formed one by one, the first and last steps partial (their
    maps from _step_affine); the projections on two rows to 1e-12 and the states to 1e-11
    of their largest value (rounding of the modal recurrence over 300 steps). The train
    is the stiff two-mass one of the test above."""
    from camsim.engine.stepping import StepMaps

    rng = np.random.default_rng(5)
    A, L = stiff_train()
    n = A.shape[0]
    B = np.zeros((n, 4))
    b = np.zeros(n)
    lin = nonlinear._LinearLaw(A, B, b)
    h = 2e-5
    maps = StepMaps(lin, h, series=True)
    assert maps.modal
    WL = np.array([maps.Gamma[j] @ L for j in range(4)])
    K = 300  # beyond the doubling scan's length: the blocked recurrence
    steps = np.full(K, h)
    steps[0], steps[-1] = 0.37 * h, 0.61 * h
    D0 = np.zeros(8)
    g0 = np.zeros(n)
    first = nonlinear._step_affine(lin, maps, WL, L, False, float(steps[0]), D0, g0)
    last = nonlinear._step_affine(lin, maps, WL, L, False, float(steps[-1]), D0, g0)
    proj = np.array([[0.0, 1.0], [1.0, 0.0], [0.0, 0.3], [0.2, 1.0]])  # two rows of δ-like projections
    t = np.concatenate([[0.0], np.cumsum(steps)])
    r = 50.0 * np.sin(2e3 * t) + rng.normal(0.0, 1.0, K + 1)
    rd = 1e5 * np.cos(2e3 * t)
    X = np.column_stack([r, rd * h])
    resp = nonlinear._RemainderResponse(maps, WL, proj, h, steps, first, last, K, n)
    Y = resp.project(X)
    Z = resp.states()

    def hermite(k):
        hk = steps[k]
        c2 = (3 * (r[k + 1] - r[k]) / hk - 2 * rd[k] - rd[k + 1]) / hk
        c3 = (2 * (r[k] - r[k + 1]) / hk + rd[k] + rd[k + 1]) / hk**2
        return np.array([r[k], rd[k], 2 * c2, 6 * c3])

    z = np.zeros(n)
    ref = [z]
    for k in range(K):
        if k == 0:
            z = hermite(0) @ first[2]
        elif k == K - 1:
            z = last[0] @ z + hermite(k) @ last[2]
        else:
            z = maps.Phi @ z + hermite(k) @ WL
        ref.append(z)
    ref = np.array(ref)
    scale = np.max(np.abs(ref @ proj), axis=0)
    np.testing.assert_allclose(Y / scale, (ref @ proj) / scale, rtol=0, atol=1e-12)
    np.testing.assert_allclose(Z / np.max(np.abs(ref), axis=0), ref / np.max(np.abs(ref), axis=0), rtol=0, atol=1e-11)


def test_anderson_solves_a_linear_fixed_point():
    """_Anderson (depth 3) on x = M·x + b (symmetric M, spectrum 0 … 0.9) is, after 25
    iterations, 100 times closer to the solution of (I − M)·x = b (numpy's solve) than the
    plain iteration; _solve_small against numpy's solve on a ridge-shifted 3×3 Gram
    matrix (1e-12)."""
    from camsim.engine.remainder import _Anderson, _solve_small

    rng = np.random.default_rng(3)
    n = 30
    Q, _ = np.linalg.qr(rng.normal(size=(n, n)))
    M = Q @ np.diag(np.linspace(0.0, 0.9, n)) @ Q.T
    b = rng.normal(size=n)
    exact = np.linalg.solve(np.eye(n) - M, b)
    acc = _Anderson(3)
    x = np.zeros((n // 2, 2))
    plain = np.zeros(n)
    for _ in range(25):
        x = acc.next(x, (M @ x.reshape(-1) + b).reshape(x.shape))
        plain = M @ plain + b
    assert np.max(np.abs(x.reshape(-1) - exact)) < 1e-2 * np.max(np.abs(plain - exact))
    V = rng.normal(size=(50, 3))
    G = V.T @ V
    rhs = rng.normal(size=3)
    ours = _solve_small(G.tolist(), rhs.tolist(), 1e-13)
    np.testing.assert_allclose(ours, np.linalg.solve(G + (1e-13 * np.trace(G) + 1e-300) * np.eye(3), rhs), rtol=1e-12)


def test_fast_input_projection_is_the_input():
    """_FastInput.project(g)(t) — Horner in plain floats, used by the event root finder —
    equals g·u(t) from the same per-step polynomials (to rounding), across grid steps."""
    from camsim.cam.program import CamProgram
    from camsim.model.assembly import Model

    machine = load_machine_text(TEXT, source="pressed")
    integ = integrate.Integrator(Model(machine), CamProgram(machine.cam), 2e-5, t_ref=0.0)
    t0 = integ.t_ref + 3.3 * integ.h
    t1 = integ.t_ref + 7.0 * integ.h
    from camsim.engine.bounce import _FastInput

    fast = _FastInput(integ, t0, t1)
    g = np.array([1.0, -2e-3, 3e-5, 1e-7])
    at = fast.project(g)
    for t in np.linspace(t0, t1, 17):
        want = float(g @ fast(float(t)))
        assert abs(at(float(t)) - want) <= 1e-14 * max(abs(want), float(np.max(np.abs(fast.C))) * 1e-3)

"""camsim.engine.dop853.OneContactDOP853: DOP853 built on the linear structure around one contact.

References:

* scipy's :class:`scipy.integrate.DOP853` (Hairer's pair, stepped stage by stage through
  the right-hand side) on the same equation: a two-mass train (4 states) driven by a
  cubic cam input through a spring-damper, its second mass pressed on a Hunt–Crossley
  power-law contact F = C·δ^1.425·(1 + χ·δ̇) that stays closed. From the same first step
  both take the same steps; states, step times and the dense output agree to 1e-12 of the
  state's scale (rounding: the stages are summed in another order).
* The Hertz impact closed form (Johnson, Contact Mechanics, §11.4): a mass m reaching a
  contact F = C·δ^a at v0 stops at δ_max = ((a + 1)·m·v0²/(2C))^(1/(a+1)) after
  t_max = (δ_max/v0)·√π·Γ(1 + 1/(a+1))/Γ(1/2 + 1/(a+1)); at rtol 1e-11 to 1e-9 of δ_max
  and 1e-8 of v0. The onset (F ∝ τ^a, not smooth) is where scipy's shrink factor (at most
  5× per try) wastes tries: fewer rejected steps there than scipy's. A whole bounce
  releases at 2·t_max at −v0 (elastic): the steps shaped by the contact (onset ramp,
  release approach) end there as closely in fewer tries.
* numpy.roots for the release time's quadratic.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from scipy.integrate import DOP853

from camsim.engine.dop853 import OneContactDOP853

# --------------------------------------------------------------------------- the pressed train
M1, M2 = 0.5, 0.8  # [kg]
K1, C1 = 2.0e5, 15.0  # [N/m], [N·s/m] cam → M1
K12, C12 = 5.0e5, 8.0  # M1 → M2
CP, AP, CHI = 4.0e9, 1.425, 0.35  # C [N/m^a], a, χ [s/m]
#: x = [x1, x2, v1, v2]; δ = x2 + 1e-5 m (pressed 10 µm at x2 = 0), δ̇ = v2
A_TRAIN = np.array([
    [0.0, 0.0, 1.0, 0.0],
    [0.0, 0.0, 0.0, 1.0],
    [-(K1 + K12) / M1, K12 / M1, -(C1 + C12) / M1, C12 / M1],
    [K12 / M2, -K12 / M2, C12 / M2, -C12 / M2],
])
L_TRAIN = np.array([0.0, 0.0, 0.0, -1.0 / M2])
M_TRAIN = np.array([[0.0, 1.0, 0.0, 0.0], [0.0, 0.0, 0.0, 1.0]])
PRELOAD = 1.0e-5  # [m]


S0 = 2e-3  # [m] the cam's offset: the contact carries about 300 N


def cam(t):
    """s(t), ṡ(t) of the cam [m, m/s] (a cubic, 13 µm over the 20 ms)."""
    t = np.asarray(t, dtype=float)
    return S0 + 2e-4 * t + 0.03 * t**2 - 0.4 * t**3, 2e-4 + 0.06 * t - 1.2 * t**2


def static_state():
    """x1, x2 at rest under the cam's offset, and small velocities (the contact rings)."""
    from scipy.optimize import brentq

    k_series = 1.0 / (1.0 / K1 + 1.0 / K12)
    delta = brentq(lambda d: k_series * (S0 + PRELOAD - d) - CP * d**AP, 1e-12, 1e-3)
    x2 = delta - PRELOAD
    x1 = x2 + CP * delta**AP / K12
    return x1, x2


def train_inputs(ts, t_lo=None, t_hi=None):
    """[g(t); m(t)]: the cam's force on M1 and the contact's offsets (δ, δ̇)."""
    s, v = cam(ts)
    out = np.zeros((np.size(ts), 6))
    out[:, 2] = (K1 * s + C1 * v) / M1
    out[:, 4] = PRELOAD
    return out


def hc_force(delta, rate):
    if delta <= 0.0:
        return 0.0
    f = CP * delta**AP * (1.0 + CHI * rate)
    return f if f > 0.0 else 0.0


def train_rhs(t, z):
    g = train_inputs(np.array([t]))[0]
    delta, rate = M_TRAIN @ z + g[4:]
    return A_TRAIN @ z + g[:4] + L_TRAIN * hc_force(delta, rate)


RTOL = 1e-11
ATOL = np.array([1e-13, 1e-13, 1e-10, 1e-10])


def train_pair(first_step, v0=(1e-3, -1e-3), t0=0.0):
    z0 = np.array([*static_state(), *v0])
    ours = OneContactDOP853(A_TRAIN, L_TRAIN, M_TRAIN, train_inputs, lambda t: train_inputs(np.array([t]))[0],
                            hc_force, t0, z0, 0.02, RTOL, ATOL, 1e-3, first_step)
    ref = DOP853(train_rhs, t0, z0, 0.02, rtol=RTOL, atol=ATOL, max_step=1e-3, first_step=first_step)
    return ours, ref


SCALE = np.array([1e-3, 1e-3, 1e-3, 1e-3])  # the states' magnitudes


@pytest.mark.parametrize("h", [1e-6, 4e-6, 1.5e-5])
@pytest.mark.parametrize("t0, v0", [(0.0, (1e-3, -1e-3)), (0.004, (-2e-3, 1e-3))])
def test_one_step_matches_scipy_dop853(h, t0, v0):
    """From the same state and step both compute the same DOP853 step (to rounding)."""
    ours, ref = train_pair(h, v0, t0)
    ours.step()
    ref.step()
    assert ours.t_old == ref.t_old == t0
    assert ours.t == ref.t  # the first step was accepted by both: the same length
    assert M_TRAIN[0] @ ours.y + PRELOAD > 0.0  # closed and loaded: the smooth case
    np.testing.assert_allclose(ours.y / SCALE, ref.y / SCALE, rtol=0, atol=1e-13)
    ts = np.linspace(ref.t_old, ref.t, 7)
    np.testing.assert_allclose(ours.dense_output()(ts) / SCALE[:, None], ref.dense_output()(ts) / SCALE[:, None],
                               rtol=0, atol=1e-13)
    np.testing.assert_allclose(ours.dense_output()(ts[3]), ref.dense_output()(ts[3]), rtol=1e-12, atol=1e-20)


def test_run_matches_scipy_dop853():
    """Over 20 ms (about 25 periods of the contact mode) the two agree to the tolerance."""
    ours, ref = train_pair(None)
    while ours.status == "running":
        assert ours.step() is None
        assert M_TRAIN[0] @ ours.y + PRELOAD > 0.0  # closed throughout: the smooth case
    while ref.status == "running":
        ref.step()
    assert ours.t == ref.t == 0.02
    np.testing.assert_allclose(ours.y / SCALE, ref.y / SCALE, rtol=0, atol=1e-9)


# --------------------------------------------------------------------------- Hertz impact
MASS, V0 = 0.2, 0.5  # [kg], [m/s]


def hertz_solver(first_step=None):
    A = np.array([[0.0, 1.0], [0.0, 0.0]])
    L = np.array([0.0, -1.0 / MASS])
    M = np.eye(2)
    zero = lambda ts, lo=None, hi=None: np.zeros((np.size(ts), 4))  # noqa: E731
    force = lambda d, r: CP * d**AP if d > 0.0 else 0.0  # noqa: E731
    return A, L, M, zero, force


def hertz_closed_form():
    q = 1.0 / (AP + 1.0)
    d_max = ((AP + 1.0) * MASS * V0**2 / (2.0 * CP)) ** q
    t_max = d_max / V0 * math.sqrt(math.pi) * math.gamma(1.0 + q) / math.gamma(0.5 + q)
    return d_max, t_max


def _hertz_run(t_end, **control):
    """The Hertz impact stepped from its onset (δ = 0 at v0) to t_end, with the solver's
    ``control`` keywords: (the solver at t_end, its tries, its rejected tries)."""
    _, t_max = hertz_closed_form()
    A, L, M, zero, force = hertz_solver()
    ours = OneContactDOP853(A, L, M, zero, lambda t: np.zeros(4), force, 0.0, np.array([0.0, V0]), t_end,
                            RTOL, np.array([1e-13, 1e-10]), t_max / 4, None, **control)
    tries = 0
    original = ours._attempt

    def counting(t, y, h):
        nonlocal tries
        tries += 1
        return original(t, y, h)

    ours._attempt = counting
    steps = 0
    while ours.status == "running":
        assert ours.step() is None
        steps += 1
    return ours, tries, tries - steps


def test_hertz_onset_closed_form_and_fewer_rejections():
    d_max, t_max = hertz_closed_form()
    _, _, _, _, force = hertz_solver()
    ours, _, ours_rejected = _hertz_run(t_max)
    assert ours.y[0] == pytest.approx(d_max, rel=1e-9)
    assert abs(ours.y[1]) <= 1e-8 * V0

    def rhs(t, z):
        return np.array([z[1], -force(z[0], z[1]) / MASS])

    ref = DOP853(rhs, 0.0, np.array([0.0, V0]), t_max, rtol=RTOL, atol=np.array([1e-13, 1e-10]), max_step=t_max / 4)
    ref_steps = 0
    while ref.status == "running":
        ref.step()
        ref_steps += 1
    # scipy: 2 evaluations to start (f0 and the starting-step estimate), 12 per try
    ref_rejected = (ref.nfev - 2) // 12 - ref_steps
    assert ref.y[0] == pytest.approx(d_max, rel=1e-9)  # the reference is right too
    assert ours_rejected < ref_rejected, (ours_rejected, ref_rejected)


def _bounce(exponent):
    """A whole Hertz bounce (onset at t = 0, release at 2·t_max) and free flight to
    2.2·t_max: (tries, rejected tries, final state's error against the closed form
    scaled by [δ_max, v0])."""
    d_max, t_max = hertz_closed_form()
    t_end = 2.2 * t_max
    ours, tries, rejected = _hertz_run(t_end, exponent=exponent, onset=True)
    # elastic: the mass leaves at −v0 at 2·t_max and flies on
    exact = np.array([-V0 * (t_end - 2.0 * t_max), -V0])
    return tries, rejected, (ours.y - exact) / np.array([d_max, V0])


def test_contact_shaped_steps_hertz_bounce():
    """With the law's exponent the onset ramp and the release approach shape the steps:
    a whole Hertz bounce ends as close to the closed form (Johnson: release at 2·t_max at
    −v0, elastic; 1e-8 of δ_max and of v0, measured 5e-10) with fewer tries and fewer
    rejected ones than scipy's control (measured 35 tries, 7 rejected, against 43 and
    13)."""
    plain_tries, plain_rejected, plain_error = _bounce(None)
    tries, rejected, error = _bounce(AP)
    assert np.max(np.abs(plain_error)) <= 1e-8  # the reference run is right too
    assert np.max(np.abs(error)) <= 1e-8
    assert tries < plain_tries and rejected < plain_rejected, (tries, rejected, plain_tries, plain_rejected)


def test_contact_shaped_steps_leave_a_closed_contact_alone():
    """Inside a contact that neither opens nor releases (the pressed train) the contact
    control changes no step: the same steps and states as without it, bit for bit."""
    z0 = np.array([*static_state(), 1e-3, -1e-3])
    plain, shaped = (OneContactDOP853(A_TRAIN, L_TRAIN, M_TRAIN, train_inputs,
                                      lambda t: train_inputs(np.array([t]))[0], hc_force, 0.0, z0, 0.02, RTOL, ATOL,
                                      1e-3, None, exponent=exponent) for exponent in (None, AP))
    while plain.status == "running":
        plain.step()
        shaped.step()
        assert shaped.t == plain.t and np.array_equal(shaped.y, plain.y)
    assert shaped.status == "finished"


@pytest.mark.parametrize("c0, c1, c2", [(1.0, -2.0, 0.0), (1.0, -3.0, 2.0), (2e-6, -0.1, 40.0), (2e-6, -0.1, -40.0),
                                        (1.0, -1.0, 1.0)])
def test_first_root_of_the_release_quadratic(c0, c1, c2):
    """The smallest positive root of c0 + c1·τ + c2·τ² against numpy.roots (1e-12
    relative), inf when there is none."""
    from camsim.engine.dop853 import _first_root

    roots = np.roots([c2, c1, c0]) if c2 else np.array([-c0 / c1])
    real = [r.real for r in np.atleast_1d(roots) if abs(r.imag) <= 1e-12 * abs(r) and r.real > 0.0]
    got = _first_root(c0, c1, c2)
    if real:
        assert got == pytest.approx(min(real), rel=1e-12)
    else:
        assert got == math.inf


# --------------------------------------------------------------------------- structure
def _pressed_train(first_step, structure=None, v0=(1e-3, -1e-3), t0=0.0):
    z0 = np.array([*static_state(), *v0])
    return OneContactDOP853(A_TRAIN, L_TRAIN, M_TRAIN, train_inputs, lambda t: train_inputs(np.array([t]))[0],
                            hc_force, t0, z0, 0.02, RTOL, ATOL, 1e-3, first_step, structure=structure)


@pytest.mark.parametrize("first_step", [None, 4e-6])
def test_given_structure_steps_bit_for_bit(first_step):
    """structure=OneContactDOP853.structure(A, L, M) passed in takes the same steps as the
    one built inside, bit for bit (==): step times and lengths, states, forces and the
    dense output over 8 steps of the pressed train; one structure serves two spans in
    turn and is left unchanged (reference: the solver building its own)."""
    shared = OneContactDOP853.structure(A_TRAIN, L_TRAIN, M_TRAIN)
    before = [a.copy() for a in shared]
    solvers = [_pressed_train(first_step, shared, (-2e-3, 1e-3), 0.004), _pressed_train(first_step, shared),
               _pressed_train(first_step)]
    for _ in range(8):
        for s in solvers:
            assert s.step() is None and s.status == "running"
        given, own = solvers[1], solvers[2]
        assert given.t == own.t and given.t_old == own.t_old and given.h_abs == own.h_abs and given.F == own.F
        assert np.array_equal(given.y, own.y) and np.array_equal(given.f, own.f)
        ts = np.linspace(own.t_old, own.t, 5)
        assert np.array_equal(given.dense_output()(ts), own.dense_output()(ts))
    assert own.t > 8 * 1e-6  # steps of some length were taken
    for a, b in zip(shared, before):
        assert np.array_equal(a, b)


def test_structure_is_the_matrix_powers():
    """M·A^p, its transpose, M·A^p·L and (Aᵀ)^p for p = 0..11 against
    numpy.linalg.matrix_power (binary powering, another order of products), to 1e-12
    relative element by element (measured: 3e-16)."""
    MAp, MApT, MApL, ApT = OneContactDOP853.structure(A_TRAIN, L_TRAIN, M_TRAIN)
    n = A_TRAIN.shape[0]
    assert MAp.shape == (24, n) and MApT.shape == (n, 24) and MApL.shape == (12, 2) and ApT.shape == (12, n, n)
    assert np.array_equal(MApT, MAp.T)
    for p in range(12):
        power = np.linalg.matrix_power(A_TRAIN, p)
        np.testing.assert_allclose(MAp[2 * p:2 * p + 2], M_TRAIN @ power, rtol=1e-12, atol=0, err_msg=str(p))
        np.testing.assert_allclose(MApL[p], M_TRAIN @ power @ L_TRAIN, rtol=1e-12, atol=0, err_msg=str(p))
        np.testing.assert_allclose(ApT[p], np.linalg.matrix_power(A_TRAIN.T, p), rtol=1e-12, atol=0, err_msg=str(p))


# --------------------------------------------------------------------------- span going on
def test_moved_bound_continues_as_one_run():
    """A solver stopped at t1 (its last step cut short by t_bound) whose bound is moved on
    to t2 goes on with the step its control had proposed, not with the cut one, and ends
    as close to solve_ivp (DOP853, rtol 1e-13) as scipy's DOP853 run straight to t2 at the
    same tolerance (within twice its error)."""
    from scipy.integrate import solve_ivp

    ours, ref = train_pair(None)
    ours.t_bound = 0.0051234  # inside a step
    while ours.status == "running":
        ours.step()
    assert ours.t == 0.0051234
    assert ours.h_abs >= ours.h_previous  # the proposal kept (the cut step was shorter)
    ours.t_bound, ours.status = 0.02, "running"
    while ours.status == "running":
        assert ours.step() is None
    while ref.status == "running":
        ref.step()
    z0 = np.array([*static_state(), 1e-3, -1e-3])
    tight = solve_ivp(train_rhs, (0.0, 0.02), z0, method="DOP853", rtol=1e-13, atol=1e-18).y[:, -1]
    straight = float(np.max(np.abs(ref.y - tight) / SCALE))
    assert float(np.max(np.abs(ours.y - tight) / SCALE)) <= 2.0 * straight


def test_projected_dense_output_is_the_dense_output():
    """Dense.project(g)(t) — plain floats, used by the event root finder — equals
    g·dense(t) (to rounding)."""
    ours, _ = train_pair(4e-6)
    ours.step()
    dense = ours.dense_output()
    g = np.array([0.3, -1.0, 2e-3, 5e-4])
    at = dense.project(g)
    for t in np.linspace(ours.t_old, ours.t, 9):
        assert at(float(t)) == pytest.approx(float(g @ dense(t)), rel=1e-14, abs=1e-20)


def test_the_located_extremes_of_a_power_law_seat_are_those_of_scipys_dop853(monkeypatch):
    """The located extremes re-integrate a closed contact's candidate steps with
    OneContactDOP853 (scipy's steps, its stages as one linear map; camsim.engine.dense).
    Reference: the same refinement with scipy's solve_ivp DOP853 at the same tolerances
    (dense.ONE_CONTACT = False): every located extreme of machines/cdtm-power.toml's
    revolution to 1e-12 of its value (measured 5.4e-14)."""
    import camsim
    import camsim.engine.dense as dense

    machine = camsim.load_machine(Path(__file__).resolve().parents[1] / "machines" / "cdtm-power.toml")
    ours = camsim.simulate(machine, warmup_cycles=0, sample_rate=10e3).located
    monkeypatch.setattr(dense, "ONE_CONTACT", False)
    scipys = camsim.simulate(machine, warmup_cycles=0, sample_rate=10e3).located
    assert set(ours) == set(scipys)
    worst = 0.0
    for path, senses in scipys.items():
        for sense, ref in senses.items():
            got = ours[path][sense]
            if ref is None:
                assert got is None
                continue
            worst = max(worst, abs(got.value - ref.value) / max(abs(ref.value), 1e-300))
    assert worst <= 1e-12

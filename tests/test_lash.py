"""``type = "lash"`` (two-sided clearance, spec §3).

Reference: a mass M = 0.5 kg moving at v = 0.5 m/s inside a clearance c = 2 mm (offset
0.3 mm) with an undamped linear contact k = 1e6 N/m on each side. Between contacts it
flies at constant speed; each contact is half a period of the contact oscillator,
π/ω with ω = √(k/M), and returns it at the same speed. So the impacts come at
t₁ = (c/2 + o)/v (the upper side, d = x), then every π/ω + c/v, alternately on the upper and lower side, with a
peak force v·√(k·M). With ``restitution`` e the rebound speeds fall as eⁿ·v (the
closed-form mapping of a clamped linear contact, docs/contacts.md). Tolerances: times
1e-9 s, speeds and forces 1e-9 relative.

The other laws on the same flight:

- ``law = "restitution"`` (rigid): free flight at constant speed between the walls, each
  impact reversing the speed and scaling it by e (Newton), so impact k comes at speed
  eᵏ·v after the flight c/(eᵏ⁻¹·v); e = 0 sticks at the first wall. Times to 1e-12 s,
  speeds to 1e-12 relative (closed form).
- ``law = "power"`` and ``law = "adams-impact"``: against an independent event-driven
  :func:`scipy.integrate.solve_ivp` (DOP853, rtol 1e-12) of the same equations, written
  out below (free flight in closed form, each contact phase integrated until δ returns
  to 0): displacement to 1e-8 m at every sample, impact and release times to 1e-9 s.
  With ``restitution`` the rebound is also e times the approach speed (the definition,
  spec §3) to 1e-8 relative.
- A yoke (``between = ["cam", "M"]``, rigid law, e = 0) on a cycloidal rise of lift L
  over β: resting on the lower side, the yoke pushes the mass with M·s̈ until s̈ = 0 at
  β/2 (``release`` there, at speed 2L/β), the mass flies at 2L/β until d reaches the upper
  side, v·(t − β/2) − (s(t) − s(β/2)) = c (an ``impact`` at 2L/β − ṡ, and ``stick``), then
  the upper side pulls with −M·s̈; the fall mirrors it half a cycle later. Times to 1e-9 s,
  forces to 1e-9 of the peak M·2πL/β².
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.optimize import brentq

from camsim.machine.loader import load_machine_text
from camsim import simulate

M, V, C, O, K = 0.5, 0.5, 2e-3, 0.3e-3, 1e6


def _machine(extra="", duration="30 ms", stiff=f'stiffness = "{K} N/m"'):
    return load_machine_text(f"""
schema = 1
[machine]
name = "lash"
[[mass]]
name = "M"
mass = "{M} kg"
[[element]]
name = "slot"
type = "lash"
between = ["ground", "M"]
clearance = "{C} m"
offset = "{O} m"
{stiff}
{extra}
[initial.M]
displacement = "0 m"
velocity = "{V} m/s"
[simulation]
duration = "{duration}"
warmup_cycles = 0
sample_rate = "100 kHz"
""")


def test_lash_impacts_at_analytic_times():
    r = simulate(_machine())
    w = math.sqrt(K / M)
    impacts = [e for e in r.events if e.kind == "impact"]
    assert len(impacts) >= 4
    t = (C / 2 + O) / V
    for n, ev in enumerate(impacts):
        assert abs(ev.time - t) < 1e-9, (n, ev.time, t)
        assert ev.relative_velocity == pytest.approx(V, rel=1e-9)
        assert ev.peak_force == pytest.approx(V * math.sqrt(K * M), rel=1e-6)  # sampled peak, parabola-refined
        t += math.pi / w + C / V
    # sides alternate: the force is tension-positive (upper side +, lower side −)
    x = r.masses["M"]["displacement"]
    f = r.elements["slot"]
    assert f.max() > 0 and f.min() < 0
    assert abs(f[x > O + C / 2].min()) >= 0 and (f[x < O - C / 2] <= 0).all() and (f[x > O + C / 2] >= 0).all()


def test_lash_restitution_rebounds():
    r = simulate(_machine("restitution = 0.5", duration="40 ms"))
    impacts = [e for e in r.events if e.kind == "impact"]
    assert len(impacts) >= 3
    for n, ev in enumerate(impacts[:3]):
        assert ev.relative_velocity == pytest.approx(V * 0.5**n, rel=1e-9)


# ---------------------------------------------------------------------- rigid lash
@pytest.mark.parametrize("e", [0.6, 0.45, 1.0])
def test_rigid_lash_newton_rebounds(e):
    r = simulate(_machine(f'law = "restitution"\nrestitution = {e}', duration="40 ms", stiff=""))
    impacts = [ev for ev in r.events if ev.kind == "impact"]
    assert [ev.kind for ev in r.events] == ["impact"] * len(impacts)  # no stick, no release
    t, speed = (C / 2 + O) / V, V
    expected = []
    while t < 0.04:
        expected.append((t, speed))
        speed *= e
        t += C / speed
    assert len(impacts) == len(expected) >= 3
    for ev, (t, speed) in zip(impacts, expected):
        assert ev.time == pytest.approx(t, abs=1e-12)
        assert ev.relative_velocity == pytest.approx(speed, rel=1e-12)
    # free flight at constant speed: the displacement is piecewise linear between the walls
    x = r.masses["M"]["displacement"]
    assert x.max() <= O + C / 2 + 1e-15 and x.min() >= O - C / 2 - 1e-15
    assert not np.any(r.elements["slot"])


def test_rigid_lash_plastic_sticks():
    r = simulate(_machine('law = "restitution"\nrestitution = 0', duration="10 ms", stiff=""))
    t1 = (C / 2 + O) / V
    assert [(ev.kind, ev.time) for ev in r.events] == [("impact", pytest.approx(t1, abs=1e-12)),
                                                      ("stick", pytest.approx(t1, abs=1e-12))]
    x = r.masses["M"]["displacement"]
    after = r.time > t1
    np.testing.assert_allclose(x[after], O + C / 2, rtol=0, atol=1e-15)
    np.testing.assert_allclose(r.masses["M"]["velocity"][after], 0.0, atol=1e-15)


# ---------------------------------------------------------------------- compliant laws
POWER_C, POWER_A = 1e9, 1.5
ADAMS = dict(k=1e9, n=1.5, c_max=200.0, depth=5e-5)


def _hc_alpha(e):
    """α(e): the nonzero root of α(1 + e) + ln(1 − α·e) − ln(1 + α) = 0 (spec §3)."""
    if e >= 1.0:
        return 0.0
    f = lambda a: a * (1 + e) + math.log1p(-a * e) - math.log1p(a)  # noqa: E731
    upper = 1.0 / e * (1 - 1e-15) if e > 0 else 1e6
    return brentq(f, 1e-3, upper, xtol=1e-15, rtol=1e-15)


def _power_force(chi_fixed=None, e=None):
    def force(delta, rate, v_impact):
        chi = chi_fixed if chi_fixed is not None else _hc_alpha(e) / v_impact
        return max(0.0, POWER_C * delta**POWER_A * (1.0 + chi * rate))
    return force


def _adams_force(delta, rate, v_impact):
    u = min(delta / ADAMS["depth"], 1.0)
    c = ADAMS["c_max"] * u * u * (3.0 - 2.0 * u)
    return max(0.0, ADAMS["k"] * delta ** ADAMS["n"] + c * rate)


def _reference(force, t_end):
    """Independent event-driven solution of M·ẍ = ±F on each wall, free flight between.

    Returns (pieces, events): pieces are (t0, t1, x(t)) callables, events (kind, time, speed).
    """
    high, low = O + C / 2, O - C / 2
    t, x, v = 0.0, 0.0, V
    pieces, events = [], []
    while t < t_end:
        wall = high if v > 0 else low
        t_hit = t + (wall - x) / v
        pieces.append((t, t_hit, lambda tt, t=t, x=x, v=v: x + v * (tt - t)))
        if t_hit >= t_end:
            break
        s = 1.0 if v > 0 else -1.0  # δ = s·(x − wall), δ̇ = s·v, force −s·F on the mass
        v_imp = abs(v)
        events.append(("impact", t_hit, v_imp))

        def rhs(_, y, s=s, wall=wall, v_imp=v_imp):
            delta, rate = s * (y[0] - wall), s * y[1]
            return [y[1], -s * force(max(delta, 0.0), rate, v_imp) / M]

        def opened(_, y, s=s, wall=wall):
            return s * (y[0] - wall)
        opened.terminal, opened.direction = True, -1
        sol = solve_ivp(rhs, (t_hit, t_hit + 1.0), [wall, v], method="DOP853", rtol=1e-12, atol=1e-18,
                        events=opened, dense_output=True)
        t_rel = float(sol.t_events[0][0])
        x, v = float(sol.y_events[0][0][0]), float(sol.y_events[0][0][1])
        pieces.append((t_hit, t_rel, lambda tt, sol=sol: sol.sol(tt)[0]))
        events.append(("release", t_rel, abs(v)))
        t = t_rel
    return pieces, events


def _check_against_reference(r, force, t_end):
    pieces, ref_events = _reference(force, t_end)
    ref_events = [ev for ev in ref_events if ev[1] <= t_end]
    events = [(ev.kind, ev.time, abs(ev.relative_velocity)) for ev in r.events]
    assert len(events) == len(ref_events) >= 4
    for (kind, t, _), (ref_kind, ref_t, _) in zip(events, ref_events):
        assert kind == ref_kind
        assert t == pytest.approx(ref_t, abs=1e-9)
    x = r.masses["M"]["displacement"]
    expected = np.empty_like(x)
    for t0, t1, f in pieces:
        sel = (r.time >= t0) & (r.time <= t1)
        expected[sel] = [f(tt) for tt in r.time[sel]]
    np.testing.assert_allclose(x, expected, rtol=0, atol=1e-8)
    return events, ref_events


POWER_KEYS = f'law = "power"\ncoefficient = "{POWER_C} N/m**{POWER_A}"\nexponent = {POWER_A}\n'


@pytest.mark.parametrize("e", [0.7, 0.3])
def test_power_lash_restitution_against_solve_ivp(e):
    r = simulate(_machine(POWER_KEYS + f"restitution = {e}", duration="20 ms", stiff=""))
    events, _ = _check_against_reference(r, _power_force(e=e), 0.02)
    impacts = [speed for kind, _, speed in events if kind == "impact"]
    for n, speed in enumerate(impacts):  # the achieved restitution is e on both sides
        assert speed == pytest.approx(V * e**n, rel=1e-8)
    # tension-positive: the upper side pulls (+), the lower side pushes (−); peaks at the first impact
    f = r.elements["slot"]
    assert f.max() > 0 > f.min()


def test_power_lash_hysteresis_damping_against_solve_ivp():
    r = simulate(_machine(POWER_KEYS + 'hysteresis_damping = "0.5 s/m"', duration="20 ms", stiff=""))
    _check_against_reference(r, _power_force(chi_fixed=0.5), 0.02)


def test_adams_impact_lash_against_solve_ivp():
    keys = (f'law = "adams-impact"\nstiffness = "{ADAMS["k"]} N/m**{ADAMS["n"]}"\nexponent = {ADAMS["n"]}\n'
            f'max_damping = "{ADAMS["c_max"]} N*s/m"\npenetration_depth = "{ADAMS["depth"]} m"')
    r = simulate(_machine(keys, duration="20 ms", stiff=""))
    _check_against_reference(r, _adams_force, 0.02)
    # the reported force is the law's on the closed side, tension-positive
    x, v, f = r.masses["M"]["displacement"], r.masses["M"]["velocity"], r.elements["slot"]
    for k in np.flatnonzero(np.abs(f) > 1.0)[::7]:
        if x[k] > O + C / 2:
            assert f[k] == pytest.approx(_adams_force(x[k] - O - C / 2, v[k], None), rel=1e-9)
        else:
            assert f[k] == pytest.approx(-_adams_force(O - C / 2 - x[k], -v[k], None), rel=1e-9)


# ---------------------------------------------------------------------- a yoke on the cam
YOKE_L, YOKE_BETA, YOKE_M, YOKE_C = 10e-3, 0.25, 0.2, 1e-3


def _yoke_text():
    return f"""
schema = 1
[machine]
name = "yoke"
[cam]
speed = "60 rpm"
segments = [
  {{ motion = "rise", law = "cycloidal", duration = "90 deg", lift = "{YOKE_L} m" }},
  {{ motion = "dwell", duration = "90 deg" }},
  {{ motion = "fall", law = "cycloidal", duration = "90 deg", lift = "{YOKE_L} m" }},
  {{ motion = "dwell", duration = "90 deg" }},
]
[[mass]]
name = "M"
mass = "{YOKE_M} kg"
[[element]]
name = "yoke"
type = "lash"
law = "restitution"
restitution = 0
between = ["cam", "M"]
clearance = "{YOKE_C} m"
[initial.M]
displacement = "{-YOKE_C / 2} m"
velocity = "0 m/s"
[simulation]
cycles = 1
warmup_cycles = 0
sample_rate = "10 kHz"
"""


def _cycloid(tau):
    """s, ṡ, s̈ of the cycloidal rise (Norton, ch. 3) at local time τ ∈ [0, β]."""
    w = 2 * math.pi / YOKE_BETA
    s = YOKE_L * (tau / YOKE_BETA - math.sin(w * tau) / (2 * math.pi))
    return s, YOKE_L / YOKE_BETA * (1 - math.cos(w * tau)), YOKE_L * w / YOKE_BETA * math.sin(w * tau)


def test_rigid_yoke_sticks_and_releases():
    r = simulate(load_machine_text(_yoke_text()))
    t_r = YOKE_BETA / 2
    v_r = 2 * YOKE_L / YOKE_BETA
    s_r = _cycloid(t_r)[0]
    t_i = brentq(lambda t: v_r * (t - t_r) - (_cycloid(t)[0] - s_r) - YOKE_C, t_r + 1e-6, YOKE_BETA, xtol=1e-15)
    v_i = v_r - _cycloid(t_i)[1]
    expected = [("release", t_r, 0.0), ("impact", t_i, v_i), ("stick", t_i, 0.0)]
    expected += [(kind, t + 0.5, v) for kind, t, v in expected]  # the fall mirrors the rise
    got = [(ev.kind, ev.time, ev.relative_velocity) for ev in r.events]
    assert [k for k, _, _ in got] == [k for k, _, _ in expected]
    for (_, t, v), (_, t_ref, v_ref) in zip(got, expected):
        assert t == pytest.approx(t_ref, abs=1e-9)
        assert abs(v) == pytest.approx(v_ref, rel=1e-9, abs=1e-12)
    # resting: the yoke carries M·s̈ (tension-positive: −M·s̈ pushing on the lower side
    # during the first half of the rise, −M·s̈ pulling on the upper side after the impact)
    f = r.elements["yoke"]
    peak = YOKE_M * 2 * math.pi * YOKE_L / YOKE_BETA**2
    for sel in ((r.time > 0) & (r.time < t_r), (r.time > t_i) & (r.time < YOKE_BETA)):
        expected_f = np.array([-YOKE_M * _cycloid(t)[2] for t in r.time[sel]])
        np.testing.assert_allclose(f[sel], expected_f, rtol=0, atol=1e-9 * peak)
    flight = (r.time > t_r) & (r.time < t_i)
    assert not np.any(f[flight])


def test_rigid_lash_chatter_ends_in_stick_under_gravity():
    """A mass dropped h = 10 mm inside a rigid lash (e = 0.5) bounces on the lower side.

    Reference: Newton's law with free flight under gravity, impact n at speed eⁿ·v0 and the
    flights 2eⁿv0/g accumulating at t∞ = t0 + 2·e·v0/(g·(1 − e)), t0 = √(2h/g),
    v0 = √(2gh); then it rests (one ``stick``) and the lower side carries the weight m·g
    (tension-positive: −m·g). The lower side sits at d = 0 (offset = c/2), so that the
    Zeno cut-off acts as on a seat at gap 0 (tests/test_engine_analytic.py). Tolerances:
    times 1e-9 s, speeds 1e-9 relative, force 1e-9 relative.
    """
    g, h, e, m, c = 9.80665, 0.010, 0.5, 0.01, 0.020
    r = simulate(load_machine_text(f"""
schema = 1
[machine]
name = "chatter"
[[mass]]
name = "M"
mass = "{m} kg"
[[element]]
name = "slot"
type = "lash"
law = "restitution"
restitution = {e}
between = ["ground", "M"]
clearance = "{c} m"
offset = "{c / 2} m"
[initial.M]
displacement = "{h} m"
velocity = "0 m/s"
[simulation]
gravity = true
duration = "0.3 s"
warmup_cycles = 0
sample_rate = "10 kHz"
"""))
    t0, v0 = math.sqrt(2 * h / g), math.sqrt(2 * g * h)
    impacts = [ev for ev in r.events if ev.kind == "impact"]
    t = t0
    for n, ev in enumerate(impacts[:10]):
        assert ev.time == pytest.approx(t, abs=1e-9)
        assert ev.relative_velocity == pytest.approx(v0 * e**n, rel=1e-9)
        t += 2 * e**(n + 1) * v0 / g
    sticks = [ev for ev in r.events if ev.kind == "stick"]
    t_inf = t0 + 2 * e * v0 / (g * (1 - e))
    assert len(sticks) == 1 and sticks[0].time == pytest.approx(t_inf, abs=1e-9)
    assert r.events[-1].kind == "stick"
    after = r.time > t_inf + 1e-3
    np.testing.assert_allclose(r.elements["slot"][after], -m * g, rtol=1e-9)

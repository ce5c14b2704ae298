"""Rigid contacts that stick and act together (issue 12, spec §3-4).

References:
- Goldsmith, *Impact* (1960), ch. 1: direct central impact of two bodies with Newton's
  coefficient e — momentum conserved, relative velocity reversed and scaled by e:
  v1' = (m1v1 + m2v2 − m2·e·(v1 − v2))/(m1 + m2), v2' = (m1v1 + m2v2 + m1·e·(v1 − v2))/(m1 + m2);
  e = 0: both move on at the common velocity vc = (m1v1 + m2v2)/(m1 + m2).
- Simultaneous impacts: Newton's law per contact with momentum conservation, as one LCP,
  solved by hand below for a three-ball chain (the striker A reaches B while B touches C).
- Statics: a stack of rigid bodies resting under gravity carries (m1 + m2)·g at the bottom
  contact and m2·g at the top one.
Tolerances: velocities 1e-12 relative (impulses are one exact linear solve), forces 1e-9.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from camsim.machine.loader import load_machine_text
from camsim.engine.rigid import solve_lcp
from camsim import simulate

G = 9.80665


def _pair(e, m1=2.0, m2=1.0, v1=3.0, v2=-1.0, gap=0.1, x2=0.2):
    return f"""
schema = 1
[machine]
name = "collinear impact"
[[mass]]
name = "A"
mass = "{m1} kg"
[[mass]]
name = "B"
mass = "{m2} kg"
[[element]]
name = "AB"
type = "contact"
between = ["A", "B"]
law = "restitution"
gap = "{gap} m"
restitution = {e}
[initial.A]
displacement = "0 m"
velocity = "{v1} m/s"
[initial.B]
displacement = "{x2} m"
velocity = "{v2} m/s"
[simulation]
duration = "0.1 s"
warmup_cycles = 0
sample_rate = "1 kHz"
"""


@pytest.mark.parametrize("e", [0.6, 0.0])
def test_goldsmith_collinear_impact(e):
    """Goldsmith ch. 1 final velocities to 1e-12; e = 0: one impact, one stick, then the
    pair moves on together at vc (no release, no further impacts)."""
    m1, m2, v1, v2 = 2.0, 1.0, 3.0, -1.0
    r = simulate(load_machine_text(_pair(e, m1, m2, v1, v2)))
    p = m1 * v1 + m2 * v2
    v1f = (p - m2 * e * (v1 - v2)) / (m1 + m2)
    v2f = (p + m1 * e * (v1 - v2)) / (m1 + m2)
    assert r.masses["A"]["velocity"][-1] == pytest.approx(v1f, rel=1e-12, abs=1e-12)
    assert r.masses["B"]["velocity"][-1] == pytest.approx(v2f, rel=1e-12, abs=1e-12)
    kinds = [ev.kind for ev in r.events]
    # impact at t = gap closing: (x2 − gap)/(v1 − v2)
    assert r.events[0].time == pytest.approx(0.1 / 4.0, abs=1e-15)
    if e == 0.0:
        assert kinds == ["impact", "stick"]
        d = r.masses["B"]["displacement"] - r.masses["A"]["displacement"]
        after = r.time > r.events[0].time + 1e-9
        assert np.max(np.abs(d[after] - 0.1)) < 1e-12
    else:
        assert kinds == ["impact"]


def _chain(e):
    return f"""
schema = 1
[machine]
name = "three-ball chain"
[[mass]]
name = "A"
mass = "1 kg"
[[mass]]
name = "B"
mass = "1 kg"
[[mass]]
name = "C"
mass = "1 kg"
[[element]]
name = "AB"
type = "contact"
between = ["A", "B"]
law = "restitution"
gap = "0 m"
restitution = {e}
[[element]]
name = "BC"
type = "contact"
between = ["B", "C"]
law = "restitution"
gap = "0 m"
restitution = {e}
[initial.A]
displacement = "-0.01 m"
velocity = "1 m/s"
[initial.B]
displacement = "0 m"
velocity = "0 m/s"
[initial.C]
displacement = "0 m"
velocity = "0 m/s"
[simulation]
duration = "0.05 s"
warmup_cycles = 0
sample_rate = "1 kHz"
"""


@pytest.mark.parametrize("e", [1.0, 0.5])
def test_simultaneous_contacts_one_lcp(e):
    """A (1 m/s) strikes B, which rests against C (equal masses). Newton's law on both
    contacts at once: W = [[2, −1], [−1, 2]], q = [−(1+e), 0]; both contacts active gives
    P = W⁻¹·[(1+e), 0] = (1+e)/3·[2, 1] > 0, so v_A = 1 − 2(1+e)/3, v_B = v_C = (1+e)/3
    (momentum 1 kg·m/s conserved); B and C then move on together (BC persistent)."""
    r = simulate(load_machine_text(_chain(e)))
    assert r.masses["A"]["velocity"][-1] == pytest.approx(1 - 2 * (1 + e) / 3, rel=1e-12, abs=1e-13)
    assert r.masses["B"]["velocity"][-1] == pytest.approx((1 + e) / 3, rel=1e-12)
    assert r.masses["C"]["velocity"][-1] == pytest.approx((1 + e) / 3, rel=1e-12)
    impacts = [ev for ev in r.events if ev.kind == "impact"]
    assert [ev.element for ev in impacts] == ["AB"]
    assert impacts[0].time == pytest.approx(0.01, abs=1e-15)


def _stack(drop=None):
    initial = ""
    if drop is not None:
        initial = f"""
[initial.B]
displacement = "{0.05 + drop} m"
velocity = "0 m/s"
[initial.A]
displacement = "0 m"
velocity = "0 m/s"
"""
    return f"""
schema = 1
[machine]
name = "stack"
[[mass]]
name = "A"
mass = "2 kg"
[[mass]]
name = "B"
mass = "0.5 kg"
[[element]]
name = "floor"
type = "contact"
between = ["ground", "A"]
law = "restitution"
gap = 0
restitution = 0.5
[[element]]
name = "AB"
type = "contact"
between = ["A", "B"]
law = "restitution"
gap = "0.05 m"
restitution = 0.0
{initial}
[simulation]
gravity = true
duration = "0.3 s"
warmup_cycles = 0
sample_rate = "1 kHz"
"""


def test_stack_rests_under_gravity():
    """Two rigid bodies stacked on the floor, placed touching (an [initial] table: the
    static-equilibrium search does not place masses on rigid contacts): no event, at rest,
    contact forces (m_A + m_B)·g = 24.516625 N and m_B·g = 4.903325 N (statics) to 1e-9."""
    r = simulate(load_machine_text(_stack(drop=0.0)))
    assert [ev.kind for ev in r.events] == []
    assert np.max(np.abs(r.masses["A"]["velocity"])) < 1e-12
    assert np.allclose(r.elements["floor"], 2.5 * G, rtol=1e-9)
    assert np.allclose(r.elements["AB"], 0.5 * G, rtol=1e-9)


def test_plastic_drop_on_a_resting_body():
    """B dropped from 20 mm onto A resting on the floor (AB plastic, floor e = 0.5): the
    impulses of the simultaneous LCP stop B and A together (the floor contact takes the
    rest: A cannot move down), one `impact` and one `stick` on AB at t = √(2h/g), then the
    stack rests with the static forces (to 1e-9)."""
    h = 0.02
    r = simulate(load_machine_text(_stack(drop=h)))
    t_hit = math.sqrt(2 * h / G)
    ab = [(ev.kind, ev.time) for ev in r.events if ev.element == "AB"]
    assert [k for k, _ in ab] == ["impact", "stick"]
    assert ab[0][1] == pytest.approx(t_hit, abs=1e-12)
    assert [ev.kind for ev in r.events if ev.element == "floor"] == []
    after = r.time > t_hit + 1e-6
    assert np.max(np.abs(r.masses["B"]["velocity"][after])) < 1e-12
    assert np.allclose(r.elements["floor"][after], 2.5 * G, rtol=1e-9)
    assert np.allclose(r.elements["AB"][after], 0.5 * G, rtol=1e-9)


def test_lcp_solver_hand_cases():
    """solve_lcp against hand solutions: 2x2 with one active contact, none, both."""
    W = np.array([[2.0, -1.0], [-1.0, 2.0]])
    assert np.allclose(solve_lcp(W, np.array([1.0, 2.0])), [0.0, 0.0])
    x = solve_lcp(W, np.array([-2.0, 3.0]))
    assert np.allclose(x, [1.0, 0.0]) and np.all(W @ x + [-2.0, 3.0] >= -1e-15)
    assert np.allclose(solve_lcp(W, np.array([-3.0, 0.0])), [2.0, 1.0])

"""``type = "lash"`` (two-sided clearance, spec §3).

Reference: a mass M = 0.5 kg moving at v = 0.5 m/s inside a clearance c = 2 mm (offset
0.3 mm) with an undamped linear contact k = 1e6 N/m on each side. Between contacts it
flies at constant speed; each contact is half a period of the contact oscillator,
π/ω with ω = √(k/M), and returns it at the same speed. So the impacts come at
t₁ = (c/2 + o)/v (the upper side, d = x), then every π/ω + c/v, alternately on the upper and lower side, with a
peak force v·√(k·M). With ``restitution`` e the rebound speeds fall as eⁿ·v (the
closed-form mapping of a clamped linear contact, docs/contacts.md). Tolerances: times
1e-9 s, speeds and forces 1e-9 relative.
"""

from __future__ import annotations

import math

import pytest

from camsim.loader import load_machine_text
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

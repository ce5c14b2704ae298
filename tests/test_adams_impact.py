"""``law = "adams-impact"`` (MSC Adams IMPACT, spec §3).

Reference: a tight ``solve_ivp`` (DOP853, rtol 1e-13, each smooth piece of the force law
its own run ended at a located kink) of the same equation written out here — a 0.5 kg mass dropped under gravity from 5 mm onto an IMPACT contact
(k = 1e8 N/m^1.5, n = 1.5, c_max = 200 N·s/m, d = 0.05 mm), Adams's cubic STEP and the
force clamped at zero — with a terminal event at δ = 0 on the way out. Tolerances: the
rebound speed and contact duration to 1e-8 relative, the trajectory to 1e-8 of the peak
penetration.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from camsim import simulate
from camsim.machine.loader import load_machine_text

M, G, K, N, CMAX, D, H = 0.5, 9.80665, 1.0e8, 1.5, 200.0, 5.0e-5, 5.0e-3

TEXT = f"""
schema = 1
[machine]
name = "IMPACT drop"
[[mass]]
name = "M"
mass = "{M} kg"
[[element]]
name = "stop"
type = "contact"
between = ["ground", "M"]
law = "adams-impact"
gap = 0
exponent = {N}
stiffness = "{K} N/m**{N}"
max_damping = "{CMAX} N*s/m"
penetration_depth = "{D} m"
[initial.M]
displacement = "{H} m"
velocity = "0 m/s"
[simulation]
gravity = true
duration = "40 ms"
warmup_cycles = 0
sample_rate = "200 kHz"
"""


def _force(delta, rate):
    if delta <= 0:
        return 0.0
    u = min(delta / D, 1.0)
    f = K * delta**N + CMAX * u * u * (3 - 2 * u) * rate
    return max(f, 0.0)


def reference():
    """The drop integrated piece by piece between the force law's kinks.

    The IMPACT force has two kinks inside the contact: the STEP ends at δ = d, and the
    force is clamped at zero where the damping term would pull (the mass leaves the
    force briefly on the way out and meets it again). An integrator stepping across a
    kink loses its order there, and where its steps fall depends on the last bits of the
    arithmetic (numpy 1 and 2 gave rebounds 9e-6 apart). Here each smooth piece is its
    own DOP853 run (rtol 1e-13), ended by a located event at the kink, so the reference
    converges whatever the step sequence.
    """
    t0 = math.sqrt(2 * H / G)
    v0 = math.sqrt(2 * G * H)

    def step(delta):
        u = min(delta / D, 1.0)
        return u * u * (3 - 2 * u)

    def pushing(_t, y):  # the unclamped force's value: it pushes while > 0
        # (continued below δ = 0 as −K·|δ|^n, not as 0: a clamped phase's end step lands at
        # δ < 0, and a value of exactly 0 there made solve_ivp's root finder take that step
        # end for the crossing and miss the real one just before δ = 0, where the elastic
        # term, ∝ δ^1.5, outgrows the damping term, ∝ δ²: the law pushes again for the last
        # 19 µs of the contact. The former reference treated them as free flight and read a
        # rebound 9.2e-6 slower than the law gives.)
        return K * math.copysign(abs(y[0]) ** N, y[0]) + CMAX * step(y[0]) * y[1]

    def at_d(_t, y):
        return y[0] - D

    def out(_t, y):
        return y[0]

    def free(_t, y):
        return [y[1], G]

    def loaded(_t, y):
        return [y[1], G - (K * max(y[0], 0.0) ** N + CMAX * step(y[0]) * y[1]) / M]

    pieces, t, y = [], 0.0, np.array([0.0, v0])
    clamped, inner = False, False  # the force is zero; δ > d
    while True:
        out.terminal, out.direction = True, -1
        at_d.terminal, at_d.direction = True, (-1 if inner else 1)
        pushing.terminal, pushing.direction = True, (1 if clamped else -1)
        # (max_step: a clamped phase is free flight, which DOP853 would cross in one step,
        # over the law's brief push before δ = 0: − + − inside one step, no sign change seen)
        sol = solve_ivp(free if clamped else loaded, (t, 0.01), y, method="DOP853", rtol=1e-13,
                        atol=[1e-17, 1e-13], events=[out, at_d, pushing], dense_output=True, first_step=1e-10,
                        max_step=1e-6)
        hit = [k for k in range(3) if sol.t_events[k].size]
        assert hit, "the contact never ended"
        i = min(hit, key=lambda k: sol.t_events[k][0])
        t_end = float(sol.t_events[i][0])
        pieces.append((t, t_end, sol.sol))
        t, y = t_end, sol.y_events[i][0].copy()
        if i == 0:
            break
        if i == 1:
            inner = not inner
        else:
            clamped = not clamped

    class Dense:
        """``sol(t)`` over the whole contact, from the piece holding each t."""

        @staticmethod
        def sol(times):
            times = np.atleast_1d(times)
            result = np.empty((2, times.size))
            for k, s in enumerate(times):
                piece = next((p for p in pieces if p[0] <= s <= p[1]), pieces[-1])
                result[:, k] = piece[2](s)
            return result

    return t0, v0, t, -y[1], Dense


def test_adams_impact_drop_against_solve_ivp():
    """The drop against the piecewise reference: the kinks of the law (δ = d, the clamp, and
    the push again just before release) are located by camsim like events (issue 34)."""
    t0, v0, duration, rebound, sol = reference()
    r = simulate(load_machine_text(TEXT))
    impact = [e for e in r.events if e.kind == "impact"][0]
    release = [e for e in r.events if e.kind == "release"][0]
    assert impact.time == pytest.approx(t0, abs=1e-12)
    assert impact.relative_velocity == pytest.approx(v0, rel=1e-12)
    assert release.time - impact.time == pytest.approx(duration, rel=1e-8)
    assert -release.relative_velocity == pytest.approx(rebound, rel=1e-8)
    inside = (r.time > impact.time) & (r.time < release.time)
    delta_ref = sol.sol(r.time[inside] - impact.time)[0]
    peak = float(np.max(delta_ref))
    assert np.max(np.abs(-r.masses["M"]["displacement"][inside] - delta_ref)) < 1e-8 * peak
    assert 0 < rebound < v0

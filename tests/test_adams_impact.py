"""``law = "adams-impact"`` (MSC Adams IMPACT, spec §3).

Reference: a tight ``solve_ivp`` (DOP853, rtol 1e-12) of the same equation written out
here — a 0.5 kg mass dropped under gravity from 5 mm onto an IMPACT contact
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
from camsim.loader import load_machine_text

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
    t0 = math.sqrt(2 * H / G)
    v0 = math.sqrt(2 * G * H)

    def rhs(_t, y):  # y = [δ, δ̇] with δ = −x
        return [y[1], G - _force(y[0], y[1]) / M]

    def out(_t, y):
        return y[0]

    out.terminal, out.direction = True, -1
    sol = solve_ivp(rhs, (0, 0.01), [0.0, v0], method="DOP853", rtol=1e-12, atol=[1e-16, 1e-12],
                    events=out, dense_output=True, first_step=1e-9)
    t_out = sol.t_events[0][0]
    return t0, v0, t_out, -sol.y_events[0][0][1], sol


@pytest.mark.xfail(
    int(np.__version__.split(".")[0]) < 2,
    strict=True,
    reason="reference not converged: with numpy 1.x this DOP853 run takes another step sequence "
    "through the force's re-engagement just before exit and its rebound moves 9e-6 relative "
    "(camsim's numbers are the same on numpy 1 and 2; see issue 30's report)",
)
def test_adams_impact_drop_against_solve_ivp():
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

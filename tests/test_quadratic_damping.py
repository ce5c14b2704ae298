"""Quadratic damping of springs and links (spec §10): f_q = c_q·ḋ·|ḋ| added to the force.

References:

* Closed form: a mass m leaving at v0 on a quadratic damper alone (k = 0) slows as
  v(t) = v0/(1 + c_q·v0·t/m) and travels x(t) = (m/c_q)·ln(1 + c_q·v0·t/m); at 1e-9 of v0
  and of x (the engine integrates F_nl to its tolerance, rtol 1e-10).
* scipy's DOP853 at rtol 1e-13 on the same equation for a spring–mass with both viscous and
  quadratic damping ringing down from an initial displacement: 1e-8 of the amplitude.
* The static equilibrium is linear (f_q vanishes at rest): the preloaded train's rest state
  with and without c_q is the same to rounding.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from camsim.errors import MachineFileError
from camsim.machine.loader import load_machine_text
from camsim.run.simulation import simulate

M, V0, CQ = 0.4, 2.0, 3.0  # [kg], [m/s], [N·s²/m²]


def _drag(k: str = "0 N/m", cq: float = CQ, x0: str = "0 m", v0: float = V0, duration: str = "50 ms",
          c: str = "0 N*s/m", rate: str = "20 kHz") -> str:
    return f"""
schema = 1
[machine]
name = "a mass on a quadratic damper"
[[mass]]
name = "m"
mass = "{M} kg"
[[element]]
name = "drag"
type = "spring"
between = ["ground", "m"]
stiffness = "{k}"
damping = "{c}"
quadratic_damping = "{cq} N*s^2/m^2"
[initial.m]
displacement = "{x0}"
velocity = "{v0} m/s"
[simulation]
duration = "{duration}"
sample_rate = "{rate}"
"""


def test_pure_quadratic_drag_is_the_closed_form():
    r = simulate(load_machine_text(_drag()))
    t = r.time
    a = CQ * V0 / M
    v_ref = V0 / (1.0 + a * t)
    x_ref = (M / CQ) * np.log1p(a * t)
    assert np.max(np.abs(r.masses["m"]["velocity"] - v_ref)) < 1e-9 * V0
    assert np.max(np.abs(r.masses["m"]["displacement"] - x_ref)) < 1e-9 * x_ref[-1]
    # the element's force is −f_q (tension-positive f = c_q·ḋ·|ḋ|, ḋ = v): −m·a = −m·dv/dt
    f = r.elements["drag"]
    assert np.max(np.abs(f - CQ * v_ref * np.abs(v_ref))) < 1e-8 * CQ * V0**2


def test_ring_down_matches_a_tight_dop853():
    k, c, x0 = 2.0e4, 1.5, 5e-3
    r = simulate(load_machine_text(_drag(k=f"{k} N/m", c=f"{c} N*s/m", x0=f"{x0} m", v0=0.0, duration="40 ms",
                                         rate="50 kHz")))

    def rhs(_t, y):
        x, v = y
        return [v, (-k * x - c * v - CQ * v * abs(v)) / M]

    ref = solve_ivp(rhs, (0.0, float(r.time[-1])), [x0, 0.0], method="DOP853", rtol=1e-13, atol=1e-16,
                    t_eval=r.time, dense_output=False)
    assert np.max(np.abs(r.masses["m"]["displacement"] - ref.y[0])) < 1e-8 * x0


def test_sample_rate_does_not_change_the_motion():
    """Invariant: the 10 kHz samples are the 50 kHz run's every fifth (to the integrator's
    tolerance, the nodes differ)."""
    fine = simulate(load_machine_text(_drag(k="2e4 N/m", x0="5 mm", v0=0.0, duration="20 ms", rate="50 kHz")))
    coarse = simulate(load_machine_text(_drag(k="2e4 N/m", x0="5 mm", v0=0.0, duration="20 ms", rate="10 kHz")))
    assert np.max(np.abs(fine.masses["m"]["displacement"][::5] - coarse.masses["m"]["displacement"])) < 1e-10 * 5e-3


def test_rest_is_linear():
    """f_q vanishes at rest: the equilibrium of a gravity-loaded spring does not move."""
    text = _drag(k="2e4 N/m", v0=0.0, duration="5 ms").replace('[simulation]', '[simulation]\ngravity = "9.81 m/s^2"')
    text = text.replace('[initial.m]\ndisplacement = "0 m"\nvelocity = "0.0 m/s"\n', "")
    r = simulate(load_machine_text(text))
    x = r.masses["m"]["displacement"]
    assert np.max(np.abs(x - x[0])) < 1e-15
    assert x[0] == pytest.approx(-M * 9.81 / 2e4, rel=1e-12)


def test_negative_quadratic_damping_is_refused():
    with pytest.raises(MachineFileError, match="quadratic_damping"):
        load_machine_text(_drag(cq=-1.0))

"""Gaps of either sign (spec §10): a contact's ``gap`` g0 < 0 is a stop on the far side of the
origin — the contact touches at d = g0 < 0 (δ = g0 − d) — for every law.

References and tolerances:

* Static equilibrium of a mass m on a spring k_s under gravity, resting on a stop at x = g0 < 0
  (``between = ["ground", "m"]``): k_s·x + m·g = F(g0 − x) with F the law at rest (k·δ for the
  linear and ElastoGap laws; C·δ^a for the power law and Adams IMPACT; (4/3)·E*·√R·δ^1.5 for a
  Hertz sphere, E* from the test's own [[material]] values; the rigid stop holds x = g0 with
  the force k_s·g0 + m·g), solved here by Brent's method to rounding: the position to 1e-12
  relative, the contact force to 1e-9 relative.
* A drop onto a stop at x = g0 < 0 from x = 0 at rest under gravity g: the impact comes at
  t = √(2|g0|/g) with approach speed √(2·g·|g0|) (kinematics), to 1e-12 s and 1e-12 relative,
  for every law; an undamped linear or ElastoGap stop then holds the mass for
  (2π − 2·atan(v/(ω·δ_s)))/ω, ω = √(k/m), δ_s = m·g/k (the harmonic motion about the static
  deflection, δ = δ_s·(1 − cos ωt) + (v/ω)·sin ωt, back at δ = 0) to 1e-9 s and releases it at
  v (1e-9 relative); a rigid stop rebounds at e·v (the next impact 2·e·v/g later, 1e-12 s).
* A mass given inside a compliant stop at a negative gap ([initial]) starts closed: the force
  at t = 0 is k·(g0 − x0) (1e-12 relative). A rigid stop refuses an [initial] state that
  penetrates it, at a negative gap as at any other.
"""

from __future__ import annotations

import math

import pytest
from scipy.optimize import brentq

from camsim.errors import InputError
from camsim.machine.loader import load_machine_text
from camsim.run.simulation import simulate

G = 9.80665
M, KS, G0 = 2.0, 100.0, -1e-3  # [kg], [N/m], [m]
E_MAT, NU_MAT, RADIUS = 200e9, 0.3, 5e-3  # the [[material]] of the Hertz case, sphere radius [m]

#: law → (the element's keys, F(δ) at rest [N] written out here, the penetration-free slope
#: scale used to bracket the root)
LAWS = {
    "linear": ('law = "linear"\nstiffness = "2e6 N/m"\ndamping_ratio = 0.05', lambda d: 2e6 * d),
    "power": ('law = "power"\ncoefficient = "3e9 N/m^1.5"\nexponent = 1.5\nrestitution = 0.8', lambda d: 3e9 * d**1.5),
    "adams-impact": ('law = "adams-impact"\nstiffness = "3e9 N/m^1.5"\nexponent = 1.5\nmax_damping = "50 N*s/m"\n'
                     'penetration_depth = "0.01 mm"', lambda d: 3e9 * d**1.5),
    "elastogap": ('law = "elastogap"\nstiffness = "2e6 N/m"\nrestitution = 0.7', lambda d: 2e6 * d),
    "hertz": ('law = "hertz"\ngeometry = "sphere-on-flat"\nradius = "5 mm"\nmaterials = ["mat", "mat"]\n'
              'restitution = 0.8',
              lambda d: 4.0 / 3.0 * (E_MAT / (2.0 * (1.0 - NU_MAT**2))) * math.sqrt(RADIUS) * d**1.5),
    "restitution": ('law = "restitution"\nrestitution = 0.5', None),
}


def _machine(law_keys: str, *, spring: bool = True, initial: str = "", gap: float = G0, duration: str = "2 ms",
             rate: str = "100 kHz") -> str:
    spring_table = f"""
[[element]]
name = "spring"
type = "spring"
between = ["ground", "m"]
stiffness = "{KS} N/m"
""" if spring else ""
    return f"""
schema = 1
[machine]
name = "a stop below the origin"
[[mass]]
name = "m"
mass = "{M} kg"
[[element]]
name = "stop"
type = "contact"
between = ["ground", "m"]
gap = "{gap} m"
{law_keys}
{spring_table}
[[material]]
name = "mat"
youngs_modulus = "{E_MAT} Pa"
poisson_ratio = {NU_MAT}
{initial}
[simulation]
duration = "{duration}"
gravity = true
sample_rate = "{rate}"
"""


@pytest.mark.parametrize("law", list(LAWS))
def test_rests_on_a_stop_below_the_origin(law):
    keys, force = LAWS[law]
    r = simulate(load_machine_text(_machine(keys)))
    x0, f0 = r.masses["m"]["displacement"][0], r.elements["stop"][0]
    if force is None:  # rigid: held at the stop by the force the spring and gravity need
        x_ref, f_ref = G0, KS * G0 + M * G
    else:  # k_s·x + m·g = F(g0 − x): one root below g0
        x_ref = brentq(lambda x: KS * x + M * G - force(G0 - x), G0 - 1e-2, G0, xtol=1e-300, rtol=1e-15)
        f_ref = force(G0 - x_ref)
    assert x0 == pytest.approx(x_ref, rel=1e-12)
    assert f0 == pytest.approx(f_ref, rel=1e-9)
    assert not list(r.events)  # at rest: nothing happens
    assert r.masses["m"]["displacement"][-1] == pytest.approx(x_ref, rel=1e-12)


@pytest.mark.parametrize("law", list(LAWS))
def test_drop_onto_a_stop_below_the_origin(law):
    keys, _ = LAWS[law]
    r = simulate(load_machine_text(_machine(keys, spring=False, initial='[initial.m]\ndisplacement = "0 m"\n'
                                            'velocity = "0 m/s"', duration="30 ms")))
    t_hit = math.sqrt(2.0 * abs(G0) / G)
    first = r.impacts()[0]
    assert first.time == pytest.approx(t_hit, abs=1e-12)
    assert first.relative_velocity == pytest.approx(G * t_hit, rel=1e-12)
    if law == "restitution":
        assert r.impacts()[1].time == pytest.approx(t_hit + 2 * 0.5 * G * t_hit / G, abs=1e-12)


@pytest.mark.parametrize("law", ["linear", "elastogap"])
def test_undamped_drop_contact_time_is_the_closed_form(law):
    k = 2e6
    keys = f'law = "{law}"\nstiffness = "{k} N/m"'
    r = simulate(load_machine_text(_machine(keys, spring=False, initial='[initial.m]\ndisplacement = "0 m"\n'
                                            'velocity = "0 m/s"', duration="25 ms")))
    t_hit = math.sqrt(2.0 * abs(G0) / G)
    first = r.impacts()[0]
    assert first.time == pytest.approx(t_hit, abs=1e-12)
    w, v, static = math.sqrt(k / M), G * t_hit, M * G / k
    assert first.contact_duration == pytest.approx((2 * math.pi - 2 * math.atan(v / (w * static))) / w, abs=1e-9)
    release = next(e for e in r.events if e.kind == "release")
    assert abs(release.relative_velocity) == pytest.approx(G * t_hit, rel=1e-9)


def test_initial_state_inside_a_stop_at_a_negative_gap_starts_closed():
    x0 = G0 - 1e-5
    r = simulate(load_machine_text(_machine('law = "linear"\nstiffness = "2e6 N/m"', spring=False,
                                            initial=f'[initial.m]\ndisplacement = "{x0} m"\nvelocity = "0 m/s"',
                                            rate="10 MHz", duration="0.1 ms")))
    assert r.elements["stop"][0] == pytest.approx(2e6 * (G0 - x0), rel=1e-12)
    assert not r.impacts()  # it starts closed: no impact row


def test_rigid_stop_at_a_negative_gap_refuses_a_penetrating_start():
    text = _machine(LAWS["restitution"][0], spring=False,
                    initial=f'[initial.m]\ndisplacement = "{G0 - 1e-6} m"\nvelocity = "0 m/s"')
    with pytest.raises((InputError, ValueError), match="penetrates"):
        simulate(load_machine_text(text))
    # touching it is allowed: it rests there
    r = simulate(load_machine_text(_machine(LAWS["restitution"][0], spring=False,
                                            initial=f'[initial.m]\ndisplacement = "{G0} m"\nvelocity = "0 m/s"')))
    assert r.masses["m"]["displacement"][-1] == pytest.approx(G0, rel=1e-12)
    assert r.elements["stop"][-1] == pytest.approx(M * G, rel=1e-12)

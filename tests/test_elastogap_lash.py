"""``type = "lash"`` with ``law = "elastogap"`` and lashes whose sides differ (spec §10).

The flight of tests/test_lash.py: a mass M = 0.5 kg leaves x = 0 at V = 0.5 m/s inside a
clearance C = 2 mm (offset O = 0.3 mm) between ``ground`` and the mass, so d = x; it meets
the upper side at x = O + C/2 first, then alternates. Between contacts it flies freely.

References and tolerances:

* ElastoGap on both sides, undamped (n = 1): each contact is half a period, π·√(M/k), and
  returns the mass at the speed it came; the impacts come at the closed-form times (times
  1e-9 s, speeds and the peak force V·√(k·M) 1e-9 relative).
* ElastoGap with ``restitution`` e (n = 1): every rebound is e times the approach speed
  (:func:`camsim.physics.restitution.elastogap_restitution`, itself checked against DOP853
  in tests/test_elastogap.py) to 1e-9 relative; and every contact against scipy's
  ``solve_ivp`` DOP853 at rtol 1e-13 on the clipped law F = kδ + clip(cδ̇, −kδ, kδ),
  written below independently of camsim (one right-hand side with the clip; the integration
  stopped and restarted where the clip changes, so that no step straddles a corner): the
  contact time to 1e-9 s, the rebound speed to 1e-9 relative, the peak force to 1e-9
  relative, and the impact times of the whole flight to 1e-9 s.
* ElastoGap with n = 1.5 and a damping coefficient (the clipped law integrated by camsim to
  its tolerance): against the same DOP853 reference, rebound speeds to 1e-7 relative, times
  to 1e-9 s.
* A lash with ``lower`` and ``upper`` tables: a linear k1 below and an ElastoGap k2 above,
  undamped — contact times π·√(M/k2) and π·√(M/k1) alternately, peaks V·√(k·M) and Johnson's
  upper bounds per side (1e-9); damped by restitutions e1 (linear) and e2 (ElastoGap) — the
  approach speeds V, e2·V, e1·e2·V, e1·e2²·V, … (1e-9 relative); two rigid sides with their
  own e — free flights and Newton's law in closed form (1e-12); a power-law side with the
  exact Hunt–Crossley mapping rebounds at exactly its e (1e-8).
* Two free masses meeting in an ElastoGap lash given ``restitution`` e (alone, or as one
  side's table): the mapping with the reduced mass gives Newton's outcome — momentum
  conserved, relative velocity reversed and scaled by e — to 1e-9 relative.
* ``element.<name>.upper.<key>`` key paths set and read a side's keys.
* Invariants: the sample rate does not move an event (1e-12 s); the file order of the
  elements does not change the results (events 1e-12 s, traces 1e-12 of their peak); a lash
  whose two tables hold the same law runs as the lash with that law (the same).
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.optimize import minimize_scalar

from camsim.machine.loader import load_machine_text
from camsim.physics.restitution import elastogap_damping_ratio, elastogap_restitution
from camsim.run.simulation import simulate

M, V, C, O = 0.5, 0.5, 2e-3, 0.3e-3  # [kg], [m/s], [m], [m]
HIGH, LOW = O + C / 2, O - C / 2


def _lash(keys: str, duration: str = "30 ms", rate: str = "100 kHz", spring: bool = False,
          spring_first: bool = False) -> str:
    lash = f"""
[[element]]
name = "slot"
type = "lash"
between = ["ground", "M"]
clearance = "{C} m"
offset = "{O} m"
{keys}
"""
    spring_table = """
[[element]]
name = "spring"
type = "spring"
between = ["ground", "M"]
stiffness = "300 N/m"
damping = "0.2 N*s/m"
""" if spring else ""
    elements = spring_table + lash if spring_first else lash + spring_table
    return f"""
schema = 1
[machine]
name = "lash"
[[mass]]
name = "M"
mass = "{M} kg"
{elements}
[initial.M]
displacement = "0 m"
velocity = "{V} m/s"
[simulation]
duration = "{duration}"
sample_rate = "{rate}"
"""


# ---------------------------------------------------------------------- the reference
def _contact(k: float, c: float, v: float, n: float = 1.0) -> tuple[float, float, float]:
    """(contact time [s], rebound speed [m/s], peak force [N]) of the mass M arriving at v on
    F = k·δⁿ + clip(c·δ̇, −k·δⁿ, k·δⁿ), by DOP853 (rtol 1e-13) from touch-down (δ = 0, δ̇ = v)
    to δ = 0 again. The law is one right-hand side; the integration stops where the clip
    lets go of the approach (c·δ̇ = k·δⁿ), where the rebound's clip takes over
    (k·δⁿ + c·δ̇ = 0) and at δ = 0, each a terminal event, and restarts from there."""

    def force(delta, rate):
        elastic = k * max(delta, 0.0) ** n
        return elastic + min(max(c * rate, -elastic), elastic)

    def rhs(_t, y):
        return [y[1], -force(y[0], y[1]) / M]

    def approach_ends(_t, y):
        return c * y[1] - k * max(y[0], 0.0) ** n

    def law_ends(_t, y):
        return k * max(y[0], 0.0) ** n + c * y[1]

    def contact_ends(_t, y):
        return y[0]

    events = [approach_ends, law_ends, contact_ends]
    for e in events:
        e.terminal, e.direction = True, -1
    span = 50 * math.pi * math.sqrt(M / k) if n == 1 else 1e-2
    t, y, peak = 0.0, np.array([0.0, v]), 0.0
    for stage, event in enumerate(events if c > 0 else [contact_ends]):
        sol = solve_ivp(rhs, (t, t + span), y, method="DOP853", rtol=1e-13, atol=1e-20, events=[event],
                        dense_output=True, max_step=span / 4000)
        assert sol.t_events[0].size == 1, f"stage {stage} did not end"
        t_end = float(sol.t_events[0][0])
        grid = np.linspace(t, t_end, 4001)
        values = np.array([force(*sol.sol(s)) for s in grid])
        i = int(np.argmax(values))
        lo, hi = grid[max(i - 1, 0)], grid[min(i + 1, len(grid) - 1)]
        best = minimize_scalar(lambda s: -force(*sol.sol(s)), bounds=(lo, hi), method="bounded",
                               options={"xatol": 1e-16})
        peak = max(peak, values[i], -best.fun, force(*sol.y_events[0][0]))
        t, y = t_end, sol.y_events[0][0]
    return t, -float(y[1]), peak


def _flight(contacts, t_end: float) -> list[tuple[float, float]]:
    """(impact time, approach speed) of the flight of the module docstring, each contact's
    (time, rebound) given by ``contacts(side, speed)``, side +1 upper first, −1 lower."""
    out, t, v, side = [], HIGH / V, V, 1
    while t < t_end:
        out.append((t, v))
        duration, v = contacts(side, v)
        t += duration + C / v
        side = -side
    return out


def _check_flight(r, expected, t_tol=1e-9, v_tol=1e-9):
    impacts = r.impacts()
    assert len(impacts) == len(expected) >= 4
    for ev, (t, v) in zip(impacts, expected):
        assert abs(ev.time - t) < t_tol, (ev.time, t)
        assert ev.relative_velocity == pytest.approx(v, rel=v_tol)


# ---------------------------------------------------------------------- ElastoGap on both sides
def test_undamped_elastogap_lash_is_the_closed_form():
    k = 1e6
    r = simulate(load_machine_text(_lash(f'law = "elastogap"\nstiffness = "{k} N/m"')))
    half = math.pi * math.sqrt(M / k)
    _check_flight(r, _flight(lambda side, v: (half, v), 30e-3))
    for ev in r.impacts():
        if not math.isnan(ev.contact_duration):
            assert abs(ev.contact_duration - half) < 1e-9
        assert ev.peak_force == pytest.approx(V * math.sqrt(k * M), rel=1e-9)


@pytest.mark.parametrize("e", [0.8, 0.5])
def test_elastogap_lash_restitution(e):
    k = 1e6
    r = simulate(load_machine_text(_lash(f'law = "elastogap"\nstiffness = "{k} N/m"\nrestitution = {e}',
                                         duration="80 ms")))
    zeta = elastogap_damping_ratio(e)
    assert elastogap_restitution(zeta) == pytest.approx(e, rel=1e-12)
    c = 2.0 * zeta * math.sqrt(k * M)
    duration, rebound, peak = _contact(k, c, V)
    assert rebound == pytest.approx(e * V, rel=1e-9)  # the mapping against the reference
    # linear law: the contact time is the same at every speed, the rebound and peak scale with it
    expected = _flight(lambda side, v: (duration, e * v), 80e-3)
    _check_flight(r, expected)
    for ev, (_, v) in zip(r.impacts(), expected):
        if not math.isnan(ev.contact_duration):
            assert abs(ev.contact_duration - duration) < 1e-9
        assert ev.peak_force == pytest.approx(peak * v / V, rel=1e-9)
    releases = [ev for ev in r.events if ev.kind == "release"]
    for ev, (_, v) in zip(releases, expected):
        assert abs(ev.relative_velocity) == pytest.approx(e * v, rel=1e-9)


def test_elastogap_lash_power_law_side():
    n, kn, c = 1.5, 2.0e9, 40.0
    r = simulate(load_machine_text(_lash(f'law = "elastogap"\nexponent = {n}\nstiffness = "{kn} N/m^1.5"\n'
                                         f'damping = "{c} N*s/m"', duration="20 ms")))

    def contact(side, v):
        duration, rebound, _ = _contact(kn, c, v, n)
        return duration, rebound

    expected = _flight(contact, 20e-3)
    _check_flight(r, expected, v_tol=1e-7)


def test_elastogap_lash_refuses_a_ratio_with_another_exponent():
    from camsim.errors import MachineFileError

    for keys, key in (('damping_ratio = 0.1', "element[0].damping_ratio"), ('restitution = 0.5', "element[0].restitution")):
        with pytest.raises(MachineFileError) as info:
            load_machine_text(_lash(f'law = "elastogap"\nexponent = 1.5\nstiffness = "2e9 N/m^1.5"\n{keys}'))
        assert key in str(info.value) and "\n" not in str(info.value)


# ---------------------------------------------------------------------- a law per side
K1, K2 = 1e6, 4e6


def test_different_sides_undamped():
    r = simulate(load_machine_text(_lash(f'lower = {{ law = "linear", stiffness = "{K1} N/m" }}\n'
                                         f'upper = {{ law = "elastogap", stiffness = "{K2} N/m" }}')))

    def contact(side, v):
        return math.pi * math.sqrt(M / (K2 if side > 0 else K1)), v

    expected = _flight(contact, 30e-3)
    _check_flight(r, expected)
    for n, ev in enumerate(r.impacts()):
        k = K2 if n % 2 == 0 else K1
        if not math.isnan(ev.contact_duration):
            assert abs(ev.contact_duration - math.pi * math.sqrt(M / k)) < 1e-9
        assert ev.peak_force == pytest.approx(V * math.sqrt(k * M), rel=1e-9)
        assert ev.johnson_upper == pytest.approx(V * math.sqrt(k * M), rel=1e-9)


def test_different_sides_with_their_own_restitution():
    e1, e2 = 0.6, 0.85
    r = simulate(load_machine_text(_lash(f'lower = {{ law = "linear", stiffness = "{K1} N/m", restitution = {e1} }}\n'
                                         f'upper = {{ law = "elastogap", stiffness = "{K2} N/m", restitution = {e2} }}',
                                         duration="40 ms")))
    c2 = 2.0 * elastogap_damping_ratio(e2) * math.sqrt(K2 * M)
    duration2, rebound2, _ = _contact(K2, c2, V)  # the ElastoGap side: DOP853 reference
    assert rebound2 == pytest.approx(e2 * V, rel=1e-9)
    impacts = r.impacts()
    speeds = [ev.relative_velocity for ev in impacts]
    expected = [V]
    while len(expected) < len(speeds):
        expected.append(expected[-1] * (e2 if len(expected) % 2 == 1 else e1))
    assert len(speeds) >= 4
    assert speeds == pytest.approx(expected, rel=1e-9)
    upper = [ev for n, ev in enumerate(impacts) if n % 2 == 0 and not math.isnan(ev.contact_duration)]
    assert all(abs(ev.contact_duration - duration2) < 1e-9 for ev in upper)
    assert r.machine.element("slot").damping_note().startswith("lower linear")


def test_two_rigid_sides_with_their_own_restitution():
    e1, e2 = 0.5, 0.9
    r = simulate(load_machine_text(_lash(f'lower = {{ law = "restitution", restitution = {e1} }}\n'
                                         f'upper = {{ law = "restitution", restitution = {e2} }}')))

    def contact(side, v):
        return 0.0, v * (e2 if side > 0 else e1)

    _check_flight(r, _flight(contact, 30e-3), t_tol=1e-12, v_tol=1e-12)


def test_power_law_side_rebounds_at_its_restitution():
    e = 0.7
    r = simulate(load_machine_text(_lash('lower = { law = "power", coefficient = "1e9 N/m^1.5", exponent = 1.5, '
                                         f'restitution = {e} }}\nupper = {{ law = "linear", stiffness = "{K1} N/m" }}',
                                         duration="20 ms")))
    impacts = r.impacts()
    assert len(impacts) >= 3
    # upper (linear, undamped) returns the speed; lower (power) rebounds at e
    assert impacts[1].relative_velocity == pytest.approx(V, rel=1e-9)
    assert impacts[2].relative_velocity == pytest.approx(e * V, rel=1e-8)


# ---------------------------------------------------------------------- invariants
@pytest.mark.parametrize("keys", [
    'law = "elastogap"\nstiffness = "1e6 N/m"\nrestitution = 0.8',
    f'lower = {{ law = "linear", stiffness = "{K1} N/m", damping_ratio = 0.1 }}\n'
    f'upper = {{ law = "elastogap", stiffness = "{K2} N/m", damping = "20 N*s/m" }}',
])
def test_sample_rate_does_not_move_the_events(keys):
    fine = simulate(load_machine_text(_lash(keys, rate="200 kHz", spring=True)))
    coarse = simulate(load_machine_text(_lash(keys, rate="7 kHz", spring=True)))
    assert len(fine.events) == len(coarse.events) >= 6
    for a, b in zip(fine.events, coarse.events):
        assert a.kind == b.kind
        assert abs(a.time - b.time) < 1e-12


@pytest.mark.parametrize("keys", [
    'law = "elastogap"\nstiffness = "1e6 N/m"\nrestitution = 0.8',
    f'lower = {{ law = "linear", stiffness = "{K1} N/m", damping_ratio = 0.1 }}\n'
    f'upper = {{ law = "elastogap", stiffness = "{K2} N/m", damping = "20 N*s/m" }}',
])
def test_file_order_does_not_change_the_results(keys):
    a = simulate(load_machine_text(_lash(keys, spring=True)))
    b = simulate(load_machine_text(_lash(keys, spring=True, spring_first=True)))
    assert [e.kind for e in a.events] == [e.kind for e in b.events]
    assert max(abs(x.time - y.time) for x, y in zip(a.events, b.events)) < 1e-12
    for quantity in ("displacement", "velocity"):
        x, y = a.masses["M"][quantity], b.masses["M"][quantity]
        assert np.max(np.abs(x - y)) <= 1e-12 * np.max(np.abs(x))
    f, g = a.elements["slot"], b.elements["slot"]
    assert np.max(np.abs(f - g)) <= 1e-12 * np.max(np.abs(f))


@pytest.mark.parametrize("law", ['law = "elastogap", stiffness = "1e6 N/m", restitution = 0.8',
                                 'law = "linear", stiffness = "1e6 N/m", damping_ratio = 0.1',
                                 'law = "power", coefficient = "1e9 N/m^1.5", exponent = 1.5, restitution = 0.7'])
def test_same_law_on_both_sides_is_the_lash_of_that_law(law):
    one = simulate(load_machine_text(_lash(law.replace(", ", "\n"), spring=True)))
    two = simulate(load_machine_text(_lash(f"lower = {{ {law} }}\nupper = {{ {law} }}", spring=True)))
    assert [e.kind for e in one.events] == [e.kind for e in two.events]
    assert max(abs(x.time - y.time) for x, y in zip(one.events, two.events)) < 1e-12
    x, y = one.masses["M"]["displacement"], two.masses["M"]["displacement"]
    assert np.max(np.abs(x - y)) <= 1e-12 * np.max(np.abs(x))


def test_side_keys_are_key_paths():
    """``--set``/``--vary`` reach a side's keys: element.<name>.upper.<key> (the value as set,
    read back from the machine's description; a misspelt key is one error naming it)."""
    from camsim.errors import MachineFileError
    from camsim.machine.keys import document_paths, machine_value
    from camsim.machine.loader import machine_to_dict

    text = _lash(f'lower = {{ law = "linear", stiffness = "{K1} N/m" }}\n'
                 f'upper = {{ law = "elastogap", stiffness = "{K2} N/m" }}')
    machine = load_machine_text(text, overrides=["element.slot.upper.stiffness=5e6"])
    assert machine.element("slot").upper_law.stiffness == 5e6
    assert machine.element("slot").lower_law.stiffness == K1
    assert machine_value(machine_to_dict(machine), "element.slot.upper.stiffness") == 5e6
    import tomllib

    assert "element.slot.lower.damping_ratio" in document_paths(tomllib.loads(text))
    with pytest.raises(MachineFileError) as info:
        load_machine_text(text, overrides=["element.slot.upper.stifness=1"])
    assert "element.slot.upper.stifness" in str(info.value) and "stiffness" in str(info.value)


@pytest.mark.parametrize("keys", ['law = "elastogap"\nstiffness = "2e6 N/m"\nrestitution = {e}',
                                  'lower = {{ law = "elastogap", stiffness = "2e6 N/m", restitution = {e} }}\n'
                                  'upper = {{ law = "linear", stiffness = "1e6 N/m" }}'])
def test_restitution_uses_the_reduced_mass_of_two_free_masses(keys):
    """Two free masses meeting on the lower side: the ElastoGap mapping with the reduced mass
    m1·m2/(m1 + m2) gives exactly Newton's outcome with e (momentum conserved, the relative
    velocity reversed and scaled by e), 1e-9 relative."""
    e, m1, m2, v1, v2 = 0.6, 0.3, 0.7, 0.4, -0.2
    text = f"""
schema = 1
[machine]
name = "two masses in a lash"
[[mass]]
name = "A"
mass = "{m1} kg"
[[mass]]
name = "B"
mass = "{m2} kg"
[[element]]
name = "slot"
type = "lash"
between = ["A", "B"]
clearance = "2 mm"
{keys.format(e=e)}
[initial.A]
displacement = "0 m"
velocity = "{v1} m/s"
[initial.B]
displacement = "0 m"
velocity = "{v2} m/s"
[simulation]
duration = "4 ms"
sample_rate = "100 kHz"
"""
    r = simulate(load_machine_text(text))
    assert [ev.kind for ev in r.events] == ["impact", "release"]
    w = v1 - v2
    assert r.masses["A"]["velocity"][-1] == pytest.approx(v1 - (1 + e) * m2 / (m1 + m2) * w, rel=1e-9)
    assert r.masses["B"]["velocity"][-1] == pytest.approx(v2 + (1 + e) * m1 / (m1 + m2) * w, rel=1e-9)


def test_load_work_on_a_mass_in_an_elastogap_lash_of_another_exponent():
    """A sine load drives a mass back and forth inside an undamped ElastoGap lash with n = 1.5
    (a law without a tangent: camsim integrates it by DOP853): the load's work over the record
    equals the energy balance ½·m·(v₁² − v₀²) + U(δ₁) − U(δ₀), U = k·δ^(n+1)/(n+1) on the side
    closed at the end (conservative law), to 1e-6 of the largest kinetic energy."""
    m, n, k, c = 1.0, 1.5, 1e9, 2e-3
    text = f"""
schema = 1
[machine]
name = "load in a lash"
[[mass]]
name = "m"
mass = "{m} kg"
[[element]]
name = "slot"
type = "lash"
between = ["ground", "m"]
clearance = "{c} m"
law = "elastogap"
exponent = {n}
stiffness = "{k} N/m^1.5"
damping = "0 N*s/m"
[[load]]
name = "push"
on = "m"
sine = {{ amplitude = "50 N", frequency = "40 Hz" }}
[initial.m]
displacement = "0 m"
velocity = "-0.3 m/s"
[simulation]
duration = "60 ms"
sample_rate = "50 kHz"
"""
    r = simulate(load_machine_text(text))
    assert len(r.impacts()) >= 2
    x, v = r.masses["m"]["displacement"], r.masses["m"]["velocity"]

    def energy(xi, vi):
        delta = max(-c / 2 - xi, xi - c / 2, 0.0)
        return 0.5 * m * vi**2 + k * delta ** (n + 1) / (n + 1)

    balance = energy(x[-1], v[-1]) - energy(x[0], v[0])
    assert r.load_work["push"] == pytest.approx(balance, abs=1e-6 * 0.5 * m * float(np.max(v**2)))

"""The element registry and protocol (issue 11).

References: the spec's element list (§3: spring, preloaded, contact with laws linear,
power, restitution), its force laws at chosen points (hand-computed values), and the
machine-file reference that the same schema generates.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pytest

from camsim import elements
from camsim.elements import Branch, GuardKind, element_class
from camsim.elements.events import EventKind


def test_registered_kinds_are_the_spec_s():
    assert elements.element_types()[:3] == ("spring", "preloaded", "contact")
    assert set(elements.laws_of("contact")) >= {"linear", "power", "restitution"}
    assert element_class("contact") is elements.LinearContact  # the default law
    assert element_class("contact", "restitution") is elements.RigidContact


def test_registering_a_name_twice_is_refused():
    with pytest.raises(ValueError, match="registered twice"):
        @elements.register
        @dataclass(frozen=True)
        class Again(elements.Spring):
            pass


def test_key_laws_come_from_the_schemas():
    laws = elements.key_laws("contact")
    assert laws["stiffness"] == ("linear", "adams-impact", "elastogap")  # elastogap: issue 43
    assert set(laws["restitution"]) == {"linear", "power", "restitution", "hertz", "elastogap"}  # linear: issue 12; hertz: 39; elastogap: 43
    assert laws["gap"] == elements.laws_of("contact")


def test_forces_on_their_branches():
    """Hand-computed forces: spring f = P + k·d + c·ḋ; link separated f = P + k_pull·(d − P/k_push);
    linear contact F = k·δ + c·δ̇ clamped at zero; power F = C·δ^a."""
    d = np.array([-1e-3, 0.0, 2e-3])
    rate = np.array([0.1, 0.0, -0.1])
    spring = elements.Spring("k", "ground", "M", stiffness=1000.0, preload=5.0)
    assert np.allclose(spring.force(None, d, rate, {"c": 10.0}, None), 5.0 + 1000.0 * d + 10.0 * rate)
    link = elements.PreloadedLink("l", "A", "B", push_stiffness=1e4, pull_stiffness=1e3, preload=20.0)
    f = link.force(Branch.SEPARATED, np.array([3e-3]), np.zeros(1), {"c_push": 0.0, "c_pull": 0.0}, None)
    assert f[0] == pytest.approx(20.0 + 1e3 * (3e-3 - 2e-3), rel=1e-15)
    seat = elements.LinearContact("s", "ground", "M", gap=1e-3, stiffness=1e5)
    closed = seat.force(Branch.CLOSED, np.array([0.0, 2e-3]), np.array([0.0, 0.0]), {"c": 0.0}, None)
    assert closed.tolist() == [100.0, 0.0]  # δ = 1 mm → 100 N; δ < 0 → clamped
    power = elements.PowerContact("p", "ground", "M", coefficient=1e9, exponent=1.5)
    assert power.nonlinear_force_scalar(1e-4, 0.0, None) == pytest.approx(1e9 * 1e-6, rel=1e-14)


def test_outcomes_are_typed():
    link = elements.PreloadedLink("l", "A", "B", push_stiffness=1e4, pull_stiffness=1e3, preload=20.0)
    out = link.outcome(GuardKind.SEPARATE, -0.2)
    assert out.branch is Branch.SEPARATED and out.event is EventKind.SEPARATION and out.velocity == 0.2
    rigid = elements.RigidContact("r", "ground", "M", restitution=0.5)
    assert rigid.outcome(GuardKind.CLOSE, 0.3).rigid_impact
    power = elements.PowerContact("p", "ground", "M", coefficient=1e9, exponent=1.5, restitution=0.8)
    assert power.outcome(GuardKind.CLOSE, 0.3).v_impact == 0.3


def test_a_lifted_contact_that_pushes_again_is_no_impact():
    """Issue 34: a lifted compliant contact whose law pushes again (δ > 0, δ̇ = −k·δ/c < 0)
    closes without an event row, and keeps the approach speed of the impact that closed it
    (v_impact None: unchanged; it was reset to 1e-12 m/s, a Hunt–Crossley χ = α(e)/1e-12)."""
    seat = elements.LinearContact("s", "ground", "M", stiffness=1e5)
    power = elements.PowerContact("p", "ground", "M", coefficient=1e9, exponent=1.5, restitution=0.8)
    for contact in (seat, power):
        out = contact.outcome(GuardKind.REENGAGE, -0.018)
        assert out.branch is Branch.CLOSED and out.event is None and out.v_impact is None
    from camsim.elements.lash import LinearLash

    lash = LinearLash("y", "cam", "M", clearance=1e-4, offset=5e-5, stiffness=1e5)
    assert lash.outcome_at(GuardKind.REENGAGE, -0.018, -1e-6).branch is lash.closed_branches[0]
    assert lash.outcome_at(GuardKind.REENGAGE, 0.018, 2e-4).branch is lash.closed_branches[1]
    assert lash.outcome_at(GuardKind.REENGAGE, 0.018, 2e-4).event is None


def test_rigid_initial_penetration_is_refused():
    rigid = elements.RigidContact("r", "ground", "M", gap=0.0, restitution=0.5)
    with pytest.raises(ValueError, match="penetrates the rigid contact r"):
        rigid.branch_from_state(-1e-3, no_impact=False)
    assert rigid.branch_from_state(0.0, no_impact=False) is Branch.STUCK


# --------------------------------------------------------------------------- scalar_force
# scalar_force(v_impact) binds a nonlinear law's constants for the DOP853 hot path. It
# must return what nonlinear_force_scalar returns bit for bit (==), and the vectorised
# nonlinear_force to 1e-15 relative (numpy's pow may round differently by an ulp). The
# reference for the values themselves is each law as documented, written out here:
# power F = C·δ^a·(1 + χ·δ̇), χ = α(e)/v (or hysteresis_damping), clamped at 0; Adams
# IMPACT F = k·δ^n + c_max·u²(3 − 2u)·δ̇ (u = min(δ/d, 1)), clamped with clamp = true; 0
# for δ ≤ 0. Tolerance 1e-14 of the terms' magnitude (the same operations, maybe in
# another order).

#: δ [m]: separated, touching, then 1e-9 .. 1e-4 (through Adams's d = 50 µm); δ̇ [m/s].
GRID_DELTA = [-1e-4, -1e-9, -0.0, 0.0, 1e-9, 1e-8, 1e-7, 1e-6, 3e-6, 1e-5, 3e-5, 5e-5, 7e-5, 1e-4]
GRID_RATE = [-1.0, -0.7, -0.3, -0.05, -0.0, 0.0, 0.05, 0.3, 0.7, 1.0]
C_P, A_P, E_P, V_P = 4.0e9, 1.425, 0.8, 0.3  # power law: N/m^a, -, -, m/s
K_A, N_A, CMAX_A, D_A = 1.0e8, 1.5, 200.0, 5.0e-5  # Adams IMPACT: N/m^n, -, N·s/m, m

LASH_TOML = f"""
schema = 1
[machine]
name = "lashes"
[[mass]]
name = "M"
mass = "0.5 kg"
[[element]]
name = "power_slot"
type = "lash"
between = ["ground", "M"]
clearance = "1 mm"
law = "power"
exponent = {A_P}
coefficient = "{C_P} N/m**{A_P}"
restitution = {E_P}
[[element]]
name = "adams_slot"
type = "lash"
between = ["ground", "M"]
clearance = "1 mm"
law = "adams-impact"
exponent = {N_A}
stiffness = "{K_A} N/m**{N_A}"
max_damping = "{CMAX_A} N*s/m"
penetration_depth = "{D_A} m"
[initial.M]
displacement = "0 m"
velocity = "0 m/s"
[simulation]
duration = "1 ms"
warmup_cycles = 0
sample_rate = "100 kHz"
"""


def _power_law(chi):
    def law(delta, rate):
        if delta <= 0.0:
            return 0.0, 0.0
        elastic = C_P * delta**A_P
        return max(elastic * (1.0 + chi * rate), 0.0), elastic * (1.0 + abs(chi * rate))
    return law


def _adams_law(clamp):
    def law(delta, rate):
        if delta <= 0.0:
            return 0.0, 0.0
        u = min(delta / D_A, 1.0)
        elastic, damping = K_A * delta**N_A, CMAX_A * u * u * (3.0 - 2.0 * u) * rate
        force = elastic + damping
        return (max(force, 0.0) if clamp else force), abs(elastic) + abs(damping)
    return law


def _nonlinear_elements():
    """(label, element, v_impact, documented law (δ, δ̇) → (F, scale of its terms))."""
    from camsim.machine.loader import load_machine_text
    from camsim.physics.restitution import hc_alpha

    chi_e = hc_alpha(E_P, "exact") / V_P
    lashes = {e.name: e for e in load_machine_text(LASH_TOML).elements}
    restituted = elements.PowerContact("p", "ground", "M", coefficient=C_P, exponent=A_P, restitution=E_P)
    return [
        ("power restitution", restituted, V_P, _power_law(chi_e)),
        ("power restitution, closed from the start", restituted, None, _power_law(0.0)),
        ("power hysteresis_damping", elements.PowerContact("p", "ground", "M", coefficient=C_P, exponent=A_P,
                                                           hysteresis_damping=1.5), V_P, _power_law(1.5)),
        ("power undamped", elements.PowerContact("p", "ground", "M", coefficient=C_P, exponent=A_P), V_P,
         _power_law(0.0)),
        # a contact's law is unclamped: its clamp is a branch of its own (issue 34; the force it
        # reports is clamped, test_adams_contact_reports_its_clamped_force); so is a lash's,
        # whose sides have the contact's branches (clamped, clamped-high)
        ("adams clamp", elements.AdamsImpactContact("a", "ground", "M", stiffness=K_A, exponent=N_A,
                                                    max_damping=CMAX_A, penetration_depth=D_A), V_P, _adams_law(False)),
        ("adams no clamp", elements.AdamsImpactContact("a", "ground", "M", stiffness=K_A, exponent=N_A,
                                                       max_damping=CMAX_A, penetration_depth=D_A, clamp=False), V_P,
         _adams_law(False)),
        ("power lash", lashes["power_slot"], V_P, _power_law(chi_e)),
        ("adams lash", lashes["adams_slot"], V_P, _adams_law(False)),
    ]


SCALAR_CASES = ["power-restitution", "power-not-yet-impacted", "power-hysteresis", "power-undamped", "adams-clamp",
                "adams-no-clamp", "power-lash", "adams-lash"]


@pytest.mark.parametrize("case", range(len(SCALAR_CASES)), ids=SCALAR_CASES)
def test_scalar_force_is_the_scalar_and_vector_law(case):
    """scalar_force(v) == nonlinear_force_scalar bit for bit; nonlinear_force to 1e-15
    relative; the documented law to 1e-14 of its terms (see above)."""
    label, element, v_impact, law = _nonlinear_elements()[case]
    force = element.scalar_force(v_impact)
    deltas, rates = np.meshgrid(GRID_DELTA, GRID_RATE, indexing="ij")
    bound = np.array([[force(d, r) for r in GRID_RATE] for d in GRID_DELTA])
    scalar = np.array([[element.nonlinear_force_scalar(d, r, v_impact) for r in GRID_RATE] for d in GRID_DELTA])
    assert bound.tobytes() == scalar.tobytes(), label  # bit for bit (the sign of a zero too)
    vector = element.nonlinear_force(deltas, rates, v_impact)
    np.testing.assert_allclose(bound, vector, rtol=1e-15, atol=0, err_msg=label)
    for (i, j), value in np.ndenumerate(bound):
        ref, scale = law(GRID_DELTA[i], GRID_RATE[j])
        assert abs(value - ref) <= 1e-14 * scale, (label, GRID_DELTA[i], GRID_RATE[j], value, ref)
    # the grid reaches every branch of the law: zero, positive, and (unclamped) negative
    assert (bound == 0.0).any() and (bound > 0.0).any(), label
    if label in ("adams no clamp", "adams clamp", "adams lash"):
        assert (bound < 0.0).any()
    # damped and clamped: the damping term cancels the force at some δ > 0, δ̇ < 0
    clamps = label in ("power restitution", "power hysteresis_damping", "power lash")
    assert ((bound == 0.0) & (deltas > 0.0)).any() == clamps, label


def test_power_scalar_force_by_hand():
    """One value by hand: F = C·δ^a·(1 + χ·δ̇), χ = α_exact(0.8)/0.3 m/s, to 1e-14."""
    from camsim.physics.restitution import hc_alpha

    contact = elements.PowerContact("p", "ground", "M", coefficient=4.0e9, exponent=1.425, restitution=0.8)
    chi = hc_alpha(0.8, "exact") / 0.3
    expected = 4.0e9 * (2.5e-5) ** 1.425 * (1.0 + chi * -0.4)
    assert expected > 0.0
    assert contact.scalar_force(0.3)(2.5e-5, -0.4) == pytest.approx(expected, rel=1e-14)


def test_adams_contact_reports_its_clamped_force():
    """An Adams IMPACT contact with ``clamp`` reports max(0, law) on its closed branches, 0 on
    its clamped branch (the law there is watched, not acting); without ``clamp`` the law."""
    from camsim.elements.base import Branch

    clamped = elements.AdamsImpactContact("a", "ground", "M", stiffness=K_A, exponent=N_A, max_damping=CMAX_A,
                                          penetration_depth=D_A)
    free = elements.AdamsImpactContact("a", "ground", "M", stiffness=K_A, exponent=N_A, max_damping=CMAX_A,
                                       penetration_depth=D_A, clamp=False)
    deltas, rates = np.meshgrid(GRID_DELTA, GRID_RATE, indexing="ij")
    d, d_rate = clamped.gap - deltas.ravel(), -rates.ravel()  # d = gap − δ, ḋ = −δ̇
    law = np.array([_adams_law(False)(a, b)[0] for a, b in zip(deltas.ravel(), rates.ravel())])
    for branch in (Branch.CLOSED, Branch.CLOSED_DEEP):
        np.testing.assert_allclose(clamped.force(branch, d, d_rate, {}, None), np.maximum(law, 0.0), rtol=1e-14, atol=1e-300)
        np.testing.assert_allclose(free.force(branch, d, d_rate, {}, None), law, rtol=1e-14, atol=1e-300)
    assert not np.any(clamped.force(Branch.CLAMPED, d, d_rate, {}, None))
    assert clamped.acts(Branch.CLOSED) and not clamped.acts(Branch.CLAMPED)

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
from camsim.events import EventKind


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
    assert laws["stiffness"] == ("linear", "adams-impact")
    assert set(laws["restitution"]) == {"linear", "power", "restitution"}  # linear: issue 12
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


def test_rigid_initial_penetration_is_refused():
    rigid = elements.RigidContact("r", "ground", "M", gap=0.0, restitution=0.5)
    with pytest.raises(ValueError, match="penetrates the rigid contact r"):
        rigid.branch_from_state(-1e-3, no_impact=False)
    assert rigid.branch_from_state(0.0, no_impact=False) is Branch.STUCK

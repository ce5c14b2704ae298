"""``law = "restitution"``: a rigid stop with Newton's impact law (spec §3).

At impact the relative velocity reverses and shrinks by e (momentum of the two bodies
conserved). While the bodies rest against each other (e = 0, or a chatter sequence that
would not end) the contact is persistent — ``stick`` — and carries whatever compressive
force keeps them together, a constraint of the model; it opens (``release``) when that
force reaches zero. The classic cam-jump model (Barkan; Dresner and Barkan used e = 0).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

from camsim.elements.affine import Affine
from camsim.elements.base import FORCE_TOL, LENGTH_TOL, Branch, GuardKind, Outcome, Param, register
from camsim.elements.contact import CONTACT_PARAMS, Contact
from camsim.elements.events import EventKind


@register
@dataclass(frozen=True)
class RigidContact(Contact):
    """Rigid contact with coefficient of restitution ``restitution`` e ∈ [0, 1]."""

    law_name: ClassVar[str] = "restitution"
    summary: ClassVar[str] = "rigid stop, Newton's impact law with restitution e; sticks when at rest"
    params: ClassVar[tuple[Param, ...]] = (
        *CONTACT_PARAMS,
        Param("restitution", "number", "e of Newton's impact law", required=True, minimum=0.0, maximum=1.0),
    )
    closed_branch: ClassVar[Branch] = Branch.STUCK

    def branches(self, no_impact):
        return (Branch.BILATERAL,) if no_impact else (Branch.OPEN, Branch.STUCK)

    def is_constraint(self, branch):
        return branch in (Branch.STUCK, Branch.BILATERAL)

    def guards(self, branch, ctx):
        if branch == Branch.STUCK:
            lam = ctx.constraint_force()
            return [(GuardKind.RELEASE, Affine(lam.Cz, lam.Du, lam.Fn, lam.e + FORCE_TOL), FORCE_TOL)]
        if branch == Branch.OPEN:
            delta, _ = ctx.penetration()
            return [self._approach_guard(delta)]
        return []

    def closing(self, rate):
        return Outcome(None, EventKind.IMPACT, rate, rigid_impact=True)

    def rest_open(self, branch, delta, constraint_force):
        return Branch.OPEN if constraint_force() < -FORCE_TOL else branch

    def branch_from_state(self, d, no_impact):
        if no_impact:
            return Branch.BILATERAL
        delta = self.gap - d
        if delta > LENGTH_TOL:
            raise ValueError(f"the initial state penetrates the rigid contact {self.name} by {delta:.3g} m")
        return Branch.STUCK if abs(delta) <= LENGTH_TOL else Branch.OPEN

    def johnson_bounds(self, m1, m2, v):
        inf = float("inf")
        return inf, inf  # a rigid stop: an impulse, no finite peak

    def impact_force(self, force):
        return None

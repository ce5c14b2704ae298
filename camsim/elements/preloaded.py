"""``type = "preloaded"``: the over-travel link, two parts held together by a preloaded spring.

Joined (d ≤ d_sep = P/k_push): f = k_push·d + c_push·ḋ. Separated: f = P + k_pull·(d − d_sep)
+ c_pull·ḋ. The force-deflection curve is continuous; crossing d_sep is an event
(``separation`` going up, ``rejoin`` — an impact — coming back). Spec §3.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

from camsim.elements.affine import Affine
from camsim.elements.base import (DAMPING_PARAMS, LENGTH_TOL, QUADRATIC_DAMPING, Branch, Element, GuardKind, Outcome,
                                   Param, pair_mass, register)
from camsim.elements.events import EventKind
from camsim.elements.quadratic import QuadraticDamping


@register
@dataclass(frozen=True)
class PreloadedLink(QuadraticDamping, Element):
    """Over-travel link: ``push_stiffness``, ``pull_stiffness`` [N/m], ``preload`` P [N] > 0,
    ``quadratic_damping`` c_q [N·s²/m²] on both branches."""

    push_stiffness: float = 0.0
    pull_stiffness: float = 0.0
    preload: float = 0.0
    quadratic_damping: float = 0.0

    type_name: ClassVar[str] = "preloaded"
    summary: ClassVar[str] = "over-travel link: joined f = k_push·d, separated f = P + k_pull·(d − P/k_push)"
    closing_ends: ClassVar[EventKind] = EventKind.SEPARATION
    params: ClassVar[tuple[Param, ...]] = (
        Param("push_stiffness", "stiffness", "k_push of the joined branch", required=True, minimum=0.0, strict=True,
              example='"8144 lbf/in"'),
        Param("pull_stiffness", "stiffness", "k_pull of the separated branch", required=True, minimum=0.0, strict=True,
              example='"219 lbf/in"'),
        Param("preload", "force", "P, the tension at which the parts separate", required=True, minimum=0.0, strict=True,
              example='"28.12 lbf"'),
        *DAMPING_PARAMS,
        QUADRATIC_DAMPING,
    )

    @property
    def separation_deflection(self) -> float:
        """d_sep = P / k_push [m]."""
        return self.preload / self.push_stiffness

    def describe(self) -> dict:
        return {**super().describe(), "separation_deflection": self.separation_deflection}

    def branches(self, no_impact: bool) -> tuple[Branch, ...]:
        return (Branch.JOINED,) if no_impact else (Branch.JOINED, Branch.SEPARATED)

    def branch_stiffnesses(self) -> dict[str, float]:
        return {"c_push": self.push_stiffness, "c_pull": self.pull_stiffness}

    def linear_law(self, branch, damping):
        if branch == Branch.SEPARATED:
            k = self.pull_stiffness
            return k, damping["c_pull"], self.preload - k * self.separation_deflection
        return self.push_stiffness, damping["c_push"], 0.0

    def force(self, branch, d, d_rate, damping, v_impact):
        return super().force(branch, d, d_rate, damping, v_impact) + self.quadratic_force(d_rate)

    def guards(self, branch, ctx):
        d, _ = ctx.deflection()
        dsep = self.separation_deflection
        if branch == Branch.JOINED:
            return [(GuardKind.SEPARATE, Affine(-d.Cz, -d.Du, -d.Fn, dsep - d.e), LENGTH_TOL)]
        if branch == Branch.SEPARATED:
            return [(GuardKind.REJOIN, Affine(d.Cz, d.Du, d.Fn, d.e - dsep), LENGTH_TOL)]
        return []

    def outcome(self, kind, rate):
        if kind == GuardKind.SEPARATE:
            return Outcome(Branch.SEPARATED, EventKind.SEPARATION, -rate)
        return Outcome(Branch.JOINED, EventKind.REJOIN, rate)

    def branch_at_rest(self, branch, d, constraint_force):
        return Branch.SEPARATED if d > self.separation_deflection + LENGTH_TOL else Branch.JOINED

    def branch_from_state(self, d, no_impact):
        return Branch.SEPARATED if d > self.separation_deflection and not no_impact else Branch.JOINED

    def johnson_bounds(self, m1, m2, v):
        from camsim.physics.impact import johnson_linear

        return johnson_linear(m1, m2, v, 0.0, self.push_stiffness)

    def impact_duration(self, m1, m2, v):
        from camsim.physics.duration import linear_contact_duration

        return linear_contact_duration(self.push_stiffness, pair_mass(m1, m2))

    def impact_force(self, force):
        return self.preload - force  # compression at the interface of the two parts

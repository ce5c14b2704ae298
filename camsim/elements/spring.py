"""``type = "spring"``: a spring-damper, f = P + k·d + c·ḋ (spec §3), with quadratic damping c_q·ḋ·|ḋ| (§10)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

from camsim.elements.base import DAMPING_PARAMS, QUADRATIC_DAMPING, Branch, Element, Param, register
from camsim.elements.quadratic import QuadraticDamping


@register
@dataclass(frozen=True)
class Spring(QuadraticDamping, Element):
    """Spring: f = P + k·d + c·ḋ (+ c_q·ḋ·|ḋ|). ``stiffness`` k [N/m], ``preload`` P [N],
    ``quadratic_damping`` c_q [N·s²/m²]."""

    stiffness: float = 0.0
    preload: float = 0.0
    quadratic_damping: float = 0.0

    type_name: ClassVar[str] = "spring"
    summary: ClassVar[str] = "linear spring-damper, f = P + k·d + c·ḋ (tension-positive)"
    params: ClassVar[tuple[Param, ...]] = (
        Param("stiffness", "stiffness", "k; 0 only with a positive `damping` (a pure damper)", required=True, minimum=0.0, example='"9051 lbf/in"'),
        Param("preload", "force", "P, the tension at zero deflection; a spring that pulls the upper mass toward "
              "the lower node (e.g. a closure spring holding a follower on the cam) has a positive preload",
              default=0.0),
        *DAMPING_PARAMS,
        QUADRATIC_DAMPING,
    )

    @classmethod
    def check(cls, values, error, driven) -> None:
        damping = values["damping"]
        if (values["stiffness"] == 0.0 and not (damping.coefficient or 0.0) > 0.0
                and not values.get("quadratic_damping", 0.0) > 0.0):
            raise error("stiffness", "a spring with zero stiffness needs a positive damping coefficient "
                        "(damping = ... or quadratic_damping = ...), else it does nothing")
        if damping.ratio is not None and values["stiffness"] == 0.0:
            raise error("damping_ratio", "a damping ratio needs stiffness > 0; give damping (a coefficient) instead")

    def branch_stiffnesses(self) -> dict[str, float]:
        return {"c": self.stiffness}

    def linear_law(self, branch: Branch | None, damping: dict[str, float]) -> tuple[float, float, float]:
        return self.stiffness, damping["c"], self.preload

    def force(self, branch, d, d_rate, damping, v_impact):
        return super().force(branch, d, d_rate, damping, v_impact) + self.quadratic_force(d_rate)

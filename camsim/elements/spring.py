"""``type = "spring"``: a linear spring-damper, f = P + k·d + c·ḋ (spec §3)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

from camsim.elements.base import DAMPING_PARAMS, Branch, Element, Param, register


@register
@dataclass(frozen=True)
class Spring(Element):
    """Linear spring: f = P + k·d + c·ḋ. ``stiffness`` k [N/m], ``preload`` P [N]."""

    stiffness: float = 0.0
    preload: float = 0.0

    type_name: ClassVar[str] = "spring"
    summary: ClassVar[str] = "linear spring-damper, f = P + k·d + c·ḋ (tension-positive)"
    params: ClassVar[tuple[Param, ...]] = (
        Param("stiffness", "stiffness", "k; 0 only with a positive `damping` (a pure damper)", required=True, minimum=0.0, example='"9051 lbf/in"'),
        Param("preload", "force", "P, the tension at zero deflection; a spring that pulls the upper mass toward "
              "the lower node (e.g. a closure spring holding a follower on the cam) has a positive preload",
              default=0.0),
        *DAMPING_PARAMS,
    )

    @classmethod
    def check(cls, values, error, driven) -> None:
        damping = values["damping"]
        if values["stiffness"] == 0.0 and not (damping.coefficient or 0.0) > 0.0:
            raise error("stiffness", "a spring with zero stiffness needs a positive damping coefficient "
                        "(damping = ...), else it does nothing")
        if damping.ratio is not None and values["stiffness"] == 0.0:
            raise error("damping_ratio", "a damping ratio needs stiffness > 0; give damping (a coefficient) instead")

    def branch_stiffnesses(self) -> dict[str, float]:
        return {"c": self.stiffness}

    def linear_law(self, branch: Branch | None, damping: dict[str, float]) -> tuple[float, float, float]:
        return self.stiffness, damping["c"], self.preload

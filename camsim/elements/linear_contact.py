"""``law = "linear"`` (the default): F = max(0, k·δ + c·δ̇) while δ > 0 (spec §3).

A damped linear contact can pull at separation; it opens when its force reaches zero,
not when δ does (see docs/model.md), and while it penetrates with a pulling law it is
"lifted": open until the law pushes again or δ returns to zero.

Its damping is a coefficient, a ratio ζ of critical, or a ``restitution`` e: the viscous
c = 2ζ(e)·√(k·m) for which an isolated impact of the contact's reduced mass m, with the
force clamped at zero, rebounds with exactly e (:func:`camsim.physics.restitution.linear_damping_ratio`,
solved once at load).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from camsim.elements.affine import N_INPUT, Affine
from camsim.elements.base import DAMPING_PARAMS, DEFAULT_LAW, FORCE_TOL, Branch, GuardKind, Param, pair_mass, register
from camsim.elements.contact import CONTACT_PARAMS, Contact
from camsim.physics.restitution import linear_damping_ratio


@register
@dataclass(frozen=True)
class LinearContact(Contact):
    """Linear spring-damper contact: ``stiffness`` k [N/m], damping as for a spring."""

    stiffness: float = 0.0

    law_name: ClassVar[str] = "linear"
    summary: ClassVar[str] = "compliant contact F = k·δ + c·δ̇ (clamped at zero)"
    params: ClassVar[tuple[Param, ...]] = (
        *CONTACT_PARAMS,
        Param("stiffness", "stiffness", "k", required=True, minimum=0.0, strict=True, example='"8597740 N/m"'),
        *DAMPING_PARAMS,
        Param("restitution", "number", "instead of damping/damping_ratio: the restitution an isolated impact "
              "achieves (c = 2ζ(e)·√(k·m), m the contact's reduced mass)", minimum=0.0, maximum=1.0, strict=True),
    )

    @classmethod
    def check(cls, values, error, driven) -> None:
        super().check(values, error, driven)
        damping = values.get("damping")
        if values.get("restitution") is not None and damping is not None and (
            damping.coefficient is not None or damping.ratio is not None
        ):
            raise error("restitution", "give restitution or damping/damping_ratio, not both")

    def damping_coefficients(self, reference_mass, reduced_mass=None):
        if self.restitution is None:
            return super().damping_coefficients(reference_mass, reduced_mass)
        zeta = linear_damping_ratio(self.restitution)
        return {"c": 2.0 * zeta * (self.stiffness * reduced_mass()) ** 0.5}

    def damping_note(self):
        return f"restitution {self.restitution:g}" if self.restitution is not None else None

    def branch_stiffnesses(self) -> dict[str, float]:
        return {"c": self.stiffness}

    def linear_law(self, branch, damping):
        if branch in (Branch.CLOSED, Branch.BILATERAL):
            # Compressive F = k·δ + c·δ̇ with δ = g0 − d  →  tension f = −F.
            k = self.stiffness
            return k, damping["c"], -k * self.gap
        return None

    def force(self, branch, d, d_rate, damping, v_impact):
        if branch not in (Branch.CLOSED, Branch.BILATERAL):
            return np.zeros_like(d)
        force = self.stiffness * (self.gap - d) - damping["c"] * d_rate
        return force if branch == Branch.BILATERAL else np.maximum(force, 0.0)

    def _law_affine(self, ctx, sign: float) -> Affine:
        delta, rate = ctx.penetration()
        k, c = sign * self.stiffness, sign * ctx.damping["c"]
        return Affine.combine([(np.array([[k]]), delta), (np.array([[c]]), rate)], np.zeros(1), np.zeros((1, N_INPUT)))

    def closed_guards(self, branch, ctx):
        return [(GuardKind.RELEASE, self._law_affine(ctx, 1.0), FORCE_TOL)]

    def lifted_guards(self, ctx):
        return [(GuardKind.REENGAGE, self._law_affine(ctx, -1.0), FORCE_TOL)]

    def johnson_bounds(self, m1, m2, v):
        from camsim.physics.impact import johnson_linear

        return johnson_linear(m1, m2, v, 0.0, self.stiffness)

    def impact_duration(self, m1, m2, v):
        from camsim.physics.duration import linear_contact_duration

        return linear_contact_duration(self.stiffness, pair_mass(m1, m2))


DEFAULT_LAW["contact"] = LinearContact.law_name

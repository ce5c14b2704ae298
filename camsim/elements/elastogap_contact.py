"""``law = "elastogap"``: the gap law of Modelica's ElastoGap (spec §10).

    F = k·δⁿ + clip(c·δ̇, −k·δⁿ, +k·δⁿ)   while δ > 0

(Modelica.Mechanics.Translational.Components.ElastoGap, n = 1 by default): a compliant
contact whose damping force never exceeds its spring force. At touch-down (δ = 0) the
force is 0 — continuous, no jump to c·v as a plain linear contact has — and it never pulls.
The two clip bounds are kinks of the law, located like events (no rows of the event table)
as Adams's are; between them the law is one of three pieces, each a branch:

- ``closed-deep`` (c·δ̇ ≥ k·δⁿ, the approach): F = 2·k·δⁿ;
- ``closed`` (|c·δ̇| < k·δⁿ): F = k·δⁿ + c·δ̇;
- ``clamped`` (c·δ̇ ≤ −k·δⁿ, the rebound's end): F = 0, the bodies move apart freely until
  δ returns to 0 (``release``) or the law pushes again.

With n = 1 every piece is linear: the contact is exact like the rest of the engine. With
n ≠ 1 the closed contact is one nonlinear force F_nl (the clipped law itself), integrated
to the engine's tolerance (DOP853, :mod:`camsim.engine.rk`), its kinks stepped across;
its damping is then a coefficient (``damping``).

``damping``, ``damping_ratio`` or ``restitution`` set c; a restitution e is the c for which
an isolated impact of the contact's reduced mass rebounds with exactly e (n = 1:
:func:`camsim.physics.restitution.elastogap_damping_ratio`, solved once at load).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from camsim.elements.affine import Affine
from camsim.elements.base import DAMPING_PARAMS, FORCE_TOL, LENGTH_TOL, Branch, GuardKind, Outcome, Param, pair_mass, register
from camsim.elements.contact import CONTACT_PARAMS, Contact
from camsim.elements.events import EventKind

#: The branches of a closed phase: the approach's clip, the law, the rebound's clip.
_CLOSED = (Branch.CLOSED_DEEP, Branch.CLOSED, Branch.CLAMPED)


@register
@dataclass(frozen=True)
class ElastoGapContact(Contact):
    """ElastoGap contact: ``stiffness`` k [N/m^n], ``exponent`` n, damping c (see module docstring)."""

    stiffness: float = 0.0
    exponent: float = 1.0

    law_name: ClassVar[str] = "elastogap"
    summary: ClassVar[str] = "Modelica's ElastoGap: F = k·δⁿ + clip(c·δ̇, −k·δⁿ, k·δⁿ), no jump at touch-down, never pulls"
    params: ClassVar[tuple[Param, ...]] = (
        *CONTACT_PARAMS,
        Param("exponent", "number", "n of k·δⁿ (1: linear and exact)", default=1.0, minimum=0.0, strict=True),
        Param("stiffness", "power_coefficient", "k of k·δⁿ (N/m for n = 1)", required=True, minimum=0.0, strict=True,
              example='"8597740 N/m"'),
        *DAMPING_PARAMS,
        Param("restitution", "number", "instead of damping/damping_ratio: the restitution an isolated impact "
              "achieves (n = 1)", minimum=0.0, maximum=1.0, strict=True),
    )

    @classmethod
    def check(cls, values, error, driven) -> None:
        super().check(values, error, driven)
        damping = values.get("damping")
        if values.get("restitution") is not None:
            if damping is not None and (damping.coefficient is not None or damping.ratio is not None):
                raise error("restitution", "give restitution or damping/damping_ratio, not both")
            if values.get("exponent", 1.0) != 1.0:
                raise error("restitution", "the restitution mapping of the elastogap law is for exponent = 1; "
                            "give damping (a coefficient) with another exponent")
        if damping is not None and damping.ratio is not None and values.get("exponent", 1.0) != 1.0:
            raise error("damping_ratio", "a damping ratio needs exponent = 1 (a stiffness in N/m); give damping")

    @property
    def linear(self) -> bool:
        return self.exponent == 1.0

    def damping_coefficients(self, reference_mass, reduced_mass=None):
        if self.restitution is None:
            return super().damping_coefficients(reference_mass, reduced_mass)
        from camsim.physics.restitution import elastogap_damping_ratio

        zeta = elastogap_damping_ratio(self.restitution)
        return {"c": 2.0 * zeta * (self.stiffness * reduced_mass()) ** 0.5}

    def damping_note(self):
        return f"restitution {self.restitution:g}" if self.restitution is not None else None

    def branch_stiffnesses(self) -> dict[str, float]:
        return {"c": self.stiffness}

    def branches(self, no_impact):
        if no_impact:
            return (Branch.BILATERAL,)
        return (Branch.OPEN, *_CLOSED) if self.linear else (Branch.OPEN, Branch.CLOSED)

    closed_branch: ClassVar[Branch] = Branch.CLOSED

    # ------------------------------------------------------------------ the law
    def is_nonlinear(self, branch):
        return not self.linear and branch == Branch.CLOSED

    def linear_law(self, branch, damping):
        if not self.linear:
            return None
        k, g = self.stiffness, self.gap
        if branch in (Branch.CLOSED, Branch.BILATERAL):  # F = k·δ + c·δ̇, tension f = −F
            return k, damping["c"], -k * g
        if branch == Branch.CLOSED_DEEP:  # F = 2·k·δ
            return 2.0 * k, 0.0, -2.0 * k * g
        return None

    def _pieces(self, delta, delta_rate, c):
        """(elastic k·δⁿ, damping c·δ̇) on samples."""
        pen = np.maximum(np.asarray(delta, dtype=float), 0.0)
        return self.stiffness * pen**self.exponent, c * np.asarray(delta_rate, dtype=float)

    def force(self, branch, d, d_rate, damping, v_impact):
        if branch == Branch.BILATERAL:
            return self.stiffness * (self.gap - d) - damping["c"] * d_rate
        if branch not in _CLOSED:
            return np.zeros_like(d)
        elastic, viscous = self._pieces(self.gap - d, -d_rate, damping["c"])
        return np.where(np.asarray(self.gap - d) > 0.0, elastic + np.clip(viscous, -elastic, elastic), 0.0)

    # n ≠ 1: the closed contact's force is F_nl, the clipped law (c: the damping coefficient)
    def nonlinear_force(self, delta, delta_rate, v_impact=None):
        elastic, viscous = self._pieces(delta, delta_rate, self.damping.coefficient or 0.0)
        return np.where(np.asarray(delta) > 0.0, elastic + np.clip(viscous, -elastic, elastic), 0.0)

    def nonlinear_force_scalar(self, delta: float, delta_rate: float, v_impact=None) -> float:
        if delta <= 0.0:
            return 0.0
        elastic = self.stiffness * delta**self.exponent
        return elastic + min(max((self.damping.coefficient or 0.0) * delta_rate, -elastic), elastic)

    # ------------------------------------------------------------------ guards
    def _affines(self, ctx):
        """(k·δ, c·δ̇) as affine maps (n = 1)."""
        delta, rate = ctx.penetration()
        k, c = self.stiffness, ctx.damping["c"]
        return (Affine(k * delta.Cz, k * delta.Du, k * delta.Fn, k * delta.e),
                Affine(c * rate.Cz, c * rate.Du, c * rate.Fn, c * rate.e))

    def closed_guards(self, branch, ctx):
        delta, _ = ctx.penetration()
        out = [(GuardKind.RELEASE, delta, LENGTH_TOL)]
        if not self.linear:
            return out
        el, vi = self._affines(ctx)
        high = Affine.combine([(np.eye(1), vi), (-np.eye(1), el)], np.zeros(1))  # c·δ̇ − k·δ
        low = Affine.combine([(np.eye(1), el), (np.eye(1), vi)], np.zeros(1))  # k·δ + c·δ̇
        if branch == Branch.CLOSED_DEEP:
            return out + [(GuardKind.KINK_DOWN, high, FORCE_TOL)]
        if branch == Branch.CLOSED:
            return out + [(GuardKind.KINK_UP, _neg(high), FORCE_TOL), (GuardKind.CLAMP, low, FORCE_TOL)]
        return out + [(GuardKind.UNCLAMP, _neg(low), FORCE_TOL)]  # clamped

    def outcome_at(self, kind, rate, d):
        if kind == GuardKind.KINK_UP:
            return Outcome(Branch.CLOSED_DEEP)
        if kind in (GuardKind.KINK_DOWN, GuardKind.UNCLAMP):
            return Outcome(Branch.CLOSED)
        if kind == GuardKind.CLAMP:
            return Outcome(Branch.CLAMPED)
        return self.outcome(kind, rate)

    def closing(self, rate: float) -> Outcome:
        # at touch-down c·δ̇ = c·v > k·δ = 0: the approach's clip, F = 2kδ = 0 (continuous)
        return Outcome(Branch.CLOSED_DEEP if self.linear else Branch.CLOSED, EventKind.IMPACT, rate)

    def branch_at_rest(self, branch, d, constraint_force):
        new = super().branch_at_rest(branch, d, constraint_force)
        return Branch.CLOSED if new in _CLOSED else new

    def rest_open(self, branch, delta, constraint_force):
        return Branch.OPEN if delta <= 0 else branch

    def branch_from_state(self, d, no_impact):
        branch = super().branch_from_state(d, no_impact)
        return Branch.CLOSED if branch in _CLOSED else branch

    # ------------------------------------------------------------------ impacts
    def johnson_bounds(self, m1, m2, v):
        if self.linear:
            from camsim.physics.impact import johnson_linear

            return johnson_linear(m1, m2, v, 0.0, self.stiffness)
        from camsim.physics.impact import johnson_power

        return johnson_power(m1, m2, v, 0.0, self.stiffness, self.exponent)

    def impact_duration(self, m1, m2, v):
        if self.linear:
            from camsim.physics.duration import linear_contact_duration

            return linear_contact_duration(self.stiffness, pair_mass(m1, m2))
        from camsim.physics.duration import power_contact_duration

        return power_contact_duration(self.stiffness, self.exponent, pair_mass(m1, m2), v)


def _neg(a: Affine) -> Affine:
    return Affine(-a.Cz, -a.Du, -a.Fn, -a.e)

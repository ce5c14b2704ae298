"""``law = "power"``: F = C·δ^a, optionally Hunt–Crossley damped, F = C·δ^a·(1 + χ·δ̇) (spec §3).

The thesis's common-velocity contact (eq. 3.30; C and a from a log-log fit). While closed
its force is nonlinear: the integrator carries it as F_nl (:mod:`camsim.engine.nonlinear`).

Damping: with ``restitution`` e, χ = α(e)/v with v the approach speed of the impact that
closed the contact and α from ``damping_model`` (:mod:`camsim.physics.restitution`): ``"exact"``
(default; an isolated impact then rebounds with exactly e), ``"lankarani-nikravesh"``
(α = 3(1 − e²)/4) or ``"flores"`` (α = 8(1 − e)/(5e)). A contact closed from the start has
no damping until its first impact. Or ``hysteresis_damping`` χ [s/m] directly (no
mapping, damped from the start).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from camsim.elements.affine import Affine
from camsim.elements.base import FACTOR_TOL, LENGTH_TOL, Branch, GuardKind, Outcome, Param, pair_mass, register
from camsim.elements.contact import CONTACT_PARAMS, Contact
from camsim.elements.events import EventKind
from camsim.physics.restitution import DAMPING_MODELS, hc_alpha


@register
@dataclass(frozen=True)
class PowerContact(Contact):
    """Power-law contact: ``coefficient`` C [N/m^a], ``exponent`` a > 0, ``restitution`` e."""

    coefficient: float = 0.0
    exponent: float = 1.0
    damping_model: str = "exact"
    hysteresis_damping: float | None = None

    law_name: ClassVar[str] = "power"
    summary: ClassVar[str] = "compliant contact F = C·δ^a, Hunt–Crossley damped with restitution"
    #: The closed force is analytic in (δ, δ̇) for δ > 0 (no kink inside a closed phase):
    #: camsim.engine.collocation may carry it with polynomial node values.
    analytic_closed: ClassVar[bool] = True
    params: ClassVar[tuple[Param, ...]] = (
        *CONTACT_PARAMS,
        Param("exponent", "number", "a", required=True, minimum=0.0, strict=True),
        Param("coefficient", "power_coefficient", "C of F = C·δ^a, e.g. `\"1.11e7 lbf/in**1.425\"` (the unit's "
              "length exponent must equal `exponent`)", required=True, minimum=0.0,
              strict=True, example='"1.11e7 lbf/in**1.425"'),
        Param("restitution", "number", "coefficient of restitution an isolated impact achieves: Hunt–Crossley "
              "damping χ = α(e)/v (none when absent; e = 0 needs infinite damping: use law = \"restitution\")",
              minimum=0.0, maximum=1.0, strict=True),
        Param("damping_model", "choice", "α(e) of the Hunt–Crossley damping: the exact mapping, or a published "
              "approximation (to reproduce published results)", default="exact", choices=tuple(DAMPING_MODELS)),
        Param("hysteresis_damping", "slowness", "χ of F = C·δ^a·(1 + χ·δ̇) given directly, instead of restitution",
              minimum=0.0),
    )

    refused_hints: ClassVar[dict[str, str]] = {
        "damping": "a power-law contact is damped through restitution (Hunt-Crossley)",
    }

    @classmethod
    def check(cls, values, error, driven) -> None:
        super().check(values, error, driven)
        if values.get("hysteresis_damping") is not None and values.get("restitution") is not None:
            raise error("hysteresis_damping", "give restitution or hysteresis_damping, not both")

    def damping_note(self):
        if self.hysteresis_damping is not None:
            return "Hunt-Crossley"
        if self.restitution is not None:
            return f"Hunt-Crossley ({self.damping_model})"
        return None

    @property
    def damped(self) -> bool:
        return self.restitution is not None or bool(self.hysteresis_damping)

    def hysteresis(self, v_impact: float | None) -> float:
        """χ [s/m] of the closed phase begun at approach speed ``v_impact`` [m/s] (0: undamped)."""
        if self.hysteresis_damping is not None:
            return self.hysteresis_damping
        if self.restitution is None or not v_impact:
            return 0.0
        return hc_alpha(self.restitution, self.damping_model) / v_impact

    def is_nonlinear(self, branch):
        return branch == Branch.CLOSED

    def is_constraint(self, branch):
        # Made bilateral for the no-impact variant, the contact holds its nodes together.
        return branch == Branch.BILATERAL

    def nonlinear_force(self, delta: np.ndarray, delta_rate: np.ndarray, v_impact: float | None) -> np.ndarray:
        """F = C·δ^a·(1 + χ·δ̇), χ from :meth:`hysteresis`, ≥ 0 [N] on samples."""
        pen = np.maximum(delta, 0.0)
        force = self.coefficient * pen**self.exponent
        chi = self.hysteresis(v_impact)
        if chi:
            force = force * (1.0 + chi * delta_rate)
        return np.maximum(force, 0.0)

    def nonlinear_force_scalar(self, delta: float, delta_rate: float, v_impact: float | None) -> float:
        """:meth:`nonlinear_force` for one sample, in plain floats (the hot path of a contact phase)."""
        if delta <= 0.0:
            return 0.0
        force = self.coefficient * delta**self.exponent
        chi = self.hysteresis(v_impact)
        if chi:
            force *= 1.0 + chi * delta_rate
        return force if force > 0.0 else 0.0

    def scalar_force(self, v_impact: float | None):
        """:meth:`nonlinear_force_scalar` at a fixed approach speed, as a function of
        (δ, δ̇) with the law's constants bound (called thousands of times per bounce)."""
        C, a, chi = self.coefficient, self.exponent, self.hysteresis(v_impact)

        def damped(delta: float, delta_rate: float) -> float:
            if delta <= 0.0:
                return 0.0
            F = C * delta**a * (1.0 + chi * delta_rate)
            return F if F > 0.0 else 0.0

        def undamped(delta: float, delta_rate: float) -> float:
            return C * delta**a if delta > 0.0 else 0.0

        return damped if chi else undamped

    def nonlinear_tangent(self, delta: np.ndarray, delta_rate: np.ndarray, v_impact: float | None):
        """(F, ∂F/∂δ, ∂F/∂δ̇) on samples [N, N/m, N·s/m] (zero where the force is clamped)."""
        chi = self.hysteresis(v_impact)
        if delta.min() > 0.0:
            # the usual case inside a closed phase: the same arithmetic without the masks
            base = self.coefficient * delta**self.exponent
            factor = 1.0 + chi * delta_rate
            F = base * factor
            if F.min() > 0.0:
                return F, self.exponent * base / delta * factor, base * chi
        pen = np.maximum(delta, 0.0)
        base = self.coefficient * pen**self.exponent
        chi = self.hysteresis(v_impact)
        factor = 1.0 + chi * delta_rate
        with np.errstate(divide="ignore", invalid="ignore"):
            kt = np.where(pen > 0, self.exponent * base / np.where(pen > 0, pen, 1.0), 0.0) * factor
        F = base * factor
        ct = base * chi
        off = F <= 0.0
        return np.where(off, 0.0, F), np.where(off, 0.0, kt), np.where(off, 0.0, ct)

    def force(self, branch, d, d_rate, damping, v_impact):
        if branch != Branch.CLOSED:
            return np.zeros_like(d)
        return self.nonlinear_force(self.gap - d, -d_rate, v_impact)

    def _factor(self, ctx) -> Affine | None:
        """The Hunt–Crossley factor 1 + χ·δ̇ as an affine guard (None when undamped)."""
        beta = self.hysteresis(ctx.v_impact)
        if not beta:
            return None
        _, rate = ctx.penetration()
        return Affine(beta * rate.Cz, beta * rate.Du, beta * rate.Fn, 1.0 + beta * rate.e)

    def closed_guards(self, branch, ctx):
        # δ > 0 and the Hunt–Crossley factor > 0
        delta, _ = ctx.penetration()
        out = [(GuardKind.RELEASE, delta, LENGTH_TOL)]
        factor = self._factor(ctx)
        if factor is not None:
            out.append((GuardKind.RELEASE, factor, FACTOR_TOL))
        return out

    def lifted_guards(self, ctx):
        factor = self._factor(ctx)
        if factor is None:
            return []
        return [(GuardKind.REENGAGE, Affine(-factor.Cz, -factor.Du, -factor.Fn, -factor.e), FACTOR_TOL)]

    def closing(self, rate):
        v_impact = max(rate, 1e-12) if self.restitution is not None else None
        return Outcome(Branch.CLOSED, EventKind.IMPACT, rate, v_impact=v_impact)

    def johnson_bounds(self, m1, m2, v):
        from camsim.physics.impact import johnson_power

        return johnson_power(m1, m2, v, 0.0, self.coefficient, self.exponent)

    def impact_duration(self, m1, m2, v):
        from camsim.physics.duration import power_contact_duration

        return power_contact_duration(self.coefficient, self.exponent, pair_mass(m1, m2), v)

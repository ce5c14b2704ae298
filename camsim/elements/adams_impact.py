"""``law = "adams-impact"``: the IMPACT contact function of MSC Adams (and SolidWorks Motion).

    F = max(0, k·δ^n + c(δ)·δ̇)   while δ > 0,   c(δ) = c_max·STEP(δ; 0, 0; d, 1)

with Adams's cubic STEP, c(δ) = c_max·u²·(3 − 2u), u = δ/d, below the ``penetration_depth``
d and c_max beyond (spec §3). Parameters: ``stiffness`` k [N/m^n], ``exponent`` n > 0,
``max_damping`` c_max [N·s/m], ``penetration_depth`` d > 0 [m]; ``clamp = false`` drops
the max(0, ·) (the contact may then pull while δ > 0, as Adams's IMPACT does).

While closed the force is nonlinear (integrated by :mod:`camsim.engine.nonlinear`). The contact
closes when δ crosses 0 upward (an ``impact``) and opens when δ returns to 0 (``release``);
with ``clamp`` the force is zero, not negative, in between when the damping term would
pull (the motion is the same as an opening at F = 0, which a non-affine force cannot mark
exactly as an event).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from camsim.elements.base import LENGTH_TOL, Branch, GuardKind, Param, pair_mass, register
from camsim.elements.contact import CONTACT_PARAMS, Contact


def step_cubic(u: np.ndarray) -> np.ndarray:
    """Adams's STEP(x; 0, 0; 1, 1) = u²(3 − 2u) on [0, 1], 0 below, 1 above."""
    u = np.clip(u, 0.0, 1.0)
    return u * u * (3.0 - 2.0 * u)


@register
@dataclass(frozen=True)
class AdamsImpactContact(Contact):
    """Adams IMPACT contact: k, n, c_max, d (see module docstring)."""

    stiffness: float = 0.0
    exponent: float = 1.5
    max_damping: float = 0.0
    penetration_depth: float = 1e-4
    clamp: bool = True

    law_name: ClassVar[str] = "adams-impact"
    summary: ClassVar[str] = "MSC Adams IMPACT: F = k·δ^n + STEP(δ; 0, 0; d, c_max)·δ̇"
    params: ClassVar[tuple[Param, ...]] = (
        *CONTACT_PARAMS,
        Param("exponent", "number", "n", required=True, minimum=0.0, strict=True),
        Param("stiffness", "power_coefficient", "k of k·δ^n, e.g. `\"1e8 N/m**1.5\"` (the unit's length exponent "
              "must equal `exponent`)", required=True, minimum=0.0, strict=True, example='"1e8 N/m**1.5"'),
        Param("max_damping", "damping", "c_max, reached at penetration_depth", required=True, minimum=0.0),
        Param("penetration_depth", "length", "d: the damping ramps up (cubic STEP) over 0 ≤ δ ≤ d",
              required=True, minimum=0.0, strict=True),
        Param("clamp", "bool", "max(0, ·) on the force (false: it may pull while δ > 0, as in Adams)", default=True),
    )

    def is_nonlinear(self, branch):
        return branch == Branch.CLOSED

    def is_constraint(self, branch):
        return branch == Branch.BILATERAL

    def nonlinear_tangent(self, delta, delta_rate, v_impact=None):
        """(F, ∂F/∂δ, ∂F/∂δ̇) on samples [N, N/m, N·s/m]."""
        delta = np.asarray(delta, dtype=float)
        delta_rate = np.asarray(delta_rate, dtype=float)
        pen = np.maximum(delta, 0.0)
        k, n, d = self.stiffness, self.exponent, self.penetration_depth
        elastic = k * pen**n
        u = pen / d
        inside = u < 1.0
        c = self.max_damping * step_cubic(u)
        dc = np.where(inside, self.max_damping * 6.0 * u * (1.0 - u) / d, 0.0)
        with np.errstate(divide="ignore", invalid="ignore"):
            k_el = np.where(pen > 0, n * elastic / np.where(pen > 0, pen, 1.0), 0.0)
        F = elastic + c * delta_rate
        kt = k_el + dc * delta_rate
        ct = c
        off = pen <= 0.0
        if self.clamp:
            off = off | (F <= 0.0)
        return np.where(off, 0.0, F), np.where(off, 0.0, kt), np.where(off, 0.0, ct)

    def nonlinear_force(self, delta, delta_rate, v_impact=None):
        return self.nonlinear_tangent(delta, delta_rate)[0]

    def nonlinear_force_scalar(self, delta: float, delta_rate: float, v_impact=None) -> float:
        if delta <= 0.0:
            return 0.0
        u = delta / self.penetration_depth
        c = self.max_damping * (u * u * (3.0 - 2.0 * u) if u < 1.0 else 1.0)
        force = self.stiffness * delta**self.exponent + c * delta_rate
        return force if (force > 0.0 or not self.clamp) else 0.0

    def scalar_force(self, v_impact=None):
        """:meth:`nonlinear_force_scalar` as a function of (δ, δ̇) (the law has no
        approach-speed dependence to bind)."""
        return lambda delta, delta_rate: self.nonlinear_force_scalar(delta, delta_rate)

    def force(self, branch, d, d_rate, damping, v_impact):
        if branch != Branch.CLOSED:
            return np.zeros_like(d)
        return self.nonlinear_force(self.gap - d, -d_rate)

    def closed_guards(self, branch, ctx):
        delta, _ = ctx.penetration()
        return [(GuardKind.RELEASE, delta, LENGTH_TOL)]

    def johnson_bounds(self, m1, m2, v):
        from camsim.physics.impact import johnson_power

        return johnson_power(m1, m2, v, 0.0, self.stiffness, self.exponent)

    def impact_duration(self, m1, m2, v):
        from camsim.physics.duration import power_contact_duration

        return power_contact_duration(self.stiffness, self.exponent, pair_mass(m1, m2), v)

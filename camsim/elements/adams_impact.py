"""``law = "adams-impact"``: the IMPACT contact function of MSC Adams (and SolidWorks Motion).

    F = max(0, k·δ^n + c(δ)·δ̇)   while δ > 0,   c(δ) = c_max·STEP(δ; 0, 0; d, 1)

with Adams's cubic STEP, c(δ) = c_max·u²·(3 − 2u), u = δ/d, below the ``penetration_depth``
d and c_max beyond (spec §3). Parameters: ``stiffness`` k [N/m^n], ``exponent`` n > 0,
``max_damping`` c_max [N·s/m], ``penetration_depth`` d > 0 [m]; ``clamp = false`` drops
the max(0, ·) (the contact may then pull while δ > 0, as Adams's IMPACT does).

While closed the force is nonlinear (integrated by :mod:`camsim.engine.nonlinear`). The contact
closes when δ crosses 0 upward (an ``impact``) and opens when δ returns to 0 (``release``).

The law has kinks inside a closed phase, and each is located like an event (issue 34), so
that every integrator sees a smooth law between them (one stepping across a kink loses its
order there, and where its steps fall then moves the rebound by ~1e-5): the damping ramp
ends at δ = d (branch ``closed`` below it, ``closed-deep`` beyond: the cubic STEP's second
derivative jumps there), and with ``clamp`` the force is zero where the damping term would
pull (branch ``clamped``: the unclamped law is still evaluated, to tell when it pushes
again, but does not act). None of these is a row of the event table: the contact is closed
from its impact to its release at δ = 0.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from camsim.elements.affine import Affine
from camsim.elements.base import FORCE_TOL, LENGTH_TOL, Branch, GuardKind, Outcome, Param, pair_mass, register
from camsim.elements.contact import CONTACT_PARAMS, Contact

#: The branches of a closed phase (the law acting, or clamped at zero).
_CLOSED = (Branch.CLOSED, Branch.CLOSED_DEEP, Branch.CLAMPED)


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

    def branches(self, no_impact):
        if no_impact:
            return (Branch.BILATERAL,)
        return (Branch.OPEN, *_CLOSED) if self.clamp else (Branch.OPEN, Branch.CLOSED, Branch.CLOSED_DEEP)

    def is_nonlinear(self, branch):
        return branch in _CLOSED

    def acts(self, branch):
        return branch != Branch.CLAMPED

    def is_constraint(self, branch):
        return branch == Branch.BILATERAL

    def _piece(self, delta: float) -> Branch:
        """The closed branch of the law's piece at penetration δ."""
        return Branch.CLOSED_DEEP if delta >= self.penetration_depth else Branch.CLOSED

    def nonlinear_tangent(self, delta, delta_rate, v_impact=None):
        """(F, ∂F/∂δ, ∂F/∂δ̇) of the law on samples [N, N/m, N·s/m], not clamped (the clamp
        is a branch, ``clamped``, entered where F reaches zero)."""
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
        return np.where(off, 0.0, F), np.where(off, 0.0, kt), np.where(off, 0.0, ct)

    def nonlinear_force(self, delta, delta_rate, v_impact=None):
        return self.nonlinear_tangent(delta, delta_rate)[0]

    def nonlinear_force_scalar(self, delta: float, delta_rate: float, v_impact=None) -> float:
        if delta <= 0.0:
            return 0.0
        u = delta / self.penetration_depth
        c = self.max_damping * (u * u * (3.0 - 2.0 * u) if u < 1.0 else 1.0)
        return self.stiffness * delta**self.exponent + c * delta_rate

    def scalar_force(self, v_impact=None):
        """:meth:`nonlinear_force_scalar` as a function of (δ, δ̇) (the law has no
        approach-speed dependence to bind)."""
        return lambda delta, delta_rate: self.nonlinear_force_scalar(delta, delta_rate)

    def force(self, branch, d, d_rate, damping, v_impact):
        if branch not in (Branch.CLOSED, Branch.CLOSED_DEEP):
            return np.zeros_like(d)
        force = self.nonlinear_force(self.gap - d, -d_rate)
        return np.maximum(force, 0.0) if self.clamp else force

    def closed_guards(self, branch, ctx):
        delta, _ = ctx.penetration()
        depth = Affine(delta.Cz, delta.Du, delta.Fn, delta.e - self.penetration_depth)  # δ − d
        out = [(GuardKind.RELEASE, delta, LENGTH_TOL)]
        if branch == Branch.CLAMPED:
            # clamped: pushes again when the unclamped law turns positive
            return out + [(GuardKind.UNCLAMP, self._law(ctx, -1.0), FORCE_TOL)]
        if branch == Branch.CLOSED:
            out.append((GuardKind.KINK_UP, Affine(-depth.Cz, -depth.Du, -depth.Fn, -depth.e), LENGTH_TOL))
        else:
            out.append((GuardKind.KINK_DOWN, depth, LENGTH_TOL))
        if self.clamp:
            out.append((GuardKind.CLAMP, self._law(ctx, 1.0), FORCE_TOL))
        return out

    def _law(self, ctx, sign: float) -> Affine:
        """±F_nl, this contact's (unclamped) law, as a guard."""
        config = ctx.config
        Fn = np.zeros((1, len(config.power_contacts)))
        Fn[0, config.power_contacts.index(ctx.index)] = sign
        return Affine(np.zeros((1, config.dim)), np.zeros((1, 4)), Fn, np.zeros(1))

    def outcome_at(self, kind, rate, d):
        delta = self.gap - d
        if kind == GuardKind.KINK_UP:
            return Outcome(Branch.CLOSED_DEEP)
        if kind == GuardKind.KINK_DOWN:
            return Outcome(Branch.CLOSED)
        if kind == GuardKind.CLAMP:
            return Outcome(Branch.CLAMPED)
        if kind == GuardKind.UNCLAMP:
            return Outcome(self._piece(delta))
        outcome = self.outcome(kind, rate)
        if outcome.branch == Branch.CLOSED:  # closing: onto the piece at δ (≈ 0)
            return Outcome(self._piece(delta), outcome.event, outcome.velocity, outcome.v_impact)
        return outcome

    def branch_at_rest(self, branch, d, constraint_force):
        new = super().branch_at_rest(branch, d, constraint_force)
        return self._piece(self.gap - d) if new in _CLOSED else new

    def rest_open(self, branch, delta, constraint_force):
        return Branch.OPEN if delta <= 0 else branch

    def branch_from_state(self, d, no_impact):
        branch = super().branch_from_state(d, no_impact)
        return self._piece(self.gap - d) if branch == Branch.CLOSED else branch

    def johnson_bounds(self, m1, m2, v):
        from camsim.physics.impact import johnson_power

        return johnson_power(m1, m2, v, 0.0, self.stiffness, self.exponent)

    def impact_duration(self, m1, m2, v):
        from camsim.physics.duration import power_contact_duration

        return power_contact_duration(self.stiffness, self.exponent, pair_mass(m1, m2), v)

"""``type = "lash"``: a two-sided clearance between two nodes (a yoke, a roller in a slot,
gear backlash; spec §3).

With ``clearance`` c ≥ 0 and ``offset`` o (default 0) the element is free while
|d − o| < c/2. Beyond either side a contact closes, with penetration

    δ_low = (o − c/2) − d   (d below the clearance: pushes the nodes apart),
    δ_high = d − (o + c/2)  (d above it: pulls them together),

i.e. δ = |d − o| − c/2 on the side that touches, and the contact ``law`` of the element
(one set of parameters for both sides). Each side closing is an ``impact``, each opening a
``release`` (the force reaching zero). Supported law: ``"linear"``, F = max(0, k·δ + c·δ̇),
damped by ``damping``, ``damping_ratio`` or ``restitution`` (the mapping of a linear
contact, with the lash's reduced mass).

Its force is reported **tension-positive** like a spring's: negative while the lower side
pushes the nodes apart, positive while the upper side pulls them together. In the
no-impact variant a lash is removed (both sides stay open), unless it joins the cam.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from camsim.affine import N_INPUT, Affine
from camsim.elements.base import (
    CAM,
    DAMPING_PARAMS,
    FORCE_TOL,
    LENGTH_TOL,
    Branch,
    Element,
    GuardKind,
    Outcome,
    Param,
    register,
)
from camsim.events import EventKind
from camsim.restitution import linear_damping_ratio

#: Contact laws a lash supports.
LASH_LAWS = ("linear",)


@register
@dataclass(frozen=True)
class Lash(Element):
    """Two-sided clearance: ``clearance`` c [m], ``offset`` o [m], a linear law on each side."""

    clearance: float = 0.0
    offset: float = 0.0
    law: str = "linear"
    stiffness: float = 0.0
    restitution: float | None = None

    type_name: ClassVar[str] = "lash"
    summary: ClassVar[str] = "two-sided clearance: free while |d − offset| < clearance/2, a contact beyond either side"
    params: ClassVar[tuple[Param, ...]] = (
        Param("clearance", "length", "c: total free play (free while |d − offset| < c/2)", required=True, minimum=0.0),
        Param("offset", "length", "o: the centre of the free play in d", default=0.0),
        Param("law", "choice", "the contact law of both sides", default="linear", choices=LASH_LAWS),
        Param("stiffness", "stiffness", "k of each side", required=True, minimum=0.0, strict=True),
        *DAMPING_PARAMS,
        Param("restitution", "number", "instead of damping/damping_ratio: the restitution an isolated impact "
              "on either side achieves", minimum=0.0, maximum=1.0, strict=True),
    )

    @classmethod
    def check(cls, values, error, driven) -> None:
        damping = values.get("damping")
        if values.get("restitution") is not None and damping is not None and (
            damping.coefficient is not None or damping.ratio is not None
        ):
            raise error("restitution", "give restitution or damping/damping_ratio, not both")

    @property
    def impact_only(self) -> bool:  # type: ignore[override]
        return CAM not in self.nodes

    @property
    def low(self) -> float:
        """d at which the lower side touches [m]."""
        return self.offset - 0.5 * self.clearance

    @property
    def high(self) -> float:
        """d at which the upper side touches [m]."""
        return self.offset + 0.5 * self.clearance

    # ------------------------------------------------------------------ branches and laws
    def branches(self, no_impact):
        return (Branch.OPEN,) if no_impact else (Branch.OPEN, Branch.CLOSED, Branch.CLOSED_HIGH)

    def branch_stiffnesses(self):
        return {"c": self.stiffness}

    def damping_coefficients(self, reference_mass, reduced_mass=None):
        if self.restitution is None:
            return super().damping_coefficients(reference_mass, reduced_mass)
        zeta = linear_damping_ratio(self.restitution)
        return {"c": 2.0 * zeta * (self.stiffness * reduced_mass()) ** 0.5}

    def linear_law(self, branch, damping):
        k, c = self.stiffness, damping["c"]
        if branch == Branch.CLOSED:  # tension f = −F_low = k·d + c·ḋ − k·low
            return k, c, -k * self.low
        if branch == Branch.CLOSED_HIGH:  # tension f = +F_high = k·d + c·ḋ − k·high
            return k, c, -k * self.high
        return None

    def force(self, branch, d, d_rate, damping, v_impact):
        law = self.linear_law(branch, damping)
        if law is None:
            return np.zeros_like(d)
        k, c, f0 = law
        f = k * d + c * d_rate + f0
        return np.minimum(f, 0.0) if branch == Branch.CLOSED else np.maximum(f, 0.0)

    def penetration(self, d: float) -> float:
        return max(self.low - d, d - self.high)

    # ------------------------------------------------------------------ guards and events
    def _sides(self, ctx):
        d, rate = ctx.deflection()
        low = Affine(-d.Cz, -d.Du, -d.Fn, self.low - d.e)
        low_rate = Affine(-rate.Cz, -rate.Du, -rate.Fn, -rate.e)
        high = Affine(d.Cz, d.Du, d.Fn, d.e - self.high)
        return (low, low_rate), (high, rate)

    def _law(self, ctx, side, sign):
        delta, rate = side
        k, c = sign * self.stiffness, sign * ctx.damping["c"]
        return Affine.combine([(np.array([[k]]), delta), (np.array([[c]]), rate)], np.zeros(1), np.zeros((1, N_INPUT)))

    def guards(self, branch, ctx):
        low, high = self._sides(ctx)
        if branch == Branch.CLOSED:
            return [(GuardKind.RELEASE, self._law(ctx, low, 1.0), FORCE_TOL)]
        if branch == Branch.CLOSED_HIGH:
            return [(GuardKind.RELEASE, self._law(ctx, high, 1.0), FORCE_TOL)]
        out = []
        for side in (low, high):
            delta = side[0]
            if ctx.now(delta) <= LENGTH_TOL:
                out.append((GuardKind.CLOSE, Affine(-delta.Cz, -delta.Du, -delta.Fn, -delta.e), LENGTH_TOL))
            else:  # lifted on this side: closes when its law pushes again
                out.append((GuardKind.CLOSE, self._law(ctx, side, -1.0), FORCE_TOL))
                out.append((GuardKind.UNLIFT, delta, LENGTH_TOL))
        return out

    def outcome(self, kind, rate):
        # rate = −ḋ: positive when d falls (the lower side closes), negative when it rises.
        if kind == GuardKind.UNLIFT:
            return Outcome()
        if kind == GuardKind.RELEASE:
            return Outcome(Branch.OPEN, EventKind.RELEASE, rate)
        if rate >= 0.0:
            return Outcome(Branch.CLOSED, EventKind.IMPACT, rate)
        return Outcome(Branch.CLOSED_HIGH, EventKind.IMPACT, -rate)

    def branch_at_rest(self, branch, d, constraint_force):
        return self.branch_from_state(d, False)

    def branch_from_state(self, d, no_impact):
        if no_impact:
            return Branch.OPEN
        if d < self.low - LENGTH_TOL:
            return Branch.CLOSED
        if d > self.high + LENGTH_TOL:
            return Branch.CLOSED_HIGH
        return Branch.OPEN

    def johnson_bounds(self, m1, m2, v):
        from camsim.impact import johnson_linear

        return johnson_linear(m1, m2, abs(v), 0.0, self.stiffness)

    def impact_force(self, force):
        return np.abs(force)

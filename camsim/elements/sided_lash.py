"""A ``type = "lash"`` whose two sides differ: ``lower`` and ``upper`` tables (spec §10).

    [[element]]
    name = "yoke"
    type = "lash"
    between = ["cam", "M1"]
    clearance = "0.2 mm"
    lower = { law = "linear", stiffness = "2e7 N/m", damping_ratio = 0.05 }
    upper = { law = "elastogap", stiffness = "5e6 N/m", restitution = 0.6 }

Each table holds one side's law and its keys, exactly as the element itself holds them for a
lash with one law (``law`` defaults to ``"linear"``; ``clearance`` and ``offset`` stay on the
element: the two sides share the clearance). Each side is a lash of its own law — an instance
of that law's lash class (:mod:`camsim.elements.lash`, :mod:`camsim.elements.elastogap_lash`)
with the element's name, nodes and clearance — and :class:`SidedLash` hands every question
about a branch to the side that branch belongs to: a side's law, its damping, its guards and
kinks, its impacts (:meth:`~camsim.elements.base.Element.acting` tells the engine which side's
law a closed nonlinear phase or an impact's Johnson bounds read). While open, each side watches
its own approach. The damping coefficients are named per side: ``c_lower``, ``c_upper``.

Both sides rigid (``law = "restitution"``, each with its own e) or both compliant: a rigid
stop on one side and a compliant law on the other is refused (the rigid solver treats a
lash as rigid on both sides or neither).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np

from camsim.elements.base import Branch, Param, register
from camsim.elements.lash import LASH_PARAMS, Lash

#: The element's own keys (the geometry both sides share).
_SHARED = tuple(p for p in LASH_PARAMS if p.key != "law")
_EXAMPLE = '{ law = "linear", stiffness = "1e6 N/m" }'


class _SideContext:
    """A guard context that reads one side's damping coefficients (``ctx.damping``)."""

    def __init__(self, ctx, damping: dict[str, float]):
        self._ctx = ctx
        self.damping = damping

    def __getattr__(self, name: str) -> Any:
        return getattr(self._ctx, name)


@register
@dataclass(frozen=True)
class SidedLash(Lash):
    """A lash with a law per side: ``lower_law`` and ``upper_law``, each a :class:`Lash` of its
    law (the element's name, nodes, clearance and offset are copied into both)."""

    lower_law: Lash | None = None
    upper_law: Lash | None = None

    law_name: ClassVar[str | None] = None
    summary: ClassVar[str] = ("a lash whose sides differ: `lower` and `upper` tables, each a side's `law` and its keys "
                              "as a lash of that law takes them (`clearance` and `offset` stay on the element)")
    params: ClassVar[tuple[Param, ...]] = (
        *_SHARED,
        Param("lower", "law_table", "the lower side's law and its keys (the side that pushes the nodes apart)",
              required=True, field="lower_law", example=_EXAMPLE),
        Param("upper", "law_table", "the upper side's law and its keys (the side that pulls them together)",
              required=True, field="upper_law", example=_EXAMPLE),
    )
    selected_by: ClassVar[tuple[str, ...]] = ("lower", "upper")
    refused_hints: ClassVar[dict[str, str]] = {
        "": "a lash with `lower` and `upper` tables gives each side's law keys in its table",
    }

    def __post_init__(self) -> None:
        # Each side is this element seen through one law: its name, nodes and geometry.
        for attr in ("lower_law", "upper_law"):
            side = getattr(self, attr)
            if side is not None:
                object.__setattr__(self, attr, dataclasses.replace(
                    side, name=self.name, lower=self.lower, upper=self.upper, clearance=self.clearance,
                    offset=self.offset, cam_nodes=self.cam_nodes))

    @classmethod
    def check(cls, values, error, driven) -> None:
        lower, upper = values.get("lower_law"), values.get("upper_law")
        if lower is None or upper is None:
            return
        rigid = [side.is_constraint(side.closed_branches[k]) for k, side in enumerate((lower, upper))]
        if rigid[0] != rigid[1]:
            key = "lower" if rigid[0] else "upper"
            raise error(key, 'law = "restitution" on one side only: a lash\'s sides are both rigid or both compliant '
                        '(give the other side a stiff compliant law, or make both rigid)')

    # ------------------------------------------------------------------ sides
    @property
    def sides(self) -> tuple[Lash, Lash]:
        """(lower side's lash, upper side's lash)."""
        return self.lower_law, self.upper_law

    def side(self, sign: float) -> Lash:
        """The lash of side σ (+1 lower, −1 upper)."""
        return self.lower_law if sign > 0 else self.upper_law

    @property
    def closed_branches(self) -> tuple[Branch, Branch]:  # type: ignore[override]
        return self.lower_law.closed_branches[0], self.upper_law.closed_branches[1]

    @property
    def side_branches(self):
        return self.lower_law.side_branches[0], self.upper_law.side_branches[1]

    def acting(self, branch):
        sign = self.side_of(branch)
        return self.side(sign) if sign else self

    @staticmethod
    def _suffix(sign: float) -> str:
        return "_lower" if sign > 0 else "_upper"

    def _damping(self, sign: float, damping: dict[str, float]) -> dict[str, float]:
        """Side σ's own damping coefficients out of the element's (``c_lower`` → ``c``)."""
        suffix = self._suffix(sign)
        return {key[: -len(suffix)]: c for key, c in damping.items() if key.endswith(suffix)}

    # ------------------------------------------------------------------ damping
    def branch_stiffnesses(self):
        return {key + self._suffix(sign): k for sign in (1.0, -1.0) for key, k in self.side(sign).branch_stiffnesses().items()}

    def damping_coefficients(self, reference_mass, reduced_mass=None):
        out = {}
        for sign in (1.0, -1.0):
            side = self.side(sign)
            ref = lambda side=side: reference_mass(side.damping.reference_mass)  # noqa: E731 - the side's m_ref
            out.update({key + self._suffix(sign): c for key, c in side.damping_coefficients(ref, reduced_mass).items()})
        return out

    def damping_note(self):
        def note(side: Lash) -> str:
            d = side.damping
            if d.ratio is not None:
                return f"zeta {d.ratio:g}"
            if d.coefficient is not None:
                return f"c {d.coefficient:g} N*s/m"
            return side.damping_note() or "none"

        return f"lower {self.lower_law.law_name}: {note(self.lower_law)}; upper {self.upper_law.law_name}: " \
               f"{note(self.upper_law)}"

    # ------------------------------------------------------------------ branches and laws
    def linear_law(self, branch, damping):
        sign = self.side_of(branch)
        return self.side(sign).linear_law(branch, self._damping(sign, damping)) if sign else None

    def linear_part(self, branch, damping):
        sign = self.side_of(branch)
        return self.side(sign).linear_part(branch, self._damping(sign, damping)) if sign else None

    def is_constraint(self, branch):
        sign = self.side_of(branch)
        return bool(sign) and self.side(sign).is_constraint(branch)

    def is_nonlinear(self, branch):
        sign = self.side_of(branch)
        return bool(sign) and self.side(sign).is_nonlinear(branch)

    def acts(self, branch):
        sign = self.side_of(branch)
        return self.side(sign).acts(branch) if sign else True

    def nonlinear_at_rest(self, branch):
        sign = self.side_of(branch)
        return self.side(sign).nonlinear_at_rest(branch) if sign else True

    def stuck_branch(self, sign):
        return self.side(sign).stuck_branch(sign)

    def reported_constraint_force(self, branch, lam):
        return self.side(self.side_of(branch) or 1.0).reported_constraint_force(branch, lam)

    def force(self, branch, d, d_rate, damping, v_impact):
        sign = self.side_of(branch)
        if not sign:
            return np.zeros_like(d)
        return self.side(sign).force(branch, d, d_rate, self._damping(sign, damping), v_impact)

    # ------------------------------------------------------------------ guards and events
    def _context(self, sign: float, ctx):
        return _SideContext(ctx, self._damping(sign, ctx.damping))

    def guards(self, branch, ctx):
        sign = self.side_of(branch)
        if sign:
            return self.side(sign).side_guards(sign, branch, self._context(sign, ctx))
        return [*self.lower_law.side_guards(1.0, branch, self._context(1.0, ctx)),
                *self.upper_law.side_guards(-1.0, branch, self._context(-1.0, ctx))]

    def guard_key(self, branch, ctx):
        sign = self.side_of(branch)
        if sign:
            return self.side(sign).side_guard_key(sign, branch, self._context(sign, ctx))
        return (self.lower_law.side_guard_key(1.0, branch, self._context(1.0, ctx)),
                self.upper_law.side_guard_key(-1.0, branch, self._context(-1.0, ctx)))

    def outcome_at(self, kind, rate, d):
        # every guard of a side is crossed on that side of the clearance: that side's law answers
        return self.side(self.nearest(d)).outcome_at(kind, rate, d)

    def branch_at_rest(self, branch, d, constraint_force):
        sign = self.side_of(branch) or self.nearest(d)
        side = self.side(sign)
        new = side.branch_at_rest(branch if self.side_of(branch) == sign else Branch.OPEN, d, constraint_force)
        if side.side_of(new) == -sign:  # the equilibrium moved to the other side: its own law
            return self.side(-sign).branch_at_rest(Branch.OPEN, d, constraint_force)
        return new

    def branch_from_state(self, d, no_impact):
        if no_impact:
            return Branch.OPEN
        return self.side(self.nearest(d)).branch_from_state(d, no_impact)

    # ------------------------------------------------------------------ impacts
    def johnson_bounds(self, m1, m2, v):
        return None  # a side's own (the engine asks acting(branch) of the impact's side)

    def impact_force(self, force):
        return self.lower_law.impact_force(force)  # both sides compliant, or both rigid

    def impact_duration(self, m1, m2, v):
        durations = [t for t in (s.impact_duration(m1, m2, v) for s in self.sides) if t is not None]
        return min(durations) if durations else None

    def describe(self) -> dict:
        out: dict[str, Any] = {"name": self.name, "lower": self.lower, "upper": self.upper, "type": self.type_name,
                               "clearance": self.clearance, "offset": self.offset}
        out["sides"] = {}
        for key, side in (("lower", self.lower_law), ("upper", self.upper_law)):
            row = side.describe()
            for common in ("name", "lower", "upper", "type", "clearance", "offset"):
                row.pop(common, None)
            row.update(damping=side.damping.coefficient, damping_ratio=side.damping.ratio,
                       reference_mass=side.damping.reference_mass)
            out["sides"][key] = row
        return out

"""``type = "contact"``: what every unilateral contact shares, whatever its law (spec §3).

With ``gap`` g0 the penetration is δ = g0 − d (g0 of either sign, spec §10: a negative gap is
a contact closed at zero deflection — an interference fit, or a stop on the far side of the
origin, below a mass whose coordinate is negative there); the contact force is compressive
(it pushes the nodes apart) and acts only while δ > 0. Each law is a subclass in a
module of its own (``linear_contact``, ``power_contact``, ``rigid_contact``, ...),
registered under ``type = "contact"`` and its ``law`` name.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

from camsim.elements.base import FIXED_NODES, LENGTH_TOL, Branch, Element, GuardKind, Outcome, Param
from camsim.elements.events import EventKind

#: Keys every contact takes, whatever its law.
CONTACT_PARAMS: tuple[Param, ...] = (
    Param("law", "string", "the contact law (the tables below, one per law)", default="linear"),
    Param("gap", "length", "g0: penetration δ = g0 − d; any sign (g0 < 0: closed at zero deflection, an "
          "interference or a stop beyond the origin)", default=0.0),
    Param("transducer", "bool", "its force is summed into `/transducer/force`", default=False),
)


@dataclass(frozen=True)
class Contact(Element):
    """Unilateral contact; penetration δ = gap − d, force compressive-positive.

    Attributes
    ----------
    gap : float
        g0 [m], either sign.
    transducer : bool
        Its force is summed into ``/transducer/force``.
    restitution : float or None
        Coefficient of restitution e ∈ [0, 1] of laws that take one.
    """

    gap: float = 0.0
    transducer: bool = False
    restitution: float | None = None

    type_name: ClassVar[str] = "contact"
    unilateral: ClassVar[bool] = True

    @property
    def law(self) -> str:
        """The ``law`` name it was written with."""
        return self.law_name

    @property
    def impact_only(self) -> bool:  # type: ignore[override]
        # The no-impact variant keeps the cam contact (made bilateral) and drops the rest.
        return not self.at_cam

    @classmethod
    def check(cls, values, error, driven) -> None:
        lower, upper = values["lower"], values["upper"]
        if driven is not None and driven in (lower, upper):
            other = upper if lower == driven else lower
            if other in FIXED_NODES:
                raise error("between", f"{driven} is driven by the cam (cam.drives): its motion is prescribed, "
                            f"so a contact with {other} could never close or open; remove cam.drives to let the "
                            "follower separate")

    def penetration(self, d: float) -> float:
        return self.gap - d

    def contact_side(self, branch, d=None):
        return 1.0, self.gap

    def describe(self) -> dict:
        out = super().describe()
        out.setdefault("restitution", None)
        return out

    def branches(self, no_impact: bool) -> tuple[Branch, ...]:
        return (Branch.BILATERAL,) if no_impact else (Branch.OPEN, Branch.CLOSED)

    def guards(self, branch, ctx):
        if branch == Branch.BILATERAL:
            return []
        if branch == Branch.OPEN:
            delta, _ = ctx.penetration()
            if ctx.now(delta) <= LENGTH_TOL:
                return [self._approach_guard(delta)]
            # Penetrating but the law would pull (a damped contact lifted off): it closes
            # when the law pushes again, and stops being "lifted" when δ returns to 0.
            return [*self.lifted_guards(ctx), (GuardKind.UNLIFT, delta, LENGTH_TOL)]
        return self.closed_guards(branch, ctx)

    def guard_key(self, branch, ctx):
        if branch == Branch.OPEN:  # approaching, or lifted off while penetrating
            delta, _ = ctx.penetration()
            return ctx.v_impact, ctx.now(delta) <= LENGTH_TOL
        return ctx.v_impact

    @staticmethod
    def _approach_guard(delta):
        from camsim.elements.affine import Affine

        return (GuardKind.CLOSE, Affine(-delta.Cz, -delta.Du, -delta.Fn, -delta.e), LENGTH_TOL)

    def closed_guards(self, branch, ctx):
        """Guards of the closed branch (the law's)."""
        return []

    def lifted_guards(self, ctx):
        """Guards of an open contact that penetrates while its law would pull."""
        return []

    def outcome(self, kind, rate):
        if kind == GuardKind.UNLIFT:
            return Outcome()
        if kind == GuardKind.RELEASE:
            return Outcome(Branch.OPEN, EventKind.RELEASE, rate)
        if kind == GuardKind.REENGAGE:
            return self.reengaging()
        return self.closing(rate)

    def reengaging(self) -> Outcome:
        """A lifted contact whose law pushes again while it still penetrates (δ > 0).

        Its force rises from zero, continuously: there is no approach (δ̇ = −k·δ/c < 0 for a
        linear law) and nothing to annotate, so this is no impact and no row of the event
        table (spec §3: a contact closes when δ rises through 0). The contact keeps the
        approach speed of the impact that closed it (a power law's χ = α(e)/v).
        """
        return Outcome(self.closed_branch)

    def closing(self, rate: float) -> Outcome:
        """The outcome of the contact closing at approach speed ``rate`` [m/s]."""
        return Outcome(Branch.CLOSED, EventKind.IMPACT, rate)

    def branch_at_rest(self, branch, d, constraint_force):
        delta = self.gap - d
        if branch == Branch.BILATERAL:
            return branch
        if branch == Branch.OPEN:
            return self.closed_branch if delta > LENGTH_TOL else branch
        return self.rest_open(branch, delta, constraint_force)

    #: The branch a contact takes when it closes at rest.
    closed_branch: ClassVar[Branch] = Branch.CLOSED

    def rest_open(self, branch, delta, constraint_force) -> Branch:
        """Whether a closed contact opens at rest (static equilibrium iteration)."""
        return Branch.OPEN if delta <= 0 else branch

    def branch_from_state(self, d, no_impact):
        if no_impact:
            return Branch.BILATERAL
        return Branch.CLOSED if self.gap - d > LENGTH_TOL else Branch.OPEN

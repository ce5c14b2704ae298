"""``type = "lash"``, ``law = "elastogap"``: Modelica's ElastoGap on each side of a clearance
(spec §10).

Each side closes with the gap law of :mod:`camsim.elements.elastogap_contact` along its own
penetration δ (:mod:`camsim.elements.lash`):

    F = k·δⁿ + clip(c·δ̇, −k·δⁿ, +k·δⁿ)   while δ > 0.

With n = 1 the law is exact like the contact's: each side has the contact's three closed
pieces as branches — ``closed-deep`` / ``closed-deep-high`` (the approach's clip, F = 2kδ),
``closed`` / ``closed-high`` (F = kδ + cδ̇) and ``clamped`` / ``clamped-high`` (F = 0 until δ
returns to 0 or the law pushes again) — and the contact's kink guards, read through the
side's penetration (:class:`camsim.elements.lash._Side`), so every kink is located like an
event (no row of the event table). With n ≠ 1 a closed side is the clipped law as one
nonlinear force, integrated to the engine's tolerance with its kinks stepped across, as a
power-law lash's; its damping is then a coefficient (``damping``).

``damping``, ``damping_ratio`` or ``restitution`` set c; ``restitution`` e is the mapping of
:func:`camsim.physics.restitution.elastogap_damping_ratio` with the reduced mass of the two
nodes, as for the contact: every impact on either side rebounds with exactly e.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

from camsim.elements.base import Branch, GuardKind, Outcome, Param, register
from camsim.elements.contact import Contact
from camsim.elements.elastogap_contact import ElastoGapContact
from camsim.elements.lash import LASH_PARAMS, Lash, _law_params

#: A side's closed pieces in the contact's terms, and the lash's branch for each (lower, upper).
_PIECES: dict[Branch, tuple[Branch, Branch]] = {
    Branch.CLOSED_DEEP: (Branch.CLOSED_DEEP, Branch.CLOSED_DEEP_HIGH),
    Branch.CLOSED: (Branch.CLOSED, Branch.CLOSED_HIGH),
    Branch.CLAMPED: (Branch.CLAMPED, Branch.CLAMPED_HIGH),
}
#: The lash's branch → the contact's piece.
_PIECE_OF = {lash: piece for piece, pair in _PIECES.items() for lash in pair}


@register
@dataclass(frozen=True)
class ElastoGapLash(Lash):
    """Lash with an ElastoGap contact on each side (see module docstring)."""

    law_name: ClassVar[str] = "elastogap"
    summary: ClassVar[str] = ("two-sided clearance with Modelica's ElastoGap on each side: "
                              "F = k·δⁿ + clip(c·δ̇, −k·δⁿ, k·δⁿ)")
    params: ClassVar[tuple[Param, ...]] = (*LASH_PARAMS, *_law_params(ElastoGapContact))
    contact_class: ClassVar[type[Contact]] = ElastoGapContact
    locates_kinks: ClassVar[bool] = True

    @property
    def linear(self) -> bool:
        return self.exponent == 1.0

    @property
    def side_branches(self):
        if not self.linear:
            return super().side_branches
        return tuple(tuple(_PIECES[p][k] for p in _PIECES) for k in (0, 1))

    def _contact_branch(self, branch):
        return _PIECE_OF.get(branch, Branch.CLOSED)

    def _lash_branch(self, contact_branch, sign):
        return _PIECES[contact_branch if self.linear else Branch.CLOSED][0 if sign > 0 else 1]

    # ------------------------------------------------------------------ the law
    def linear_law(self, branch, damping):
        sign = self.side_of(branch)
        if not sign or not self.linear:
            return None
        law = self.contact.linear_law(self._contact_branch(branch), damping)
        if law is None:  # clamped: no force
            return None
        # The contact (gap 0) gives tension f' = k·d' + c·ḋ' + f0 along its own deflection
        # d' = −δ: below, d' = d − low (f = f'); above, d' = high − d and f = +F = −f'.
        k, c, f0 = law
        return (k, c, f0 - k * self.low) if sign > 0 else (k, c, -f0 - k * self.high)

    # n ≠ 1: a closed side's force is the clipped law (F_nl), integrated by DOP853 (no tangent)
    def is_nonlinear(self, branch):
        return not self.linear and bool(self.side_of(branch))

    def nonlinear_force(self, delta, delta_rate, v_impact=None):
        """The law's compressive force along the closed side's δ [N]."""
        return self.contact.nonlinear_force(delta, delta_rate, v_impact)

    def nonlinear_force_scalar(self, delta: float, delta_rate: float, v_impact=None) -> float:
        return self.contact.nonlinear_force_scalar(delta, delta_rate, v_impact)

    # ------------------------------------------------------------------ events
    def outcome_at(self, kind, rate, d):
        if kind in (GuardKind.KINK_UP, GuardKind.KINK_DOWN, GuardKind.CLAMP, GuardKind.UNCLAMP):
            sign = self.nearest(d)  # a kink happens inside a closed side: d is beyond it
            piece = self.contact.outcome_at(kind, rate if sign > 0 else -rate, 0.0).branch
            return Outcome(self._lash_branch(piece, sign))
        return super().outcome_at(kind, rate, d)

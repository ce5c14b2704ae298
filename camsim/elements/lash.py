"""``type = "lash"``: a two-sided clearance between two nodes (a yoke, a roller in a slot,
gear backlash; spec §3).

With ``clearance`` c ≥ 0 and ``offset`` o (default 0) the element is free while
|d − o| < c/2. Beyond either side a contact closes, with penetration

    δ_low = (o − c/2) − d   (d below the clearance: pushes the nodes apart),
    δ_high = d − (o + c/2)  (d above it: pulls them together),

i.e. δ = |d − o| − c/2 on the side that touches, and the contact ``law`` of the element,
any law of ``type = "contact"`` with one set of parameters for both sides:

- ``"linear"`` (default): F = max(0, k·δ + c·δ̇), damped by ``damping``, ``damping_ratio``
  or ``restitution`` (the mapping of a linear contact, with the lash's reduced mass);
- ``"power"``: F = C·δ^a·(1 + χ·δ̇), with ``restitution`` (and ``damping_model``) or
  ``hysteresis_damping`` as a power-law contact has; χ follows each side's own impact;
- ``"adams-impact"``: MSC Adams's IMPACT function;
- ``"restitution"``: a rigid stop on each side, Newton's law at each impact, resting
  (``stick``) and ``release`` as a rigid contact, solved with the other rigid contacts
  as one LCP (:mod:`camsim.engine.rigid`);
- ``"elastogap"``: Modelica's ElastoGap on each side (:mod:`camsim.elements.elastogap_lash`).

A lash whose sides differ gives ``lower`` and ``upper`` tables, each side a lash of its own
law (:mod:`camsim.elements.sided_lash`).

Each law is one class here, registered under ``type = "lash"`` and the law's name; it
delegates the law to an instance of that law's contact class (built from the same
parameters, ``gap`` 0) and tells the model which side is closed: a side σ (+1 lower,
−1 upper) acts with penetration δ = σ·(g − d), g the side's touching deflection
(:meth:`Lash.contact_side`).

Each side closing is an ``impact``, each opening a ``release`` (the force reaching zero).
Its force is reported **tension-positive** like a spring's: negative while the lower side
pushes the nodes apart, positive while the upper side pulls them together. In the
no-impact variant a lash is removed (both sides stay open), unless it joins the cam.
"""

from __future__ import annotations

from dataclasses import dataclass, fields
from functools import cached_property
from typing import Any, ClassVar

import numpy as np

from camsim.elements.affine import Affine
from camsim.elements.adams_impact import AdamsImpactContact
from camsim.elements.base import DEFAULT_LAW, FORCE_TOL, LENGTH_TOL, Branch, Element, GuardKind, Outcome, Param, register
from camsim.elements.contact import CONTACT_PARAMS, Contact
from camsim.elements.linear_contact import LinearContact
from camsim.elements.power_contact import PowerContact
from camsim.elements.rigid_contact import RigidContact
from camsim.elements.events import EventKind

#: Keys every lash takes, whatever its law.
LASH_PARAMS: tuple[Param, ...] = (
    Param("clearance", "length", "c: total free play (free while |d − offset| < c/2)", required=True, minimum=0.0),
    Param("offset", "length", "o: the centre of the free play in d", default=0.0),
    Param("law", "string", "the contact law of both sides (the tables below, one per law)", default="linear"),
)
#: Keys of a contact that a lash does not take (the lash has its own geometry).
_CONTACT_ONLY = tuple(p.key for p in CONTACT_PARAMS)


def _law_params(contact: type[Contact]) -> tuple[Param, ...]:
    return tuple(p for p in contact.params if p.key not in _CONTACT_ONLY)


#: Guard kinds of a contact law's kinks, which a lash does not locate (see Lash.guards).
_KINKS = (GuardKind.KINK_UP, GuardKind.KINK_DOWN, GuardKind.CLAMP, GuardKind.UNCLAMP)


class _Side:
    """A guard context seen from one side of a lash: ``penetration`` is that side's δ, δ̇."""

    def __init__(self, ctx, delta: Affine, rate: Affine):
        self._ctx = ctx
        self._pen = (delta, rate)

    def penetration(self):
        return self._pen

    def __getattr__(self, name: str) -> Any:
        return getattr(self._ctx, name)


@dataclass(frozen=True)
class Lash(Element):
    """Two-sided clearance: ``clearance`` c [m], ``offset`` o [m], a contact law on each side.

    The law's parameters are the fields of the law's contact class (see :attr:`contact`).
    """

    clearance: float = 0.0
    offset: float = 0.0
    stiffness: float = 0.0
    restitution: float | None = None
    coefficient: float = 0.0
    exponent: float = 1.0
    damping_model: str = "exact"
    hysteresis_damping: float | None = None
    max_damping: float = 0.0
    penetration_depth: float = 1e-4
    clamp: bool = True

    type_name: ClassVar[str] = "lash"
    #: The contact class of the law (one instance of it computes each side's force).
    contact_class: ClassVar[type[Contact]] = LinearContact
    #: The branches on which each side is closed: (lower, upper).
    closed_branches: ClassVar[tuple[Branch, Branch]] = (Branch.CLOSED, Branch.CLOSED_HIGH)

    @property
    def law(self) -> str:
        """The ``law`` name it was written with."""
        return self.law_name

    @classmethod
    def check(cls, values, error, driven) -> None:
        # The law's own cross-key checks (its node checks concern a one-sided contact).
        cls.contact_class.check({**values, "lower": "", "upper": ""}, error, None)

    @cached_property
    def contact(self) -> Contact:
        """The law: a contact of :attr:`contact_class` with the same parameters and ``gap`` 0."""
        own = {f.name for f in fields(self.contact_class)}
        values = {f.name: getattr(self, f.name) for f in fields(self) if f.name in own and f.name != "gap"}
        return self.contact_class(**values, gap=0.0)

    @property
    def impact_only(self) -> bool:  # type: ignore[override]
        return not self.at_cam

    @property
    def low(self) -> float:
        """d at which the lower side touches [m]."""
        return self.offset - 0.5 * self.clearance

    @property
    def high(self) -> float:
        """d at which the upper side touches [m]."""
        return self.offset + 0.5 * self.clearance

    # ------------------------------------------------------------------ sides
    @property
    def side_branches(self) -> tuple[tuple[Branch, ...], tuple[Branch, ...]]:
        """The branches on which each side is closed: (lower's, upper's); the first of each
        is :attr:`closed_branches`' (the side at rest)."""
        return (self.closed_branches[0],), (self.closed_branches[1],)

    def contact_side(self, branch, d=None):
        sign = self.side_of(branch)
        if sign < 0:
            return -1.0, self.high
        if sign > 0 or d is None:
            return 1.0, self.low
        return (1.0, self.low) if self.nearest(d) > 0 else (-1.0, self.high)

    def nearest(self, d: float) -> float:
        """σ of the side nearest deflection ``d`` (+1 lower, −1 upper)."""
        return 1.0 if self.low - d >= d - self.high else -1.0

    def side_of(self, branch) -> float:
        """σ of the side closed on ``branch`` (0: open)."""
        lower, upper = self.side_branches
        if branch in lower:
            return 1.0
        if branch in upper:
            return -1.0
        return 0.0

    def _contact_branch(self, branch) -> Branch:
        """The branch of the law's contact that the lash's ``branch`` is on one side."""
        return Branch.CLOSED

    def _lash_branch(self, contact_branch: Branch, sign: float) -> Branch:
        """The lash's branch on side ``sign`` for the law's contact on ``contact_branch``."""
        return self.closed_branches[0 if sign > 0 else 1]

    def penetration(self, d: float) -> float:
        return max(self.low - d, d - self.high)

    def _side_deflection(self, branch, d, d_rate):
        """The law's own deflection d' = −δ and its rate on the side closed on ``branch``."""
        if self.side_of(branch) > 0:
            return d - self.low, d_rate
        return self.high - d, -d_rate

    # ------------------------------------------------------------------ branches and laws
    def branches(self, no_impact):
        lower, upper = self.side_branches
        return (Branch.OPEN,) if no_impact else (Branch.OPEN, *lower, *upper)

    def branch_stiffnesses(self):
        return self.contact.branch_stiffnesses()

    def damping_coefficients(self, reference_mass, reduced_mass=None):
        return self.contact.damping_coefficients(reference_mass, reduced_mass)

    def damping_note(self):
        return self.contact.damping_note()

    def force(self, branch, d, d_rate, damping, v_impact):
        sign = self.side_of(branch)
        if not sign:
            return np.zeros_like(d)
        dd, rate = self._side_deflection(branch, d, d_rate)
        # The law's compressive F along the side's δ; tension-positive: −F below, +F above.
        return -sign * self.contact.force(self._contact_branch(branch), dd, rate, damping, v_impact)

    # ------------------------------------------------------------------ guards and events
    def _sides(self, ctx):
        d, rate = ctx.deflection()
        low = _Side(ctx, Affine(-d.Cz, -d.Du, -d.Fn, self.low - d.e), Affine(-rate.Cz, -rate.Du, -rate.Fn, -rate.e))
        high = _Side(ctx, Affine(d.Cz, d.Du, d.Fn, d.e - self.high), rate)
        return low, high

    #: Whether the kinks of the law inside a closed phase are located (branches of each side).
    locates_kinks: ClassVar[bool] = False

    def guards(self, branch, ctx):
        sign = self.side_of(branch)
        if sign:
            return self.side_guards(sign, branch, ctx)
        # Open: each side's guards as an open contact's (approach, or lifted and closing again).
        return [*self.side_guards(1.0, branch, ctx), *self.side_guards(-1.0, branch, ctx)]

    def side_guards(self, sign: float, branch, ctx):
        """Guards of side σ on ``branch``: its law's closed guards on a branch of that side,
        else an open contact's (approach, or lifted and closing again)."""
        side = self._sides(ctx)[0 if sign > 0 else 1]
        if self.side_of(branch) != sign:
            return self.contact.guards(Branch.OPEN, side)
        if self.locates_kinks:
            return self.contact.guards(self._contact_branch(branch), side)
        # the law's guards on the closed side (its release; a lash of this law has one closed
        # branch per side, so the kinks of its law inside a closed phase are stepped across:
        # an ElastoGap lash with n ≠ 1; Adams IMPACT's are located, AdamsImpactLash)
        guards = self.contact.guards(self.contact.closed_branch, side)
        return [g for g in guards if g[0] not in _KINKS]

    def guard_key(self, branch, ctx):
        sign = self.side_of(branch)
        if sign:
            return self.side_guard_key(sign, branch, ctx)
        return self.side_guard_key(1.0, branch, ctx), self.side_guard_key(-1.0, branch, ctx)

    def side_guard_key(self, sign: float, branch, ctx):
        """:meth:`guard_key` of side σ's guards (:meth:`side_guards`)."""
        side = self._sides(ctx)[0 if sign > 0 else 1]
        if self.side_of(branch) != sign:
            return self.contact.guard_key(Branch.OPEN, side)
        contact_branch = self._contact_branch(branch) if self.locates_kinks else self.contact.closed_branch
        return self.contact.guard_key(contact_branch, side)

    def outcome_at(self, kind, rate, d):
        # rate = −ḋ: the lower side's δ̇; the upper side's is −rate.
        if kind == GuardKind.UNLIFT:
            return Outcome()
        if kind == GuardKind.RELEASE:
            return Outcome(Branch.OPEN, EventKind.RELEASE, rate if d < self.offset else -rate)
        sign = self.nearest(d)
        if kind == GuardKind.REENGAGE:  # that side's force resumes: no impact, no row
            return Outcome(self.closed_branches[0 if sign > 0 else 1])
        closing = self.contact.closing(rate if sign > 0 else -rate)
        branch = None if closing.branch is None else self._lash_branch(closing.branch, sign)
        return Outcome(branch, closing.event, closing.velocity, closing.v_impact, closing.rigid_impact)

    def outcome(self, kind, rate):
        return self.outcome_at(kind, rate, self.low if rate >= 0.0 else self.high)

    def branch_at_rest(self, branch, d, constraint_force):
        return self.branch_from_state(d, False)

    def branch_from_state(self, d, no_impact):
        if no_impact:
            return Branch.OPEN
        if d < self.low - LENGTH_TOL:
            return self.closed_branches[0]
        if d > self.high + LENGTH_TOL:
            return self.closed_branches[1]
        return Branch.OPEN

    # ------------------------------------------------------------------ impacts
    def johnson_bounds(self, m1, m2, v):
        return self.contact.johnson_bounds(m1, m2, abs(v))

    def impact_force(self, force):
        return self.contact.impact_force(np.abs(force))

    def describe(self) -> dict:
        out = super().describe()
        if "restitution" in {p.key for p in self.params}:
            out.setdefault("restitution", None)
        return out


@register
@dataclass(frozen=True)
class LinearLash(Lash):
    """Lash with a linear spring-damper contact on each side."""

    law_name: ClassVar[str] = "linear"
    summary: ClassVar[str] = "two-sided clearance: free while |d − offset| < clearance/2, a linear contact beyond either side"
    params: ClassVar[tuple[Param, ...]] = (*LASH_PARAMS, *_law_params(LinearContact))
    contact_class: ClassVar[type[Contact]] = LinearContact

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


class _NonlinearLash(Lash):
    """A lash whose law's force is nonlinear while a side is closed (integrated as F_nl)."""

    def is_nonlinear(self, branch):
        return branch in self.closed_branches

    def nonlinear_force(self, delta, delta_rate, v_impact=None):
        """The law's compressive force along the closed side's δ [N] (see :meth:`Lash.contact_side`)."""
        return self.contact.nonlinear_force(delta, delta_rate, v_impact)

    def nonlinear_force_scalar(self, delta: float, delta_rate: float, v_impact=None) -> float:
        return self.contact.nonlinear_force_scalar(delta, delta_rate, v_impact)

    def scalar_force(self, v_impact=None):
        return self.contact.scalar_force(v_impact)

    def nonlinear_tangent(self, delta, delta_rate, v_impact=None):
        return self.contact.nonlinear_tangent(delta, delta_rate, v_impact)


@register
@dataclass(frozen=True)
class PowerLash(_NonlinearLash):
    """Lash with a power-law (Hunt–Crossley) contact on each side."""

    law_name: ClassVar[str] = "power"
    summary: ClassVar[str] = "two-sided clearance with a power-law contact F = C·δ^a on each side"
    params: ClassVar[tuple[Param, ...]] = (*LASH_PARAMS, *_law_params(PowerContact))
    contact_class: ClassVar[type[Contact]] = PowerContact
    refused_hints: ClassVar[dict[str, str]] = PowerContact.refused_hints


#: An Adams IMPACT side's closed pieces in the contact's terms, and the lash's branch for each
#: (lower, upper): the law acting below its penetration depth, beyond it, and clamped at zero.
_ADAMS_PIECES: dict[Branch, tuple[Branch, Branch]] = {
    Branch.CLOSED: (Branch.CLOSED, Branch.CLOSED_HIGH),
    Branch.CLOSED_DEEP: (Branch.CLOSED_DEEP, Branch.CLOSED_DEEP_HIGH),
    Branch.CLAMPED: (Branch.CLAMPED, Branch.CLAMPED_HIGH),
}
#: The lash's branch → the contact's piece.
_ADAMS_PIECE_OF = {lash: piece for piece, pair in _ADAMS_PIECES.items() for lash in pair}


@register
@dataclass(frozen=True)
class AdamsImpactLash(_NonlinearLash):
    """Lash with an Adams IMPACT contact on each side.

    Each side has the contact's closed pieces as branches -- ``closed`` / ``closed-high``
    (inside the damping ramp), ``closed-deep`` / ``closed-deep-high`` (beyond it) and, with
    ``clamp``, ``clamped`` / ``clamped-high`` (the law would pull: no force until δ returns
    to 0 or the law pushes again) -- and the contact's kink guards, read through the side's
    penetration, so every kink of the law inside a closed phase is located like an event
    (no row of the event table), as for the contact. Stepped across, the clamp's kinks
    (where the damping ramp's pull outweighs k·δⁿ while the side unloads, and the law's
    push again just before the release) hid a force hump of ~1e-8 N·s from DOP853's error
    estimate between its stages: the release's speed then hung on where the steps fell
    (5e-8 m/s of 0.31 m/s, moved by the file's table order on a two-station machine)."""

    law_name: ClassVar[str] = "adams-impact"
    summary: ClassVar[str] = "two-sided clearance with an MSC Adams IMPACT contact on each side"
    params: ClassVar[tuple[Param, ...]] = (*LASH_PARAMS, *_law_params(AdamsImpactContact))
    contact_class: ClassVar[type[Contact]] = AdamsImpactContact
    locates_kinks: ClassVar[bool] = True

    @property
    def side_branches(self):
        pieces = (Branch.CLOSED, Branch.CLOSED_DEEP, Branch.CLAMPED) if self.clamp else (Branch.CLOSED,
                                                                                          Branch.CLOSED_DEEP)
        return tuple(tuple(_ADAMS_PIECES[p][k] for p in pieces) for k in (0, 1))

    def _contact_branch(self, branch):
        return _ADAMS_PIECE_OF.get(branch, Branch.CLOSED)

    def _lash_branch(self, contact_branch, sign):
        return _ADAMS_PIECES.get(contact_branch, _ADAMS_PIECES[Branch.CLOSED])[0 if sign > 0 else 1]

    def is_nonlinear(self, branch):
        return bool(self.side_of(branch))

    def acts(self, branch):
        return branch not in (Branch.CLAMPED, Branch.CLAMPED_HIGH)

    # The law is the contact's, unclamped: its clamp is a branch of each side (the engine
    # watches the unclamped law there to tell when it pushes again); the element's force
    # (Lash.force, the contact's on the side's piece) is clamped.

    def outcome_at(self, kind, rate, d):
        if kind in (GuardKind.KINK_UP, GuardKind.KINK_DOWN, GuardKind.CLAMP, GuardKind.UNCLAMP):
            sign = self.nearest(d)  # a kink happens inside a closed side: d is beyond it
            # the contact's own deflection d' = −δ of that side (its piece after UNCLAMP is at δ)
            own = d - self.low if sign > 0 else self.high - d
            piece = self.contact.outcome_at(kind, rate if sign > 0 else -rate, own).branch
            return Outcome(self._lash_branch(piece, sign))
        return super().outcome_at(kind, rate, d)

    def branch_from_state(self, d, no_impact):
        branch = super().branch_from_state(d, no_impact)
        sign = self.side_of(branch)
        if not sign:
            return branch
        return self._lash_branch(self.contact._piece(self.low - d if sign > 0 else d - self.high), sign)


@register
@dataclass(frozen=True)
class RigidLash(Lash):
    """Lash with a rigid stop on each side (Newton's law with restitution e, sticking)."""

    law_name: ClassVar[str] = "restitution"
    summary: ClassVar[str] = "two-sided clearance with a rigid stop on each side (Newton's law, sticks when at rest)"
    params: ClassVar[tuple[Param, ...]] = (*LASH_PARAMS, *_law_params(RigidContact))
    contact_class: ClassVar[type[Contact]] = RigidContact
    closed_branches: ClassVar[tuple[Branch, Branch]] = (Branch.STUCK, Branch.STUCK_HIGH)

    @classmethod
    def check(cls, values, error, driven) -> None:
        super().check(values, error, driven)
        if not values.get("clearance", 0.0) > 0.0:
            raise error("clearance", "a rigid lash needs clearance > 0 (with none, both stops hold the nodes "
                        "rigidly together: use a stiff spring)")

    def is_constraint(self, branch):
        return branch in self.closed_branches

    def stuck_branch(self, sign):
        return self.closed_branches[0 if sign > 0 else 1]

    def reported_constraint_force(self, branch, lam):
        return -self.side_of(branch) * lam  # tension-positive

    def force(self, branch, d, d_rate, damping, v_impact):
        return np.zeros_like(d)  # only on a constraint branch, whose force is λ

    def branch_at_rest(self, branch, d, constraint_force):
        if self.side_of(branch):
            return Branch.OPEN if constraint_force() < -FORCE_TOL else branch
        # Open at rest but through a stop: the equilibrium rests on that stop (as a rigid
        # contact closes at rest), not an error (that is for a given [initial] state).
        if self.penetration(d) > LENGTH_TOL:
            return self.closed_branches[0] if self.nearest(d) > 0 else self.closed_branches[1]
        return self.branch_from_state(d, False)

    def branch_from_state(self, d, no_impact):
        if no_impact:
            return Branch.OPEN
        delta = self.penetration(d)
        if delta > LENGTH_TOL:
            raise ValueError(f"the initial state penetrates the rigid lash {self.name} by {delta:.3g} m")
        if abs(delta) <= LENGTH_TOL:
            return self.closed_branches[0] if self.nearest(d) > 0 else self.closed_branches[1]
        return Branch.OPEN


DEFAULT_LAW["lash"] = LinearLash.law_name

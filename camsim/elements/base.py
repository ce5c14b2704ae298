"""The element protocol: what every element kind and contact law tells the rest of camsim.

An element kind (``type`` in the machine file) or contact law (``law``) is one class,
derived from :class:`Element` and registered with :func:`register` under the names the
machine file uses. The loader, the model, the integrator, the run and the docs ask the
class — its :attr:`Element.params` schema, its branches, forces, guards and event
outcomes — and never compare kind or law names themselves.

A new law is one module under ``camsim/elements/`` with one class; see
``docs/architecture.md`` ("Adding a contact law").
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from enum import Enum, StrEnum
from typing import Any, ClassVar

import numpy as np

from camsim.elements.events import EventKind

#: Node names that are not masses.
GROUND = "ground"
CAM = "cam"
FIXED_NODES = (GROUND, CAM)

#: A guard within this of zero at the start of a stretch counts as just crossed [m]
#: (0.1 pm: far below any deflection of interest, far above rounding of mm-size positions).
LENGTH_TOL = 1e-13
#: The same for force guards [N] (1 nN; see docs/model.md on grazing releases).
FORCE_TOL = 1e-9
#: The same for the dimensionless Hunt–Crossley factor of a damped power-law contact.
FACTOR_TOL = 1e-12


class Branch(str, Enum):
    """Branch states of switching elements (one linear law each)."""

    JOINED = "joined"  # preloaded link, d ≤ d_sep
    SEPARATED = "separated"  # preloaded link, d > d_sep
    OPEN = "open"  # contact carries no force
    CLOSED = "closed"  # compliant contact pressing (linear or power law); a lash's lower side
    CLOSED_HIGH = "closed-high"  # a lash pressing on its upper side (issue 12)
    STUCK = "stuck"  # rigid contact resting closed: a constraint; a rigid lash's lower side
    STUCK_HIGH = "stuck-high"  # a rigid lash resting closed on its upper side
    BILATERAL = "bilateral"  # no-impact variant: cam contact that never opens
    CLOSED_DEEP = "closed-deep"  # a closed contact past a kink of its law (Adams IMPACT beyond its damping ramp)
    CLAMPED = "clamped"  # penetrating, the law's force clamped at zero (watched, not acting; issue 34)
    CLOSED_DEEP_HIGH = "closed-deep-high"  # a lash's upper side past a kink of its law (ElastoGap's approach clip)
    CLAMPED_HIGH = "clamped-high"  # a lash's upper side penetrating, its law clamped at zero (ElastoGap)
    FREE = "free"  # a friction pair left out (the static equilibrium it starts stuck in)
    HELD = "held"  # a friction pair stuck: a constraint at the deflection it stuck at (spec §10)
    SLIDING_UP = "sliding-up"  # a friction pair sliding with ḋ > 0
    SLIDING_DOWN = "sliding-down"  # a friction pair sliding with ḋ < 0


class GuardKind(StrEnum):
    """What crossing a guard means; the element turns it into an :class:`Outcome`."""

    SEPARATE = "separate"  # a preloaded link reaches its separation deflection
    REJOIN = "rejoin"  # a separated link closes again
    CLOSE = "close"  # a contact closes: its penetration rises through zero (an impact)
    RELEASE = "release"  # a contact's force reaches zero
    UNLIFT = "unlift"  # a lifted compliant contact's penetration returns to zero
    REENGAGE = "reengage"  # a lifted compliant contact's law pushes again (no impact: issue 34)
    # A closed nonlinear law's kinks, located like events but no rows of the event table
    # (issue 34): its next piece, its previous one; its force clamped at zero, and pushing again.
    KINK_UP = "kink-up"
    KINK_DOWN = "kink-down"
    CLAMP = "clamp"
    UNCLAMP = "unclamp"
    # A friction pair (spec §10): its sliding velocity reaches zero (the engine's stick test);
    # its holding force reaches +F_B or −F_B (it slips up or down).
    HALT = "halt"
    SLIP_UP = "slip-up"
    SLIP_DOWN = "slip-down"
    # A friction pair whose normal force follows a program: it rises above zero, falls to zero.
    GRIP = "grip"
    LOOSEN = "loosen"


@dataclass(frozen=True)
class Param:
    """One key of an element's table in the machine file.

    Attributes
    ----------
    key : str
        The TOML key.
    dimension : str
        A dimension of :data:`camsim.units.DIMENSIONS` (``"stiffness"``...), ``"number"``
        (dimensionless, percent allowed), ``"bool"``, ``"choice"`` (one of ``choices``),
        ``"power_coefficient"`` (units N/m^a with the element's ``exponent``), or
        ``"law_table"`` (a table holding a law of the element's type and its keys: a lash's
        side, read into an element of that law).
    doc : str
        One line for the reference table.
    required : bool
    default : object
        SI value when the key is absent (None: absent).
    minimum, maximum : float or None
        Range; ``strict`` makes the minimum exclusive.
    example : str
        Shown in the "missing required key" message.
    field : str
        The attribute of the element class it sets (default: ``key``).
    choices : tuple of str
        The allowed values of a ``"choice"`` key.
    """

    key: str
    dimension: str
    doc: str
    required: bool = False
    default: Any = None
    minimum: float | None = None
    maximum: float | None = None
    strict: bool = False
    example: str = ""
    field: str = ""
    choices: tuple[str, ...] = ()

    @property
    def attribute(self) -> str:
        return self.field or self.key

    @property
    def unit(self) -> str:
        """The SI unit of the key (for docs, sweeps and studies)."""
        from camsim.units import DIMENSIONS

        if self.dimension == "power_coefficient":
            return "N/m^exponent"
        if self.dimension == "force_program":  # a force, or a table of its program
            return "N"
        return DIMENSIONS.get(self.dimension, "").replace("**", "^")


#: Keys every element takes.
COMMON_PARAMS: tuple[Param, ...] = (
    Param("name", "string", "unique name of the element", required=True),
    Param("type", "string", "element kind", required=True),
    Param("between", "nodes", "[lower, upper] node names (ground, cam or masses); deflection d = x_upper − x_lower", required=True),
)
#: The quadratic damping of springs and links (spec §10).
QUADRATIC_DAMPING = Param("quadratic_damping", "quadratic_damping", "c_q: f_q = c_q·ḋ·|ḋ| added to the force "
                          "(nonlinear: the element is integrated to tolerance)", default=0.0, minimum=0.0)
#: Keys of viscously damped kinds.
DAMPING_PARAMS: tuple[Param, ...] = (
    Param("damping", "damping", "viscous coefficient c (or damping_ratio, not both)", minimum=0.0),
    Param("damping_ratio", "number", "ζ: c = 2ζ·√(k·m_ref) per branch stiffness k", minimum=0.0),
    Param("reference_mass", "string", "mass m_ref of damping_ratio (default: upper node's, else lower's)"),
)


@dataclass(frozen=True)
class Damping:
    """How an element is damped: a coefficient [N·s/m], or a ratio ζ of critical.

    With a ratio, c = 2ζ·√(k·m_ref) per branch, m_ref being the mass named by
    ``reference_mass`` (default: the upper node's, or the lower node's when the upper is
    ground or the cam). At most one of ``coefficient`` and ``ratio`` is set.
    """

    coefficient: float | None = None
    ratio: float | None = None
    reference_mass: str | None = None


@dataclass(frozen=True)
class Outcome:
    """What crossing a guard does to an element.

    Attributes
    ----------
    branch : Branch or None
        The new branch (None: unchanged).
    event : EventKind or None
        The event to record (None: none).
    velocity : float
        The relative velocity recorded with it [m/s].
    v_impact : float or None
        Approach speed to remember for the contact (Hunt–Crossley damping) [m/s].
    rigid_impact : bool
        Newton's impact law applies (the integrator solves it, with any other rigid
        contact that is resting closed).
    """

    branch: Branch | None = None
    event: EventKind | None = None
    velocity: float = float("nan")
    v_impact: float | None = None
    rigid_impact: bool = False


@dataclass(frozen=True)
class Element:
    """Common part of every element: joins ``lower`` and ``upper`` along the axis.

    Deflection d = x_upper − x_lower; force f is tension-positive (acts −f on upper),
    except for :attr:`unilateral` elements (contacts), whose force is compressive-positive.
    Subclasses declare :attr:`params` and override the protocol methods below.
    """

    name: str
    lower: str
    upper: str
    damping: Damping = field(default_factory=Damping)
    #: The machine's cam nodes (``("cam",)`` unless the file has ``[[cam]]`` tables, issue 38):
    #: an element touching one of them is a cam contact (kept, bilateral, in the no-impact
    #: variant).
    cam_nodes: tuple[str, ...] = field(default=(CAM,), kw_only=True, compare=False, repr=False)

    #: Machine-file ``type`` (and ``law`` for contacts) this class is registered under.
    type_name: ClassVar[str] = ""
    law_name: ClassVar[str | None] = None
    #: The keys of its table, after :data:`COMMON_PARAMS`.
    params: ClassVar[tuple[Param, ...]] = ()
    #: One line for the docs.
    summary: ClassVar[str] = ""
    #: Contacts push only: compressive-positive force.
    unilateral: ClassVar[bool] = False
    #: Removed in the no-impact variant (spec §4).
    impact_only: ClassVar[bool] = False
    #: Key prefix → why this kind refuses such a key (appended to the loader's message).
    refused_hints: ClassVar[dict[str, str]] = {}
    #: A distributed element (a rod) that the model expands into lumped masses and
    #: springs (``expand``, ``interior_nodes``); never itself a term of the equations.
    compound: ClassVar[bool] = False
    #: Result quantities besides ``force`` a compound element records: name → (unit, long name).
    result_quantities: ClassVar[dict[str, tuple[str, str]]] = {}

    @property
    def nodes(self) -> tuple[str, str]:
        return (self.lower, self.upper)

    @property
    def at_cam(self) -> bool:
        """Whether one end is a cam node."""
        return self.lower in self.cam_nodes or self.upper in self.cam_nodes

    def on_cams(self, cam_nodes: tuple[str, ...]) -> "Element":
        """The same element in a machine whose cam nodes are ``cam_nodes``."""
        import dataclasses

        return dataclasses.replace(self, cam_nodes=tuple(cam_nodes))

    @property
    def force_sense(self) -> str:
        """How the element's force is signed in results."""
        return "compressive-positive" if self.unilateral else "tension-positive"

    def reported_as(self, key: str) -> tuple[str, str]:
        """(element name, key) a message about ``key`` of this element names (a rod's segment
        names its rod's ``segments``)."""
        return self.name, key

    def parent(self) -> str | None:
        """The compound element this one is a part of (a rod's segment: the rod), else None."""
        return None

    def interior_nodes(self) -> tuple[str, ...]:
        """Nodes the element adds to the machine (a rod's ``<rod>[k]``); none for lumped elements."""
        return ()

    def node_mass(self, node: str) -> float:
        """Mass [kg] the element lumps at its end ``node`` (a rod's m/(2N)); 0 for lumped elements."""
        return 0.0

    # ------------------------------------------------------------------ loading
    #: Keys whose presence in a table selects this class over the law's (a variant of a type
    #: with laws, registered without one: a lash with ``lower``/``upper`` tables).
    selected_by: ClassVar[tuple[str, ...]] = ()

    @classmethod
    def for_table(cls, row: dict[str, Any]) -> type["Element"]:
        """The class that reads the machine file's table ``row`` of this kind and law: itself,
        or a variant its keys select (:attr:`selected_by`)."""
        for variant in variants(cls.type_name):
            if variant is not cls and any(key in row for key in variant.selected_by):
                return variant
        return cls

    @classmethod
    def check(cls, values: dict[str, Any], error: Callable[[str, str], Exception], driven: str | None) -> None:
        """Cross-key checks after each key parsed (raise ``error(key, message)``)."""

    # ------------------------------------------------------------------ branches
    def branches(self, no_impact: bool) -> tuple[Branch, ...]:
        """Branches the element can be on (empty: it never switches)."""
        return ()

    def branch_stiffnesses(self) -> dict[str, float]:
        """Stiffness of each branch that a damping ratio refers to, by damping name."""
        return {}

    def damping_coefficients(self, reference_mass: Callable[[], float],
                             reduced_mass: Callable[[], float] | None = None) -> dict[str, float]:
        """Viscous coefficient [N·s/m] per damping name (see :meth:`branch_stiffnesses`).

        ``reference_mass()`` gives m_ref [kg] of a damping ratio (``reference_mass(name)``: the
        mass named ``name``, for an element whose parts name their own); ``reduced_mass`` gives
        m1·m2/(m1 + m2) of the element's two nodes [kg] (a fixed or driven node counts as
        infinite), for laws whose damping follows from a restitution.
        """
        stiffnesses = self.branch_stiffnesses()
        d = self.damping
        if not stiffnesses:
            return {}
        if d.coefficient is not None:
            return {key: d.coefficient for key in stiffnesses}
        if d.ratio:
            m_ref = reference_mass()
            return {key: 2.0 * d.ratio * math.sqrt(k * m_ref) for key, k in stiffnesses.items()}
        return {key: 0.0 for key in stiffnesses}

    def linear_law(self, branch: Branch | None, damping: dict[str, float]) -> tuple[float, float, float] | None:
        """(k, c, f0) with tension f = k·d + c·ḋ + f0 on a linear branch; None if no force."""
        return None

    def is_constraint(self, branch: Branch | None) -> bool:
        """True when the branch holds the nodes rigidly together (a constraint)."""
        return False

    def acting(self, branch: Branch | None) -> "Element":
        """The element whose law acts on ``branch``: itself, except for an element made of
        laws that differ by branch (a lash with a table per side answers with that side's
        lash). The engine asks it for a closed nonlinear law's force (``nonlinear_force``...)
        and an impact's Johnson bounds, which are not asked by branch."""
        return self

    def is_nonlinear(self, branch: Branch | None) -> bool:
        """True when the branch's force is nonlinear (integrated as F_nl)."""
        return False

    def linear_part(self, branch: Branch | None, damping: dict[str, float]) -> tuple[float, float, float] | None:
        """(k, c, f0) of a nonlinear branch's linear part (its rest is F_nl): a spring with
        quadratic damping keeps its stiffness in the linear system, so the grid and the
        natural frequencies see it; None when the whole force is F_nl."""
        return None

    def nonlinear_at_rest(self, branch: Branch | None) -> bool:
        """Whether a nonlinear branch's F_nl acts at rest (False: it vanishes with the
        relative velocity, as quadratic damping does: the static equilibrium is linear)."""
        return True

    def acts(self, branch: Branch | None) -> bool:
        """Whether a nonlinear branch's F_nl acts on the masses (False: it is only watched —
        a law clamped at zero whose unclamped value tells when it pushes again)."""
        return True

    def contact_side(self, branch: Branch | None, d: float | None = None) -> tuple[float, float]:
        """(σ, g) of the contact acting on ``branch``: penetration δ = σ·(g − d) [-, m].

        Asked of elements whose branch is nonlinear or a constraint: the contact force F
        (compressive along δ) acts σ·F·G on the free masses, and a constraint holds
        σ·(G·x + g_s·s) = σ·g. Contacts: (1, gap). A two-sided element (a lash) answers
        for the side closed on ``branch``, or, when open, the side nearest deflection ``d``.
        """
        return 1.0, 0.0

    def stuck_branch(self, sign: float) -> Branch:
        """The constraint branch of a rigid contact resting on side ``sign`` (σ of :meth:`contact_side`)."""
        return Branch.STUCK

    def reported_constraint_force(self, branch: Branch | None, lam: np.ndarray) -> np.ndarray:
        """The reported force [N] of a constraint branch from its compressive force λ [N]."""
        return lam

    def outcome_at(self, kind: GuardKind, rate: float, d: float) -> Outcome:
        """:meth:`outcome`, knowing the deflection ``d`` at the crossing [m] (two-sided elements)."""
        return self.outcome(kind, rate)

    def force(self, branch: Branch | None, d: np.ndarray, d_rate: np.ndarray, damping: dict[str, float],
              v_impact: float | None) -> np.ndarray:
        """The element's reported force on samples [N] (not on a constraint branch)."""
        law = self.linear_law(branch, damping)
        if law is None:
            return np.zeros_like(d)
        k, c, f0 = law
        return k * d + c * d_rate + f0

    def penetration(self, d: float) -> float:
        """δ such that the element closes as δ grows: −d (contacts: gap − d) [m]."""
        return 0.0 - d

    # ------------------------------------------------------------------ events
    def guards(self, branch: Branch, ctx) -> list[tuple[GuardKind, Any, float]]:
        """Guards keeping the branch valid while > 0: (kind, Affine, tolerance)."""
        return []

    def guard_key(self, branch: Branch, ctx) -> Any:
        """What, besides the configuration, this element's :meth:`guards` depend on: a
        hashable (the engine keeps the guards of each configuration and key, issue 42). The
        default is the element's impact speed (a power law's damping reads it); an element
        whose guards read the state (``ctx.now``) says what they read of it."""
        return ctx.v_impact

    def outcome(self, kind: GuardKind, rate: float) -> Outcome:
        """What crossing a guard of ``kind`` does; ``rate`` is δ̇ = −ḋ at the crossing [m/s]."""
        return Outcome()

    def branch_at_rest(self, branch: Branch, d: float, constraint_force: Callable[[], float]) -> Branch:
        """The branch implied by deflection ``d`` at rest (static equilibrium iteration)."""
        return branch

    def branch_from_state(self, d: float, no_impact: bool) -> Branch:
        """The branch at a given initial deflection (``[initial]``); ValueError if impossible."""
        return self.branches(no_impact)[0]

    # ------------------------------------------------------------------ impacts
    #: The event that ends a contact this element's impact began.
    closing_ends: ClassVar[EventKind] = EventKind.RELEASE

    def johnson_bounds(self, m1: float, m2: float, v: float) -> tuple[float, float] | None:
        """Johnson's lower and upper impact-force bounds [N] (spec §5); None if not defined."""
        return None

    def impact_force(self, force: np.ndarray) -> np.ndarray | None:
        """The force whose peak is an impact's simulated peak (None: no finite peak)."""
        return force

    def impact_duration(self, m1: float, m2: float, v: float) -> float | None:
        """Estimated duration [s] of an undamped impact between masses ``m1`` and ``m2`` [kg]
        (either may be ``inf``) approaching at ``v`` [m/s]; None when the element has no
        compliant impact (a rigid contact, a spring). Used to choose a rod's segments."""
        return None

    def stress(self, peak_force: float) -> dict | None:
        """Contact stress at ``peak_force`` [N] against the materials' yield (Hertz contacts), else None."""
        return None

    # ------------------------------------------------------------------ description
    def damping_note(self) -> str | None:
        """How the element is damped when not viscously (for ``camsim validate``)."""
        return None

    def describe(self) -> dict[str, Any]:
        """The element's SI parameters as a JSON-able dict (validate, lump, ``machine_to_dict``)."""
        out: dict[str, Any] = {"name": self.name, "lower": self.lower, "upper": self.upper, "type": self.type_name}
        if self.law_name is not None:
            out["law"] = self.law_name
        for p in self.params:
            if p.dimension == "string" or p.key in ("damping", "damping_ratio", "reference_mass", "law"):
                continue
            out[p.key] = getattr(self, p.attribute)
        return out


def pair_mass(m1: float, m2: float) -> float:
    """m1·m2/(m1 + m2) [kg], either mass may be ``inf`` (not both)."""
    if math.isinf(m1):
        return m2
    if math.isinf(m2):
        return m1
    return m1 * m2 / (m1 + m2)


# ---------------------------------------------------------------------- the registry
_REGISTRY: dict[tuple[str, str | None], type[Element]] = {}
#: The law a contact has when the file names none.
DEFAULT_LAW: dict[str, str] = {}


def register(cls: type[Element]) -> type[Element]:
    """Class decorator: make ``cls`` the element for its ``type_name`` (and ``law_name``)."""
    key = (cls.type_name, cls.law_name)
    if key in _REGISTRY:
        raise ValueError(f"element kind {key} registered twice")
    _REGISTRY[key] = cls
    return cls


def element_types() -> tuple[str, ...]:
    """The ``type`` names a machine file may use, in registration order."""
    return tuple(dict.fromkeys(t for t, _ in _REGISTRY))


def laws_of(type_name: str) -> tuple[str, ...]:
    """The ``law`` names of an element type (empty for types without laws)."""
    return tuple(law for t, law in _REGISTRY if t == type_name and law is not None)


def element_class(type_name: str, law: str | None = None) -> type[Element]:
    """The class registered for ``type`` (and ``law``); KeyError if none."""
    if law is None and laws_of(type_name):
        law = DEFAULT_LAW[type_name]
    return _REGISTRY[(type_name, law)]


def variants(type_name: str) -> list[type[Element]]:
    """Classes of a type with laws that no ``law`` names (chosen by their keys: :meth:`Element.for_table`)."""
    return [cls for (t, law), cls in _REGISTRY.items() if t == type_name and law is None and laws_of(type_name)]


def classes() -> list[type[Element]]:
    """Every registered element class, in registration order."""
    return list(_REGISTRY.values())


def type_keys(type_name: str) -> tuple[str, ...]:
    """Every key a table of ``type`` may hold, over all its laws (without the common ones)."""
    keys: dict[str, None] = {}
    for (t, _), cls in _REGISTRY.items():
        if t == type_name:
            keys.update((p.key, None) for p in cls.params)
    return tuple(keys)


def key_laws(type_name: str) -> dict[str, tuple[str, ...]]:
    """For each key of a type with laws, the laws that take it."""
    out: dict[str, list[str]] = {}
    for (t, law), cls in _REGISTRY.items():
        if t == type_name and law is not None:
            for p in cls.params:
                out.setdefault(p.key, []).append(law)
    return {k: tuple(v) for k, v in out.items()}


def param(type_name: str, key: str, law: str | None = None) -> Param | None:
    """The :class:`Param` of ``key`` in a table of ``type`` (any law when ``law`` is None)."""
    for (t, l_), cls in _REGISTRY.items():
        if t == type_name and (law is None or l_ == law):
            for p in (*COMMON_PARAMS, *cls.params):
                if p.key == key:
                    return p
    return None

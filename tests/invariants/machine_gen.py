"""Hypothesis strategies for well-formed camsim machine files (the invariant suite).

A machine is first drawn as a :class:`MachineSpec` (plain SI numbers), then written as
TOML text by :func:`render`, in SI or in US customary units, with its ``[[mass]]`` and
``[[element]]`` tables in any order. The invariants compare runs of texts rendered from
the same spec, so the spec is the one source of the numbers.

What is drawn (spec §3, §6):

* a cam program of 2-4 motions between dwells, every law of spec §2, 60-150 deg per
  motion, lifts 2-15 mm at the roller, an optional linkage ratio; speeds 600-1800 rpm
  (revolutions of 33-100 ms, so that a 500 kHz run stays well under a second);
* 1-4 masses (0.05-2 kg) in a chain above the cam. The cam drives the first mass
  (``cam.drives``), or acts on it through a contact of any law (linear, power,
  restitution = rigid, adams-impact) or through a lash of any law; a closure spring from
  ground holds the first mass with a preload drawn *around the jump onset* (0.5-2 times
  the force that the largest deceleration of the cam needs), so that the runs straddle
  the speed at which the follower leaves the cam;
* each further mass hangs on the previous one by a spring or a preloaded over-travel link,
  optionally doubled by a contact or a lash of any law, optionally stopped by a seat
  (a ground contact of any law with a gap inside the lift, as the thesis machine's seat);
* gravity on or off; an ``[initial]`` table (a drop of the last mass, or a velocity) or
  not;
* with ``several_contacts`` (issue 34): three masses, the cam acting on the first through
  a contact (the cam node moves with s(t), the follower may leave it) and a concentric
  *disc* under it as well (a ground contact whose surface is inside the lift: the follower
  lands on it where the lobe drops below it), and the second mass *between two stops*: a
  seat under it (ground) and a stop carried by the third mass above it.

Stiffnesses stay within 1e3-3e6 N/m (natural frequencies below ~1.5 kHz), so a machine
runs in a fraction of a second at any sample rate of the suite.
"""

from __future__ import annotations

import math
import random
from dataclasses import dataclass, field

from hypothesis import strategies as st

#: Laws of spec §2 and their peak normalised accelerations C_a (y'' max for β = 1).
LAW_PEAK = {
    "cycloidal": 2 * math.pi,
    "harmonic": math.pi**2 / 2,
    "modified-trapezoid": 4.8881,
    "modified-sine": 5.5280,
    "poly345": 5.7735,
    "poly4567": 7.5107,
}
CONTACT_LAWS = ("linear", "power", "restitution", "adams-impact")

# US customary units, exactly as defined (NIST SP 811): the inch, the pound and the
# pound-force (lb × standard gravity).
INCH = 0.0254
POUND = 0.45359237
LBF = POUND * 9.80665

#: dimension tag → (SI unit text, US unit text, SI value of one US unit).
UNITS = {
    "length": ("m", "in", INCH),
    "mass": ("kg", "lb", POUND),
    "force": ("N", "lbf", LBF),
    "stiffness": ("N/m", "lbf/in", LBF / INCH),
    "damping": ("N*s/m", "lbf*s/in", LBF / INCH),
    "velocity": ("m/s", "in/s", INCH),
    "acceleration": ("m/s^2", "in/s^2", INCH),
    "hysteresis": ("s/m", "s/in", 1.0 / INCH),
}


@dataclass
class Q:
    """A quantity: SI value and its dimension tag (``"power:1.5"`` for C of F = C·δ^a)."""

    value: float
    dim: str


@dataclass
class MachineSpec:
    """One machine in SI, before it is written as text."""

    rpm: float
    segments: list  # (motion, law | None, duration [deg], lift [m] at the roller)
    ratio: float | None
    drives: str | None
    masses: list  # (name, kg)
    elements: list  # dict: name, type, between, and keys → Q | str | float | bool
    gravity: bool
    initial: dict = field(default_factory=dict)  # mass → {"displacement": Q, "velocity": Q}
    warmup_cycles: int = 1
    cycles: int = 1
    sample_rate: float = 50_000.0
    mass_order: list | None = None  # permutation of masses for render (None: as drawn)
    element_order: list | None = None

    @property
    def period(self) -> float:
        """One revolution [s] (as camsim computes it: 2π/ω)."""
        return 2 * math.pi / (self.rpm * 2 * math.pi / 60.0)

    @property
    def linear(self) -> bool:
        """True when every element is a spring, preloaded link or linear contact."""
        return all(e["type"] in ("spring", "preloaded") or (e["type"] == "contact" and e.get("law") == "linear")
                   for e in self.elements)


# --------------------------------------------------------------------------- rendering
def _quantity(q: Q, us: bool) -> str | float:
    dim = q.dim
    if dim.startswith("power:"):
        a = float(dim.split(":")[1])
        if us:  # C [N/m^a] → [lbf/in^a]
            return f"{q.value * INCH**a / LBF!r} lbf/in**{a!r}"
        return f"{q.value!r} N/m**{a!r}"
    if dim == "angle":
        return f"{q.value!r} deg"
    si, usu, factor = UNITS[dim]
    if us:
        return f"{q.value / factor!r} {usu}"
    return f"{q.value!r} {si}"


def _toml_value(v, us: bool) -> str:
    if isinstance(v, Q):
        v = _quantity(v, us)
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, (int, float)):
        return repr(v)
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(_toml_value(x, us) for x in v) + "]"
    return '"' + str(v) + '"'


def render(spec: MachineSpec, units: str = "SI", sample_rate: float | None = None) -> str:
    """The machine file of ``spec`` as TOML text.

    Parameters
    ----------
    spec : MachineSpec
    units : {"SI", "US"}
        Every dimensioned value in SI units or in US customary units (in, lb, lbf, lbf/in,
        lbf·s/in, in/s); speeds in rpm and angles in degrees either way.
    sample_rate : float, optional
        [Hz]; default ``spec.sample_rate``.
    """
    us = units == "US"
    out = ["schema = 1", "", "[machine]", 'name = "hypothesis machine"', "", "[cam]", f'speed = "{spec.rpm!r} rpm"']
    if spec.ratio is not None:
        out.append(f"ratio = {spec.ratio!r}")
    if spec.drives is not None:
        out.append(f'drives = "{spec.drives}"')
    out.append("segments = [")
    for motion, law, duration, lift in spec.segments:
        row = f'  {{ motion = "{motion}", duration = "{duration!r} deg"'
        if law is not None:
            row += f', law = "{law}", lift = {_toml_value(Q(lift, "length"), us)}'
        out.append(row + " },")
    out.append("]")
    masses = spec.masses if spec.mass_order is None else [spec.masses[i] for i in spec.mass_order]
    for name, kg in masses:
        out += ["", "[[mass]]", f'name = "{name}"', f"mass = {_toml_value(Q(kg, 'mass'), us)}"]
    elements = spec.elements if spec.element_order is None else [spec.elements[i] for i in spec.element_order]
    for e in elements:
        out += ["", "[[element]]"]
        for key, value in e.items():
            out.append(f"{key} = {_toml_value(value, us)}")
    out += ["", "[simulation]", f"cycles = {spec.cycles}", f"warmup_cycles = {spec.warmup_cycles}",
            f'sample_rate = "{(sample_rate or spec.sample_rate)!r} Hz"', f"gravity = {'true' if spec.gravity else 'false'}"]
    for name, values in spec.initial.items():
        out += ["", f"[initial.{name}]"]
        for key, q in values.items():
            out.append(f"{key} = {_toml_value(q, us)}")
    return "\n".join(out) + "\n"


# --------------------------------------------------------------------------- strategies
def _log_uniform(lo: float, hi: float):
    return st.floats(allow_subnormal=False, min_value=math.log(lo), max_value=math.log(hi)).map(math.exp)


@st.composite
def cam_programs(draw):
    """(segments, peak deceleration per unit ω² [m/rad²] at the roller, total lift [m])."""
    n_motions = draw(st.sampled_from([2, 2, 4]))
    durations = [draw(st.floats(allow_subnormal=False, min_value=60.0, max_value=150.0 if n_motions == 2 else 80.0)) for _ in range(n_motions)]
    dwell_total = 360.0 - sum(durations)
    dwells = [dwell_total / n_motions] * n_motions  # a dwell after each motion
    lift = draw(st.floats(allow_subnormal=False, min_value=0.002, max_value=0.015))
    segments, peak = [], 0.0
    for k in range(n_motions):
        motion = "rise" if k % 2 == 0 else "fall"
        law = draw(st.sampled_from(tuple(LAW_PEAK)))
        beta = math.radians(durations[k])
        peak = max(peak, LAW_PEAK[law] * lift / beta**2)
        segments.append((motion, law, durations[k], lift))
        segments.append(("dwell", None, dwells[k], 0.0))
    # durations must add up to 360 deg exactly as the loader sums them: let the last dwell
    # take the rounding
    total = sum(s[2] for s in segments[:-1])
    segments[-1] = ("dwell", None, 360.0 - total, 0.0)
    return segments, peak, lift


def _damping(draw, allow_restitution: bool) -> dict:
    choice = draw(st.sampled_from(["none", "ratio", "coefficient"] + (["restitution"] if allow_restitution else [])))
    if choice == "ratio":
        return {"damping_ratio": draw(st.floats(allow_subnormal=False, min_value=0.0, max_value=0.2))}
    if choice == "coefficient":
        return {"damping": Q(draw(st.floats(allow_subnormal=False, min_value=0.0, max_value=50.0)), "damping")}
    if choice == "restitution":
        return {"restitution": draw(st.floats(allow_subnormal=False, min_value=0.3, max_value=1.0))}
    return {}


def _contact_law(draw, law: str, plain: bool = False) -> dict:
    """Law keys of a contact or lash (stiffness 1e4..3e6 N/m or its power-law equivalent);
    ``plain``: no restitution-given damping (the reference of invariant (e) takes c or ζ)."""
    if law == "linear":
        return {"law": "linear", "stiffness": Q(draw(_log_uniform(1e4, 3e6)), "stiffness"), **_damping(draw, not plain)}
    if law == "power":
        a = draw(st.sampled_from([1.0, 1.25, 1.5]))
        k_ref = draw(_log_uniform(1e4, 3e6))  # secant stiffness at 0.1 mm
        out = {"law": "power", "exponent": a, "coefficient": Q(k_ref * 1e-4 ** (1 - a), f"power:{a!r}")}
        damping = draw(st.sampled_from(["none", "restitution", "hysteresis"]))
        if damping == "restitution":
            out["restitution"] = draw(st.floats(allow_subnormal=False, min_value=0.3, max_value=1.0))
        elif damping == "hysteresis":
            out["hysteresis_damping"] = Q(draw(st.floats(allow_subnormal=False, min_value=0.0, max_value=2.0)), "hysteresis")
        return out
    if law == "restitution":
        return {"law": "restitution", "restitution": draw(st.sampled_from([0.0, 0.0, 0.3, 0.6]))}
    n = draw(st.sampled_from([1.0, 1.5]))
    k_ref = draw(_log_uniform(1e4, 3e6))
    return {"law": "adams-impact", "exponent": n, "stiffness": Q(k_ref * 1e-4 ** (1 - n), f"power:{n!r}"),
            "max_damping": Q(draw(st.floats(allow_subnormal=False, min_value=0.0, max_value=50.0)), "damping"),
            "penetration_depth": Q(draw(st.floats(allow_subnormal=False, min_value=1e-5, max_value=1e-3)), "length")}


@st.composite
def machine_specs(draw, linear: bool = False, max_masses: int = 4, nonlinear_laws: bool = True,
                  several_contacts: bool = False, cam_contact: bool = False):
    """A :class:`MachineSpec`.

    Parameters
    ----------
    linear : bool
        Only springs, preloaded links and linear contacts (the machines the independent
        reference of invariant (e) solves), the cam driving the first mass or acting
        through a linear contact.
    max_masses : int
    nonlinear_laws : bool
        False: no power-law or Adams IMPACT contact (linear and rigid contacts only).
    several_contacts : bool
        Several contacts on one mass: three masses; a contact from the moving cam and a
        disc (a ground contact) on the first; a seat under the second and a stop on it
        from the third (issue 34).
    cam_contact : bool
        The cam acts on the first mass through a contact or a lash, never drives it: the
        cam node moves with s(t) and the follower may leave it (issue 34).
    """
    laws = ("linear",) if linear else CONTACT_LAWS if nonlinear_laws else ("linear", "restitution")
    nonlinear = []  # at most one power-law or adams-impact contact: they step by collocation,
    # ~10x the cost of a linear step, and a 500 kHz run must stay well under a second

    def law_of():
        law = draw(st.sampled_from(laws if not nonlinear else tuple(x for x in laws if x in ("linear", "restitution"))))
        if law in ("power", "adams-impact"):
            nonlinear.append(law)
        return law

    segments, peak, lift = draw(cam_programs())
    rpm = draw(st.floats(allow_subnormal=False, min_value=600.0, max_value=1800.0))
    ratio = draw(st.one_of(st.none(), st.floats(allow_subnormal=False, min_value=0.5, max_value=1.5)))
    model_lift = lift * (ratio or 1.0)
    omega = rpm * 2 * math.pi / 60.0
    n = 3 if several_contacts else draw(st.integers(min_value=1, max_value=max_masses))
    names = [f"M{k + 1}" for k in range(n)]
    masses = [(name, draw(_log_uniform(0.05, 2.0))) for name in names]
    gravity = draw(st.booleans())
    couplings = ["drives", "contact"] if linear else ["drives", "contact", "contact", "lash"]
    if cam_contact:
        couplings = [c for c in couplings if c != "drives"]
    coupling = "contact" if several_contacts else draw(st.sampled_from(couplings))
    elements: list[dict] = []
    # The closure spring holds the chain against the cam. Its preload is drawn around the
    # jump onset: the force that the chain's mass needs at the cam's largest deceleration.
    m_chain = sum(kg for _, kg in masses)
    k_close = draw(_log_uniform(1e3, 3e4))
    need = m_chain * peak * (ratio or 1.0) * omega**2 - 0.5 * k_close * model_lift
    onset = draw(st.floats(allow_subnormal=False, min_value=0.5, max_value=2.0))
    preload = max(1.0, onset * need)
    elements.append({"name": "closure", "type": "spring", "between": ["ground", "M1"],
                     "stiffness": Q(k_close, "stiffness"), "preload": Q(preload, "force"), **_damping(draw, False)})
    drives = None
    if coupling == "drives":
        drives = "M1"
    elif coupling == "contact":
        law = law_of()
        elements.append({"name": "roller", "type": "contact", "between": ["cam", "M1"], **_contact_law(draw, law, linear)})
        if several_contacts:
            # a concentric disc beside the lobe: its surface inside the lift, so that the
            # follower lands on it where the lobe drops below it. Not rigid under a rigid
            # lobe: two rigid contacts on one degree of freedom, stuck together at the
            # crossing, are refused by the rigid solver ("over-constrain the masses": a
            # known limit, docs/model.md "Events at one instant")
            disc_law = law_of()
            while disc_law == "restitution" and law == "restitution":
                disc_law = law_of()
            elements.append({"name": "disc", "type": "contact", "between": ["ground", "M1"],
                             "gap": Q(draw(st.floats(allow_subnormal=False, min_value=0.1, max_value=0.9)) * model_lift, "length"),
                             **_contact_law(draw, disc_law, linear)})
    else:
        law = law_of()
        clearance = draw(st.floats(allow_subnormal=False, min_value=2e-5, max_value=2e-4))
        # free while 0 < d < clearance (offset = clearance/2): the closure spring keeps
        # the follower on the lower face, d ≤ 0; the upper face catches it when it jumps
        elements.append({"name": "yoke", "type": "lash", "between": ["cam", "M1"], "clearance": Q(clearance, "length"),
                         "offset": Q(clearance / 2, "length"), **_contact_law(draw, law, linear)})
    for k in range(1, n):
        lower, upper = names[k - 1], names[k]
        kind = draw(st.sampled_from(["spring", "preloaded"]))
        if kind == "spring":
            elements.append({"name": f"k{k}{k + 1}", "type": "spring", "between": [lower, upper],
                             "stiffness": Q(draw(_log_uniform(1e4, 1e6)), "stiffness"), **_damping(draw, False)})
        else:
            k_push = draw(_log_uniform(1e5, 3e6))
            elements.append({"name": f"k{k}{k + 1}", "type": "preloaded", "between": [lower, upper],
                             "push_stiffness": Q(k_push, "stiffness"),
                             "pull_stiffness": Q(draw(_log_uniform(1e3, 1e5)), "stiffness"),
                             "preload": Q(draw(_log_uniform(1.0, 100.0)), "force"), **_damping(draw, False)})
        extra = draw(st.sampled_from(["none", "none", "contact", "lash"] if not linear else ["none", "contact"]))
        if several_contacts:
            extra = "contact" if k == 2 else "none"  # M2 between its seat and M3's stop
        if extra == "contact":
            elements.append({"name": f"stop{k}{k + 1}", "type": "contact", "between": [lower, upper],
                             "gap": Q(draw(st.floats(allow_subnormal=False, min_value=1e-5, max_value=5e-4)), "length"),
                             **_contact_law(draw, law_of(), linear)})
        elif extra == "lash":
            elements.append({"name": f"lash{k}{k + 1}", "type": "lash", "between": [lower, upper],
                             "clearance": Q(draw(st.floats(allow_subnormal=False, min_value=1e-4, max_value=1e-3)), "length"),
                             **_contact_law(draw, law_of(), linear)})
        if (k == 1) if several_contacts else draw(st.booleans()):
            elements.append({"name": f"seat{k + 1}", "type": "contact", "between": ["ground", upper],
                             "gap": Q(draw(st.floats(allow_subnormal=False, min_value=0.1, max_value=0.6)) * model_lift, "length"),
                             **_contact_law(draw, law_of(), linear)})
    free = [name for name in names if name != drives]
    initial = {}
    if free and draw(st.integers(min_value=0, max_value=3)) == 0:
        name = free[-1]
        touching = [e for e in elements if name in e["between"]]
        rigid = [e for e in touching if e["type"] == "lash" or e.get("law") == "restitution"]
        if draw(st.booleans()) and not rigid and not any(e["between"] == ["ground", name] for e in touching):
            # a drop: the mass starts above its rest position, at rest (not where it would
            # sit inside a rigid stop: that is an input error, tested elsewhere)
            initial[name] = {"displacement": Q(draw(st.floats(allow_subnormal=False, min_value=1e-4, max_value=2e-3)), "length")}
        else:
            initial[name] = {"velocity": Q(draw(st.floats(allow_subnormal=False, min_value=-0.3, max_value=0.3)), "velocity")}
    warmup = draw(st.sampled_from([0, 1]))
    spec = MachineSpec(rpm=rpm, segments=segments, ratio=ratio, drives=drives, masses=masses, elements=elements,
                       gravity=gravity, initial=initial, warmup_cycles=warmup, cycles=1)
    return spec


def permuted(spec: MachineSpec, seed: int) -> MachineSpec:
    """The same machine with its mass and element tables in another order."""
    rng = random.Random(seed)
    mass_order = list(range(len(spec.masses)))
    element_order = list(range(len(spec.elements)))
    rng.shuffle(mass_order)
    rng.shuffle(element_order)
    if len(element_order) > 1 and element_order == sorted(element_order):
        element_order.reverse()
    return MachineSpec(**{**spec.__dict__, "mass_order": mass_order, "element_order": element_order})


def nudged(spec: MachineSpec, ulps: int) -> MachineSpec:
    """The same machine with every dimensioned value (masses, stiffnesses, forces, lengths,
    damping...) multiplied by 1 + ulps·2⁻⁵², about what a unit conversion's rounding does."""
    import copy

    factor = 1.0 + ulps * 2.0**-52
    out = copy.deepcopy(spec)
    out.masses = [(name, kg * factor) for name, kg in out.masses]
    for e in out.elements:
        for key, value in e.items():
            if isinstance(value, Q):
                e[key] = Q(value.value * factor, value.dim)
    for values in out.initial.values():
        for key, q in values.items():
            values[key] = Q(q.value * factor, q.dim)
    return out

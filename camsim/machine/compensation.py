"""Dynamic compensation (polydyne cam design) of a machine's cam (issue 27, spec §2).

With ``[cam.compensation] output = "M3"`` the written program is the motion y(t) wanted at
the output mass at the design speed ω, not the cam's. This module computes the cam
displacement s(t) (model axis) that moves the output exactly as y, for the machine as
the spec takes it for the design: contacts on the path closed, contacts off the path open,
preloaded links on their held (joined) branch.

**The walk up the path.** The path is the chain of nodes n₀ = output, n₁, …, n_P = the cam
(or the mass the cam drives), joined by the elements E_j between n_{j−1} and n_j (parallel
elements between the same two nodes act together). With δ_j = x(n_j) − x(n_{j−1}), the
linear law of each element gives the force of E_j on n_{j−1} as K_j·δ_j + C_j·δ̇_j + F0_j.
Mass n_{j−1}, whose motion is already known, needs from E_j the force

    Q_j = m·ẍ + m·g − (forces of every other element on it),

the other elements being the one below it on the path (its reaction −Q_{j−1}), springs and
links to ground or to nodes already known, and open contacts (no force). Then

* undamped (C_j = 0): δ_j = (Q_j − F0_j)/K_j, algebraic — for one mass on a spring
  s = y + (m/k)·ÿ (+ preload and weight)/k;
* damped: C_j·δ̇ + K_j·δ = Q_j − F0_j, a linear first-order equation whose periodic
  solution is taken in the frequency domain (δ̂ₙ = ĝₙ/(K_j + i·n·ω·C_j) on a uniform grid
  of 2¹⁵ points a revolution; the signal is smooth, so the sampling error is spectrally
  small) and whose derivatives follow exactly from the equation itself:
  δ⁽ᵏ⁾ = (g⁽ᵏ⁻¹⁾ − K_j·δ⁽ᵏ⁻¹⁾)/C_j. That recursion multiplies the error of δ⁽ᵏ⁻¹⁾ by
  K/(C·ω) at every order (ω the signal's frequency): harmless for a well-damped element
  (about 80 per order for the CDTM's links at ζ = 0.06), ruinous for a nearly undamped
  one (8e7 per order at ζ = 6e-8: the cam's third derivative came out 1e15 times too
  large and the run blew up, issue 34). Where the recursion would multiply the error by
  more than :data:`RECURSION_GAIN_MAX` over the orders the cam needs, the solution is
  split into its quasi-static expansion and a remainder,
  δ = Σ_{j<J} (−τ)ʲ·g⁽ʲ⁾/K + δ_r with τ = C/K and C·δ̇_r + K·δ_r = (−τ)ᴶ·g⁽ᴶ⁾
  (an identity: the sum telescopes), whose first J derivatives need no division by C
  (the remainder is (τ·ω)ᴶ smaller, which cancels the gain);
* rigid (a closed restitution contact): δ_j = its gap;

and x(n_j) = x(n_{j−1}) + δ_j. At the top, s = x(n_P).

An undamped path gives s as a finite combination of y and its derivatives (exact to any
order; :class:`camsim.cam.compensated.CompensatedProfile` ``"algebraic"``); a damped one a
periodic table of s, s′, s″, s‴ (``"table"``). Each mass costs two derivatives of y (one
less per damped element): s, v, a of the cam are continuous only if y is continuous up to
order 2N + 2 for N masses on an undamped path; otherwise the error names the join and the
derivative that jumps.

Not handled (errors, naming the element or mass): a nonlinear element on the path (power
law, Adams impact, lash), a path that is not a chain (an element from a path mass to a
node higher up the path, or a second route to the cam), an element from a path mass to a
mass off the path other than an open contact (off-path masses driven forward: not yet).
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from camsim.cam.compensated import CompensatedProfile
from camsim.cam.program import CamProgram
from camsim.elements import CAM, GROUND, Element
from camsim.elements.base import Branch
from camsim.machine.description import Cam, Machine

__all__ = ["CompensationError", "compensate", "GRID_POINTS", "RECURSION_GAIN_MAX", "assumption_warnings"]

#: Grid points over one revolution for a damped path's periodic solution.
GRID_POINTS = 2**15
#: Largest error gain the derivative recursion δ⁽ᵏ⁾ = (g⁽ᵏ⁻¹⁾ − K·δ⁽ᵏ⁻¹⁾)/C may have over the
#: orders the cam needs (the product of K/(C·ω_k) over them); above it the quasi-static
#: expansion takes over (:func:`_periodic`). The FFT leaves δ with an error near 1e-13 of
#: itself, so 1e9 keeps the needed derivatives to about 1e-4; the shipped machines (gain
#: 4e7 at ζ = 0.06) stay on the recursion, their numbers unchanged.
RECURSION_GAIN_MAX = 1e9
#: Cam-table orders the compensation delivers: s and its first three derivatives.
_TABLE_ORDERS = 4
_TWO_PI = 2.0 * math.pi
#: A derivative jump smaller than this fraction of its peak over the revolution is rounding.
_JUMP_TOLERANCE = 1e-8


class CompensationError(ValueError):
    """The compensation cannot be built; ``key`` is the machine-file key to name."""

    def __init__(self, key: str, message: str):
        super().__init__(message)
        self.key = key
        self.message = message


# ------------------------------------------------------------------------------- signals
class _Lin:
    """A signal Σ cₙ·y⁽ⁿ⁾(t) + c (time derivatives of the written output motion)."""

    def __init__(self, terms: dict[int, float] | None = None, const: float = 0.0):
        self.terms = {n: c for n, c in (terms or {}).items() if c != 0.0}
        self.const = const

    def deriv(self, k: int = 1) -> "_Lin":
        return _Lin({n + k: c for n, c in self.terms.items()}, 0.0)

    def __add__(self, other):
        if isinstance(other, (int, float)):
            return _Lin(self.terms, self.const + other)
        terms = dict(self.terms)
        for n, c in other.terms.items():
            terms[n] = terms.get(n, 0.0) + c
        return _Lin(terms, self.const + other.const)

    def __mul__(self, a: float) -> "_Lin":
        return _Lin({n: a * c for n, c in self.terms.items()}, a * self.const)

    def __sub__(self, other):
        return self + other * -1.0

    __rmul__ = __mul__

    @property
    def order(self) -> int:
        return max(self.terms, default=0)


class _Jet:
    """A periodic signal on the grid with its time derivatives: rows 0…L−1."""

    def __init__(self, rows: np.ndarray):
        self.rows = rows

    def deriv(self, k: int = 1) -> "_Jet":
        return _Jet(self.rows[k:])

    def __add__(self, other):
        if isinstance(other, (int, float)):
            rows = self.rows.copy()
            rows[0] = rows[0] + other
            return _Jet(rows)
        n = min(len(self.rows), len(other.rows))
        return _Jet(self.rows[:n] + other.rows[:n])

    def __mul__(self, a: float) -> "_Jet":
        return _Jet(a * self.rows)

    def __sub__(self, other):
        return self + other * -1.0

    __rmul__ = __mul__


def _zero_like(sig):
    if isinstance(sig, _Lin):
        return _Lin()
    return _Jet(np.zeros_like(sig.rows))


# ------------------------------------------------------------------------------- the path
def _damping(machine: Machine, e: Element) -> dict[str, float]:
    from camsim.physics.restitution import reduced_mass

    def ref(name=None):
        if name or e.damping.reference_mass is not None:
            return machine.mass_of(name or e.damping.reference_mass)
        name = e.lower if e.upper in (GROUND, CAM) else e.upper
        return machine.mass_of(name)

    return e.damping_coefficients(ref, lambda: reduced_mass(machine, e))


def _two_sided(e: Element) -> bool:
    """A clearance element (a lash): free inside its clearance, closed on either side."""
    return len(getattr(e, "closed_branches", ())) > 1


def _held_branch(e: Element):
    """The branch the design takes: a contact closed, a preloaded link joined (its first branch)."""
    if e.unilateral:
        return Branch.STUCK if e.is_constraint(Branch.STUCK) else getattr(e, "closed_branch", Branch.CLOSED)
    branches = e.branches(False)
    return branches[0] if branches else None


def _element_key(machine: Machine, e: Element) -> str:
    index = [x.name for x in machine.elements].index(e.name)
    return f"element[{index}]"


def _find_path(machine: Machine, output: str, top: set[str]) -> list[str]:
    """Nodes from the output to the cam, through masses only (breadth first)."""
    prev: dict[str, str | None] = {output: None}
    queue = [output]
    found = None
    while queue and found is None:
        node = queue.pop(0)
        for e in machine.elements:
            if node not in (e.lower, e.upper):
                continue
            other = e.upper if e.lower == node else e.lower
            if other == GROUND or other in prev:
                continue
            prev[other] = node
            if other in top:
                found = other
                break
            queue.append(other)
    if found is None:
        raise CompensationError("cam.compensation.output", f"{output} is not connected to the cam by elements "
                                "(through masses, not ground): there is no path to compensate")
    path = [found]
    while prev[path[-1]] is not None:
        path.append(prev[path[-1]])  # type: ignore[arg-type]
    return path[::-1]


def compensate(machine: Machine, grid_points: int = GRID_POINTS) -> Machine:
    """The machine with its cam replaced by the compensated cam (``cam.compensated`` set).

    Parameters
    ----------
    machine : Machine
        With ``cam.compensation`` set (the loader calls this).
    grid_points : int
        Grid of a damped path's periodic solution [-].

    Returns
    -------
    Machine
        ``cam.compensated`` is the :class:`CompensatedProfile`; ``cam.output_program`` the
        written program (a Cam without compensation) — the motion wanted at the output.

    Raises
    ------
    CompensationError
        Naming the key: a nonlinear element on the path, a program not smooth enough, a
        path that is not a chain, an off-path mass coupled to the path.
    """
    cam = machine.cam
    comp = cam.compensation
    for e in machine.elements:  # issue 39: a rod is many masses and springs; not compensated
        if e.compound:
            raise CompensationError(_element_key(machine, e), f"{e.name} is a rod: dynamic compensation works on "
                                    "lumped masses and springs; model the rod as a spring (its E*A/L) for the design")
    written = dataclasses.replace(cam, compensation=None, compensated=None, output_program=None, geometry=None)
    program = CamProgram(written)
    omega = comp.speed
    output = comp.output
    top = {CAM} | ({cam.drives} if cam.drives else set())
    path = _find_path(machine, output, top)
    index = {n: k for k, n in enumerate(path)}
    masses = {m.name: m.mass for m in machine.masses}
    g = machine.simulation.gravity

    # Group the elements: path groups E_j (between path[j-1] and path[j]) and the rest.
    groups: list[list[Element]] = [[] for _ in path]
    others: dict[str, list[Element]] = {n: [] for n in path}
    for e in machine.elements:
        ends = (e.lower, e.upper)
        lo_i = [index[n] if n in index else (len(path) - 1 if n in top else None) for n in ends]
        if all(i is not None for i in lo_i) and abs(lo_i[0] - lo_i[1]) == 1:
            groups[max(lo_i)].append(e)
            continue
        for n in ends:
            if n in index and n not in top:
                others[n].append(e)

    damped = False
    laws: list[list[tuple[Element, tuple | None, float]]] = [[] for _ in path]
    for j in range(1, len(path)):
        for e in groups[j]:
            key = _element_key(machine, e)
            branch = _held_branch(e)
            if e.is_constraint(branch) if branch is not None else False:
                sigma = 1.0 if e.lower == path[j - 1] else -1.0
                laws[j].append((e, None, sigma * e.gap))
                continue
            nonlinear = _two_sided(e) or e.is_nonlinear(branch)
            law = None if nonlinear else e.linear_law(branch, _damping(machine, e))
            if law is None:
                raise CompensationError(key, f"{e.name} is on the path from {output} to the cam and its force law "
                                        "is nonlinear; compensation needs linear elements on the path (springs, "
                                        "preloaded links, linear or rigid contacts)")
            if law[1] > 0.0:
                damped = True
            sigma = 1.0 if e.lower == path[j - 1] else -1.0
            laws[j].append((e, law, sigma))

    # The written output motion y(t) on the model axis, at the design speed.
    req_order = 2 + 2 * (len(path) - 1) + 4  # generous: y jets carried on the grid
    expansion = [0] * len(path)
    if damped:
        theta = np.arange(grid_points) * (_TWO_PI / grid_points)
        lift = program.lift_derivatives(theta, req_order)
        expansion, orders = _expansion_plan(laws, lift, omega)
        if orders > req_order:
            req_order = orders
            lift = program.lift_derivatives(theta, req_order)
        rows = np.array([cam.ratio * omega**n * lift[n] for n in range(req_order + 1)])
        y = _Jet(rows)
    else:
        theta = None
        y = _Lin({0: 1.0})

    x = {path[0]: y}
    reaction = _zero_like(y)  # force of the path element below on the current node
    orders_lost = 0
    for j in range(1, len(path)):
        node = path[j - 1]
        m = masses[node]
        xi = x[node]
        known = reaction
        for e in others[node]:
            other = e.upper if e.lower == node else e.lower
            if e.unilateral or _two_sided(e):
                continue  # off the path: open
            key = _element_key(machine, e)
            if other != GROUND and other not in x:
                where = "a node higher up the path" if other in index or other in top else f"mass {other}, off the path"
                raise CompensationError(key, f"{e.name} joins {node} (on the compensation path) to {where}: only a "
                                        "chain of elements from the output to the cam can be compensated")
            law = e.linear_law(_held_branch(e), _damping(machine, e))
            if law is None:
                continue
            k, c, f0 = law
            xo = _zero_like(y) if other == GROUND else x[other]
            d = (xo - xi) if e.lower == node else (xi - xo)
            tension = d * k + d.deriv() * c + f0 if c else d * k + f0
            known = known + (tension if e.lower == node else tension * -1.0)
        q = xi.deriv(2) * m - known + m * g  # the force E_j must put on node
        rigid = [t for t in laws[j] if t[1] is None]
        if rigid:
            delta = _zero_like(y) + rigid[0][2]
        else:
            K = sum(law[0] for _, law, _ in laws[j])
            C = sum(law[1] for _, law, _ in laws[j])
            F0 = sum(sigma * law[2] for _, law, sigma in laws[j])
            rhs = q - F0
            if C == 0.0:
                delta = rhs * (1.0 / K)
            else:
                delta = _periodic(rhs, K, C, omega, expansion[j])
                orders_lost -= 1
        x[path[j]] = xi + delta
        reaction = q * -1.0
        orders_lost += 2
    s = x[path[-1]]
    written_key = "cam.segments" if cam.segments else "cam.table"
    if isinstance(s, _Lin):
        need = s.order + 2
    else:
        need = req_order - len(s.rows) + 3
    _check_smooth(program, cam, need, len(path) - 1, written_key)
    names = tuple(e.name for grp in groups[1:] for e in grp)
    if isinstance(s, _Lin):
        # lift(θ) = s/ratio, y⁽ⁿ⁾(t) = ratio·ωⁿ·L⁽ⁿ⁾(θ)  →  lift = Σ cₙ ωⁿ L⁽ⁿ⁾ + const/ratio
        coeffs = tuple(sorted((n, c * omega**n) for n, c in s.terms.items()))
        profile = CompensatedProfile(written=written, output=output, speed=omega, kind="algebraic",
                                     coefficients=coeffs, offset=s.const / cam.ratio, path=names)
    else:
        rows = s.rows[:_TABLE_ORDERS]
        if not np.all(np.isfinite(rows)):  # a row _periodic could not form reached the cam
            raise AssertionError("compensation: the cam table's derivatives are not all available")
        jets = np.array([rows[n] / (cam.ratio * omega**n) for n in range(len(rows))])
        profile = CompensatedProfile(written=written, output=output, speed=omega, kind="table",
                                     theta=theta, jets=jets, path=names)
    new_cam = dataclasses.replace(cam, compensated=profile, output_program=written)
    return dataclasses.replace(machine, cam=new_cam)


def _expansion_plan(laws, lift: np.ndarray, omega: float) -> tuple[list[int], int]:
    """Terms J of the quasi-static expansion for each damped path element (0: the plain
    recursion), and the highest order of y the walk then needs.

    Walking down from the cam: the top element delivers δ up to order 3 (the table's s‴).
    An element that delivers orders up to k with J terms reads its right-hand side up to
    order k + J − 1, which holds the acceleration (two orders more) of the node below it,
    so the element below delivers orders up to k + J + 1. The recursion's error gain over
    k orders is estimated from the written motion's spectrum: g⁽ⁱ⁾ ~ y⁽ⁱ⁺²⁾, so
    K/(C·ω_i) ≈ K·‖y⁽ⁱ⁺¹⁾‖/(C·‖y⁽ⁱ⁺²⁾‖) (``lift``: θ-derivatives of y, ``omega`` [rad/s]).
    """
    peak = np.max(np.abs(lift), axis=1)
    # ‖L⁽ⁱ⁾‖/‖L⁽ⁱ⁺¹⁾‖ [rad]; a derivative that vanishes has nothing to amplify
    spacing = [peak[i] / peak[i + 1] if peak[i + 1] > 0.0 else 0.0 for i in range(len(peak) - 1)]

    def gain(K: float, C: float, orders: int) -> float:
        out = 1.0
        for i in range(1, orders + 1):
            out *= max(1.0, K * spacing[min(i + 1, len(spacing) - 1)] / (C * omega))
        return out

    plan = [0] * len(laws)
    need = _TABLE_ORDERS - 1
    for j in range(len(laws) - 1, 0, -1):
        linear = [law for _, law, _ in laws[j] if law is not None]
        K = sum(law[0] for law in linear)
        C = sum(law[1] for law in linear)
        if linear and len(linear) == len(laws[j]) and C > 0.0 and K > 0.0 and gain(K, C, need) > RECURSION_GAIN_MAX:
            plan[j] = need
        need += plan[j] + 1
    return plan, need


def _periodic(rhs, K: float, C: float, omega: float, terms: int = 0) -> _Jet:
    """Periodic solution δ of C·δ̇ + K·δ = rhs(t) and its derivatives.

    ``terms`` = 0: δ by FFT, its derivatives from the equation, δ⁽ᵏ⁾ = (g⁽ᵏ⁻¹⁾ − K·δ⁽ᵏ⁻¹⁾)/C.
    ``terms`` = J > 0 (a nearly undamped element, :func:`_expansion_plan`): the quasi-static
    expansion Σ_{j<J} (−τ)ʲ·g⁽ᵏ⁺ʲ⁾/K (τ = C/K, exact pointwise from the rows) plus the same
    FFT and recursion for the remainder C·δ̇_r + K·δ_r = (−τ)ᴶ·g⁽ᴶ⁾. Rows that would need g
    beyond its last row are NaN, so that no inexact row reaches the cam unnoticed. The
    result has one row more than ``rhs`` either way.
    """
    rows = rhs.rows
    n = rows.shape[1]
    period = _TWO_PI / omega
    freq = _TWO_PI / period * np.arange(n // 2 + 1)
    J = min(terms, len(rows) - 1)
    if J <= 0:
        d0 = np.fft.irfft(np.fft.rfft(rows[0]) / (K + 1j * freq * C), n)
        out = np.empty((len(rows) + 1, n))
        out[0] = d0
        for k in range(1, len(rows) + 1):
            out[k] = (rows[k - 1] - K * out[k - 1]) / C
        return _Jet(out)
    tau = C / K
    top = len(rows) - J  # the highest order both parts can form
    out = np.full((len(rows) + 1, n), np.nan)
    weights = (-tau) ** np.arange(J - 1, -1, -1)  # smallest term first
    for k in range(top + 1):
        out[k] = np.tensordot(weights, rows[k : k + J][::-1], axes=1) / K
    rest = rows[J:] * (-tau) ** J
    r = np.fft.irfft(np.fft.rfft(rest[0]) / (K + 1j * freq * C), n)
    out[0] += r
    for k in range(1, top + 1):
        r = (rest[k - 1] - K * r) / C
        out[k] += r
    return _Jet(out)


def _check_smooth(program: CamProgram, cam: Cam, need: int, n_masses: int, key: str) -> None:
    """The written program must be continuous up to derivative ``need`` at every join."""
    if program.kind == "table":
        if need > 4:
            raise CompensationError("cam.table", f"compensation through {n_masses} mass(es) needs the written "
                                    f"program continuous up to derivative {need}; a table profile (a quintic "
                                    "spline) is continuous up to derivative 4 only: write it as segments")
        return
    starts = program.boundary_angles()
    left = program.lift_derivatives(starts, need, side="left")
    right = program.lift_derivatives(starts, need, side="right")
    sample = program.lift_derivatives(np.linspace(0.0, _TWO_PI, 4001), need)
    scale = np.max(np.abs(sample), axis=1)
    names = ["displacement", "velocity", "acceleration", "jerk"] + [f"derivative {n}" for n in range(4, need + 1)]
    for k, th in enumerate(starts):
        for n in range(need + 1):
            jump = abs(right[n, k] - left[n, k])
            if jump > _JUMP_TOLERANCE * max(scale[n], 1e-300):
                before = (k - 1) % len(starts)
                raise CompensationError(
                    f"cam.segments[{k}]",
                    f"the {names[n]} (order {n}) of the written program jumps at the start of this segment (the "
                    f"join with cam.segments[{before}], {math.degrees(float(th)):g} deg); compensation through {n_masses} mass(es) needs it continuous "
                    f"up to order {need} (give the segments enough continuity, e.g. polynomial continuity = {need})")


def compensate_cams(machine: Machine, grid_points: int = GRID_POINTS) -> Machine:
    """The machine with every cam that has a ``compensation`` replaced by its compensated cam.

    One ``[cam]``: :func:`compensate`. Several ``[[cam]]`` tables (issue 38): each compensated
    cam is built on the machine as that cam sees it (its node named ``cam``, the elements that
    touch other cams left out), which holds when no other cam acts on its path to the output
    (an error otherwise: the other cams' motions would enter the compensation). Error keys
    name the cam's table, ``cam[i]....``.
    """
    if not machine.multi_cam:
        return compensate(machine, grid_points)
    cams = list(machine.cams)
    for i, cam in enumerate(cams):
        if cam.compensation is None:
            continue
        others = set(machine.cam_names) - {cam.name}

        def node(n: str, name: str = cam.name) -> str:
            return CAM if n == name else n

        elements = tuple(dataclasses.replace(e, lower=node(e.lower), upper=node(e.upper))
                         for e in machine.elements if not set(e.nodes) & others)
        view = dataclasses.replace(machine, cam=dataclasses.replace(cam, name=CAM, phase=0.0), cams=(),
                                   multi_cam=False, elements=elements)
        prefix = f"cam[{i}]"
        try:
            top = {CAM} | ({cam.drives} if cam.drives else set())
            path = _find_path(view, cam.compensation.output, top)
            for e in machine.elements:
                if set(e.nodes) & others and set(e.nodes) & set(path):
                    raise CompensationError(f"{prefix}.compensation.output",
                                            f"element {e.name} joins the compensation path to another cam: a cam's "
                                            "compensation needs a path that no other cam acts on")
            done = compensate(view, grid_points).cam
        except CompensationError as exc:
            key = prefix + exc.key[3:] if exc.key.startswith("cam.") else exc.key
            raise CompensationError(key, exc.message.replace("cam.", f"{prefix}.")) from None
        cams[i] = dataclasses.replace(done, name=cam.name, phase=cam.phase)
    return dataclasses.replace(machine, cams=tuple(cams))


def assumption_warnings(machine: Machine, events) -> list[str]:
    """The compensation's own assumptions, checked on a simulated run (issue 35).

    The compensated cam is exact for the machine with the contacts on its path closed, the
    preloaded links on it joined and the contacts off it open (module docstring). A run in
    which a path contact opens (``release``), a path link separates (``separation``) or a
    contact off the path closes (``impact``, ``rejoin``, ``stick``) does not move the output
    as written from that moment: one warning per element, naming it and when it first did.

    Parameters
    ----------
    machine : Machine
        The simulated machine (nothing is checked without ``cam.compensated``).
    events : iterable of Event
        The run's events (``kind``, ``element``, ``time`` [s], ``angle_deg`` [deg]).
    """
    if machine.multi_cam:  # issue 38: each compensated cam, over the elements of its station
        out = []
        for cam in machine.cams:
            if getattr(cam, "compensated", None) is not None:
                station = _station_elements(machine, cam.name)
                out += [w.replace("[cam.compensation]", f"[cam {cam.name} compensation]")
                        for w in _assumption_warnings(cam, [e for e in events if e.element in station])]
        return out
    return _assumption_warnings(machine.cam, events)


def _station_elements(machine: Machine, cam_name: str) -> set[str]:
    """The elements reached from cam ``cam_name`` through masses (not through the ground or
    another cam): the station it drives."""
    stops = {GROUND, *machine.cam_names}
    seen, names, todo = {cam_name}, set(), [cam_name]
    while todo:
        node = todo.pop()
        for e in machine.elements:
            if node in e.nodes and e.name not in names:
                names.add(e.name)
                for other in e.nodes:
                    if other not in seen and other not in stops:
                        seen.add(other)
                        todo.append(other)
    return names


def _assumption_warnings(cam, events) -> list[str]:
    comp = getattr(cam, "compensated", None) if cam is not None else None
    if comp is None:
        return []
    on_path = set(comp.path)
    first: dict[str, tuple[str, object]] = {}
    for e in sorted(events, key=lambda e: e.time):
        kind = str(getattr(e.kind, "value", e.kind))
        if e.element in on_path and kind in ("release", "separation"):
            first.setdefault(e.element, (kind, e))
        elif e.element not in on_path and e.element != CAM and kind in ("impact", "rejoin", "stick"):
            first.setdefault(e.element, (kind, e))
    rpm = comp.speed * 60.0 / (2.0 * math.pi)
    chain = " - ".join(comp.path)
    out = []
    for name, (kind, e) in first.items():
        what = {"release": "opened (the design keeps it closed)", "separation": "separated (the design keeps it joined)"}.get(
            kind, "closed (the design keeps a contact off the path open)")
        angle = getattr(e, "angle_deg", float("nan"))
        where = f"t = {e.time:.6g} s" + (f", cam angle {angle:.5g} deg" if angle == angle else "")
        out.append(f"[cam.compensation]: {name} {what} at {where}: from then on {comp.output} does not follow the "
                   f"written motion (the cam is compensated for {rpm:.6g} rpm along {chain})")
    return out

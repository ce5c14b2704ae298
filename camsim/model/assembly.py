"""Model assembly: from a :class:`~camsim.machine.description.Machine` to linear branch systems.

The free masses obey M·ẍ = Σ element forces (+ gravity). Every element sits on one
linear *branch* between events (a link joined or separated, a contact open, closed or
stuck), so for a *configuration* — one branch per switching element — the state z obeys

    ż = A·z + B·u(t) + b + L·F_nl,        u = [s, ṡ, s̈, s⃛]

where u is the cam motion on the model axis and F_nl the forces of power-law contacts
that are closed (the only nonlinear terms). Rigid (restitution) contacts that are stuck
are constraints: the configuration then uses reduced coordinates q with
x = N·q + p0 + p_s·s (N an orthonormal null-space basis), and z = [q, q̇].

Everything observable (positions, velocities, accelerations of the free masses,
constraint forces) is an affine map of (z, u, F_nl) — an :class:`Affine` — so the
integrator can evaluate traces and event guards on whole arrays at once.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass, field

import numpy as np
import scipy.linalg

from camsim.elements.affine import N_INPUT, Affine
from camsim.elements import CAM, GROUND, Branch, Element
from camsim.errors import InputError
from camsim.physics.restitution import reduced_mass
from camsim.machine.description import Machine



@dataclass
class ElementGeometry:
    """How an element's deflection depends on the free coordinates and the cam.

    d = G·x + g_s·s (+ 0),  ḋ = G·v + g_s·ṡ.
    """

    G: np.ndarray  # (n,)
    g_s: float


@dataclass
class Configuration:
    """The linear system of one combination of branches (see module docstring)."""

    branches: tuple[Branch, ...]
    A: np.ndarray
    B: np.ndarray
    b: np.ndarray
    L: np.ndarray
    power_contacts: tuple[int, ...]  # element indices of closed power-law contacts (F_nl order)
    stuck_contacts: tuple[int, ...]  # element indices of stuck rigid contacts (λ order)
    x: Affine  # free-mass positions (n rows)
    v: Affine
    a: Affine
    lam: Affine  # constraint forces of stuck contacts, compressive-positive
    N: np.ndarray  # (n, nq) null-space basis (identity when unconstrained)
    p0: np.ndarray  # (n,)
    p_s: np.ndarray  # (n,)
    cache: dict = field(default_factory=dict, repr=False)

    @property
    def dim(self) -> int:
        return self.A.shape[0]

    @property
    def linear(self) -> bool:
        return not self.power_contacts

    def state_from_full(self, x: np.ndarray, v: np.ndarray, s: float, sdot: float) -> np.ndarray:
        """Reduced state z from full positions and velocities (projection onto the constraints)."""
        q = self.N.T @ (x - self.p0 - self.p_s * s)
        qd = self.N.T @ (v - self.p_s * sdot)
        return np.concatenate([q, qd])


class Model:
    """The assembled machine: free coordinates, element geometry, configurations.

    Parameters
    ----------
    machine : Machine
    no_impact : bool
        Build the no-impact variant (spec §4): contacts removed, preloaded links fixed on
        their joined branch, contacts with the cam made bilateral.
    """

    def __init__(self, machine: Machine, *, no_impact: bool = False):
        from camsim.model.rods import expand

        # issue 39: rods become lumped masses and springs here; the model (and the engine
        # under it) works on the expanded machine, results are named after the machine
        machine, self.compounds = expand(machine)
        self.machine = machine
        self.no_impact = no_impact
        self.driven = machine.cam.drives if machine.cam is not None else None
        self.free_names = [m.name for m in machine.free_masses]
        self.index = {name: i for i, name in enumerate(self.free_names)}
        self.n = len(self.free_names)
        self.mass = np.array([m.mass for m in machine.free_masses], dtype=float)
        self.gravity = machine.simulation.gravity
        self.driven_mass = machine.mass_of(self.driven) if self.driven else 0.0
        elements = [e for e in machine.elements if not (no_impact and e.impact_only)]
        self.elements: list[Element] = elements
        self.geometry = [self._geometry(e) for e in elements]
        self.switching = [i for i, e in enumerate(elements) if e.branches(no_impact)]
        self.damping = [e.damping_coefficients(lambda e=e: self.reference_mass(e),
                                               lambda e=e: reduced_mass(machine, e)) for e in elements]  # issue 12
        self._configs: dict[tuple[Branch, ...], Configuration] = {}
        #: compound element name → the indices of its parts in :attr:`elements` (issue 39)
        self.parts = {name: [i for i, e in enumerate(elements) if e.parent() == name] for name in self.compounds}

    # ------------------------------------------------------------------ geometry
    def node_coefficients(self, node: str) -> tuple[np.ndarray, float]:
        """x_node = e·x_free + c·s."""
        e = np.zeros(self.n)
        if node == GROUND:
            return e, 0.0
        if node == CAM or node == self.driven:
            return e, 1.0
        e[self.index[node]] = 1.0
        return e, 0.0

    def _geometry(self, element: Element) -> ElementGeometry:
        e_lo, c_lo = self.node_coefficients(element.lower)
        e_up, c_up = self.node_coefficients(element.upper)
        return ElementGeometry(G=e_up - e_lo, g_s=c_up - c_lo)

    def reference_mass(self, element: Element) -> float:
        """m_ref of a damping ratio [kg] (spec §3)."""
        if element.damping.reference_mass:
            return self.machine.mass_of(element.damping.reference_mass)
        for node in (element.upper, element.lower):
            if node not in (GROUND, CAM):
                return self.machine.mass_of(node)
        raise InputError(f"element {element.name}: no mass to reference its damping ratio to")

    # ------------------------------------------------------------------ element laws
    def linear_branch(self, index: int, branch: Branch | None) -> tuple[float, float, float] | None:
        """(k, c, f0) with tension f = k·d + c·ḋ + f0 on a linear branch; None if no force."""
        return self.elements[index].linear_law(branch, self.damping[index])

    def branch_options(self, index: int) -> tuple[Branch, ...]:
        """Branches element ``index`` can be on in this model."""
        return self.elements[index].branches(self.no_impact)

    def all_branch_combinations(self) -> list[tuple[Branch, ...]]:
        return list(itertools.product(*(self.branch_options(i) for i in self.switching)))

    def branch_of(self, branches: tuple[Branch, ...], index: int) -> Branch | None:
        if index in self.switching:
            return branches[self.switching.index(index)]
        return None

    def is_rigid(self, index: int, branch: Branch | None) -> bool:
        return self.elements[index].is_constraint(branch)

    # ------------------------------------------------------------------ assembly
    def configuration(self, branches: tuple[Branch, ...]) -> Configuration:
        """The (cached) linear system for one combination of branches."""
        config = self._configs.get(branches)
        if config is None:
            config = self._assemble(branches)
            self._configs[branches] = config
        return config

    def _assemble(self, branches: tuple[Branch, ...]) -> Configuration:
        n = self.n
        K = np.zeros((n, n))
        C = np.zeros((n, n))
        k_s = np.zeros(n)  # generalized force per unit s  (moves to the right-hand side)
        c_s = np.zeros(n)
        F0 = -self.mass * self.gravity  # constant generalized force
        power: list[int] = []
        rigid: list[int] = []
        for i, geo in enumerate(self.geometry):
            branch = self.branch_of(branches, i)
            if self.is_rigid(i, branch):
                rigid.append(i)
                continue
            if self.elements[i].is_nonlinear(branch):
                power.append(i)
                continue
            law = self.linear_branch(i, branch)
            if law is None:
                continue
            k, c, f0 = law
            # Tension f acts −f on the upper node, +f on the lower: Q = −f·G.
            K += k * np.outer(geo.G, geo.G)
            C += c * np.outer(geo.G, geo.G)
            k_s -= k * geo.G * geo.g_s
            c_s -= c * geo.G * geo.g_s
            F0 -= f0 * geo.G
        # Power-law contact force F (compressive) acts +F on the upper node: Q = F·G; a
        # contact on side σ of a two-sided element (a lash) acts σ·F·G (issue 12 hook).
        sides = {i: self.elements[i].contact_side(self.branch_of(branches, i)) for i in (*power, *rigid)}
        # (a watched law, clamped at zero, acts with a zero column: issue 34)
        P = np.array([sides[i][0] * self.geometry[i].G * float(self.elements[i].acts(self.branch_of(branches, i)))
                      for i in power]).T.reshape(n, len(power))

        if rigid:
            J = np.array([sides[i][0] * self.geometry[i].G for i in rigid])
            j_s = np.array([sides[i][0] * self.geometry[i].g_s for i in rigid])
            r0 = np.array([sides[i][0] * sides[i][1] for i in rigid])  # σ·(G·x + g_s·s) = σ·gap
            if np.linalg.matrix_rank(J) < len(rigid):
                raise InputError(
                    "rigid contacts " + ", ".join(self.elements[i].name for i in rigid)
                    + " over-constrain the masses when closed together"
                )
            N = scipy.linalg.null_space(J) if n else np.zeros((0, 0))
            pinv = np.linalg.pinv(J)
            p0 = pinv @ r0
            p_s = -pinv @ j_s
        else:
            J = np.zeros((0, n))
            N = np.eye(n)
            p0 = np.zeros(n)
            p_s = np.zeros(n)
        nq = N.shape[1]
        Mfull = np.diag(self.mass)
        Mr = N.T @ Mfull @ N
        Mr_inv = np.linalg.inv(Mr) if nq else np.zeros((0, 0))
        Kr = N.T @ K @ N
        Cr = N.T @ C @ N
        # Generalized force F = −K·x − C·v + k_s·s + c_s·ṡ + F0 with x = N q + p0 + p_s s.
        f_s = N.T @ (-K @ p_s + k_s)  # per s
        f_sd = N.T @ (-C @ p_s + c_s)  # per ṡ
        f_sdd = -N.T @ (Mfull @ p_s)  # per s̈ (inertia of the prescribed part)
        f_0 = N.T @ (-K @ p0 + F0)
        m = 2 * nq
        A = np.zeros((m, m))
        A[:nq, nq:] = np.eye(nq)
        A[nq:, :nq] = -Mr_inv @ Kr
        A[nq:, nq:] = -Mr_inv @ Cr
        B = np.zeros((m, N_INPUT))
        B[nq:, 0] = Mr_inv @ f_s
        B[nq:, 1] = Mr_inv @ f_sd
        B[nq:, 2] = Mr_inv @ f_sdd
        b = np.zeros(m)
        b[nq:] = Mr_inv @ f_0
        L = np.zeros((m, len(power)))
        L[nq:, :] = Mr_inv @ (N.T @ P)

        p = len(power)
        zeros_u = np.zeros((n, N_INPUT))
        # x = N q + p0 + p_s s
        Du_x = zeros_u.copy()
        Du_x[:, 0] = p_s
        x_map = Affine(np.hstack([N, np.zeros((n, nq))]), Du_x, np.zeros((n, p)), p0.copy())
        Du_v = zeros_u.copy()
        Du_v[:, 1] = p_s
        v_map = Affine(np.hstack([np.zeros((n, nq)), N]), Du_v, np.zeros((n, p)), np.zeros(n))
        # ẍ = N q̈ + p_s s̈,  q̈ = rows nq: of (A z + B u + b + L F)
        Du_a = N @ B[nq:]
        Du_a[:, 2] += p_s
        a_map = Affine(N @ A[nq:], Du_a, N @ L[nq:], N @ b[nq:])
        # Constraint forces: Jᵀ·λ = M·ẍ − F(x, v, s, ṡ)  →  λ = (J Jᵀ)⁻¹ J (M ẍ − F).
        if rigid:
            W = np.linalg.solve(J @ J.T, J)  # (r, n)
            # F as an affine map: −K x − C v + k_s s + c_s ṡ + F0 + P F_nl
            Du_F = zeros_u.copy()
            Du_F[:, 0] = k_s
            Du_F[:, 1] = c_s
            F_map = Affine.combine(
                [(-K, x_map), (-C, v_map)], const=F0, du=Du_F
            )
            F_map = Affine(F_map.Cz, F_map.Du, F_map.Fn + P, F_map.e)
            lam = Affine.combine([(W @ Mfull, a_map), (-W, F_map)], const=np.zeros(len(rigid)), du=np.zeros((len(rigid), N_INPUT)))
        else:
            lam = Affine(np.zeros((0, m)), np.zeros((0, N_INPUT)), np.zeros((0, p)), np.zeros(0))
        return Configuration(
            branches=branches, A=A, B=B, b=b, L=L, power_contacts=tuple(power), stuck_contacts=tuple(rigid),
            x=x_map, v=v_map, a=a_map, lam=lam, N=N, p0=p0, p_s=p_s,
        )

    # ------------------------------------------------------------------ element quantities
    def deflection(self, index: int, x: np.ndarray, s: np.ndarray) -> np.ndarray:
        """d = x_upper − x_lower for full positions x (..., n) and cam s (...)."""
        geo = self.geometry[index]
        return x @ geo.G + geo.g_s * s

    def power_force(self, index: int, delta: np.ndarray, delta_rate: np.ndarray, v_impact: float | None) -> np.ndarray:
        """Force of a nonlinear (power-law) contact on samples, ≥ 0 [N]."""
        return self.elements[index].nonlinear_force(delta, delta_rate, v_impact)

    def element_forces(
        self,
        branches: tuple[Branch, ...],
        x: np.ndarray,
        v: np.ndarray,
        s: np.ndarray,
        sdot: np.ndarray,
        lam: np.ndarray,
        config: Configuration,
        v_impacts: dict[int, float],
    ) -> np.ndarray:
        """Forces of all elements on samples: (N, n_elements) [N].

        Tension-positive for springs and links, compressive-positive for contacts.
        """
        out = np.zeros((x.shape[0], len(self.elements)))
        for i, element in enumerate(self.elements):
            geo = self.geometry[i]
            d = x @ geo.G + geo.g_s * s
            dd = v @ geo.G + geo.g_s * sdot
            if i in config.stuck_contacts:
                out[:, i] = element.reported_constraint_force(self.branch_of(branches, i),
                                                              lam[:, config.stuck_contacts.index(i)])
            else:
                out[:, i] = element.force(self.branch_of(branches, i), d, dd, self.damping[i], v_impacts.get(i))
        return out

    def cam_contact_force(self, forces: np.ndarray, sddot: np.ndarray) -> np.ndarray | None:
        """Force the cam must exert on the driven mass: m·s̈ − Σ forces on it (+ m·g) [N]."""
        if not self.driven:
            return None
        total = self.driven_mass * (sddot + self.gravity)
        for i, element in enumerate(self.elements):
            if self.driven not in element.nodes:
                continue
            sign_on_upper = 1.0 if element.unilateral else -1.0
            # tension f: −f on upper, +f on lower; contact F: +F on upper, −F on lower.
            on_driven = sign_on_upper if element.upper == self.driven else -sign_on_upper
            total = total - on_driven * forces[:, i]
        return total

    def natural_modes(self, branches: tuple[Branch, ...]) -> list[tuple[float, float]]:
        """(natural frequency [Hz], damping ratio) of each mode of a linear configuration."""
        config = self.configuration(branches)
        if config.dim == 0:
            return []
        eig = np.linalg.eigvals(config.A)
        modes = []
        for lam in eig:
            if lam.imag < -1e-9 * max(1.0, abs(lam)):
                continue  # one of each conjugate pair
            wn = abs(lam)
            zeta = -lam.real / wn if wn > 0 else float("nan")
            modes.append((wn / (2 * math.pi), zeta))
        modes.sort()
        return modes

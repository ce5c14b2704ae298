"""Model assembly: from a :class:`~camsim.machine.description.Machine` to linear branch systems.

The free masses obey M·ẍ = Σ element forces (+ gravity). Every element sits on one
linear *branch* between events (a link joined or separated, a contact open, closed or
stuck), so for a *configuration* — one branch per switching element — the state z obeys

    ż = A·z + B·u(t) + b + L·F_nl,        u = [s₁, ṡ₁, s̈₁, s⃛₁, s₂, …]

where u is the motion of every cam on the model axis (four channels per cam, cam by cam:
:mod:`camsim.elements.affine`; one cam, or none, gives u = [s, ṡ, s̈, s⃛]), then one group
[F, Ḟ, F̈, F⃛] per process load (``[[load]]``, issue 43: a load enters B like gravity, as a
generalized force on its mass, but time-dependent; a load on a driven mass enters the cam
contact force only), and F_nl the forces of power-law contacts that are closed (the only
nonlinear terms). Rigid (restitution) contacts that are stuck
are constraints: the configuration then uses reduced coordinates q with
x = N·q + p0 + P_s·s (N an orthonormal null-space basis, s the cams' displacements), and
z = [q, q̇].

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


#: Configurations with stuck friction pairs kept (each stick holds its own deflection).
HELD_CONFIGURATIONS = 256


@dataclass
class ElementGeometry:
    """How an element's deflection depends on the free coordinates and the cams.

    d = G·x + Σ_q g_s[q]·s_q (+ 0),  ḋ = G·v + Σ_q g_s[q]·ṡ_q.
    """

    G: np.ndarray  # (n,)
    g_s: np.ndarray  # (cams,)

    def cam_term(self, s) -> np.ndarray | float:
        """Σ_q g_s[q]·s_q for cam values s (..., cams) (the cam part of d, or of ḋ from ṡ)."""
        s = np.asarray(s, dtype=float)
        out = self.g_s[0] * s[..., 0]
        for q in range(1, self.g_s.size):
            out = out + self.g_s[q] * s[..., q]
        return out


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
    p_s: np.ndarray  # (n, cams)
    cache: dict = field(default_factory=dict, repr=False)
    #: The deflections stuck friction pairs are held at ((element index, d [m]), ...).
    holds: tuple[tuple[int, float], ...] = ()
    #: Stuck friction pairs that share their load with stuck rigid contacts: element index →
    #: the force they carry [N] (tension-positive, ±F_B; :meth:`Model._saturated`).
    saturated: dict = field(default_factory=dict)

    @property
    def key(self):
        """What identifies it among a model's configurations: the branches (and the holds)."""
        return (self.branches, self.holds) if self.holds else self.branches

    @property
    def dim(self) -> int:
        return self.A.shape[0]

    @property
    def linear(self) -> bool:
        return not self.power_contacts

    def state_from_full(self, x: np.ndarray, v: np.ndarray, s, sdot) -> np.ndarray:
        """Reduced state z from full positions and velocities (projection onto the
        constraints); ``s``, ``sdot`` the cams' displacements and velocities (one value per
        cam, or a float for one cam)."""
        s, sdot = np.atleast_1d(s), np.atleast_1d(sdot)
        ps, psd = self.p_s[:, 0] * s[0], self.p_s[:, 0] * sdot[0]
        for c in range(1, s.size):
            ps, psd = ps + self.p_s[:, c] * s[c], psd + self.p_s[:, c] * sdot[c]
        q = self.N.T @ (x - self.p0 - ps)
        qd = self.N.T @ (v - psd)
        return np.concatenate([q, qd])

    def state_from_input(self, x: np.ndarray, v: np.ndarray, u: np.ndarray) -> np.ndarray:
        """Reduced state z from full positions, velocities and one input row u (the cams' 4·c
        channels, then the loads')."""
        cams = N_INPUT * self.p_s.shape[1]
        return self.state_from_full(x, v, u[0:cams:N_INPUT], u[1:cams:N_INPUT])


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
        cams = tuple(getattr(machine, "cams", ()) or ((machine.cam,) if machine.cam is not None else ()))
        #: The cam nodes in input order (cam q drives channels 4q … 4q+3); a machine without
        #: a cam keeps one cam node, ``cam``, at rest.
        self.cam_names: list[str] = [getattr(c, "name", CAM) for c in cams] or [CAM]
        self.cam_index = {name: q for q, name in enumerate(self.cam_names)}
        self.n_cams = len(self.cam_names)
        #: The process loads (issue 43), in the order of their input groups after the cams'.
        self.loads = tuple(getattr(machine, "loads", ()))
        self.n_loads = len(self.loads)
        #: Columns of the cams' channels in u (the loads' follow).
        self.n_cam_input = N_INPUT * self.n_cams
        elements = [e for e in machine.elements if not (no_impact and e.impact_only)]
        #: Friction pairs whose normal force follows a program (spec §10): (element index,
        #: its program's description), one input group each after the loads'.
        self.normal_programs = [(i, e.normal_program) for i, e in enumerate(elements)
                                if getattr(e, "normal_program", None) is not None]
        #: Columns of the input u: four per cam, then four per load, then four per normal force.
        self.n_input = N_INPUT * (self.n_cams + self.n_loads + len(self.normal_programs))
        #: Driven mass → the index of the cam that drives it.
        self.drives: dict[str, int] = {c.drives: q for q, c in enumerate(cams) if c.drives}
        self.driven = next(iter(self.drives), None)  # the first driven mass (one-cam machines: the one)
        self.free_names = [m.name for m in machine.free_masses]
        self.index = {name: i for i, name in enumerate(self.free_names)}
        self.n = len(self.free_names)
        self.mass = np.array([m.mass for m in machine.free_masses], dtype=float)
        self.gravity = machine.simulation.gravity
        self.driven_mass = machine.mass_of(self.driven) if self.driven else 0.0
        self.driven_masses = {name: machine.mass_of(name) for name in self.drives}
        elements = [e for e in machine.elements if not (no_impact and e.impact_only)]
        self.elements: list[Element] = elements
        self.geometry = [self._geometry(e) for e in elements]
        self.switching = [i for i, e in enumerate(elements) if e.branches(no_impact)]
        self.damping = [e.damping_coefficients(lambda name=None, e=e: self.reference_mass(e, name),
                                               lambda e=e: reduced_mass(machine, e)) for e in elements]  # issue 12
        self._configs: dict[tuple[Branch, ...], Configuration] = {}
        self._held: dict = {}  # (branches, holds) -> configuration with stuck friction pairs
        #: compound element name → the indices of its parts in :attr:`elements` (issue 39)
        self.parts = {name: [i for i, e in enumerate(elements) if e.parent() == name] for name in self.compounds}

    # ------------------------------------------------------------------ geometry
    def node_coefficients(self, node: str) -> tuple[np.ndarray, np.ndarray]:
        """x_node = e·x_free + c·s (c one coefficient per cam)."""
        e = np.zeros(self.n)
        c = np.zeros(self.n_cams)
        if node == GROUND:
            return e, c
        if node in self.cam_index:
            c[self.cam_index[node]] = 1.0
            return e, c
        if node in self.drives:
            c[self.drives[node]] = 1.0
            return e, c
        e[self.index[node]] = 1.0
        return e, c

    def _geometry(self, element: Element) -> ElementGeometry:
        e_lo, c_lo = self.node_coefficients(element.lower)
        e_up, c_up = self.node_coefficients(element.upper)
        return ElementGeometry(G=e_up - e_lo, g_s=c_up - c_lo)

    def reference_mass(self, element: Element, name: str | None = None) -> float:
        """m_ref of a damping ratio [kg] (spec §3): the mass ``name`` when given (a part of
        the element names its own), else the element's."""
        if name or element.damping.reference_mass:
            return self.machine.mass_of(name or element.damping.reference_mass)
        for node in (element.upper, element.lower):
            if node != GROUND and node not in self.cam_index:
                return self.machine.mass_of(node)
        raise InputError(f"element {element.name}: no mass to reference its damping ratio to")

    def load_column(self, index: int) -> int:
        """Column of load ``index``'s force F in the input u (its Ḟ, F̈, F⃛ follow)."""
        return self.n_cam_input + N_INPUT * index

    def load_values(self, u: np.ndarray) -> np.ndarray:
        """Every load's force [N] from input rows u (..., n_input): (..., loads)."""
        return np.asarray(u)[..., self.n_cam_input : self.n_cam_input + N_INPUT * self.n_loads : N_INPUT]

    def normal_column(self, index: int) -> int:
        """Column of element ``index``'s programmed normal force N in the input u."""
        k = next(k for k, (i, _) in enumerate(self.normal_programs) if i == index)
        return self.n_cam_input + N_INPUT * (self.n_loads + k)

    def _input_forces(self, branches) -> np.ndarray:
        """Generalized force on the free masses per unit of each input group after the cams':
        (n, loads + normal forces). A load acts along +x on its mass (zeros on a driven mass:
        the cam carries it); a sliding friction pair's force ±μ·N(t) acts −f·G."""
        out = np.zeros((self.n, self.n_loads + len(self.normal_programs)))
        out[:, : self.n_loads] = self._load_forces()
        for k, (i, _) in enumerate(self.normal_programs):
            a = self.elements[i].input_force(self.branch_of(branches, i))
            if a:
                out[:, self.n_loads + k] = -a * self.geometry[i].G
        return out

    def _load_forces(self) -> np.ndarray:
        """Generalized force of a unit force of each load on the free masses: (n, loads)
        (a column of zeros for a load on a driven mass: the cam carries it)."""
        out = np.zeros((self.n, self.n_loads))
        for k, load in enumerate(self.loads):
            if load.on in self.index:
                out[self.index[load.on], k] = 1.0
        return out

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
    def configuration(self, branches: tuple[Branch, ...], holds: tuple[tuple[int, float], ...] = ()) -> Configuration:
        """The (cached) linear system for one combination of branches.

        ``holds``: the deflection d [m] each stuck friction pair holds, ((element index, d),
        ...) in index order (a pair held without one holds d = 0). A stuck pair is a
        constraint like a stuck rigid contact, at its own deflection: each stick makes a
        configuration of its own (kept among the last :data:`HELD_CONFIGURATIONS`).
        """
        if not holds:
            config = self._configs.get(branches)
            if config is None:
                config = self._assemble(branches)
                self._configs[branches] = config
            return config
        key = (branches, holds)
        config = self._held.get(key)
        if config is None:
            config = self._assemble(branches, holds)
            if len(self._held) >= HELD_CONFIGURATIONS:
                self._held.pop(next(iter(self._held)))
            self._held[key] = config
        return config

    def _assemble(self, branches: tuple[Branch, ...], holds: tuple[tuple[int, float], ...] = ()) -> Configuration:
        n = self.n
        K = np.zeros((n, n))
        C = np.zeros((n, n))
        nc = self.n_cams
        k_s = np.zeros((n, nc))  # generalized force per unit s of each cam (moves to the right-hand side)
        c_s = np.zeros((n, nc))
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
                # a nonlinear element may keep a linear part in the linear system (a spring
                # with quadratic damping: its stiffness sets the grid and the modes)
                law = self.elements[i].linear_part(branch, self.damping[i])
            else:
                law = self.linear_branch(i, branch)
            if law is None:
                continue
            k, c, f0 = law
            # Tension f acts −f on the upper node, +f on the lower: Q = −f·G.
            K += k * np.outer(geo.G, geo.G)
            C += c * np.outer(geo.G, geo.G)
            for q in range(nc):
                k_s[:, q] -= k * geo.G * geo.g_s[q]
                c_s[:, q] -= c * geo.G * geo.g_s[q]
            F0 -= f0 * geo.G
        # Stuck friction pairs that hold what stuck rigid contacts already hold (a part on a
        # stop and on its guide): the pair carries its break-away force first and the
        # contacts the rest (spec §10); it is then a constant force, not a constraint.
        saturated = self._saturated(rigid, branches)
        for i, f in saturated.items():
            rigid.remove(i)
            F0 -= f * self.geometry[i].G
        # Power-law contact force F (compressive) acts +F on the upper node: Q = F·G; a
        # contact on side σ of a two-sided element (a lash) acts σ·F·G (issue 12 hook).
        sides = {i: self.elements[i].contact_side(self.branch_of(branches, i)) for i in (*power, *rigid)}
        # (a watched law, clamped at zero, acts with a zero column: issue 34)
        P = np.array([sides[i][0] * self.geometry[i].G * float(self.elements[i].acts(self.branch_of(branches, i)))
                      for i in power]).T.reshape(n, len(power))

        if rigid:
            J = np.array([sides[i][0] * self.geometry[i].G for i in rigid])
            j_s = np.array([sides[i][0] * self.geometry[i].g_s for i in rigid]).reshape(len(rigid), nc)
            held = dict(holds)
            # σ·(G·x + g_s·s) = σ·gap; a stuck friction pair: G·x + g_s·s = its hold
            r0 = np.array([held[i] if i in held else sides[i][0] * sides[i][1] for i in rigid])
            if np.linalg.matrix_rank(J) < len(rigid):
                raise InputError(
                    "rigid contacts " + ", ".join(self.elements[i].name for i in rigid)
                    + " over-constrain the masses when closed together"
                )
            N = scipy.linalg.null_space(J) if n else np.zeros((0, 0))
            pinv = np.linalg.pinv(J)
            p0 = pinv @ r0
            p_s = np.column_stack([-pinv @ j_s[:, q] for q in range(nc)]).reshape(n, nc)
        else:
            J = np.zeros((0, n))
            N = np.eye(n)
            p0 = np.zeros(n)
            p_s = np.zeros((n, nc))
        nq = N.shape[1]
        Mfull = np.diag(self.mass)
        Mr = N.T @ Mfull @ N
        Mr_inv = np.linalg.inv(Mr) if nq else np.zeros((0, 0))
        Kr = N.T @ K @ N
        Cr = N.T @ C @ N
        # Generalized force F = −K·x − C·v + k_s·s + c_s·ṡ + F0 with x = N q + p0 + p_s s
        # (one column per cam).
        f_s = [N.T @ (-K @ p_s[:, q] + k_s[:, q]) for q in range(nc)]  # per s
        f_sd = [N.T @ (-C @ p_s[:, q] + c_s[:, q]) for q in range(nc)]  # per ṡ
        f_sdd = [-N.T @ (Mfull @ p_s[:, q]) for q in range(nc)]  # per s̈ (inertia of the prescribed part)
        f_0 = N.T @ (-K @ p0 + F0)
        m = 2 * nq
        A = np.zeros((m, m))
        A[:nq, nq:] = np.eye(nq)
        A[nq:, :nq] = -Mr_inv @ Kr
        A[nq:, nq:] = -Mr_inv @ Cr
        B = np.zeros((m, self.n_input))
        for q in range(nc):
            B[nq:, N_INPUT * q] = Mr_inv @ f_s[q]
            B[nq:, N_INPUT * q + 1] = Mr_inv @ f_sd[q]
            B[nq:, N_INPUT * q + 2] = Mr_inv @ f_sdd[q]
        # issue 43: a load is a generalized force like gravity, in time; so is a sliding friction
        # pair's ±μ·N(t) when its normal force follows a program
        loads = self._input_forces(branches)
        for k in range(loads.shape[1]):
            B[nq:, self.load_column(k)] = Mr_inv @ (N.T @ loads[:, k])
        b = np.zeros(m)
        b[nq:] = Mr_inv @ f_0
        L = np.zeros((m, len(power)))
        L[nq:, :] = Mr_inv @ (N.T @ P)

        p = len(power)
        zeros_u = np.zeros((n, self.n_input))
        # x = N q + p0 + p_s s
        Du_x = zeros_u.copy()
        Du_v = zeros_u.copy()
        for q in range(nc):
            Du_x[:, N_INPUT * q] = p_s[:, q]
            Du_v[:, N_INPUT * q + 1] = p_s[:, q]
        x_map = Affine(np.hstack([N, np.zeros((n, nq))]), Du_x, np.zeros((n, p)), p0.copy())
        v_map = Affine(np.hstack([np.zeros((n, nq)), N]), Du_v, np.zeros((n, p)), np.zeros(n))
        # ẍ = N q̈ + p_s s̈,  q̈ = rows nq: of (A z + B u + b + L F)
        Du_a = N @ B[nq:]
        for q in range(nc):
            Du_a[:, N_INPUT * q + 2] += p_s[:, q]
        a_map = Affine(N @ A[nq:], Du_a, N @ L[nq:], N @ b[nq:])
        # Constraint forces: Jᵀ·λ = M·ẍ − F(x, v, s, ṡ)  →  λ = (J Jᵀ)⁻¹ J (M ẍ − F).
        if rigid:
            W = np.linalg.solve(J @ J.T, J)  # (r, n)
            # F as an affine map: −K x − C v + k_s s + c_s ṡ + F0 + P F_nl
            Du_F = zeros_u.copy()
            for q in range(nc):
                Du_F[:, N_INPUT * q] = k_s[:, q]
                Du_F[:, N_INPUT * q + 1] = c_s[:, q]
            for k in range(loads.shape[1]):
                Du_F[:, self.load_column(k)] = loads[:, k]
            F_map = Affine.combine(
                [(-K, x_map), (-C, v_map)], const=F0, du=Du_F
            )
            F_map = Affine(F_map.Cz, F_map.Du, F_map.Fn + P, F_map.e)
            lam = Affine.combine([(W @ Mfull, a_map), (-W, F_map)], const=np.zeros(len(rigid)), du=np.zeros((len(rigid), self.n_input)))
        else:
            lam = Affine(np.zeros((0, m)), np.zeros((0, self.n_input)), np.zeros((0, p)), np.zeros(0))
        return Configuration(
            branches=branches, A=A, B=B, b=b, L=L, power_contacts=tuple(power), stuck_contacts=tuple(rigid),
            x=x_map, v=v_map, a=a_map, lam=lam, N=N, p0=p0, p_s=p_s, holds=holds, saturated=saturated,
        )

    def _saturated(self, rigid: list[int], branches) -> dict[int, float]:
        """Stuck friction pairs among the constraints ``rigid`` whose rows depend on the
        others' (see :meth:`_assemble`): element index → the force it carries, −F_B or +F_B
        (tension-positive), the sense that relieves the contact it shares the load with."""
        # (a pair whose normal force follows a program has no constant F_B: it stays a
        # constraint, and the over-constraint error below names it)
        pairs = [i for i in rigid if self.elements[i].type_name == "friction" and not self.elements[i].programmed]
        if not pairs:
            return {}
        rows = {i: self.elements[i].contact_side(self.branch_of(branches, i))[0]
                * np.concatenate([self.geometry[i].G, self.geometry[i].g_s]) for i in rigid}
        keep = [i for i in rigid if i not in pairs]
        out: dict[int, float] = {}
        for i in pairs:
            trial = np.array([rows[j] for j in (*keep, i)])
            if np.linalg.matrix_rank(trial) == len(keep) + 1:
                keep.append(i)
                continue
            contacts = [j for j in keep if j not in pairs]
            if not contacts:
                keep.append(i)  # dependent on other pairs only: the over-constraint error names them
                continue
            base = np.array([rows[j] for j in contacts])
            beta = np.linalg.lstsq(base.T, rows[i], rcond=None)[0]
            k = int(np.argmax(np.abs(beta)))
            # the pair's force −f·row relieves contact k (which pushes +λ·row_k): f = −F_B·sign(β_k)
            out[i] = -self.elements[i].holding_force * float(np.sign(beta[k]))
        return out

    # ------------------------------------------------------------------ element quantities
    def deflection(self, index: int, x: np.ndarray, s) -> np.ndarray:
        """d = x_upper − x_lower for full positions x (..., n) and the cams' displacements
        s (..., cams), or (...) for one cam."""
        geo = self.geometry[index]
        return x @ geo.G + geo.cam_term(self._per_cam(s, x))

    def _per_cam(self, s, x) -> np.ndarray:
        """Cam values as (..., cams): a one-cam value (..., ) without the cam axis gains it."""
        s = np.asarray(s, dtype=float)
        if s.ndim == np.ndim(x) - 1:
            s = s[..., None]
        return s

    def acting(self, index: int, branches: tuple[Branch, ...]) -> Element:
        """The element whose law acts for element ``index`` on ``branches`` (a lash with a
        table per side: the closed side's; :meth:`~camsim.elements.base.Element.acting`)."""
        return self.elements[index].acting(self.branch_of(branches, index))

    def power_force(self, index: int, branches: tuple[Branch, ...], delta: np.ndarray, delta_rate: np.ndarray,
                    v_impact: float | None) -> np.ndarray:
        """Force of a nonlinear (power-law) contact on samples, ≥ 0 [N]."""
        return self.acting(index, branches).nonlinear_force(delta, delta_rate, v_impact)

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
        u: np.ndarray | None = None,
    ) -> np.ndarray:
        """Forces of all elements on samples: (N, n_elements) [N].

        Tension-positive for springs and links, compressive-positive for contacts. ``s``,
        ``sdot``: the cams' displacements and velocities (N, cams), or (N,) for one cam;
        ``u``: the whole input rows (N, n_input), needed by a friction pair whose normal force
        follows a program.
        """
        out = np.zeros((x.shape[0], len(self.elements)))
        s, sdot = self._per_cam(s, x), self._per_cam(sdot, x)
        for i, element in enumerate(self.elements):
            geo = self.geometry[i]
            d = x @ geo.G + geo.cam_term(s)
            dd = v @ geo.G + geo.cam_term(sdot)
            if i in config.stuck_contacts:
                out[:, i] = element.reported_constraint_force(self.branch_of(branches, i),
                                                              lam[:, config.stuck_contacts.index(i)])
            elif i in config.saturated:
                out[:, i] = config.saturated[i]
            elif getattr(element, "programmed", False):
                if u is None:
                    raise ValueError(f"the force of {element.name} needs its normal force (the input rows u)")
                out[:, i] = element.force(self.branch_of(branches, i), d, dd, self.damping[i], v_impacts.get(i),
                                          normal=np.asarray(u)[:, self.normal_column(i)])
            else:
                out[:, i] = element.force(self.branch_of(branches, i), d, dd, self.damping[i], v_impacts.get(i))
        return out

    def cam_contact_force(self, forces: np.ndarray, sddot: np.ndarray, driven: str | None = None,
                          loads: np.ndarray | None = None) -> np.ndarray | None:
        """Force the cam must exert on a driven mass: m·s̈ − Σ forces on it − Σ loads on it (+ m·g) [N].

        ``driven``: the mass (default the first driven one); ``sddot`` its cam's s̈ (N,), or
        every cam's (N, cams); ``loads``: every load's force (N, loads) (:meth:`load_values`)."""
        driven = driven or self.driven
        if not driven:
            return None
        sddot = np.asarray(sddot, dtype=float)
        if sddot.ndim == 2:
            sddot = sddot[:, self.drives[driven]]
        total = self.driven_masses[driven] * (sddot + self.gravity)
        for i, element in enumerate(self.elements):
            if driven not in element.nodes:
                continue
            sign_on_upper = 1.0 if element.unilateral else -1.0
            # tension f: −f on upper, +f on lower; contact F: +F on upper, −F on lower.
            on_driven = sign_on_upper if element.upper == driven else -sign_on_upper
            total = total - on_driven * forces[:, i]
        for k, load in enumerate(self.loads):  # issue 43: a load on the driven mass, along +x
            if load.on == driven:
                if loads is None:
                    raise ValueError(f"the cam contact force on {driven} needs the force of load {load.name}")
                total = total - loads[:, k]
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

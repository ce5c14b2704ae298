"""An independent, slow, tight-tolerance reference solver of camsim's equations.

Written from the model contract (``shared/spec/model.md`` §3-§4) only: it does not import
or copy camsim's model, integrator or simulation code. It uses camsim only for the
input (:mod:`camsim.machine.loader`, the :mod:`camsim.machine.description` dataclasses) and for the cam
motion (:class:`camsim.cam.program.CamProgram`), which has its own tests.

Method
------
Every free mass obeys m·ẍ = Σ (element forces) − m·g. On a fixed set of branches every
element force is affine in the node states, written as a *tension*

    f = a + k·d + c·ḋ,        d = x_upper − x_lower,

acting −f on the upper node and +f on the lower one:

- spring: a = P, k, c;
- preloaded link, joined (d ≤ d_sep = P/k_push): a = 0, k_push, c_push; separated:
  a = P − k_pull·d_sep, k_pull, c_pull;
- linear contact, closed: the compressive force F = k·δ + c·δ̇ with δ = g0 − d is the
  tension f = −F = −k·g0 + k·d + c·ḋ; open: f = 0.

The ODE y' = [v, M⁻¹·(node forces)] is integrated with
:func:`scipy.integrate.solve_ivp` (DOP853, ``rtol`` 1e-12 by default, ``atol`` 1e-15 m on
displacements and 1e-12 m/s on velocities) between branch changes, which are terminal
events of solve_ivp located by its root finder on the dense output:

- preloaded link: g = d − d_sep crosses 0 upward (``separation``) or downward
  (``rejoin``);
- linear contact: it is closed exactly when δ > 0 and k·δ + c·δ̇ > 0 (spec §3:
  F = max(0, k·δ + c·δ̇) while δ > 0), i.e. when h = min(δ, δ + (c/k)·δ̇) > 0; h crossing 0
  downward is a ``release``; upward it is an ``impact`` where δ rises through 0 (δ̇ ≥ 0,
  spec §3: "the contact closes when δ crosses 0 upward") and a ``reengage`` where δ is
  still positive and the law turns positive again (δ̇ < 0: no approach, the force rises
  from zero; camsim records no row for it, issue 34).

Each integration also stops at the cam's segment boundaries (where the cam jerk or
acceleration may jump), and the step is limited to a fortieth of the shortest natural period
of any branch so that a guard cannot cross and re-cross unseen inside one step.

The initial state is static equilibrium at t = 0 with zero velocities: the linear statics
is solved for a branch set, the branches are updated from the solution (contact closed
iff δ > 0, link separated iff d > d_sep) and this is repeated until consistent. An
``[initial]`` table overrides the named masses (the others keep their equilibrium).

Only springs, preloaded links and *linear* contacts are supported (what the reference
machines use); a power-law or restitution contact raises ``NotImplementedError``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from scipy.integrate import solve_ivp

from camsim.cam.program import CamProgram
from camsim.machine.description import CAM, FIXED_NODES, GROUND, Contact, Machine, PreloadedLink, Spring

__all__ = ["ReferenceResult", "ReferenceSolver", "reference_run"]

#: Default relative tolerance of solve_ivp.
RTOL = 1e-12
#: Absolute tolerance on displacements [m] and velocities [m/s].
ATOL_X = 1e-15
ATOL_V = 1e-12


@dataclass
class ReferenceResult:
    """Traces and events of a reference run, times on the recorded base (0 at t_rec).

    Attributes
    ----------
    time : ndarray
        [s].
    masses : dict
        name -> {"displacement" [m], "velocity" [m/s], "acceleration" [m/s^2]}.
    events : list of tuple
        (time [s], element name, kind, rate [m/s]) with rate = δ̇ for contacts, ḋ for links:
        the rows of camsim's event table (no ``reengage``).
    all_events : list of tuple
        Every branch change from t = 0 on the absolute time base (warm-up included),
        ``reengage`` too.
    initial_state : ndarray
        [x..., v...] of the free masses at t = 0.
    """

    time: np.ndarray
    masses: dict
    events: list
    all_events: list = field(default_factory=list)
    initial_state: np.ndarray | None = None


class ReferenceSolver:
    """The machine's equations on branches, assembled as incidence arrays.

    Parameters
    ----------
    machine : Machine
        The machine (SI).
    rtol : float
        Relative tolerance of solve_ivp.
    method : str
        solve_ivp method (``"DOP853"`` or ``"Radau"``).
    """

    def __init__(self, machine: Machine, rtol: float = RTOL, method: str = "DOP853"):
        self.machine = machine
        self.rtol = rtol
        self.method = method
        self.cam = CamProgram(machine.cam)
        self.driven = machine.cam.drives if machine.cam is not None else None
        self.g = machine.simulation.gravity
        self.free = [m.name for m in machine.masses if m.name != self.driven]
        self.mass = np.array([m.mass for m in machine.masses if m.name != self.driven])
        self.n = len(self.free)
        # Columns of the node vector: ground, cam (and the driven mass, which moves with it),
        # then the free masses.
        col = {GROUND: 0, CAM: 1}
        if self.driven is not None:
            col[self.driven] = 1
        for i, name in enumerate(self.free):
            col[name] = 2 + i
        ne = len(machine.elements)
        self.D = np.zeros((ne, 2 + self.n))
        for j, e in enumerate(machine.elements):
            self.D[j, col[e.upper]] += 1.0
            self.D[j, col[e.lower]] -= 1.0
            if isinstance(e, Contact) and e.law != "linear":
                raise NotImplementedError(f"reference solver: contact law {e.law!r} ({e.name})")
            if not isinstance(e, (Spring, PreloadedLink, Contact)):
                raise NotImplementedError(type(e).__name__)
        self.Dfix = self.D[:, :2]
        self.Dfree = self.D[:, 2:]
        self.elements = machine.elements
        # Damping coefficients per branch, c = 2ζ√(k·m_ref) (spec §3).
        self.c = [self._damping(e) for e in machine.elements]

    # ------------------------------------------------------------------ parameters
    def _damping(self, e) -> dict:
        if isinstance(e, PreloadedLink):
            ks = {"push": e.push_stiffness, "pull": e.pull_stiffness}
        else:
            ks = {"k": e.stiffness}
        d = e.damping
        if d.coefficient is not None:
            return {key: d.coefficient for key in ks}
        if d.ratio is None:
            return {key: 0.0 for key in ks}
        if d.reference_mass is not None:
            ref = d.reference_mass
        else:
            ref = e.lower if e.upper in FIXED_NODES else e.upper
        m_ref = self.machine.mass_of(ref)
        return {key: 2.0 * d.ratio * math.sqrt(k * m_ref) for key, k in ks.items()}

    def branch_coefficients(self, branches: tuple) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(a, k, c) arrays of the tension law f = a + k·d + c·ḋ on ``branches``.

        ``branches[j]`` is True for a closed contact or a separated link.
        """
        ne = len(self.elements)
        a, k, c = np.zeros(ne), np.zeros(ne), np.zeros(ne)
        for j, (e, on) in enumerate(zip(self.elements, branches)):
            if isinstance(e, Spring):
                a[j], k[j], c[j] = e.preload, e.stiffness, self.c[j]["k"]
            elif isinstance(e, PreloadedLink):
                if on:
                    a[j] = e.preload - e.pull_stiffness * e.separation_deflection
                    k[j], c[j] = e.pull_stiffness, self.c[j]["pull"]
                else:
                    k[j], c[j] = e.push_stiffness, self.c[j]["push"]
            elif on:  # closed linear contact
                a[j], k[j], c[j] = -e.stiffness * e.gap, e.stiffness, self.c[j]["k"]
        return a, k, c

    def max_frequency(self) -> float:
        """Highest natural angular frequency [rad/s] over all branch combinations (bound)."""
        kmax = []
        for e in self.elements:
            if isinstance(e, PreloadedLink):
                kmax.append(max(e.push_stiffness, e.pull_stiffness))
            else:
                kmax.append(e.stiffness)
        K = self.Dfree.T @ (np.array(kmax)[:, None] * self.Dfree)
        if self.n == 0:
            return 0.0
        w2 = np.linalg.eigvals(np.linalg.solve(np.diag(self.mass), K))
        return float(np.sqrt(np.max(np.abs(w2))))

    # ------------------------------------------------------------------ equations
    def _fixed(self, t: float) -> tuple[np.ndarray, np.ndarray]:
        s, v, _, _ = self.cam.svaj(t)
        return np.array([0.0, float(s)]), np.array([0.0, float(v)])

    def deflections(self, t: float, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Element deflections d [m] and rates ḋ [m/s] at state ``y``."""
        xf, vf = self._fixed(t)
        d = self.Dfix @ xf + self.Dfree @ y[: self.n]
        dd = self.Dfix @ vf + self.Dfree @ y[self.n:]
        return d, dd

    def rhs(self, t: float, y: np.ndarray, coef) -> np.ndarray:
        a, k, c = coef
        d, dd = self.deflections(t, y)
        f = a + k * d + c * dd
        force = -(self.Dfree.T @ f)
        return np.concatenate((y[self.n:], force / self.mass - self.g))

    def guards(self, t: float, y: np.ndarray) -> np.ndarray:
        """Guard values, one per element: crossing 0 changes its branch (nan for springs)."""
        d, dd = self.deflections(t, y)
        out = np.full(len(self.elements), np.nan)
        for j, e in enumerate(self.elements):
            if isinstance(e, PreloadedLink):
                out[j] = d[j] - e.separation_deflection
            elif isinstance(e, Contact):
                delta, ddelta = e.gap - d[j], -dd[j]
                tau = self.c[j]["k"] / e.stiffness
                out[j] = min(delta, delta + tau * ddelta)
        return out

    # ------------------------------------------------------------------ statics
    def static_equilibrium(self, t: float = 0.0, max_iter: int = 100) -> tuple[np.ndarray, tuple]:
        """Static equilibrium [x..., 0...] at ``t`` and its consistent branch set."""
        branches = tuple(isinstance(e, Contact) for e in self.elements)  # start with contacts closed
        xf, _ = self._fixed(t)
        seen = set()
        for _ in range(max_iter):
            a, k, _c = self.branch_coefficients(branches)
            K = self.Dfree.T @ (k[:, None] * self.Dfree)
            rhs = -self.Dfree.T @ (a + k * (self.Dfix @ xf)) - self.mass * self.g
            x = np.linalg.solve(K, rhs)
            d = self.Dfix @ xf + self.Dfree @ x
            new = []
            for j, e in enumerate(self.elements):
                if isinstance(e, PreloadedLink):
                    new.append(bool(d[j] > e.separation_deflection))
                elif isinstance(e, Contact):
                    new.append(bool(e.gap - d[j] > 0.0))
                else:
                    new.append(False)
            new = tuple(new)
            if new == branches:
                return np.concatenate((x, np.zeros(self.n))), branches
            if new in seen:
                raise RuntimeError("static equilibrium: branch iteration cycles")
            seen.add(branches)
            branches = new
        raise RuntimeError("static equilibrium: no consistent branch set")

    def branches_at(self, t: float, y: np.ndarray) -> tuple:
        """Consistent branch set of a state (guard > 0 means closed / separated)."""
        g = self.guards(t, y)
        return tuple(bool(v > 0.0) if np.isfinite(v) else False for v in g)

    # ------------------------------------------------------------------ dynamics
    def integrate(self, y0: np.ndarray, branches: tuple, t0: float, t1: float, t_eval: np.ndarray, pieces=None):
        """Integrate from ``t0`` to ``t1`` through branch changes.

        Returns
        -------
        samples : ndarray (len(t_eval), 3n)
            x, v, a of the free masses at ``t_eval``.
        events : list of (time, element, kind, rate)
        y1, branches1 : the state and branches at ``t1``.

        ``pieces``, when a list, receives ``(t_start, t_end, dense solution, coef, branches)``
        of every integration between branch changes (for extremes located on the solution).
        """
        n = self.n
        atol = np.concatenate((np.full(n, ATOL_X), np.full(n, ATOL_V)))
        wmax = self.max_frequency()
        # a fortieth of the shortest period: at a tenth, a release and re-impact 71 µs apart
        # fell inside one step, both ends on the same side, and went unseen (issue 34; camsim,
        # which screens every step for such a dip, found it)
        max_step = (2 * math.pi / wmax) / 40.0 if wmax > 0 else np.inf
        stops = [t0, *self.cam.boundary_times(t0, t1), t1]
        out = np.full((len(t_eval), 3 * n), np.nan)
        events: list = []
        t, y = t0, np.array(y0, dtype=float)
        for t_stop in stops[1:]:
            while t < t_stop:
                coef = self.branch_coefficients(branches)
                funcs = []
                for j, e in enumerate(self.elements):
                    if isinstance(e, Spring):
                        continue

                    def g(tt, yy, *_args, j=j):
                        return self.guards(tt, yy)[j]

                    g.terminal = True
                    g.direction = -1.0 if branches[j] else 1.0
                    g.index = j
                    funcs.append(g)
                sel = (t_eval >= t) & (t_eval <= t_stop)
                sol = solve_ivp(self.rhs, (t, t_stop), y, method=self.method, rtol=self.rtol, atol=atol,
                                args=(coef,), events=funcs or None, dense_output=True, max_step=max_step)
                if sol.status < 0:
                    raise RuntimeError(f"solve_ivp failed at t = {t}: {sol.message}")
                t_end = sol.t[-1]
                if pieces is not None and t_end > t:
                    pieces.append((t, t_end, sol.sol, coef, branches))
                # Samples up to t_end belong to this branch set.
                idx = np.flatnonzero(sel & (t_eval <= t_end))
                for i in idx:
                    yi = sol.sol(t_eval[i])
                    out[i, : 2 * n] = yi
                    out[i, 2 * n:] = self.rhs(t_eval[i], yi, coef)[n:]
                t, y = t_end, sol.y[:, -1].copy()
                if sol.status == 1:  # an event: switch that element's branch
                    hit = [(sol.t_events[i][0], funcs[i].index) for i in range(len(funcs)) if len(sol.t_events[i])]
                    te, j = min(hit)
                    e = self.elements[j]
                    d, dd = self.deflections(te, y)
                    new = list(branches)
                    new[j] = not branches[j]
                    if isinstance(e, PreloadedLink):
                        kind = "separation" if new[j] else "rejoin"
                        rate = dd[j]
                    else:
                        rate = -dd[j]
                        kind = ("impact" if rate >= 0.0 else "reengage") if new[j] else "release"
                    events.append((te, e.name, kind, rate))
                    branches = tuple(new)
        return out, events, y, branches

    def run(self, warmup_cycles: int | None = None, cycles: int | None = None,
            sample_rate: float | None = None) -> ReferenceResult:
        """Warm-up, then record; sample grid t_rec + k/sample_rate (as camsim)."""
        sim = self.machine.simulation
        warmup = sim.warmup_cycles if warmup_cycles is None else warmup_cycles
        cycles = sim.cycles if cycles is None else cycles
        rate = sim.sample_rate if sample_rate is None else sample_rate
        if self.machine.cam is not None and sim.duration is None:
            period = self.cam.period
            t_rec, t_end = warmup * period, (warmup + cycles) * period
        else:
            t_rec, t_end = 0.0, float(sim.duration)
        nsamp = int(math.floor((t_end - t_rec) * rate + 1e-9)) + 1
        t_eval = t_rec + np.arange(nsamp) / rate
        given = {ic.mass for ic in self.machine.initial
                 if ic.displacement is not None and ic.velocity is not None}
        if given >= set(self.free):  # every mass given: no statics needed
            y0, branches = np.zeros(2 * self.n), ()
        else:
            y0, branches = self.static_equilibrium(0.0)
        for ic in self.machine.initial:
            i = self.free.index(ic.mass)
            if ic.displacement is not None:
                y0[i] = ic.displacement
            if ic.velocity is not None:
                y0[self.n + i] = ic.velocity
        if self.machine.initial:
            branches = self.branches_at(0.0, y0)
        out, events, _, _ = self.integrate(y0, branches, 0.0, t_end, t_eval)
        masses = {}
        n = self.n
        s, v, a, _ = self.cam.svaj(t_eval)
        for m in self.machine.masses:
            if m.name == self.driven:
                masses[m.name] = {"displacement": s, "velocity": v, "acceleration": a}
            else:
                i = self.free.index(m.name)
                masses[m.name] = {"displacement": out[:, i], "velocity": out[:, n + i],
                                  "acceleration": out[:, 2 * n + i]}
        rec = [(te - t_rec, name, kind, rate_) for te, name, kind, rate_ in events
               if te >= t_rec - 1e-12 and kind != "reengage"]
        return ReferenceResult(time=t_eval - t_rec, masses=masses, events=rec, all_events=events,
                               initial_state=y0)


def reference_run(machine: Machine, rtol: float = RTOL, method: str = "DOP853", **kw) -> ReferenceResult:
    """Shorthand for ``ReferenceSolver(machine, rtol, method).run(**kw)``."""
    return ReferenceSolver(machine, rtol=rtol, method=method).run(**kw)


def located_extremes(solver: ReferenceSolver, warmup_cycles: int, cycles: int) -> dict:
    """Extremes of the recorded window located on the reference's own dense solution.

    The same warm-up and recording as :meth:`ReferenceSolver.run`; per integration piece
    (no branch change inside) each quantity is sampled at 4001 points of the dense output,
    and its best sample is refined by a bounded scalar search (Brent, xatol 1e-15 s) on
    the dense output. Returns ``{"elements": {name: [(impact time, peak force, its time),
    ...]}, "masses": {name: {"acceleration": (|peak|, time), ...}}}`` on the recorded clock,
    the element force compressive-positive for contacts (the force pushing the parts apart,
    k·δ + c·δ̇), P − f for a preloaded link (the compression at its interface, as camsim
    reports a rejoin's force).
    """
    from scipy.optimize import minimize_scalar

    period = solver.cam.period
    t_rec, t_end = warmup_cycles * period, (warmup_cycles + cycles) * period
    y0, branches = solver.static_equilibrium(0.0)
    pieces: list = []
    solver.integrate(y0, branches, 0.0, t_end, np.zeros(0), pieces=pieces)
    n = solver.n

    def located(fn, a, b):
        ts = np.linspace(a, b, 4001)
        values = np.array([fn(t) for t in ts])
        k = int(np.argmax(values))
        lo, hi = ts[max(k - 1, 0)], ts[min(k + 1, ts.size - 1)]
        if hi > lo:
            res = minimize_scalar(lambda t: -fn(t), bounds=(lo, hi), method="bounded",
                                  options={"xatol": 1e-15, "maxiter": 500})
            if -res.fun > values[k]:
                return float(-res.fun), float(res.x)
        return float(values[k]), float(ts[k])

    out: dict = {"elements": {}, "masses": {}}
    for j, e in enumerate(solver.elements):
        if isinstance(e, Spring):
            continue
        impacts = []
        for t0, t1, sol, coef, br in pieces:
            if t1 <= t_rec or not br[j] == isinstance(e, Contact):
                continue  # contacts: closed pieces; links: joined pieces
            a = max(t0, t_rec)

            def force(t, sol=sol, coef=coef):
                d, dd = solver.deflections(t, sol(t))
                f = coef[0][j] + coef[1][j] * d[j] + coef[2][j] * dd[j]
                return -f if isinstance(e, Contact) else e.preload - f

            value, when = located(force, a, min(t1, t_end))
            impacts.append((t0 - t_rec, value, when - t_rec))
        out["elements"][e.name] = impacts
    for i, name in enumerate(solver.free):
        best = None
        for t0, t1, sol, coef, br in pieces:
            if t1 <= t_rec or t0 >= t_end:
                continue
            for sign in (1.0, -1.0):
                hit = located(lambda t, sol=sol, coef=coef: sign * solver.rhs(t, sol(t), coef)[n + i], max(t0, t_rec),
                              min(t1, t_end))
                if best is None or hit[0] > best[0]:
                    best = hit
        out["masses"][name] = {"acceleration": (best[0], best[1] - t_rec)}
    return out

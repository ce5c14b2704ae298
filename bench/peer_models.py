"""The independent reference solver's equations, assembled for the peer integrators.

Shared by ``bench/bench_engine.py``, ``bench/bench_peers.py`` and
``tests/test_bench_peers.py``. The equations, branches and guards are those of
``tests/reference/reference_solver.py`` (its :class:`ReferenceSolver` provides the branch
coefficients, the static equilibrium and the incidence arrays; nothing here is taken from
camsim's engine). This module only assembles them so that each peer gets a fair chance:

- per branch set the system is ẏ = A·y + e_s·s(t) + e_v·v(t) + f0 with a constant A,
  assembled once and given as the Jacobian to the peers that take one (Radau, LSODA,
  CVODE BDF and Adams);
- the cam is evaluated by scalar ``math`` code of the same laws (checked against
  :meth:`CamProgram.svaj` to 1e-12 by :meth:`ScalarCam.check`) instead of the vectorised
  CamProgram, which costs about 0.1 ms per scalar call and would dominate a peer's time;
- every branch change is a root function of the integrator and a restart; every cam
  segment boundary is a stop (the cam's jerk or acceleration may jump there);
- samples come from each integrator's own dense output / interpolation;
- ``capped`` runs limit the step to a tenth of the shortest natural period, as the
  reference solver does (so that a guard cannot cross and re-cross unseen inside one step);
  free runs let the error estimate choose every step.

Two drivers share that loop: :class:`IvpDriver` (:func:`scipy.integrate.solve_ivp`) and
:class:`CvodeDriver` (SUNDIALS CVODE through scikit-sundae, imported only when used).
"""

from __future__ import annotations

import math
import os
import platform
import subprocess
import sys
import time
from bisect import bisect_right
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
for _p in (ROOT, ROOT / "tests" / "reference"):
    if str(_p) not in sys.path:
        sys.path.insert(0, str(_p))

import numpy as np  # noqa: E402
from scipy.integrate import solve_ivp  # noqa: E402

from camsim.cam import laws as _laws  # noqa: E402
from camsim.cam.program import CamProgram  # noqa: E402
from camsim.machine.description import PreloadedLink, Spring  # noqa: E402
from reference_solver import ReferenceSolver  # noqa: E402

CDTM = ROOT / "machines" / "cdtm.toml"
STORED = ROOT / "tests" / "data" / "reference" / "cdtm.npz"
SAMPLE_RATE = 50_000.0  # [Hz]
BRANCH_KINDS = ("impact", "release", "separation", "rejoin")
TWO_PI = 2.0 * math.pi
REF_RTOL = 1e-13  # DOP853 rtol of the accuracy reference
REF_ATOL_X, REF_ATOL_V = 1e-15, 1e-12  # its atol [m], [m/s]
#: solve_ivp methods given the constant Jacobian (LSODA needs it as a callable).
JAC_METHODS = ("Radau", "BDF", "LSODA")
#: CVODE's return status when a root function fired.
CV_ROOT_RETURN = 2


class Timeout(Exception):
    """A peer run exceeded its time budget."""


# ------------------------------------------------------------------------------ cam
def _scalar_law(name: str):
    """(y, y′) of the normalised rise ``name`` at a float u, with ``math`` only."""
    if name in ("poly345", "poly4567"):
        coeffs = {"poly345": {3: 10.0, 4: -15.0, 5: 6.0},
                  "poly4567": {4: 35.0, 5: -84.0, 6: 70.0, 7: -20.0}}[name]

        def law(u):
            y = y1 = 0.0
            for n, c in coeffs.items():
                y += c * u**n
                y1 += n * c * u ** (n - 1)
            return y, y1
        return law
    if name == "cycloidal":
        return lambda u: (u - math.sin(TWO_PI * u) / TWO_PI, 1.0 - math.cos(TWO_PI * u))
    if name == "harmonic":
        return lambda u: (0.5 * (1.0 - math.cos(math.pi * u)), 0.5 * math.pi * math.sin(math.pi * u))
    pw = _laws._FUNCTIONS[name]  # modified-trapezoid / modified-sine: piecewise acceleration
    pieces = [(p.u0, p.u1, p.a, p.k, p.c, p.b, d1, d0) for p, (d1, d0) in zip(pw.pieces, pw.consts)]
    uppers = [p[1] for p in pieces[:-1]]
    scale = pw.scale

    def law(u):
        u0, u1, a, k, c, b, d1, d0 = pieces[bisect_right(uppers, u)]
        if k:
            arg = k * (u - c)
            y = -a / k**2 * math.cos(arg) + 0.5 * b * u * u + d1 * u + d0
            y1 = a / k * math.sin(arg) + b * u + d1
        else:
            y = 0.5 * b * u * u + d1 * u + d0
            y1 = b * u + d1
        return y * scale, y1 * scale
    return law


class ScalarCam:
    """s(t) [m] and v(t) [m/s] of a segment cam inside one known segment, in ``math``.

    :meth:`segment_at` picks the segment (and revolution) of a span between two segment
    boundaries; :meth:`sv` then evaluates that segment's law at a float time.
    """

    def __init__(self, program: CamProgram):
        self.p = program
        self.w, self.r, self.th0 = program.speed, program.ratio, program.start_angle
        self.laws = [None if law is None else _scalar_law(law) for law in program._laws]
        self.seg = None

    def segment_at(self, t_mid: float) -> None:
        theta = self.th0 + self.w * t_mid
        rev = math.floor(theta / TWO_PI)
        i = int(np.searchsorted(self.p._starts, theta - rev * TWO_PI, side="right") - 1)
        beta = float(self.p._betas[i])
        self.seg = (rev * TWO_PI + float(self.p._starts[i]), beta, float(self.p._signed[i]),
                    float(self.p._h0[i]), self.laws[i])

    def sv(self, t: float) -> tuple[float, float]:
        start, beta, h, h0, law = self.seg
        if law is None:
            return self.r * h0, 0.0
        y, y1 = law((self.th0 + self.w * t - start) / beta)
        return self.r * (h0 + h * y), self.r * h * y1 * self.w / beta

    def check(self, t0: float, t1: float) -> float:
        """Largest difference from CamProgram.svaj over 2000 times, relative to the peaks."""
        bounds = [t0, *self.p.boundary_times(t0, t1), t1]
        worst = 0.0
        for a, b in zip(bounds[:-1], bounds[1:]):
            self.segment_at(0.5 * (a + b))
            ts = np.linspace(a, b, 2000 // (len(bounds) - 1))[1:-1]
            s_ref, v_ref, _, _ = self.p.svaj(ts)
            got = np.array([self.sv(t) for t in ts])
            worst = max(worst, float(np.max(np.abs(got[:, 0] - s_ref))) / 0.01,
                        float(np.max(np.abs(got[:, 1] - v_ref))) / 0.5)
        return worst


# ------------------------------------------------------------------------------ drivers
def linear_system(ref: ReferenceSolver, branches: tuple):
    """(A, e_s, e_v, f0) of ẏ = A·y + e_s·s + e_v·v + f0, y = [x, v] of the free masses, on
    ``branches``: the reference solver's tension laws f = a + k·d + c·ḋ assembled through
    its incidence arrays (also the floor's system, ``floor_model.py``)."""
    n = ref.n
    a, k, c = ref.branch_coefficients(branches)
    Df, d1 = ref.Dfree, ref.Dfix[:, 1]
    minv = (1.0 / ref.mass)[:, None]
    A = np.zeros((2 * n, 2 * n))
    A[:n, n:] = np.eye(n)
    A[n:, :n] = -minv * (Df.T @ (k[:, None] * Df))
    A[n:, n:] = -minv * (Df.T @ (c[:, None] * Df))
    es, ev, f0 = np.zeros(2 * n), np.zeros(2 * n), np.zeros(2 * n)
    es[n:] = -minv[:, 0] * (Df.T @ (k * d1))
    ev[n:] = -minv[:, 0] * (Df.T @ (c * d1))
    f0[n:] = -minv[:, 0] * (Df.T @ a) - ref.g
    return A, es, ev, f0


class HybridDriver:
    """The reference solver's hybrid system and the event-restart loop shared by the peers.

    A subclass integrates one span on a fixed branch set with :meth:`_span`.
    """

    def __init__(self, machine):
        self.ref = ReferenceSolver(machine)
        self.cam = ScalarCam(self.ref.cam)
        self.n = self.ref.n
        self.systems: dict = {}
        wmax = self.ref.max_frequency()
        self.max_step = (TWO_PI / wmax) / 10.0 if wmax > 0 else np.inf
        self.nfev = 0
        n, ref = self.n, self.ref
        # Guard rows of the non-spring elements: (index, kind, row, d1, constant, tau).
        self.guard_rows = []
        for j, e in enumerate(ref.elements):
            if isinstance(e, Spring):
                continue
            row, d1 = ref.Dfree[j].copy(), float(ref.Dfix[j, 1])
            if isinstance(e, PreloadedLink):
                self.guard_rows.append((j, "link", row, d1, e.separation_deflection, 0.0))
            else:
                self.guard_rows.append((j, "contact", row, d1, e.gap, ref.c[j]["k"] / e.stiffness))
        self._n_guards = len(self.guard_rows)
        self._scalar_guards = [
            (kind == "link", [(i, float(r)) for i, r in enumerate(row) if r],
             [(n + i, float(r)) for i, r in enumerate(row) if r], d1, const, tau)
            for _, kind, row, d1, const, tau in self.guard_rows]

    def system(self, branches: tuple):
        """(A, e_s, e_v, f0) of ẏ = A·y + e_s·s + e_v·v + f0 on ``branches`` (cached)."""
        if branches not in self.systems:
            self.systems[branches] = linear_system(self.ref, branches)
        return self.systems[branches]

    def guards_into(self, t: float, y, out) -> None:
        """Write every guard value at (t, y) into ``out`` (crossing 0 changes a branch).

        Scalar Python on the nonzero incidence entries: CVODE evaluates its root functions
        at every requested output time (25,001 a revolution), where numpy's per-call
        overhead on 2-vectors would cost the peer about 10 µs a sample.
        """
        s, v = self.cam.sv(t)
        yl = y.tolist()
        for k, (kind, pos, vel, d1, const, tau) in enumerate(self._scalar_guards):
            d = d1 * s
            for i, coef in pos:
                d += coef * yl[i]
            if kind:  # preloaded link: d − d_sep
                out[k] = d - const
            else:  # contact: min(δ, δ + τ·δ̇), δ = gap − d
                dd = d1 * v
                for i, coef in vel:
                    dd += coef * yl[i]
                delta = const - d
                out[k] = min(delta, delta - tau * dd)

    def directions(self, branches: tuple) -> list[int]:
        """Crossing direction of each guard on ``branches``: up to switch on, down to switch off."""
        return [-1 if branches[g[0]] else 1 for g in self.guard_rows]

    def _span(self, method, rtol, atol, branches, t, t_stop, y, t_eval, out, max_step):
        """Integrate from ``t`` toward ``t_stop`` on ``branches``; fill ``out`` at ``t_eval``.

        Returns (t_end, y_end, j) with j the element index of the branch change that ended
        the span, or None when it reached ``t_stop``.
        """
        raise NotImplementedError

    def run(self, method: str, rtol: float, atol, cycles: int = 1, warmup_cycles: int = 0,
            sample_rate: float = SAMPLE_RATE, deadline: float = math.inf, capped: bool = True):
        """Integrate; return (time [s], {mass: displacement [m]}, events, seconds).

        ``events`` are (time [s] on the recorded base, element, kind). ``capped`` limits the
        step to a tenth of the shortest natural period (as the reference solver does); without
        it the integrator chooses every step by its error estimate alone.
        """
        max_step = self.max_step if capped else np.inf
        t_start = time.perf_counter()
        ref, n, cam = self.ref, self.n, self.cam
        period = ref.cam.period
        t_rec, t_end = warmup_cycles * period, (warmup_cycles + cycles) * period
        nsamp = int(math.floor((t_end - t_rec) * sample_rate + 1e-9)) + 1
        t_eval = t_rec + np.arange(nsamp) / sample_rate
        y, branches = ref.static_equilibrium(0.0)
        out = np.full((nsamp, 2 * n), np.nan)
        events = []
        stops = [0.0, *ref.cam.boundary_times(0.0, t_end), t_end]
        t = 0.0
        self.nfev = 0
        for t_stop in stops[1:]:
            cam.segment_at(0.5 * (t + t_stop))
            while t < t_stop:
                if time.perf_counter() > deadline:
                    raise Timeout
                t, y, j = self._span(method, rtol, atol, branches, t, t_stop, y, t_eval, out, max_step)
                if j is not None:
                    new = list(branches)
                    new[j] = not branches[j]
                    e = ref.elements[j]
                    if isinstance(e, PreloadedLink):
                        kind = "separation" if new[j] else "rejoin"
                    else:
                        kind = "impact" if new[j] else "release"
                    events.append((t - t_rec, e.name, kind))
                    branches = tuple(new)
        elapsed = time.perf_counter() - t_start
        disp = {name: out[:, i] for i, name in enumerate(ref.free)}
        self.velocity = {name: out[:, n + i] for i, name in enumerate(ref.free)}
        events = [ev_ for ev_ in events if ev_[0] >= -1e-12]
        return t_eval - t_rec, disp, events, elapsed


class IvpDriver(HybridDriver):
    """The hybrid system integrated by :func:`scipy.integrate.solve_ivp`, one guard function each."""

    def _guard_funcs(self, branches):
        """Event functions of the non-spring elements on ``branches`` (terminal)."""
        n, cam = self.n, self.cam
        funcs = []
        for j, kind, row, d1, const, tau in self.guard_rows:
            if kind == "link":
                def g(t, y, row=row, d1=d1, dsep=const):
                    s, _ = cam.sv(t)
                    return d1 * s + row @ y[:n] - dsep
            else:
                def g(t, y, row=row, d1=d1, gap=const, tau=tau):
                    s, v = cam.sv(t)
                    delta = gap - d1 * s - row @ y[:n]
                    return min(delta, delta - tau * (d1 * v + row @ y[n:]))
            g.terminal = True
            g.direction = -1.0 if branches[j] else 1.0
            g.index = j
            funcs.append(g)
        return funcs

    def _span(self, method, rtol, atol, branches, t, t_stop, y, t_eval, out, max_step):
        cam = self.cam
        A, es, ev, f0 = self.system(branches)

        def rhs(tt, yy):
            s, v = cam.sv(tt)
            return A @ yy + es * s + ev * v + f0

        funcs = self._guard_funcs(branches)
        kw = {"jac": (lambda tt, yy: A)} if method in JAC_METHODS else {}
        sol = solve_ivp(rhs, (t, t_stop), y, method=method, rtol=rtol, atol=atol,
                        events=funcs or None, dense_output=True, max_step=max_step, **kw)
        if sol.status < 0:
            raise RuntimeError(f"solve_ivp {method} failed at t = {t}: {sol.message}")
        self.nfev += sol.nfev
        t_end = sol.t[-1]
        idx = np.flatnonzero((t_eval >= t) & (t_eval <= t_end))
        if idx.size:
            out[idx] = sol.sol(t_eval[idx]).T
        j = None
        if sol.status == 1:
            _, j = min((sol.t_events[i][0], funcs[i].index) for i in range(len(funcs)) if len(sol.t_events[i]))
        return t_end, sol.y[:, -1].copy(), j


class CvodeDriver(HybridDriver):
    """The hybrid system integrated by SUNDIALS CVODE (scikit-sundae), method BDF or Adams.

    One CVODE object per (method, tolerances, step cap, branch set) is built once and
    re-initialised (``CVodeReInit``) at every restart. The root functions are the guards of
    all non-spring elements, with the crossing direction of that branch set; the Jacobian is
    the constant A of the branch set (dense linear solver). Samples are CVODE's own
    interpolation at the requested output times (``CV_NORMAL``); the integration never
    passes the span's end (``tstop``).
    """

    def __init__(self, machine):
        from sksundae.cvode import CVODE  # the optional `bench` extra

        super().__init__(machine)
        self._CVODE = CVODE
        self._solvers: dict = {}

    def _solver(self, method, rtol, atol, branches, max_step):
        key = (method, rtol, np.asarray(atol).tobytes(), branches, max_step)
        if key not in self._solvers:
            A, es, ev, f0 = self.system(branches)
            cam, guards_into = self.cam, self.guards_into

            def rhsfn(t, y, yp):
                s, v = cam.sv(t)
                yp[:] = A @ y + es * s + ev * v + f0

            def jacfn(t, y, yp, JJ):
                JJ[:, :] = A

            opts = {}
            if self._n_guards:
                def eventsfn(t, y, events):
                    guards_into(t, y, events)

                eventsfn.terminal = [True] * self._n_guards
                eventsfn.direction = self.directions(branches)
                opts = {"eventsfn": eventsfn, "num_events": self._n_guards}
            self._solvers[key] = self._CVODE(
                rhsfn, method=method, rtol=rtol, atol=np.asarray(atol, dtype=float), jacfn=jacfn,
                max_step=0.0 if not np.isfinite(max_step) else float(max_step),
                max_num_steps=1_000_000, **opts)
        return self._solvers[key]

    def _span(self, method, rtol, atol, branches, t, t_stop, y, t_eval, out, max_step):
        solver = self._solver(method, rtol, atol, branches, max_step)
        lo = int(np.searchsorted(t_eval, t, side="right"))
        hi = int(np.searchsorted(t_eval, t_stop, side="left"))
        tspan = np.concatenate(([t], t_eval[lo:hi], [t_stop]))
        res = solver.solve(tspan, y)
        if res.status < 0:
            raise RuntimeError(f"CVODE {method} failed at t = {t}: {res.message}")
        self.nfev += res.nfev
        m = len(res.t)
        # Rows: t, the output times reached (in order), then the root or t_stop. With no output
        # time inside the span scikit-sundae returns every internal step instead: none is a sample.
        if hi > lo and m > 2:
            out[lo:lo + m - 2] = res.y[1:m - 1]
        if lo > 0 and t_eval[lo - 1] == t:
            out[lo - 1] = y
        t_end, y_end = float(res.t[-1]), res.y[-1].copy()
        j = None
        if res.status == CV_ROOT_RETURN:
            # Events of earlier solves stay in the list: the last row is this one.
            hit = np.flatnonzero(res.i_events[-1])
            j = self.guard_rows[int(hit[0])][0]
        elif hi < len(t_eval) and t_eval[hi] == t_stop:
            out[hi] = y_end
        return t_end, y_end, j


DRIVERS = {"solve_ivp": IvpDriver, "CVODE": CvodeDriver}


# ------------------------------------------------------------------------------ accuracy
def errors(disp: dict, events: list, ref_disp: dict, ref_events: list, masses) -> tuple[float, float]:
    """(displacement error relative to peak, event-time error [s]; inf if the sequences differ)."""
    ex = 0.0
    for m in masses:
        r = ref_disp[m]
        ex = max(ex, float(np.max(np.abs(disp[m] - r)) / np.max(np.abs(r))))
    if not np.isfinite(ex):
        ex = math.inf
    seq = [(e[1], e[2]) for e in events]
    ref_seq = [(e[1], e[2]) for e in ref_events]
    if seq != ref_seq:
        return ex, math.inf
    et = max((abs(a[0] - b[0]) for a, b in zip(events, ref_events)), default=0.0)
    return ex, et


def camsim_events(run) -> list:
    """(time, element, kind) of a camsim run's branch changes."""
    return [(e.time, e.element, e.kind) for e in run.events if e.kind in BRANCH_KINDS]


def stored_reference(masses) -> tuple[dict, list]:
    """Displacements and events of ``tests/data/reference/cdtm.npz`` (ReferenceSolver rtol
    1e-12, 10 kHz, the second revolution after one warm-up revolution)."""
    with np.load(STORED) as st:
        disp = {m: st[f"{m}/displacement"] for m in masses}
        events = list(zip(st["event_time"].tolist(), st["event_element"].tolist(), st["event_kind"].tolist()))
    return disp, events


def tight_atol(n: int) -> np.ndarray:
    """The accuracy reference's atol: 1e-15 m on displacements, 1e-12 m/s on velocities."""
    return np.concatenate((np.full(n, REF_ATOL_X), np.full(n, REF_ATOL_V)))


# ------------------------------------------------------------------------------ reporting
def load_average() -> str:
    try:
        return " ".join(f"{x:.2f}" for x in os.getloadavg())
    except OSError:
        return "?"


def print_machine(title: str, versions: str = "", more: tuple = ()) -> None:
    """Print ``title`` and the machine: CPU, Python and library versions (+ ``versions``),
    the lines ``more``, the checkout and the load average."""
    import scipy

    print(title)
    print(f"  CPU      {cpu_model()}, {os.cpu_count()} cores")
    print(f"  Python   {platform.python_version()}, numpy {np.__version__}, scipy {scipy.__version__}{versions}")
    for line in more:
        print(f"  {line}")
    print(f"  camsim   {git_describe()} (git describe --always --dirty)")
    print(f"  load     {load_average()} (1/5/15 min) at start; other jobs on the 2 cores inflate times",
          flush=True)


def git_describe() -> str:
    """``git describe --always --dirty`` of the checkout, or '?'."""
    try:
        return subprocess.run(["git", "describe", "--always", "--dirty"], cwd=ROOT, capture_output=True,
                              text=True, check=True).stdout.strip()
    except (OSError, subprocess.CalledProcessError):
        return "?"


def cpu_model() -> str:
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or "?"


def best_of(f, n: int) -> float:
    """Best wall time [s] of ``n`` calls of ``f``."""
    best = math.inf
    for _ in range(n):
        t0 = time.perf_counter()
        f()
        best = min(best, time.perf_counter() - t0)
    return best


def fmt_t(seconds: float) -> str:
    if not math.isfinite(seconds):
        return "-"
    return f"{seconds * 1e3:.1f} ms" if seconds < 1.0 else f"{seconds:.2f} s"


def fmt_e(x: float) -> str:
    return "differ" if math.isinf(x) else f"{x:.1e}"

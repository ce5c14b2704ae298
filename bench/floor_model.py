"""The numpy/scipy floor of a camsim run: the no-impact linear chain, sampled directly.

Shared by ``bench/bench_floor.py`` and ``tests/test_bench_floor.py``. It produces the
traces of camsim's no-impact variant (spec §4: every contact removed, every preloaded
link fixed on its joined branch) of a cam-driven machine at the output sample rate, with
no event handling at all: what numpy and scipy need to make those samples, the floor that
camsim's per-revolution cost is measured against (issue 37).

The equations are the independent reference solver's (``tests/reference/
reference_solver.py``: incidence arrays, the branch coefficients a, k, c of the tension
law f = a + k·d + c·ḋ, damping from the spec's c = 2ζ√(k·m_ref)), assembled into
ẏ = A·y + e_s·s + e_v·ṡ + f0 as for the peers (``peer_models.linear_system``); nothing is taken from
``camsim.model`` or ``camsim.engine``. camsim is used for the input only: the machine
(``camsim.machine``) and the cam law, :meth:`camsim.cam.program.CamProgram.svaj`
(vectorised over all samples).

Method
------
On the no-impact branch set the free masses obey ẏ = A·y + e_s·s(t) + e_v·ṡ(t) + f0,
y = [x, v]. Over one output step h the cam displacement is carried as the degree-7
Hermite polynomial of s, ṡ, s̈, s⃛ at the step's ends (ṡ as its derivative): for the
polynomial laws that is s itself, for the others it is off by O(h⁸·s⁽⁸⁾), about 1e-20 m
at 50 kHz. The step is then exact:

    y[k+1] = Φ·y[k] + P·u[k] + Q·u[k+1],     u[k] = [s, h·ṡ, h²·s̈, h³·s⃛](t_k),

with Φ = e^{A·h} and P, Q from one matrix exponential of the system augmented by the
polynomial's integrator chain (Van Loan's block form, time normalised by h). A step that
holds a point where the cam's jerk jumps (a segment join, a piece join of the modified
trapezoid or sine: :meth:`CamProgram.break_times`) is split there, its two parts each
carried by their own Hermite polynomial (a few steps per revolution, each with its own
two exponentials).

The recurrence runs in modal coordinates: Φ = V·Λ·V⁻¹, and each mode z = (V⁻¹·y)_i is a
first-order complex recurrence z[k+1] = λ_i·z[k] + r[k], one
:func:`scipy.signal.lfilter` call (only one mode of each complex-conjugate pair: y is
real, so y = Re(Σ V_i z_i) with weight 2 on the pair). Accelerations, element forces and
the cam contact force follow vectorised from the samples.
"""

from __future__ import annotations

import math
import sys
from dataclasses import dataclass, replace
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
for _p in (ROOT, ROOT / "bench", ROOT / "tests" / "reference"):
    if str(_p) not in sys.path:
        sys.path.insert(0, str(_p))

import numpy as np  # noqa: E402
from scipy.linalg import expm  # noqa: E402
from scipy.signal import lfilter  # noqa: E402

from camsim.machine.description import Contact  # noqa: E402
from peer_models import linear_system  # noqa: E402
from reference_solver import ReferenceSolver  # noqa: E402

#: Hermite order carried over a step: s and its derivatives 0..3 at both ends (degree 7).
ORDERS = 4
#: Basis terms σ^m/m!, m = 0..7.
DEGREE = 2 * ORDERS


def no_impact_machine(machine):
    """The machine of spec §4's no-impact variant: its contact elements removed.

    The preloaded links stay, fixed on their joined branch by :class:`Floor` (branch set
    all False: joined, in the reference solver's convention).
    """
    return replace(machine, elements=tuple(e for e in machine.elements if not isinstance(e, Contact)))


@dataclass
class FloorSystem:
    """The no-impact system of a machine and its exact one-step map at a sample rate.

    Built by :func:`floor_system`; :func:`floor_run` uses it.
    """

    ref: ReferenceSolver
    h: float  # output step [s]
    A: np.ndarray  # (2n, 2n)
    es: np.ndarray  # (2n,) input direction of s
    ev: np.ndarray  # (2n,) input direction of ṡ
    f0: np.ndarray  # (2n,) constant term
    coef: tuple  # (a, k, c) of the tension laws on the no-impact branch set
    lam: np.ndarray  # modal eigenvalues kept (one of each conjugate pair)
    weight: np.ndarray  # 2 for a conjugate pair, 1 for a real mode
    V: np.ndarray  # (2n, modes) kept eigenvectors
    Vinv: np.ndarray  # (modes, 2n) rows of V⁻¹ kept
    P: np.ndarray  # (2n, 4) the start's input map
    Q: np.ndarray  # (2n, 4) the end's input map
    c0: np.ndarray  # (2n,) the constant term's contribution over a step


def step_maps(A, es, ev, f0, h):
    """(Φ, P, Q, c0) of the exact step of length ``h`` with the Hermite input.

    y(h) = Φ·y(0) + P·u(0) + Q·u(h) + c0, u = [s, h·ṡ, h²·s̈, h³·s⃛] (scaled by this ``h``).
    ``h`` may be an array of step lengths: the maps are then stacked along a first axis.
    """
    hs = np.atleast_1d(np.asarray(h, dtype=float))
    n2 = A.shape[0]
    # Normalised time σ = τ/h: dy/dσ = h·A·y + h·e_s·s + e_v·(ds/dσ) + h·f0, s(σ) = Σ c_m σ^m/m!,
    # with the chain z' = N·z (z_1 = s, z_2 = ds/dσ, ...) and a constant 1 for f0.
    size = n2 + DEGREE + 1
    M = np.zeros((hs.size, size, size))
    M[:, :n2, :n2] = hs[:, None, None] * A
    M[:, :n2, n2] = hs[:, None] * es
    M[:, :n2, n2 + 1] = ev
    M[:, :n2, n2 + DEGREE] = hs[:, None] * f0
    for m in range(DEGREE - 1):
        M[:, n2 + m, n2 + m + 1] = 1.0
    E = expm(M)
    phi, G, c0 = E[:, :n2, :n2], E[:, :n2, n2:n2 + DEGREE], E[:, :n2, n2 + DEGREE]
    # The coefficients c_m = s^(m)(0)·h^m for m < 4; c_4..c_7 from the end values:
    # u_i(1) = Σ_m c_m / (m - i)!  (i = 0..3)  ->  c_hi = H⁻¹·(u(1) − T·c_lo).
    fact = [math.factorial(j) for j in range(DEGREE)]
    T = np.array([[1.0 / fact[m - i] if m >= i else 0.0 for m in range(ORDERS)] for i in range(ORDERS)])
    H = np.array([[1.0 / fact[m - i] for m in range(ORDERS, DEGREE)] for i in range(ORDERS)])
    Hinv = np.linalg.inv(H)
    G_lo, G_hi = G[:, :, :ORDERS], G[:, :, ORDERS:]
    P = G_lo - G_hi @ (Hinv @ T)
    Q = G_hi @ Hinv
    if np.ndim(h) == 0:
        return phi[0], P[0], Q[0], c0[0]
    return phi, P, Q, c0


def floor_system(machine, sample_rate: float) -> FloorSystem:
    """The no-impact system of ``machine`` (SI) and its exact step at ``sample_rate`` [Hz]."""
    ref = ReferenceSolver(no_impact_machine(machine))
    branches = (False,) * len(ref.elements)  # every preloaded link joined
    A, es, ev, f0 = linear_system(ref, branches)
    h = 1.0 / sample_rate
    phi, P, Q, c0 = step_maps(A, es, ev, f0, h)
    lam_all, V_all = np.linalg.eig(phi)
    Vinv_all = np.linalg.inv(V_all)
    keep = lam_all.imag >= 0.0
    weight = np.where(lam_all.imag > 0.0, 2.0, 1.0)[keep]
    return FloorSystem(ref, h, A, es, ev, f0, ref.branch_coefficients(branches), lam_all[keep], weight,
                       V_all[:, keep], Vinv_all[keep], P, Q, c0)


def _split_steps(sys_: FloorSystem, t: np.ndarray, U: np.ndarray, w: np.ndarray) -> None:
    """Replace in ``w`` the input term of every step that holds a jerk jump of the cam.

    ``U`` holds the scaled cam derivatives at the samples (right limits). All such steps are
    handled together: four cam evaluations and one stacked matrix exponential per part.
    """
    cam, h = sys_.ref.cam, sys_.h
    breaks = cam.break_times(float(t[0]), float(t[-1]))
    if not breaks.size:
        return
    ks = np.searchsorted(t, breaks, side="right") - 1
    scale = h ** np.arange(ORDERS)[:, None]
    # A break on a sample: the step that ends there takes the left limit at its end.
    on = (breaks == t[ks]) & (ks > 0)
    if on.any():
        k = ks[on]
        u_end = np.array(cam.svaj(breaks[on], side="left")) * scale
        w[:, k - 1] = sys_.P @ U[:, k - 1] + sys_.Q @ u_end + sys_.c0[:, None]
    inside = breaks > t[ks]
    if not inside.any():
        return
    k, tb = ks[inside], breaks[inside]
    h1, h2 = tb - t[k], t[k + 1] - tb
    # Each part carried by its own Hermite: the left limits at the break close the first part
    # and the step's end (a further break there is another step's).
    u_a = np.array(cam.svaj(t[k])) * h1 ** np.arange(ORDERS)[:, None]
    u_bl = np.array(cam.svaj(tb, side="left")) * h1 ** np.arange(ORDERS)[:, None]
    u_br = np.array(cam.svaj(tb, side="right")) * h2 ** np.arange(ORDERS)[:, None]
    u_e = np.array(cam.svaj(t[k + 1], side="left")) * h2 ** np.arange(ORDERS)[:, None]
    _, P1, Q1, c01 = step_maps(sys_.A, sys_.es, sys_.ev, sys_.f0, h1)
    phi2, P2, Q2, c02 = step_maps(sys_.A, sys_.es, sys_.ev, sys_.f0, h2)
    part1 = np.einsum("bij,jb->bi", P1, u_a) + np.einsum("bij,jb->bi", Q1, u_bl) + c01
    part2 = np.einsum("bij,jb->bi", P2, u_br) + np.einsum("bij,jb->bi", Q2, u_e) + c02
    w[:, k] = (np.einsum("bij,bj->bi", phi2, part1) + part2).T


def floor_run(machine, cycles: int = 1, sample_rate: float = 50e3, system: FloorSystem | None = None) -> dict:
    """Traces of the no-impact variant over ``cycles`` revolutions from static equilibrium at t = 0.

    Returns
    -------
    dict
        The result-file paths of camsim's traces (spec §7), each made by the floor:
        ``time``, ``cam/angle`` [deg], ``cam/displacement|velocity|acceleration|jerk``,
        ``masses/<name>/displacement|velocity|acceleration``, ``elements/<name>/force`` (tension-positive),
        ``cam_contact/force`` (when the cam drives a mass); SI.
    """
    sys_ = system if system is not None else floor_system(machine, sample_rate)
    ref, n, h = sys_.ref, sys_.ref.n, sys_.h
    t_end = cycles * ref.cam.period
    nsamp = int(math.floor(t_end * sample_rate + 1e-9)) + 1
    t = np.arange(nsamp) / sample_rate
    s, v, acc, jerk = ref.cam.svaj(t)
    # Static equilibrium at t = 0 on the joined branch set, zero velocities (spec §4).
    a, k, c = sys_.coef
    Df, d1 = ref.Dfree, ref.Dfix[:, 1]
    K = Df.T @ (k[:, None] * Df)
    x0 = np.linalg.solve(K, -Df.T @ (a + k * d1 * s[0]) - ref.mass * ref.g)
    y0 = np.concatenate((x0, np.zeros(n)))
    # Input of every step: P·u[k] + Q·u[k+1] + c0, then the steps across a jerk jump.
    U = np.vstack((s, h * v, (h * h) * acc, (h * h * h) * jerk))
    w = sys_.P @ U[:, :-1] + sys_.Q @ U[:, 1:] + sys_.c0[:, None]
    _split_steps(sys_, t, U, w)
    # Modal recurrences: z[0] = V⁻¹·y0, z[k+1] = λ·z[k] + (V⁻¹·w)[k].
    r = np.empty((sys_.lam.size, nsamp), dtype=complex)
    r[:, 0] = sys_.Vinv @ y0
    r[:, 1:] = sys_.Vinv @ w
    y = np.zeros((2 * n, nsamp))
    for i, lam in enumerate(sys_.lam):
        z = lfilter([1.0], [1.0, -lam], r[i])
        y += sys_.weight[i] * (sys_.V[:, i:i + 1] * z[None, :]).real
    ydot = sys_.A @ y + np.outer(sys_.es, s) + np.outer(sys_.ev, v) + sys_.f0[:, None]
    out = {"time": t, "cam/angle": np.degrees(ref.cam.angle(t)), "cam/displacement": s, "cam/velocity": v,
           "cam/acceleration": acc, "cam/jerk": jerk}
    for m in ref.machine.masses:
        if m.name == ref.driven:
            out.update({f"masses/{m.name}/displacement": s, f"masses/{m.name}/velocity": v,
                        f"masses/{m.name}/acceleration": acc})
        else:
            i = ref.free.index(m.name)
            out.update({f"masses/{m.name}/displacement": y[i], f"masses/{m.name}/velocity": y[n + i],
                        f"masses/{m.name}/acceleration": ydot[n + i]})
    # Element tensions f = a + k·d + c·ḋ, d = D_fix·[0, s] + D_free·x.
    d = np.outer(d1, s) + Df @ y[:n]
    dd = np.outer(d1, v) + Df @ y[n:]
    f = a[:, None] + k[:, None] * d + c[:, None] * dd
    for j, e in enumerate(ref.elements):
        out[f"elements/{e.name}/force"] = f[j]
    if ref.driven is not None:
        # The driven mass: m·s̈ = Fc + (forces of its elements); an element acts −f on its
        # upper node and +f on its lower one (D's driven column is +1 / −1 there).
        m1 = ref.machine.mass_of(ref.driven)
        out["cam_contact/force"] = m1 * (acc + ref.g) + d1 @ f
    return out


def trace_errors(floor: dict, result) -> dict:
    """Largest |floor − camsim| of each floor trace relative to camsim's peak of it.

    ``result`` is a camsim ``RunResult`` of the no-impact variant on the same grid. A path
    that camsim does not write is an error (the floor would be doing other work).
    """
    traces = result.traces()
    out = {}
    for path, value in floor.items():
        if path not in traces:
            raise KeyError(f"camsim's result has no trace {path!r}")
        ref = np.asarray(traces[path].data)
        if ref.shape != value.shape:
            raise ValueError(f"{path}: {value.shape} samples against camsim's {ref.shape}")
        peak = float(np.max(np.abs(ref)))
        out[path] = float(np.max(np.abs(value - ref))) / peak if peak > 0 else float(np.max(np.abs(value)))
    return out

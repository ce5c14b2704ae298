"""Process loads in a run: each load's force, its located extremes and its work per cycle.

A load (``[[load]]``, spec §10) is an input of the engine like the cam's motion
(:mod:`camsim.loads`); its force is recorded as ``/loads/<name>/force`` and its maximum and
minimum are located on the solution like every reported peak (:class:`camsim.run.extremes.Observables`).

**Work per cycle.** W = ∫ F·ẋ dt of a load over the first recorded revolution (over the
recorded time for a machine without a cam), ẋ the velocity of the mass it acts on (ṡ of its
cam for a driven mass). It is integrated on the engine's solution, not on the output
samples, so it does not depend on the sample rate:

* on every step between two nodes of a stretch (the engine's grid, its breaks and events, the
  window's ends), for a **driven mass** F·ṡ is integrated by Gauss–Legendre with
  :data:`WORK_POINTS` points (exact for polynomials of degree 2·WORK_POINTS − 1), F and ṡ
  from their laws; steps are at most 1/64 of the shortest motion of the cam and the loads and
  neither has a kink inside one, so the rule is exact to rounding;
* for a **free mass in a linear configuration** the integral is the exact one of the step's
  solution: the state over the step is the Taylor series of the configuration's exact
  solution (:func:`camsim.engine.taylor.taylor_coefficients`, a polynomial in σ = τ/h), ẋ an
  affine map of it and of the input, F the input's own polynomial over the step (what the
  engine integrates), and ∫F·ẋ of two polynomials is summed term by term;
* for a free mass while a closed power-law contact makes the stretch nonlinear, the state
  between nodes is known only by integrating again; there the two-point Hermite rule of
  order six on the nodes' values and their first two rates,
  h/2·(g₀ + g₁) + h²/10·(ġ₀ − ġ₁) + h³/120·(g̈₀ + g̈₁) (g = F·ẋ, ġ = Ḟ·ẋ + F·ẍ,
  g̈ = F̈·ẋ + 2Ḟ·ẍ + F·x⃛, the jerk from the equations and the contacts' tangents), is used.

:class:`LoadWork` accumulates it stretch by stretch, for the in-memory and the streamed run
alike (:func:`camsim.run.extremes.digest` feeds it).
"""

from __future__ import annotations

import math

import numpy as np

from camsim.elements.affine import N_INPUT
from camsim.engine.stepping import _P, step_input_derivatives

__all__ = ["WORK_POINTS", "LoadWork", "load_columns", "load_row", "load_summary", "load_traces", "program_text"]

#: Gauss–Legendre points per step of the work integral.
WORK_POINTS = 6
_X, _W = np.polynomial.legendre.leggauss(WORK_POINTS)
_SIGMA = 0.5 * (_X + 1.0)
_WEIGHT = 0.5 * _W


def _scales(h: np.ndarray, n: int) -> np.ndarray:
    """h^k/k! for k = 0 … n − 1 of each step: (S, n)."""
    return np.cumprod(np.concatenate([np.ones((h.size, 1)), h[:, None] / np.arange(1, n)[None, :]], axis=1), axis=1)


def _velocity_series(config, i: int, z0: np.ndarray, D: np.ndarray, h: np.ndarray) -> np.ndarray:
    """The velocity of free mass ``i`` over each step as a polynomial in σ = τ/h: its
    coefficients (S, K + 1), from the Taylor series of the linear configuration's exact
    solution with the input the steps' polynomials (the series of
    :func:`camsim.engine.taylor.taylor_coefficients`, in its balanced coordinates, for one row
    of the state: e_{k+1} = h/(k+1)·(A_b·e_k + (B_b·u⁽ᵏ⁾ + [k = 0]·b_b)·h^k/k!), and ẋ_i =
    v_z·z + v_u·u + v_e)."""
    from camsim.engine.taylor import _balanced, _terms

    T, Ab, Bb, bb, norm = _balanced(config)
    S = z0.shape[0]
    K = _terms(float(np.max(h)) * norm)
    n_in = Bb.shape[1]
    order = np.tile(np.arange(N_INPUT), n_in // N_INPUT)  # each channel's derivative order in its group
    first = (_P + 1) * np.repeat(np.arange(n_in // N_INPUT), N_INPUT)  # its group's first column in D
    cz, du = config.v.Cz[i] * T, config.v.Du[i]
    out = np.zeros((S, K + 1))
    e = z0 / T
    out[:, 0] = e @ cz + config.v.e[i]
    hk = np.ones(S)  # h^k/k!
    AbT, BbT = Ab.T, Bb.T
    for k in range(K):
        nxt = e @ AbT
        if k <= _P:  # u⁽ᵏ⁾: channel (q, d) is D[:, 8q + d + k] while d + k ≤ 7, zero after
            live = order + k <= _P
            uk = np.zeros((S, n_in))
            uk[:, live] = D[:, first[live] + order[live] + k]
            out[:, k] += (uk @ du) * hk
            nxt += (uk @ BbT) * hk[:, None]
        if k == 0:
            nxt += bb
        e = nxt * (h / (k + 1))[:, None]
        hk = hk * h / (k + 1)
        out[:, k + 1] = e @ cz
    return out


def _integral(f: np.ndarray, g: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    """∫ f(σ)·g(σ) dσ from ``lo`` to ``hi`` of each row's polynomials, exactly: f (S, J) and g
    (S, K) their coefficients of σ⁰, σ¹, …; → (S,)."""
    J, K = f.shape[1], g.shape[1]
    c = np.zeros((f.shape[0], J + K - 1))
    for j in range(J):
        c[:, j : j + K] += f[:, j : j + 1] * g
    n = np.arange(1, J + K)
    if np.all(lo == 0.0) and np.all(hi == 1.0):  # whole steps (all but a window's edges)
        return c @ (1.0 / n)
    return np.sum(c * (hi[:, None] ** n - lo[:, None] ** n) / n, axis=1)


def load_columns(machine) -> list[tuple[str, str]]:
    """The scalars of a machine's loads with their SI units: ``max_load:<name>``,
    ``min_load:<name>`` [N] and ``load_work:<name>`` [J] per load."""
    out = []
    for load in getattr(machine, "loads", ()):
        out += [(f"max_load:{load.name}", "N"), (f"min_load:{load.name}", "N"), (f"load_work:{load.name}", "J")]
    return out


def load_traces(model, u: np.ndarray) -> dict[str, np.ndarray]:
    """Each load's force [N] from input rows u (N, n_input): name → (N,)."""
    values = model.load_values(u)
    return {load.name: values[:, k] for k, load in enumerate(model.loads)}


def program_text(load) -> str:
    """A load's program in a few words (for tables): ``constant``, ``segments (4)``,
    ``angle table press.csv``, ``sine``."""
    if load.kind == "force":
        return "constant"
    if load.kind == "segments":
        return f"segments ({len(load.segments)})"
    if load.kind == "table":
        return f"{load.table.over} table {load.table.source}"
    return "sine"


# ---------------------------------------------------------------------- the work per cycle
class LoadWork:
    """∫ F·ẋ dt of every load over a window, stretch by stretch (module docstring).

    Parameters
    ----------
    model : Model
    window : (float, float)
        The interval [s] on the simulation clock (:func:`work_window`).
    """

    def __init__(self, model, window: tuple[float, float]):
        self.model = model
        self.lo, self.hi = float(window[0]), float(window[1])
        self.work = np.zeros(model.n_loads)
        self.covered = 0.0
        # per load: the column of its F, and the input column of ṡ (a driven mass) or the
        # free mass's index
        self._cols = [model.load_column(k) for k in range(model.n_loads)]
        self._driven = [model.drives.get(load.on) for load in model.loads]
        self._free = [model.index.get(load.on) for load in model.loads]

    def add(self, ctx, st) -> None:
        """Add one stretch (its nodes ``st.t``, states, inputs; ``st.exact`` says how its
        states between nodes are known) of the integrator ``ctx``."""
        t = st.t
        if t.size < 2 or t[-1] <= self.lo or t[0] >= self.hi:
            return
        a = np.maximum(t[:-1], self.lo)
        b = np.minimum(t[1:], self.hi)
        steps = np.flatnonzero(b > a)
        if not steps.size:
            return
        self.covered += float(np.sum(b[steps] - a[steps]))
        h = t[steps + 1] - t[steps]
        lo = (a[steps] - t[steps]) / h  # the part of each step inside the window, as fractions σ
        hi = (b[steps] - t[steps]) / h
        driven = [k for k, q in enumerate(self._driven) if q is not None]
        if driven:  # F·ṡ, both from their laws at Gauss–Legendre points (the left limit at a step's end)
            sigma = lo[:, None] + (hi - lo)[:, None] * _SIGMA[None, :]
            times = t[steps][:, None] + h[:, None] * sigma
            ends = np.broadcast_to(t[steps + 1][:, None], times.shape)
            Ug = ctx.analytic_inputs_at(times.reshape(-1), ends.reshape(-1)).reshape(times.shape + (-1,))
            for k in driven:
                g = Ug[:, :, self._cols[k]] * Ug[:, :, N_INPUT * self._driven[k] + 1]
                self.work[k] += float(np.sum((hi - lo) * h * (g @ _WEIGHT)))
        free = [k for k, i in enumerate(self._free) if i is not None]
        if not free:
            return
        config = st.config
        if not st.exact:
            from camsim.engine.dense import DenseStretch

            dense = DenseStretch(ctx, config, st.branches, st.v_impacts, False, t, st.z, st.u, None)
            self._hermite(ctx, dense, steps, lo, hi, b[steps] - a[steps], free)
            return
        # the input over each step: the engine's own polynomial of it (degree 7, from the channels
        # at the step's ends): D[:, 8q + j] the j-th derivative of group q's value at its start
        D = step_input_derivatives(st.u[steps], st.u[steps + 1], h, ctx.h)
        from camsim.engine.taylor import TAYLOR_NORM, _balanced

        short = h * _balanced(config)[4] <= TAYLOR_NORM
        if np.any(short):
            for k in free:
                v = _velocity_series(config, self._free[k], st.z[steps[short]], D[short], h[short])
                group = self._cols[k] // N_INPUT
                f = D[short, (_P + 1) * group : (_P + 1) * (group + 1)] * _scales(h[short], _P + 1)
                self.work[k] += float(np.sum(h[short] * _integral(f, v, lo[short], hi[short])))
        if not np.all(short):  # a step too long for the series: Gauss–Legendre on its exact states
            from camsim.engine.dense import DenseStretch

            dense = DenseStretch(ctx, config, st.branches, st.v_impacts, True, t, st.z, st.u, None)
            longs = np.flatnonzero(~short)
            sigma = lo[longs, None] + (hi - lo)[longs, None] * _SIGMA[None, :]
            Zs, Ug = dense.states(steps[longs], sigma)
            S, P, m = Zs.shape
            v = config.v(Zs.reshape(S * P, m), Ug.reshape(S * P, -1)).reshape(S, P, -1)
            width = (hi - lo)[longs] * h[longs]
            for k in free:
                g = Ug[:, :, self._cols[k]] * v[:, :, self._free[k]]
                self.work[k] += float(np.sum(width * (g @ _WEIGHT)))

    def _hermite(self, ctx, dense, steps, lo, hi, width, free) -> None:
        """The two-point Hermite rule of order six on the nodes of a nonlinear stretch:
        h/2·(g₀ + g₁) + h²/10·(ġ₀ − ġ₁) + h³/120·(g̈₀ + g̈₁), g = F·ẋ, ġ = Ḟ·ẋ + F·ẍ,
        g̈ = F̈·ẋ + 2Ḟ·ẍ + F·x⃛, the mass's jerk x⃛ from the configuration's equations and the
        closed contacts' tangents (the window's edges inside a step: their states by DOP853
        from the step's start node)."""
        config = dense.config
        ends = []
        for frac in (lo, hi):
            at_node = (frac == 0.0) | (frac == 1.0)
            Z = np.where(frac[:, None] == 1.0, dense.Z[steps + 1], dense.Z[steps])
            U = np.where(frac[:, None] == 1.0, dense.U[steps + 1], dense.U[steps])
            inner = np.flatnonzero(~at_node)
            if inner.size:
                z_e, u_e = dense.states(steps[inner], frac[inner][:, None])
                Z[inner], U[inner] = z_e[:, 0], u_e[:, 0]
            ends.append((U, *self._kinematics(ctx, config, Z, U, dense.v_impacts)))
        (U0, v0, a0, j0), (U1, v1, a1, j1) = ends
        h = width
        for k in free:
            c, i = self._cols[k], self._free[k]
            g = [U[:, c] * v[:, i] for U, v in ((U0, v0), (U1, v1))]
            d = [U[:, c + 1] * v[:, i] + U[:, c] * a[:, i] for U, v, a in ((U0, v0, a0), (U1, v1, a1))]
            dd = [U[:, c + 2] * v[:, i] + 2.0 * U[:, c + 1] * a[:, i] + U[:, c] * j[:, i]
                  for U, v, a, j in ((U0, v0, a0, j0), (U1, v1, a1, j1))]
            self.work[k] += float(np.sum(0.5 * h * (g[0] + g[1]) + h**2 / 10.0 * (d[0] - d[1])
                                         + h**3 / 120.0 * (dd[0] + dd[1])))

    @staticmethod
    def _kinematics(ctx, config, Z, U, v_impacts):
        """Velocities, accelerations and jerks of the free masses at states Z with inputs U (a
        nonlinear configuration): ȧ = a_z·ż + a_u·u̇ + a_F·Ḟ_nl, each closed contact's
        Ḟ = ∂F/∂δ·δ̇ + ∂F/∂δ̇·δ̈ (its tangent)."""
        from camsim.elements.affine import input_rate

        fn = ctx.nonlinear_forces(config, Z, U, v_impacts)
        v, a = config.v(Z, U, fn), config.a(Z, U, fn)
        zdot = Z @ config.A.T + U @ config.B.T + config.b + (fn @ config.L.T if config.L.shape[1] else 0.0)
        udot = input_rate(U)
        fdot = np.zeros_like(fn)
        for k, i in enumerate(config.power_contacts):
            delta, rate = ctx._delta(config, i)
            d = delta(Z, U)[:, 0]
            dd = rate(Z, U)[:, 0]
            ddd = zdot @ rate.Cz[0] + udot @ rate.Du[0]
            kt, ct = _slopes(ctx.model.acting(i, config.branches), d, dd, v_impacts.get(i))
            fdot[:, k] = kt * dd + ct * ddd
        jerk = zdot @ config.a.Cz.T + udot @ config.a.Du.T + (fdot @ config.a.Fn.T if fn.shape[1] else 0.0)
        return v, a, jerk

    def values(self) -> dict[str, float]:
        """Each load's work [J] over the window (NaN when the run did not cover it)."""
        complete = self.covered >= (self.hi - self.lo) * (1.0 - 1e-9)
        return {load.name: (float(w) if complete else math.nan) for load, w in zip(self.model.loads, self.work)}


def _slopes(law, delta, rate, v_impact):
    """(∂F/∂δ, ∂F/∂δ̇) of a closed nonlinear law on samples: its tangent, or for a law without
    one (ElastoGap with n ≠ 1, integrated by DOP853) central differences of its force."""
    tangent = getattr(law, "nonlinear_tangent", None)
    if tangent is not None:
        return tangent(delta, rate, v_impact)[1:]
    force = law.nonlinear_force
    hd = 1e-7 * np.maximum(np.abs(delta), 1e-12)
    hr = 1e-7 * np.maximum(np.abs(rate), 1e-9)
    kt = (force(delta + hd, rate, v_impact) - force(delta - hd, rate, v_impact)) / (2.0 * hd)
    ct = (force(delta, rate + hr, v_impact) - force(delta, rate - hr, v_impact)) / (2.0 * hr)
    return kt, ct


def work_window(machine, t_rec: float, t_end: float, period: float | None) -> tuple[tuple[float, float], bool]:
    """The window of the work per cycle [s, simulation clock]: the first recorded revolution,
    or the record without a cam (or when it is shorter); and whether it is a revolution."""
    if period is not None and math.isfinite(period) and t_end >= t_rec + period * (1.0 - 1e-12):
        return (t_rec, t_rec + period), True
    return (t_rec, t_end), False


def work_over(machine) -> str:
    """``"revolution"`` when a run of ``machine`` records at least one revolution (its work is
    per cycle), ``"record"`` otherwise (no cam, or a ``duration`` shorter than a revolution)."""
    cam = machine.cam
    if cam is None:
        return "record"
    duration = machine.simulation.duration
    return "record" if duration is not None and duration < cam.period * (1.0 - 1e-12) else "revolution"


# ---------------------------------------------------------------------- scalars and summary
def _extreme(result, name: str, which: str):
    """(value, time) of a load's located maximum or minimum; a result without located extremes
    (read from an old file) gives its samples'; None without either."""
    path = f"loads/{name}/force"
    hit = (getattr(result, "located", None) or {}).get(path)
    if hit is not None:
        return hit[which].value, hit[which].time
    extreme = getattr(result, "extreme", None)
    return extreme(path, which) if extreme is not None else None


def load_row(result) -> dict[str, float]:
    """The :func:`load_columns` scalars of a result (its located extremes; its work)."""
    work = getattr(result, "load_work", None) or {}
    out = {}
    for load in getattr(result.machine, "loads", ()):
        top, bottom = _extreme(result, load.name, "max"), _extreme(result, load.name, "min")
        out[f"max_load:{load.name}"] = top[0] if top is not None else math.nan
        out[f"min_load:{load.name}"] = bottom[0] if bottom is not None else math.nan
        out[f"load_work:{load.name}"] = float(work.get(load.name, math.nan))
    return out


def load_summary(result) -> dict[str, dict] | None:
    """Per load: the mass, the program, the located largest and smallest force (``{"value",
    "time"}``, SI) and the work per cycle [J] (``work_over``: ``"revolution"`` or
    ``"record"``); None without loads."""
    loads = getattr(result.machine, "loads", ())
    if not loads:
        return None
    work = getattr(result, "load_work", None) or {}
    over = work_over(result.machine)
    out = {}
    for load in loads:
        entry = {"on": load.on, "program": program_text(load)}
        for which in ("max", "min"):
            hit = _extreme(result, load.name, which)
            entry[which] = {"value": hit[0], "time": hit[1]} if hit is not None else None
        w = work.get(load.name)
        entry["work"] = None if w is None or math.isnan(w) else float(w)
        entry["work_over"] = over
        out[load.name] = entry
    return out

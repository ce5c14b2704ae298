"""The fit's solver: simulations on demand (cached, in parallel) and least squares.

:class:`Evaluator` runs the machine at parameter vectors through the executors of
:mod:`camsim.analyses.sweep.runner` (serial or a local process pool; the task is
:func:`camsim.analyses.sweep.runner.run_variant`, so a fitted run is exactly a ``camsim run`` of the
machine with the fitted values as ``--set`` overrides) and caches each run's traces by
the parameter vector, so no vector is simulated twice.

:func:`solve` minimises ½ Σ r² with :func:`scipy.optimize.least_squares` (method
``trf``, trust-region reflective, within the bounds). The optimiser works on coordinates
u ∈ [0, 1]: each parameter mapped linearly (or, for ``--log``, logarithmically) between
its bounds, so that every variable has the same scale (``x_scale`` = 1 there, i.e. the
span of the bounds in the parameter's own units). The Jacobian is a forward difference
with step :data:`FD_STEP` in u (stepping inward at an upper bound); the perturbed
simulations of one Jacobian run in parallel (``workers``). A time shift (``--align
offset``) needs no simulation of its own: it moves the measured times against the cached
run. With ``starts`` > 1 the first start is the given one and the others are a seeded
Latin hypercube (:class:`scipy.stats.qmc.LatinHypercube`) in the bounds; the lowest cost
wins.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from camsim.errors import SimulationError

__all__ = ["FD_STEP", "Evaluator", "Solution", "solve", "jacobian"]

#: Forward-difference step of the Jacobian, in the coordinates scaled to the bounds.
FD_STEP = 1e-4
#: Forward-difference step of a fit with scalar ``--target`` values. A peak is the largest
#: of the samples, so it moves in steps as the peak slides between samples: over a step of
#: 1e-4 of the bounds the jitter can outweigh (even reverse) the trend, and the solver then
#: stopped short of a reachable target (issue 26: ended at 981.8 m/s² where 400 was within
#: the bounds; with this step it reaches it). 1 % of the bounds spans many sample spacings.
TARGET_FD_STEP = 1e-2
#: Stopping tolerances of least_squares (relative change of cost, of u, and gradient norm).
FTOL = 1e-8
XTOL = 1e-8
GTOL = 1e-8
#: Central-difference step of the final Jacobian used for the uncertainty.
CD_STEP = 1e-4


@dataclass
class Run:
    """What the fit keeps of one simulation: the time base, the needed traces, the scalars."""

    time: np.ndarray
    traces: dict[str, np.ndarray]
    scalars: dict[str, float]


class Evaluator:
    """Simulations of the machine at SI parameter vectors, cached, run in parallel.

    Parameters
    ----------
    source : camsim.analyses.sweep.runner.MachineSource
    fixed : sequence of str
        ``--set`` overrides applied first.
    keys : sequence of str
        The simulated parameters' keys.
    paths : sequence of str
        Traces to keep.
    settings : camsim.analyses.sweep.runner.SweepSettings
        Cycles, warm-up, sample rate (``keep_traces`` is forced on).
    workers : int
        Processes for simultaneous runs (1: in this process).
    """

    def __init__(self, source, fixed: Sequence[str], keys: Sequence[str], paths: Sequence[str], settings, workers: int = 1,
                 store=None):
        from dataclasses import replace

        from camsim.analyses.executors import make_executor

        self.source = source
        self.fixed = tuple(fixed)
        self.keys = list(keys)
        self.paths = list(paths)
        self.settings = replace(settings, keep_traces=True)
        self.cache: dict[tuple[float, ...], Run] = {}
        self.count = 0
        # The crash-safe row store (camsim.io.rowstore) keeps every finished evaluation, so
        # a fit interrupted by Ctrl-C or a kill resumes without simulating them again.
        self.store = store
        if store is not None:
            for row in store.rows().values():
                key, run = _run_from_row(row, self.keys)
                self.cache[key] = run
        self.resumed = len(self.cache)
        self.executor = make_executor(max(1, workers), max(1, min(workers, 2 * len(self.keys))), None, None)

    def overrides(self, x: Sequence[float]) -> tuple[str, ...]:
        """The ``KEY=VALUE`` overrides (SI) that set the parameters to ``x``."""
        from camsim.analyses.fit.params import override_text

        return self.fixed + tuple(override_text(k, float(v)) for k, v in zip(self.keys, x))

    def runs(self, points: Sequence[Sequence[float]]) -> list[Run]:
        """The runs at ``points`` (SI vectors), simulating those not yet cached.

        Raises
        ------
        SimulationError
            A run failed (naming the parameter values).
        """
        from camsim.analyses.fit.measured import trace
        from camsim.analyses.fit.objective import run_scalars
        from camsim.analyses.sweep import runner as sweep  # run_variant looked up at call time (tests replace it)

        keys = [tuple(float(v) for v in p) for p in points]
        todo = list(dict.fromkeys(k for k in keys if k not in self.cache))
        if todo:
            tasks = [(self.source, self.overrides(k), self.settings) for k in todo]
            for i, (row, result) in self.executor.run(tasks, sweep.run_variant, sweep.failed_row):
                if row.get("status") != "ok" or result is None:
                    where = ", ".join(f"{k}={v:.6g}" for k, v in zip(self.keys, todo[i]))
                    raise SimulationError(f"fit: the run at {where} failed: {row.get('status')}")
                run = Run(
                    time=np.asarray(result.time, dtype=float),
                    traces={p: trace(result, p) for p in self.paths},
                    scalars=run_scalars(result),
                )
                self.cache[todo[i]] = run
                if self.store is not None:
                    self.store.append(len(self.cache) - 1, _row_of(todo[i], run, self.keys))
                self.count += 1
        return [self.cache[k] for k in keys]

    def close(self) -> None:
        """Stop the worker processes."""
        self.executor.close()

    def abort(self) -> None:
        """Stop the worker processes now (Ctrl-C)."""
        self.executor.abort()


def store_columns(keys: Sequence[str]) -> list[tuple[str, str]]:
    """Columns of a fit's evaluation store: each parameter's SI value, and the run (JSON)."""
    from camsim.analyses.sweep.runner import key_unit

    return [(f"param:{k}", key_unit(k)) for k in keys] + [("run", "")]


def _row_of(key: tuple[float, ...], run: Run, keys: Sequence[str]) -> dict:
    import json

    data = {"time": run.time.tolist(), "traces": {p: np.asarray(v, dtype=float).tolist() for p, v in run.traces.items()},
            "scalars": {k: float(v) for k, v in run.scalars.items()}}
    return {**{f"param:{k}": float(v) for k, v in zip(keys, key)}, "run": json.dumps(data, allow_nan=True)}


def _run_from_row(row: dict, keys: Sequence[str]) -> tuple[tuple[float, ...], Run]:
    import json

    data = json.loads(row["run"])
    run = Run(time=np.asarray(data["time"], dtype=float),
              traces={p: np.asarray(v, dtype=float) for p, v in data["traces"].items()},
              scalars={k: float(v) for k, v in data["scalars"].items()})
    return tuple(float(row[f"param:{k}"]) for k in keys), run


@dataclass
class Problem:
    """The pieces :func:`solve` needs: parameters, how to split them, the objective."""

    params: list  # Parameter-like: from_unit, to_unit, key
    n_sim: int  # the first n_sim parameters are simulated; the rest (a shift) are not
    evaluator: Evaluator
    objective: object

    def x(self, u: np.ndarray) -> np.ndarray:
        return np.array([p.from_unit(float(ui)) for p, ui in zip(self.params, u)])

    @property
    def fd_step(self) -> float:
        """The finite-difference step in u: :data:`TARGET_FD_STEP` with scalar targets, else :data:`FD_STEP`."""
        return TARGET_FD_STEP if getattr(self.objective, "targets", None) else FD_STEP

    def residuals_at(self, xs: Sequence[np.ndarray]) -> list[np.ndarray]:
        runs = self.evaluator.runs([x[: self.n_sim] for x in xs])
        out = []
        for x, run in zip(xs, runs):
            shift = float(x[self.n_sim]) if len(x) > self.n_sim else 0.0
            out.append(self.objective.residuals(run.time, run.traces, run.scalars, shift))
        return out


def jacobian(problem: Problem, u: np.ndarray, r0: np.ndarray | None = None, central: bool = False, step: float | None = None) -> np.ndarray:
    """d r / d u by finite differences; the perturbed runs are simulated together.

    Forward differences (step inward at the upper bound), or central ones where both
    sides lie within [0, 1] when ``central``. ``step`` defaults to :attr:`Problem.fd_step`.
    """
    if step is None:
        step = problem.fd_step
    n = u.size
    points, plan = [], []
    for i in range(n):
        if central and step <= u[i] <= 1.0 - step:
            up, dn = u.copy(), u.copy()
            up[i] += step
            dn[i] -= step
            plan.append((len(points), len(points) + 1, 2 * step))
            points += [up, dn]
        else:
            h = step if u[i] + step <= 1.0 else -step
            p = u.copy()
            p[i] += h
            plan.append((len(points), None, h))
            points.append(p)
    rs = problem.residuals_at([problem.x(p) for p in points])
    if r0 is None and any(b is None for _, b, _ in plan):
        r0 = problem.residuals_at([problem.x(u)])[0]
    jac = np.empty((rs[0].size if rs else 0, n))
    for i, (a, b, h) in enumerate(plan):
        jac[:, i] = (rs[a] - (rs[b] if b is not None else r0)) / h
    return jac


@dataclass
class Solution:
    """One least-squares run."""

    u: np.ndarray
    cost: float
    converged: bool
    status: int
    message: str
    nfev: int
    start_u: np.ndarray


def _one_start(problem: Problem, u0: np.ndarray, max_nfev: int | None, report: Callable[[str], None] | None, label: str) -> Solution:
    from scipy.optimize import least_squares

    state = {"iteration": 0}

    def fun(u):
        return problem.residuals_at([problem.x(u)])[0]

    def jac(u):
        r0 = fun(u)
        if report is not None:
            x = problem.x(u)
            shown = ", ".join(f"{p.key}={v:.6g}" for p, v in zip(problem.params, x))
            report(f"{label}iteration {state['iteration']}: cost {0.5 * float(r0 @ r0):.6g}; {shown}")
        state["iteration"] += 1
        return jacobian(problem, np.asarray(u, dtype=float), r0)

    sol = least_squares(
        fun,
        u0,
        jac=jac,
        bounds=(np.zeros(u0.size), np.ones(u0.size)),
        method="trf",
        x_scale=np.ones(u0.size),
        max_nfev=max_nfev,
        ftol=FTOL,
        xtol=XTOL,
        gtol=GTOL,
    )
    return Solution(
        u=np.asarray(sol.x, dtype=float),
        cost=float(sol.cost),
        converged=bool(sol.status > 0),
        status=int(sol.status),
        message=str(sol.message),
        nfev=int(sol.nfev),
        start_u=np.asarray(u0, dtype=float),
    )


def start_points(params: Sequence, starts: int, seed: int) -> list[np.ndarray]:
    """The given start, then ``starts - 1`` Latin-hypercube points in [0, 1]^n (seeded)."""
    first = np.array([p.to_unit(p.start) for p in params], dtype=float)
    points = [np.clip(first, 0.0, 1.0)]
    if starts > 1:
        from scipy.stats import qmc

        sample = qmc.LatinHypercube(d=len(params), seed=np.random.default_rng(seed)).random(starts - 1)
        points += [np.asarray(row, dtype=float) for row in sample]
    return points


def solve(
    problem: Problem,
    starts: int = 1,
    seed: int = 0,
    max_nfev: int | None = None,
    report: Callable[[str], None] | None = None,
) -> tuple[Solution, list[Solution]]:
    """Minimise ½ Σ r² from each start; return the best solution and all of them.

    Parameters
    ----------
    problem : Problem
    starts : int
        Number of starts (the given one plus Latin-hypercube points).
    seed : int
        Seed of the Latin hypercube.
    max_nfev : int, optional
        Largest number of residual evaluations per start (``least_squares``'s
        ``max_nfev``; Jacobian runs are not counted). Default: scipy's (100 n).
    report : callable, optional
        Called with one progress line per iteration.
    """
    solutions = []
    points = start_points(problem.params, starts, seed)
    for k, u0 in enumerate(points):
        label = f"start {k + 1}/{len(points)}: " if len(points) > 1 else ""
        sol = _one_start(problem, u0, max_nfev, report, label)
        solutions.append(sol)
        if report is not None:
            state = "converged" if sol.converged else "not converged"
            report(f"{label}{state} after {sol.nfev} evaluations: cost {sol.cost:.6g} ({sol.message})")
    best = min(solutions, key=lambda s: (math.inf if not math.isfinite(s.cost) else s.cost))
    return best, solutions

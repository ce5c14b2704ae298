"""Evaluating candidates: the runs of each (every speed × every robust sample), cached and stored.

A *candidate* is one set of variable values; an *evaluation* of it is every run it needs:
one per ``--speeds`` speed, times N samples with ``--robust``. Runs are the study's task
(:func:`camsim.analyses.study.runner.run_sample`, i.e. an ordinary run of the machine with
``--set`` overrides), so an optimised machine is exactly a ``camsim run`` of
``OPTIMISED.toml``. The runs of a whole batch of candidates (a population of the
differential evolution, the speeds of one candidate) go to the executor together
(:mod:`camsim.analyses.executors`: serial, process pool or Dask).

Every finished run is appended to a :class:`~camsim.io.rowstore.RowStore` (its journal is
fsync'ed before the next one is counted), keyed by its exact overrides. The solvers are
deterministic (seeded, and a batch does not depend on the order in which its runs
finish), so ``--resume`` simply runs the solver again from the start with the stored runs
as a cache: it asks for the same candidates in the same order, finds every run that had
finished, and runs only the rest — no evaluation lost, none repeated.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from camsim.analyses.optimize.problem import Problem, assignment
from camsim.analyses.optimize.robust import is_binary, quantile_margin, violation_probability
from camsim.analyses.study.outputs import OutputExpr, ParamExpr

__all__ = ["Candidate", "Evaluator", "BudgetExhausted", "FAILED_MARGIN"]

#: Scaled constraint value of a candidate whose run failed (finite, so the solvers can rank it).
FAILED_MARGIN = 1e6


class BudgetExhausted(Exception):
    """The ``--budget`` of candidate evaluations is used up."""


@dataclass
class Candidate:
    """One evaluated candidate.

    Attributes
    ----------
    index : int
        Order of evaluation (0 = first).
    values : dict
        Variable key -> value [SI] or option text (and the absorbing duration).
    objectives : list of float
        Each goal's worst value over the speeds [SI] (mean over the samples with --robust).
    per_speed : list of dict
        Per speed: ``speed`` [rad/s or None], ``objectives`` [SI], ``constraints`` (value,
        margin, and with --robust the probability and its interval).
    g : ndarray
        Scaled constraint values seen by the solver, ≤ 0 when satisfied.
    feasible : bool
    violation : float
        Sum of the positive scaled constraint values (0 when feasible).
    status : str
        ``ok``, or why it has no value (a failed run, an absorbing duration ≤ 0).
    """

    index: int
    values: dict[str, Any]
    objectives: list[float]
    per_speed: list[dict]
    g: np.ndarray
    feasible: bool
    violation: float
    status: str = "ok"
    x: tuple = ()

    def f(self, goal_senses: Sequence[str]) -> list[float]:
        """Objectives in minimisation form (+inf where unknown)."""
        out = []
        for v, sense in zip(self.objectives, goal_senses):
            if not math.isfinite(v):
                out.append(math.inf)
            else:
                out.append(v if sense == "min" else -v)
        return out


@dataclass
class RunSpec:
    """What the evaluator runs: settings shared by every run."""

    cycles: int | None = None
    warmup_cycles: int | None = None
    sample_rate: float | None = None


class Evaluator:
    """Candidates -> runs (cached by their overrides, stored, in parallel) -> :class:`Candidate`.

    Parameters
    ----------
    source : MachineSource
    fixed : sequence of str
        ``--set`` overrides (first in every run).
    problem : Problem
    draws : list of list of str
        With --robust: for each of the N samples, its ``KEY=VALUE`` overrides (a key that
        is also a variable holds the *deviation* from its nominal, added to the candidate).
    deviations : dict
        Per sample index: key -> deviation [SI] for the keys that are also variables.
    executor : executor of :mod:`camsim.analyses.executors`
    store : RowStore or None
    cache : dict
        Overrides text -> stored run row (from a resumed journal).
    budget : int or None
        Largest number of candidate evaluations.
    """

    def __init__(self, source, fixed, problem: Problem, spec: RunSpec, *, draws=None, deviations=None,
                 executor=None, store=None, cache=None, budget=None, p_max: float = 1e-3, seed: int = 0,
                 scales: Sequence[float] | None = None,
                 progress: Callable[[int, int | None, float | None], None] | None = None):
        from camsim.analyses.executors import Serial
        from camsim.analyses.study.runner import RunSettings

        self.source = source
        self.fixed = tuple(fixed)
        self.problem = problem
        self.spec = spec
        self.exprs = problem.run_exprs
        self.settings = RunSettings(outputs=tuple(e for e in self.exprs if isinstance(e, OutputExpr)),
                                    cycles=spec.cycles, warmup_cycles=spec.warmup_cycles, sample_rate=spec.sample_rate)
        self.draws = draws or [[]]
        self.deviations = deviations or [{}]
        self.executor = executor or Serial()
        self.store = store
        self.cache: dict[str, dict] = dict(cache or {})
        self.next_run = max([int(r.get("run", -1)) for r in self.cache.values()], default=-1) + 1
        self.budget = budget
        self.p_max = p_max
        self.seed = seed
        self.progress = progress
        self.candidates: list[Candidate] = []
        self.by_key: dict[tuple, Candidate] = {}
        self.scales = list(scales) if scales is not None else None
        self.runs_made = 0
        self.runs_reused = 0
        self.lost = 0

    # -- candidates ----------------------------------------------------------------------
    def values_of(self, x: Sequence[float]) -> dict[str, Any]:
        """Variable values of solver coordinates ``x`` (and the absorbing duration)."""
        values = {v.key: v.from_unit(u) for v, u in zip(self.problem.variables, x)}
        absorbed = self.problem.absorbed(values)
        if absorbed is not None:
            values[self.problem.absorb] = absorbed
        return values

    def _key(self, values: dict[str, Any]) -> tuple:
        return tuple((k, v if isinstance(v, str) else float(v)) for k, v in values.items())

    def overrides(self, values: dict[str, Any], speed: float | None, sample: int) -> tuple[str, ...]:
        out = list(self.fixed)
        dev = self.deviations[sample] if self.problem.robust else {}
        for v in self.problem.variables:
            value = values[v.key]
            if v.key in dev:
                value = float(value) + dev[v.key]
            out.append(v.assignment(value))
        if self.problem.absorb is not None:
            out.append(assignment(self.problem.absorb, float(values[self.problem.absorb])))
        if speed is not None:
            out.append(f"cam.speed={float(speed)!r}")
        if self.problem.robust:
            out.extend(self.draws[sample])
        return tuple(out)

    def evaluate(self, xs: Sequence[Sequence[float]]) -> list[Candidate]:
        """Evaluate a batch of candidates (solver coordinates); runs in parallel, cached.

        Raises
        ------
        BudgetExhausted
            Before running a batch that would exceed the budget (the candidates of the
            batch that fit are evaluated first).
        """
        wanted = []
        for x in xs:
            values = self.values_of(x)
            key = self._key(values)
            wanted.append((tuple(float(u) for u in x), values, key))
        new = []
        for item in wanted:
            if item[2] not in self.by_key and item[2] not in [n[2] for n in new]:
                new.append(item)
        over = False
        if self.budget is not None and len(self.candidates) + len(new) > self.budget:
            new = new[: max(0, self.budget - len(self.candidates))]
            over = True
        self._run_batch(new)
        if over:
            raise BudgetExhausted()
        return [self.by_key[item[2]] for item in wanted]

    def _run_batch(self, new) -> None:
        from camsim.analyses.executors import EXECUTOR_ERROR
        from camsim.analyses.study.runner import run_sample
        from camsim.analyses.sweep.runner import failed_row

        n_samples = len(self.draws) if self.problem.robust else 1
        tasks, where = [], []
        plan = []
        for x, values, key in new:
            absorbed = values.get(self.problem.absorb) if self.problem.absorb else None
            runs = {}
            if absorbed is None or absorbed > 0:
                for si, speed in enumerate(self.problem.speeds):
                    for j in range(n_samples):
                        ov = self.overrides(values, speed, j)
                        text = "\n".join(ov)
                        runs[(si, j)] = text
                        if text not in self.cache and text not in where:
                            tasks.append((self.source, ov, self.settings))
                            where.append(text)
            plan.append((x, values, key, runs))
        if tasks:
            names = {e.text for e in self.exprs}
            for k, (row, _) in self.executor.run(tasks, run_sample, failed_row):
                text = where[k]
                if row.get(EXECUTOR_ERROR):
                    self.lost += 1
                    raise KeyboardInterrupt  # a killed worker: stop, keep what is stored, resume reruns it
                kept = {"run": self.next_run, "overrides": text, "status": str(row.get("status", ""))}
                for name in names:
                    v = row.get(name, math.nan)
                    kept[name] = float(v) if isinstance(v, (int, float, np.number)) and v is not None else math.nan
                self.next_run += 1
                self.runs_made += 1
                if self.store is not None:
                    self.store.append(kept["run"], kept)
                self.cache[text] = kept
        for x, values, key, runs in plan:
            cand = self._candidate(x, values, runs)
            self.candidates.append(cand)
            self.by_key[key] = cand
            if self.progress is not None:
                self.progress(len(self.candidates), self.budget, self.best_value())

    def _candidate(self, x, values, runs) -> Candidate:
        p = self.problem
        n_samples = len(self.draws) if p.robust else 1
        absorbed = values.get(p.absorb) if p.absorb else None
        g: list[float] = []
        per_speed = []
        objectives_per_speed = []
        status = "ok"
        if absorbed is not None and absorbed <= 0:
            status = f"infeasible: the absorbing duration {p.absorb} would be {math.degrees(absorbed):.6g} deg (≤ 0)"
            g = [1.0 + (-absorbed) / (2 * math.pi)] + [0.0] * (len(p.constraints) * len(p.speeds))
            return Candidate(len(self.candidates), values, [math.nan] * len(p.goals), [], np.array(g), False,
                             float(g[0]), status, x)
        if absorbed is not None:
            g.append(-absorbed / (2 * math.pi))
        for si, speed in enumerate(p.speeds):
            rows = [self.cache[runs[(si, j)]] for j in range(n_samples)]
            bad = [r["status"] for r in rows if r["status"] != "ok"]
            if bad and status == "ok":
                status = bad[0]

            def column(expr):
                if isinstance(expr, ParamExpr):
                    return np.full(n_samples, float(values[expr.key]) if not isinstance(values[expr.key], str) else math.nan)
                return np.array([r.get(expr.text, math.nan) if r["status"] == "ok" else math.nan for r in rows], dtype=float)

            objs = []
            for goal in p.goals:
                col = column(goal.expr)
                objs.append(float(np.mean(col)) if np.all(np.isfinite(col)) else math.nan)
            objectives_per_speed.append(objs)
            cons = []
            for ci, c in enumerate(p.constraints):
                col = column(c.expr)
                margins = np.array([c.margin(v) for v in col])
                scale = self.scales[ci] if self.scales else 1.0
                entry = {"expr": c.text, "value": float(np.mean(col)) if col.size else math.nan}
                if not np.all(np.isfinite(margins)):
                    gv = FAILED_MARGIN
                elif p.robust:
                    binary = is_binary(col)
                    gv = quantile_margin(margins, self.p_max, binary) / scale
                    entry.update(violation_probability(margins, binary, self.seed + ci))
                    entry["quantile_margin"] = gv * scale
                else:
                    gv = float(margins[0]) / scale
                entry["margin"] = float(np.mean(margins)) if np.all(np.isfinite(margins)) else math.nan
                entry["satisfied"] = bool(gv <= 0)
                g.append(float(gv))
                cons.append(entry)
            per_speed.append({"speed": speed, "objectives": objs, "constraints": cons})
        objectives = []
        for k, goal in enumerate(p.goals):
            vals = [o[k] for o in objectives_per_speed]
            if not all(math.isfinite(v) for v in vals):
                objectives.append(math.nan)
            else:
                objectives.append(max(vals) if goal.sense == "min" else min(vals))
        garr = np.array(g, dtype=float)
        violation = float(np.sum(np.clip(garr, 0.0, None))) if garr.size else 0.0
        feasible = status == "ok" and violation == 0.0 and all(math.isfinite(v) for v in objectives)
        if status != "ok" and violation == 0.0:
            violation = FAILED_MARGIN
        return Candidate(len(self.candidates), values, objectives, per_speed, garr, feasible, violation, status, x)

    # -- summaries -----------------------------------------------------------------------
    def n_constraints(self) -> int:
        return (1 if self.problem.absorb else 0) + len(self.problem.constraints) * len(self.problem.speeds)

    def best_value(self, goal: int = 0) -> float | None:
        senses = [g.sense for g in self.problem.goals]
        best = None
        for c in self.candidates:
            if c.feasible:
                v = c.f(senses)[goal]
                if best is None or v < best[0]:
                    best = (v, c.objectives[goal])
        return None if best is None else best[1]

    def best(self, goal: int = 0) -> Candidate | None:
        """The feasible candidate with the best objective ``goal`` (first found wins ties)."""
        senses = [g.sense for g in self.problem.goals]
        feas = [c for c in self.candidates if c.feasible]
        if not feas:
            return None
        return min(feas, key=lambda c: (c.f(senses)[goal], c.index))

    def least_violating(self) -> Candidate | None:
        if not self.candidates:
            return None
        return min(self.candidates, key=lambda c: (c.violation, c.index))

"""``camsim.optimize``: design a machine to its limits, over a speed range, robust to tolerances.

The steps of :func:`optimize`:

1. parse and check the problem against the machine (:mod:`.problem`): nothing runs and
   nothing is written on bad input;
2. run the machine as the file gives it (at the first speed): it checks every expression
   (an unknown scalar or trace lists what exists), gives the expressions' units (for the
   constraint limits) and the scale of each constraint;
3. with ``robust``, draw the N samples of the ``--dist`` inputs once (common random
   numbers, :mod:`camsim.analyses.study.sampling`, seeded);
4. run the solver (:mod:`.solvers`) over an :class:`~.evaluate.Evaluator` that runs each
   candidate at every speed (and sample) through the shared executors and stores every run
   in the row store (``history``), for ``resume``;
5. the optimum (or, when nothing is feasible, the least-violating candidate), its
   constraints per speed, the active ones, the Pareto front; ``OPTIMISED.toml`` and the
   history file (:mod:`.files`).
"""

from __future__ import annotations

import hashlib
import math
import os
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from camsim.errors import InputError, SimulationError
from camsim.analyses.optimize.evaluate import BudgetExhausted, Candidate, Evaluator, RunSpec
from camsim.analyses.optimize.problem import Problem, build_problem, expression_units

__all__ = ["optimize", "OptimizeResult", "OptimizeInterrupted", "METHODS", "DEFAULT_BUDGET"]

METHODS = ("de", "local", "pareto")
#: Candidate evaluations by default.
DEFAULT_BUDGET = {"de": 300, "local": 60, "pareto": 120}
#: Relative closeness to a limit at which a constraint is reported active.
ACTIVE_TOLERANCE = 1e-3
_RPM = 60.0 / (2.0 * math.pi)


class OptimizeInterrupted(KeyboardInterrupt):
    """Ctrl-C (or SIGTERM, or a lost worker) stopped the optimisation; the stored runs are kept."""

    def __init__(self, evaluations: int, runs: int, history: Path | None, lost: int = 0, made: int = 0):
        super().__init__(f"{evaluations} evaluations done")
        #: Candidate evaluations completed; simulation runs kept in the history's journal
        #: (0 without a history); runs lost with a worker; runs made by this process.
        self.evaluations, self.runs, self.history, self.lost, self.made = evaluations, runs, history, lost, made


@dataclass
class OptimizeResult:
    """The outcome of an optimisation.

    Attributes
    ----------
    status : str
        ``optimal`` (a feasible optimum was found), ``infeasible`` (no candidate met the
        constraints: :attr:`best` is the least-violating one).
    best : Candidate or None
        The optimum (or the least-violating candidate).
    initial : Candidate or None
        The machine file's values, evaluated the same way (None when the file's values lie
        outside the bounds).
    front : list of Candidate
        The Pareto front (``method="pareto"``), by the first objective.
    candidates : list of Candidate
        Every evaluation, in order.
    """

    status: str
    method: str
    problem: Problem
    best: Candidate | None
    initial: Candidate | None
    front: list[Candidate]
    candidates: list[Candidate]
    runs: int
    runs_reused: int
    seed: int
    budget: int
    executor: str
    units: dict[str, str]
    p_max: float = 1e-3
    samples: int = 0
    notes: list[str] = field(default_factory=list)
    output: Path | None = None
    history: Path | None = None
    source_text: str = ""
    source_name: str = ""
    fixed: list[str] = field(default_factory=list)

    @property
    def feasible(self) -> bool:
        return self.status == "optimal"

    @property
    def values(self) -> dict[str, Any]:
        return {} if self.best is None else dict(self.best.values)

    @property
    def objective(self) -> float:
        return math.nan if self.best is None else self.best.objectives[0]

    def active(self) -> list[str]:
        """Constraints within 0.1 % (of their scale) of their limit at the optimum, at some speed."""
        if self.best is None:
            return []
        out = []
        for c in self.problem.constraints:
            for s in self.best.per_speed:
                e = next((x for x in s["constraints"] if x["expr"] == c.text), None)
                if e is None:
                    continue
                scale = max(abs(c.limit), abs(e["value"]) if math.isfinite(e["value"]) else 0.0)
                margin = e.get("quantile_margin", e["margin"])
                if scale > 0 and math.isfinite(margin) and abs(margin) <= ACTIVE_TOLERANCE * scale:
                    out.append(c.text)
                    break
        return out

    def _candidate_json(self, c: Candidate | None) -> dict | None:
        if c is None:
            return None
        speeds = []
        for s in c.per_speed:
            speeds.append({
                "speed_rpm": None if s["speed"] is None else s["speed"] * _RPM,
                "objectives": s["objectives"],
                "constraints": s["constraints"],
            })
        return {
            "index": c.index,
            "values": {k: v for k, v in c.values.items()},
            "objectives": c.objectives,
            "feasible": c.feasible,
            "violation": c.violation,
            "status": c.status,
            "per_speed": speeds,
        }

    def to_json(self) -> dict:
        """The ``--json`` payload (schema in ``docs/optimize.md``)."""
        p = self.problem
        return {
            "status": self.status,
            "method": self.method,
            "seed": self.seed,
            "budget": self.budget,
            "evaluations": len(self.candidates),
            "runs": self.runs,
            "runs_reused": self.runs_reused,
            "speeds_rpm": [None if s is None else s * _RPM for s in p.speeds],
            "robust": {"samples": self.samples, "max_probability": self.p_max} if p.robust else None,
            "variables": [
                {"key": v.key, "unit": v.unit, "low": None if v.is_choice else v.low,
                 "high": None if v.is_choice else v.high, "log": v.log, "choices": list(v.choices) if v.choices else None,
                 "initial": v.initial, "value": None if self.best is None else self.best.values.get(v.key)}
                for v in p.variables
            ],
            "absorb": None if p.absorb is None else {
                "key": p.absorb, "unit": "rad", "initial": p.absorb_initial,
                "value": None if self.best is None else self.best.values.get(p.absorb)},
            "objectives": [{"expr": g.text, "sense": g.sense, "unit": g.unit,
                            "value": None if self.best is None else self.best.objectives[i],
                            "initial": None if self.initial is None else self.initial.objectives[i]}
                           for i, g in enumerate(p.goals)],
            "constraints": [{"expr": c.text, "op": c.op, "limit": c.limit, "unit": c.unit} for c in p.constraints],
            "active": self.active(),
            "optimum": self._candidate_json(self.best),
            "initial": self._candidate_json(self.initial),
            "front": [{"values": c.values, "objectives": c.objectives} for c in self.front] if self.method == "pareto" else None,
            "output": None if self.output is None else str(self.output),
            "history": None if self.history is None else str(self.history),
            "notes": self.notes,
        }


def _check_size(source, fixed, problem, budget, robust, samples, cycles, warmup_cycles, sample_rate, max_runs,
                max_output) -> None:
    """Know before you start (issue 35): refuse a job of too many runs, or runs too large to
    hold, before the reference run (InputError naming the estimate and the remedies)."""
    from camsim.run.budget import DEFAULT_MAX_OUTPUT, DEFAULT_MAX_RUNS, check_budget, check_runs, estimate_run

    n_speeds = len(problem.speeds)
    n_samples = samples if robust else 1
    counted = f"--budget {budget} evaluations" + (f" x {n_speeds} speeds" if n_speeds > 1 else "") + (
        f" x {n_samples} robust samples" if robust else "") + " + 1 reference"
    fewer = []
    if n_speeds > 1:
        fewer.append("fewer --speeds (a coarser step)")
    if robust:
        fewer.append("fewer robust --samples")
    fewer.append("a smaller --budget")
    check_runs(budget * n_speeds * n_samples + 1, DEFAULT_MAX_RUNS if max_runs is None else max_runs, "optimize",
               counted, "make fewer runs with " + ", ".join(fewer))
    speeds = [s for s in problem.speeds if s is not None]
    slowest = [f"cam.speed={min(speeds)!r}"] if speeds else []  # the longest run: most samples
    machine = source.load(list(fixed) + slowest)
    estimate = estimate_run(machine, cycles=cycles, warmup_cycles=warmup_cycles, sample_rate=sample_rate)
    where = f"{source.source or 'optimize'}" + (f" at {min(speeds) * 60 / (2 * math.pi):.6g} rpm" if speeds else "")
    check_budget(estimate, DEFAULT_MAX_OUTPUT if max_output is None else max_output, where)


def _meta(source, fixed, args: dict) -> dict:
    return {"kind": "camsim optimize", "machine_sha256": hashlib.sha256(source.text.encode()).hexdigest(),
            "set": list(fixed), **args}


def _draws(problem: Problem, dists, samples: int, seed: int, tol_sigma: float):
    """The N robust samples: overrides per sample, and deviations of keys that are variables."""
    from camsim.analyses.study.distributions import parse_dist
    from camsim.analyses.study.sampling import to_values, unit_sample

    parsed = [parse_dist(d, tol_sigma) for d in dists]
    if not parsed:
        raise InputError("--robust: give the tolerances as --dist KEY=SPEC (as in camsim study)")
    keys = [d.key for d in parsed]
    for k in keys:
        if keys.count(k) > 1:
            raise InputError(f"--dist: key {k} is given twice")
    values = to_values(unit_sample(samples, len(parsed), "mc", seed), parsed)
    var_keys = set(problem.param_keys)
    draws, devs = [], []
    for i in range(samples):
        ov, dev = [], {}
        for j, d in enumerate(parsed):
            if d.key in var_keys:
                dev[d.key] = float(values[i, j] - d.nominal)
            else:
                ov.append(f"{d.key}={float(values[i, j])!r}")
        draws.append(ov)
        devs.append(dev)
    return parsed, draws, devs


def optimize(
    machine: str | os.PathLike[str] | Any,
    variables: Sequence[str] = (),
    *,
    minimize: Sequence[str] | str = (),
    maximize: Sequence[str] | str = (),
    constraints: Sequence[str] = (),
    choices: Sequence[str] = (),
    log: Sequence[str] = (),
    absorb: str | None = None,
    speeds: str | Sequence[float] | None = None,
    robust: bool = False,
    dists: Sequence[str] = (),
    samples: int = 32,
    max_probability: float = 1e-3,
    tol_sigma: float = 3.0,
    method: str = "de",
    budget: int | None = None,
    points: int = 11,
    seed: int = 0,
    fixed: Sequence[str] = (),
    cycles: int | None = None,
    warmup_cycles: int | None = None,
    sample_rate: float | None = None,
    workers: int | None = None,
    scheduler: str | None = None,
    dask_local: int | None = None,
    output: str | os.PathLike[str] | None = None,
    history: str | os.PathLike[str] | None = None,
    resume: bool = False,
    fresh: bool = False,
    force: bool = False,
    progress: Callable[[int, int | None, float | None], None] | None = None,
    on_start: Callable[[int, int, str], None] | None = None,
    on_units: Callable[[str, Any], None] | None = None,
    max_runs: int | None = None,
    max_output: float | None = None,
) -> OptimizeResult:
    """Optimise machine keys for an objective under constraints (``camsim optimize``).

    Parameters
    ----------
    machine : path or MachineSource
        The machine file.
    variables : sequence of str
        ``KEY=LOW:HIGH[:START][UNIT]`` continuous variables (``--var``).
    minimize, maximize : str or sequence of str
        Objective expressions (two in all for ``method="pareto"``): a run scalar,
        ``REDUCER:PATH[@FROM:TO]`` or ``param:KEY``.
    constraints : sequence of str
        ``EXPR<=VALUE[UNIT]`` or ``EXPR>=VALUE[UNIT]``.
    choices : sequence of str
        ``KEY=a,b,c`` categorical variables (``de`` and ``pareto`` only... ``de`` only).
    log : sequence of str
        Keys searched on a log scale.
    absorb : str, optional
        ``cam.segments[i].duration`` that takes up the rest of 360°.
    speeds : str or sequence of float, optional
        ``FROM:TO:STEP[UNIT]`` (default unit rpm) or speeds [rad/s]: every candidate runs at
        each; None: the file's speed.
    robust : bool
        Constraints as violation probabilities over ``dists`` (``samples`` common random
        numbers), each ≤ ``max_probability``.
    method : str
        ``de``, ``local`` or ``pareto``.
    budget : int, optional
        Largest number of candidate evaluations (default :data:`DEFAULT_BUDGET`).
    points : int
        Points of the ε-constraint sweep (``pareto``).
    seed : int
        Seed of the solver and of the robust samples.
    fixed : sequence of str
        ``--set`` overrides of every run.
    cycles, warmup_cycles, sample_rate :
        Run settings of every run (None: the file's).
    workers, scheduler, dask_local :
        Executors as in ``sweep`` (default: every core).
    output : path, optional
        ``OPTIMISED.toml``: the machine file with the optimum written in place (not
        written when no candidate is feasible).
    history : path, optional
        HDF5 history of every evaluation; its journal keeps every run for ``resume``.
    force : bool
        Replace an existing result of another camsim command at ``output`` or ``history``.
    resume, fresh : bool
        Continue the interrupted job writing ``history`` / discard its journal.
    progress : callable, optional
        ``progress(evaluations, budget, best_so_far)`` after each candidate.
    on_start : callable, optional
        ``on_start(budget, stored_runs, executor_name)`` once every check passed.
    on_units : callable, optional
        ``on_units(si_unit, machine)`` once the first objective's SI unit is known (from a run
        of the machine as given), before the first candidate: what ``progress`` reports the best
        value in (issue 44: the CLI shows it in the machine file's units).
    max_runs : int, optional
        Refuse (InputError, before anything runs) a job that could make more simulation
        runs: ``budget`` x speeds x robust samples (default
        :data:`camsim.run.budget.DEFAULT_MAX_RUNS`; ``math.inf``: no limit).
    max_output : float, optional
        Refuse a run whose output (held in memory) would be larger [bytes], estimated at
        the slowest speed (default :data:`camsim.run.budget.DEFAULT_MAX_OUTPUT`).

    Returns
    -------
    OptimizeResult

    Raises
    ------
    InputError
        Any bad input (nothing is written).
    SimulationError
        The machine as given does not run.
    OptimizeInterrupted
        Ctrl-C or SIGTERM: every finished run is in the history's journal.
    """
    from camsim.analyses.executors import default_workers, make_executor
    from camsim.analyses.optimize.policy import check_outputs
    from camsim.analyses.sweep.runner import MachineSource

    if method not in METHODS:
        raise InputError(f"--method {method}: unknown method (one of {', '.join(METHODS)})")
    minimize = [minimize] if isinstance(minimize, str) else list(minimize)
    maximize = [maximize] if isinstance(maximize, str) else list(maximize)
    budget = DEFAULT_BUDGET[method] if budget is None else budget
    if isinstance(budget, bool) or not isinstance(budget, (int, np.integer)) or budget < 1:
        raise InputError(f"--budget {budget}: needs a whole number of at least 1")
    if not isinstance(seed, (int, np.integer)) or seed < 0:
        raise InputError(f"--seed {seed}: needs a whole number ≥ 0")
    if not (0.0 < max_probability < 1.0):
        raise InputError(f"--max-probability {max_probability}: must lie strictly between 0 and 1")
    if robust and (isinstance(samples, bool) or samples < 2):
        raise InputError(f"--samples {samples}: --robust needs at least 2 samples")
    if dists and not robust:
        raise InputError("--dist: needs --robust (the tolerances apply to robust constraints)")
    if scheduler is not None and dask_local is not None:
        raise InputError("--scheduler and --dask-local: give one of them, not both")
    workers = default_workers() if workers is None else workers
    if workers < 1:
        raise InputError(f"--workers {workers}: needs at least 1")
    if sample_rate is not None and not sample_rate > 0:
        raise InputError("--sample-rate: must be positive")
    source = machine if isinstance(machine, MachineSource) else MachineSource.from_path(machine)
    problem = build_problem(source, fixed, variables, log, choices, absorb, minimize, maximize, constraints, speeds)
    if method == "pareto" and len(problem.goals) != 2:
        raise InputError("--method pareto: needs two objectives (e.g. --maximize param:cam.speed --minimize maxabs:masses/F/acceleration)")
    if method != "pareto" and len(problem.goals) != 1:
        raise InputError(f"--method {method}: one objective (two objectives need --method pareto)")
    if method in ("local", "pareto") and any(v.is_choice for v in problem.variables):
        raise InputError(f"--choice: needs --method de (a local method cannot search a categorical key)")
    if method == "pareto" and points < 3:
        raise InputError(f"--points {points}: the front needs at least 3")
    x_file = [v.to_unit(v.start) for v in problem.variables]
    inside = all(0.0 <= u <= (v.high if v.is_choice else 1.0) for u, v in zip(x_file, problem.variables))
    if not inside and method == "local":
        raise InputError("--method local: the file's values lie outside the --var bounds; give START (KEY=LOW:HIGH:START)")
    from camsim.io.rowstore import journal_path_for

    journal = journal_path_for(history) if history is not None else None
    inputs = [source.source] if source.source and Path(source.source).exists() else []
    check_outputs(inputs, {"-o": output, "-r": history}, journal, resume, fresh, force)
    _check_size(source, fixed, problem, budget, robust, int(samples), cycles, warmup_cycles, sample_rate,
                max_runs, max_output)

    # The machine as the file gives it: the expressions, their units, the constraint scales.
    from camsim.run.simulation import simulate

    first_speed = problem.speeds[0]
    try:
        ref_machine = source.load(list(fixed) + ([] if first_speed is None else [f"cam.speed={first_speed!r}"]))
        reference = simulate(ref_machine, cycles=cycles, warmup_cycles=warmup_cycles, sample_rate=sample_rate)
    except SimulationError as exc:
        raise SimulationError(f"the machine as given does not run: {exc}") from None
    units = expression_units(problem, reference)
    if on_units is not None and problem.goals:
        on_units(problem.goals[0].unit, ref_machine)
    scales = []
    ref_values = {v.key: v.initial for v in problem.variables}
    for c in problem.constraints:
        from camsim.analyses.study.outputs import ParamExpr

        if isinstance(c.expr, ParamExpr):
            ref = ref_values.get(c.expr.key, 0.0)
        else:
            try:
                ref = c.expr.evaluate(reference)
            except KeyError:
                ref = 0.0
        ref = float(ref) if isinstance(ref, (int, float)) and math.isfinite(float(ref)) else 0.0
        scales.append(max(abs(c.limit), abs(ref)) or 1.0)
    del reference

    parsed_dists, draws, devs = [], None, None
    if robust:
        problem.robust = True
        parsed_dists, draws, devs = _draws(problem, dists, int(samples), int(seed), tol_sigma)

    meta = _meta(source, fixed, {
        "var": list(variables), "choice": list(choices), "log": list(log), "absorb": absorb,
        "minimize": minimize, "maximize": maximize, "constraint": list(constraints),
        "speeds": [None if s is None else float(s) for s in problem.speeds], "robust": bool(robust),
        "dist": list(dists), "samples": int(samples) if robust else 0, "max_probability": float(max_probability),
        "tol_sigma": float(tol_sigma), "method": method, "seed": int(seed), "points": int(points),
        "cycles": cycles, "warmup_cycles": warmup_cycles, "sample_rate": sample_rate,
    })
    names = [e.text for e in problem.run_exprs]
    columns = [("run", ""), ("overrides", "")] + [(n, units.get(n, "")) for n in names] + [("status", "")]
    store, cache = None, {}
    notes: list[str] = []
    if history is not None:
        from camsim.io.hdf5 import write_root_attributes
        from camsim.io.rowstore import RowStore

        def decorate(f) -> None:
            write_root_attributes(f, problem.base, "optimize")
            f.create_group("optimize", track_order=True).attrs["interrupted"] = True

        kwargs = {"table": "optimize/runs", "decorate": decorate}
        if resume:
            store = RowStore.resume(history, meta, **kwargs)
            if store.columns != [tuple(c) for c in columns]:
                store.close()
                raise InputError(f"{store.journal}: cannot resume: the stored columns differ from this job's")
            cache = {r["overrides"]: r for r in store.rows().values()}
            before = store.info.get("budget")
            if before is not None and int(before) != int(budget):  # issue 35: a changed setting is stated
                notes.append(f"resumed with --budget {budget}; the interrupted job had --budget {before} (its "
                             f"{len(cache)} stored runs are reused either way)")
    executor = None
    try:
        executor = make_executor(workers, 10**6, scheduler, dask_local)
        if store is None and history is not None:
            store = RowStore.create(history, columns, meta, info={"budget": int(budget)}, **kwargs)
    except BaseException:
        if store is not None:
            store.close()
        if executor is not None:
            executor.close()
        raise
    ev = Evaluator(source, fixed, problem, RunSpec(cycles, warmup_cycles, sample_rate), draws=draws, deviations=devs,
                   executor=executor, store=store, cache=cache, budget=None, p_max=max_probability, seed=int(seed),
                   scales=scales, progress=progress)
    interrupted = False
    front: list[Candidate] = []
    initial = None
    try:
        if on_start is not None:
            on_start(budget, len(cache), executor.name)
        from camsim.analyses.optimize import solvers

        # The file's values (or START) first: the reference the report compares with.
        ev.budget = budget
        if inside:
            initial = ev.evaluate([tuple(x_file)])[0]
        remaining = budget - len(ev.candidates)
        try:
            if method == "de":
                solvers.solve_de(ev, int(seed), budget, notes=notes)
            elif method == "local":
                solvers.solve_local(ev, remaining, notes=notes)
            else:
                front = solvers.solve_pareto(ev, remaining, int(points), notes=notes)
        except BudgetExhausted:
            notes.append(f"stopped at the budget of {budget} evaluations")
    except KeyboardInterrupt:
        interrupted = True
        try:
            executor.abort()
        except Exception:  # noqa: BLE001 - on the way out
            pass
    finally:
        try:
            executor.close()
        except Exception:  # noqa: BLE001 - workers stopped on purpose
            if not interrupted:
                raise
    if interrupted:
        kept = len(cache) + ev.runs_made if store is not None else 0
        if store is not None:
            if kept:
                store.close()
            else:  # nothing finished: no journal to resume
                store.remove_journal()
        raise OptimizeInterrupted(len(ev.candidates), kept, None if history is None else Path(history), ev.lost,
                                  made=ev.runs_made)

    notes = list(dict.fromkeys(notes))
    best = ev.best(0)
    status = "optimal"
    if method == "pareto":
        if not front:
            status = "infeasible"
            best = ev.least_violating()
        else:
            best = front[0]
    elif best is None:
        status = "infeasible"
        best = ev.least_violating()
    result = OptimizeResult(
        status=status, method=method, problem=problem, best=best, initial=initial, front=front,
        candidates=list(ev.candidates), runs=ev.runs_made + len(cache), runs_reused=len(cache), seed=int(seed),
        budget=budget, executor=executor.name, units=units, p_max=max_probability,
        samples=int(samples) if robust else 0, notes=notes,
        history=None if history is None else Path(history), source_text=source.text, source_name=source.source,
        fixed=list(fixed),
    )
    from camsim.analyses.optimize.files import write_history, write_optimised

    if history is not None:
        store.close(complete=True)
        write_history(result, Path(history), store.rows())
        store.remove_journal()
    if output is not None and result.feasible:
        write_optimised(result, Path(output))
        result.output = Path(output)
    return result

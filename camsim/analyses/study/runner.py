"""Running a tolerance study: draw the machines, run them, keep the rows, compute the statistics.

:func:`study` is what ``camsim study`` calls. The steps:

1. parse the inputs (:mod:`.distributions`), correlations, ``--output`` expressions;
2. run the *nominal* machine once in this process (every input at its nominal, mean,
   median or mid-range value): it checks that every key exists in the machine and every
   ``--output`` trace exists, and it tells which summary scalars a run provides (the
   columns). It is not one of the study's rows;
3. draw every sample up front from ``seed`` (:mod:`.sampling`), so the rows do not depend
   on the number of workers or on the order in which runs finish;
4. run the samples not yet stored, serially, in a process pool (``workers``) or on Dask
   (``scheduler``), with the executors of :mod:`camsim.analyses.sweep.runner`; each finished row is
   appended to the row store (:mod:`.store`) at once, so an interrupted study loses no
   finished row and ``resume=True`` runs only the missing ones;
5. statistics (:mod:`.statistics`), limit probabilities and Sobol' indices
   (:mod:`.sensitivity`) from the rows; the HDF5 and CSV files (:mod:`.files`).

A run that fails (a sampled value the loader rejects, a simulation error) is a row with
``status`` holding the one-line reason and NaN outputs; it is left out of the statistics.
"""

from __future__ import annotations

import hashlib
import os
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from camsim.errors import InputError, MachineFileError, SimulationError
from camsim.analyses.study.analysis import analyse, complete_row, stored_row, typed
from camsim.analyses.study.distributions import DEFAULT_TOL_SIGMA, Distribution, parse_dist
from camsim.analyses.study.outputs import OutputExpr, parse_output, run_scalars, run_unit
from camsim.analyses.study.sampling import (
    METHODS,
    apply_copula,
    block_names,
    correlation_matrix,
    is_power_of_two,
    n_runs,
    parse_correlate,
    saltelli_design,
    to_values,
    unit_sample,
)

__all__ = ["RunSettings", "StudyResult", "StudyInterrupted", "run_sample", "study"]


@dataclass(frozen=True)
class RunSettings:
    """What every run of a study shares (picklable: it travels to the workers).

    Attributes
    ----------
    outputs : tuple of OutputExpr
        The ``--output`` reductions.
    cycles, warmup_cycles : int, optional
        Recorded and warm-up revolutions (None: the machine file's).
    sample_rate : float, optional
        Output sample rate [Hz] (None: the machine file's).
    """

    outputs: tuple[OutputExpr, ...] = ()
    cycles: int | None = None
    warmup_cycles: int | None = None
    sample_rate: float | None = None


#: Seeds are stored as unsigned 64-bit attributes: 0 <= seed < 2**64.
SEED_LIMIT = 2**64


def _one_line(exc: BaseException) -> str:
    text = str(exc).strip().splitlines()
    return f"{type(exc).__name__}: {text[0]}" if text and text[0] else type(exc).__name__


def run_sample(source, overrides: Sequence[str], settings: RunSettings) -> tuple[dict[str, Any], None]:
    """Load, run and reduce one sampled machine; never raises for a run that fails.

    The task every executor runs (module level, so process pools and Dask can ship it).
    A worker loads the machine text with its unit conversions kept from run to run
    (camsim.units), and runs :func:`camsim.run.evaluation.evaluate` when no trace is
    reduced (the summary without traces), :func:`~camsim.run.simulation.simulate` otherwise.

    Returns
    -------
    row : dict
        The run's summary scalars (:func:`camsim.analyses.study.outputs.run_scalars`), one value
        per ``--output`` expression, and ``status``: ``"ok"`` or the one-line error.
    None
        (The executors' second slot, which a sweep uses for traces.)
    """
    from camsim.run.evaluation import evaluate
    from camsim.run.simulation import simulate

    try:
        machine = source.load(overrides)
        # without trace reductions a run is a design evaluation: its summary without traces
        # (camsim.run.evaluation, issue 42), the same scalars as a full run
        run = simulate if settings.outputs else evaluate
        result = run(machine, cycles=settings.cycles, warmup_cycles=settings.warmup_cycles, sample_rate=settings.sample_rate)
        row = run_scalars(result)
        for expr in settings.outputs:
            row[expr.text] = expr.evaluate(result)
        row["status"] = "ok"
    except Exception as exc:  # noqa: BLE001 - a failing run is recorded, the study goes on
        row = {"status": _one_line(exc)}
    return row, None


class StudyInterrupted(KeyboardInterrupt):
    """Ctrl-C stopped a study, or worker processes failed; the finished rows are kept.

    Attributes
    ----------
    done, total : int
        Runs stored and runs of the study.
    store : Path or None
        The study file, which holds the finished rows (its journal ``<file>.journal``
        is what ``resume=True`` continues from).
    lost : int
        Runs that did not run because their worker process failed (0 after Ctrl-C).
    """

    def __init__(self, done: int, total: int, store: Path | None, lost: int = 0):
        super().__init__(f"{done} of {total} runs done")
        self.done, self.total, self.store, self.lost = done, total, store, lost


@dataclass
class StudyResult:
    """Rows and statistics of a tolerance study.

    Attributes
    ----------
    rows : pandas.DataFrame
        One row per run, in run order: ``run``, ``design`` (``sample``; or ``A``, ``B``,
        ``AB:<key>`` for the blocks of Saltelli's design), ``param:<key>`` [SI] per
        input, one column per output quantity [SI], ``status``.
    columns : list of (str, str)
        Column names and SI units, in order.
    stats : dict
        Output -> statistics (:func:`camsim.analyses.study.statistics.describe`).
    limits : list of dict
        One per limit (:func:`camsim.analyses.study.statistics.limit_probability`).
    sensitivity : dict or None
        Output -> input -> indices (:func:`camsim.analyses.study.sensitivity.sobol_from_outputs`),
        None without ``sensitivity=True``.
    ranking : list of (str, float)
        Inputs by largest total Sobol' index over the limited outputs (all outputs when
        there is no limit): the tolerance to tighten first comes first.
    """

    rows: Any
    columns: list[tuple[str, str]]
    stats: dict[str, dict]
    limits: list[dict]
    sensitivity: dict[str, Any] | None
    ranking: list[tuple[str, float]]
    dists: list[Distribution]
    n_samples: int
    n_runs: int
    seed: int
    method: str
    machine: Any = None
    fixed_overrides: list[str] = field(default_factory=list)
    correlate: list[str] = field(default_factory=list)
    settings: RunSettings = field(default_factory=RunSettings)
    warnings: list[str] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)
    executor: str = "serial"
    resumed: int = 0
    output: Path | None = None
    csv: Path | None = None
    limit_texts: list[str] = field(default_factory=list)
    #: Runs that did not run (their worker process failed; ``--resume`` runs them).
    not_run: int = 0

    @property
    def outputs(self) -> list[str]:
        """Output quantities with statistics."""
        return list(self.stats)

    @property
    def failed(self) -> int:
        """Runs that failed."""
        return int((self.rows["status"] != "ok").sum())

    def to_json(self) -> dict:
        """The ``--json`` payload (documented in ``docs/tolerance.md``)."""
        sens = None
        if self.sensitivity is not None:
            sens = {q: v for q, v in self.sensitivity.items()}
        return {
            "n_samples": self.n_samples,
            "n_runs": self.n_runs,
            "seed": self.seed,
            "method": self.method,
            "output": None if self.output is None else str(self.output),
            "csv": None if self.csv is None else str(self.csv),
            "failed": self.failed,
            "not_run": self.not_run,
            "incomplete": self.failed > 0,
            "outputs": self.stats,
            "limits": self.limits,
            "sensitivity": sens,
            "ranking": [{"key": k, "total": t} for k, t in self.ranking],
        }


def _meta(source, fixed, dists, tol_sigma, correlate, method, seed, samples, sensitivity, settings) -> dict:
    """What identifies a study (a resume with other values is refused)."""
    return {
        "kind": "camsim study",
        "machine_sha256": hashlib.sha256(source.text.encode()).hexdigest(),
        "set": list(fixed),
        "dist": [d.text for d in dists],
        "tol_sigma": float(tol_sigma),
        "correlate": list(correlate),
        "method": method,
        "seed": int(seed),
        "samples": int(samples),
        "sensitivity": bool(sensitivity),
        "output": [e.text for e in settings.outputs],
        "cycles": settings.cycles,
        "warmup_cycles": settings.warmup_cycles,
        "sample_rate": settings.sample_rate,
    }


def _assignment(key: str, value: float) -> str:
    """``KEY=VALUE`` with the SI value written exactly (a bare number is SI to the loader)."""
    return f"{key}={float(value)!r}"


def _check_keys(source, fixed, dists) -> Any:
    """Load the nominal machine; a loader error about an input names its ``--dist`` option."""
    nominal = [_assignment(d.key, d.nominal) for d in dists]
    try:
        return source.load(list(fixed) + nominal)
    except MachineFileError as exc:
        for d, a in zip(dists, nominal):
            tail = f" (value from --set {a})"
            if exc.message.endswith(tail):
                raise InputError(f"{exc.file}: {exc.key}: {exc.message[: -len(tail)]} (nominal value of --dist {d.text})") from None
            if exc.key == d.key:
                raise InputError(f"{exc.file}: {exc.key}: {exc.message} (--dist {d.text})") from None
        raise


def study(
    machine: str | os.PathLike[str] | Any,
    dists: Sequence[str | Distribution],
    samples: int,
    *,
    method: str = "mc",
    seed: int = 0,
    tol_sigma: float = DEFAULT_TOL_SIGMA,
    correlate: Sequence[str] = (),
    outputs: Sequence[str] = (),
    limits: Sequence[str] = (),
    sensitivity: bool = False,
    fixed: Sequence[str] = (),
    cycles: int | None = None,
    warmup_cycles: int | None = None,
    sample_rate: float | None = None,
    workers: int | None = None,
    scheduler: str | None = None,
    dask_local: int | None = None,
    output: str | os.PathLike[str] | None = None,
    resume: bool = False,
    progress: Callable[[int, int], None] | None = None,
    on_start: Callable[[int, int, str], None] | None = None,
    max_runs: float | None = None,
    max_output: float | None = None,
) -> StudyResult:
    """Run a tolerance study of a machine: statistics, limit probabilities, Sobol' indices.

    Parameters
    ----------
    machine : path or camsim.analyses.sweep.runner.MachineSource
        The machine file.
    dists : sequence of str or Distribution
        ``KEY=SPEC`` inputs (:func:`camsim.analyses.study.distributions.parse_dist`).
    samples : int
        Samples ``N``. With ``sensitivity`` the study makes ``N (d + 2)`` runs for ``d``
        inputs (Saltelli's design; ``N`` a power of two).
    method : str
        ``mc``, ``lhs`` or ``sobol`` (scrambled; a count that is not a power of two
        gives a warning in :attr:`StudyResult.warnings`).
    seed : int
        Seed of every random draw: the same seed gives the same rows, bit for bit,
        whatever the number of workers.
    tol_sigma : float
        Standard deviations between a ``tol:`` nominal and its limits.
    correlate : sequence of str
        ``KEY1,KEY2=RHO``: correlation of two inputs' normal scores (Gaussian copula).
    outputs : sequence of str
        ``REDUCER:PATH`` expressions (:mod:`camsim.analyses.study.outputs`).
    limits : sequence of str
        ``QUANTITY OP VALUE[UNIT]``, e.g. ``"min_cam_contact_force<0N"``.
    sensitivity : bool
        Compute first-order and total Sobol' indices.
    fixed : sequence of str
        ``KEY=VALUE`` overrides of every run (``--set``).
    cycles, warmup_cycles : int, optional
        Recorded and warm-up revolutions of every run.
    sample_rate : float, optional
        Output sample rate [Hz].
    workers : int, optional
        Local processes (default: the number of cores; 1 runs in this process).
    scheduler : str, optional
        Address of a running Dask scheduler.
    dask_local : int, optional
        Start a Dask LocalCluster with this many workers.
    output : path, optional
        Study file (HDF5 ``/study/rows``) with a CSV beside it. While the study runs,
        the rows are kept by :class:`camsim.io.rowstore.RowStore`: the journal
        ``<output>.journal`` (removed when the study is complete) and ``<output>`` as a
        view of the finished rows. None: rows in memory only, nothing written.
    resume : bool
        Continue the interrupted study writing ``output`` (same inputs and options):
        only the runs not stored are made.
    progress : callable, optional
        ``progress(done, total)`` after each finished run.
    on_start : callable, optional
        ``on_start(n_runs, n_to_run, executor_name)`` once the checks passed, before
        the first run.

    Returns
    -------
    StudyResult

    Raises
    ------
    InputError
        Any bad input (nothing is written).
    SimulationError
        The nominal machine does not run.
    StudyInterrupted
        Ctrl-C: the finished rows are kept for ``resume``.
    """
    from camsim.analyses.study.statistics import parse_limit
    from camsim.analyses.executors import default_workers, make_executor
    from camsim.analyses.sweep.runner import MachineSource

    if method not in METHODS:
        raise InputError(f"--method {method}: unknown sampling method (one of {', '.join(METHODS)})")
    if isinstance(samples, bool) or not isinstance(samples, (int, np.integer)) or samples < 1:
        raise InputError(f"--samples {samples}: needs a whole number of at least 1")
    samples = int(samples)
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or not 0 <= seed < SEED_LIMIT:
        # checked before any run: the seed is stored as an unsigned 64-bit attribute (issue 26)
        raise InputError(f"--seed {seed}: needs a whole number from 0 to 2^64 - 1 = {SEED_LIMIT - 1}")
    parsed = [d if isinstance(d, Distribution) else parse_dist(d, tol_sigma) for d in dists]
    if not parsed:
        raise InputError("study: give at least one --dist KEY=SPEC")
    keys = [d.key for d in parsed]
    for k in keys:
        if keys.count(k) > 1:
            raise InputError(f"--dist: key {k} is given twice")
    fixed_keys = {a.partition("=")[0].strip() for a in fixed}
    for d in parsed:
        if d.key in fixed_keys:
            raise InputError(f"--dist {d.text}: {d.key} is also fixed by --set")
    pairs = [parse_correlate(c, keys) for c in correlate]
    corr = correlation_matrix(pairs, len(keys), list(correlate))
    if sensitivity and pairs:
        raise InputError("--sensitivity: Sobol' indices need independent inputs; drop --correlate")
    if sensitivity and samples < 2:
        raise InputError(
            f"--samples {samples}: --sensitivity needs at least 2 samples (the indices are variances over the "
            "samples, and their intervals a bootstrap of them), e.g. --samples 64"
        )
    if sensitivity and not is_power_of_two(samples):
        raise InputError(
            f"--samples {samples}: --sensitivity needs a power of two (Saltelli's estimator on Sobol' points), "
            f"e.g. {1 << (samples - 1).bit_length()}"
        )
    if sample_rate is not None and not sample_rate > 0:
        raise InputError("--sample-rate: must be positive")
    exprs = []
    for text in outputs:
        e = parse_output(text)
        if e.text in [x.text for x in exprs]:
            raise InputError(f"--reduce {text}: given twice")
        exprs.append(e)
    settings = RunSettings(outputs=tuple(exprs), cycles=cycles, warmup_cycles=warmup_cycles, sample_rate=sample_rate)
    if scheduler is not None and dask_local is not None:
        raise InputError("--scheduler and --dask-local: give one of them, not both")
    workers = default_workers() if workers is None else workers
    if workers < 1:
        raise InputError(f"--workers {workers}: needs at least 1")
    source = machine if isinstance(machine, MachineSource) else MachineSource.from_path(machine)

    # Know before you start (issue 35): the runs, and the size of each (held in memory).
    from camsim.run.budget import DEFAULT_MAX_OUTPUT, DEFAULT_MAX_RUNS, check_budget, check_runs, estimate_run

    total_runs = n_runs(samples, len(parsed), sensitivity)
    counted = f"--samples {samples}" + (f" x (d + 2) = {samples} x {len(parsed) + 2} for --sensitivity" if sensitivity else "")
    check_runs(total_runs, DEFAULT_MAX_RUNS if max_runs is None else max_runs, "study", counted,
               "make fewer runs with fewer --samples" + (" (or without --sensitivity)" if sensitivity else ""))

    # The nominal machine: key checks, the output columns.
    from camsim.run.simulation import simulate

    base = _check_keys(source, fixed, parsed)
    check_budget(estimate_run(base, cycles=cycles, warmup_cycles=warmup_cycles, sample_rate=sample_rate),
                 DEFAULT_MAX_OUTPUT if max_output is None else max_output, str(source.source or "study"))
    try:
        nominal_result = simulate(base, cycles=cycles, warmup_cycles=warmup_cycles, sample_rate=sample_rate)
    except SimulationError as exc:
        raise SimulationError(f"the nominal machine does not run: {exc}") from None
    row = run_scalars(nominal_result)
    scalar_names = [k for k, v in row.items() if isinstance(v, (bool, int, float, np.number))]
    for e in exprs:
        try:
            e.evaluate(nominal_result)
        except KeyError:
            raise InputError(
                f"--reduce {e.text}: the run has no trace '{e.path}' (masses/<mass>/<quantity>, elements/<element>/force, "
                "transducer/force, cam_contact/force, cam/<quantity>)"
            ) from None
    columns: list[tuple[str, str]] = [("run", ""), ("design", "")]
    columns += [(f"param:{d.key}", d.unit) for d in parsed]
    columns += [(name, run_unit(nominal_result, name)) for name in scalar_names]
    columns += [(e.text, run_unit(nominal_result, e.path)) for e in exprs]
    del nominal_result
    columns.append(("status", ""))
    units = dict(columns)
    output_names = scalar_names + [e.text for e in exprs]
    parsed_limits = [parse_limit(text, {q: units[q] for q in output_names}) for text in limits]
    from camsim.run.result import unreachable_limit

    limit_warnings = [w for lim in parsed_limits if (w := unreachable_limit(base, lim.quantity, lim.op, lim.threshold))]

    # Every sample, drawn up front.
    warn: list[str] = list(limit_warnings)
    d = len(parsed)
    if sensitivity:
        u = saltelli_design(samples, d, method, int(seed), warn)
        design = [name for name in block_names(keys) for _ in range(samples)]
    else:
        u = apply_copula(unit_sample(samples, d, method, int(seed), warn), corr)
        design = ["sample"] * samples
    values = to_values(u, parsed)
    total = n_runs(samples, d, sensitivity)

    # The row store: a journal beside the output and the output itself as a view of the
    # finished rows while the study runs (camsim.io.rowstore).
    from camsim.analyses.study.store import MemoryRowStore, open_store

    meta = _meta(source, fixed, parsed, tol_sigma, correlate, method, seed, samples, sensitivity, settings)
    h5_path = csv_path = store = None
    if output is not None:
        from camsim.io.atomic import check_writable
        from camsim.io.rowstore import journal_path_for
        from camsim.analyses.study.files import csv_path_for

        h5_path = Path(output)
        csv_path = csv_path_for(h5_path)
        check_writable(h5_path)
        check_writable(csv_path)
        if resume:
            store = open_store(h5_path, columns, meta, base, resume=True)
        elif journal_path_for(h5_path).exists():
            raise InputError(
                f"{h5_path}: an interrupted study left {journal_path_for(h5_path)}; add --resume to continue it, "
                "or delete that file to start again"
            )
    elif resume:
        raise InputError("--resume: needs the study's output file (-o)")

    column_names = {c for c, _ in columns}
    done = store.done() if store is not None else set()
    todo = [i for i in range(total) if i not in done]
    resumed = len(done)
    executor = None
    name = "serial"
    try:
        # the executor first: an unreachable scheduler must leave nothing behind
        if todo:
            executor = make_executor(workers, len(todo), scheduler, dask_local)
            name = executor.name
    except BaseException:
        if store is not None:
            store.close()
        raise
    if store is None:
        store = open_store(h5_path, columns, meta, base, resume=False) if output is not None else MemoryRowStore.create(None, columns, meta)
    tasks = [(source, tuple(fixed) + tuple(_assignment(k, v) for k, v in zip(keys, values[i])), settings) for i in todo]
    interrupted, lost = _run_missing(executor, tasks, todo, store, lambda i, row: stored_row(i, design[i], keys, values[i], row, column_names),
                               total, progress, on_start, name)
    stored = store.rows()
    if interrupted:
        if stored:
            store.close()
        else:  # nothing finished: no journal to resume (a rerun starts afresh)
            store.remove_journal()
        raise StudyInterrupted(len(stored), total, h5_path, lost=lost)
    not_run = [i for i in range(total) if i not in stored]
    rows = dict(stored)
    for i in not_run:  # a worker process died: no result, and no conclusion drawn without it
        rows[i] = stored_row(i, design[i], keys, values[i],
                              {"status": "not run: its worker process failed (--resume runs it)"}, column_names)

    import pandas as pd

    frame = pd.DataFrame([complete_row(rows[i], columns) for i in range(total)], columns=[c for c, _ in columns])
    frame = typed(frame)
    stats, limit_rows, sens, ranking, notes = analyse(frame, output_names, parsed_limits, keys, samples, sensitivity, int(seed))
    result = StudyResult(
        rows=frame,
        columns=columns,
        stats=stats,
        limits=limit_rows,
        sensitivity=sens,
        ranking=ranking,
        dists=parsed,
        n_samples=samples,
        n_runs=total,
        seed=int(seed),
        method=method,
        machine=base,
        fixed_overrides=list(fixed),
        correlate=list(correlate),
        settings=settings,
        warnings=warn,
        notes=notes,
        executor=name,
        resumed=resumed,
        output=h5_path,
        csv=csv_path,
        limit_texts=list(limits),
        not_run=len(not_run),
    )
    if output is not None:
        from camsim.analyses.study.files import write_study

        store.close(complete=not not_run)
        write_study(result, h5_path, csv_path)  # replaces the view with the final file
        if not not_run:  # kept for --resume otherwise
            store.remove_journal()
    else:
        store.close()
    return result


def _run_missing(executor, tasks, todo, store, stored_row, total, progress, on_start, name) -> tuple[bool, int]:
    """Run the tasks of the missing rows, appending each row as it finishes.

    Returns
    -------
    interrupted : bool
        Ctrl-C (or SIGTERM) stopped the runs.
    lost : int
        Runs whose worker process failed (not stored: a resume runs them again).
    """
    from camsim.analyses.executors import EXECUTOR_ERROR
    from camsim.analyses.sweep.runner import failed_row

    interrupted = False
    lost = 0
    try:
        if on_start is not None:
            on_start(total, len(todo), name)
        finished = total - len(todo)
        if todo:
            for k, (row, _) in executor.run(tasks, run_sample, failed_row):
                i = todo[k]
                if row.get(EXECUTOR_ERROR):
                    lost += 1
                    continue
                row = {c: v for c, v in row.items() if not c.startswith("param:")}
                store.append(i, stored_row(i, row))
                finished += 1
                if progress is not None:
                    progress(finished, total)
    except KeyboardInterrupt:
        interrupted = True
        if executor is not None:
            executor.abort()
    finally:
        if executor is not None:
            try:
                executor.close()
            except Exception:  # noqa: BLE001 - workers stopped on purpose after Ctrl-C
                if not interrupted:
                    raise
    return interrupted, lost

"""``camsim.analyses.fit.fit``: calibrate a machine file to measured traces and scalar targets.

This module assembles the pieces: the measured CSV (:mod:`camsim.analyses.fit.measured`), the
parameters (:mod:`camsim.analyses.fit.params`), the weighted residuals
(:mod:`camsim.analyses.fit.objective`), the solver (:mod:`camsim.analyses.fit.solve`) and the linearised
statistics (:mod:`camsim.analyses.fit.uncertainty`), and returns a
:class:`~camsim.analyses.fit.result.FitResult`. Writing the fitted machine file is
:func:`camsim.analyses.fit.tomledit.fitted_text`; the figure is :func:`camsim.figures.fit.plot_fit`.
See ``docs/fitting.md``.
"""

from __future__ import annotations

import math
import os
from pathlib import Path
from collections.abc import Callable, Mapping, Sequence

import numpy as np

from camsim.errors import InputError

__all__ = ["fit", "ALIGN_MODES", "DEFAULT_SHIFT_FRACTION"]

#: Values of ``align``.
ALIGN_MODES = ("none", "offset")
#: Default ``max_shift`` with ``align="offset"``, as a fraction of the cam period.
DEFAULT_SHIFT_FRACTION = 0.05
#: A fitted coordinate this close to a bound (in units of the bounds' span) is "on" it.
ON_BOUND = 1e-6


class _Shift:
    """The time shift of ``--align offset`` as a fitted parameter [s]."""

    key = "align.offset"
    unit = "s"
    log = False
    initial = 0.0
    start = 0.0

    def __init__(self, max_shift: float):
        self.low, self.high = -max_shift, max_shift

    def to_unit(self, value: float) -> float:
        return (value - self.low) / (self.high - self.low)

    def from_unit(self, u: float) -> float:
        return self.low + u * (self.high - self.low)


def fit(
    machine: str | os.PathLike[str],
    measured: str | os.PathLike[str] | None,
    params: Sequence[str],
    *,
    targets: Sequence[str] = (),
    sigma: Sequence[str] | Mapping[str, float] = (),
    log: Sequence[str] = (),
    fixed: Sequence[str] = (),
    align: str = "none",
    max_shift: float | str | None = None,
    window: tuple[float, float] | str | None = None,
    drop_nan: bool = False,
    cycles: int | None = None,
    warmup_cycles: int | None = None,
    sample_rate: float | None = None,
    workers: int = 1,
    starts: int = 1,
    seed: int = 0,
    max_evaluations: int | None = None,
    progress: Callable[[str], None] | None = None,
    evaluations: str | os.PathLike[str] | None = None,
    resume: bool = False,
):
    """Fit machine keys so that the simulation reproduces measured traces and scalars.

    Parameters
    ----------
    machine : path or camsim.analyses.sweep.runner.MachineSource
        The machine file.
    measured : path or None
        CSV of measured traces (``time [s]`` then ``<result path> [unit]`` columns; see
        :func:`camsim.analyses.fit.measured.read_measured`). None when fitting to targets only.
    params : sequence of str
        ``KEY=LOW:HIGH[UNIT]`` or ``KEY=LOW:HIGH:START[UNIT]`` (:mod:`camsim.analyses.fit.params`).
    targets : sequence of str
        ``NAME=VALUE[UNIT]`` scalars of the run (``max_transducer_force=148lbf``,
        ``first_impact_time=0.31s``; :func:`camsim.analyses.fit.objective.scalar_units`).
    sigma : sequence of str or mapping
        Noise level per measured path or target, ``PATH=VALUE[UNIT]`` texts or a mapping
        name → SI value. Default: estimated from the data (channels) or 1 % of the value
        (targets).
    log : sequence of str
        Keys fitted on a log scale.
    fixed : sequence of str
        ``KEY=VALUE`` overrides applied before the fitted values (``--set``).
    align : {"none", "offset"}
        ``"offset"`` also fits a time shift between the measured and simulated time bases.
    max_shift : float or str, optional
        Bound of the shift [s] (or text with a unit); default 5 % of the cam period.
    window : (float, float) or str, optional
        Measured times compared [s] (or ``"START:STOP[UNIT]"``).
    drop_nan : bool
        Leave out NaN or empty cells instead of refusing the file.
    cycles, warmup_cycles : int, optional
        Recorded and warm-up revolutions of every run (default: the machine file's).
    sample_rate : float, optional
        Output sample rate of every run [Hz] (default: the machine file's). The
        simulated trace is interpolated linearly at the measured times.
    workers : int
        Processes running the simulations of one Jacobian at once.
    starts : int
        Starts of the solver: the given one plus ``starts - 1`` Latin-hypercube points.
    seed : int
        Seed of the Latin hypercube.
    max_evaluations : int, optional
        Largest number of residual evaluations per start (default: scipy's, 100 per
        parameter).
    progress : callable, optional
        Called with one line per solver iteration (iteration, cost, parameters).
    evaluations : path, optional
        Keep every finished simulation in this crash-safe row store
        (:mod:`camsim.io.rowstore`: a journal beside an HDF5 view), so that a fit stopped
        by Ctrl-C, SIGTERM or SIGKILL loses none; removed when the fit completes.
    resume : bool
        Reuse the evaluations of an interrupted fit stored at ``evaluations`` (the same
        machine, parameters, traces and settings; refused otherwise). The solver is
        deterministic, so it asks for the same points again and finds them stored.

    Returns
    -------
    FitResult
        ``converged`` is False when the solver stopped at ``max_evaluations``.

    Raises
    ------
    InputError
        Any bad input (file, column, key, option named in one line).
    SimulationError
        A run at some parameter values failed.
    """
    from camsim.analyses.fit.measured import read_measured, result_paths
    from camsim.analyses.fit.objective import (
        build_objective,
        parse_max_shift,
        parse_sigma,
        parse_target,
        parse_window,
        scalar_units,
    )
    from camsim.analyses.fit.params import resolve_params
    from camsim.analyses.fit.result import FitResult
    from camsim.analyses.fit.solve import CD_STEP, Evaluator, Problem, jacobian, solve
    from camsim.analyses.fit.uncertainty import uncertainty
    from camsim.analyses.sweep.runner import MachineSource, SweepSettings

    if align not in ALIGN_MODES:
        raise InputError(f"--align {align}: one of {', '.join(ALIGN_MODES)}")
    if workers < 1:
        raise InputError(f"--workers {workers}: needs at least 1")
    if starts < 1:
        raise InputError(f"--starts {starts}: needs at least 1")
    if max_evaluations is not None and max_evaluations < 1:
        raise InputError(f"--max-evaluations {max_evaluations}: needs at least 1")
    if sample_rate is not None and not sample_rate > 0:
        raise InputError("--sample-rate: must be positive")
    if cycles is not None and cycles < 1:
        raise InputError(f"--cycles {cycles}: needs at least 1")
    source = machine if isinstance(machine, MachineSource) else MachineSource.from_path(machine)
    fixed = list(fixed)
    base = source.load(fixed)
    from camsim.run.budget import check_in_memory

    check_in_memory(base, str(source.source or "fit"), cycles=cycles, warmup_cycles=warmup_cycles,
                    sample_rate=sample_rate)  # every evaluation's traces are held in memory (issue 45)
    parameters = resolve_params(source, fixed, params, log)
    paths = result_paths(base)
    data = read_measured(measured, paths, drop_nan=drop_nan) if measured is not None else None
    units = scalar_units(base)
    goals = [parse_target(t, units) for t in targets]
    names = [g[0] for g in goals]
    for i, n in enumerate(names):
        if n in names[:i]:
            raise InputError(f"--target {targets[i]}: {n} is given twice")
    sigma_units = {c.path: c.unit for c in data.channels} if data is not None else {}
    sigma_units.update({n: units[n] for n in names})
    if isinstance(sigma, Mapping):
        sigmas = {}
        for k, v in sigma.items():
            if k not in sigma_units:
                raise InputError(f"sigma: '{k}' is neither a measured column nor a target")
            if not float(v) > 0:
                raise InputError(f"sigma: {k}: the noise level must be positive")
            sigmas[k] = float(v)
    else:
        sigmas = dict(parse_sigma(s, sigma_units) for s in sigma)
    if isinstance(window, str):
        window = parse_window(window)
    has_cam = base.cam is not None
    period = base.cam.period if has_cam else None
    n_cycles = cycles if cycles is not None else base.simulation.cycles
    t_end = n_cycles * period if has_cam and (cycles is not None or base.simulation.duration is None) else float(base.simulation.duration or 0.0)
    shift_bound = None
    if align == "offset":
        if isinstance(max_shift, str):
            shift_bound = parse_max_shift(max_shift)
        elif max_shift is not None:
            if not max_shift > 0:
                raise InputError("--max-shift: must be positive")
            shift_bound = float(max_shift)
        elif period is not None:
            shift_bound = DEFAULT_SHIFT_FRACTION * period
        else:
            raise InputError("--align offset: give --max-shift (the machine has no cam period to take 5 % of)")
    elif max_shift is not None:
        raise InputError("--max-shift: only with --align offset")
    warnings: list[str] = []
    objective = build_objective(data, goals, units, sigmas, window, t_end, period, shift_bound, warnings)
    if objective.size == 0:
        raise InputError("fit: nothing to fit to: give a MEASURED.csv file or at least one --target")
    all_params = list(parameters) + ([_Shift(shift_bound)] if shift_bound is not None else [])
    settings = SweepSettings(cycles=cycles, warmup_cycles=warmup_cycles, sample_rate=sample_rate)
    store = _evaluation_store(evaluations, resume, source, fixed, parameters, objective.paths, settings)
    evaluator = Evaluator(source, fixed, [p.key for p in parameters], objective.paths, settings, workers, store=store)
    problem = Problem(params=all_params, n_sim=len(parameters), evaluator=evaluator, objective=objective)
    try:
        best, solutions = solve(problem, starts=starts, seed=seed, max_nfev=max_evaluations, report=progress)
        u = best.u
        x = problem.x(u)
        (r,) = problem.residuals_at([x])
        jac_u = jacobian(problem, u, r, central=True, step=max(CD_STEP, problem.fd_step))
        (run,) = evaluator.runs([x[: len(parameters)]])
    except BaseException:
        evaluator.abort()
        if store is not None:
            store.close()  # the evaluations so far stay for --resume
        raise
    finally:
        evaluator.close()
    if store is not None:  # the fit completed: its evaluations are not needed again
        store.close()
        store.remove_journal()
        Path(store.path).unlink(missing_ok=True)
    # d z / d u: the span of the bounds (in ln for log parameters)
    span = np.array([math.log(p.high / p.low) if p.log else p.high - p.low for p in all_params])
    jac_z = jac_u / span
    keys = [p.key for p in all_params]
    stats = uncertainty(jac_z, r, keys, x, [p.log for p in all_params], [(p.low, p.high) for p in all_params])
    for p, ui in zip(all_params, u):
        if ui <= ON_BOUND or ui >= 1.0 - ON_BOUND:
            side = "lower" if ui <= ON_BOUND else "upper"
            warnings.append(
                f"{p.key}: ended on its {side} bound; the best value may lie beyond it (widen the bounds), "
                "and its interval assumes an optimum inside them"
            )
    warnings += stats.warnings
    if not best.converged:
        warnings.insert(0, f"not converged: {best.message}")
    shift = float(x[len(parameters)]) if shift_bound is not None else 0.0
    from camsim.analyses.fit.params import override_text

    given = np.array([p.start for p in all_params], dtype=float)

    def start_value(sol) -> np.ndarray:
        # the given start exactly (not through the [0, 1] mapping), else the hypercube point
        return given if sol is solutions[0] else problem.x(sol.start_u)

    return FitResult(
        keys=keys,
        units=[p.unit for p in all_params],
        values=x,
        initial=start_value(best),
        file_values=np.array([p.initial for p in all_params], dtype=float),
        stderr=stats.stderr,
        ci95=stats.ci95,
        correlation=stats.correlation,
        bounds=[(p.low, p.high) for p in all_params],
        log=[p.log for p in all_params],
        cost=0.5 * float(r @ r),
        rms_residual=objective.rms(run.time, run.traces, run.scalars, shift),
        sigma={**dict(zip(objective.paths, objective.sigmas)), **{t.name: t.sigma for t in objective.targets}},
        n_evaluations=evaluator.count,
        converged=best.converged,
        message=best.message,
        warnings=warnings,
        condition=stats.condition,
        residual_variance=stats.residual_variance,
        dof=stats.dof,
        starts=[
            {
                "start": start_value(s).tolist(),
                "value": problem.x(s.u).tolist(),
                "cost": s.cost,
                "converged": s.converged,
            }
            for s in solutions
        ],
        sim_time=run.time,
        sim_traces=dict(run.traces),
        channels=list(zip(objective.paths, objective.times, objective.values, objective.simulated(run.time, run.traces, shift))),
        shift=shift,
        overrides=[override_text(p.key, float(v)) for p, v in zip(parameters, x)],
        targets={t.name: {"value": float(t.value), "sigma": float(t.sigma), "unit": t.unit,
                          "achieved": float(run.scalars.get(t.name, math.nan))} for t in objective.targets},
    )


def _evaluation_store(path, resume: bool, source, fixed, parameters, paths, settings):
    """The row store of a fit's simulations (None without ``path``)."""
    if path is None:
        if resume:
            raise InputError("--resume: needs the evaluation store of the interrupted fit (-o names it)")
        return None
    import hashlib

    from camsim.analyses.fit.solve import store_columns
    from camsim.io.rowstore import RowStore, journal_path_for

    keys = [p.key for p in parameters]
    meta = {
        "job": "camsim fit",
        "machine_sha256": hashlib.sha256(source.text.encode()).hexdigest(),
        "fixed": list(fixed),
        "parameters": keys,
        "traces": list(paths),
        "cycles": settings.cycles,
        "warmup_cycles": settings.warmup_cycles,
        "sample_rate": settings.sample_rate,
    }
    def decorate(f) -> None:  # a camsim file of its own kind: never mistaken for a user's (issue 35)
        from camsim.io.hdf5 import SCHEMA
        from camsim._version import __version__

        f.attrs["camsim_version"] = __version__
        f.attrs["schema"] = SCHEMA
        f.attrs["file_kind"] = "fit"

    if resume:
        return RowStore.resume(path, meta, table="evaluations", decorate=decorate)
    if journal_path_for(path).exists():
        raise InputError(f"{path}: the evaluations of an interrupted fit are there; add --resume to continue it, "
                         f"or delete {journal_path_for(path)} to start over")
    return RowStore.create(path, store_columns(keys), meta, table="evaluations", decorate=decorate)

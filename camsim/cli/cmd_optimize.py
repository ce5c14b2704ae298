"""``camsim optimize``: the machine that minimises (or maximises) an objective under constraints."""

from __future__ import annotations

import math
from pathlib import Path

import typer

from camsim.cli.helptext import CYCLES_HELP, SAMPLE_RATE_HELP, WARMUP_HELP
from camsim.cli.app import app, err_console, fail, print_json, user_errors
from camsim.cli.units_option import check_units, machine_units, units_option


class _Progress:
    """Evaluations done / budget and the best feasible objective so far, on stderr
    (:class:`camsim.cli.progress.Bar`: a live bar on a terminal, a line every 10 s elsewhere)."""

    def __init__(self, quiet: bool, units: str = "file", options: tuple = ()) -> None:
        from camsim.cli.progress import Bar

        self.bar = Bar("optimize", "evaluations", quiet=quiet)
        self.units, self.options = units, list(options)
        self.si_unit, self.shown = "", None

    def objective(self, si_unit: str, machine) -> None:
        """The best value is shown in the objective's display unit (issue 44: "best: 216.496" was SI, unitless)."""
        from camsim.cli.units_option import machine_units

        self.si_unit, self.shown = si_unit, machine_units(self.units, machine, self.options)

    def start(self, budget: int, stored: int, executor: str) -> None:
        if stored:
            err_console.print(f"resuming: {stored} runs already stored are reused", markup=False)
        self.bar.start(budget, executor, note="best: none feasible yet")

    def __call__(self, done: int, budget: int | None, best: float | None) -> None:
        if best is None:
            text = "best: none feasible yet"
        elif self.shown is not None:
            text = f"best: {self.shown.quantity(best, self.si_unit, '.6g')}"
        else:
            text = f"best: {best:.6g}"
        self.bar(done, budget, note=text)

    def close(self) -> None:
        self.bar.close()


def _fmt(v) -> str:
    if v is None:
        return "—"
    if isinstance(v, str):
        return v
    return "—" if not math.isfinite(v) else f"{v:.6g}"


def _render(result, display=None) -> None:
    """The optimum, objectives and constraints in ``display`` (default the machine file's units)."""
    from camsim.display import in_units
    from camsim.reports.display import as_display

    p = result.problem
    display = as_display(display, getattr(p, "base", None))
    err = err_console

    def q(value, si_unit: str) -> str:
        """A value with its display unit (a number alone without a unit)."""
        if value is None or isinstance(value, str) or not math.isfinite(value):
            return _fmt(value)
        return display.quantity(value, si_unit, ".6g") if si_unit else _fmt(value)

    head = {"optimal": "optimum", "infeasible": "NO FEASIBLE CANDIDATE; the least-violating one"}[result.status]
    err.print(f"{head} after {len(result.candidates)} evaluations ({result.runs} runs, {result.method}, seed {result.seed}):", markup=False)
    for v in p.variables:
        new = result.best.values.get(v.key)
        unit = "" if v.is_choice else v.unit
        err.print(f"  {v.key} = {q(new, unit)}   (file: {q(v.initial, unit)})", markup=False)
    if p.absorb is not None:
        err.print(f"  {p.absorb} = {q(result.best.values[p.absorb], 'rad')} (absorbs the rest of 360 deg; "
                  f"file: {q(p.absorb_initial, 'rad')})", markup=False)
    for k, g in enumerate(p.goals):
        init = "" if result.initial is None else f"   (file: {q(result.initial.objectives[k], g.unit)})"
        err.print(f"  {g.sense}imise {g.text} = {q(result.best.objectives[k], g.unit)}{init}", markup=False)
    units = {c.text: c.unit for c in p.constraints}
    for s in result.best.per_speed:
        where = "" if s["speed"] is None else f" at {display.quantity(s['speed'], 'rad/s', '.6g')}"
        for c in s["constraints"]:
            line = f"  {c['expr']}{where}: {q(c['value'], units.get(c['expr'], ''))} ({'ok' if c['satisfied'] else 'VIOLATED'})"
            if "probability" in c:
                lo, hi = c["ci95"]
                line += f", P(violation) = {_fmt(c['probability'])} (95 % {_fmt(lo)} … {_fmt(hi)}, {c['method']})"
            err.print(line, markup=False)
    if result.active():
        err.print("  active: " + ", ".join(result.active()), markup=False)
    if result.front:
        err.print(f"Pareto front: {len(result.front)} points", markup=False)
        for c in result.front:
            err.print("  " + "  ".join(f"{g.text} = {q(c.objectives[k], g.unit)}" for k, g in enumerate(p.goals)), markup=False)
    for n in result.notes:
        err.print(f"note: {in_units(n, display)}", markup=False)
    if result.best is not None and (any(not math.isfinite(o) for o in result.best.objectives if isinstance(o, float))
                                    or result.best.status != "ok"):  # issue 35: every "—" says why
        err.print(f"—: no value: {result.best.status if result.best.status != 'ok' else 'the run gave none'}", markup=False)


@app.command("optimize")
def optimize_command(
    machine: Path = typer.Argument(..., help="Machine file (TOML)."),
    var: list[str] = typer.Option([], "--var", metavar="KEY=LOW:HIGH[:START][UNIT]", help="A continuous machine key and its bounds (repeatable), e.g. element.K23.preload=20:40lbf."),
    log: list[str] = typer.Option([], "--log", metavar="KEY", help="Search this --var on a log scale (repeatable)."),
    choice: list[str] = typer.Option([], "--choice", metavar="KEY=a,b,c", help="A categorical key and its options (repeatable; --method de), e.g. cam.segments[0].law=cycloidal,poly345."),
    absorb: str = typer.Option(None, "--absorb", metavar="cam.segments[i].duration", help="This segment takes up whatever the other durations leave of 360 deg."),
    minimize: list[str] = typer.Option([], "--minimize", metavar="EXPR", help="Objective to minimise: a run scalar, REDUCER:PATH[@FROM:TO] or param:KEY."),
    maximize: list[str] = typer.Option([], "--maximize", metavar="EXPR", help="Objective to maximise (two objectives in all with --method pareto)."),
    constraint: list[str] = typer.Option([], "--constraint", metavar="EXPR<=VALUE[UNIT]", help='A constraint (repeatable), e.g. "min_cam_contact_force>=50N", "jump<=0".'),
    speeds: str = typer.Option(None, "--speeds", metavar="FROM:TO:STEP[UNIT]", help="Evaluate every candidate at each speed (default unit rpm); objective: worst over them; constraints: at each."),
    robust: bool = typer.Option(False, "--robust", help="Constraints as violation probabilities over the --dist tolerances (common random numbers)."),
    dist: list[str] = typer.Option([], "--dist", metavar="KEY=SPEC", help="A tolerance, as in camsim study (repeatable; with --robust). On an optimised key it is the deviation from the candidate."),
    samples: int = typer.Option(32, "--samples", "-n", help="Robust samples N per candidate and speed (the same N draws for every candidate)."),
    max_probability: float = typer.Option(1e-3, "--max-probability", help="Largest violation probability of each robust constraint."),
    tol_sigma: float = typer.Option(3.0, "--tol-sigma", help="Standard deviations between a tol: nominal and its limits."),
    method: str = typer.Option("de", "--method", help="de (differential evolution), local (COBYLA / Brent from the file's values) or pareto (two objectives, epsilon-constraint)."),
    budget: int = typer.Option(None, "--budget", help="Largest number of candidate evaluations (default: de 300, local 60, pareto 120)."),
    points: int = typer.Option(11, "--points", help="Points of the Pareto front's epsilon sweep."),
    seed: int = typer.Option(0, "--seed", min=0, help="Seed of the solver and of the robust samples."),
    out: Path = typer.Option(None, "-o", "--out", metavar="OPTIMISED.toml", help="The machine file with the optimum written in place (not written when nothing is feasible)."),
    history: Path = typer.Option(None, "-r", "--history", metavar="HISTORY.h5", help="Every evaluation (HDF5); its journal makes --resume possible."),
    resume: bool = typer.Option(False, "--resume", help="Continue an interrupted optimisation (same command): stored runs are reused, none repeated."),
    fresh: bool = typer.Option(False, "--fresh", help="Discard the journal an interrupted optimisation left and start again."),
    force: bool = typer.Option(False, "--force", help="Replace an existing result of another camsim command (a file of another kind or an input is never replaced)."),
    plot: Path = typer.Option(None, "--plot", metavar="FILE.png", help="Convergence, the front, and the optimum's response against the file's."),
    set_: list[str] = typer.Option([], "--set", help="Override a machine key for every run (repeatable)."),
    cycles: int = typer.Option(None, "--cycles", min=1, help=CYCLES_HELP),
    warmup: int = typer.Option(None, "--warmup", min=0, help=WARMUP_HELP),
    sample_rate: str = typer.Option(None, "--sample-rate", help=SAMPLE_RATE_HELP),
    workers: int = typer.Option(None, "--workers", min=1, help="Local worker processes (default: the number of cores; 1 runs serially)."),
    scheduler: str = typer.Option(None, "--scheduler", metavar="tcp://HOST:PORT", help="Run on this Dask scheduler (needs camsim[dask])."),
    dask_local: int = typer.Option(None, "--dask-local", min=1, metavar="N", help="Start a Dask LocalCluster of N workers."),
    json_: bool = typer.Option(False, "--json", help="Print the result as JSON on stdout (schema in docs/optimize.md)."),
    quiet: bool = typer.Option(False, "--quiet", "-q", help="No progress (a bar on a terminal, a line every 10 s elsewhere)."),
    max_runs: int = typer.Option(100_000, "--max-runs", min=1, help="Refuse (exit 2, before anything runs) a job that could make more simulation runs: --budget x speeds x robust samples."),
    yes: bool = typer.Option(False, "--yes", "-y", help="Run a job above --max-runs (or whose runs exceed the 2 GB output estimate)."),
    units: str = units_option(),
) -> None:
    """Optimise MACHINE: the --var/--choice values that minimise or maximise the objective
    while every --constraint holds at every --speeds speed (with --robust: for all but
    --max-probability of the machines as built).

    Exit 0 with a feasible optimum, 1 when no candidate is feasible (the least-violating one
    is reported, no OPTIMISED.toml is written), 2 on bad input, 130 after Ctrl-C or SIGTERM
    (every finished run is kept: the same command with --resume continues).
    """
    from camsim.analyses.optimize import OptimizeInterrupted, optimize
    from camsim.analyses.optimize.policy import check_outputs
    from camsim.errors import InputError
    from camsim.run.lifecycle import sigterm_as_interrupt

    bar = _Progress(quiet, units, (*var, *constraint, *dist, *set_, *([speeds] if speeds else [])))
    with user_errors(), sigterm_as_interrupt():
        check_units(units)
        rate = None
        if sample_rate is not None:
            from camsim.units import QuantityError, to_si

            try:
                rate = to_si(sample_rate, "frequency")
            except QuantityError as exc:
                raise InputError(f"--sample-rate: {exc}") from None
        check_outputs([machine], {"--plot": plot}, None, False, False, force)
        try:
            result = optimize(
                machine, var, minimize=minimize, maximize=maximize, constraints=constraint, choices=choice, log=log,
                absorb=absorb, speeds=speeds, robust=robust, dists=dist, samples=samples, max_probability=max_probability,
                tol_sigma=tol_sigma, method=method, budget=budget, points=points, seed=seed, fixed=set_, cycles=cycles,
                warmup_cycles=warmup, sample_rate=rate, workers=workers, scheduler=scheduler, dask_local=dask_local,
                output=out, history=history, resume=resume, fresh=fresh, force=force, progress=bar, on_start=bar.start, on_units=bar.objective,
                max_runs=math.inf if yes else max_runs, max_output=math.inf if yes else None,
            )
        except OptimizeInterrupted as exc:
            bar.close()
            done = f"interrupted after {exc.evaluations} complete candidate evaluation{'s' if exc.evaluations != 1 else ''}"
            why = f" ({exc.lost} run(s) lost with a worker process)" if exc.lost else ""
            if exc.history is None:
                raise fail(f"{done}{why}; nothing was kept (no -r HISTORY.h5 to keep the runs in)", 130) from None
            if not exc.runs:
                raise fail(f"{done}{why}; no simulation run had finished: nothing was kept", 130) from None
            raise fail(f"{done}{why}; the {exc.runs} finished simulation runs are kept in {exc.history} (and its "
                       ".journal): run the same command with --resume to continue without running them again",
                       130) from None
        finally:
            bar.close()
        shown = machine_units(units, getattr(result.problem, "base", None),
                              [*var, *constraint, *dist, *set_, *([speeds] if speeds else [])])
        if plot is not None:
            from camsim.figures.optimize import save_optimize_plot

            save_optimize_plot(result, plot, units=shown)
        if json_:
            print_json(result.to_json())
        else:
            _render(result, shown)
            wrote = [str(p) for p in (result.output, result.history, plot) if p is not None]
            if wrote:
                err_console.print("wrote " + ", ".join(wrote), markup=False)
        if not result.feasible:
            unwritten = f"{out} was not written" if out is not None else "no machine file is written"
            raise fail(f"no candidate meets the constraints (the least-violating one is reported); {unwritten}", 1)


# What the command reads and writes (camsim.cli.contracts; the conformance suite's source).
from camsim.cli.contracts import Reads, Writes, declare
from camsim.io.outputs import HDF5, TOML, FIGURES
declare("optimize", reads=[Reads("machine", "machine")], force=True,
        writes=[Writes("out", "-o", TOML, "optimize", optional=True), Writes("history", "-r", HDF5, "optimize", journal=True, optional=True),
                Writes("plot", "--plot", FIGURES, "figure", optional=True)],
        example=("optimize", "{in:machine}", "--var", "element.K.preload=20:60N", "--minimize", "max_cam_contact_force",
                 "--method", "local", "--budget", "3", "--workers", "1", "-q", "-o", "{out:-o}", "-r", "{out:-r}", "--plot", "{out:--plot}"))

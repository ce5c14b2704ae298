"""Parameter and speed sweeps: one machine run over a grid of overridden values.

A sweep is the grid of all combinations of a few varied machine keys (``--vary
cam.speed=60:600:10rpm``, ``--values element.seat.stiffness=1e6,2e6``). Every variant is
an ordinary run of the machine with ``KEY=VALUE`` overrides applied by the loader, so
each value gets the loader's unit and dimension checks. Each run is reduced to one
summary row (SI) with fixed column names (:func:`sweep_columns`):

``param:<key>`` for each varied key, then ``peak_displacement:<mass>``,
``peak_velocity:<mass>``, ``peak_acceleration:<mass>`` for every mass,
``peak_transducer_force``, ``max_cam_contact_force``, ``min_cam_contact_force``,
``jump``, ``impacts``, ``max_impact_velocity``, ``periodicity_residual``, ``status``.

Variants run serially, in a local process pool, or on a Dask cluster
(:mod:`camsim.analyses.executors`); the task is the
module-level function :func:`run_variant` (one variant per task), so the rows are the
same numbers whichever executor ran them, and they are put back in grid order.

For a sweep of ``cam.speed`` the lowest swept speed at which the follower jumps is
reported, and :func:`run_sweep` with ``refine_jump=True`` bisects between the last
speed below it (which does not jump) and it, until the bracket is 0.1 rpm wide.

See ``docs/sweeps.md``.
"""

from __future__ import annotations

import math
import os
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from camsim.errors import InputError, MachineFileError
from camsim.analyses.executors import EXECUTOR_ERROR as _EXECUTOR_ERROR
from camsim.analyses.executors import default_workers as _default_workers
from camsim.analyses.executors import make_executor as _make_executor
from camsim.analyses.executors import one_line as _one_line
from camsim.analyses.sweep.grid import build_grid, parse_values, parse_vary  # noqa: F401 - re-exported
from camsim.analyses.sweep.files import csv_path_for, jsonable_rows, write_sweep  # noqa: F401 - re-exported
from camsim.analyses.sweep.result import SweepResult, SweepSettings  # noqa: F401 - re-exported

__all__ = [
    "MachineSource",
    "SweepSettings",
    "SweepResult",
    "parse_vary",
    "parse_values",
    "build_grid",
    "run_variant",
    "run_sweep",
    "write_sweep",
    "sweep_columns",
    "csv_path_for",
    "jsonable_rows",
    "finish_sweep",
    "JUMP_RESOLUTION_RPM",
]

#: Width of the speed bracket at which the jump-onset bisection stops [rpm].
JUMP_RESOLUTION_RPM = 0.1
#: Default largest number of variants run without confirmation (``--max-variants``).
DEFAULT_MAX_VARIANTS = 1000

#: Columns after the parameters and the run's scalars (:func:`camsim.run.result.scalar_columns`).
STATUS_COLUMN = ("status", "")
_RPM = 60.0 / (2.0 * math.pi)  # rad/s -> rpm

# --------------------------------------------------------------------------------------
# Inputs
# --------------------------------------------------------------------------------------
@dataclass(frozen=True)
class MachineSource:
    """A machine file's text and where it came from (what a worker needs to load it).

    The text travels to the worker (a Dask worker need not see the file); ``base_dir``
    is where a cam ``table`` CSV is looked up, so a remote worker needs that path too.
    """

    text: str
    source: str
    base_dir: str

    @classmethod
    def from_path(cls, path: str | os.PathLike[str]) -> MachineSource:
        """Read a machine file (raises :class:`MachineFileError` like the loader)."""
        from camsim.machine.loader import read_machine_text

        return cls(text=read_machine_text(path), source=str(path), base_dir=str(Path(path).parent))

    def load(self, overrides: Sequence[str] = ()):
        """The :class:`~camsim.machine.description.Machine` with ``overrides`` (loader checks apply)."""
        from camsim.machine.loader import load_machine_text

        return load_machine_text(self.text, source=self.source, base_dir=Path(self.base_dir), overrides=list(overrides))


# --------------------------------------------------------------------------------------
# One variant
# --------------------------------------------------------------------------------------
def key_unit(key: str, machine=None) -> str:
    """SI unit of the ``param:<key>`` column (``""`` for numbers and unknown leaves).

    ``coefficient`` is a power law's C [N/m^a] or a friction pair's μ (a number): with the
    ``machine`` it is the element's own (``N/m^1.5``, or ``""``)."""
    from camsim.machine.keys import unit

    leaf = key.rsplit(".", 1)[-1]
    if leaf == "coefficient" and machine is not None:
        exponent = machine_value(machine, key[: -len(leaf)] + "exponent")
        return f"N/m^{exponent:g}" if isinstance(exponent, float) else ""
    return unit(key)


def machine_value(machine, key: str) -> Any:
    """The SI value of override key ``key`` in a loaded machine (None if not found).

    Reads :func:`camsim.machine.loader.machine_to_dict`, so it is the value the run used, e.g.
    ``cam.speed`` in rad/s and a lift given as an angle already turned into metres; the key is
    read by :func:`camsim.machine.keys.machine_value` (the one owner of the key grammar).
    """
    from camsim.machine import keys
    from camsim.machine.loader import machine_to_dict

    return keys.machine_value(machine_to_dict(machine), key)


def _text_value(assignment: str, key: str) -> Any:
    """Best-effort SI number of an override's value text (for rows that did not load)."""
    from camsim.units import ureg

    raw = assignment.partition("=")[2].strip().strip('"')
    unit = key_unit(key)
    try:
        q = ureg.Quantity(raw)
        if not unit or isinstance(q, (int, float)) or q.dimensionless:
            value = q.to("").magnitude if hasattr(q, "to") else q
        else:
            value = q.to(unit).magnitude
        return float(value)
    except Exception:  # noqa: BLE001 - any unparsable text: no number
        return raw


def _param_value(machine, assignment: str) -> Any:
    key = assignment.partition("=")[0].strip()
    value = machine_value(machine, key) if machine is not None else None
    if isinstance(value, bool) or value is None or not isinstance(value, (int, float)):
        return _text_value(assignment, key) if value is None else value
    return float(value)


def failed_row(args, exc: BaseException) -> dict[str, Any]:
    """The row of a variant whose task failed outside it (a worker killed): its parameters
    as written, and the error as its status."""
    _, overrides, _ = args
    params = {f"param:{a.partition('=')[0].strip()}": _text_value(a, a.partition("=")[0].strip()) for a in overrides}
    return {**params, "status": _one_line(exc)}


def summary_row(result) -> dict[str, Any]:
    """The summary columns of one run: :meth:`RunResult.scalars` and ``status = "ok"``."""
    return {**result.scalars(), "status": "ok"}


def run_variant(source: MachineSource, overrides: Sequence[str], settings: SweepSettings) -> tuple[dict[str, Any], Any]:
    """Load, run and summarise one variant; never raises for a variant that fails.

    This is the task every executor runs (a module-level function, so that process
    pools and Dask can ship it).

    Parameters
    ----------
    source : MachineSource
        The machine file's text.
    overrides : sequence of str
        ``"KEY=VALUE"`` assignments: the fixed ``--set`` ones first, then the varied ones.
    settings : SweepSettings

    Returns
    -------
    row : dict
        ``param:<key>`` for every override key (its SI value as the run used it), the
        summary columns of :func:`summary_row`, and ``status``: ``"ok"`` or the
        one-line error (``"SimulationError: ..."``) of a variant that failed to load or run.
    result : RunResult or None
        The run, when ``settings.keep_traces`` and the run succeeded.
    """
    from camsim.run.evaluation import evaluate
    from camsim.run.simulation import simulate

    machine = None
    try:
        machine = source.load(overrides)
        # a variant whose traces are not kept is a design evaluation: its summary without
        # traces (camsim.run.evaluation, issue 42), the same scalars as a full run
        run = simulate if settings.keep_traces else evaluate
        result = run(
            machine,
            cycles=settings.cycles,
            warmup_cycles=settings.warmup_cycles,
            sample_rate=settings.sample_rate,
        )
        row = summary_row(result)
    except Exception as exc:  # noqa: BLE001 - a failing variant is recorded, the sweep goes on
        result = None
        row = {"status": _one_line(exc)}
    params = {f"param:{a.partition('=')[0].strip()}": _param_value(machine, a) for a in overrides}
    return {**params, **row}, (result if settings.keep_traces else None)


# --------------------------------------------------------------------------------------
# The sweep
# --------------------------------------------------------------------------------------
def sweep_columns(keys: Sequence[str], masses: Sequence[str], machine=None) -> list[tuple[str, str]]:
    """The column names and SI units of a sweep over ``keys`` of a machine with ``masses``
    (``machine``: the base machine, for keys whose unit depends on it)."""
    from camsim.run.result import scalar_columns

    return [(f"param:{k}", key_unit(k, machine)) for k in keys] + scalar_columns(list(masses)) + [STATUS_COLUMN]


def _complete_row(row: dict[str, Any], columns: Sequence[tuple[str, str]]) -> dict[str, Any]:
    from camsim.run.result import missing_scalar

    return {name: row[name] if name in row else ("cancelled" if name == "status" else missing_scalar(name))
            for name, _ in columns}


def _unify_params(rows, overrides_per_row, keys) -> None:
    """A parameter column with any non-number value holds the value texts instead."""
    for j, key in enumerate(keys):
        name = f"param:{key}"
        if any(not isinstance(r[name], (int, float)) or isinstance(r[name], bool) for r in rows):
            for r, ov in zip(rows, overrides_per_row):
                r[name] = ov[j].partition("=")[2].strip()




def run_sweep(
    machine_path: str | os.PathLike[str] | MachineSource,
    vary: Sequence[str] = (),
    values: Sequence[str] = (),
    *,
    fixed: Sequence[str] = (),
    workers: int | None = None,
    scheduler: str | None = None,
    dask_local: int | None = None,
    keep_traces: bool = False,
    refine_jump: bool = False,
    cycles: int | None = None,
    warmup_cycles: int | None = None,
    sample_rate: float | None = None,
    max_variants: int | None = None,
    progress: Callable[[int, int], None] | None = None,
    on_start: Callable[[int, str], None] | None = None,
    output: str | os.PathLike[str] | None = None,
    resume: bool = False,
    warn: Callable[[str], None] | None = None,
) -> SweepResult:
    """Run a machine over the grid of all combinations of the varied keys.

    Parameters
    ----------
    machine_path : path or MachineSource
        The machine file.
    vary : sequence of str
        ``KEY=START:STOP:STEP[UNIT]`` ranges (:func:`parse_vary`).
    values : sequence of str
        ``KEY=v1,v2,...`` lists (:func:`parse_values`). Grid axes are the ``vary`` keys in
        order, then the ``values`` keys; the last axis varies fastest.
    fixed : sequence of str
        ``KEY=VALUE`` overrides applied to every variant before the varied ones (``--set``).
    workers : int, optional
        Local processes (default: the number of cores); 1 runs serially in this process.
    scheduler : str, optional
        Address of a running Dask scheduler, ``tcp://HOST:PORT``.
    dask_local : int, optional
        Start a Dask LocalCluster with this many single-threaded worker processes on
        127.0.0.1 for the sweep.
    keep_traces : bool
        Keep each variant's RunResult in :attr:`SweepResult.runs` (memory: all traces).
    refine_jump : bool
        Bisect the jump onset of a ``cam.speed`` sweep to 0.1 rpm (``cam.speed`` must be
        the only varied key).
    cycles, warmup_cycles : int, optional
        Override the machine's recorded and warm-up revolutions.
    sample_rate : float, optional
        Override the machine's output sample rate [Hz].
    max_variants : int, optional
        Refuse grids larger than this (None: no limit).
    progress : callable, optional
        Called as ``progress(done, total)`` after each finished variant.
    on_start : callable, optional
        Called as ``on_start(n_variants, executor_name)`` once the checks passed.
    output : path, optional
        The sweep file: each row is stored as its variant finishes (a
        :class:`~camsim.io.rowstore.RowStore`: journal ``<output>.journal``, and the
        HDF5 file rewritten atomically, readable while the sweep runs), so a killed
        sweep keeps every finished row. :func:`write_sweep` later replaces the file
        with the final table; :func:`finish_sweep` then removes the journal.
    resume : bool
        With ``output``: run only the variants missing from its journal (the job must
        be the same: machine text, ranges, ``--set``, run settings); the rows are the
        ones an uninterrupted sweep gives. Without a journal: a fresh sweep.
    warn : callable, optional
        Called with each warning about the inputs before anything runs: a bare number read as
        SI in the machine file, in ``--set`` or in a varied key's values
        (:func:`camsim.machine.keys.bare_number_note`: ``--vary cam.speed = 60:600:10 → 60 to
        600 rad/s = 573 to 5730 rpm``).

    Returns
    -------
    SweepResult
        With ``interrupted=True`` and rows of status ``"cancelled"`` when Ctrl-C
        (KeyboardInterrupt) stopped it; the finished rows are kept.

    Raises
    ------
    InputError
        A malformed range or list, a key the machine does not have or a value of the
        wrong dimension (checked on the first and last variant before anything runs),
        too many variants, conflicting executor options, an unreachable scheduler, Dask
        not installed.
    """
    source = machine_path if isinstance(machine_path, MachineSource) else MachineSource.from_path(machine_path)
    axes = [parse_vary(v) for v in vary] + [parse_values(v) for v in values]
    if not axes:
        raise InputError("sweep: give at least one --vary KEY=START:STOP:STEP or --values KEY=v1,v2,...")
    keys = [k for k, _ in axes]
    grid = build_grid(axes)
    if max_variants is not None and len(grid) > max_variants:
        raise InputError(
            f"sweep: {len(grid)} variants exceed --max-variants {max_variants}; pass --yes to run them anyway"
        )
    if scheduler is not None and dask_local is not None:
        raise InputError("--scheduler and --dask-local: give one of them, not both")
    if dask_local is not None and dask_local < 1:
        raise InputError(f"--dask-local {dask_local}: needs at least 1 worker")
    workers = _default_workers() if workers is None else workers
    if workers < 1:
        raise InputError(f"--workers {workers}: needs at least 1")
    if refine_jump and keys != ["cam.speed"]:
        raise InputError("--refine-jump: needs a sweep of cam.speed alone (--vary cam.speed=START:STOP:STEPrpm)")
    fixed = list(fixed)
    base = source.load(fixed)  # the --set overrides alone
    if warn is not None:  # issue 44: bare numbers are SI, and say so before anything runs
        from camsim.display import display_units
        from camsim.machine.notes import option_notes

        shown = display_units("file", base.text, [*vary, *values])
        written = {k.strip(): spec for k, _, spec in (t.partition("=") for t in (*vary, *values))}
        for note in [*base.notes, *option_notes("--vary", axes[:len(vary)], shown, written),
                     *option_notes("--values", axes[len(vary):], shown, written)]:
            warn(note)
    # The loader's checks on the varied keys, before anything runs: the first and last
    # variants hold every key and both ends of every range.
    from camsim.run.budget import check_in_memory

    for ov in (grid[0], grid[-1]) if len(grid) > 1 else (grid[0],):
        try:
            variant = source.load(fixed + list(ov))
        except MachineFileError as exc:
            suffix = next((f" (value from --set {a})" for a in ov if exc.message.endswith(f" (value from --set {a})")), None)
            if suffix is None:
                raise
            raise MachineFileError(exc.file, exc.key, exc.message[: -len(suffix)] + suffix.replace("--set", "--vary/--values")) from None
        # each variant's traces are held in memory: the grid's ends bound them (issue 45)
        check_in_memory(variant, f"{source.source or 'sweep'} ({', '.join(ov) or 'the machine'})", cycles=cycles,
                        warmup_cycles=warmup_cycles, sample_rate=sample_rate)
    settings = SweepSettings(cycles=cycles, warmup_cycles=warmup_cycles, sample_rate=sample_rate, keep_traces=keep_traces)
    if sample_rate is not None and sample_rate <= 0:
        raise InputError("--sample-rate: must be positive")
    columns = sweep_columns(keys, list(base.node_names), base)
    from camsim.run import families  # the design's, the camshaft's, the loads', the friction pairs'

    columns[-1:-1] = families.columns(base)  # before "status"
    if resume and keep_traces:
        raise InputError("--resume with --keep-traces: the traces of the variants run before are not kept; rerun without --resume")
    raw: list[dict | None] = [None] * len(grid)
    executor = _make_executor(workers, len(grid), scheduler, dask_local)  # checks the scheduler first
    store = None
    if output is not None:  # issue 16: rows stored as they finish
        try:
            store, stored = _open_store(output, resume, columns, _sweep_meta(source, vary, values, fixed, settings), base)
        except BaseException:
            executor.close()
            raise
        for i, row in stored.items():
            if 0 <= i < len(grid):
                raw[i] = row
    todo = [i for i in range(len(grid)) if raw[i] is None]
    tasks = [(source, tuple(fixed) + grid[i], settings) for i in todo]
    runs: list[Any] = [None] * len(grid) if keep_traces else []
    interrupted = False
    lost = 0
    onset = bracket = None
    notes: list[str] = []
    try:
        if on_start is not None:
            on_start(len(grid), executor.name)
        done = len(grid) - len(todo)
        if progress is not None and done:
            progress(done, len(grid))
        for k, (row, result) in executor.run(tasks, run_variant, failed_row):
            i = todo[k]
            # the --set keys are not columns; only the varied ones
            transient = row.pop(_EXECUTOR_ERROR, False)
            row = {name: v for name, v in row.items() if not name.startswith("param:") or name[6:] in keys}
            raw[i] = row
            if transient:
                lost += 1
            elif store is not None:
                store.append(i, row)
            if keep_traces:
                runs[i] = result
            done += 1
            if progress is not None:
                progress(done, len(grid))
        first, _ = _first_jump(raw, keys)
        if refine_jump and first is not None:
            onset, bracket, note = _refine(executor, source, fixed, settings, raw, first)
            if note:
                notes.append(note)
    except KeyboardInterrupt:
        interrupted = True
        executor.abort()
    finally:
        if store is not None:
            store.close()
        if not interrupted:
            executor.close()
        else:
            try:
                executor.close()
            except Exception:  # noqa: BLE001 - the workers were stopped on purpose
                pass

    rows = []
    for i, row in enumerate(raw):
        if row is None:
            params = {
                f"param:{a.partition('=')[0].strip()}": _text_value(a, a.partition("=")[0].strip()) for a in grid[i]
            }
            row = {**params, "status": "cancelled"}
        rows.append(_complete_row(row, columns))
    _unify_params(rows, grid, keys)
    first, note = _first_jump(rows, keys)
    if note:
        notes.append(note)
    return SweepResult(
        rows=rows,
        columns=columns,
        jump_onset_rpm=onset,
        first_jump_rpm=None if first is None else first[1] * _RPM,
        jump_bracket_rpm=bracket,
        machine=base,
        overrides=grid,
        fixed_overrides=fixed,
        runs=runs,
        settings=settings,
        interrupted=interrupted,
        executor=executor.name,
        notes=notes,
        journal=None if store is None else store.journal,
        resumed=len(grid) - len(todo),
        executor_failures=lost,
    )


def _sweep_meta(source: MachineSource, vary, values, fixed, settings: SweepSettings) -> dict[str, Any]:
    """What identifies a sweep for ``--resume``: same meta, same grid, same rows."""
    import hashlib

    return {
        "kind": "sweep",
        "machine_sha256": hashlib.sha256(source.text.encode("utf-8")).hexdigest(),
        "vary": list(vary),
        "values": list(values),
        "set": list(fixed),
        "cycles": settings.cycles,
        "warmup_cycles": settings.warmup_cycles,
        "sample_rate": settings.sample_rate,
    }


def _open_store(output, resume: bool, columns, meta, machine):
    """The RowStore of a sweep at ``output`` and the rows it already holds."""
    from camsim.io.rowstore import RowStore, journal_path_for
    from camsim.io.hdf5 import write_root_attributes

    def decorate(f) -> None:
        write_root_attributes(f, machine, "sweep")
        f.create_group("sweep", track_order=True).attrs["interrupted"] = True

    kwargs = {"table": "sweep/summary", "decorate": decorate}
    if resume and journal_path_for(output).exists():
        store = RowStore.resume(output, meta, **kwargs)
        if store.columns != [tuple(c) for c in columns]:
            store.close()
            raise InputError(f"{store.journal}: cannot resume: the stored columns differ from this sweep's")
    else:
        store = RowStore.create(output, columns, meta, **kwargs)
    return store, store.rows()


def finish_sweep(result: SweepResult) -> None:
    """Remove the journal of a sweep that ran every variant (after :func:`write_sweep`).

    Kept when the sweep was interrupted or a worker failed, for ``--resume`` (unless no
    variant finished: there is nothing to resume then).
    """
    finished = any(r["status"] != "cancelled" for r in result.rows)
    if result.journal is not None and (not (result.interrupted or result.executor_failures) or not finished):
        Path(result.journal).unlink(missing_ok=True)


def _first_jump(rows, keys) -> tuple[tuple[int, float] | None, str | None]:
    """(row index, speed [rad/s]) of the lowest swept speed whose variant jumps, and a note.

    Only rows that ran decide, and only when every lower speed ran too: a failed or
    cancelled row below the lowest jumping one could be the true onset, so then no speed
    is claimed (None and the note says why; issue 26).
    """
    if "cam.speed" not in keys:
        return None, None
    best = None
    for i, r in enumerate(rows):
        if r is None or r.get("status") != "ok" or not r.get("jump"):
            continue
        speed = r.get("param:cam.speed")
        if not isinstance(speed, float) or math.isnan(speed):
            continue
        if best is None or speed < best[1]:
            best = (i, speed)
    missing = []
    for r in rows:
        if r is not None and r.get("status") == "ok":
            continue
        speed = None if r is None else r.get("param:cam.speed")
        missing.append(speed if isinstance(speed, float) else math.nan)
    if best is not None:
        below = [s for s in missing if not s >= best[1]]  # NaN: unknown speed, may be below
        if below:
            return None, (
                f"no jump onset: the follower jumps at {best[1] * _RPM:.6g} rpm, but {len(below)} lower "
                "speeds did not run (failed or cancelled), so the onset may lie below"
            )
        return best, None
    if missing:
        return None, (
            f"no conclusion on a jump: {len(missing)} of {len(rows)} speeds did not run (failed or cancelled); "
            "the follower does not jump at the speeds that ran"
        )
    return None, None


def _refine(executor, source, fixed, settings, rows, first) -> tuple[float | None, tuple[float, float] | None, str | None]:
    """Bisect between the highest non-jumping swept speed below the first jump and it."""
    _, hi_speed = first
    below = [
        r["param:cam.speed"]
        for r in rows
        if r is not None and r.get("status") == "ok" and not r.get("jump") and r["param:cam.speed"] < hi_speed
    ]
    if not below:
        return None, None, (
            f"the follower already jumps at the lowest swept speed {hi_speed * _RPM:.6g} rpm: "
            "the onset is below the swept range, not refined"
        )
    lo, hi = max(below) * _RPM, hi_speed * _RPM
    quiet = SweepSettings(cycles=settings.cycles, warmup_cycles=settings.warmup_cycles, sample_rate=settings.sample_rate)
    while hi - lo > JUMP_RESOLUTION_RPM:
        mid = 0.5 * (lo + hi)
        ((_, (row, _)),) = list(executor.run([(source, tuple(fixed) + (f"cam.speed={mid!r} rpm",), quiet)], run_variant, failed_row))
        if row["status"] != "ok":
            return None, (lo, hi), f"jump-onset refinement stopped at {mid:.6g} rpm: {row['status']}"
        if row["jump"]:
            hi = mid
        else:
            lo = mid
    return 0.5 * (lo + hi), (lo, hi), None


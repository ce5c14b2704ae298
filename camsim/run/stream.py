"""Streamed runs: traces go to the file while the run proceeds, memory stays bounded.

:func:`simulate_to_file` is what ``camsim run`` calls. The integrator hands each recorded
stretch to a :class:`StreamAssembler` (``Integrator.run(on_stretch=...)``) instead of
collecting them; the assembler turns it into output samples with the very functions the
in-memory path uses (:func:`camsim.run.simulation.stretch_samples`,
:func:`camsim.run.simulation.sample_traces`), so the traces in the file equal those of
:func:`camsim.run.simulation.simulate` bit for bit. Pieces of :data:`FLUSH` samples are
appended to the file (:class:`camsim.run.streamfile.TraceStreamWriter`) and dropped.

Everything the summary needs is computed on the fly over every recorded revolution,
whatever is stored (``record``, ``record_last``, ``summary_only``):

* peaks, cam-force extremes and their times: folded piece by piece from each piece's own
  :meth:`RunResult.summary` / :meth:`RunResult.scalars` (the first occurrence wins, as
  ``argmax`` over the whole trace);
* the event table: the integrator's events as they happen; the located peak force and the
  contact duration of each impact, and the run's located extremes, by the folder the
  in-memory path uses too (:class:`camsim.run.extremes.ExtremesFolder`);
* the jump rows: none here — they are events of the integrator (camsim.engine.watch).

A sample is processed only once every event that could concern it is known: the
integrator reports, with each stretch, the time up to which its event list is complete;
samples within :func:`_margin` of that time wait for the next stretch.
"""

from __future__ import annotations

import math
import os
from fnmatch import fnmatchcase
from typing import Any

import numpy as np
from threadpoolctl import threadpool_limits

from camsim.errors import InputError, SimulationError
from camsim.elements.events import EventTable
from camsim.run.result import MASS_QUANTITIES, RunResult, scalar_columns
from camsim.run.assemble import after_run_warnings, boundaries_deg, negative_cam_force_warning, recorded_event
from camsim.run.extremes import ExtremesFolder, digest, ingest_event
from camsim.run.samples import RunSetup, empty_traces, sample_traces
from camsim.run.simulation import _simulate

__all__ = ["simulate_to_file", "StreamedRun", "trace_layout", "machine_trace_layout", "select_traces", "FLUSH"]

#: Output samples assembled before they are appended to the file and dropped.
FLUSH = 65536


def _margin(h_out: float) -> float:
    """Samples closer than this [s] to the time up to which events are known wait: twice
    the on-grid tolerance of a sample (1e-6 of a sample interval) plus slack for rounding."""
    return 1e-5 * h_out + 1e-9


# ---------------------------------------------------------------------- layout and selection
def _empty_result(run: RunSetup, events=None, located=None) -> RunResult:
    return RunResult(
        machine=run.machine, **empty_traces(run), events=EventTable(events or []),
        periodicity_residual=float("nan"), warnings=[], no_impact=run.no_impact, located=located,
    )


def trace_layout(run: RunSetup) -> dict:
    """Path → :class:`~camsim.run.result.Trace` (empty data) of every trace this run has, in file order."""
    return _empty_result(run).traces()


def machine_trace_layout(machine, no_impact: bool = False) -> dict:
    """:func:`trace_layout` of a machine before any run (builds its model; milliseconds)."""
    from camsim.cam.camshaft import cam_input
    from camsim.model.assembly import Model

    cam = cam_input(machine)
    run = RunSetup(machine, Model(machine, no_impact=no_impact), cam, None, 0.0, 0.0, 1.0, [], no_impact,
                   cam.period if machine.cam is not None else None)
    return trace_layout(run)


def select_traces(paths, record: list[str] | None, summary_only: bool) -> list[str]:
    """The trace paths to store: those matching any of ``record`` (fnmatch patterns on
    result paths, a leading ``/`` ignored), all without ``record``, none with
    ``summary_only``; ``time`` goes with any other.

    Raises
    ------
    InputError
        A pattern that matches no trace (naming the paths there are).
    """
    paths = list(paths)
    if summary_only:
        return []
    if not record:
        return paths
    chosen = set()
    for pattern in record:
        pat = pattern.strip().lstrip("/")
        hits = {p for p in paths if fnmatchcase(p, pat)}
        if not pat or not hits:
            raise InputError(f"--record {pattern}: matches no trace; this run has {', '.join(paths)}")
        chosen |= hits
    if chosen - {"time"}:
        chosen.add("time")
    return [p for p in paths if p in chosen]


# ---------------------------------------------------------------------- the summary object
class StreamedRun:
    """What a streamed run returns: its summary, events and warnings; traces are in the file.

    Offers the summary side of :class:`~camsim.run.result.RunResult` (:meth:`summary`,
    :meth:`scalars`, :meth:`impacts`, :meth:`follower_jumps`, ``events``, ``warnings``,
    ``periodicity_residual``), computed over every recorded revolution; :meth:`open`
    reads the stored traces back as a RunResult.

    Attributes
    ----------
    path : str
        The result file.
    recorded : list of str
        The trace paths stored in it.
    record_last : int
        Revolutions of traces stored (0: all).
    samples : int
        Output samples of the run (stored or not).
    stored_samples : int
        Samples per stored trace.
    """

    def __init__(self, machine, events: EventTable, warnings: list[str], no_impact: bool, boundaries: np.ndarray,
                 scalars: dict, summary_masses: dict, extremes: dict, samples: int, design=None, located=None, shaft=None):
        self.machine = machine
        self.events = events
        self.warnings = warnings
        self.no_impact = no_impact
        self.boundaries_deg = boundaries
        self.periodicity_residual = float("nan")
        self.steady_state = None  # set by the run (camsim.run.steady), as on RunResult
        self.sample_rate = 0.0
        self.path = ""
        self.recorded: list[str] = []
        self.record_last = 0
        self.samples = samples
        self.stored_samples = 0
        self._scalars = scalars
        self._masses = summary_masses
        self._extremes = extremes
        self._design = design  # camsim.cam.design.DesignAccumulator with [cam.geometry]
        #: The located extremes (camsim.run.extremes), as RunResult.located.
        self.located = located
        self.rods: dict[str, dict] = {}  # issue 39: each rod's discretisation and extremes
        self._shaft = shaft  # camsim.run.camshaft.CamshaftAccumulator: several cams or a [camshaft] (issue 38)
        self.shaft_dynamics: dict | None = None
        #: Each load's work per cycle [J] (camsim.run.loads; None without loads, issue 43).
        self.load_work: dict[str, float] | None = None
        self.friction_energy: dict[str, float] | None = None

    def camshaft_summary(self, cs: float | None = None) -> dict | None:
        """The camshaft section over every revolution (as :meth:`RunResult.camshaft_summary`)."""
        if self._shaft is None:
            return None
        if cs is not None and cs != self._shaft.cs:
            import copy

            other = copy.copy(self._shaft)
            other.cs = cs
            return other.summary(self.located)
        return self._shaft.summary(self.located)

    def design_summary(self, cs: float | None = None) -> dict | None:
        """Cam design checks and dynamic quantities over every revolution (as
        :meth:`RunResult.design_summary`); None without ``[cam.geometry]``."""
        return None if self._design is None else self._design.summary(cs, self.located)

    def missing_reasons(self) -> dict[str, str]:
        """Why each scalar without a value is absent (as :meth:`RunResult.missing_reasons`)."""
        from camsim.run.result import missing_reason

        scalars = self.scalars()
        design = (self.design_summary() or {}).get("reasons", {})
        out = {}
        for name in scalars:
            why = missing_reason(self.machine, name, {**scalars, "status": "ok"})
            if why is not None:
                out[name] = design.get(name, why) if why.startswith("not computed") else why
        return out

    def peak(self, name: str, quantity: str) -> float:
        """Largest |sample| of a mass's displacement, velocity or acceleration [SI]."""
        return float(self._scalars[f"peak_{quantity}:{name}"])

    def impacts(self) -> EventTable:
        """Impact-like events (contacts closing and links rejoining)."""
        return self.events.impacts()

    def follower_jumps(self) -> bool:
        """True when the follower leaves the cam (negative cam force, or a cam contact opens)."""
        return bool(self._scalars["jump"])

    def scalars(self) -> dict[str, Any]:
        """The flat summary, as :meth:`RunResult.scalars` (same names, units, values)."""
        from camsim.cam.design import design_row_from

        out = dict(self._scalars)
        out["periodicity_residual"] = float(self.periodicity_residual)
        out.update(design_row_from(self.design_summary()))
        if self._shaft is not None:
            out.update(self._shaft.row(self.located))
        from camsim.run import families  # issue 43: the loads', the friction pairs'

        out.update(families.rows(self))
        return out

    def summary(self) -> dict:
        """Peaks with when, forces, impacts and residual, as :meth:`RunResult.summary`."""
        out: dict = {"machine": self.machine.name, "no_impact": self.no_impact, "masses": self._masses}
        out.update(self._extremes)
        out["located"] = self.located is not None
        out["jump"] = self.follower_jumps()
        out["impacts"] = [e.to_dict() for e in self.impacts()]
        out["events"] = len(self.events)
        out["periodicity_residual"] = None if math.isnan(self.periodicity_residual) else float(self.periodicity_residual)
        out["warnings"] = list(self.warnings)
        out["reasons"] = self.missing_reasons()  # issue 26: why a value is null
        design = self.design_summary()
        if design is not None:
            out["design"] = design
        from camsim.run.checks import contact_stress_rows  # issue 39

        stress = contact_stress_rows(self.machine, self.events)
        if self.rods:
            out["rods"] = self.rods
        if stress:
            out["contact_stress"] = stress
        shaft = self.camshaft_summary()
        if shaft is not None:
            if self.shaft_dynamics is not None:
                shaft["dynamics"] = self.shaft_dynamics
            out["camshaft"] = shaft
        from camsim.run import families  # issue 43: the loads', the friction pairs'

        out.update(families.summaries(self))
        return out

    def open(self) -> RunResult:
        """The stored traces read back as a :class:`RunResult` (:func:`camsim.open_result`)."""
        from camsim.run.result import open_result

        return open_result(self.path)


# ---------------------------------------------------------------------- the assembler
class StreamAssembler:
    """Consumer of a run's stretches: samples → file pieces, summary and events on the fly.

    Parameters
    ----------
    run : RunSetup
    writer : TraceStreamWriter, optional
        Receives each piece of traces (None: nothing stored).
    flush : int, optional
        Samples per piece (default :data:`FLUSH`).
    """

    def __init__(self, run: RunSetup, writer=None, flush: int | None = None, path: str = "", record_last: int = 0):
        self.run = run
        self.writer = writer
        self.path = path
        self.record_last = record_last
        self.flush = flush or FLUSH
        self.margin = _margin(run.h_out)
        self._pending: list[np.ndarray] | None = None  # t, x, v, a, u, forces not yet committed
        self._buffer: list[list[np.ndarray]] = []
        self._buffered = 0
        self.events = EventTable()
        from camsim.cam.design import DesignAccumulator

        self._design = DesignAccumulator.for_machine(run.machine)  # None without [cam.geometry]
        from camsim.run import camshaft

        self._shaft = camshaft.CamshaftAccumulator(run.machine) if camshaft.active(run.machine) else None
        self._folder = ExtremesFolder(run.observables, run.t_rec) if run.observables is not None else None
        self._samples = 0
        self._masses: dict[str, dict[str, dict]] = {}
        self._extremes: dict[str, dict | None] = {"peak_transducer_force": None, "max_cam_contact_force": None, "min_cam_contact_force": None}
        self._scalars: dict[str, Any] = {}
        self._jump_samples = False
        self._cam_min: tuple[float, float] | None = None
        self._rods: dict[str, dict] = {}

    # ------------------------------------------------------------------ events
    def _ingest_events(self) -> None:
        run = self.run
        t_rec, t_end = run.t_rec, run.t_end
        for e in run.integrator.take_events():  # the engine keeps the recent ones it reads
            if not (t_rec - 1e-12 <= e.time <= t_end + 1e-12):
                continue
            ev = recorded_event(run, e)
            if self._folder is not None:
                ingest_event(self._folder, run.model, ev, e.time)
            self.events.append(ev)

    # ------------------------------------------------------------------ samples
    def on_stretch(self, stretch, t_known: float) -> None:
        """Take one recorded stretch; every event before ``t_known`` [s] is recorded."""
        self._ingest_events()
        record, samples = digest(self.run, stretch)
        if self._folder is not None:
            self._folder.add(record)
        if samples is not None:
            if self._pending is None:
                self._pending = list(samples)
            else:
                self._pending = [np.concatenate([a, b]) for a, b in zip(self._pending, samples)]
        self._commit(t_known - self.margin)

    def _commit(self, before: float | None) -> None:
        """Move pending samples earlier than ``before`` [s] (all: None) to the buffer,
        dropping a sample whose grid point the next sample also has (the later wins)."""
        if self._pending is None:
            return
        t = self._pending[0]
        if before is None:
            n = t.size
        else:
            n = min(int(np.searchsorted(t, before, side="left")), t.size - 1)  # the last waits for its successor
        if n <= 0:
            return
        run = self.run
        grid_index = np.round((t[: n + 1] - run.t_rec) / run.h_out)
        keep = np.ones(n, dtype=bool)
        if n < t.size:
            keep = grid_index[:n] != grid_index[1 : n + 1]
        else:
            keep[:-1] = grid_index[:-1] != grid_index[1:]
        piece = [arr[:n] if np.all(keep) else arr[:n][keep] for arr in self._pending]
        piece.append(grid_index[:n] if np.all(keep) else grid_index[:n][keep])
        self._pending = None if n == t.size else [arr[n:] for arr in self._pending]
        self._buffer.append(piece)
        self._buffered += piece[0].size
        if self._buffered >= self.flush:
            self._flush()

    def _flush(self) -> None:
        if not self._buffer:
            return
        parts = [np.concatenate(col) if len(self._buffer) > 1 else self._buffer[0][i] for i, col in enumerate(zip(*self._buffer))]
        self._buffer, self._buffered = [], 0
        _, x, v, a, u, forces, grid_index = parts
        time = grid_index * self.run.h_out
        traces = sample_traces(self.run, time, x, v, a, u, forces)
        piece = RunResult(machine=self.run.machine, **traces, events=EventTable(), periodicity_residual=float("nan"))
        self._samples += time.size
        self._fold(piece)
        if self._design is not None:
            self._design.add(piece)
        if self._shaft is not None:
            self._shaft.add(piece)
        cf = traces["cam_contact_force"]
        if cf is not None:
            k = int(np.argmin(cf))
            if self._cam_min is None or cf[k] < self._cam_min[0]:
                self._cam_min = (cf[k], time[k])
        if self.writer is not None:
            self.writer.append(piece.traces())

    def _fold(self, piece: RunResult) -> None:
        """Fold one piece's peaks and extremes into the run's (first occurrence wins)."""
        summary, scalars = piece.summary(), piece.scalars()
        for name, entry in summary["masses"].items():
            mine = self._masses.setdefault(name, {})
            for quantity, value in entry.items():
                if quantity not in mine or value["peak"] > mine[quantity]["peak"]:
                    mine[quantity] = value
        for key, better in (("peak_transducer_force", float.__gt__), ("max_cam_contact_force", float.__gt__),
                            ("min_cam_contact_force", float.__lt__)):
            value = summary[key]
            if value is not None and (self._extremes[key] is None or better(value["value"], self._extremes[key]["value"])):
                self._extremes[key] = value
        for key, value in scalars.items():
            if key.startswith("peak_") or key in ("max_cam_contact_force", "cam_separation"):
                old = self._scalars.get(key)
                self._scalars[key] = value if old is None or math.isnan(old) or value > old else old
            elif key == "min_cam_contact_force":
                old = self._scalars.get(key)
                self._scalars[key] = value if old is None or math.isnan(old) or value < old else old
        self._jump_samples = self._jump_samples or bool(scalars["jump"])
        for name, row in summary.get("rods", {}).items():  # issue 39: a rod's extremes
            mine = self._rods.setdefault(name, row)
            for key in ("max_stress", "max_end_force"):
                if row[key] is not None and (mine[key] is None or row[key]["value"] > mine[key]["value"]):
                    mine[key] = row[key]

    # ------------------------------------------------------------------ the end
    def finish(self) -> StreamedRun:
        """Process what is left and return the run's summary (residual and rate set by the caller)."""
        self._ingest_events()
        self._commit(None)
        self._flush()
        if not self._samples:
            raise SimulationError("the run recorded no samples")
        run = self.run
        events = self.events
        located = self._folder.finish() if self._folder is not None else None
        # The located extremes and the event-derived scalars (impacts, their largest speed,
        # a cam contact opening) from the same code as an in-memory result, on a result
        # without samples.
        probe = _empty_result(run, events, located)
        from_events, probe_summary = probe.scalars(), probe.summary()
        if run.model.driven:
            # jump rows came with the integrator's events (camsim.engine.watch)
            events.sort(key=lambda e: e.time)
            if run.machine.multi_cam and self._shaft is not None:  # issue 38: each driven mass's own
                for cam in run.machine.cams:
                    hit = (located or {}).get(f"cams/{cam.name}/contact_force")
                    low = (hit["min"].value, hit["min"].time) if hit is not None else self._shaft.force_min.get(cam.name)
                    if cam.drives and low is not None and low[0] < 0:
                        run.warnings.append(negative_cam_force_warning(cam.drives, *low))
                low = None
            else:
                low = probe_summary["min_cam_contact_force"] if located is not None else None
            if low is not None and low["value"] < 0:
                run.warnings.append(negative_cam_force_warning(run.model.driven, low["value"], low["time"]))
            elif low is None and not run.machine.multi_cam and self._cam_min is not None and self._cam_min[0] < 0:
                run.warnings.append(negative_cam_force_warning(run.model.driven, *self._cam_min))
        run.warnings.extend(after_run_warnings(run.machine, events))  # issue 39
        scalars: dict[str, Any] = {}
        for name, _ in scalar_columns(list(run.machine.node_names)):
            scalars[name] = self._scalars.get(name, from_events[name])
        masses = {name: {q: self._masses[name][q] for q in MASS_QUANTITIES} for name in run.machine.node_names}
        extremes = dict(self._extremes)
        if located is not None:
            for name in scalars:
                if name.startswith("peak_") or name in ("max_cam_contact_force", "min_cam_contact_force"):
                    scalars[name] = from_events[name]
            masses = {m: {q: probe_summary["masses"][m][q] for q in MASS_QUANTITIES} for m in masses}
            extremes = {key: probe_summary[key] for key in extremes}
        scalars["jump"] = bool((self._jump_samples and located is None) or from_events["jump"])
        scalars["impacts"] = from_events["impacts"]
        scalars["max_impact_velocity"] = from_events["max_impact_velocity"]
        # the span off the cam runs between events, to the end of the record when still open
        scalars["cam_separation_angle"] = probe.separation_span(run.t_end - run.t_rec)
        if self._shaft is not None:  # issue 38: a collision of two stations' parts is a warning row
            run.warnings.extend(self._shaft.warnings())
        streamed = StreamedRun(run.machine, events, run.warnings, run.no_impact, boundaries_deg(run), scalars, masses,
                               extremes, self._samples, design=self._design, located=located, shaft=self._shaft)
        streamed.rods = probe_summary.get("rods", self._rods) if located is not None else self._rods
        streamed.load_work = run.load_work.values() if run.load_work is not None else None  # issue 43
        streamed.friction_energy = run.friction_work.values() if run.friction_work is not None else None
        return streamed

    def close(self, result: StreamedRun) -> None:
        """Write the event table, attributes and summary once the result is complete."""
        result.path = self.path
        result.record_last = self.record_last
        if self.writer is not None:
            result.recorded = list(self.writer.paths)
            result.stored_samples = self.writer.samples
            self.writer.finish(result)


# ---------------------------------------------------------------------- the API
def limit_heap_growth() -> bool:
    """Fix glibc's mmap threshold at 128 kB for this process (``mallopt``; Linux/glibc).

    glibc raises the threshold after each large block it frees, after which the
    0.5-1 MB pieces of a streamed run come from the heap, which fragments and keeps
    growing slowly (measured on a CDTM run: +10 MB per 100 revolutions; flat with the
    threshold fixed). The ``run`` command calls this; a library user may. Returns
    False where it is not available.
    """
    import ctypes
    import ctypes.util

    try:
        libc = ctypes.CDLL(ctypes.util.find_library("c") or "libc.so.6")
        return bool(libc.mallopt(-3, 128 * 1024))  # M_MMAP_THRESHOLD
    except (OSError, AttributeError):
        return False


def simulate_to_file(
    machine,
    path: str | os.PathLike[str],
    *,
    no_impact: bool = False,
    cycles: int | None = None,
    warmup_cycles: int | None = None,
    sample_rate: float | None = None,
    progress=None,
    record: list[str] | None = None,
    record_last: int | None = None,
    summary_only: bool = False,
    compress: bool = False,
) -> StreamedRun:
    """Simulate a machine, writing its traces to an HDF5 file while it runs.

    Memory stays bounded whatever the number of revolutions; the file is written to a
    temporary name and renamed when complete (an error or Ctrl-C leaves the previous
    file and no temporary one). The traces equal those of :func:`camsim.run.simulation.simulate`
    bit for bit; the summary is computed over every recorded revolution.

    Parameters
    ----------
    machine : Machine
    path : path
        The result file (spec §7 layout, plus ``/summary``).
    no_impact, cycles, warmup_cycles, sample_rate, progress
        As :func:`camsim.run.simulation.simulate` (``sample_rate`` [Hz]).
    record : list of str, optional
        fnmatch patterns of the trace paths to store (``"transducer/*"``,
        ``"masses/M3/*"``); default all.
    record_last : int, optional
        Store only the last N recorded revolutions of traces (needs a cam).
    summary_only : bool
        Store no trace: the event table and the summary only.
    compress : bool
        gzip + shuffle the stored traces.

    Returns
    -------
    StreamedRun

    Raises
    ------
    InputError
        Bad settings or a ``record`` pattern that matches no trace (before integrating).
    SimulationError
        As :func:`camsim.run.simulation.simulate`.
    """
    from camsim.io.hdf5 import write_root_attributes
    from camsim.io.outputs import writing
    from camsim.run.streamfile import TraceStreamWriter

    if record_last is not None and record_last < 1:
        raise InputError(f"--record-last {record_last}: must be at least 1 revolution")
    # No chunk cache: the writer writes whole chunks, and HDF5's cache (with its free
    # lists) would otherwise hold on to memory that grows with the file (measured).
    with threadpool_limits(limits=1, user_api="blas"), writing(path, "hdf5", owner="run") as target, \
            target.h5(rdcc_nbytes=0) as f:
        write_root_attributes(f, machine, "run")

        def make(run: RunSetup) -> StreamAssembler:
            stored = select_traces(trace_layout(run), record, summary_only)
            keep_from = None
            if record_last is not None:
                if run.period is None:
                    raise InputError(f"--record-last {record_last}: needs a cam (revolutions); {run.machine.source} has none")
                k = math.ceil(((run.t_end - run.t_rec) - record_last * run.period) / run.h_out - 1e-6)
                keep_from = k * run.h_out if k > 0 else None
            writer = TraceStreamWriter(f, trace_layout(run), stored, keep_from, boundaries_deg(run), compress=compress,
                                       check=target.check)
            return StreamAssembler(run, writer, path=str(path), record_last=int(record_last or 0))

        return _simulate(machine, no_impact, cycles, warmup_cycles, sample_rate, progress, stream=make)


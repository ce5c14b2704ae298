"""Writing run and comparison results to HDF5 (spec §7).

Layout of a run (at the file root, or inside ``/impact`` and ``/no_impact`` of a
comparison)::

    time, cam/{angle,displacement,velocity,acceleration,jerk,boundaries_deg},
    masses/<name>/{displacement,velocity,acceleration}, elements/<name>/force,
    cam_contact/force, transducer/force, loads/<name>/force, events, extremes

Every trace has ``units`` and ``long_name`` attributes and ``time`` attached as its
dimension scale. Files are written atomically and deterministically.
"""

from __future__ import annotations

import math
import os
from collections.abc import Sequence
from typing import TYPE_CHECKING

import h5py
import numpy as np

from camsim.io.hdf5 import SCHEMA, write_root_attributes, write_table, write_time, write_trace  # noqa: F401 - SCHEMA, write_root_attributes: also this writer's names
from camsim.io.outputs import writing

if TYPE_CHECKING:
    from camsim.elements.events import Event

def write_events(group: h5py.Group, events: Sequence["Event"]) -> None:
    """The event table as a compound dataset (NaN where a column does not apply)."""
    from camsim.elements.events import EventTable

    write_table(group, "events", EventTable(events).columns())


def write_extremes(group: h5py.Group, result) -> None:
    """The run's located extremes (spec §4) as the table ``extremes``: per quantity (a
    result path, or ``cam_force``) its unit, largest value and when, smallest value and when
    (recorded clock). Nothing when the run located none."""
    located = getattr(result, "located", None)
    if not located:
        return
    from camsim.run.extremes import observable_units

    paths = list(located)
    units = [observable_units(p) for p in paths]
    columns = {
        "quantity": (np.array(paths, dtype=object), ""),
        "units": (np.array(units, dtype=object), ""),
        "max": (np.array([located[p]["max"].value for p in paths]), "quantity's"),
        "max_time": (np.array([located[p]["max"].time for p in paths]), "s"),
        "min": (np.array([located[p]["min"].value for p in paths]), "quantity's"),
        "min_time": (np.array([located[p]["min"].time for p in paths]), "s"),
    }
    write_table(group, "extremes", columns)


def write_run_group(group: h5py.Group, result) -> h5py.Dataset:
    """Write one :class:`~camsim.run.result.RunResult` into ``group``; returns its time scale.

    The traces and their units are the result's own (:meth:`RunResult.traces`).
    """
    traces = result.traces()
    time = write_time(group, traces.pop("time").data)
    for path, trace in traces.items():
        write_trace(group, path, trace.data, trace.units, trace.long_name, time)
        if path == "cam/jerk":  # the joins sit with the cam traces (spec §7 order)
            group.create_dataset("cam/boundaries_deg", data=np.asarray(result.boundaries_deg, dtype=float)).attrs["units"] = "deg"
        elif path == "camshaft/angle" and "cam/jerk" not in traces:  # several cams: the shaft's angles of every join
            group.create_dataset("camshaft/boundaries_deg", data=np.asarray(result.boundaries_deg, dtype=float)).attrs["units"] = "deg"
    write_events(group, result.events)
    write_extremes(group, result)
    write_run_attributes(group, result)
    write_summary(group, result)
    return time


def write_run_attributes(group: h5py.Group, result) -> None:
    """The run's attributes on its group: no-impact variant, sample rate, periodicity residual
    and how the steady state was reached (an in-memory result and a streamed one alike)."""
    group.attrs["no_impact"] = bool(result.no_impact)
    group.attrs["sample_rate"] = float(result.sample_rate)
    residual = result.periodicity_residual
    group.attrs["periodicity_residual"] = float(residual) if not math.isnan(residual) else float("nan")
    steady = getattr(result, "steady_state", None)
    if steady is not None:  # issue 42: the warm-up revolutions, or shooting (camsim.run.steady)
        group.attrs["steady_state"] = str(steady["method"])
        group.attrs["steady_state_revolutions"] = int(steady["revolutions"])


def write_summary(group: h5py.Group, result) -> h5py.Group:
    """The run's flat summary as attributes of ``<group>/summary``.

    One attribute per scalar of :meth:`~camsim.run.result.RunResult.scalars` (SI; NaN where
    it does not apply) with its unit in ``units:<name>``; ``recorded``: the trace paths
    the file holds (JSON list; all of them unless the run was recorded with ``--record``
    or ``--summary-only``); ``record_last``: revolutions of traces kept (0: all);
    ``warnings``: the run's warnings (JSON list, SI) and ``notes``: how the machine file was read
    (JSON list, :attr:`Machine.notes`), both as the run printed them. A streamed run computes the
    scalars over every revolution, whatever it stored.
    """
    import json

    from camsim.run.result import scalar_columns

    from camsim.cam.design import design_columns
    from camsim.run.camshaft import camshaft_columns

    scalars = result.scalars()
    # every scalar with its unit: the cam design's and the camshaft's too (issue 44: the page
    # showed "peak_camshaft_torque 23.76 -", SI without a unit)
    from camsim.run import families  # the design's, the camshaft's, the loads', the friction pairs'

    units = dict(scalar_columns(list(result.machine.node_names)) + families.columns(result.machine))
    g = group.create_group("summary", track_order=True)
    for name, value in scalars.items():
        g.attrs[name] = value
        g.attrs[f"units:{name}"] = units.get(name, "")
    recorded = getattr(result, "recorded", None)
    if recorded is None:
        recorded = list(result.traces())
    g.attrs["recorded"] = json.dumps(list(recorded))
    g.attrs["record_last"] = int(getattr(result, "record_last", 0) or 0)
    # Issue 44: what the run printed, so the report page shows every warning: the run's own
    # (composed in SI, shown in the reader's units) and how its machine file was read (as printed).
    g.attrs["warnings"] = json.dumps(list(getattr(result, "warnings", []) or []), ensure_ascii=False)
    g.attrs["notes"] = json.dumps(list(getattr(result.machine, "notes", ()) or ()), ensure_ascii=False)
    return g


def write_run(result, path: str | os.PathLike[str]) -> None:
    """Write a run result to ``path`` atomically."""
    with writing(path, "hdf5", owner="run") as target, target.h5() as f:
        write_root_attributes(f, result.machine, "run")
        write_run_group(f, result)


def write_comparison(comparison, path: str | os.PathLike[str]) -> None:
    """Write a :class:`~camsim.analyses.compare.Comparison` (impact, no-impact, difference) atomically."""
    with writing(path, "hdf5", owner="compare") as target, target.h5() as f:
        write_root_attributes(f, comparison.impact.machine, "compare")
        write_run_group(f.create_group("impact", track_order=True), comparison.impact)
        write_run_group(f.create_group("no_impact", track_order=True), comparison.no_impact)
        diff = f.create_group("difference", track_order=True)
        time = write_time(diff, comparison.time)
        for name, quantities in comparison.difference.items():
            for quantity, data in quantities.items():
                write_trace(diff, f"masses/{name}/{quantity}", data, "%", f"{quantity} of {name}: 100·(impact − no impact)/max|impact|", time)

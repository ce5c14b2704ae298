"""Writing a sweep: the HDF5 table (``/sweep/summary``, units per column) and a CSV beside it."""

from __future__ import annotations

import csv
import math
import os
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

if TYPE_CHECKING:
    from camsim.analyses.sweep.result import SweepResult


def csv_path_for(path: str | os.PathLike[str]) -> Path:
    """The CSV written beside a sweep file: same stem, ``.csv``."""
    return Path(path).with_suffix(".csv")


def csv_cell(value: Any) -> str:
    """One CSV cell of a result table: true/false, integers, floats that read back exactly."""
    if isinstance(value, (bool, np.bool_)):
        return "true" if value else "false"
    if isinstance(value, (int, np.integer)):
        return str(int(value))
    if isinstance(value, (float, np.floating)):
        return repr(float(value))  # round-trips exactly; nan as "nan"
    return str(value)


def write_sweep(result: "SweepResult", path: str | os.PathLike[str], csv_path: str | os.PathLike[str] | None = None,
                units: Any = None) -> tuple[Path, Path]:
    """Write a sweep as HDF5 (``/sweep/summary``) and the same table as CSV, atomically.

    The HDF5 file carries the root attributes of every camsim file (``file_kind`` =
    ``"sweep"``, the machine with its ``--set`` overrides); ``/sweep/summary`` is a
    compound table with a ``units:<column>`` attribute per column and the attributes
    ``jump_onset_rpm`` and ``first_jump_rpm`` (NaN when None). With kept traces, variant
    ``k`` (the row index, from 0) is under ``/sweep/variants/<k>/`` in the run layout.
    The CSV, a table for a person (a spreadsheet), is in the display units ``units`` (a
    :class:`~camsim.display.DisplayUnits`; default the machine file's own, docs/units.md): one
    header line with each column's name and unit (``param:cam.speed [rpm]``,
    ``peak_transducer_force [lbf]``; issue 44: it had no units and the speed in rad/s), the
    values converted (floats written in full; ``nan`` where absent; ``true``/``false``). The
    HDF5 table stays SI.

    Returns
    -------
    (Path, Path)
        The HDF5 and CSV paths.
    """
    from camsim.io.atomic import check_writable
    from camsim.io.hdf5 import write_table
    from camsim.io.outputs import writing
    from camsim.run.runfile import write_root_attributes, write_run_group

    h5_path = Path(path)
    csv_target = csv_path_for(h5_path) if csv_path is None else Path(csv_path)
    check_writable(h5_path)
    check_writable(csv_target)
    nan = float("nan")
    with writing(h5_path, "hdf5", owner="sweep") as target, target.h5() as f:
        write_root_attributes(f, result.machine, "sweep")
        group = f.create_group("sweep", track_order=True)
        group.attrs["varied_keys"] = [name[6:] for name, _ in result.columns if name.startswith("param:")]
        group.attrs["fixed_overrides"] = list(result.fixed_overrides) or [""]
        s = result.settings
        group.attrs["cycles"] = -1 if s.cycles is None else s.cycles
        group.attrs["warmup_cycles"] = -1 if s.warmup_cycles is None else s.warmup_cycles
        group.attrs["sample_rate"] = nan if s.sample_rate is None else float(s.sample_rate)
        group.attrs["interrupted"] = bool(result.stopped)
        group.attrs["incomplete"] = bool(result.incomplete)  # a row did not run: no conclusion drawn
        cols = {name: (result.column(name), unit) for name, unit in result.columns}
        table = write_table(group, "summary", cols)
        table.attrs["jump_onset_rpm"] = nan if result.jump_onset_rpm is None else float(result.jump_onset_rpm)
        table.attrs["first_jump_rpm"] = nan if result.first_jump_rpm is None else float(result.first_jump_rpm)
        if result.jump_bracket_rpm is not None:
            table.attrs["jump_bracket_rpm"] = np.array(result.jump_bracket_rpm, dtype=float)
        if result.runs:
            variants = group.create_group("variants", track_order=True)
            for k, run in enumerate(result.runs):
                if run is None:
                    continue
                g = variants.create_group(str(k), track_order=True)
                g.attrs["overrides"] = list(result.overrides[k])
                write_run_group(g, run)
                target.check()  # a full disk stops here, not after every variant
    shown = units if units is not None else result.machine.display_units
    factors = [shown.shown(unit)[1] if unit else 1.0 for _, unit in result.columns]
    with writing(csv_target, "csv", owner="csv") as target, target.text() as fh:
        writer = csv.writer(fh)
        writer.writerow([shown.header(name, unit) for name, unit in result.columns])
        for row in result.rows:
            writer.writerow([csv_cell(_scaled(row[name], k)) for (name, _), k in zip(result.columns, factors)])
    return h5_path, csv_target


def _scaled(value: Any, factor: float) -> Any:
    """A numeric cell in its display unit; text, flags and counts as they are."""
    if isinstance(value, (float, np.floating)) and factor != 1.0:
        return float(value) * factor
    return value


def jsonable_rows(result: "SweepResult") -> list[dict[str, Any]]:
    """Rows with NaN as None (for ``--json``), each with ``reasons``: why a value is null."""
    from camsim.run.result import missing_reason

    out = []
    for row in result.rows:
        entry = {k: (None if isinstance(v, float) and math.isnan(v) else v) for k, v in row.items()}
        reasons = {}
        for k, v in entry.items():
            if v is None and not k.startswith("param:"):
                reasons[k] = missing_reason(result.machine, k, row) or "not computed"
        entry["reasons"] = reasons
        out.append(entry)
    return out

"""Export result files to CSV, and read those CSV files back.

CSV layout (one header row, then data):

* The header row names each column by its HDF5 path relative to the run layout, with the
  SI unit in brackets: ``time [s],cam/angle [deg],masses/M2/velocity [m/s],...``. A
  numeric column always has brackets (``[]`` when dimensionless); a text column (event
  ``element``, ``kind``, ``masses``) has none. :func:`read_csv` uses exactly this rule.
* Numbers are written with Python's ``repr`` of a float: the shortest text that reads
  back to the same double, so a round trip is exact bit for bit. ``nan`` and ``inf`` are
  written as such.
* ``time`` is always the first column of a trace CSV.

The events table goes to a second CSV with the same header convention.
"""

from __future__ import annotations

import csv
import difflib
import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from camsim.errors import InputError, ResultFileError
from camsim.io.atomic import check_writable
from camsim.io.outputs import writing
from camsim.io.results import file_kind, list_traces, open_h5, read_events, table_units, units_of

#: Groups of a comparison file that hold a time base.
COMPARE_GROUPS = ("impact", "no_impact", "difference")


@dataclass(frozen=True)
class ExportResult:
    """What :func:`export_csv` wrote.

    Attributes
    ----------
    csv : Path
        The traces.
    events_csv : Path or None
        The events table, when written.
    columns : tuple of str
        Column names (HDF5 paths) of the trace CSV, in order.
    rows : int
        Number of samples (data rows) in the trace CSV.
    """

    csv: Path
    events_csv: Path | None
    columns: tuple[str, ...]
    rows: int


def header_cell(name: str, units: str | None) -> str:
    """``name [units]`` for a numeric column, ``name`` for a text column (``units`` None)."""
    return name if units is None else f"{name} [{units}]"


def parse_header_cell(cell: str) -> tuple[str, str | None]:
    """Inverse of :func:`header_cell`: ``"time [s]"`` -> ``("time", "s")``, ``"kind"`` -> ``("kind", None)``."""
    cell = cell.strip()
    if cell.endswith("]") and " [" in cell:
        name, _, units = cell[:-1].rpartition(" [")
        return name, units
    return cell, None


def write_csv(target: str | os.PathLike[str], columns: dict[str, np.ndarray], units: dict[str, str | None]) -> Path:
    """Write equal-length columns to ``target`` atomically in the layout of this module.

    Parameters
    ----------
    columns : dict
        Name -> 1-D array. Float/int/bool columns are written as numbers (``repr``),
        object/str columns as text.
    units : dict
        Name -> unit text for numeric columns, ``None`` for text columns.
    """
    names = list(columns)
    lengths = {len(columns[n]) for n in names}
    if len(lengths) > 1:
        raise ValueError(f"columns of different lengths: {sorted(lengths)}")
    cells = []
    for n in names:
        values = np.asarray(columns[n])
        if units.get(n) is None:
            cells.append([str(v) for v in values])
        else:
            cells.append(values.astype(np.float64).tolist())  # Python floats: csv writes repr()
    with writing(target, "csv", owner="csv") as out, out.text() as fh:
        writer = csv.writer(fh, lineterminator="\r\n")  # RFC 4180; quotes text holding \r or \n
        writer.writerow([header_cell(n, units.get(n)) for n in names])
        writer.writerows(zip(*cells))
    return Path(target)


def read_csv(path: str | os.PathLike[str]) -> tuple[dict[str, np.ndarray], dict[str, str | None]]:
    """Read a CSV written by :func:`export_csv` (or :func:`write_csv`).

    Returns
    -------
    columns : dict
        Name -> array: float64 for numeric columns, object (str) for text columns.
    units : dict
        Name -> unit text, ``None`` for text columns.

    Raises
    ------
    InputError
        If the file is missing, empty, ragged or a numeric cell does not parse.
    """
    p = Path(path)
    try:
        fh = open(p, newline="", encoding="utf-8")
    except OSError as exc:
        raise InputError(f"{p}: cannot be read ({exc.strerror or exc})") from None
    with fh:
        reader = csv.reader(fh)
        try:
            header = next(reader)
        except StopIteration:
            raise InputError(f"{p}: empty file, no header row") from None
        parsed = [parse_header_cell(c) for c in header]
        rows = list(reader)
    names = [n for n, _ in parsed]
    units = dict(parsed)
    if len(set(names)) != len(names):
        raise InputError(f"{p}: header: repeated column names")
    for i, row in enumerate(rows, start=2):
        if len(row) != len(names):
            raise InputError(f"{p}: line {i}: {len(row)} cells, header has {len(names)}")
    out: dict[str, np.ndarray] = {}
    for j, (name, unit) in enumerate(parsed):
        raw = [r[j] for r in rows]
        if unit is None:
            out[name] = np.array(raw, dtype=object)
        else:
            try:
                out[name] = np.array([float(v) for v in raw], dtype=np.float64)
            except ValueError:
                raise InputError(f"{p}: column {name}: a cell is not a number") from None
    return out, units


def default_csv_path(path: str | os.PathLike[str], group: str | None = None) -> Path:
    """``<input stem>.csv`` next to the input (``<stem>_<group>.csv`` for a comparison group)."""
    p = Path(path)
    return p.with_name(f"{p.stem}_{group}.csv" if group else f"{p.stem}.csv")


def default_events_path(csv_path: str | os.PathLike[str]) -> Path:
    """``<csv stem>_events.csv`` next to the trace CSV."""
    p = Path(csv_path)
    return p.with_name(f"{p.stem}_events.csv")


def _in_display(columns: dict[str, np.ndarray], units: dict[str, str | None], display) -> tuple[dict, dict]:
    """The numeric columns in ``display``'s units (text columns and times unchanged)."""
    out, out_units = {}, {}
    for name, values in columns.items():
        unit = units.get(name)
        if unit is None or values.dtype.kind in "OSU":
            out[name], out_units[name] = values, unit
            continue
        shown, k = display.shown(unit)
        out[name], out_units[name] = (values * k if k != 1.0 else values), shown
    return out, out_units


def export_csv(
    path: str | os.PathLike[str],
    out: str | os.PathLike[str] | None = None,
    columns: list[str] | None = None,
    events_csv: str | os.PathLike[str] | None = None,
    events: bool = True,
    group: str | None = None,
    units: str | None = None,
) -> ExportResult:
    """Export the traces (and the events table) of a run layout to CSV.

    Parameters
    ----------
    path : path
        A run file, or a comparison file together with ``group``.
    out : path, optional
        The trace CSV (default ``<input stem>.csv`` next to the input).
    columns : list of str, optional
        Trace paths to write (``masses/M2/velocity``; a leading ``/`` is ignored);
        ``time`` is always the first column. Default: every trace on the time base.
    events_csv : path, optional
        Where to write the events (default ``<out stem>_events.csv``). Asking for it
        explicitly on a file without events is an error.
    events : bool
        Write the events CSV at all.
    group : str, optional
        For a comparison file: ``impact``, ``no_impact`` or ``difference``.
    units : str, optional
        ``file``, ``si`` or ``us``: every column in those display units (issue 36; ``file``:
        the result's machine file's, recorded in the file), the header naming them. Default:
        the SI values as stored, to the last bit.

    Raises
    ------
    InputError, ResultFileError
        Unknown column, wrong file kind, unwritable output; nothing is written then.
    """
    system = units
    with open_h5(path) as f:
        kind = file_kind(f)
        if kind == "compare":
            if group is None:
                raise ResultFileError(
                    f"{f.filename}: a comparison file holds several runs: choose one with --group "
                    f"({', '.join(COMPARE_GROUPS)})"
                )
            if group not in COMPARE_GROUPS or group not in f:
                raise InputError(f"{f.filename}: --group {group}: not in the file (one of {', '.join(COMPARE_GROUPS)})")
            root = f[group]
        elif group is not None:
            raise InputError(f"{f.filename}: --group {group}: only comparison files have groups (this is a {kind} file)")
        elif kind != "run":
            raise ResultFileError(f"{f.filename}: export writes the traces of a run; this is a {kind} file")
        else:
            root = f
        traces = list_traces(root)
        if not traces:
            raise ResultFileError(f"{f.filename}: {root.name}: no time base (no /time dataset)")
        if columns:
            chosen = ["time"]
            for c in columns:
                key = c.strip().lstrip("/")
                if key not in traces:
                    close = difflib.get_close_matches(key, list(traces), n=1)
                    hint = f"; did you mean {close[0]}?" if close else ""
                    raise InputError(f"{f.filename}: --columns {c}: no such trace{hint}")
                if key not in chosen:
                    chosen.append(key)
        else:
            chosen = list(traces)
        table = read_events(root) if events else None
        if events_csv is not None and table is None:
            raise InputError(f"{f.filename}: --events-csv: the file has no events table")
        target = Path(out) if out is not None else default_csv_path(path, group)
        ev_target = None
        if table is not None:
            ev_target = Path(events_csv) if events_csv is not None else default_events_path(target)
            if ev_target.resolve() == target.resolve():
                raise InputError(f"{ev_target}: the events CSV would overwrite the trace CSV")
        from camsim.io.outputs import CSV, check_output, output_format

        check_output(target, output_format(target, CSV), owner="csv", inputs=[("result file", path)])
        if ev_target is not None:
            check_output(ev_target, output_format(ev_target, CSV, "--events-csv"), owner="csv",
                         inputs=[("result file", path)], option="--events-csv")
        data = {c: traces[c][()] for c in chosen}
        units: dict[str, str | None] = {c: units_of(traces[c]) for c in chosen}
        ev_units: dict[str, str | None] = {}
        if table is not None:
            col_units = table_units(root["events"])
            ev_units = {c: (None if table[c].dtype.kind in "OSU" else col_units.get(c, "")) for c in table}
        if system is not None:
            from camsim.io.results import file_display_units

            display = file_display_units(f, system)
            data, units = _in_display(data, units, display)
            if table is not None:
                table, ev_units = _in_display(table, ev_units, display)
    write_csv(target, data, units)
    if table is not None and ev_target is not None:
        write_csv(ev_target, table, ev_units)
    rows = len(data["time"])
    return ExportResult(csv=target, events_csv=ev_target, columns=tuple(chosen), rows=rows)

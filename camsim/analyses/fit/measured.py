"""Measured traces for ``camsim fit``: reading the CSV and naming the result paths.

The measured file is a CSV with one header line. The first column is time, written
``time [s]`` (any time unit in the brackets: ``time [ms]``); every other column is a
result path of the run layout (``docs/results.md``) with its unit in brackets, e.g.
``transducer/force [lbf]``, ``masses/M3/acceleration [m/s^2]``,
``elements/K23/force [kN]``, ``cam_contact/force [N]``. Values are converted with the
one pint registry (:mod:`camsim.units`) to the SI unit of the path (the unit the HDF5
result stores), so everything after this module is SI.

Every problem is an :class:`~camsim.errors.InputError` of one line naming the file and
the column (or row): an unknown path, a unit of the wrong dimension, a cell that is not
a number, a NaN or empty cell (unless ``drop_nan``), times that do not increase.
"""

from __future__ import annotations

import csv
import math
import os
import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from camsim.errors import InputError

__all__ = ["Channel", "Measured", "read_measured", "result_paths", "trace"]

#: SI unit (as stored in the HDF5 result) of each quantity of a path's last part.
_QUANTITY_UNITS = {
    "displacement": "m",
    "velocity": "m/s",
    "acceleration": "m/s^2",
    "jerk": "m/s^3",
    "force": "N",
    "angle": "deg",
}

_HEADER = re.compile(r"^\s*(?P<name>[^\[\]]*?)\s*\[(?P<unit>[^\[\]]*)\]\s*$")


@dataclass(frozen=True)
class Channel:
    """One measured column.

    Attributes
    ----------
    path : str
        Result path, e.g. ``transducer/force``.
    unit : str
        SI unit of the values (the unit of the path in a result file).
    written_unit : str
        The unit the CSV header gave.
    time : ndarray
        Sample times [s] on the measured time base (after ``drop_nan``, this
        channel's own valid samples).
    values : ndarray
        Samples in ``unit``.
    column : int
        1-based column number in the file (for messages).
    """

    path: str
    unit: str
    written_unit: str
    time: np.ndarray
    values: np.ndarray
    column: int


@dataclass(frozen=True)
class Measured:
    """The measured traces of one CSV file.

    Attributes
    ----------
    source : str
        The file name as given.
    time_header : str
        The first column's header (for messages).
    channels : tuple of Channel
    dropped : int
        Cells left out by ``drop_nan`` (0 otherwise).
    """

    source: str
    time_header: str
    channels: tuple[Channel, ...]
    dropped: int = 0

    @property
    def t_min(self) -> float:
        """Earliest sample time of any channel [s]."""
        return min(float(c.time[0]) for c in self.channels)

    @property
    def t_max(self) -> float:
        """Latest sample time of any channel [s]."""
        return max(float(c.time[-1]) for c in self.channels)


def result_paths(machine) -> dict[str, str]:
    """Every trace path a run of ``machine`` has, with its SI unit (the HDF5 ``units``).

    Parameters
    ----------
    machine : Machine

    Returns
    -------
    dict
        path → unit, e.g. ``{"cam/displacement": "m", "masses/M3/acceleration": "m/s^2",
        "elements/seat/force": "N", "transducer/force": "N", ...}``.
    """
    paths: dict[str, str] = {}
    for q in ("angle", "displacement", "velocity", "acceleration", "jerk"):
        paths[f"cam/{q}"] = _QUANTITY_UNITS[q]
    for m in machine.masses:
        for q in ("displacement", "velocity", "acceleration"):
            paths[f"masses/{m.name}/{q}"] = _QUANTITY_UNITS[q]
    for e in machine.elements:
        paths[f"elements/{e.name}/force"] = "N"
    if machine.cam is not None and machine.cam.drives:
        paths["cam_contact/force"] = "N"
    if any(getattr(e, "transducer", False) for e in machine.elements):
        paths["transducer/force"] = "N"
    return paths


def trace(result, path: str) -> np.ndarray:
    """The SI samples of result path ``path`` of a :class:`~camsim.run.result.RunResult`."""
    return np.asarray(result.trace(path), dtype=float)


def _convert(values: np.ndarray, unit: str, target: str) -> np.ndarray:
    from camsim.units import ureg

    return np.asarray(ureg.Quantity(values, unit).to(target).magnitude, dtype=float)


def _check_unit(unit: str, target: str, where: str, what: str) -> None:
    import pint

    from camsim.units import ureg

    if re.search(r"(?<![A-Za-z_])mils?(?![A-Za-z_])", unit):
        raise InputError(f'{where}: "mil" is ambiguous (pint reads it as an angle); write "thou"')
    try:
        q = ureg.Quantity(1.0, unit) if unit.strip() else ureg.Quantity(1.0)
    except Exception:  # pint raises several unrelated types for unparsable text
        raise InputError(f"{where}: '{unit}' is not a unit") from None
    try:
        q.to(target)
    except pint.DimensionalityError:
        raise InputError(f"{where}: unit '{unit}' cannot be converted to {target} ({what})") from None


def read_measured(path: str | os.PathLike[str], paths: dict[str, str], drop_nan: bool = False) -> Measured:
    """Read a measured-trace CSV and convert it to SI.

    Parameters
    ----------
    path : path
        The CSV file.
    paths : dict
        Result paths the machine offers, with their SI units (:func:`result_paths`).
    drop_nan : bool
        Leave out NaN or empty cells (each channel keeps its own valid samples; a row
        whose time is missing is dropped). Without it such a cell is an error.

    Returns
    -------
    Measured

    Raises
    ------
    InputError
        One line naming the file and the column or row: no such file, no data, a first
        column that is not ``time [unit]``, a header without ``[unit]``, an unknown
        result path, a path given twice, a unit of the wrong dimension, a cell that is
        not a number, a NaN or empty cell, times that do not strictly increase.
    """
    source = str(path)
    try:
        with open(path, newline="", encoding="utf-8") as fh:
            rows = [r for r in csv.reader(fh) if r and any(c.strip() for c in r)]
    except FileNotFoundError:
        raise InputError(f"{source}: no such measured-data file") from None
    except IsADirectoryError:
        raise InputError(f"{source}: is a directory, not a CSV file") from None
    except UnicodeDecodeError as exc:
        raise InputError(f"{source}: not UTF-8 text ({exc.reason} at byte {exc.start})") from None
    except csv.Error as exc:
        raise InputError(f"{source}: not a readable CSV file ({exc})") from None
    except OSError as exc:
        raise InputError(f"{source}: cannot read ({exc.strerror or exc})") from None
    if not rows:
        raise InputError(f"{source}: empty file (expected a header 'time [s],<path> [unit],...' and data rows)")
    header, data = [h.strip() for h in rows[0]], rows[1:]
    if len(header) < 2:
        raise InputError(f"{source}: the header has {len(header)} column; expected time and at least one measured path")
    parsed = []
    for j, h in enumerate(header):
        where = f"{source}: column {j + 1} '{h}'"
        m = _HEADER.match(h)
        if not m:
            raise InputError(f"{where}: expected 'NAME [UNIT]', e.g. 'transducer/force [lbf]'")
        parsed.append((m.group("name").strip(), m.group("unit").strip()))
    time_name, time_unit = parsed[0]
    if time_name != "time":
        raise InputError(f"{source}: column 1 '{header[0]}': the first column must be time, e.g. 'time [s]'")
    _check_unit(time_unit, "s", f"{source}: column 1 '{header[0]}'", "a time")
    seen: dict[str, int] = {}
    for j, (name, unit) in enumerate(parsed[1:], start=2):
        where = f"{source}: column {j} '{header[j - 1]}'"
        if name not in paths:
            known = ", ".join(sorted(paths))
            raise InputError(f"{where}: unknown result path '{name}' for this machine (known: {known})")
        if name in seen:
            raise InputError(f"{where}: path '{name}' is also column {seen[name]}")
        seen[name] = j
        _check_unit(unit, paths[name], where, f"the unit of {name}")
    if not data:
        raise InputError(f"{source}: no data rows after the header")
    table = np.empty((len(data), len(header)))
    for i, row in enumerate(data):
        line = i + 2
        if len(row) != len(header):
            raise InputError(f"{source}: line {line}: {len(row)} cells, the header has {len(header)}")
        for j, cell in enumerate(row):
            text = cell.strip()
            if not text:
                table[i, j] = math.nan
                continue
            try:
                table[i, j] = float(text)
            except ValueError:
                raise InputError(f"{source}: line {line}, column {j + 1} '{header[j]}': '{text}' is not a number") from None
            if math.isinf(table[i, j]):
                raise InputError(f"{source}: line {line}, column {j + 1} '{header[j]}': infinite value")
    dropped = 0
    bad = np.isnan(table)
    if bad.any() and not drop_nan:
        i, j = map(int, np.argwhere(bad)[0])
        raise InputError(
            f"{source}: line {i + 2}, column {j + 1} '{header[j]}': missing or NaN value "
            "(pass --drop-nan to leave such cells out)"
        )
    keep_rows = ~bad[:, 0]
    dropped += int(np.count_nonzero(~keep_rows)) * (len(header) - 1)
    table = table[keep_rows]
    lines = np.flatnonzero(keep_rows) + 2
    if table.shape[0] == 0:
        raise InputError(f"{source}: column 1 '{header[0]}': no valid times")
    t = _convert(table[:, 0], time_unit, "s")
    steps = np.diff(t)
    if np.any(steps <= 0):
        k = int(np.flatnonzero(steps <= 0)[0])
        what = "duplicate time" if steps[k] == 0 else "time goes backwards"
        raise InputError(
            f"{source}: column 1 '{header[0]}': {what} at line {lines[k + 1]} "
            f"({table[k + 1, 0]:g} after {table[k, 0]:g}); times must strictly increase"
        )
    channels = []
    for j, (name, unit) in enumerate(parsed[1:], start=1):
        ok = ~np.isnan(table[:, j])
        dropped += int(np.count_nonzero(~ok))
        if np.count_nonzero(ok) < 3:
            raise InputError(f"{source}: column {j + 1} '{header[j]}': fewer than 3 valid samples")
        channels.append(
            Channel(
                path=name,
                unit=paths[name],
                written_unit=unit,
                time=t[ok],
                values=_convert(table[ok, j], unit, paths[name]),
                column=j + 1,
            )
        )
    return Measured(source=source, time_header=header[0], channels=tuple(channels), dropped=dropped)


def write_measured(path: str | os.PathLike[str], time: np.ndarray, columns: dict[str, tuple[np.ndarray, str]], time_unit: str = "s") -> Path:
    """Write a measured-trace CSV (the format :func:`read_measured` reads), atomically.

    Parameters
    ----------
    path : path
    time : ndarray
        Sample times in ``time_unit``.
    columns : dict
        path → (values, unit), written as ``path [unit]``.
    time_unit : str

    Returns
    -------
    Path
    """
    from camsim.io.outputs import writing

    target = Path(path)
    with writing(target, "csv", owner="csv") as out, out.text() as fh:
        w = csv.writer(fh, lineterminator="\n")
        w.writerow([f"time [{time_unit}]"] + [f"{p} [{u}]" for p, (_, u) in columns.items()])
        arrays = [np.asarray(v, dtype=float) for v, _ in columns.values()]
        for i, ti in enumerate(np.asarray(time, dtype=float)):
            w.writerow([repr(float(ti))] + [repr(float(a[i])) for a in arrays])
    return target

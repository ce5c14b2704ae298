"""Reading force-deflection samples (a CSV with units in its header) for ``camsim impact fit``."""

from __future__ import annotations

import csv
import re
from dataclasses import dataclass
from pathlib import Path

from camsim.errors import InputError
from camsim.units import QuantityError, to_si

_HEADER = re.compile(r"^\s*(?P<name>[A-Za-z_ ]*?)\s*\[(?P<unit>[^\]]*)\]\s*$")


@dataclass(frozen=True)
class ForceDeflectionData:
    """Samples read by :func:`read_force_deflection_csv`, in SI.

    Attributes
    ----------
    deflection : list of float
        Deflections [m].
    force : list of float
        Forces [N].
    deflection_unit, force_unit : str
        The units written in the file's header.
    lines : list of int
        The file line of each sample (for messages).
    """

    deflection: list[float]
    force: list[float]
    deflection_unit: str
    force_unit: str
    lines: list[int]


def read_force_deflection_csv(path: str | Path) -> ForceDeflectionData:
    """Read a force-deflection CSV with units in its header, e.g. ``deflection [in],force [lbf]``.

    Parameters
    ----------
    path : str or Path
        The CSV file: a header naming a ``deflection`` and a ``force`` column, each with
        its unit in brackets, then one sample per line.

    Returns
    -------
    ForceDeflectionData
        Deflections [m], forces [N], the units of the file and the line of each sample.

    Raises
    ------
    InputError
        ``file: header: ...`` or ``file: line N: ...`` for a file that cannot be read.
    """
    name = str(path)
    try:
        with open(path, newline="", encoding="utf-8") as handle:
            reader = csv.reader(handle)
            rows = []
            lines = []
            for row in reader:
                if row and any(cell.strip() for cell in row):
                    rows.append(row)
                    lines.append(reader.line_num)
    except OSError as exc:
        raise InputError(f"{name}: cannot read: {exc.strerror}") from None
    except UnicodeDecodeError:
        raise InputError(f"{name}: not a text CSV file") from None
    if not rows:
        raise InputError(f"{name}: empty file")
    columns: dict[str, tuple[int, str]] = {}
    for index, cell in enumerate(rows[0]):
        match = _HEADER.match(cell)
        label = (match.group("name") if match else cell).strip().lower()
        if label in ("deflection", "force"):
            if not match:
                raise InputError(
                    f'{name}: header: column "{cell.strip()}" needs its unit in brackets, '
                    f'e.g. "{label} [{"in" if label == "deflection" else "lbf"}]"'
                )
            columns[label] = (index, match.group("unit").strip())
    for label, example in (("deflection", "deflection [in]"), ("force", "force [lbf]")):
        if label not in columns:
            raise InputError(f'{name}: header: no "{label}" column (expected e.g. "{example}")')
    scale = {}
    for label, dimension in (("deflection", "length"), ("force", "force")):
        unit = columns[label][1]
        try:
            scale[label] = to_si(f"1 {unit}", dimension)
        except QuantityError as exc:
            raise InputError(f"{name}: header: {label} unit: {exc}") from None
    deflection: list[float] = []
    force: list[float] = []
    for line_number, row in zip(lines[1:], rows[1:]):
        values = {}
        for label in ("deflection", "force"):
            index = columns[label][0]
            if index >= len(row):
                raise InputError(f"{name}: line {line_number}: no {label} value")
            try:
                values[label] = float(row[index])
            except ValueError:
                raise InputError(
                    f'{name}: line {line_number}: {label}: expected a number, got "{row[index].strip()}"'
                ) from None
        deflection.append(values["deflection"] * scale["deflection"])
        force.append(values["force"] * scale["force"])
    return ForceDeflectionData(deflection, force, columns["deflection"][1], columns["force"][1], lines[1:])

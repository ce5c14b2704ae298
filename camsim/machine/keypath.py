"""The framework of the key-path grammar: parts, table kinds, their registry, the bare-number note.

:mod:`camsim.machine.keys` registers the machine file's tables on it and offers the entry
points; this module holds what every table kind shares (issue 44): the parts of a path
(``cam.segments[2].lift`` → ``[("cam", None), ("segments", 2), ("lift", None)]``), the
:class:`TableKind` protocol and :data:`KINDS`, where a path lands (:class:`Address`), and the
one warning that a bare number was read as SI (:func:`bare_number_note`).
"""

from __future__ import annotations

import math
import re
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass
from typing import Any, ClassVar

from camsim.elements import Param
from camsim.errors import MachineFileError
from camsim.machine.reading import _suggest

__all__ = ["Address", "KINDS", "Part", "TableKind", "bare_number_note", "is_bare_number", "parse", "register", "try_parse"]

Part = tuple[str, "int | None"]

_PART = re.compile(r"^([A-Za-z_][\w\-]*)(?:\[(\d+)\])?$")


def try_parse(key: str) -> list[Part] | None:
    """The parts of ``key`` (``cam.segments[2].lift`` → ``[("cam", None), ("segments", 2), ("lift", None)]``),
    or None when it is not a key path."""
    matches = [_PART.match(p.strip()) for p in key.split(".")]
    if not key.strip() or not all(matches):
        return None
    return [(m.group(1), None if m.group(2) is None else int(m.group(2))) for m in matches]


def parse(key: str, source: str = "<string>") -> list[Part]:
    """:func:`try_parse`, raising :class:`MachineFileError` for a malformed key."""
    parts = try_parse(key)
    if parts is None:
        raise MachineFileError(source, key, "malformed override key (write e.g. cam.segments[2].lift)")
    return parts


@dataclass
class Address:
    """Where a key path lands in a parsed document.

    Attributes
    ----------
    table : dict
        The table that holds the value (a TOML table, an array-of-tables row or an inline
        table), created when the document had none.
    leaf : str
        The key inside it.
    path : str
        The canonical path, as error messages name it (``element[2].stiffness``).
    """

    table: Any
    leaf: str
    path: str

    def set(self, value: Any) -> str:
        self.table[self.leaf] = value
        return self.path


#: ``make_table(super_table)`` → a new empty table for the document (a dict; tomlkit tables
#: for a document edited in place).
TableFactory = Callable[[bool], Any]


def _dict_table(super_table: bool = False) -> dict:
    return {}


@dataclass
class _Context:
    doc: Any
    key: str
    source: str
    make_table: TableFactory

    def error(self, message: str, key: str | None = None) -> MachineFileError:
        return MachineFileError(self.source, self.key if key is None else key, message)

    def unknown(self, valid: Sequence[str], word: str) -> MachineFileError:
        return self.error(f"unknown key; {_suggest(word, valid)}")

    def table(self, parent: Any, name: str, where: str | None = None, super_table: bool = False) -> Any:
        if name not in parent:
            parent[name] = self.make_table(super_table)
        table = parent[name]
        if not isinstance(table, dict):
            raise self.error("expected a table", where or name)
        return table


def _named_rows(rows: Any) -> dict[str, dict]:
    if not isinstance(rows, list):
        return {}
    return {r["name"]: r for r in rows if isinstance(r, dict) and isinstance(r.get("name"), str)}


def _find(params: Iterable[Param], leaf: str) -> Param | None:
    return next((p for p in params if p.key == leaf), None)


class TableKind:
    """One table of the machine file as key paths address it (subclass and :func:`register`).

    ``head`` is the first part of its paths; ``example`` a path shown when one is incomplete.
    """

    head: ClassVar[str]
    example: ClassVar[str]

    def address(self, ctx: _Context, parts: list[Part]) -> Address:
        """The table and leaf ``parts`` land on in ``ctx.doc`` (tables made when missing)."""
        raise NotImplementedError

    def param(self, parts: list[Part]) -> Param | None:
        """The schema key ``parts`` name (its dimension and SI unit), or None."""
        raise NotImplementedError

    def value(self, machine: Mapping[str, Any], parts: list[Part]) -> Any:
        """The SI value ``parts`` name in :func:`camsim.machine.loader.machine_to_dict`'s description."""
        raise NotImplementedError

    def paths(self, doc: Mapping[str, Any]) -> list[str]:
        """Every path of this table a document offers (keys left at their defaults too)."""
        raise NotImplementedError


#: head → table kind; :func:`register` adds one.
KINDS: dict[str, TableKind] = {}


def register(kind: type[TableKind]) -> type[TableKind]:
    """Class decorator: the table kind answers for paths starting with ``kind.head``."""
    KINDS[kind.head] = kind()
    return kind


# ---------------------------------------------------------------------- bare numbers
_NUMBER_FIRST = re.compile(r"\s*[-+]?(?:\d|\.\d)")
_BARE = re.compile(r"^\s*[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?\s*$")
#: Dimensions whose bare numbers need no warning: shown the same in every system (times,
#: frequencies), read as degrees (angles, documented), or numbers.
_SAME_EVERYWHERE = ("time", "frequency", "angle", "dimensionless", "number", "integer", "bool", "string", "choice")


def is_bare_number(value: Any) -> bool:
    """True for a number without a unit: ``120``, ``1.5e6`` or the string ``"120"``."""
    if isinstance(value, bool):
        return False
    if isinstance(value, (int, float)):
        return math.isfinite(float(value))
    return isinstance(value, str) and bool(_BARE.match(value))


def bare_number_note(key: str, value: Any, si_unit: str, shown: Any, written: str = "") -> str | None:
    """The one warning that a bare number was read as SI, with its value in the units shown.

    ``cam.speed = 120 → 120 rad/s = 1146 rpm (a bare number is read as SI; write the unit:
    "120 rpm" if you meant rpm)``.

    Parameters
    ----------
    key : str
        What the user wrote it for: a key path (``cam.speed``), an option and its key
        (``--vary cam.speed``) or an option (``--mass``).
    value : object or sequence
        The value as written (a number, or a string that is one); a sequence of them for
        an option that gives several (a ``--vary`` range: its first and last are shown).
    si_unit : str
        The SI unit it is read in (``"rad/s"``, ``"N/m"``); ``""`` for a number: no note.
    shown : DisplayUnits
        The units the file (or command) shows values in.
    written : str
        How the value was written, when not ``value`` itself (``60:600:10`` of a range).

    Returns
    -------
    str or None
        None when ``value`` is not a bare number, is zero (zero in every unit), or
        ``si_unit`` reads the same in every system (times, frequencies; a bare angle is
        degrees, not SI).
    """
    from camsim.display.units import si_dimension, typographic

    values = list(value) if isinstance(value, (list, tuple)) else [value]
    if not si_unit or not values or not all(is_bare_number(v) for v in values) \
            or all(float(v) == 0.0 for v in values):
        return None
    found = si_dimension(si_unit)
    if found is None or found[0] == "angle":
        return None
    numbers = [float(values[0]), float(values[-1])] if len(values) > 1 else [float(values[0])]
    unit, factor = shown.shown(si_unit)
    text = (written or " ".join(v if isinstance(v, str) else f"{v:g}" for v in values)).strip()
    si_text = typographic(si_unit)

    def span(scale: float, fmt: str) -> str:
        return " to ".join(format(n * scale, fmt) for n in numbers)

    read = f"{span(1.0, 'g')} {si_text}" + ("" if (unit == si_text and factor == 1.0) else f" = {span(factor, '.4g')} {unit}")
    sep = " " if key.startswith("-") and " " not in key else " = "
    advice = "write the unit" if (unit == si_text and factor == 1.0) else f'write the unit: "{text} {unit}" if you meant {unit}'
    return f'{key}{sep}{text} → {read} (a bare number is read as SI; {advice})'

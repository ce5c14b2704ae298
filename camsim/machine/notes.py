"""The bare-number notes of a machine document and of command-line values (issue 44).

A bare number where a key has a unit is SI by the file format; each one is said in one line
with its value in the file's units (:func:`camsim.machine.keys.bare_number_note`). This module
walks a document's values (:func:`value_notes`) and a command line's (:func:`option_notes`)
for them. An analysis loads one file with other overrides for every run: the file's own rows
are computed once per text by the loader and only the overridden values are looked at again
(:func:`document_notes`, issue 42).
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping, Sequence
from typing import Any

from camsim.errors import MachineFileError
from camsim.machine.keypath import _NUMBER_FIRST, _SAME_EVERYWHERE
from camsim.machine.keys import _Absent, _no_table, address, bare_number_note, \
    document_paths, is_bare_number, param, unit

__all__ = ["bare_number_notes", "document_notes", "notes_of", "option_notes", "value_notes", "writes_unit"]


def option_notes(option: str, axes: Iterable[tuple[str, Sequence[str]]], shown: Any,
                 written: Mapping[str, str] | None = None) -> list[str]:
    """The bare-number warnings of command-line values: one per key whose values are bare numbers.

    ``axes``: (key path, value texts) as an option gave them (``--vary cam.speed=60:600:10``
    gives ``("cam.speed", ["60", "70", …, "600"])``); ``written``: key → the text as written.
    """
    notes = []
    for key, texts in axes:
        note = bare_number_note(f"{option} {key}", list(texts), unit(key), shown, (written or {}).get(key, ""))
        if note:
            notes.append(note)
    return notes


def bare_number_notes(doc: Mapping[str, Any], shown: Any, skip: Iterable[str] = ()) -> list[str]:
    """The bare-number warnings of a document that otherwise writes units: one per key.

    A document that writes no unit at all (every value SI by the file format) gets none; nor
    does a bare 0 (zero in every unit), an angle (a bare angle is degrees) or a time or
    frequency (shown the same in every system). ``skip``: canonical paths not to report
    (the values ``--set`` wrote: their own note says so).
    """
    return notes_of(value_notes(doc, shown), skip)


def notes_of(rows: Sequence[tuple[str, bool, str | None]], skip: Iterable[str] = ()) -> list[str]:
    """:func:`bare_number_notes` from the rows of :func:`value_notes`: none where no value
    writes a unit, else each note whose canonical path is not in ``skip``."""
    skip = set(skip)
    if not any(writes for _, writes, _ in rows):
        return []
    return [note for path, _, note in rows if note and path not in skip]


def value_notes(doc: Mapping[str, Any], shown: Any) -> list[tuple[str, bool, str | None]]:
    """Per value of the document, in its order: (canonical path, whether it is written with a
    unit, its bare-number note or None)."""
    rows: list[tuple[str, bool, str | None]] = []
    for path in document_paths(doc):
        p = param(path)
        try:
            where = address(doc, path, make_table=_no_table)
        except (MachineFileError, _Absent):
            continue
        value = where.table.get(where.leaf) if isinstance(where.table, dict) else None
        if value is None:
            continue
        note = None
        if p is not None and p.dimension not in _SAME_EVERYWHERE and p.unit and p.unit != "N/m^exponent":
            note = bare_number_note(path, value, p.unit, shown) or None
        rows.append((where.path, writes_unit(value), note))
    return rows


def writes_unit(value: Any) -> bool:
    """Whether a document value is a quantity written with its unit (``"28.12 lbf"``)."""
    from camsim.machine.reading import _has_unit

    return isinstance(value, str) and bool(_NUMBER_FIRST.match(value)) and not is_bare_number(value) and _has_unit(value)


def document_notes(doc: dict, base: Mapping[str, Any], rows: Sequence[tuple[str, bool, str | None]], origin: Iterable[str],
                   shown: Any) -> list[str]:
    """:func:`bare_number_notes` of ``doc`` with the ``origin`` paths skipped (the values the
    command line wrote), from ``rows``, the :func:`value_notes` of ``base`` (the file's own
    document, which ``doc`` is with overrides): the rows of the values no override wrote are
    the file's, and whether the document writes units at all takes the overridden values as
    they now are. An override that is not a plain value of the file (a table, a list, a key
    the file leaves out) walks ``doc`` as it is."""
    origin = list(origin)
    values = {path for path, _, _ in rows}
    now = {}
    for path in origin:
        if path not in values:
            return bare_number_notes(doc, shown, skip=origin)
        try:
            before = address(base, path, make_table=_no_table)
            after = address(doc, path, make_table=_no_table)
        except (MachineFileError, _Absent):
            return bare_number_notes(doc, shown, skip=origin)
        old, new = before.table.get(before.leaf), after.table.get(after.leaf)
        if isinstance(old, (dict, list)) or isinstance(new, (dict, list)):
            return bare_number_notes(doc, shown, skip=origin)
        now[path] = writes_unit(new)
    return notes_of([(path, now.get(path, writes), note) for path, writes, note in rows], skip=origin)

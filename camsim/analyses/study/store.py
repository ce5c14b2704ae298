"""Crash-safe rows of a study: :class:`camsim.io.rowstore.RowStore`, or memory without a file.

With an output file the study keeps its rows in the project's row store: a journal
``<output>.journal`` (one fsync'ed line per finished run) and ``<output>`` itself as an
HDF5 view of the finished rows (``/study/rows``, readable while the study runs), which the
final file replaces when every run is done. Without an output file the rows stay in
memory (:class:`MemoryRowStore`, the same interface).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from camsim.errors import InputError

__all__ = ["MemoryRowStore", "open_store"]


def open_store(output: Path, columns: list[tuple[str, str]], meta: dict, machine: Any, resume: bool):
    """The RowStore of a study writing ``output`` (created, or resumed with a meta check)."""
    from camsim.io.rowstore import RowStore
    from camsim.io.hdf5 import write_root_attributes

    def decorate(f) -> None:
        write_root_attributes(f, machine, "study")
        f.create_group("study", track_order=True).attrs["interrupted"] = True

    kwargs = {"table": "study/rows", "decorate": decorate}
    if not resume:
        return RowStore.create(output, columns, meta, **kwargs)
    from camsim.io.rowstore import journal_path_for

    if not journal_path_for(output).exists():
        raise InputError(f"--resume: no interrupted study to continue ({journal_path_for(output)} does not exist)")
    store = RowStore.resume(output, meta, **kwargs)
    if store.columns != [tuple(c) for c in columns]:
        store.close()
        raise InputError(f"{store.journal}: cannot resume: the stored columns differ from this study's")
    return store


class MemoryRowStore:
    """The RowStore interface in memory: a study without an output file."""

    def __init__(self, columns, meta):
        self.columns, self.meta, self._rows = list(columns), meta, {}

    @classmethod
    def create(cls, path, columns, meta) -> MemoryRowStore:
        return cls(columns, meta)

    def done(self) -> set[int]:
        return set(self._rows)

    def append(self, index: int, row: dict) -> None:
        self._rows[int(index)] = dict(row)

    def rows(self) -> dict[int, dict]:
        return dict(self._rows)

    def close(self, complete: bool = False) -> None:
        pass

    def remove_journal(self) -> None:
        pass

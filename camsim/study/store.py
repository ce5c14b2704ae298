"""Crash-safe rows of a study: the shared ``camsim.io.rowstore.RowStore``, or a stand-in.

The project's row mechanism (``camsim/io/rowstore.py``, issue 16) is used when it is
installed. Until then :class:`JsonLinesRowStore` implements the same interface: one JSON
line per finished run, flushed and ``fsync``-ed before :meth:`append` returns, so a
SIGKILL loses at most the line being written (a torn last line is dropped on resume).
Floats are written with ``repr`` (JSON), so they read back bit for bit.
"""

from __future__ import annotations

import json
import os
from pathlib import Path
from typing import Any

from camsim.errors import InputError

__all__ = ["RowStore", "JsonLinesRowStore", "MemoryRowStore", "store_path"]


def store_path(output: str | os.PathLike[str]) -> Path:
    """Where the rows of a study writing ``output`` are kept while it runs."""
    p = Path(output)
    return p.with_name(p.name + ".rows")


class JsonLinesRowStore:
    """Append-only table of finished runs in a JSON-lines file (RowStore interface)."""

    def __init__(self, path: Path, meta: dict, columns: list, rows: dict[int, dict], fh):
        self.path = path
        self.meta = meta
        self.columns = columns
        self._rows = rows
        self._fh = fh

    @classmethod
    def create(cls, path, columns: list[tuple[str, str]], meta: dict) -> JsonLinesRowStore:
        """A new, empty store at ``path`` (an existing one is replaced)."""
        path = Path(path)
        fh = open(path, "w", encoding="utf-8")
        fh.write(json.dumps({"meta": meta, "columns": [list(c) for c in columns]}, sort_keys=True) + "\n")
        fh.flush()
        os.fsync(fh.fileno())
        return cls(path, meta, [tuple(c) for c in columns], {}, fh)

    @classmethod
    def resume(cls, path, meta: dict) -> JsonLinesRowStore:
        """Reopen the store at ``path`` for appending; InputError if missing or of another job."""
        path = Path(path)
        if not path.is_file():
            raise InputError(f"--resume: no interrupted study to continue ({path} does not exist)")
        with open(path, "rb") as fh:
            data = fh.read()
        lines = data.split(b"\n")
        try:
            header = json.loads(lines[0])
        except (json.JSONDecodeError, IndexError):
            raise InputError(f"--resume: {path} is not a study's row file") from None
        old = header.get("meta", {})
        if old != meta:
            diff = sorted(k for k in set(old) | set(meta) if old.get(k) != meta.get(k))
            raise InputError(f"--resume: {path} belongs to a different study (differs in: {', '.join(diff)})")
        rows: dict[int, dict] = {}
        good = len(lines[0]) + 1
        for line in lines[1:]:
            if not line.endswith(b"}"):
                break  # the torn line of a killed append, or the final empty string
            try:
                entry = json.loads(line)
            except json.JSONDecodeError:
                break
            rows[int(entry["i"])] = entry["row"]
            good += len(line) + 1
        fh = open(path, "r+", encoding="utf-8")
        fh.truncate(min(good, len(data)))
        fh.seek(0, os.SEEK_END)
        return cls(path, meta, [tuple(c) for c in header["columns"]], rows, fh)

    def done(self) -> set[int]:
        """Indices already stored."""
        return set(self._rows)

    def append(self, index: int, row: dict[str, Any]) -> None:
        """Store one row; durable on disk when this returns."""
        self._fh.write(json.dumps({"i": int(index), "row": row}, allow_nan=True) + "\n")
        self._fh.flush()
        os.fsync(self._fh.fileno())
        self._rows[int(index)] = row

    def rows(self) -> dict[int, dict]:
        """Everything stored so far."""
        return dict(self._rows)

    def close(self) -> None:
        if self._fh is not None:
            self._fh.close()
            self._fh = None

    def remove(self) -> None:
        """Close and delete the file (after the study's files are written)."""
        self.close()
        self.path.unlink(missing_ok=True)


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
        self._rows[int(index)] = row

    def rows(self) -> dict[int, dict]:
        return dict(self._rows)

    def close(self) -> None:
        pass

    def remove(self) -> None:
        pass


try:  # the shared mechanism, once it has landed (issue 16)
    from camsim.io.rowstore import RowStore  # type: ignore[import-not-found]
except ModuleNotFoundError as _exc:  # pragma: no cover - depends on the checkout
    if _exc.name != "camsim.io.rowstore":
        raise
    RowStore = JsonLinesRowStore  # type: ignore[misc,assignment]

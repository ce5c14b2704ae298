"""Crash-safe result rows: an append-only journal plus an HDF5 table rewritten atomically.

Sweeps, studies and fits run many independent evaluations for a long time. A
:class:`RowStore` keeps every finished evaluation (a *row*, keyed by an integer index)
so that a job killed by SIGINT, SIGTERM or SIGKILL (an out-of-memory killer, a
preempted cluster job) loses nothing it had finished, and a resumed job runs only the
missing indices.

Design (why not HDF5 SWMR)
--------------------------
Two files, with one job each:

``<path>.journal`` — the truth. A text file opened ``O_APPEND``; one line per row::

    <crc32 of the JSON, 8 hex digits> <JSON>\\n

The first line is a header holding the columns (name, SI unit) and ``meta``.
:meth:`RowStore.append` writes the whole line with one ``write(2)`` and ``fsync(2)``\\s
it before returning, so a row whose ``append`` returned survives SIGKILL (the data is
in the kernel after ``write``) and a power cut (after ``fsync``). A line cut short by a
crash fails its checksum or has no newline; it is ignored when reading and cut off when
the journal is resumed. Floats are written with ``repr`` (JSON), so they read back bit
for bit; NaN and infinities are kept.

``<path>`` — the view: an ordinary HDF5 file (table ``/<table>``, one compound row per
stored index in index order, a ``units:<column>`` attribute per column) rewritten from
the rows in memory into a temporary file that is then renamed over ``<path>``
(``os.replace`` is atomic). A reader (h5py, ``camsim plot``) therefore always opens a
complete, consistent file while the job runs, and a SIGKILL at any moment leaves either
the previous view or the new one. The view is rewritten after an append unless rows
arrive faster than ``view_ratio`` times the time the last rewrite took (default 10: the
rewrite costs at most about a tenth of the job); the rows it skipped are written by the
next rewrite or by :meth:`RowStore.close`, and are in the journal in any case.

HDF5's single-writer/multiple-reader mode was considered and not used: a writer killed
while the file is open leaves the superblock marked "open for writing" (clearing it
needs the ``h5clear`` tool, which h5py does not expose), variable-length strings (the
``status`` column) are not appendable under SWMR, and the appended order (the order in
which parallel workers finish) would make the bytes of the file depend on scheduling.
The view written here is in index order, so the same rows give the same bytes.

Temporary view files carry the writer's process id (``.<name>.<pid>.<random>.tmp``); a
store that opens removes the ones whose process is dead. While a store is open it holds
the output's lock (:mod:`camsim.io.locks`, naming its process id to a second writer)
and an ``flock`` on the journal, so two jobs never write the same journal.

Every file goes through the output policy (:func:`camsim.io.outputs.writing`): the view
and the journal's header line are written atomically; rows are appended with
:func:`camsim.io.atomic.append_record`. When the file system refuses (a full disk), the
row being appended is cut off again, the journal keeps every row stored before, and
:class:`camsim.errors.FileSystemError` says so (exit 1; ``--resume`` continues once there
is space).
"""

from __future__ import annotations

import fcntl
import json
import math
import os
import time
import zlib
from collections.abc import Callable, Iterable, Mapping
from pathlib import Path
from typing import Any

import numpy as np

from camsim.errors import FileSystemError, InputError
from camsim.io import locks
from camsim.io.atomic import append_record, open_journal, remove_stale_temps, temp_path_for

__all__ = ["RowStore", "journal_path_for", "read_rows", "remove_stale_temps", "temp_path_for"]

#: Journal format version (header key ``rowstore``).
FORMAT = 1
#: Name of the index column of the HDF5 view.
INDEX_COLUMN = "index"


def journal_path_for(path: str | os.PathLike[str]) -> Path:
    """The journal kept beside the view ``path``: ``<path>.journal``."""
    p = Path(path)
    return p.with_name(p.name + ".journal")


# --------------------------------------------------------------------------------------
# Journal lines
# --------------------------------------------------------------------------------------
def _encode(record: Mapping[str, Any]) -> bytes:
    text = json.dumps(record, allow_nan=True, separators=(",", ":"), ensure_ascii=True)
    data = text.encode("ascii")
    return b"%08x " % zlib.crc32(data) + data + b"\n"


def _decode(line: bytes) -> dict | None:
    """The record of one journal line, or None when it is cut short or corrupt."""
    if not line.endswith(b"\n") or len(line) < 10 or line[8:9] != b" ":
        return None
    data = line[9:-1]
    try:
        if int(line[:8], 16) != zlib.crc32(data):
            return None
        record = json.loads(data)
    except ValueError:
        return None
    return record if isinstance(record, dict) else None


def _read_journal(path: Path) -> tuple[dict, dict[int, dict], int]:
    """(header, rows, length in bytes of the valid prefix) of a journal."""
    try:
        raw = path.read_bytes()
    except FileNotFoundError:
        raise InputError(f"{path}: no journal to resume (the job was never started here, or it completed)") from None
    header = None
    rows: dict[int, dict] = {}
    valid = 0
    pos = 0
    while pos < len(raw):
        end = raw.find(b"\n", pos)
        line = raw[pos:] if end < 0 else raw[pos : end + 1]
        record = _decode(line)
        if record is None:
            break  # a line cut short by a crash: everything after it is not trusted
        if header is None:
            if record.get("rowstore") != FORMAT:
                raise InputError(f"{path}: not a camsim row journal (format {record.get('rowstore')!r})")
            header = record
        else:
            rows[int(record["i"])] = record["row"]
        pos += len(line)
        valid = pos
    if header is None:
        raise InputError(f"{path}: empty or damaged row journal (no header line)")
    return header, rows, valid


def _differences(stored: Any, given: Any, prefix: str = "") -> list[str]:
    """Dotted keys whose values differ between two JSON-able values."""
    if isinstance(stored, dict) and isinstance(given, dict):
        out = []
        for key in sorted(set(stored) | set(given), key=str):
            name = f"{prefix}.{key}" if prefix else str(key)
            if key not in stored:
                out.append(f"{name} (not in the stored job)")
            elif key not in given:
                out.append(f"{name} (missing now)")
            else:
                out.extend(_differences(stored[key], given[key], name))
        return out
    return [] if _json_equal(stored, given) else [f"{prefix or 'meta'} (stored {stored!r}, now {given!r})"]


def _json_equal(a: Any, b: Any) -> bool:
    return json.dumps(a, allow_nan=True, sort_keys=True) == json.dumps(b, allow_nan=True, sort_keys=True)


def _jsonable(value: Any) -> Any:
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, (list, tuple)):
        return [_jsonable(v) for v in value]
    if isinstance(value, dict):
        return {str(k): _jsonable(v) for k, v in value.items()}
    return value


# --------------------------------------------------------------------------------------
# The HDF5 view
# --------------------------------------------------------------------------------------
def _column_array(values: list[Any]) -> np.ndarray:
    """The stored array of one column: bool, int64, float64 (None -> NaN) or UTF-8 text."""
    present = [v for v in values if v is not None]
    if present and len(present) == len(values) and all(isinstance(v, (bool, np.bool_)) for v in present):
        return np.array([bool(v) for v in values], dtype=bool)
    if present and all(isinstance(v, (int, np.integer)) and not isinstance(v, (bool, np.bool_)) for v in present) and len(present) == len(values):
        return np.array(values, dtype=np.int64)
    if all(isinstance(v, (int, float, np.integer, np.floating)) and not isinstance(v, (bool, np.bool_)) for v in present):
        return np.array([math.nan if v is None else float(v) for v in values], dtype=np.float64)
    return np.array(["" if v is None else str(v) for v in values], dtype=object)


def _write_view(
    path: Path,
    table: str,
    columns: list[tuple[str, str]],
    meta: dict,
    rows: Mapping[int, Mapping[str, Any]],
    complete: bool,
    decorate: Callable[[Any], None] | None,
) -> None:
    import h5py

    from camsim.io.outputs import writing

    indices = sorted(rows)
    with writing(path) as target, target.h5() as f:
        if decorate is not None:
            decorate(f)
        dtypes = [(INDEX_COLUMN, np.int64)]
        arrays = [np.array(indices, dtype=np.int64)]
        for name, _ in columns:
            array = _column_array([rows[i].get(name) for i in indices])
            dtypes.append((name, h5py.string_dtype("utf-8") if array.dtype == object else array.dtype))
            arrays.append(array)
        data = np.empty(len(indices), dtype=dtypes)
        for (name, _), array in zip(dtypes, arrays):
            data[name] = array
        dset = f.create_dataset(table, data=data)
        dset.attrs[f"units:{INDEX_COLUMN}"] = ""
        for name, unit in columns:
            dset.attrs[f"units:{name}"] = unit
        dset.attrs["rowstore_meta"] = json.dumps(meta, allow_nan=True, sort_keys=True)
        dset.attrs["complete"] = bool(complete)
    _fsync_directory(path.parent)


def _fsync_directory(directory: Path) -> None:
    try:
        fd = os.open(directory if str(directory) else ".", os.O_RDONLY)
    except OSError:
        return
    try:
        os.fsync(fd)
    except OSError:
        pass
    finally:
        os.close(fd)


# --------------------------------------------------------------------------------------
# The store
# --------------------------------------------------------------------------------------
class RowStore:
    """Append-only table of finished evaluations that survives SIGINT, SIGTERM and SIGKILL.

    Rows are keyed by an integer index (the variant / sample / evaluation number).
    :meth:`append` returns only when the row is durable on disk (journal written and
    fsync'ed). ``meta`` (a JSON-able dict) identifies the job: a resume with different
    meta is refused (:class:`InputError` naming what differs). See the module docstring
    for the files and why.

    Use :meth:`create` or :meth:`resume`, not the constructor.

    Parameters of :meth:`create` and :meth:`resume` besides those of the interface
    (keyword-only, optional):

    table : str
        Dataset path of the table in the HDF5 view (default ``"rows"``).
    decorate : callable
        ``decorate(h5py.File)`` called on every rewrite of the view before the table is
        written (e.g. to write the root attributes of a camsim file).
    fsync : bool
        ``fsync`` every append (default True; False keeps SIGKILL safety, drops
        power-cut safety, and is faster on slow disks).
    view_ratio : float
        Rewrite the view after an append only when at least ``view_ratio`` times the
        duration of the last rewrite has passed since it ended (default 10; 0 rewrites
        after every append).
    """

    def __init__(
        self,
        path: Path,
        columns: list[tuple[str, str]],
        meta: dict,
        rows: dict[int, dict],
        fd: int,
        *,
        lock: locks.OutputLock,
        table: str,
        decorate: Callable[[Any], None] | None,
        fsync: bool,
        view_ratio: float,
    ) -> None:
        self.path = path
        self.journal = journal_path_for(path)
        self.columns = list(columns)
        self.meta = meta
        self._rows = rows
        self._fd: int | None = fd
        self._lock: locks.OutputLock | None = lock
        #: Settings stored with the job but not compared on resume (``info`` of :meth:`create`).
        self.info: dict = {}
        self._failed = False
        self._table = table
        self._decorate = decorate
        self._fsync = fsync
        self._view_ratio = view_ratio
        self._view_end = -math.inf
        self._view_cost = 0.0
        self._dirty = True
        self._names = {name for name, _ in self.columns}

    # -- opening -------------------------------------------------------------------------
    @classmethod
    def create(
        cls,
        path: str | os.PathLike[str],
        columns: Iterable[tuple[str, str]],
        meta: dict,
        *,
        table: str = "rows",
        decorate: Callable[[Any], None] | None = None,
        fsync: bool = True,
        view_ratio: float = 10.0,
        info: dict | None = None,
    ) -> RowStore:
        """Start a new job at ``path`` (an existing journal and view are replaced).

        Parameters
        ----------
        path : path
            The HDF5 view; the journal is ``<path>.journal``.
        columns : iterable of (str, str)
            Column name and SI unit text (``""`` for numbers without a unit), in order.
        meta : dict
            JSON-able description of the job, compared on :meth:`resume`.
        info : dict, optional
            JSON-able settings kept in the header but not compared on :meth:`resume` (a
            resumed job reads them as :attr:`info`, e.g. to state a changed budget).
        """
        path = Path(path)
        columns = [(str(n), str(u)) for n, u in columns]
        names = [n for n, _ in columns]
        if len(set(names)) != len(names):
            raise ValueError(f"RowStore: duplicate column names in {names}")
        if INDEX_COLUMN in names:
            raise ValueError(f"RowStore: '{INDEX_COLUMN}' is reserved for the row index")
        meta = _jsonable(dict(meta))
        json.dumps(meta, allow_nan=True)  # not JSON-able: TypeError now, not at resume
        journal = journal_path_for(path)
        from camsim.io.outputs import writing

        lock = locks.acquire(path, what="this job")
        fd = -1
        try:
            remove_stale_temps(path)
            remove_stale_temps(journal)
            _lock_existing(journal)  # refuse to replace a journal another job is writing
            # The new journal is written under a temporary name and renamed (the policy), so
            # a crash here leaves either no journal or one with a complete header.
            with writing(journal) as target:
                header = {"rowstore": FORMAT, "columns": columns, "meta": meta}
                if info:
                    header["info"] = _jsonable(dict(info))
                target.put_bytes(_encode(header))
            _fsync_directory(journal.parent)
            fd = open_journal(journal)
            _lock(fd, journal)
            store = cls(path, columns, meta, {}, fd, lock=lock, table=table, decorate=decorate, fsync=fsync,
                        view_ratio=view_ratio)
        except BaseException:
            if fd >= 0:
                os.close(fd)
            lock.release()
            raise
        store._refresh_view(force=True)
        return store

    @classmethod
    def resume(
        cls,
        path: str | os.PathLike[str],
        meta: dict,
        *,
        table: str = "rows",
        decorate: Callable[[Any], None] | None = None,
        fsync: bool = True,
        view_ratio: float = 10.0,
    ) -> RowStore:
        """Reopen the job at ``path`` to add the rows it is missing.

        Raises
        ------
        InputError
            No journal at ``<path>.journal``, a damaged header, another process writing
            it, or ``meta`` different from the stored one (the message names the keys).
        """
        path = Path(path)
        journal = journal_path_for(path)
        lock = locks.acquire(path, what="this job")
        fd = -1
        try:
            remove_stale_temps(path)
            remove_stale_temps(journal)
            header, rows, valid = _read_journal(journal)
            meta = _jsonable(dict(meta))
            diff = _differences(header["meta"], meta)
            if diff:
                raise InputError(f"{journal}: cannot resume: the job differs in " + "; ".join(diff))
            fd = open_journal(journal)
            _lock(fd, journal)
            if os.fstat(fd).st_size != valid:
                os.ftruncate(fd, valid)  # drop a line cut short by a crash
                os.fsync(fd)
            columns = [(str(n), str(u)) for n, u in header["columns"]]
            store = cls(path, columns, header["meta"], rows, fd, lock=lock, table=table, decorate=decorate,
                        fsync=fsync, view_ratio=view_ratio)
        except BaseException:
            if fd >= 0:
                os.close(fd)
            lock.release()
            raise
        store.info = dict(header.get("info") or {})
        store._refresh_view(force=True)
        return store

    # -- the interface -------------------------------------------------------------------
    def done(self) -> set[int]:
        """Indices already stored."""
        return set(self._rows)

    def append(self, index: int, row: Mapping[str, Any]) -> None:
        """Store one finished row; durable on disk when this returns.

        Parameters
        ----------
        index : int
            The row's key. Appending an index twice replaces the row (the last wins).
        row : mapping
            Column name -> value (float, int, bool, str or None); every key must be a
            column; missing columns are stored as None (NaN or ``""`` in the view).

        Raises
        ------
        ValueError
            A key that is not a column, or a value that is not JSON-able.
        """
        if self._fd is None:
            raise ValueError("RowStore: append after close")
        unknown = [k for k in row if k not in self._names]
        if unknown:
            raise ValueError(f"RowStore: {unknown} are not columns of this store")
        record = {"i": int(index), "row": {name: _jsonable(row[name]) for name, _ in self.columns if name in row}}
        line = _encode(record)
        size = os.fstat(self._fd).st_size
        try:
            append_record(self._fd, line, self._fsync)
        except OSError as exc:
            self._failed = True
            try:
                os.ftruncate(self._fd, size)  # the journal stays a valid prefix
            except OSError:
                pass  # a cut line fails its checksum and is dropped on resume
            if not FileSystemError.applies(exc):
                raise
            raise FileSystemError(str(self.journal), exc, advice=self._kept()) from None
        self._rows[int(index)] = record["row"]
        self._dirty = True
        self._refresh_view()

    def rows(self) -> dict[int, dict]:
        """Every stored row, by index (a copy)."""
        return {i: dict(r) for i, r in sorted(self._rows.items())}

    def close(self, complete: bool = False) -> None:
        """Write the view if rows are missing from it and release the journal.

        Parameters
        ----------
        complete : bool
            Mark the view's table ``complete`` (the job ran every index).
        """
        if self._fd is None:
            return
        try:
            if (self._dirty or complete) and not self._failed:
                self._refresh_view(force=True, complete=complete)
        finally:
            # marked closed before it is closed: an interrupt between the two must not make
            # the next close() (a caller's cleanup) close the number a second time
            fd, self._fd = self._fd, None
            try:
                os.close(fd)
            finally:
                if self._lock is not None:
                    lock, self._lock = self._lock, None
                    lock.release()

    def remove_journal(self) -> None:
        """Delete the journal (after the job's final files are written); closes first."""
        self.close()
        self.journal.unlink(missing_ok=True)

    def __enter__(self) -> RowStore:
        return self

    def __exit__(self, *exc: Any) -> None:
        self.close()

    # -- internals -----------------------------------------------------------------------
    def _kept(self) -> str:
        n = len(self._rows)
        return (f"{self.journal} keeps the {n} finished row{'s' if n != 1 else ''}; free space and run the same "
                "command with --resume to continue")
    def _refresh_view(self, force: bool = False, complete: bool = False) -> None:
        now = time.monotonic()
        if not force and now - self._view_end < self._view_ratio * self._view_cost:
            return
        try:
            _write_view(self.path, self._table, self.columns, self.meta, self._rows, complete, self._decorate)
        except FileSystemError as exc:
            self._failed = True
            raise FileSystemError(exc.path, exc.error, advice=self._kept()) from None
        self._view_end = time.monotonic()
        self._view_cost = self._view_end - now
        self._dirty = False


def _lock(fd: int, journal: Path) -> None:
    try:
        fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except BlockingIOError:
        raise InputError(f"{journal}: another process is writing this job") from None


def _lock_existing(journal: Path) -> None:
    """Raise InputError if a live process holds the lock of an existing journal."""
    try:
        fd = os.open(journal, os.O_RDONLY)
    except FileNotFoundError:
        return
    try:
        _lock(fd, journal)
    finally:
        os.close(fd)  # closing releases our probe lock


def read_rows(path: str | os.PathLike[str]) -> tuple[list[tuple[str, str]], dict, dict[int, dict]]:
    """(columns, meta, rows) of a job, from its journal (which holds every finished row).

    For scripts that watch a running job without writing to it; the HDF5 view at
    ``path`` can be read with h5py at any time too.
    """
    header, rows, _ = _read_journal(journal_path_for(path))
    return [(str(n), str(u)) for n, u in header["columns"]], header["meta"], rows

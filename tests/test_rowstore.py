"""camsim.io.rowstore: durable rows, atomic HDF5 view, resume, SIGKILL at random moments.

Reference: every stored row is a closed-form function of its index (:func:`expected_row`),
so what is read back is compared with values computed independently of the store, bit
for bit (floats compared through their int64 bit patterns; tolerance zero).
"""

from __future__ import annotations

import json
import os
import random
import signal
import subprocess
import sys
import time
from pathlib import Path

import h5py
import numpy as np
import pytest

from camsim.errors import InputError
from camsim.io.rowstore import RowStore, journal_path_for, read_rows, remove_stale_temps, temp_path_for

COLUMNS = [("speed", "rad/s"), ("force", "N"), ("count", ""), ("jump", ""), ("status", "")]
META = {"machine": "cdtm.toml", "vary": ["cam.speed=60:600:10rpm"], "cycles": 3}


def expected_row(i: int) -> dict:
    """The row of index ``i``: awkward floats (non-terminating binary fractions, NaN, inf)."""
    force = float("nan") if i % 7 == 3 else (float("inf") if i % 11 == 5 else 1.0 / (i + 3) + i * 1e-300)
    return {"speed": (i + 1) * 0.1, "force": force, "count": i * i, "jump": i % 2 == 0, "status": "ok" if i % 5 else f"Error: case {i} ü"}


def same(a: dict, b: dict) -> bool:
    """Rows equal bit for bit (floats by their bit patterns)."""
    if a.keys() != b.keys():
        return False
    for k in a:
        x, y = a[k], b[k]
        if isinstance(x, float) or isinstance(y, float):
            if np.float64(x).view(np.int64) != np.float64(y).view(np.int64):
                return False
        elif type(x) is not type(y) or x != y:
            return False
    return True


def test_rows_round_trip_bit_for_bit(tmp_path):
    path = tmp_path / "job.h5"
    store = RowStore.create(path, COLUMNS, META)
    order = [5, 0, 3, 9, 1]
    for i in order:
        store.append(i, expected_row(i))
    assert store.done() == set(order)
    store.close()
    again = RowStore.resume(path, META)
    assert again.done() == set(order)
    for i, row in again.rows().items():
        assert same(row, expected_row(i)), i
    cols, meta, rows = read_rows(path)
    assert cols == COLUMNS and meta == META and set(rows) == set(order)
    again.close()


def test_view_readable_while_running_in_index_order(tmp_path):
    path = tmp_path / "job.h5"
    store = RowStore.create(path, COLUMNS, META, view_ratio=0.0)
    with h5py.File(path, "r") as f:
        assert f["rows"].shape == (0,) and not f["rows"].attrs["complete"]
    for n, i in enumerate([4, 2, 7], start=1):
        store.append(i, expected_row(i))
        with h5py.File(path, "r") as f:  # a reader between two appends
            table = f["rows"][()]
            assert len(table) == n
            assert list(table["index"]) == sorted([4, 2, 7][:n])
            assert f["rows"].attrs["units:force"] == "N"
            assert json.loads(f["rows"].attrs["rowstore_meta"]) == META
            for rec in table:
                ref = expected_row(int(rec["index"]))
                assert np.float64(rec["force"]).view(np.int64) == np.float64(ref["force"]).view(np.int64)
                assert rec["status"].decode() == ref["status"]
                assert bool(rec["jump"]) == ref["jump"] and int(rec["count"]) == ref["count"]
    store.close(complete=True)
    with h5py.File(path, "r") as f:
        assert f["rows"].attrs["complete"]


def test_same_rows_give_same_bytes(tmp_path):
    """Appended in different orders (parallel workers finish in any order): same view bytes."""
    a, b = tmp_path / "a.h5", tmp_path / "b.h5"
    for path, order in ((a, [0, 1, 2, 3]), (b, [3, 1, 0, 2])):
        with RowStore.create(path, COLUMNS, META) as store:
            for i in order:
                store.append(i, expected_row(i))
    assert a.read_bytes() == b.read_bytes()


def test_resume_refuses_other_job_and_missing_journal(tmp_path):
    path = tmp_path / "job.h5"
    RowStore.create(path, COLUMNS, META).close()
    with pytest.raises(InputError, match=r"differs in cycles \(stored 3, now 4\)"):
        RowStore.resume(path, {**META, "cycles": 4})
    with pytest.raises(InputError, match="no journal"):
        RowStore.resume(tmp_path / "other.h5", META)


def test_unknown_column_rejected(tmp_path):
    with RowStore.create(tmp_path / "j.h5", COLUMNS, META) as store:
        with pytest.raises(ValueError, match="not columns"):
            store.append(0, {"speeed": 1.0})


def test_torn_last_line_ignored_and_cut(tmp_path):
    path = tmp_path / "job.h5"
    with RowStore.create(path, COLUMNS, META) as store:
        store.append(0, expected_row(0))
        store.append(1, expected_row(1))
    journal = journal_path_for(path)
    full = journal.read_bytes()
    lines = full.splitlines(keepends=True)
    # a crash in the middle of writing row 1: half its line
    journal.write_bytes(b"".join(lines[:2]) + lines[2][: len(lines[2]) // 2])
    store = RowStore.resume(path, META)
    assert store.done() == {0}
    store.append(2, expected_row(2))
    store.close()
    _, _, rows = read_rows(path)
    assert set(rows) == {0, 2} and same(rows[2], expected_row(2))
    # a corrupted byte (checksum mismatch) also ends the trusted prefix
    data = bytearray(journal.read_bytes())
    data[len(lines[0]) + 20] ^= 0x01
    journal.write_bytes(bytes(data))
    assert RowStore.resume(path, META).done() == set()


def test_second_writer_refused(tmp_path):
    path = tmp_path / "job.h5"
    store = RowStore.create(path, COLUMNS, META)
    with pytest.raises(InputError, match="another process is writing"):
        RowStore.resume(path, META)
    with pytest.raises(InputError, match="another process is writing"):
        RowStore.create(path, COLUMNS, META)
    store.close()
    RowStore.resume(path, META).close()


def _interrupt_after_closing(monkeypatch, chosen):
    """``os.close`` that closes, then raises KeyboardInterrupt when the descriptor is ``chosen()``:
    Ctrl-C or SIGTERM landing on the line after a close."""
    real_close = os.close

    def close(fd):
        real_close(fd)
        if fd == chosen():
            raise KeyboardInterrupt

    monkeypatch.setattr(os, "close", close)


def test_an_interrupt_just_after_a_close_closes_nothing_twice(tmp_path, monkeypatch):
    """Ctrl-C or SIGTERM right after the journal or a file being written is closed: the
    cleanup that follows (the caller's close(), the output policy's discard) does not close
    that number again. It did: an OSError (EBADF) replaced the interrupt, so the command's
    "interrupted: ... kept" line was lost, or it closed the file another part of the process
    had been given the number since (found by raising KeyboardInterrupt at each Python line
    of a store's append and close)."""
    from camsim.io.outputs import writing

    store = RowStore.create(tmp_path / "job.h5", COLUMNS, META)
    store.append(0, expected_row(0))
    journal = store._fd
    with monkeypatch.context() as m:
        _interrupt_after_closing(m, lambda: journal)
        with pytest.raises(KeyboardInterrupt):
            store.close()
    store.close()  # the caller's cleanup on the way out: nothing left to close
    assert RowStore.resume(tmp_path / "job.h5", META).rows().keys() == {0}  # lock and journal released

    sink = []
    with monkeypatch.context() as m:
        _interrupt_after_closing(m, lambda: sink[0] if sink else None)
        with pytest.raises(KeyboardInterrupt), writing(tmp_path / "out.bin") as target:
            target.binary().write(b"x")
            sink.append(target._sink.fd)
    assert not (tmp_path / "out.bin").exists()
    assert not list(tmp_path.glob(".out.bin.*.tmp"))


def test_stale_temp_files_of_dead_writers_removed(tmp_path):
    target = tmp_path / "job.h5"
    dead = subprocess.Popen([sys.executable, "-c", "pass"])
    dead.wait()
    stale = target.with_name(f".job.h5.{dead.pid}.0123abcd.tmp")
    live = temp_path_for(target)  # this process: alive
    other = tmp_path / f".other.h5.{dead.pid}.0123abcd.tmp"  # another target: not ours
    for p in (stale, live, other):
        p.write_bytes(b"x")
    assert remove_stale_temps(target) == [stale]
    assert live.exists() and other.exists() and not stale.exists()


# --------------------------------------------------------------------------------------
# SIGKILL at seeded random moments
# --------------------------------------------------------------------------------------
def _child(path: Path, start: int, ack_fd: int) -> None:
    """Writer process: open (create or resume) and append rows, acknowledging each."""
    try:
        if journal_path_for(path).exists():
            store = RowStore.resume(path, META, view_ratio=0.0)
        else:
            store = RowStore.create(path, COLUMNS, META, view_ratio=0.0)
        i = start
        while True:
            if i not in store.done():
                store.append(i, expected_row(i))
                os.write(ack_fd, b"%d\n" % i)
            i += 1
    finally:
        os._exit(0)


def test_sigkill_at_random_moments_loses_no_acknowledged_row(tmp_path):
    """25 writers killed with SIGKILL at seeded random times (0-60 ms after start or after
    the first acknowledged row).

    After each kill: every row whose append returned is in the journal, bit for bit;
    the HDF5 view opens with h5py and holds only true rows; the next writer removes the
    dead one's temporary files.
    """
    rng = random.Random(16)
    path = tmp_path / "job.h5"
    acked: set[int] = set()
    for trial in range(25):
        r, w = os.pipe()
        pid = os.fork()
        if pid == 0:  # pragma: no cover - child
            os.close(r)
            _child(path, start=trial * 3, ack_fd=w)
        os.close(w)
        early = b""
        if trial % 2:  # odd trials: kill while appending (after the first acknowledged row)
            import select

            if select.select([r], [], [], 2.0)[0]:
                early = os.read(r, 4096)
        time.sleep(rng.uniform(0.0, 0.06))  # even trials: also while opening/creating
        os.kill(pid, signal.SIGKILL)
        os.waitpid(pid, 0)
        with os.fdopen(r, "rb") as fh:
            acked |= {int(x) for x in (early + fh.read()).split()}
        if not journal_path_for(path).exists():
            assert not acked  # killed before the first journal was in place
            continue
        _, meta, rows = read_rows(path)
        assert meta == META
        assert acked <= set(rows), f"trial {trial}: lost {sorted(acked - set(rows))}"
        for i, row in rows.items():
            assert same(row, expected_row(i)), (trial, i)
        if path.exists():
            with h5py.File(path, "r") as f:
                table = f["rows"][()]
            assert set(int(x) for x in table["index"]) <= set(rows)
            for rec in table:
                ref = expected_row(int(rec["index"]))
                assert np.float64(rec["force"]).view(np.int64) == np.float64(ref["force"]).view(np.int64)
    assert len(acked) >= 12  # the writers did get work done
    store = RowStore.resume(path, META)  # the next writer cleans up after the dead ones
    store.close()
    assert [p.name for p in tmp_path.iterdir() if p.name.endswith(".tmp")] == []

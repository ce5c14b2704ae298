"""The output policy shared by every command that writes a file (docs/results.md).

One place decides what a command may write, so that no command loses a user's work:

* the **format comes from the suffix** (:func:`output_format`); an unknown suffix is bad
  input (exit 2) naming the formats the command writes;
* a command **never writes over one of its own inputs** (machine file, config, measured
  CSV, a result it reads): paths are compared resolved and with ``os.path.samefile``;
* a command **never writes over a file of another kind** (a TOML machine file, a CSV, a
  figure, an unrelated HDF5 file): the existing file is sniffed by its bytes, not by its
  name (:func:`sniff_kind`);
* replacing an existing **result of another command** (an HDF5 file whose ``file_kind``
  differs, a hand-written machine file under a TOML output) needs ``--force``;
* **companion files** (the CSV beside a sweep's HDF5) get names distinct from the main
  output and from the inputs (:func:`companion_path`);
* a **journal left by an interrupted job** is never discarded silently: the same command
  without ``--resume`` refuses, naming ``--resume`` and ``--fresh`` (:func:`check_journal`).

Every check raises :class:`camsim.errors.InputError` (one line, exit 2) before anything
is computed or written. The functions are plain library calls so that every analysis
(sweep, study, fit, optimize) applies the same rules.

And one way to write (issue 35): :func:`writing` is the only way camsim creates a file.
It hands the writer an opened temporary file (:class:`camsim.io.atomic.Target`), never a
path, and owns everything around it:

* the **lock** beside the output (:mod:`camsim.io.locks`): a second writer of the same
  file exits 2 naming the first one's process id. Inside an :func:`output_session` (every
  command runs in one) an output checked by :func:`check_output` stays locked from the
  check, before anything is computed, to the end of the command;
* the **checks** above for an output nobody checked (a library call): the suffix's
  format and owner the writer declares, against the file that is there;
* the **temporary file** and its **rename** into place, and its removal on failure;
* the **environment's refusals** (no space, a quota, a permission, a read-only file
  system, an I/O error): :class:`camsim.errors.FileSystemError`, one line naming the file
  and the cause, exit 1, nothing under the output's name.

``tests/test_architecture.py`` fails on any other way of writing a file in the package
(``open(..., "w")``, ``os.replace``, ``savefig(path)``, ``h5py.File(path, "w")``...).
"""

from __future__ import annotations

import errno
import fcntl
import os
from collections.abc import Iterable, Iterator, Mapping, Sequence
from contextlib import contextmanager
from pathlib import Path

from camsim.errors import FileSystemError, InputError
from camsim.io import locks
from camsim.io.atomic import Target, check_writable, remove_stale_temps

__all__ = [
    "HDF5",
    "CSV",
    "TOML",
    "FIGURES",
    "HTML",
    "output_format",
    "sniff_kind",
    "result_owner",
    "check_output",
    "companion_path",
    "check_journal",
    "same_file",
    "beside",
    "writing",
    "output_session",
    "hold_until_exit",
    "release_claims",
    "PDF",
    "DXF",
]

#: Suffix -> format of the outputs camsim writes.
HDF5: Mapping[str, str] = {".h5": "hdf5", ".hdf5": "hdf5"}
CSV: Mapping[str, str] = {".csv": "csv"}
TOML: Mapping[str, str] = {".toml": "toml"}
FIGURES: Mapping[str, str] = {".png": "png", ".svg": "svg", ".pdf": "pdf"}
HTML: Mapping[str, str] = {".html": "html", ".htm": "html"}
PDF: Mapping[str, str] = {".pdf": "pdf"}
DXF: Mapping[str, str] = {".dxf": "dxf"}

_HDF5_SIGNATURE = b"\x89HDF\r\n\x1a\n"
_NAMES = {"hdf5": "an HDF5 file", "toml": "a TOML file", "csv": "a CSV file", "png": "a PNG image",
          "pdf": "a PDF document", "svg": "an SVG image", "text": "a text file", "binary": "a binary file",
          "dxf": "a DXF drawing", "html": "an HTML page"}


def output_format(path: str | os.PathLike[str], formats: Mapping[str, str], option: str = "-o") -> str:
    """The format of an output from its suffix (case-insensitive).

    Parameters
    ----------
    path : path
        The output the user named.
    formats : mapping
        Accepted suffixes (with the dot) -> format name, e.g. :data:`HDF5`.
    option : str
        The option that named the file (for the message).

    Raises
    ------
    InputError
        For a suffix not in ``formats``, naming the accepted ones.
    """
    suffix = Path(path).suffix.lower()
    if suffix in formats:
        return formats[suffix]
    accepted = ", ".join(dict.fromkeys(formats))
    noun = "figure" if set(formats.values()) <= {"png", "svg", "pdf"} else "output"
    raise InputError(f"{path}: {option}: unknown {noun} format {Path(path).suffix or '(no suffix)'!r}; this command writes {accepted}")


def same_file(a: str | os.PathLike[str], b: str | os.PathLike[str]) -> bool:
    """True when ``a`` and ``b`` name the same file (resolved paths, or the same inode)."""
    pa, pb = Path(a), Path(b)
    try:
        if pa.resolve() == pb.resolve():
            return True
    except OSError:
        pass
    try:
        return pa.exists() and pb.exists() and os.path.samefile(pa, pb)
    except OSError:
        return False


def sniff_kind(path: str | os.PathLike[str]) -> str | None:
    """What an existing file holds, from its bytes: ``"hdf5"``, ``"toml"``, ``"csv"``,
    ``"png"``, ``"pdf"``, ``"svg"``, ``"dxf"``, ``"html"``, ``"text"``, ``"binary"``; None when it does
    not exist or is empty (nothing to lose)."""
    p = Path(path)
    try:
        with open(p, "rb") as fh:
            head = fh.read(65536)
    except (FileNotFoundError, IsADirectoryError, NotADirectoryError):
        return None
    except OSError:
        return "binary"
    if not head.strip():
        return None
    if head.startswith(_HDF5_SIGNATURE):
        return "hdf5"
    if head.startswith(b"\x89PNG"):
        return "png"
    if head.startswith(b"%PDF"):
        return "pdf"
    try:
        text = head.decode("utf-8")
    except UnicodeDecodeError:
        # a multi-byte character cut at the end of the 64 KiB read is still text
        try:
            text = head[:-4].decode("utf-8")
        except UnicodeDecodeError:
            return "binary"
    stripped = text.lstrip()
    if stripped[:15].lower().startswith(("<!doctype html", "<html")):
        return "html"
    if stripped.startswith("<?xml") or stripped.startswith("<svg"):
        return "svg"
    if stripped.startswith("0\nSECTION") or stripped.startswith("  0\nSECTION") or "\nSECTION\n" in text[:200]:
        return "dxf"
    import tomllib

    try:
        with open(p, "rb") as fh:
            doc = tomllib.load(fh)
        if doc:
            return "toml"
    except (tomllib.TOMLDecodeError, UnicodeDecodeError, OSError):
        pass
    first = stripped.splitlines()[0] if stripped else ""
    if "," in first or "\t" in first or ";" in first:
        return "csv"
    return "text"


def result_owner(path: str | os.PathLike[str], kind: str | None = None) -> str | None:
    """Which camsim command wrote an existing result, or None when camsim did not.

    HDF5: the root attribute ``file_kind`` (``run``, ``compare``, ``sweep``, ``study``,
    ``cam``, ...). TOML: ``lump`` (its header line), ``fit`` (its ``# fitted:`` notes),
    ``optimize`` (its ``# optimised:`` notes);
    a machine file written by hand is None. CSV: ``csv`` (camsim writes CSVs beside its
    results and from ``export``; a CSV is never a user's only copy of anything camsim
    reads, except a measured file, which is an input and refused by :func:`check_output`).
    """
    kind = sniff_kind(path) if kind is None else kind
    if kind == "hdf5":
        try:
            import h5py

            with h5py.File(path, "r") as f:
                value = f.attrs.get("file_kind")
        except Exception:  # noqa: BLE001 - unreadable HDF5: not one of ours
            return None
        if value is None:
            return None
        return value.decode() if isinstance(value, bytes) else str(value)
    if kind == "toml":
        try:
            text = Path(path).read_text(encoding="utf-8")
        except (OSError, UnicodeDecodeError):
            return None
        if "written by `camsim lump" in text[:400]:
            return "lump"
        if "# fitted:" in text:
            return "fit"
        if "# optimised:" in text:
            return "optimize"
        return None
    if kind == "csv":
        return "csv"
    if kind == "html":
        # the page's head carries its generator, after Bokeh's inlined runtime (~1.7 MB)
        marker = b'<meta name="generator" content="camsim report">'
        try:
            with open(path, "rb") as fh:
                seen = b""
                while len(seen) < 16 * 2**20:
                    chunk = fh.read(2**20)
                    if not chunk:
                        break
                    seen = seen[-len(marker):] + chunk
                    if marker in seen:
                        return "report"
                    if b"</head>" in chunk:
                        break
        except OSError:
            return None
        return None
    return None


def check_output(
    path: str | os.PathLike[str],
    fmt: str,
    *,
    owner: str,
    inputs: Iterable[tuple[str, str | os.PathLike[str] | None]] = (),
    force: bool = False,
    option: str = "-o",
    owners: Sequence[str] = (),
) -> Path:
    """Raise :class:`InputError` unless ``path`` may receive this command's output.

    Parameters
    ----------
    path : path
        The output file.
    fmt : str
        Its format (:func:`output_format`), e.g. ``"hdf5"``, ``"csv"``, ``"toml"``, ``"png"``.
    owner : str
        What this command writes there: the HDF5 ``file_kind`` (``"run"``, ``"sweep"``...)
        or ``"fit"``/``"lump"`` for a TOML file, ``"csv"`` for a CSV, ``"figure"``.
    inputs : iterable of (label, path)
        The command's inputs (``("machine file", "machines/cdtm.toml")``); None entries
        are skipped. The output may not be any of them.
    force : bool
        Replace an existing result of another command (``--force``). A file of another
        kind (by its bytes) and an input are never replaced.
    option : str
        The option naming the file, for the message.
    owners : sequence of str
        Further owners this command may replace without ``--force`` (e.g. the run view a
        sweep leaves while it runs).

    Returns
    -------
    Path
        ``path``.
    """
    target = Path(path)
    for label, source in inputs:
        if source is not None and same_file(target, source):
            raise InputError(f"{target}: {option} would write over the {label} {source}; choose another output name")
    check_writable(target)
    # Locked first (issue 45): a file that does not exist yet is claimed too, so that a second
    # writer is refused from the moment this command checks it, not when it writes.
    _claim(target)
    kind = sniff_kind(target)
    if kind is None:
        return target
    family = "figure" if fmt in ("png", "svg", "pdf") else fmt
    kind_family = "figure" if kind in ("png", "svg", "pdf") else kind
    if kind_family != family:
        raise InputError(
            f"{target}: {option}: the file exists and is {_NAMES.get(kind, kind)}, not {_NAMES.get(fmt, fmt)}; "
            "camsim never writes over a file of another kind (choose another name or remove it)"
        )
    if fmt in ("hdf5", "toml", "html"):
        found = result_owner(target, kind)
        if found != owner and found not in owners and not force:
            what = "not a camsim result" if found is None else f"a result of `camsim {found}`"
            if fmt == "toml" and found is None:
                what = "a machine file not written by camsim"
            if fmt == "html" and found is None:
                what = "an HTML page not written by camsim"
            raise InputError(f"{target}: {option}: the file exists and is {what}; pass --force to replace it")
    return target


# --------------------------------------------------------------------------------------
# Writing: the session, the claims, the one way to write a file
# --------------------------------------------------------------------------------------
#: Depth of nested output sessions, and the outputs locked in them (real path -> lock).
_SESSIONS = [0]
_CLAIMS: dict[str, locks.OutputLock] = {}
#: True when the claims outlive the session, to the process's exit (:func:`hold_until_exit`).
_UNTIL_EXIT = [False]


@contextmanager
def output_session() -> Iterator[None]:
    """A command's lifetime: outputs checked inside stay locked until it ends.

    Outside a session (a library call), :func:`check_output` only checks and
    :func:`writing` locks for the duration of the write.
    """
    _SESSIONS[0] += 1
    try:
        yield
    finally:
        _SESSIONS[0] -= 1
        if _SESSIONS[0] == 0 and not _UNTIL_EXIT[0]:
            release_claims()


def hold_until_exit() -> None:
    """Keep the outputs a command checked locked after its session, until :func:`release_claims`.

    The ``camsim`` process calls it before the command and releases the claims as the last
    thing before it exits (issue 45): the lock used to be released when the command returned,
    about a second before the process ended, and a second run started in that second replaced
    the result while both printed "wrote".
    """
    _UNTIL_EXIT[0] = True


def release_claims() -> None:
    """Release every output this process claimed (the lock files are removed)."""
    while _CLAIMS:
        _, lock = _CLAIMS.popitem()
        lock.release()


def _claim(path: Path) -> None:
    """Lock ``path`` until the session ends (no-op outside a session)."""
    if _SESSIONS[0] == 0:
        return
    key = os.path.realpath(path)
    if key not in _CLAIMS:
        _CLAIMS[key] = locks.acquire(path)


def _describe(existed: bool) -> str:
    return "the previous file is unchanged" if existed else "nothing was written under this name"


@contextmanager
def writing(
    path: str | os.PathLike[str],
    fmt: str | None = None,
    *,
    owner: str | None = None,
    option: str = "-o",
) -> Iterator[Target]:
    """Write one output: lock it, hand the writer its opened temporary file, rename it into place.

    Parameters
    ----------
    path : path
        The output.
    fmt : str, optional
        Its format (``"hdf5"``, ``"csv"``, ``"toml"``, ``"png"``...). With ``owner``, an
        output that no command checked (a library call) is checked here by
        :func:`check_output` against the file that is there; None: the caller holds the
        lock and has checked it (a row store's view).
    owner : str, optional
        What the writer writes there (:func:`check_output`).

    Yields
    ------
    Target
        The opened temporary file: ``target.h5()``, ``target.text()``, ``target.binary()``,
        ``target.put_bytes(...)``; ``target.check()`` raises a write error early.

    Raises
    ------
    FileSystemError
        The file system refused the write (exit 1): the temporary file is removed, the
        output keeps its previous content (or is absent).
    OutputLockedError
        Another process is writing the same output (exit 2).
    """
    final = Path(path)
    if fmt is not None and owner is not None and not locks.is_held(final):
        check_output(final, fmt, owner=owner, option=option)
    lock = locks.acquire(final)
    try:
        existed = final.exists()
        remove_stale_temps(final)
        target = Target(final)
        try:
            yield target
            target._finish()
        except BaseException as exc:
            target._discard()
            if FileSystemError.applies(exc):
                raise FileSystemError(str(final), exc, advice=_describe(existed)) from None
            if isinstance(exc, FileSystemError) and exc.path == str(final) and not exc.advice:
                raise exc.with_advice(_describe(existed)) from None
            raise
    finally:
        lock.release()


def beside(path: str | os.PathLike[str], suffix: str) -> Path:
    """The default output next to an input: ``machines/cdtm.toml`` + ``_sweep.h5`` ->
    ``machines/cdtm_sweep.h5``; an input without a file name ("", ".", a directory) is bad input."""
    p = Path(path)
    if not p.name or p.is_dir():
        raise InputError(f"{str(path)!r}: not a file (give the input file's name)")
    return p.with_name(p.stem + suffix)


def companion_path(path: str | os.PathLike[str], suffix: str, inputs: Iterable[str | os.PathLike[str] | None] = ()) -> Path:
    """The name of a file written beside ``path`` (e.g. the CSV beside a sweep's HDF5).

    ``<stem><suffix>``; when that is ``path`` itself or one of ``inputs``, ``<name><suffix>``
    (``out.h5.csv``), so a companion never takes the main output's or an input's name.
    """
    p = Path(path)
    candidate = p.with_suffix(suffix)
    taken = [p, *[Path(i) for i in inputs if i is not None]]
    if any(same_file(candidate, t) for t in taken):
        candidate = p.with_name(p.name + suffix)
    return candidate


def check_journal(
    output: str | os.PathLike[str],
    journal: str | os.PathLike[str],
    *,
    resume: bool,
    fresh: bool,
    what: str,
) -> bool:
    """Apply the journal rule of an interrupted job writing ``output``.

    A job that stores its progress in a journal (sweep, study, fit, optimize) must not
    discard it silently when run again: with a journal present, the command needs
    ``--resume`` (continue it) or ``--fresh`` (discard it and start again).

    Parameters
    ----------
    output : path
        The job's output (for the message).
    journal : path
        The journal an interrupted run of the job leaves.
    resume, fresh : bool
        The ``--resume`` and ``--fresh`` options.
    what : str
        The job's name, e.g. ``"sweep"``.

    Returns
    -------
    bool
        True when a journal is there to resume from.

    Raises
    ------
    InputError
        Both options; or a journal without either.
    """
    if resume and fresh:
        raise InputError("--resume and --fresh: give one of them, not both")
    journal = Path(journal)
    exists = journal.exists()
    if exists and (fresh or resume):
        _refuse_live_journal(output, journal, "--fresh" if fresh else "--resume")
    if exists and fresh:
        journal.unlink()
        return False
    if exists and not resume:
        raise InputError(
            f"{output}: an interrupted {what} left {journal}; run the same command with --resume to continue it, "
            "or with --fresh to discard it and start again"
        )
    return exists and resume


def _refuse_live_journal(output: str | os.PathLike[str], journal: Path, option: str) -> None:
    """InputError when a live process holds ``journal`` (its job is running): ``--fresh``
    would discard the rows it is writing, ``--resume`` would write beside it."""
    pid = locks.is_locked(output)
    if pid is None:
        try:
            fd = os.open(journal, os.O_RDONLY | os.O_CLOEXEC)
        except OSError:
            return
        try:
            fcntl.flock(fd, fcntl.LOCK_SH | fcntl.LOCK_NB)
        except OSError as exc:
            if exc.errno not in (errno.EWOULDBLOCK, errno.EAGAIN, errno.EACCES):
                return
            pid = 0
        finally:
            os.close(fd)
    if pid is not None:
        who = f"a running camsim process (PID {pid})" if pid else "a running camsim process"
        raise InputError(f"{journal}: {option}: the job is still running in {who}; wait for it or stop it first")

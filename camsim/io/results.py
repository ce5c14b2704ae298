"""Reading camsim result files: open and validate, find the traces, read the events.

A camsim result file is HDF5 with root attributes ``camsim_version`` and ``schema``
(spec §7). Its ``file_kind`` attribute says which layout it holds:

``run``
    one simulation: ``/time`` and the traces on it, ``/events``.
``compare``
    ``/impact`` and ``/no_impact`` (each in the run layout) and ``/difference`` (percent).
``sweep``
    ``/sweep/summary``, a table with one row per parameter point.
``cam``
    the cam program alone (``/cam/...``).

Everything here only reads; the files are opened read-only.

Every reader opens a result through :func:`open_h5`, which validates the file against
the layout of its kind (:func:`check_layout`, spec §7 and docs/results.md) before anything
reads it: a missing or malformed dataset is bad input (exit 2) naming the file and the
dataset, never a result shown without it. A run names what it stores in
``/summary``'s ``recorded`` attribute, so a trace (a mass) removed from a file is found.
"""

from __future__ import annotations

import os
from pathlib import Path

import h5py
import numpy as np

from camsim.errors import ResultFileError
from camsim.display import DisplayUnits
from camsim.io.hdf5 import read_table
from camsim.units import LARGEST

#: Result-file schema versions this version of camsim reads.
SUPPORTED_SCHEMAS = (1,)

#: The values of the root attribute ``file_kind``.
FILE_KINDS = ("run", "compare", "sweep", "cam")


def open_h5(path: str | os.PathLike[str], *, validate: bool = True) -> h5py.File:
    """Open a camsim result file read-only, after checking that it is one.

    Parameters
    ----------
    path : path
        The ``.h5`` file.
    validate : bool
        Check the layout of its kind (:func:`check_layout`); the default for every reader.

    Returns
    -------
    h5py.File
        Open read-only; the caller closes it (use it as a context manager).

    Raises
    ------
    ResultFileError
        With a one-line message naming the file: missing, not HDF5, not a camsim file
        (no ``camsim_version``/``schema`` attributes), a schema this version cannot read,
        or (``validate``) a dataset its kind holds that is missing or malformed.
    """
    p = Path(path)
    if not p.exists():
        raise ResultFileError(f"{p}: no such file")
    if p.is_dir():
        raise ResultFileError(f"{p}: is a directory, not a result file")
    try:
        is_hdf5 = h5py.is_hdf5(p)
    except OSError as exc:
        raise ResultFileError(f"{p}: cannot be read ({exc.strerror or exc})") from None
    if not is_hdf5:
        raise ResultFileError(f"{p}: not an HDF5 file")
    try:
        f = h5py.File(p, "r")
    except OSError as exc:
        raise ResultFileError(f"{p}: cannot be opened as HDF5 ({exc})") from None
    try:
        attrs = f.attrs
        if "camsim_version" not in attrs or "schema" not in attrs:
            raise ResultFileError(f"{p}: not a camsim result file (no camsim_version/schema attributes)")
        try:
            schema = int(np.asarray(attrs["schema"]).item())
        except (TypeError, ValueError):
            raise ResultFileError(f"{p}: schema: not an integer: {attrs['schema']!r}") from None
        if schema not in SUPPORTED_SCHEMAS:
            supported = ", ".join(str(s) for s in SUPPORTED_SCHEMAS)
            raise ResultFileError(
                f"{p}: schema: version {schema} is not supported by this camsim (reads {supported})"
            )
        if validate:
            check_layout(f, p)
    except H5_ERRORS as exc:  # the root group's own metadata is damaged
        f.close()
        raise ResultFileError(f"{p}: /: damaged: HDF5 cannot read the root group's attributes "
                              f"({type(exc).__name__}: {' '.join(str(exc).split())})") from None
    except BaseException:
        f.close()
        raise
    return f


#: Errors h5py raises for damaged metadata or data ("incorrect metadata checksum", "wrong
#: B-tree signature", a bad heap...): bad input, never "internal error".
H5_ERRORS = (OSError, KeyError, RuntimeError, ValueError, TypeError, IndexError, SystemError)
#: Samples read at once when the values of a dataset are checked (bounded memory).
CHUNK = 1 << 20


def _damaged(f: h5py.File, where: str, exc: BaseException) -> ResultFileError:
    text = " ".join(str(exc).split()) or type(exc).__name__
    return ResultFileError(f"{f.filename}: {where}: damaged: HDF5 cannot read it ({type(exc).__name__}: {text})")


class _Values:
    """What the layout requires of the values of some datasets (by full name): finite and within
    camsim's range (:data:`camsim.units.LARGEST`), and for a time base strictly increasing."""

    def __init__(self) -> None:
        self.finite: dict[str, str] = {}
        self.increasing: set[str] = set()
        self.columns: dict[str, tuple[str, ...]] = {}

    def check(self, f: h5py.File, dset: h5py.Dataset) -> None:
        """Read ``dset`` whole, in pieces, raising ResultFileError for values the layout refuses."""
        name = dset.name
        if dset.shape == () or dset.size == 0:
            dset[()]
            return
        previous = None
        for start in range(0, dset.shape[0], CHUNK):
            block = dset[start:start + CHUNK]
            if name in self.columns and block.dtype.names is not None:
                for column in self.columns[name]:
                    if column in block.dtype.names:
                        _finite(f, f"{name} column {column}", np.asarray(block[column], dtype=float), start)
            if name in self.finite:
                _finite(f, name, np.asarray(block, dtype=float), start)
            if name in self.increasing:
                values = np.asarray(block, dtype=float).reshape(-1)
                joined = values if previous is None else np.concatenate(([previous], values))
                bad = np.flatnonzero(~(np.diff(joined) > 0.0))
                if bad.size:
                    i = int(bad[0]) + 1 + start - (0 if previous is None else 1)
                    raise ResultFileError(f"{f.filename}: {name}: not increasing at sample {i} ({float(joined[bad[0] + 1])!r} "
                                          f"after {float(joined[bad[0]])!r}); the layout holds a strictly increasing time base")
                if values.size:
                    previous = values[-1]


def _finite(f: h5py.File, name: str, values: np.ndarray, start: int) -> None:
    bad = ~np.isfinite(values) | (np.abs(np.nan_to_num(values, nan=0.0, posinf=np.inf, neginf=np.inf)) > LARGEST)
    if bad.any():
        i = int(np.flatnonzero(bad.reshape(values.shape[0], -1).any(axis=1))[0])
        value = values.reshape(values.shape[0], -1)[i][bad.reshape(values.shape[0], -1)[i]][0]
        raise ResultFileError(f"{f.filename}: {name}: {float(value)!r} at sample {start + i}; the layout holds finite values "
                              f"within {LARGEST:g} (no value camsim writes is NaN, infinite or beyond it)")


def _read_all(f: h5py.File, values: _Values) -> None:
    """Read every attribute and every dataset of the file once, checking the values ``values``
    names: damaged HDF5 metadata or data is a ResultFileError naming the object (issue 45)."""
    where = ["/"]

    def attributes(obj, name: str) -> None:
        where[0] = f"{name}@ (its attributes)"
        for key in obj.attrs.keys():
            where[0] = f"{name}@{key}"
            obj.attrs[key]

    def walk(group: h5py.Group, prefix: str) -> None:
        where[0] = f"{prefix or '/'} (its members)"
        for key in list(group.keys()):
            name = f"{prefix}/{key}"
            where[0] = name
            item = group[key]
            attributes(item, name)
            where[0] = name
            if isinstance(item, h5py.Group):
                walk(item, name)
            elif isinstance(item, h5py.Dataset):
                values.check(f, item)

    try:
        attributes(f, "/")
        walk(f, "")
    except ResultFileError:
        raise
    except H5_ERRORS as exc:
        raise _damaged(f, where[0], exc) from None


# --------------------------------------------------------------------------------------
# The layout of each kind (issue 35: readers validate what they read)
# --------------------------------------------------------------------------------------
#: Columns every event table has (spec §7).
EVENT_COLUMNS = ("time", "angle_deg", "element", "kind")
#: Quantities of every mass (spec §7).
MASS_QUANTITIES = ("displacement", "velocity", "acceleration")


def _missing(f: h5py.File, where: str, why: str) -> ResultFileError:
    return ResultFileError(f"{f.filename}: {where}: not in the file ({why})")


def _malformed(f: h5py.File, where: str, why: str) -> ResultFileError:
    return ResultFileError(f"{f.filename}: {where}: malformed ({why})")


def _table(f: h5py.File, group: h5py.Group, name: str, columns: tuple[str, ...], why: str) -> None:
    where = f"{group.name.rstrip('/')}/{name}"
    if name not in group:
        raise _missing(f, where, why)
    dset = group[name]
    if not isinstance(dset, h5py.Dataset) or dset.dtype.names is None or dset.ndim != 1:
        raise _malformed(f, where, "not a table (a one-dimensional compound dataset)")
    lacking = [c for c in columns if c not in dset.dtype.names]
    if lacking:
        raise _malformed(f, where, f"no column {', '.join(lacking)}")


def _trace(f: h5py.File, group: h5py.Group, path: str, n: int | None, why: str) -> int:
    """Check one trace (float, first dimension the time base's); returns its length."""
    where = f"{group.name.rstrip('/')}/{path}"
    if path not in group:
        raise _missing(f, where, why)
    dset = group[path]
    if not isinstance(dset, h5py.Dataset):
        raise _malformed(f, where, "a group, not a dataset")
    if dset.ndim < 1 or dset.dtype.kind != "f":
        raise _malformed(f, where, f"{dset.dtype} of shape {dset.shape}, not floating-point samples")
    if n is not None and dset.shape[0] != n:
        raise _malformed(f, where, f"{dset.shape[0]} samples, but time has {n}")
    return dset.shape[0]


#: Traces of a run that may hold infinite or undefined values (the cam's shape: a flat
#: profile's radius of curvature is infinite; the contact quantities of [cam.geometry]).
MAY_BE_NONFINITE = ("cam/pressure_angle", "cam/pitch_radius_of_curvature", "cam/surface_radius_of_curvature",
                    "cam/pitch_curve", "cam/surface", "cam_contact/normal_force", "cam_contact/side_load",
                    "cam_contact/hertz_stress", "camshaft/")


def _full(group: h5py.Group, path: str) -> str:
    return f"{group.name.rstrip('/')}/{path}"


def _check_run(f: h5py.File, group: h5py.Group, values: _Values) -> None:
    """The run layout at ``group`` (a file root or a comparison's side)."""
    _table(f, group, "events", EVENT_COLUMNS, "a run result holds its event table, spec §7")
    values.columns[_full(group, "events")] = ("time",)
    recorded = None
    if "summary" in group:
        summary = group["summary"]
        if not isinstance(summary, h5py.Group):
            raise _malformed(f, summary.name, "a dataset, not the group of the run's scalars")
        if "recorded" in summary.attrs:
            import json

            try:
                recorded = json.loads(attr_text(summary, "recorded"))
                if not isinstance(recorded, list) or not all(isinstance(p, str) for p in recorded):
                    raise ValueError
            except ValueError:
                raise _malformed(f, f"{summary.name}@recorded", "not a JSON list of trace paths") from None
    if recorded is None:  # a file without the list of what it stores: the spec's minimum
        recorded = ["time"] + [f"masses/{m}/{q}" for m in names_under(group, "masses") for q in MASS_QUANTITIES]
        why = "a run result holds its time base and traces, spec §7"
    else:
        why = "listed in /summary recorded: the run stored it"
    if not recorded:
        return  # --summary-only: events and summary, no traces
    n = _trace(f, group, "time", None, why)
    values.increasing.add(_full(group, "time"))
    for path in recorded:
        if path != "time":
            _trace(f, group, path, n, why)
        if not path.startswith(MAY_BE_NONFINITE):
            values.finite[_full(group, path)] = path


def _check_compare(f: h5py.File, values: _Values) -> None:
    for side in ("impact", "no_impact"):
        if side not in f or not isinstance(f[side], h5py.Group):
            raise _missing(f, f"/{side}", "a comparison holds both runs, spec §7")
        _check_run(f, f[side], values)
    if "difference" not in f:
        raise _missing(f, "/difference", "a comparison holds the percent differences, spec §7")
    diff = f["difference"]
    n = _trace(f, diff, "time", None, "the differences' time base")
    values.increasing.add("/difference/time")
    values.finite["/difference/time"] = "time"
    for mass in names_under(diff, "masses"):
        for q in MASS_QUANTITIES:
            _trace(f, diff, f"masses/{mass}/{q}", n, "a difference per mass and quantity")


def _check_cam(f: h5py.File, values: _Values) -> None:
    n = _trace(f, f, "time", None, "a cam file holds one revolution, docs/cam-design.md")
    values.increasing.add("/time")
    values.finite["/time"] = "time"
    for q in ("angle", "displacement", "velocity", "acceleration", "jerk"):
        _trace(f, f, f"cam/{q}", n, "a cam file holds s, v, a, j against the cam angle")
        values.finite[f"/cam/{q}"] = q


def _job(group: str, table: str, columns: tuple[str, ...], attributes: tuple[str, ...], why: str):
    """The layout of a job's file (sweep, study, optimisation): its table, and the attributes of
    its group that the readers show -- unless the group says the job was interrupted (the view a
    running or stopped job leaves holds its rows only)."""

    def check(f: h5py.File, values: _Values) -> None:
        _table(f, f, f"{group}/{table}", columns, why)
        g = f[group]
        if bool(np.asarray(g.attrs.get("interrupted", False)).item()):
            return
        lacking = [a for a in attributes if a not in g.attrs]
        if lacking:
            raise ResultFileError(f"{f.filename}: /{group}: attribute {', '.join(lacking)} missing ({why}; a file "
                                  "written by camsim has it)")

    return check


#: file_kind -> the check of its layout.
LAYOUTS = {
    "run": lambda f, values: _check_run(f, f, values),
    "compare": _check_compare,
    "sweep": _job("sweep", "summary", ("status",), (), "a sweep holds its table, docs/sweeps.md"),
    "study": _job("study", "rows", ("run", "status"), ("summary_json", "n_samples", "n_runs", "method", "seed"),
                  "a study holds its rows and their statistics, docs/tolerance.md"),
    "optimize": _job("optimize", "runs", ("run", "status"), ("status", "method", "json"),
                     "an optimisation history holds its runs and its result, docs/optimize.md"),
    "cam": _check_cam,
}


def check_layout(f: h5py.File, path: str | os.PathLike[str] | None = None) -> str:
    """Validate an open camsim result against the layout of its kind; returns the kind.

    Raises
    ------
    ResultFileError
        Naming the file and the first dataset that is missing or malformed (exit 2).
    """
    try:
        kind = attr_text(f, "file_kind")
        if not kind:
            kind = file_kind(f)
    except ResultFileError:
        raise
    except H5_ERRORS as exc:
        raise _damaged(f, "/@file_kind", exc) from None
    check = LAYOUTS.get(kind)
    values = _Values()
    if check is not None:
        try:
            check(f, values)
        except ResultFileError:
            raise
        except H5_ERRORS as exc:  # damaged metadata: named with the object below, else here
            _read_all(f, _Values())
            raise _damaged(f, "the layout", exc) from None
    _read_all(f, values)  # every object read once: damaged HDF5 or values the layout refuses (issue 45)
    return kind


def _text(value: object) -> str:
    if isinstance(value, bytes):
        return value.decode()
    if isinstance(value, np.ndarray) and value.shape == ():
        return _text(value.item())
    return str(value)


def attr_text(obj: h5py.HLObject, name: str, default: str = "") -> str:
    """An attribute as ``str`` (decoding bytes), or ``default`` when absent."""
    if name not in obj.attrs:
        return default
    return _text(obj.attrs[name])


def file_display_units(f: h5py.File, system: str = "file") -> DisplayUnits:
    """The display units of a result file's human output under ``--units system`` (issue 36).

    ``file``: the ``display_units`` root attribute the writer recorded (the machine file's
    units); a file written before it existed counts them from its ``machine_toml``.
    """
    from camsim.display import display_units

    return display_units(system, attr_text(f, "machine_toml") or None, recorded=attr_text(f, "display_units") or None)


def file_kind(f: h5py.File) -> str:
    """The layout of a result file: ``"run"``, ``"compare"``, ``"sweep"`` or ``"cam"``.

    Read from the root attribute ``file_kind``; files without it are recognised by their
    groups (``/impact`` + ``/no_impact`` is a comparison, ``/sweep`` a sweep, ``/time`` a run,
    ``/cam`` alone a cam file).

    Raises
    ------
    ResultFileError
        If the attribute holds an unknown kind or nothing recognisable is in the file.
    """
    kind = attr_text(f, "file_kind")
    if kind:
        if kind not in FILE_KINDS:
            raise ResultFileError(f"{f.filename}: file_kind: unknown kind {kind!r} (expected one of {', '.join(FILE_KINDS)})")
        return kind
    if "impact" in f and "no_impact" in f:
        return "compare"
    if "sweep" in f:
        return "sweep"
    if "time" in f:
        return "run"
    if "cam" in f:
        return "cam"
    raise ResultFileError(f"{f.filename}: file_kind: missing and the layout is not recognisable")


def units_of(dset: h5py.Dataset) -> str:
    """The ``units`` attribute of a dataset ('' when absent)."""
    return attr_text(dset, "units")


def long_name_of(dset: h5py.Dataset) -> str:
    """The ``long_name`` attribute of a dataset (its last path component when absent)."""
    return attr_text(dset, "long_name", dset.name.rsplit("/", 1)[-1])


def _is_attached(dset: h5py.Dataset, scale: h5py.Dataset) -> bool:
    try:
        return bool(h5py.h5ds.is_attached(dset.id, scale.id, 0))
    except Exception:  # noqa: BLE001 - h5py raises various errors for non-scale datasets
        return False


def list_traces(group: h5py.Group, time_name: str = "time") -> dict[str, h5py.Dataset]:
    """All 1-D traces on the time base of ``group``, keyed by path relative to ``group``.

    The time base is ``group[time_name]``; it comes first (key ``"time"``), then every
    1-D floating-point dataset below ``group`` that has it attached as dimension scale,
    in file order. Subgroups with their own time base (e.g. ``/impact`` in a comparison
    file) are not entered.

    Returns
    -------
    dict
        ``{"time": ds, "cam/angle": ds, "masses/M2/velocity": ds, ...}``; empty if
        ``group`` has no time base.
    """
    if time_name not in group or not isinstance(group[time_name], h5py.Dataset):
        return {}
    time = group[time_name]
    out: dict[str, h5py.Dataset] = {time_name: time}
    prefix = len(group.name.rstrip("/")) + 1

    def walk(g: h5py.Group) -> None:
        for name, item in g.items():
            if isinstance(item, h5py.Group):
                if time_name in item:  # a subgroup with its own time base
                    continue
                walk(item)
            elif (
                isinstance(item, h5py.Dataset)
                and item.ndim == 1
                and item.dtype.kind == "f"
                and item.name != time.name
                and item.shape == time.shape
                and _is_attached(item, time)
            ):
                out[item.name[prefix:]] = item

    walk(group)
    return _canonical_order(out)


#: Order of the quantities of one object in listings (then alphabetical).
_LEAF_RANK = {"time": 0, "angle": 1, "displacement": 2, "velocity": 3, "acceleration": 4, "jerk": 5, "force": 6}


def _canonical_order(traces: dict[str, h5py.Dataset]) -> dict[str, h5py.Dataset]:
    """Keep groups in file order, quantities within a group as angle, s, v, a, j, force."""
    first_seen: dict[str, int] = {}
    for key in traces:
        first_seen.setdefault(key.rpartition("/")[0], len(first_seen))

    def rank(key: str) -> tuple[int, int, str]:
        parent, _, leaf = key.rpartition("/")
        return (first_seen[parent], _LEAF_RANK.get(leaf, 99), leaf)

    return {k: traces[k] for k in sorted(traces, key=rank)}


def time_bases(f: h5py.File) -> dict[str, h5py.Group]:
    """Every group holding a ``time`` dataset, keyed by its path without the leading slash.

    A run file gives ``{"": f}``; a comparison file ``{"impact": ..., "no_impact": ...,
    "difference": ...}``.
    """
    out: dict[str, h5py.Group] = {}

    def visit(name: str, item: object) -> None:
        if isinstance(item, h5py.Group) and "time" in item and isinstance(item["time"], h5py.Dataset):
            out[name] = item

    if "time" in f and isinstance(f["time"], h5py.Dataset):
        out[""] = f
    f.visititems(visit)
    return out


def all_datasets(f: h5py.File) -> dict[str, h5py.Dataset]:
    """Every dataset in the file, keyed by path without the leading slash, in file order."""
    out: dict[str, h5py.Dataset] = {}

    def visit(name: str, item: object) -> None:
        if isinstance(item, h5py.Dataset):
            out[name] = item

    f.visititems(visit)
    return out


def read_events(group: h5py.Group) -> dict[str, np.ndarray] | None:
    """The ``events`` table of a run layout as columns, or ``None`` when there is none.

    Columns (spec §7): ``time`` [s], ``angle_deg`` [deg], ``element``, ``kind``,
    ``masses``, ``relative_velocity`` [m/s], ``johnson_lower`` / ``johnson_upper`` /
    ``peak_force`` [N], ``contact_duration`` [s]; NaN where not applicable.
    """
    if "events" not in group:
        return None
    return read_table(group["events"])


def table_units(dset: h5py.Dataset) -> dict[str, str]:
    """Units of each column of a table written by :func:`camsim.io.hdf5.write_table`."""
    return {name: attr_text(dset, f"units:{name}") for name in dset.dtype.names or ()}


def require(group: h5py.Group, path: str, what: str = "") -> h5py.Dataset:
    """``group[path]`` as a dataset, or :class:`ResultFileError` naming file and path."""
    if path not in group or not isinstance(group[path], h5py.Dataset):
        where = group.name.rstrip("/") + "/" + path
        extra = f" ({what})" if what else ""
        raise ResultFileError(f"{group.file.filename}: {where}: not in the file{extra}")
    return group[path]


def names_under(group: h5py.Group, path: str) -> list[str]:
    """Names of the subgroups of ``group[path]`` (e.g. the masses), [] if absent."""
    if path not in group or not isinstance(group[path], h5py.Group):
        return []
    return [k for k, v in group[path].items() if isinstance(v, h5py.Group)]


def names_with(group: h5py.Group, path: str, leaf: str) -> list[str]:
    """Names ``n`` of subgroups of ``group[path]`` that hold a dataset ``leaf``."""
    if path not in group or not isinstance(group[path], h5py.Group):
        return []
    return [k for k, v in group[path].items() if isinstance(v, h5py.Group) and leaf in v]

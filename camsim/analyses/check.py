"""Regression check: compare a result file with a golden one, dataset by dataset.

The rule (docs/regression.md): a numeric dataset ``r`` of the result passes against the
same dataset ``g`` of the golden file when, for every sample ``i``,

    |r_i - g_i| <= atol + rtol * max_j |g_j|

i.e. the tolerance is relative to the golden dataset's peak magnitude, not to each
sample (a trace crossing zero would otherwise fail on round-off). NaN equals NaN at the
same place; a NaN against a number fails; equal infinities pass. Text and integer/bool
data must be equal exactly. Tables (``/events``, ``/sweep/summary``) must have the same
number of rows, then each float column is checked by the rule above over that column
and every other column must be equal.

Files that cannot be compared (not camsim files, different kinds, a dataset present in
one only, different units, different time grids) raise :class:`ResultFileError`; a
comparison that finds differences returns a report whose ``passed`` is False.
"""

from __future__ import annotations

import math
import os
from dataclasses import asdict, dataclass, field
from typing import Any

import h5py
import numpy as np

from camsim.errors import InputError, ResultFileError
from camsim.io.hdf5 import read_table
from camsim.io.results import all_datasets, attr_text, file_kind, list_traces, open_h5, table_units, time_bases, units_of

from camsim.analyses.tolerances import DEFAULT_ATOL, DEFAULT_RTOL  # noqa: E402  (re-exported)


@dataclass(frozen=True)
class PathDiff:
    """The comparison of one dataset (or one table column) of the two files.

    Attributes
    ----------
    path : str
        Dataset path without the leading slash (``masses/M2/velocity``); table columns as
        ``events/peak_force``.
    units : str
        SI unit of the data.
    max_abs : float
        Largest |result - golden| [units]; ``inf`` where NaN meets a number.
    max_rel : float
        ``max_abs`` divided by the golden peak |value| [-] (0 when both are 0).
    peak : float
        Largest finite |golden| value [units].
    tolerance : float
        ``atol + rtol * peak`` [units].
    passed : bool
        ``max_abs <= tolerance`` (and equal text, equal row count).
    where : float or None
        Time [s] of the worst sample (for tables: the time column of the worst row),
        ``None`` when the dataset is not on a time base.
    index : int or None
        Index of the worst sample or row.
    note : str
        What differs when it is not a number: ``"rows: 5, golden 4"``, ``"text differs"``.
    """

    path: str
    units: str
    max_abs: float
    max_rel: float
    peak: float
    tolerance: float
    passed: bool
    where: float | None = None
    index: int | None = None
    note: str = ""

    @property
    def used(self) -> float:
        """Fraction of the tolerance used, ``max_abs / tolerance`` [-] (inf if tolerance is 0)."""
        if math.isnan(self.max_abs):
            return 0.0 if self.passed else math.inf
        if self.max_abs == 0:
            return 0.0
        return self.max_abs / self.tolerance if self.tolerance > 0 else math.inf


@dataclass
class CheckReport:
    """Result of :func:`check_files`.

    Attributes
    ----------
    result, golden : str
        The two file names.
    rtol, atol : float
        The tolerances used.
    diffs : list of PathDiff
        One per dataset or table column, in the golden file's order.
    notes : list of str
        Differences that do not fail the check (other machine file, other camsim version).
    """

    result: str
    golden: str
    rtol: float
    atol: float
    diffs: list[PathDiff] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)

    @property
    def passed(self) -> bool:
        """True when every dataset is within tolerance."""
        return all(d.passed for d in self.diffs)

    @property
    def failures(self) -> list[PathDiff]:
        """The datasets beyond tolerance, worst first."""
        return sorted((d for d in self.diffs if not d.passed), key=_severity, reverse=True)

    def worst(self, n: int = 10) -> list[PathDiff]:
        """The ``n`` datasets that use most of their tolerance, failures first."""
        return sorted(self.diffs, key=_severity, reverse=True)[:n]

    def to_dict(self) -> dict[str, Any]:
        """A JSON-ready dict (non-finite numbers become ``None``)."""

        def clean(d: PathDiff) -> dict[str, Any]:
            out = asdict(d)
            for k, v in out.items():
                if isinstance(v, float) and not math.isfinite(v):
                    out[k] = None
            return out

        return {
            "result": self.result,
            "golden": self.golden,
            "rtol": self.rtol,
            "atol": self.atol,
            "passed": self.passed,
            "failed": [d.path for d in self.failures],
            "notes": list(self.notes),
            "datasets": [clean(d) for d in self.diffs],
        }


def _severity(d: PathDiff) -> tuple[int, float]:
    return (0 if d.passed else 1, d.used)


def compare_arrays(
    path: str, result: np.ndarray, golden: np.ndarray, rtol: float, atol: float, units: str = "", time: np.ndarray | None = None
) -> PathDiff:
    """Compare two numeric arrays of equal shape by the rule of this module.

    Parameters
    ----------
    time : ndarray, optional
        Time [s] of each sample, to report where the worst difference is.
    """
    r = np.asarray(result, dtype=np.float64).ravel()
    g = np.asarray(golden, dtype=np.float64).ravel()
    if r.shape != g.shape:
        return PathDiff(path, units, math.nan, math.nan, math.nan, math.nan, False, note=f"length: {r.size}, golden {g.size}")
    finite_g = np.abs(g[np.isfinite(g)])
    peak = float(finite_g.max()) if finite_g.size else 0.0
    tol = atol + rtol * peak
    with np.errstate(invalid="ignore"):
        diff = np.abs(r - g)
    same = (r == g) | (np.isnan(r) & np.isnan(g))
    diff = np.where(same, 0.0, diff)
    diff = np.where(np.isnan(diff), np.inf, diff)  # NaN vs number, or inf vs -inf
    if diff.size == 0:
        return PathDiff(path, units, 0.0, 0.0, peak, tol, True)
    i = int(np.argmax(diff))
    max_abs = float(diff[i])
    max_rel = max_abs / peak if peak > 0 else (0.0 if max_abs == 0 else math.inf)
    where = float(time[i]) if time is not None and time.size == diff.size else None
    return PathDiff(path, units, max_abs, max_rel, peak, tol, bool(max_abs <= tol), where, i)


def _compare_exact(path: str, result: np.ndarray, golden: np.ndarray, units: str = "", time=None) -> PathDiff:
    r = np.asarray(result).ravel()
    g = np.asarray(golden).ravel()
    if r.shape != g.shape:
        return PathDiff(path, units, math.nan, math.nan, math.nan, 0.0, False, note=f"length: {r.size}, golden {g.size}")
    bad = np.flatnonzero(np.array([a != b for a, b in zip(r.tolist(), g.tolist())], dtype=bool))
    if bad.size == 0:
        return PathDiff(path, units, 0.0, 0.0, 0.0, 0.0, True)
    i = int(bad[0])
    where = float(time[i]) if time is not None and len(time) == r.size else None
    note = f"{bad.size} value(s) differ, first at index {i}: {r[i]!r}, golden {g[i]!r}"
    return PathDiff(path, units, math.nan, math.nan, math.nan, 0.0, False, where, i, note)


def _compare_tables(path: str, r_ds: h5py.Dataset, g_ds: h5py.Dataset, rtol: float, atol: float) -> list[PathDiff]:
    r, g = read_table(r_ds), read_table(g_ds)
    units = table_units(g_ds)
    if list(r) != list(g):
        raise ResultFileError(
            f"{r_ds.file.filename}: /{path}: columns differ from the golden file's "
            f"({', '.join(r)} vs {', '.join(g)})"
        )
    nr, ng = len(next(iter(r.values()), [])), len(next(iter(g.values()), []))
    if nr != ng:
        return [PathDiff(path, "", math.nan, math.nan, math.nan, 0.0, False, note=f"rows: {nr}, golden {ng}")]
    time = np.asarray(g["time"], dtype=float) if "time" in g and g["time"].dtype.kind == "f" else None
    out = []
    row_units = _row_units(g)
    for col in g:
        cpath = f"{path}/{col}"
        if g[col].dtype.kind == "f" and row_units is not None and units.get(col) == "quantity's":
            # Issue 44: the extremes table's max/min hold each row's quantity in its own unit (its
            # "units" column); compared row by row, each in its unit (never "quantity's").
            for i, (quantity, unit) in enumerate(row_units):
                out.append(compare_arrays(f"{path}/{quantity}/{col}", r[col][i:i + 1], g[col][i:i + 1], rtol, atol, unit))
        elif g[col].dtype.kind == "f":
            out.append(compare_arrays(cpath, r[col], g[col], rtol, atol, units.get(col, ""), time))
        else:
            out.append(_compare_exact(cpath, r[col], g[col], units.get(col, ""), time))
    return out


def _row_units(table: dict) -> list[tuple[str, str]] | None:
    """(quantity, unit) of each row of a table that names them (the extremes table), else None."""
    if "quantity" not in table or "units" not in table:
        return None
    text = lambda v: v.decode() if isinstance(v, bytes) else str(v)  # noqa: E731
    return [(text(q), text(u)) for q, u in zip(table["quantity"], table["units"])]


def _check_tolerances(rtol: float, atol: float) -> None:
    for name, value in (("rtol", rtol), ("atol", atol)):
        if not (isinstance(value, (int, float)) and math.isfinite(value) and value >= 0):
            raise InputError(f"--{name}: must be a finite number >= 0, got {value!r}")


def _listing(paths: list[str], n: int = 5) -> str:
    shown = ", ".join("/" + p for p in paths[:n])
    return shown + (f" (and {len(paths) - n} more)" if len(paths) > n else "")


def check_files(
    result: str | os.PathLike[str],
    golden: str | os.PathLike[str],
    rtol: float = DEFAULT_RTOL,
    atol: float = DEFAULT_ATOL,
) -> CheckReport:
    """Compare every dataset and table of ``result`` with ``golden``.

    Parameters
    ----------
    result : path
        The file under test.
    golden : path
        The reference file.
    rtol : float
        Tolerance relative to each golden dataset's peak |value| [-].
    atol : float
        Absolute tolerance in each dataset's SI unit.

    Returns
    -------
    CheckReport
        ``report.passed`` is False when a dataset differs beyond tolerance (exit 1).

    Raises
    ------
    ResultFileError
        When the files cannot be compared: not camsim files, different file kinds, a
        dataset in one file only, different units, different time grids (exit 2).
    """
    _check_tolerances(rtol, atol)
    report = CheckReport(str(result), str(golden), float(rtol), float(atol))
    with open_h5(result) as rf, open_h5(golden) as gf:
        rk, gk = file_kind(rf), file_kind(gf)
        if rk != gk:
            raise ResultFileError(f"{result}: file_kind: {rk}, but the golden file is a {gk} file")
        r_sets, g_sets = all_datasets(rf), all_datasets(gf)
        missing = [p for p in g_sets if p not in r_sets]
        extra = [p for p in r_sets if p not in g_sets]
        if missing:
            raise ResultFileError(f"{result}: {_listing(missing)}: not in the file but in the golden file {golden}")
        if extra:
            raise ResultFileError(f"{result}: {_listing(extra)}: in the file but not in the golden file {golden}")
        for p, g_ds in g_sets.items():
            r_ds = r_sets[p]
            if units_of(r_ds) != units_of(g_ds):
                raise ResultFileError(
                    f"{result}: /{p}: units {units_of(r_ds)!r}, golden file has {units_of(g_ds)!r}"
                )
        # Time grids: same length, same instants within tolerance.
        time_of: dict[str, np.ndarray] = {}
        time_paths = set()
        for prefix, g_group in time_bases(gf).items():
            tpath = f"{prefix}/time" if prefix else "time"
            time_paths.add(tpath)
            gt = g_group["time"][()]
            rt = r_sets[tpath][()]
            if rt.shape != gt.shape:
                raise ResultFileError(
                    f"{result}: /{tpath}: different time grids: {rt.size} samples, golden file has {gt.size}"
                )
            tdiff = compare_arrays(tpath, rt, gt, rtol, atol, "s", gt)
            if not tdiff.passed:
                raise ResultFileError(
                    f"{result}: /{tpath}: different time grids: sample {tdiff.index} is at "
                    f"{rt[tdiff.index]!r} s, golden file {gt[tdiff.index]!r} s"
                )
            report.diffs.append(tdiff)
            for rel in list_traces(g_group):
                time_of[f"{prefix}/{rel}" if prefix else rel] = gt
        for p, g_ds in g_sets.items():
            if p in time_paths:
                continue
            r_ds = r_sets[p]
            if g_ds.dtype.names is not None:
                if r_ds.dtype.names is None:
                    raise ResultFileError(f"{result}: /{p}: not a table, but the golden file's is")
                report.diffs.extend(_compare_tables(p, r_ds, g_ds, rtol, atol))
                continue
            rv, gv = r_ds[()], g_ds[()]
            units = units_of(g_ds)
            if gv.dtype.kind == "f" and np.asarray(rv).dtype.kind in "fiu":
                report.diffs.append(compare_arrays(p, rv, gv, rtol, atol, units, time_of.get(p)))
            else:
                report.diffs.append(_compare_exact(p, rv, gv, units, time_of.get(p)))
        for attr, what in (("machine_sha256", "machine file"), ("camsim_version", "camsim version")):
            a, b = attr_text(rf, attr), attr_text(gf, attr)
            if a != b:
                report.notes.append(f"{what} differs: {attr} {a or '-'} (golden {b or '-'})")
    return report


def _fmt(x: float | None, spec: str = ".3g") -> str:
    if x is None or (isinstance(x, float) and math.isnan(x)):
        return "-"
    if isinstance(x, float) and math.isinf(x):
        return "inf"
    return format(x, spec)


def summary_line(report: CheckReport, units=None) -> str:
    """One line: PASS with the count, or FAIL naming the datasets beyond tolerance (|Δ| in
    ``units``, a :class:`~camsim.display.DisplayUnits`; SI without them)."""
    n = len(report.diffs)
    tol = f"rtol={report.rtol:g}, atol={report.atol:g}"
    if report.passed:
        return f"PASS: all {n} datasets of {report.result} within tolerance of {report.golden} ({tol})"
    fails = report.failures
    first = fails[0]
    unit, k = _shown(first.units, units)
    detail = first.note or (
        f"max |diff| {_fmt(first.max_abs * k)} {unit}".rstrip()
        + f" = {_fmt(first.max_rel)} of peak"
        + (f" at t = {_fmt(first.where, '.6g')} s" if first.where is not None else "")
    )
    names = ", ".join(d.path for d in fails[:5]) + (f" and {len(fails) - 5} more" if len(fails) > 5 else "")
    return f"FAIL: {len(fails)} of {n} datasets differ beyond tolerance ({tol}): {names}; worst {first.path}: {detail}"


def _shown(si_unit: str, units) -> tuple[str, float]:
    if units is None:
        return si_unit, 1.0
    return units.shown(si_unit)


def render_report(report: CheckReport, console, limit: int = 10, units=None) -> None:
    """Print a table of the worst differences and a PASS/FAIL line on a rich Console.

    Parameters
    ----------
    report : CheckReport
    console : rich.console.Console
        Usually the stderr console of the CLI.
    limit : int
        How many rows (worst first; failures always shown first).
    units : DisplayUnits, optional
        Units of the differences shown (SI without them; tolerances stay SI).
    """
    from rich.markup import escape
    from rich.table import Table

    table = Table(title=escape(f"check {report.result} against {report.golden}"), title_justify="left")
    table.add_column("dataset", overflow="fold", min_width=16)
    table.add_column("max |Δ|", justify="right", no_wrap=True)
    table.add_column("unit", no_wrap=True)
    table.add_column("Δ/peak", justify="right", no_wrap=True)
    table.add_column(escape("t [s]"), justify="right", no_wrap=True)
    table.add_column("Δ/tol", justify="right", overflow="fold")
    table.add_column("", no_wrap=True)
    for d in report.worst(limit):
        unit, k = _shown(d.units, units)
        table.add_row(
            escape(d.path),
            _fmt(d.max_abs * k),
            escape(unit),
            _fmt(d.max_rel),
            _fmt(d.where, ".6g"),
            "see below" if d.note else _fmt(d.used),
            "ok" if d.passed else "FAIL",
        )
    console.print(table)
    for d in report.failures:
        if d.note:
            console.print(f"{d.path}: {d.note}", markup=False, highlight=False)
    for note in report.notes:
        console.print(f"note: {note}", markup=False, highlight=False)
    console.print(summary_line(report, units), markup=False, highlight=False)

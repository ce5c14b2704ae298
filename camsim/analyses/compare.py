"""Impact vs no-impact comparisons (thesis §8.4) and comparisons of two result files.

The difference of a trace is the thesis's definition,

    difference = 100 · (impact − no_impact) / max|impact|   [%],

sample by sample on a common time grid.
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass, field

import numpy as np

from camsim.errors import ResultFileError

QUANTITIES = ("displacement", "velocity", "acceleration")


def percent_difference(impact: np.ndarray, no_impact: np.ndarray) -> np.ndarray:
    """100·(impact − no_impact)/max|impact| [%]; zero where both are identically zero."""
    peak = float(np.max(np.abs(impact))) if impact.size else 0.0
    diff = np.asarray(impact, dtype=float) - np.asarray(no_impact, dtype=float)
    if peak == 0.0:
        return np.where(diff == 0.0, 0.0, np.inf * np.sign(diff))
    return 100.0 * diff / peak


@dataclass
class ComparisonRow:
    """One line of the comparison table (SI values)."""

    mass: str
    quantity: str
    peak_impact: float
    peak_no_impact: float
    max_difference_percent: float
    time: float


@dataclass
class Comparison:
    """Two runs on one time grid and their percent differences per mass and quantity.

    Attributes
    ----------
    impact, no_impact : RunResult or None
        The runs (None when the comparison was read from files).
    time : ndarray
        The common time grid [s].
    a, b : dict
        name → quantity → trace, for the first ("impact") and second ("no impact") run.
    located : (dict or None, dict or None)
        Each side's located extremes: the peaks of the table are those (spec §4).
    difference : dict
        name → quantity → percent difference.
    labels : tuple of str
        What the two sides are called in tables.
    """

    time: np.ndarray
    a: dict[str, dict[str, np.ndarray]]
    b: dict[str, dict[str, np.ndarray]]
    difference: dict[str, dict[str, np.ndarray]] = field(default_factory=dict)
    impact: object | None = None
    no_impact: object | None = None
    labels: tuple[str, str] = ("impact", "no impact")
    #: The located extremes of each side (RunResult.located; None: none, the samples' peaks).
    located: tuple = (None, None)

    def __post_init__(self) -> None:
        if not self.difference:
            self.difference = {
                name: {q: percent_difference(self.a[name][q], self.b[name][q]) for q in QUANTITIES}
                for name in self.a
            }

    def rows(self) -> list[ComparisonRow]:
        """Per mass and quantity: both peaks, the largest |difference| and when it occurs."""
        out = []
        for name, quantities in self.difference.items():
            for q in QUANTITIES:
                diff = quantities[q]
                k = int(np.argmax(np.abs(diff))) if diff.size else 0
                out.append(
                    ComparisonRow(
                        mass=name,
                        quantity=q,
                        peak_impact=_peak(self.located[0], self.a, name, q),
                        peak_no_impact=_peak(self.located[1], self.b, name, q),
                        max_difference_percent=float(abs(diff[k])) if diff.size else 0.0,
                        time=float(self.time[k]) if diff.size else 0.0,
                    )
                )
        return out

    def to_dict(self) -> dict:
        return {
            "labels": list(self.labels),
            "rows": [
                {
                    "mass": r.mass,
                    "quantity": r.quantity,
                    "peak_a": r.peak_impact,
                    "peak_b": r.peak_no_impact,
                    "max_difference_percent": r.max_difference_percent if math.isfinite(r.max_difference_percent) else None,
                    "time": r.time,
                }
                for r in self.rows()
            ],
        }


def _peak(located, traces, name: str, quantity: str) -> float:
    """Largest |quantity| of a mass: the run's located peak (``located``, its
    :attr:`~camsim.run.result.RunResult.located`; spec §4: the number its own summary
    reports), or the largest |sample| of a side without one (files written before)."""
    hit = (located or {}).get(f"masses/{name}/{quantity}")
    if hit is not None:
        return max(abs(hit["max"].value), abs(hit["min"].value))
    data = traces[name][quantity]
    return float(np.max(np.abs(data))) if data.size else 0.0


def compare_machine(machine, **run_options) -> Comparison:
    """Run ``machine`` with and without impact and over-travel on the same grid.

    Parameters
    ----------
    machine : Machine
    **run_options
        Passed to :func:`camsim.run.simulation.simulate` (cycles, warmup_cycles, sample_rate, progress).
    """
    from camsim.run.budget import check_in_memory
    from camsim.run.simulation import simulate

    sizes = {k: run_options.get(k) for k in ("cycles", "warmup_cycles", "sample_rate")}
    check_in_memory(machine, str(machine.source or "compare"), **sizes)  # both runs are held in memory
    with_impact = simulate(machine, **run_options)
    without = simulate(machine, no_impact=True, **run_options)
    if with_impact.time.shape != without.time.shape or not np.array_equal(with_impact.time, without.time):
        raise AssertionError("the two variants ran on different grids")
    return Comparison(
        time=with_impact.time,
        a=with_impact.masses,
        b=without.masses,
        impact=with_impact,
        no_impact=without,
        located=(with_impact.located, without.located),
    )


def _read_masses(group) -> dict[str, dict[str, np.ndarray]]:
    masses = {}
    if "masses" not in group:
        return masses
    for name in group["masses"]:
        masses[name] = {q: group[f"masses/{name}/{q}"][()] for q in QUANTITIES if q in group[f"masses/{name}"]}
    return masses


def compare_files(path_a: str | os.PathLike[str], path_b: str | os.PathLike[str]) -> Comparison:
    """Compare two run files (two designs, two speeds) on their common grid.

    Raises
    ------
    ResultFileError
        When a file is not a camsim run file, the schemas differ, the grids differ or the
        masses differ.
    """
    from camsim.io.results import file_kind, open_h5

    with open_h5(path_a) as fa, open_h5(path_b) as fb:
        for path, f in ((path_a, fa), (path_b, fb)):
            if file_kind(f) != "run":
                raise ResultFileError(f"{path}: not a run file (file_kind {file_kind(f)!r}); compare takes two `camsim run` results")
        if int(fa.attrs["schema"]) != int(fb.attrs["schema"]):
            raise ResultFileError(f"{path_b}: schema {fb.attrs['schema']} differs from {path_a}'s {fa.attrs['schema']}")
        ta, tb = fa["time"][()], fb["time"][()]
        if ta.shape != tb.shape or not np.allclose(ta, tb, rtol=0, atol=1e-12):
            raise ResultFileError(
                f"{path_b}: time grid differs from {path_a}'s ({ta.size} samples at {_rate(ta)} vs "
                f"{tb.size} at {_rate(tb)}); rerun both with the same --cycles and --sample-rate"
            )
        a, b = _read_masses(fa), _read_masses(fb)
        if set(a) != set(b):
            raise ResultFileError(f"{path_b}: masses {sorted(b)} differ from {path_a}'s {sorted(a)}")
        from camsim.run.result import read_extremes

        return Comparison(time=ta, a=a, b=b, labels=(os.fspath(path_a), os.fspath(path_b)),
                          located=(read_extremes(fa), read_extremes(fb)))


def _rate(t: np.ndarray) -> str:
    if t.size < 2:
        return "one sample"
    return f"{1.0 / (t[1] - t[0]):.6g} Hz"


def write_file_comparison(comparison: Comparison, path_a, path_b, target) -> None:
    """Write a comparison of two run files: /impact ← A, /no_impact ← B, /difference."""
    from camsim.io.hdf5 import write_time, write_trace
    from camsim.io.outputs import writing
    from camsim.io.results import open_h5

    with writing(target, "hdf5", owner="compare") as w, w.h5() as out, open_h5(path_a) as fa, open_h5(path_b) as fb:
        for key in ("camsim_version", "schema", "machine_name", "machine_toml", "machine_sha256", "units_system"):
            if key in fa.attrs:
                out.attrs[key] = fa.attrs[key]
        out.attrs["file_kind"] = "compare"
        out.attrs["a_file"] = os.fspath(path_a)
        out.attrs["b_file"] = os.fspath(path_b)
        for name, src in (("impact", fa), ("no_impact", fb)):
            _copy_run(src, out.create_group(name, track_order=True))
        diff = out.create_group("difference", track_order=True)
        time = write_time(diff, comparison.time)
        for mass, quantities in comparison.difference.items():
            for q, data in quantities.items():
                write_trace(diff, f"masses/{mass}/{q}", data, "%", f"{q} of {mass}: 100·(A − B)/max|A|", time)


def _copy_run(src, dst) -> None:
    """Copy a run layout into ``dst``, re-attaching the time scale there.

    (HDF5 dimension scales are object references into the source file; copying the
    datasets verbatim would leave them pointing nowhere.)
    """
    from camsim.io.hdf5 import read_table, write_table, write_time, write_trace
    from camsim.io.results import list_traces, long_name_of, table_units, units_of

    traces = list_traces(src)
    time = write_time(dst, traces.pop("time")[()])
    for path, dset in traces.items():
        write_trace(dst, path, dset[()], units_of(dset), long_name_of(dset), time)
    if "cam/boundaries_deg" in src:
        dst.create_dataset("cam/boundaries_deg", data=src["cam/boundaries_deg"][()]).attrs["units"] = "deg"
    if "events" in src:
        units = table_units(src["events"])
        table = read_table(src["events"])
        write_table(dst, "events", {name: (values, units.get(name, "")) for name, values in table.items()})
    for key, value in src.attrs.items():
        if key not in ("camsim_version", "schema", "file_kind", "machine_toml", "units_system"):
            dst.attrs[key] = value

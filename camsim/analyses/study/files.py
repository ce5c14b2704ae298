"""The files of a study: HDF5 (``/study/rows``) and the same table as CSV beside it.

Layout of the HDF5 file (``file_kind = "study"``, the root attributes of every camsim
file, the machine without the sampled values):

``/study``
    attributes ``dist`` (the ``KEY=SPEC`` texts), ``correlate``, ``set``, ``limit``,
    ``output`` (the ``--output`` expressions), ``method``, ``seed``, ``n_samples``,
    ``n_runs``, ``tol_sigma``, ``sensitivity``, ``cycles``/``warmup_cycles`` (-1: the
    machine's), ``sample_rate`` (NaN: the machine's), and ``summary_json``: the ``--json``
    payload (statistics, limits, Sobol' indices) as text.
``/study/rows``
    compound table, one row per run in run order: ``run``, ``design``, ``param:<key>``
    [SI], the outputs [SI], ``status``; a ``units:<column>`` attribute per column (as
    ``/sweep/summary``), and ``columns``/``units`` attributes listing every column and
    its SI unit in order.

The CSV has one header line with the column names and the values in SI (floats written
so they read back exactly; ``nan`` where absent; ``true``/``false``). Both are written
atomically.
"""

from __future__ import annotations

import csv
import json
import math
import os
from pathlib import Path
from typing import Any


__all__ = ["csv_path_for", "write_study", "read_rows"]


def csv_path_for(path: str | os.PathLike[str]) -> Path:
    """The CSV written beside a study file: same stem, ``.csv``."""
    return Path(path).with_suffix(".csv")


def _json_text(payload: Any) -> str:
    def finite(v):
        if isinstance(v, float):
            return v if math.isfinite(v) else None
        if isinstance(v, dict):
            return {k: finite(x) for k, x in v.items()}
        if isinstance(v, (list, tuple)):
            return [finite(x) for x in v]
        return v

    return json.dumps(finite(payload), allow_nan=False, sort_keys=False)


def write_study(result, path: str | os.PathLike[str], csv_path: str | os.PathLike[str] | None = None) -> tuple[Path, Path]:
    """Write a :class:`~camsim.analyses.study.runner.StudyResult` as HDF5 and CSV, atomically.

    Returns
    -------
    (Path, Path)
        The HDF5 and CSV paths.
    """
    from camsim.io.atomic import check_writable
    from camsim.io.hdf5 import write_table
    from camsim.io.outputs import writing
    from camsim.io.hdf5 import write_root_attributes
    from camsim.analyses.sweep.files import csv_cell

    h5_path = Path(path)
    csv_target = csv_path_for(h5_path) if csv_path is None else Path(csv_path)
    check_writable(h5_path)
    check_writable(csv_target)
    frame = result.rows
    names = [c for c, _ in result.columns]
    s = result.settings
    with writing(h5_path, "hdf5", owner="study") as target, target.h5() as f:
        write_root_attributes(f, result.machine, "study")
        group = f.create_group("study", track_order=True)
        group.attrs["dist"] = [d.text for d in result.dists]
        group.attrs["correlate"] = list(result.correlate) or [""]
        group.attrs["set"] = list(result.fixed_overrides) or [""]
        group.attrs["limit"] = list(result.limit_texts) or [""]
        group.attrs["output"] = [e.text for e in s.outputs] or [""]
        group.attrs["method"] = result.method
        group.attrs["seed"] = int(result.seed)
        group.attrs["n_samples"] = int(result.n_samples)
        group.attrs["n_runs"] = int(result.n_runs)
        group.attrs["incomplete"] = bool(result.failed)  # issue 26: failed runs, no probabilities
        group.attrs["not_run"] = int(result.not_run)  # issue 35: runs lost with a worker (--resume)
        group.attrs["tol_sigma"] = float(result.dists[0].tol_sigma)
        group.attrs["sensitivity"] = result.sensitivity is not None
        group.attrs["cycles"] = -1 if s.cycles is None else int(s.cycles)
        group.attrs["warmup_cycles"] = -1 if s.warmup_cycles is None else int(s.warmup_cycles)
        group.attrs["sample_rate"] = math.nan if s.sample_rate is None else float(s.sample_rate)
        payload = result.to_json()
        payload.pop("output", None)
        payload.pop("csv", None)
        group.attrs["summary_json"] = _json_text(payload)
        cols = {name: (frame[name].to_numpy(), unit) for name, unit in result.columns}
        table = write_table(group, "rows", cols)
        table.attrs["columns"] = names
        table.attrs["units"] = [u for _, u in result.columns]
    with writing(csv_target, "csv", owner="csv") as target, target.text() as fh:
        writer = csv.writer(fh)
        writer.writerow(names)
        for row in frame.itertuples(index=False, name=None):
            writer.writerow([csv_cell(v) for v in row])
    return h5_path, csv_target


def read_rows(path: str | os.PathLike[str]):
    """The ``/study/rows`` table of a study file as a pandas DataFrame (SI), units in ``.attrs``."""
    import h5py
    import pandas as pd

    from camsim.io.hdf5 import read_table

    with h5py.File(path, "r") as f:
        dset = f["study/rows"]
        table = read_table(dset)
        units = {name: str(dset.attrs.get(f"units:{name}", "")) for name in table}
    frame = pd.DataFrame(table)
    frame.attrs["units"] = units
    return frame

"""The files of an optimisation: ``OPTIMISED.toml`` and the HDF5 history.

``OPTIMISED.toml`` is the input machine file with the optimum written in place by
:func:`camsim.analyses.fit.tomledit.edited_text` (as ``fit`` writes FITTED.toml): each value
in the unit and layout the file used, each changed line commented with the old value::

    preload = "31.7 lbf" # optimised: was "28.12 lbf"

The history (``-r HISTORY.h5``), written atomically when the job ends (while it runs, the
same path is the row store's view of the finished runs, :mod:`camsim.io.rowstore`):

``/optimize/runs``
    one row per run: ``run``, ``overrides`` (the run's ``KEY=VALUE`` lines), one column per
    expression [SI], ``status``.
``/optimize/candidates``
    one row per evaluated candidate, in order: ``candidate``, ``param:<key>`` [SI] (text
    for a choice), ``objective:<expr>`` [SI] (worst over the speeds), for each constraint
    and speed ``constraint:<expr>@<speed>rpm`` (value [SI]; with --robust the mean) and
    ``g:<expr>@<speed>rpm`` (the solver's scaled value, ≤ 0 satisfied; with --robust the
    normal-tail quantile margin) and, with --robust, ``probability:<expr>@<speed>rpm``,
    then ``feasible``, ``violation``, ``status``.
``/optimize/front``
    the Pareto front (``method="pareto"``): ``param:<key>`` and ``objective:<expr>``.
Attributes of ``/optimize``: ``status``, ``method``, ``seed``, ``budget``,
``evaluations``, ``runs``, ``json`` (the ``--json`` payload).
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np

__all__ = ["optimised_text", "write_optimised", "write_history"]

_RPM = 60.0 / (2.0 * math.pi)


def optimised_text(result) -> str:
    """The machine file with the optimum of ``result`` written in place (module docstring)."""
    from camsim.analyses.fit.tomledit import edited_text

    p = result.problem
    entries = []
    best = result.best

    def note(was, shown, shown_unit):
        return f"optimised: {was}"

    for v in p.variables:
        value = best.values[v.key]
        if v.is_choice:
            if value == v.initial:
                continue
            entries.append((v.key, value, "", v.initial, note))
        else:
            if float(value) == float(v.initial):
                continue
            entries.append((v.key, float(value), v.unit, float(v.initial), note))
    if p.absorb is not None:
        entries.append((p.absorb, float(best.values[p.absorb]), "rad", p.absorb_initial, note))
    return edited_text(result.source_text, entries, result.source_name or "<string>", "optimised")


def write_optimised(result, path: Path) -> Path:
    """Write :func:`optimised_text` atomically."""
    from camsim.io.outputs import writing

    content = optimised_text(result)
    with writing(path, "toml", owner="optimize") as target:
        target.put_text(content)
    return path


def _speed_tag(speed) -> str:
    return "" if speed is None else f"@{speed * _RPM:.6g}rpm"


def _table(f, name: str, columns: list[tuple[str, list, str]]) -> None:
    import h5py

    n = len(columns[0][1]) if columns else 0
    dtypes, arrays = [], []
    for cname, values, _ in columns:
        if any(isinstance(v, str) for v in values):
            arr = np.array([str(v) for v in values], dtype=object)
            dtypes.append((cname, h5py.string_dtype("utf-8")))
        elif all(isinstance(v, (bool, np.bool_)) for v in values) and values:
            arr = np.array(values, dtype=bool)
            dtypes.append((cname, bool))
        else:
            arr = np.array([math.nan if v is None else float(v) for v in values], dtype=np.float64)
            dtypes.append((cname, np.float64))
        arrays.append(arr)
    data = np.empty(n, dtype=dtypes)
    for (cname, _), arr in zip(dtypes, arrays):
        data[cname] = arr
    d = f.create_dataset(name, data=data)
    for cname, _, unit in columns:
        d.attrs[f"units:{cname}"] = unit


def write_history(result, path: Path, runs: dict[int, dict]) -> Path:
    """The history file (module docstring), written atomically over the row store's view."""
    from camsim.io.hdf5 import write_root_attributes
    from camsim.io.outputs import writing

    p = result.problem
    cands = result.candidates
    cols: list[tuple[str, list, str]] = [("candidate", [c.index for c in cands], "")]
    for v in p.variables:
        cols.append((f"param:{v.key}", [c.values.get(v.key) for c in cands], v.unit))
    if p.absorb is not None:
        cols.append((f"param:{p.absorb}", [c.values.get(p.absorb) for c in cands], "rad"))
    for k, g in enumerate(p.goals):
        cols.append((f"objective:{g.text}", [c.objectives[k] for c in cands], g.unit))
    for si, speed in enumerate(p.speeds):
        tag = _speed_tag(speed)
        for ci, con in enumerate(p.constraints):
            def pick(c, field):
                if not c.per_speed:
                    return math.nan
                return c.per_speed[si]["constraints"][ci].get(field, math.nan)

            cols.append((f"constraint:{con.text}{tag}", [pick(c, "value") for c in cands], con.unit))
            offset = (1 if p.absorb else 0) + si * len(p.constraints) + ci
            cols.append((f"g:{con.text}{tag}", [float(c.g[offset]) if c.g.size > offset else math.nan for c in cands], ""))
            if p.robust:
                cols.append((f"probability:{con.text}{tag}", [pick(c, "probability") for c in cands], ""))
    cols += [("feasible", [bool(c.feasible) for c in cands], ""), ("violation", [c.violation for c in cands], ""),
             ("status", [c.status for c in cands], "")]
    run_rows = [runs[i] for i in sorted(runs)]
    run_names = [n for n, _ in [("run", ""), ("overrides", "")]] + [e.text for e in p.run_exprs] + ["status"]
    run_cols = [(n, [r.get(n, math.nan if n not in ("overrides", "status") else "") for r in run_rows],
                 result.units.get(n, "")) for n in run_names]
    with writing(path, "hdf5", owner="optimize") as target, target.h5() as f:
        write_root_attributes(f, p.base, "optimize")
        g = f.create_group("optimize", track_order=True)
        g.attrs["status"] = result.status
        g.attrs["method"] = result.method
        g.attrs["seed"] = result.seed
        g.attrs["budget"] = result.budget
        g.attrs["evaluations"] = len(cands)
        g.attrs["runs"] = result.runs
        g.attrs["json"] = json.dumps(result.to_json(), default=str)
        if run_rows:
            _table(f, "optimize/runs", run_cols)
        if cands:
            _table(f, "optimize/candidates", cols)
        if result.front:
            fcols = [(f"param:{v.key}", [c.values.get(v.key) for c in result.front], v.unit) for v in p.variables]
            fcols += [(f"objective:{g.text}", [c.objectives[k] for c in result.front], g.unit) for k, g in enumerate(p.goals)]
            _table(f, "optimize/front", fcols)
    return path

"""What a study records of each run: the summary scalars and ``--output`` reductions.

Every run contributes the flat summary of its result (whatever scalars the run result
provides: peak displacement/velocity/acceleration of each mass, peak transducer force,
min/max cam contact force, jump flag, number of impacts, ..., and peak Hertz stress or
torque where the machine has them), read through :func:`run_scalars`, plus one column per
``--output EXPR``.

``EXPR`` is ``REDUCER:PATH``:

* ``REDUCER`` is ``max``, ``min`` (signed extremes), ``rms`` (root mean square) or
  ``mean`` of the recorded samples;
* ``PATH`` names a trace of the result layout: ``masses/<mass>/displacement|velocity|
  acceleration``, ``elements/<element>/force``, ``transducer/force``,
  ``cam_contact/force``, ``cam/displacement|velocity|acceleration|jerk``.

e.g. ``max:masses/M3/acceleration``, ``rms:transducer/force``. The column is named by
the expression and has the trace's SI unit.

:func:`run_scalars`, :func:`run_trace` and :func:`run_unit` are the only places that
read a run result (:class:`camsim.run.result.RunResult`), so a change of the result object is
a change here alone.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from typing import Any

import numpy as np

from camsim.errors import InputError

__all__ = ["REDUCERS", "OutputExpr", "parse_output", "run_scalars", "run_trace", "run_unit", "scalar_unit", "trace_unit"]

#: Reductions of a trace to one number.
REDUCERS = ("max", "min", "rms", "mean")

_TRACE_UNITS = {"displacement": "m", "velocity": "m/s", "acceleration": "m/s^2", "jerk": "m/s^3", "force": "N"}


def run_scalars(result: Any) -> dict[str, Any]:
    """The flat scalar summary of one run [SI] (:meth:`camsim.run.result.RunResult.scalars`)."""
    row = dict(result.scalars())
    row.pop("status", None)
    return row


def run_trace(result: Any, path: str) -> np.ndarray:
    """The SI samples of the trace at ``path`` of one run (KeyError if it has none)."""
    return np.asarray(result.trace(path), dtype=float)


def run_unit(result: Any, name: str) -> str:
    """SI unit of a scalar or trace of the run (by its name or path); '' if unknown."""
    try:
        return str(result.units(name))
    except KeyError:
        return scalar_unit(name)


#: SI units of the summary scalars, by name (``peak_<quantity>:<mass>`` by its quantity).
_SCALAR_UNITS = {
    "peak_transducer_force": "N",
    "max_cam_contact_force": "N",
    "min_cam_contact_force": "N",
    "max_impact_velocity": "m/s",
    "jump": "",
    "impacts": "",
    "periodicity_residual": "",
}


def scalar_unit(name: str) -> str:
    """SI unit of a summary scalar guessed from its name (for scalars the run does not describe)."""
    if name in _SCALAR_UNITS:
        return _SCALAR_UNITS[name]
    head = name.split(":", 1)[0]
    if head.startswith("peak_") and head[5:] in _TRACE_UNITS:
        return _TRACE_UNITS[head[5:]]
    lowered = head.lower()
    for word, unit in (("stress", "Pa"), ("pressure", "Pa"), ("torque", "N*m"), ("power", "W"), ("force", "N"),
                       ("acceleration", "m/s^2"), ("velocity", "m/s"), ("displacement", "m"), ("angle", "rad")):
        if word in lowered:
            return unit
    return ""


def trace_unit(path: str) -> str:
    """SI unit of the trace at ``path`` guessed from its last part."""
    return _TRACE_UNITS.get(path.strip("/").rsplit("/", 1)[-1], "")


@dataclass(frozen=True)
class OutputExpr:
    """``REDUCER:PATH``: one number per run from one trace."""

    text: str
    reducer: str
    path: str

    @property
    def unit(self) -> str:
        """SI unit of the column."""
        return trace_unit(self.path)

    def evaluate(self, result: Any) -> float:
        """The reduced value of this run [SI] (KeyError if the run has no such trace)."""
        x = run_trace(result, self.path)
        if x.size == 0:
            return float("nan")
        if self.reducer == "max":
            return float(np.max(x))
        if self.reducer == "min":
            return float(np.min(x))
        if self.reducer == "rms":
            return float(np.sqrt(np.mean(x * x)))
        return float(np.mean(x))


_EXPR = re.compile(r"^\s*([a-z]+)\s*:\s*([A-Za-z0-9_\-./]+)\s*$")


def parse_output(text: str) -> OutputExpr:
    """Parse ``REDUCER:PATH`` (syntax only; whether the run has the trace is checked on a run)."""
    m = _EXPR.match(text)
    if not m:
        raise InputError(f"--output {text}: expected REDUCER:PATH, e.g. max:masses/M3/acceleration (REDUCER one of {', '.join(REDUCERS)})")
    reducer, path = m.groups()
    if reducer not in REDUCERS:
        raise InputError(f"--output {text}: unknown reduction '{reducer}' (one of {', '.join(REDUCERS)})")
    return OutputExpr(text=f"{reducer}:{path.strip('/')}", reducer=reducer, path=path.strip("/"))

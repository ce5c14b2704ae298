"""What a study records of each run: the summary scalars and ``--output`` reductions.

Every run contributes the flat summary of its result (whatever scalars the run result
provides: peak displacement/velocity/acceleration of each mass, peak transducer force,
min/max cam contact force, jump flag, number of impacts, ..., and peak Hertz stress or
torque where the machine has them), read through :func:`run_scalars`, plus one column per
``--output EXPR``.

``EXPR`` is ``REDUCER:PATH[@FROM:TO[UNIT]]``:

* ``REDUCER`` is ``max``, ``min`` (signed extremes), ``maxabs`` (largest magnitude),
  ``rms`` (root mean square), ``mean`` or ``ptp`` (peak to peak) of the recorded samples;
* ``PATH`` names a trace of the result layout: ``masses/<mass>/displacement|velocity|
  acceleration``, ``elements/<element>/force``, ``transducer/force``,
  ``cam_contact/force``, ``cam/displacement|velocity|acceleration|jerk``.

* ``@FROM:TO`` (optional) keeps only the samples whose cam angle (modulo 360°) lies in
  [FROM, TO]; degrees unless a unit is written (``@140:180deg``, ``@2.4:3.1rad``); both ends
  within 0–360°, FROM < TO.

e.g. ``max:masses/M3/acceleration``, ``rms:transducer/force``,
``rms:masses/M3/acceleration@140:180deg`` (the residual vibration in that dwell). The
column is named by the expression and has the trace's SI unit.

The objective and constraints of ``camsim optimize`` use the same grammar
(:func:`parse_expression`), which also accepts a run scalar by name
(``peak_transducer_force``) and ``param:KEY`` (the value of an optimised machine key).

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

__all__ = ["REDUCERS", "OutputExpr", "ScalarExpr", "ParamExpr", "parse_expression", "parse_output", "run_scalars", "run_trace", "run_unit", "scalar_unit", "trace_unit"]

#: Reductions of a trace to one number.
REDUCERS = ("max", "min", "maxabs", "rms", "mean", "ptp")

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
    """``REDUCER:PATH[@FROM:TO]``: one number per run from one trace.

    Attributes
    ----------
    window : tuple of float or None
        Cam-angle window [deg] (FROM, TO) within 0–360, or None for every sample.
    """

    text: str
    reducer: str
    path: str
    window: tuple[float, float] | None = None

    @property
    def unit(self) -> str:
        """SI unit of the column."""
        return trace_unit(self.path)

    def evaluate(self, result: Any) -> float:
        """The reduced value of this run [SI] (KeyError if the run has no such trace)."""
        x = run_trace(result, self.path)
        if self.window is not None:
            angle = np.mod(run_trace(result, "cam/angle"), 360.0)
            lo, hi = self.window
            x = x[(angle >= lo) & (angle <= hi)]
        if x.size == 0:
            return float("nan")
        if self.reducer == "max":
            return float(np.max(x))
        if self.reducer == "min":
            return float(np.min(x))
        if self.reducer == "maxabs":
            return float(np.max(np.abs(x)))
        if self.reducer == "ptp":
            return float(np.ptp(x))
        if self.reducer == "rms":
            return float(np.sqrt(np.mean(x * x)))
        return float(np.mean(x))


@dataclass(frozen=True)
class ScalarExpr:
    """A run scalar by name (:meth:`camsim.run.result.RunResult.scalars`), e.g. ``peak_transducer_force``."""

    text: str

    @property
    def unit(self) -> str:
        return scalar_unit(self.text)

    def evaluate(self, result: Any) -> float:
        """The scalar of this run [SI] (KeyError if the run has none of that name)."""
        value = run_scalars(result)[self.text]
        return float("nan") if value is None else float(value)


@dataclass(frozen=True)
class ParamExpr:
    """``param:KEY``: the value of a machine key that an optimisation varies [SI]."""

    text: str
    key: str


_EXPR = re.compile(r"^\s*([a-z]+)\s*:\s*([A-Za-z0-9_\-./]+)\s*(?:@\s*(.+?)\s*)?$")
_WINDOW = re.compile(r"^([-+]?(?:\d+(?:\.\d*)?|\.\d+)(?:[eE][-+]?\d+)?)\s*:\s*([-+]?(?:\d+(?:\.\d*)?|\.\d+)(?:[eE][-+]?\d+)?)\s*([A-Za-z]*)$")
_NAME = re.compile(r"^[A-Za-z_][\w:.\-]*$")


def _parse_window(text: str, where: str) -> tuple[float, float]:
    m = _WINDOW.match(text.strip())
    if not m:
        raise InputError(f"{where}: window '@{text}' must be @FROM:TO[UNIT], e.g. @140:180deg")
    lo, hi, unit = float(m.group(1)), float(m.group(2)), (m.group(3) or "deg").lower()
    if unit in ("rad", "radian", "radians"):
        lo, hi = np.degrees(lo), np.degrees(hi)
    elif unit not in ("deg", "degree", "degrees"):
        raise InputError(f"{where}: window unit '{m.group(3)}' is not an angle (deg or rad)")
    if not (0.0 <= lo < hi <= 360.0 + 1e-9):
        raise InputError(f"{where}: window {text} must lie within 0-360 deg with FROM < TO")
    return float(lo), float(min(hi, 360.0))


def parse_output(text: str, option: str = "--reduce") -> OutputExpr:
    """Parse ``REDUCER:PATH[@FROM:TO]`` (syntax only; whether the run has the trace is checked on a run)."""
    where = f"{option} {text}"
    m = _EXPR.match(text)
    if not m:
        raise InputError(f"{where}: expected REDUCER:PATH[@FROM:TO], e.g. max:masses/M3/acceleration (REDUCER one of {', '.join(REDUCERS)})")
    reducer, path, window = m.groups()
    if reducer not in REDUCERS:
        raise InputError(f"{where}: unknown reduction '{reducer}' (one of {', '.join(REDUCERS)})")
    path = path.strip("/")
    win = _parse_window(window, where) if window else None
    name = f"{reducer}:{path}" + (f"@{win[0]:g}:{win[1]:g}deg" if win else "")
    return OutputExpr(text=name, reducer=reducer, path=path, window=win)


def parse_expression(text: str, option: str = "--minimize") -> OutputExpr | ScalarExpr | ParamExpr:
    """Parse an expression of the shared grammar: ``param:KEY``, ``REDUCER:PATH[@FROM:TO]`` or a scalar name.

    Syntax only: whether the scalar, trace or key exists is checked against a run (or the
    optimised keys) by the caller, which can list what exists.
    """
    text = text.strip()
    head, sep, rest = text.partition(":")
    if sep and head == "param":
        if not rest.strip():
            raise InputError(f"{option} {text}: param: needs a machine key, e.g. param:cam.speed")
        return ParamExpr(text=f"param:{rest.strip()}", key=rest.strip())
    if sep and "/" in rest or (sep and head in REDUCERS):
        return parse_output(text, option)
    if sep and re.match(r"^[a-z]+$", head) and "/" not in head and "@" in text:
        return parse_output(text, option)
    if not _NAME.match(text):
        raise InputError(f"{option} {text}: expected a run scalar (e.g. peak_transducer_force), REDUCER:PATH[@FROM:TO] or param:KEY")
    return ScalarExpr(text=text)

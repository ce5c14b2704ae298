"""Fitted parameters for ``camsim fit``: ``KEY=LOW:HIGH[UNIT]`` with an optional start.

A parameter is any numeric machine key of the ``--set`` grammar (``docs/machine-file.md``):
``element.K23.push_stiffness``, ``element.seat.damping_ratio``, ``mass.M3.mass``,
``element.K23.preload``, ``element.seat.gap``, ``element.seat.coefficient``,
``element.seat.restitution``, ``cam.speed``... Its bounds (and start) are written

    KEY=LOW:HIGH[UNIT]          e.g.  element.K23.push_stiffness=6000:10000lbf/in
    KEY=LOW:HIGH:START[UNIT]    e.g.  element.seat.damping_ratio=0.01:0.2:0.05

The unit written after the last number applies to every bare number; a number may carry
its own unit (``6000lbf/in:1.8e6N/m``). A bare number without any unit is SI, as in the
machine file. Bounds and start are turned into SI by the loader itself (each value is
loaded as an override of the machine, so it gets the machine file's unit and range
checks). Without START the machine file's own value is the start.

Parameters named with ``log`` are searched on a logarithmic scale (for values spanning
decades); their bounds must be positive.
"""

from __future__ import annotations

import math
import re
from collections.abc import Sequence
from dataclasses import dataclass

from camsim.errors import InputError, MachineFileError

__all__ = ["Parameter", "parse_param", "resolve_params", "override_text", "si_unit"]

_NUMBER = re.compile(r"^\s*([-+]?(?:\d+(?:\.\d*)?|\.\d+)(?:[eE][-+]?\d+)?)\s*(.*?)\s*$")


@dataclass(frozen=True)
class Parameter:
    """One fitted machine key, in SI.

    Attributes
    ----------
    key : str
        The key in the ``--set`` grammar.
    low, high : float
        Bounds [SI unit of the key].
    start : float
        Starting value [SI].
    log : bool
        Searched on a log scale.
    unit : str
        SI unit of the key (``""`` for a number).
    initial : float
        The machine file's value before the fit [SI] (what ``FITTED.toml`` replaces).
    """

    key: str
    low: float
    high: float
    start: float
    log: bool
    unit: str
    initial: float

    def to_unit(self, value: float) -> float:
        """Optimiser coordinate in [0, 1] of ``value`` (linear or log between the bounds)."""
        if self.log:
            return (math.log(value) - math.log(self.low)) / (math.log(self.high) - math.log(self.low))
        return (value - self.low) / (self.high - self.low)

    def from_unit(self, u: float) -> float:
        """Value [SI] at optimiser coordinate ``u``."""
        if self.log:
            return math.exp(math.log(self.low) + u * (math.log(self.high) - math.log(self.low)))
        return self.low + u * (self.high - self.low)


def parse_param(text: str) -> tuple[str, list[str]]:
    """Split ``KEY=LOW:HIGH[:START][UNIT]`` into the key and 2 or 3 value texts.

    Returns
    -------
    key : str
    values : list of str
        Texts for the loader: ``"6000 lbf/in"``, or a bare number (SI).

    Raises
    ------
    InputError
        Malformed text.
    """
    where = f"--param {text}"
    key, sep, spec = text.partition("=")
    key = key.strip()
    if not sep or not key:
        raise InputError(f"{where}: expected KEY=LOW:HIGH[UNIT] or KEY=LOW:HIGH:START[UNIT], e.g. element.K23.push_stiffness=6000:10000lbf/in")
    parts = spec.split(":")
    if len(parts) not in (2, 3):
        raise InputError(f"{where}: expected LOW:HIGH[UNIT] or LOW:HIGH:START[UNIT] after '='")
    split = []
    for p in parts:
        m = _NUMBER.match(p)
        if not m:
            raise InputError(f"{where}: '{p.strip()}' is not a number (with an optional unit)")
        split.append((m.group(1), m.group(2)))
    last_unit = split[-1][1]
    return key, [f"{n} {u or last_unit}".strip() for n, u in split]


def si_unit(machine, key: str) -> str:
    """SI unit of ``key`` in ``machine`` (``N/m^a`` for a power-law coefficient)."""
    from camsim.analyses.sweep.runner import key_unit

    leaf = key.rsplit(".", 1)[-1]
    if leaf == "duration" and key.startswith("cam."):
        return "rad"
    return key_unit(key, machine)


def override_text(key: str, value: str | float) -> str:
    """The ``KEY=VALUE`` override that sets ``key`` to a value text or an SI float (an angle
    carries ``rad``: a bare angle is read in degrees)."""
    if isinstance(value, float):
        from camsim.machine.keys import unit

        if unit(key) == "rad":
            return f'{key}="{value!r} rad"'
        return f"{key}={value!r}"
    number = _NUMBER.match(value)
    if number and not number.group(2):
        return f"{key}={number.group(1)}"
    return f'{key}="{value}"'


def _si_value(source, fixed: Sequence[str], key: str, text: str, where: str) -> float:
    from camsim.analyses.sweep.runner import machine_value

    try:
        machine = source.load(list(fixed) + [override_text(key, text)])
    except MachineFileError as exc:
        message = exc.message
        cut = message.find(" (value from --set")
        if cut >= 0:
            message = message[:cut]
        raise InputError(f"{where}: {exc.file}: {exc.key}: {message}") from None
    value = machine_value(machine, key)
    if not isinstance(value, float) or isinstance(value, bool):
        raise InputError(f"{where}: {key} is not a continuous number in the machine and cannot be fitted")
    return value


def resolve_params(source, fixed: Sequence[str], specs: Sequence[str], log_keys: Sequence[str] = ()) -> list[Parameter]:
    """Check every ``--param`` against the machine and turn it into SI.

    Parameters
    ----------
    source : camsim.analyses.sweep.runner.MachineSource
        The machine file.
    fixed : sequence of str
        ``--set`` overrides applied before the fitted values.
    specs : sequence of str
        ``KEY=LOW:HIGH[:START][UNIT]`` texts.
    log_keys : sequence of str
        Keys to search on a log scale (each must be one of the ``specs``' keys).

    Returns
    -------
    list of Parameter

    Raises
    ------
    InputError
        Malformed text; a key the machine does not have or that is not a number; a key
        given twice; a value the loader rejects; empty bounds (LOW ≥ HIGH); a start
        outside the bounds; a log parameter whose bounds are not positive; a ``--log``
        key that is not a ``--param``.
    """
    from camsim.analyses.sweep.runner import machine_value

    if not specs:
        raise InputError("--param: give at least one parameter to fit, e.g. --param element.K23.push_stiffness=6000:10000lbf/in")
    base = source.load(list(fixed))
    out: list[Parameter] = []
    keys = []
    for text in specs:
        where = f"--param {text}"
        key, values = parse_param(text)
        if key in keys:
            raise InputError(f"{where}: key {key} is given twice")
        keys.append(key)
        current = machine_value(base, key)
        if current is None and key.startswith("initial.") and key.count(".") == 2:
            # A free mass without an [initial.<mass>] entry starts in static equilibrium, at
            # rest (docs/machine-file.md): its velocity is 0 there; a displacement has no
            # number to start from, so it needs START (issue 26: documented as fittable).
            _si_value(source, fixed, key, values[0], where)  # the loader checks the key and mass
            if len(values) == 3:
                current = _si_value(source, fixed, key, values[2], where)
            elif key.endswith(".velocity"):
                current = 0.0
            else:
                raise InputError(f"{where}: {key}: the machine starts this mass in static equilibrium (no number); "
                                 "give a start: KEY=LOW:HIGH:START[UNIT]")
        if current is None:
            # let the loader name the problem (unknown key, no such element, with a suggestion)
            _si_value(source, fixed, key, values[0], where)
            raise InputError(f"{where}: {key}: not a value of this machine")
        if isinstance(current, bool) or not isinstance(current, (int, float)):
            raise InputError(f"{where}: {key} is {current!r}, not a continuous number; it cannot be fitted")
        if isinstance(current, int):
            raise InputError(f"{where}: {key} is an integer setting, not a continuous parameter; it cannot be fitted")
        low = _si_value(source, fixed, key, values[0], where)
        high = _si_value(source, fixed, key, values[1], where)
        unit = si_unit(base, key)
        # Quantities with their SI unit: the command prints them in the file's units (issue 44: "(SI)").
        q = lambda v: f"{v:.6g} {unit}".rstrip() if unit != "rad" else f"{math.degrees(v):.6g} deg"  # noqa: E731
        if not low < high:
            raise InputError(f"{where}: empty bounds: LOW ({q(low)}) must be below HIGH ({q(high)})")
        start = _si_value(source, fixed, key, values[2], where) if len(values) == 3 else float(current)
        if not low <= start <= high:
            what = "START" if len(values) == 3 else f"the machine file's value of {key}"
            raise InputError(f"{where}: the bounds {q(low)} to {q(high)} exclude {what} ({q(start)})")
        # A fitted value travels to the loader as a bare SI number: check that it means SI.
        probe = _si_value(source, fixed, key, f"{start!r} rad" if unit == "rad" else repr(start), where)
        if not math.isclose(probe, start, rel_tol=1e-12, abs_tol=1e-300):
            raise InputError(f"{where}: {key}: a bare number is not read in SI for this key; it cannot be fitted")
        out.append(Parameter(key=key, low=low, high=high, start=start, log=False, unit=unit, initial=float(current)))
    for k in log_keys:
        if k not in keys:
            raise InputError(f"--log {k}: not one of the --param keys ({', '.join(keys)})")
    final = []
    for p in out:
        if p.key in log_keys:
            if p.low <= 0:
                raise InputError(f"--log {p.key}: a log-scale parameter needs positive bounds (LOW is {p.low:.6g})")
            p = Parameter(p.key, p.low, p.high, p.start, True, p.unit, p.initial)
        final.append(p)
    return final

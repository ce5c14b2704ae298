"""The optimisation problem: variables, objective(s), constraints, speeds, robustness.

Everything the command line gives is parsed and checked here, against the machine,
before any run is made, so bad input is one :class:`~camsim.errors.InputError` line and
nothing is written:

* ``--var KEY=LOW:HIGH[:START][UNIT]`` (``--log KEY`` for decades): a continuous machine
  key of the ``--set`` grammar (:mod:`camsim.machine.overrides`), its bounds converted to
  SI with the loader's own checks (:func:`camsim.analyses.fit.params.parse_param`);
* ``--choice KEY=a,b,c``: a categorical key (a segment's law, ...), each option checked
  by loading the machine with it;
* ``--absorb cam.segments[i].duration``: that segment takes up whatever the other segment
  durations leave of 360°; a candidate for which it would be ≤ 0 is infeasible (a
  constraint that needs no run), never a crash;
* objective and constraints use the expression grammar shared with ``study --output``
  (:func:`camsim.analyses.study.outputs.parse_expression`); a constraint is
  ``EXPR<=VALUE[UNIT]`` or ``EXPR>=VALUE[UNIT]``;
* ``--speeds FROM:TO:STEP[UNIT]`` (or one speed, or a comma list): every candidate runs at
  each speed; the objective is its worst value over them and each constraint must hold at
  each.
"""

from __future__ import annotations

import math
import re
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from camsim.errors import InputError, MachineFileError
from camsim.analyses.study.outputs import OutputExpr, ParamExpr, ScalarExpr, parse_expression

__all__ = [
    "Variable",
    "Goal",
    "Constraint",
    "Problem",
    "parse_var",
    "parse_choice",
    "parse_constraint",
    "parse_speeds",
    "build_problem",
]

_RPM = 2.0 * math.pi / 60.0  # rpm -> rad/s
_NUMBER = re.compile(r"^\s*([-+]?(?:\d+(?:\.\d*)?|\.\d+)(?:[eE][-+]?\d+)?)\s*(.*?)\s*$")
_CONSTRAINT = re.compile(r"^\s*(.+?)\s*(<=|>=|<|>)\s*([-+]?(?:\d|\.\d).*?)\s*$")


@dataclass(frozen=True)
class Variable:
    """One optimised machine key.

    Attributes
    ----------
    key : str
        Key of the ``--set`` grammar.
    low, high : float
        Bounds [SI] (continuous); 0 and n - 1 for a choice.
    start : float or str
        Starting value [SI] (the file's, or START), or the file's choice.
    log : bool
        Searched on a log scale between the bounds.
    unit : str
        SI unit of the key.
    initial : float or str
        The machine file's value (what ``OPTIMISED.toml`` replaces).
    choices : tuple of str, optional
        The options of a categorical key (None: continuous).
    """

    key: str
    low: float
    high: float
    start: Any
    log: bool
    unit: str
    initial: Any
    choices: tuple[str, ...] | None = None

    @property
    def is_choice(self) -> bool:
        return self.choices is not None

    def from_unit(self, u: float) -> Any:
        """The value at solver coordinate ``u``: [0, 1] between the bounds, or the option index."""
        if self.choices is not None:
            return self.choices[int(min(max(round(float(u)), 0), len(self.choices) - 1))]
        u = min(max(float(u), 0.0), 1.0)
        if self.log:
            return math.exp(math.log(self.low) + u * (math.log(self.high) - math.log(self.low)))
        return self.low + u * (self.high - self.low)

    def to_unit(self, value: Any) -> float:
        """Solver coordinate of ``value``."""
        if self.choices is not None:
            return float(self.choices.index(value)) if value in self.choices else 0.0
        if self.log:
            return (math.log(value) - math.log(self.low)) / (math.log(self.high) - math.log(self.low))
        return (float(value) - self.low) / (self.high - self.low)

    def assignment(self, value: Any) -> str:
        """The ``KEY=VALUE`` override of ``value`` (SI floats written exactly)."""
        if self.choices is not None:
            return f'{self.key}="{value}"'
        return assignment(self.key, float(value), self.unit)


@dataclass(frozen=True)
class Goal:
    """An objective: an expression and its sense."""

    expr: Any
    sense: str  # "min" or "max"
    unit: str = ""

    @property
    def text(self) -> str:
        return self.expr.text


@dataclass(frozen=True)
class Constraint:
    """``EXPR<=LIMIT`` or ``EXPR>=LIMIT`` (limit in the expression's SI unit)."""

    text: str
    expr: Any
    op: str  # "<=" or ">="
    limit: float
    unit: str = ""

    def margin(self, value: float) -> float:
        """Signed distance to the limit, ≤ 0 when satisfied [SI]."""
        return value - self.limit if self.op == "<=" else self.limit - value


@dataclass
class Problem:
    """The parsed problem (SI)."""

    variables: list[Variable]
    goals: list[Goal]
    constraints: list[Constraint]
    speeds: list[float | None]  # rad/s; [None]: the machine's own speed
    absorb: str | None = None
    absorb_initial: float = math.nan
    absorb_others: dict[str, float] = field(default_factory=dict)  # duration keys -> SI value in the file
    robust: bool = False
    base: Any = None  # the machine with --set applied
    param_keys: list[str] = field(default_factory=list)

    @property
    def run_exprs(self) -> list[Any]:
        """Expressions that need a run (not ``param:``), each once."""
        out: dict[str, Any] = {}
        for e in [g.expr for g in self.goals] + [c.expr for c in self.constraints]:
            if not isinstance(e, ParamExpr):
                out.setdefault(e.text, e)
        return list(out.values())

    def absorbed(self, values: dict[str, Any]) -> float | None:
        """The absorbing segment's duration [rad] for the candidate's ``values`` (None: no --absorb)."""
        if self.absorb is None:
            return None
        total = sum(float(values.get(k, v)) for k, v in self.absorb_others.items())
        return 2.0 * math.pi - total


def assignment(key: str, value: float, unit: str = "") -> str:
    """``KEY=VALUE`` for an SI value: a bare number, except angles (a bare segment duration is
    read in degrees), which carry ``rad``."""
    if unit == "rad" or re.match(r"^cam\.segments\[\d+\]\.duration$", key):
        return f'{key}="{float(value)!r} rad"'
    return f"{key}={float(value)!r}"


# --------------------------------------------------------------------------------------
# Parsing
# --------------------------------------------------------------------------------------
def _load_error(exc: MachineFileError, where: str) -> InputError:
    message = exc.message
    cut = message.find(" (value from --set")
    if cut >= 0:
        message = message[:cut]
    return InputError(f"{where}: {exc.file}: {exc.key}: {message}")


def parse_var(source, fixed: Sequence[str], text: str, log: bool, base, absorb: str | None = None) -> Variable:
    """``KEY=LOW:HIGH[:START][UNIT]`` checked against the machine (see the module docstring).

    With ``absorb``, a segment duration is checked with the absorbing segment taking up the
    difference (alone it would break the 360° total).
    """
    from camsim.analyses.fit.params import _si_value as _fit_si_value
    from camsim.analyses.fit.params import parse_param, si_unit
    from camsim.analyses.sweep.runner import machine_value

    where = f"--var {text}"

    def _si_value(source, fixed, key, value_text, where):
        if absorb is None or not re.match(r"^cam\.segments\[\d+\]\.duration$", key):
            return _fit_si_value(source, fixed, key, value_text, where)
        from camsim.analyses.study.distributions import _to_si

        n = _NUMBER.match(value_text)
        if not n:
            raise InputError(f"{where}: '{value_text}' is not a number (with an optional unit)")
        value = _to_si(float(n.group(1)), n.group(2).replace(" ", ""), "rad", where)
        old, rest = float(machine_value(base, key)), float(machine_value(base, absorb))
        if rest + old - value > 0:
            try:
                source.load(list(fixed) + [assignment(key, value), assignment(absorb, rest + old - value)])
            except MachineFileError as exc:
                raise _load_error(exc, where) from None
        return value

    try:
        key, values = parse_param(text)
    except InputError as exc:
        raise InputError(str(exc).replace(f"--param {text}", where).replace("--param", "--var")) from None
    current = machine_value(base, key)
    if current is None:
        _si_value(source, fixed, key, values[0], where)  # the loader names the problem
        raise InputError(f"{where}: {key}: not a value of this machine")
    if isinstance(current, bool) or not isinstance(current, (int, float)) or isinstance(current, int):
        raise InputError(f"{where}: {key} is {current!r}, not a continuous number (use --choice for a setting)")
    low = _si_value(source, fixed, key, values[0], where)
    high = _si_value(source, fixed, key, values[1], where)
    if not low < high:
        raise InputError(f"{where}: empty bounds: LOW ({low:.6g}) must be below HIGH ({high:.6g}) in SI")
    start = float(current)
    if len(values) == 3:
        start = _si_value(source, fixed, key, values[2], where)
        if not low <= start <= high:
            raise InputError(f"{where}: START ({start:.6g}) lies outside the bounds [{low:.6g}, {high:.6g}] (SI)")
    angle = si_unit(base, key) == "rad"  # a bare angle is read in degrees: probe with its unit
    probe = _si_value(source, fixed, key, f"{start!r} rad" if angle else repr(start), where) \
        if not key.startswith("cam.segments") else start
    if not math.isclose(probe, start, rel_tol=1e-12, abs_tol=1e-300):
        raise InputError(f"{where}: {key}: a bare number is not read in SI for this key; it cannot be optimised")
    if log and low <= 0:
        raise InputError(f"--log {key}: a log-scale variable needs positive bounds (LOW is {low:.6g})")
    return Variable(key=key, low=low, high=high, start=start, log=log, unit=si_unit(base, key), initial=float(current))


def parse_choice(source, fixed: Sequence[str], text: str, base) -> Variable:
    """``KEY=a,b,c``: each option loaded once to check it."""
    from camsim.analyses.sweep.runner import machine_value

    where = f"--choice {text}"
    key, sep, rest = text.partition("=")
    key = key.strip()
    options = tuple(o.strip().strip('"') for o in rest.split(",") if o.strip())
    if not sep or not key or len(options) < 2:
        raise InputError(f"{where}: expected KEY=a,b[,c...] with at least two options")
    if len(set(options)) != len(options):
        raise InputError(f"{where}: an option is given twice")
    for o in options:
        try:
            source.load(list(fixed) + [f'{key}="{o}"'])
        except MachineFileError as exc:
            raise _load_error(exc, where) from None
    current = machine_value(base, key)
    initial = current if isinstance(current, str) else options[0]
    start = initial if initial in options else options[0]
    return Variable(key=key, low=0.0, high=float(len(options) - 1), start=start, log=False, unit="",
                    initial=initial, choices=options)


def parse_constraint(text: str, units: dict[str, str], option: str = "--constraint") -> Constraint:
    """``EXPR<=VALUE[UNIT]`` / ``EXPR>=VALUE[UNIT]``; ``units``: expression text -> SI unit.

    A limit on a quantity with a unit must carry a unit (a bare number is refused, since
    the same number means different things in N and lbf); a dimensionless one must not.
    """
    from camsim.analyses.study.distributions import _to_si

    where = f"{option} {text}"
    m = _CONSTRAINT.match(text)
    if not m:
        raise InputError(f'{where}: expected "EXPR<=VALUE[UNIT]" or "EXPR>=VALUE[UNIT]", e.g. "max_pressure_angle<=30deg"')
    expr_text, op, value = m.groups()
    if op in ("<", ">"):
        op += "="
    expr = parse_expression(expr_text, option)
    n = _NUMBER.match(value)
    if not n:
        raise InputError(f"{where}: '{value}' is not a number (with a unit)")
    number, unit = float(n.group(1)), n.group(2).replace(" ", "")
    si = units.get(expr.text, "")
    if si and not unit:
        raise InputError(f"{where}: the limit needs a unit ({expr.text} is in {si})")
    if unit and not si and expr.text in units:
        _number_without_unit(number, unit, expr.text, where)
    limit = _to_si(number, unit, si, where) if unit else number
    if si == "deg" and unit:  # a pressure angle is reported in degrees, not SI radians
        from camsim.units import ureg

        limit = float(ureg.Quantity(number, unit).to("deg").magnitude)
    return Constraint(text=text.strip(), expr=expr, op=op, limit=float(limit), unit=si)


def _number_without_unit(number: float, unit: str, name: str, where: str) -> None:
    """Issue 44: a unit on a quantity that has none (a count, a flag, a ratio: ``jump<=0N``) is
    refused (exit 2), never converted to base units; a dimensionless unit (``%``) is fine."""
    from camsim.units import ureg

    try:
        dimensionless = ureg.Quantity(number, unit).dimensionless
    except Exception:  # noqa: BLE001 - an unknown unit
        raise InputError(f"{where}: unknown unit '{unit}'") from None
    if not dimensionless:
        raise InputError(f"{where}: unit '{unit}' does not fit {name}, a number without a unit")


def parse_speeds(text: str | None) -> list[float | None]:
    """``FROM:TO:STEP[UNIT]``, ``A,B,C[UNIT]`` or one speed (default unit rpm) -> rad/s."""
    if text is None or not str(text).strip():
        return [None]
    from camsim.units import ureg

    where = f"--speeds {text}"
    raw = str(text).strip()
    m = re.match(r"^(.*?)([A-Za-z/][A-Za-z/ ]*)?$", raw)
    body, unit = m.group(1), (m.group(2) or "rpm").strip()
    try:
        factor = float(ureg.Quantity(1.0, unit).to("rad/s").magnitude)
    except Exception:  # noqa: BLE001 - unknown unit or wrong dimension
        raise InputError(f"{where}: '{unit}' is not a speed unit (rpm, rad/s, Hz)") from None
    try:
        if ":" in body:
            parts = [float(p) for p in body.split(":")]
            if len(parts) != 3 or not parts[2] > 0 or not parts[0] <= parts[1]:
                raise ValueError
            n = int(math.floor((parts[1] - parts[0]) / parts[2] + 1e-9)) + 1
            values = [parts[0] + i * parts[2] for i in range(n)]
        else:
            values = [float(p) for p in body.split(",")]
    except ValueError:
        raise InputError(f"{where}: expected FROM:TO:STEP[UNIT] (FROM ≤ TO, STEP > 0), A,B,C[UNIT] or one speed") from None
    if not values or not all(v > 0 and math.isfinite(v) for v in values):
        raise InputError(f"{where}: speeds must be positive")
    return [v * factor for v in values]


def build_problem(
    source,
    fixed: Sequence[str],
    variables: Sequence[str],
    logs: Sequence[str],
    choices: Sequence[str],
    absorb: str | None,
    minimize: Sequence[str],
    maximize: Sequence[str],
    constraints: Sequence[str],
    speeds: str | Sequence[float] | None,
) -> Problem:
    """Parse and check a whole problem (before a single run). See the module docstring."""
    from camsim.analyses.sweep.runner import machine_value

    try:
        base = source.load(list(fixed))
    except MachineFileError:
        raise
    if not variables and not choices:
        raise InputError("optimize: give at least one --var KEY=LOW:HIGH[UNIT] or --choice KEY=a,b,c")
    log_keys = list(logs)
    var_keys = [parse_param_key(v) for v in variables]
    for k in log_keys:
        if k not in var_keys:
            raise InputError(f"--log {k}: not one of the --var keys ({', '.join(var_keys) or 'none'})")
    absorb_key = None
    if absorb is not None:
        absorb_key = absorb.strip()
        m = re.match(r"^cam\.segments\[(\d+)\]\.duration$", absorb_key)
        n_seg = len(base.cam.segments) if base.cam is not None and base.cam.segments else 0
        if not m:
            raise InputError(f"--absorb {absorb}: must be a segment duration, cam.segments[i].duration")
        if int(m.group(1)) >= n_seg:
            raise InputError(f"--absorb {absorb}: no segment {m.group(1)}: the machine has {n_seg} (indices start at 0)")
    out: list[Variable] = []
    for text in variables:
        out.append(parse_var(source, fixed, text, parse_param_key(text) in log_keys, base, absorb_key))
    for text in choices:
        out.append(parse_choice(source, fixed, text, base))
    keys = [v.key for v in out]
    for k in keys:
        if keys.count(k) > 1:
            raise InputError(f"--var/--choice: key {k} is given twice")
    fixed_keys = {a.partition("=")[0].strip() for a in fixed}
    for k in keys:
        if k in fixed_keys:
            raise InputError(f"--var {k}: the key is also fixed by --set")
    if isinstance(speeds, str) or speeds is None:
        speed_list = parse_speeds(speeds)
    else:
        speed_list = [float(s) for s in speeds]
    if speed_list != [None] and "cam.speed" in keys:
        raise InputError("--speeds with --var cam.speed: give one of them (the speeds are a range of operation)")

    # --absorb: the segment durations of the file, in SI
    absorb_others: dict[str, float] = {}
    absorb_initial = math.nan
    if absorb is not None:
        m = re.match(r"^cam\.segments\[(\d+)\]\.duration$", absorb.strip())
        if not m:
            raise InputError(f"--absorb {absorb}: must be a segment duration, cam.segments[i].duration")
        absorb = absorb.strip()
        n_seg = len(base.cam.segments) if base.cam is not None and base.cam.segments else 0
        if int(m.group(1)) >= n_seg:
            raise InputError(f"--absorb {absorb}: no segment {m.group(1)}: the machine has {n_seg} (indices start at 0)")
        if absorb in keys:
            raise InputError(f"--absorb {absorb}: the absorbing duration cannot also be a --var")
        for i in range(n_seg):
            k = f"cam.segments[{i}].duration"
            if k != absorb:
                absorb_others[k] = float(machine_value(base, k))
        absorb_initial = float(machine_value(base, absorb))
        if not any(k in absorb_others for k in keys):
            raise InputError(f"--absorb {absorb}: no --var is a segment duration for it to absorb")

    goals = [Goal(parse_expression(t, "--minimize"), "min") for t in minimize]
    goals += [Goal(parse_expression(t, "--maximize"), "max") for t in maximize]
    if not goals:
        raise InputError("optimize: give an objective, --minimize EXPR or --maximize EXPR")
    if len(goals) > 2:
        raise InputError("optimize: at most two objectives (a Pareto front of two)")
    problem = Problem(variables=out, goals=goals, constraints=[], speeds=speed_list, absorb=absorb,
                      absorb_initial=absorb_initial, absorb_others=absorb_others, base=base, param_keys=keys)
    for g in goals:
        if isinstance(g.expr, ParamExpr) and g.expr.key not in keys:
            raise InputError(f"{g.expr.text}: {g.expr.key} is not an optimised key ({', '.join(keys)})")
    problem._constraint_texts = list(constraints)  # parsed once the units are known (check_on_run)
    return problem


def parse_param_key(text: str) -> str:
    return text.partition("=")[0].strip()


def expression_units(problem: Problem, result) -> dict[str, str]:
    """Check every expression against a run of the base machine; their SI units.

    Raises
    ------
    InputError
        An unknown scalar or trace (the message lists what exists).
    """
    from camsim.analyses.study.outputs import run_scalars, run_unit

    scalars = run_scalars(result)
    units: dict[str, str] = {}
    exprs = [g.expr for g in problem.goals]
    for text in getattr(problem, "_constraint_texts", []):
        m = _CONSTRAINT.match(text)
        if m:
            exprs.append(parse_expression(m.group(1), "--constraint"))
    for e in exprs:
        if isinstance(e, ParamExpr):
            if e.key not in problem.param_keys:
                raise InputError(f"{e.text}: {e.key} is not an optimised key ({', '.join(problem.param_keys)})")
            var = next(v for v in problem.variables if v.key == e.key)
            units[e.text] = var.unit
        elif isinstance(e, ScalarExpr):
            if e.text not in scalars:
                names = ", ".join(k for k, v in scalars.items() if isinstance(v, (int, float)))
                raise InputError(f"{e.text}: unknown run scalar; this machine's runs have: {names} "
                                 "(or REDUCER:PATH[@FROM:TO], param:KEY)")
            units[e.text] = run_unit(result, e.text)
            if units[e.text] == "" and e.text == "max_pressure_angle":
                units[e.text] = "deg"
        elif isinstance(e, OutputExpr):
            try:
                e.evaluate(result)
            except KeyError:
                paths = ", ".join(k for k in result._traces if k != "time") if hasattr(result, "_traces") else ""
                raise InputError(f"{e.text}: the run has no trace '{e.path}'; it has: {paths}") from None
            units[e.text] = run_unit(result, e.path)
    problem.constraints = [parse_constraint(t, units) for t in getattr(problem, "_constraint_texts", [])]
    problem.goals = [Goal(g.expr, g.sense, units.get(g.text, "")) for g in problem.goals]
    return units


def value_or_nan(x: Any) -> float:
    try:
        v = float(x)
    except (TypeError, ValueError):
        return math.nan
    return v if not isinstance(x, bool) else float(x)


def np_finite(values) -> np.ndarray:
    a = np.asarray(values, dtype=float)
    return a[np.isfinite(a)]

"""The units a user wrote: a machine file's (and the command line's) display units.

The rule (docs/units.md):

1. Every string value of the machine document that is a quantity with a unit (``"25.62
   lbf/in"``, ``"120 rpm"``, ``"50 deg"``) is classified by its dimension. Bare numbers
   (SI by the file format) and times and frequencies (shown the same in every system) do not
   count.
2. A dimension written directly (a length in ``in``, a force in ``lbf``, a pressure in
   ``psi``, a stiffness in ``lbf/in``) is shown in the unit written most often for it; a tie
   goes to the unit written first in the file.
3. A base dimension (length, force, mass, angle, angular speed) never written on its own
   takes the unit its compound units use most (``lbf/in`` counts for lbf and in).
4. Every other dimension is composed from the base choices (:func:`camsim.display.units.compose`:
   in → in/s, in/s², lbf/in; mm → m/s, m/s², N/m). A dimension nothing was written for is
   shown as under ``--units si`` (mm, N, kg, deg, rpm).

Units written on the command line (``--values element.K23.preload=20,28.12lbf``,
``--limit peak_transducer_force>52lbf``) take precedence over the file's for their
dimension.
"""

from __future__ import annotations

import functools
import math
import re
import tomllib
from collections.abc import Iterable, Iterator
from typing import Any

from camsim.display.units import BASE, SI, DisplayUnits, Unit, compose, system_units

__all__ = ["written_units", "display_units", "option_quantities"]

#: pint's dimensionality of a whole quantity → the display dimension it counts for.
_DIMENSIONALITY = {
    "[length]": "length",
    "[mass]": "mass",
    "[length] * [mass] / [time] ** 2": "force",
    "[mass] / [time] ** 2": "stiffness",
    "[mass] / [time]": "damping",
    "[mass] / [length]": "quadratic_damping",  # N·s²/m² (spec §10)
    "[length] / [time]": "velocity",
    "[length] / [time] ** 2": "acceleration",
    "[length] / [time] ** 3": "jerk",
    "[mass] / [length] / [time] ** 2": "pressure",
    "[length] ** 2 * [mass]": "inertia",
    "[mass] / [length] ** 3": "density",
    "[length] ** 2": "area",
    "[length] ** 2 * [mass] / [time] ** 2": "torque",  # N·m, lbf·in (a joule counts for energy)
}


def _dimensions(text: str) -> tuple:
    """``"[length] ** 2 * [mass] / [time] ** 2"`` → ``(("[length]", 2), ("[mass]", 1), ("[time]", -2))``."""
    out: dict[str, int] = {}
    sign = 1
    for token in re.findall(r"/|\[\w+\](?: \*\* \d+)?", text):
        if token == "/":
            sign = -1
            continue
        name, _, power = token.partition(" ** ")
        out[name] = out.get(name, 0) + sign * int(power or 1)
    return tuple(sorted(out.items()))


def _dimension_of(dimensionality) -> str | None:
    """The display dimension of a pint dimensionality, whatever order pint prints its factors in
    (``[mass] * [length] ** 2`` is the inertia ``kg*m^2``: issue 44)."""
    key = tuple(sorted(dict(dimensionality).items()))
    return _BY_DIMENSIONS.get(key)
_BY_DIMENSIONS = {_dimensions(k): v for k, v in _DIMENSIONALITY.items()}
#: Abbreviations pint prints differently from how people write them.
_SYMBOLS = {"th": "thou", "degree": "deg", "°": "deg", "inch": "in", "um": "µm"}
_SUP = {2: "²", 3: "³", 4: "⁴"}


def _symbol(ureg: Any, name: str) -> str:
    text = f"{ureg.Unit(name):~}"
    return _SYMBOLS.get(text, text)


def _text(ureg: Any, units: dict[str, float]) -> str | None:
    """``{'force_pound': 1, 'inch': -1}`` → ``"lbf/in"`` (None for a fractional power)."""
    num, den = [], []
    for name, power in units.items():
        if power != int(power) or abs(power) > 4:
            return None
        p = abs(int(power))
        part = _symbol(ureg, name) + (_SUP[p] if p > 1 else "")
        (num if power > 0 else den).append(part)
    text = "·".join(num) or "1"
    return text + ("/" + "·".join(den) if den else "")


def _classify(ureg: Any, quantity: Any) -> Iterator[tuple[str, bool, str, float]]:
    """(dimension, direct, unit text, size in SI) of a written quantity and of its parts.

    ``direct`` is True for the quantity as a whole, False for the base units inside a compound
    (``lbf`` and ``in`` inside ``lbf/in``).
    """
    units = dict(quantity._units)
    if not units:
        return
    angular = any("radian" in dict(ureg.Quantity(1.0, n).to_root_units()._units) for n in units)
    dims = str(quantity.dimensionality)
    whole = None
    if angular and dims == "dimensionless":
        whole = "angle"
    elif angular and dims == "1 / [time]":
        whole = "angular_speed"
    elif not angular:
        whole = _dimension_of(quantity.dimensionality)
        if whole == "torque" and any("joule" in n for n in units):
            whole = "energy"
    if whole is not None:
        text = _text(ureg, units)
        if text is not None:
            target = {"angle": "radian", "angular_speed": "radian/second"}.get(whole)
            size = float(ureg.Quantity(1.0, quantity.units).to_base_units().magnitude if target is None
                         else ureg.Quantity(1.0, quantity.units).to(target).magnitude)
            if math.isfinite(size) and size > 0:
                yield whole, True, text, size
    if len(units) > 1 or next(iter(units.values())) != 1:
        for name in units:
            part = _dimension_of(ureg.Unit(name).dimensionality)
            if part in ("length", "force", "mass"):
                size = float(ureg.Quantity(1.0, name).to_base_units().magnitude)
                yield part, False, _symbol(ureg, name), size


#: A quantity starts with its number (names such as ``"m"`` or ``"F"`` would parse as units).
_NUMBER_FIRST = re.compile(r"\s*[-+]?(?:\d|\.\d)")


def _strings(value: Any) -> Iterator[str]:
    """Every string in a parsed document that starts with a number, in file order.

    The ``[machine]`` table (free text: a name, a description) is left out.
    """
    if isinstance(value, str):
        if _NUMBER_FIRST.match(value):
            yield value
    elif isinstance(value, dict):
        for k, v in value.items():
            if k != "machine" or not isinstance(v, dict):
                yield from _strings(v)
    elif isinstance(value, list):
        for v in value:
            yield from _strings(v)


class _Votes:
    """Counts of the units written per dimension, in the order first written."""

    def __init__(self) -> None:
        self.direct: dict[str, dict[str, list]] = {}
        self.parts: dict[str, dict[str, list]] = {}

    def add(self, dimension: str, direct: bool, text: str, size: float) -> None:
        table = (self.direct if direct else self.parts).setdefault(dimension, {})
        entry = table.setdefault(text, [0, len(table), size])
        entry[0] += 1

    def winners(self) -> dict[str, Unit]:
        out: dict[str, Unit] = {}
        for table in (self.parts, self.direct):  # direct votes override the parts' below
            for dimension, counts in table.items():
                text, (_, _, size) = max(counts.items(), key=lambda kv: (kv[1][0], -kv[1][1]))
                out[dimension] = Unit(text, size)
        return out

    def count(self, ureg: Any, texts: Iterable[str]) -> None:
        for text in texts:
            try:
                quantity = ureg.Quantity(text.strip())
            except Exception:  # noqa: BLE001 - not a quantity: a name, a law, a path
                continue
            if not isinstance(quantity, ureg.Quantity):
                continue
            for dimension, direct, unit, size in _classify(ureg, quantity):
                self.add(dimension, direct, unit, size)


def _resolve(file_votes: _Votes, option_votes: _Votes | None) -> dict[str, Unit]:
    chosen = file_votes.winners()
    direct = set(file_votes.direct)
    if option_votes is not None:
        for dimension, unit in option_votes.winners().items():
            if dimension in option_votes.direct or dimension not in direct:
                chosen[dimension] = unit
        direct |= set(option_votes.direct)
    base = {d: chosen.get(d, SI[d]) for d in BASE}
    units = compose(base)
    for dimension, unit in chosen.items():
        if dimension in direct or dimension in BASE:
            units[dimension] = unit
    if "torque" in direct and "energy" not in direct:  # work follows the torque written: N·m → J
        torque = units["torque"]
        units["energy"] = Unit("J", 1.0) if torque.text == "N·m" else Unit("·".join(reversed(torque.text.split("·"))), torque.size)
    return units


def written_units(text: str, options: Iterable[str] = ()) -> DisplayUnits:
    """The ``file`` display units of a machine document (TOML text), with ``options``' units first.

    Parameters
    ----------
    text : str
        The machine file's TOML text (``Machine.text``; a result file's ``machine_toml``).
    options : iterable of str
        Quantities written on the command line (``"28.12lbf"``, ``"100rpm"``; see
        :func:`option_quantities`); their units take precedence for their dimension.

    Returns
    -------
    DisplayUnits
        ``system = "file"``. A document that is not TOML gives the ``si`` choice.
    """
    options = tuple(_one_of_each(o) for o in options)
    return DisplayUnits.of("file", _resolve(_file_votes(text), _option_votes(options) if options else None))


def _one_of_each(option: str) -> str:
    """``"28.12 lbf"`` → ``"1 lbf"``: a quantity votes by its unit alone (:func:`_classify`), so
    an analysis's runs, whose overrides differ in their numbers only, share one cached count."""
    m = _TRAILING.search(option)
    return f"1 {m.group('unit').strip()}" if m else option


@functools.lru_cache(maxsize=16)
def _file_votes(text: str) -> _Votes:
    """The units a document's quantities vote for (read only: cached per text, since an
    analysis loads one file thousands of times with other overrides; issue 42)."""
    from camsim.units import registry

    try:
        doc = tomllib.loads(text) if text else {}
    except tomllib.TOMLDecodeError:
        doc = {}
    votes = _Votes()
    votes.count(registry(), _strings(doc))
    return votes


@functools.lru_cache(maxsize=256)
def _option_votes(options: tuple[str, ...]) -> _Votes:
    """The units the command line's quantities vote for (read only, cached)."""
    from camsim.units import registry

    votes = _Votes()
    votes.count(registry(), options)
    return votes


#: The quantity at the end of an option's value: ``20:40lbf`` → ``40lbf``, ``>52 lbf`` → ``52 lbf``.
_TRAILING = re.compile(r"(?P<num>[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?)\s*(?P<unit>[A-Za-zµ°%][\w/*^.·²³ µ°-]*)\s*$")


def option_quantities(values: Iterable[str]) -> list[str]:
    """The quantities written in command-line values, for :func:`written_units`.

    ``element.K23.preload=20,28.12lbf`` → ``"28.12 lbf"``; ``cam.speed=100:600:10rpm`` →
    ``"10 rpm"``; ``peak_transducer_force>52lbf`` → ``"52 lbf"``; ``tol:28.12:3lbf`` →
    ``"3 lbf"``. Values without a unit give nothing.
    """
    out = []
    for value in values:
        text = str(value)
        for sep in ("<=", ">=", "<", ">", "="):
            if sep in text:
                text = text.split(sep, 1)[1]
                break
        m = _TRAILING.search(text)
        if m:
            out.append(f"{m.group('num')} {m.group('unit').strip()}")
    return out


def display_units(system: str, machine_text: str | None = None, options: Iterable[str] = (),
                  recorded: str | None = None) -> DisplayUnits:
    """The display units of a command's human output under ``--units system``.

    ``file``: a result's recorded choice (``recorded``, the JSON of its ``display_units``
    attribute) or the units of ``machine_text``, with the command line's ``options`` first;
    ``si`` and ``us``: the fixed choices.
    """
    if system != "file":
        return system_units(system)
    options = list(options)
    if recorded and not options:
        try:
            return DisplayUnits.from_json(recorded)
        except (ValueError, KeyError, TypeError):
            pass
    if machine_text is None and not options:
        return DisplayUnits.of("file", SI)
    return written_units(machine_text or "", option_quantities(options))

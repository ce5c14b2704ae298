"""Reading checked values from a parsed machine document: the helpers every table's reader uses.

:class:`Reader` reads one key at a time — a quantity in SI checked for its dimension and
range, a number, a string, a choice — and turns every problem into a one-line
:class:`camsim.errors.MachineFileError` naming the file and the key path. The cam tables
(:mod:`camsim.machine.camreader`) and the rest of the document
(:mod:`camsim.machine.validator`) are read with it.
"""

from __future__ import annotations

import difflib
import math
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from camsim.errors import MachineFileError
from camsim.units import QuantityError, to_si, ureg


def _suggest(word: str, choices: Sequence[str]) -> str:
    """``"did you mean 'x'?"`` or a list of the valid choices."""
    close = difflib.get_close_matches(word, list(choices), n=1, cutoff=0.6)
    if close:
        return f"did you mean '{close[0]}'?"
    return "valid: " + ", ".join(choices) if choices else "there is none"


def _fmt(value: Any) -> str:
    """A value as written in TOML, for messages."""
    if isinstance(value, str):
        return f'"{value}"'
    if isinstance(value, bool):
        return "true" if value else "false"
    return repr(value)


def _si_text(value: float, unit: str) -> str:
    return f"{value:.6g} {unit}".strip()


def _has_unit(value: Any) -> bool:
    """True if ``value`` is a string that carries a unit (``"4.4 deg"``; not ``"50"``)."""
    if not isinstance(value, str):
        return False
    text = value.strip()
    hit = _UNIT_SEEN.get(text)
    if hit is None:
        try:
            quantity = ureg.Quantity(text)
        except Exception:  # not parsable: let to_si produce the message
            return True
        hit = not getattr(quantity, "unitless", True)
        if len(_UNIT_SEEN) >= 4096:
            _UNIT_SEEN.clear()
        _UNIT_SEEN[text] = hit
    return hit


#: Texts seen by :func:`_has_unit` (an analysis loads one machine file thousands of times;
#: pint's parse is the cost, camsim.units keeps its conversions alike).
_UNIT_SEEN: dict[str, bool] = {}


def _is_angular(value: str) -> bool:
    """True if the unit of ``value`` contains an angle (rpm, rad/s, deg/s; not Hz, 1/s)."""
    try:
        return "radian" in dict(ureg.Quantity(value.strip()).to_root_units()._units)
    except Exception:  # unparsable: to_si reports it
        return True


def _angle_to_si(value: Any) -> float:
    """An angle [rad]; a bare number (or a number in a string) means degrees.

    Works around pint treating the radian as dimensionless: ``"3.1 rad"`` must stay
    radians rather than be re-read as degrees.
    """
    if _has_unit(value):
        return to_si(value, "angle")
    return to_si(value, "angle", bare_unit="deg")


class Reader:
    """Reading checked values from a parsed document; every problem a one-line
    :class:`MachineFileError` naming the file and the key path."""

    def __init__(self, source: str, base_dir: Path):
        self.source = source
        self.base_dir = base_dir

    # -- helpers ------------------------------------------------------------------
    def error(self, path: str, message: str) -> MachineFileError:
        return MachineFileError(self.source, path, message)

    def check_keys(self, table: dict, valid: Sequence[str], path: str, what: str = "") -> None:
        for key in table:
            if key not in valid:
                where = f"{path}.{key}" if path else key
                suffix = f" {what}" if what else ""
                raise self.error(where, f"unknown key{suffix}; {_suggest(key, valid)}")

    def table(self, parent: dict, key: str, path: str, required: bool = False) -> dict | None:
        value = parent.get(key)
        if value is None:
            if required:
                raise self.error(path, f"missing required table [{path}]")
            return None
        if not isinstance(value, dict):
            raise self.error(path, f"expected a table [{path}], got {_fmt(value)}")
        return value

    def rows(self, parent: dict, key: str, path: str) -> list[dict]:
        value = parent.get(key)
        if value is None:
            return []
        if not isinstance(value, list) or not all(isinstance(r, dict) for r in value):
            raise self.error(path, f"expected an array of tables ([[{key}]])")
        return value

    def quantity(
        self,
        table: dict,
        key: str,
        path: str,
        dimension: str,
        *,
        required: bool = False,
        default: float | None = None,
        bare_unit: str | None = None,
        minimum: float | None = None,
        strict: bool = False,
        example: str = "",
    ) -> float | None:
        """Read ``table[key]`` as a quantity of ``dimension`` in SI, checked against a minimum."""
        where = f"{path}.{key}"
        if key not in table:
            if required:
                hint = f" (e.g. {key} = {example})" if example else ""
                raise self.error(where, f"missing required key{hint}")
            return default
        value = table[key]
        try:
            if dimension == "angle" and bare_unit == "deg":
                number = _angle_to_si(value)
            else:
                number = to_si(value, dimension, bare_unit=bare_unit)
        except QuantityError as exc:
            raise self.error(where, str(exc)) from None
        self.check_min(number, minimum, strict, where, value)
        return number

    def number(
        self,
        table: dict,
        key: str,
        path: str,
        *,
        required: bool = False,
        default: float | None = None,
        minimum: float | None = None,
        strict: bool = False,
        maximum: float | None = None,
    ) -> float | None:
        """Read a dimensionless number (int, float or a string such as ``"6 %"``)."""
        where = f"{path}.{key}"
        if key not in table:
            if required:
                raise self.error(where, "missing required key (a number)")
            return default
        value = table[key]
        if isinstance(value, (int, float)) and not isinstance(value, bool):
            number = float(value)
            if not math.isfinite(number):
                raise self.error(where, f"expected a finite number, got {_fmt(value)}")
        else:
            try:
                number = to_si(value, "dimensionless")
            except QuantityError:
                raise self.error(where, f"expected a number, got {_fmt(value)}") from None
        self.check_min(number, minimum, strict, where, value)
        if maximum is not None and number > maximum:
            raise self.error(where, f"must be at most {maximum:g}, got {_fmt(value)}")
        return number

    def integer(self, table: dict, key: str, path: str, default: int, minimum: int) -> int:
        where = f"{path}.{key}"
        if key not in table:
            return default
        value = table[key]
        if isinstance(value, bool) or not isinstance(value, int):
            raise self.error(where, f"expected a whole number, got {_fmt(value)}")
        if value < minimum:
            raise self.error(where, f"must be at least {minimum}, got {value}")
        return value

    def string(self, table: dict, key: str, path: str, *, required: bool = False) -> str | None:
        where = f"{path}.{key}"
        if key not in table:
            if required:
                raise self.error(where, "missing required key (a string)")
            return None
        value = table[key]
        if not isinstance(value, str):
            raise self.error(where, f"expected a string, got {_fmt(value)}")
        return value

    def choice(self, table: dict, key: str, path: str, choices: Sequence[str], *, required: bool) -> str | None:
        value = self.string(table, key, path, required=required)
        if value is not None and value not in choices:
            raise self.error(f"{path}.{key}", f'unknown {key} "{value}"; {_suggest(value, choices)}')
        return value

    def check_min(self, number: float, minimum: float | None, strict: bool, where: str, value: Any) -> None:
        if minimum is None:
            return
        if strict and not number > minimum:
            raise self.error(where, f"must be greater than {minimum:g}, got {_fmt(value)}")
        if not strict and number < minimum:
            raise self.error(where, f"must not be negative, got {_fmt(value)}" if minimum == 0
                             else f"must be at least {minimum:g}, got {_fmt(value)}")

"""The grid of a sweep: ``--vary KEY=START:STOP:STEP[UNIT]`` and ``--values KEY=V1,V2,...``.

Values are kept as the text the user wrote (with units), computed in decimal so that a
range such as ``60:600:10rpm`` gives exactly 60, 70, ... 600; the loader converts each
to SI when the variant is loaded, with its usual checks.
"""

from __future__ import annotations

import itertools
import re
from collections.abc import Sequence
from decimal import Decimal, InvalidOperation

from camsim.errors import InputError

_NUMBER = re.compile(r"^\s*([-+]?(?:\d+(?:\.\d*)?|\.\d+)(?:[eE][-+]?\d+)?)\s*(.*?)\s*$")


def _split_number(text: str, where: str) -> tuple[Decimal, str]:
    m = _NUMBER.match(text)
    if not m:
        raise InputError(f"{where}: '{text.strip()}' is not a number (with an optional unit)")
    try:
        return Decimal(m.group(1)), m.group(2)
    except InvalidOperation:  # pragma: no cover - the regex admits only valid numbers
        raise InputError(f"{where}: '{text.strip()}' is not a number") from None


def _decimal_text(value: Decimal) -> str:
    """A grid value as plain text without float noise: ``60``, ``0.3``, ``1000000``."""
    text = format(value.normalize(), "f")
    return "0" if text in ("-0", "0") else text


def _with_unit(number: str, unit: str) -> str:
    return f"{number} {unit}" if unit else number


def parse_vary(text: str) -> tuple[str, list[str]]:
    """Parse ``KEY=START:STOP:STEP[UNIT]`` into the key and the grid's value texts.

    The grid is START, START+STEP, ... up to STOP; STOP is included when it falls on the
    grid (within 1e-9 of a step), otherwise the last value is the largest one below it.
    The unit, if any, is written after STEP and applies to all three numbers; START and
    STOP may repeat it (``60rpm:600rpm:10rpm``). Arithmetic is decimal, so
    ``0.1:0.3:0.1`` gives exactly ``0.1, 0.2, 0.3``. A negative STEP counts down.

    Parameters
    ----------
    text : str
        e.g. ``"cam.speed=60:600:10rpm"``, ``"element.seat.stiffness=1e6:4e6:1e6 N/m"``.

    Returns
    -------
    key : str
    values : list of str
        Value texts for the loader, e.g. ``["60 rpm", "70 rpm", ...]``; a bare number
        (no unit) is passed on bare and means SI to the loader.

    Raises
    ------
    InputError
        Malformed text, a zero step, an empty range, or mixed units.
    """
    where = f"--vary {text}"
    key, sep, spec = text.partition("=")
    key = key.strip()
    if not sep or not key:
        raise InputError(f"{where}: expected KEY=START:STOP:STEP[UNIT], e.g. cam.speed=60:600:10rpm")
    parts = spec.split(":")
    if len(parts) != 3:
        raise InputError(f"{where}: expected START:STOP:STEP[UNIT] after '=', e.g. 60:600:10rpm")
    (start, u0), (stop, u1), (step, unit) = (_split_number(p, where) for p in parts)
    for given in (u0, u1):
        if given and given.replace(" ", "") != unit.replace(" ", ""):
            raise InputError(
                f"{where}: START and STOP may only repeat the unit written after STEP ('{unit or 'none'}'), not '{given}'"
            )
    if step == 0:
        raise InputError(f"{where}: the step is zero")
    span = (stop - start) / step
    if span < 0:
        raise InputError(f"{where}: empty range (STOP {'below' if step > 0 else 'above'} START for a {'positive' if step > 0 else 'negative'} step)")
    count = int((span + Decimal("1e-9")).to_integral_value(rounding="ROUND_FLOOR")) + 1
    if count > 10**7:
        raise InputError(f"{where}: {count} values; that is not a sweep one can run")
    return key, [_with_unit(_decimal_text(start + i * step), unit) for i in range(count)]


def parse_values(text: str) -> tuple[str, list[str]]:
    """Parse ``KEY=v1,v2,...`` into the key and the value texts.

    Each value is passed to the loader as written (``100rpm,250rpm``). When only the last
    value carries a unit and the others are bare numbers, that unit applies to all
    (``100,250,400rpm``).

    Raises
    ------
    InputError
        No ``=``, no key, or an empty value.
    """
    where = f"--values {text}"
    key, sep, spec = text.partition("=")
    key = key.strip()
    if not sep or not key:
        raise InputError(f"{where}: expected KEY=v1,v2,..., e.g. cam.speed=100rpm,200rpm")
    values = [v.strip() for v in spec.split(",")]
    if not values or any(not v for v in values):
        raise InputError(f"{where}: empty value in the list")
    last = _NUMBER.match(values[-1])
    if last and last.group(2) and len(values) > 1:
        bare = [_NUMBER.match(v) for v in values[:-1]]
        if all(b and not b.group(2) for b in bare):
            values = [_with_unit(b.group(1), last.group(2)) for b in bare] + [_with_unit(last.group(1), last.group(2))]
    return key, values


def build_grid(axes: Sequence[tuple[str, Sequence[str]]]) -> list[tuple[str, ...]]:
    """All combinations of the axes' values, the last axis varying fastest.

    Returns
    -------
    list of tuple of str
        One tuple of ``"KEY=VALUE"`` overrides per variant, in grid order.

    Raises
    ------
    InputError
        A key given twice.
    """
    keys = [k for k, _ in axes]
    for k in keys:
        if keys.count(k) > 1:
            raise InputError(f"--vary/--values: key {k} is given twice")
    combos = itertools.product(*[[f"{k}={v}" for v in values] for k, values in axes])
    return [tuple(c) for c in combos]

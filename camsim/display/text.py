"""Numbers and messages for human output: engineering prefixes, SI quantities in free text.

Warnings and errors are composed in SI deep in the library (``"the cam contact force
turns negative (-12.5 N)"``); :func:`in_units` rewrites the quantities of such a text in the
chosen display units before it is printed, so a warning is in the same units as the table
above it.
"""

from __future__ import annotations

import math
import re

from camsim.display.units import DisplayUnits, typographic

__all__ = ["engineering", "in_units", "significant"]

_PREFIXES = ((1e9, "G"), (1e6, "M"), (1e3, "k"), (1.0, ""), (1e-3, "m"), (1e-6, "µ"), (1e-9, "n"))


def engineering(value: float, unit: str, digits: int = 4) -> str:
    """``50000, "Hz"`` → ``"50 kHz"``; ``0.0021, "s"`` → ``"2.1 ms"`` (prefix by magnitude).

    ``digits`` significant digits, trailing zeros dropped; 0, NaN and infinities without a prefix.
    """
    if value == 0 or not math.isfinite(value):
        return f"{value:g} {unit}"
    for scale, prefix in _PREFIXES:
        if abs(value) >= scale * (1 - 0.5 * 10.0 ** (-digits)):
            return f"{value / scale:.{digits}g} {prefix}{unit}"
    scale, prefix = _PREFIXES[-1]
    return f"{value / scale:.{digits}g} {prefix}{unit}"


def significant(number_text: str) -> int:
    """Significant digits of a number as printed (``"125.08"`` → 5, ``"1.2e+06"`` → 2), at least 4."""
    mantissa = re.split(r"[eE]", number_text.lstrip("+-"))[0].replace(".", "").lstrip("0")
    return max(4, len(mantissa))


#: SI quantities as camsim's messages write them; longest unit texts first.
_UNITS = ("N*s/m", "N·s/m", "m/s^2", "m/s**2", "m/s²", "m/s^3", "m/s**3", "m/s³", "rad/s", "N/m", "N*m", "N·m",
          "m/s", "MPa", "GPa", "Pa", "rad", "kg", "mm", "µm", "um", "N", "J", "m")
_QUANTITY = re.compile(
    r"(?<![\w.])(?P<num>[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?) ?(?P<unit>"
    + "|".join(re.escape(u) for u in _UNITS)
    + r")(?![\w/^²³·*])"
)


#: A frequency in Hz written in exponent form (7.96e+07 Hz), shown with a prefix (79.6 MHz).
_HERTZ = re.compile(r"(?<![\w.])(?P<num>[-+]?(?:\d+\.?\d*|\.\d+)[eE][-+]?\d+) Hz(?!\w)")


def in_units(text: str, display: DisplayUnits) -> str:
    """``text`` with its SI quantities shown in ``display``: ``"-12.5 N"`` → ``"-2.81 lbf"``.

    A number directly followed by one of the SI unit texts camsim's messages use (N, N/m,
    N·s/m, m, mm, m/s, m/s², m/s³, kg, rad, rad/s, Pa, MPa, N·m, J) is converted, keeping at
    least the digits it was written with; a frequency in exponent form gets a prefix
    (``7.96e+07 Hz`` → ``79.6 MHz``); everything else — text in double quotes, the
    user's own input echoed — is left as it is.
    """

    def convert(m: re.Match) -> str:
        unit, k = display.shown(m.group("unit"))
        if unit == m.group("unit") and k == 1.0:
            return m.group(0)
        digits = significant(m.group("num"))
        return f"{float(m.group('num')) * k:.{digits}g} {unit}"

    def hertz(m: re.Match) -> str:
        return engineering(float(m.group("num")), "Hz", max(3, significant(m.group("num")) - 1))

    # What the user wrote is echoed in double quotes (got "0.0625 m"): left as written.
    parts = text.split('"')
    for i in range(0, len(parts), 2):
        parts[i] = typographic_units(_HERTZ.sub(hertz, _QUANTITY.sub(convert, parts[i])))
    return '"'.join(parts)


def typographic_units(text: str) -> str:
    """``m/s^2`` and ``m/s**2`` → ``m/s²`` wherever they stand in a message."""
    return re.sub(r"(?<=[A-Za-z])(\*\*|\^)([2-6])(?![\d.])", lambda m: typographic(f"^{m.group(2)}"), text)

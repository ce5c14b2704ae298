"""Units of human output: SI (N, mm, m/s) or US customary (lbf, in, in/s), ``--units si|us``.

Only what is printed for a reader changes; files and ``--json`` are always SI. Each
SI unit text maps to the unit it is printed in and the factor from SI, e.g. under
``us`` a length in m is printed in in (× 1/0.0254) and a force in N in lbf.
"""

from __future__ import annotations

from camsim.errors import InputError
from camsim.units import LBF

__all__ = ["SYSTEMS", "check_unit_system", "shown", "header"]

#: Unit systems accepted by ``--units``.
SYSTEMS = ("si", "us")
#: One inch [m] (exact); the pound-force is camsim.units.LBF.
INCH = 0.0254

_SI = {
    "m": ("mm", 1e3),
    "m/s": ("m/s", 1.0),
    "m/s^2": ("m/s²", 1.0),
    "m/s²": ("m/s²", 1.0),
    "N": ("N", 1.0),
    "N/m": ("N/m", 1.0),
}
_US = {
    "m": ("in", 1.0 / INCH),
    "mm": ("in", 1e-3 / INCH),
    "m/s": ("in/s", 1.0 / INCH),
    "m/s^2": ("in/s²", 1.0 / INCH),
    "m/s²": ("in/s²", 1.0 / INCH),
    "N": ("lbf", 1.0 / LBF),
    "N/m": ("lbf/in", INCH / LBF),
    "N*s/m": ("lbf·s/in", INCH / LBF),
    "kg": ("lb", 1.0 / 0.45359237),
}


def check_unit_system(system: str) -> str:
    """Return ``system`` if it is one of :data:`SYSTEMS`; InputError naming ``--units`` otherwise."""
    if system not in SYSTEMS:
        raise InputError(f"--units {system}: expected one of {', '.join(SYSTEMS)}")
    return system


def shown(si_unit: str, system: str = "si") -> tuple[str, float]:
    """(printed unit, factor from SI) of a quantity whose SI unit is ``si_unit``.

    Units without an entry (s, rad/s, Hz, numbers) are printed as they are.
    """
    table = _US if system == "us" else _SI
    return table.get(si_unit, (si_unit, 1.0))


def header(name: str, unit: str) -> str:
    """A column header with its unit in brackets (``"force [N]"``; no brackets for numbers)."""
    return f"{name} [{unit}]" if unit else name


_QUANTITY_IN_TEXT = None


def in_system(text: str, system: str = "si") -> str:
    """A message with its SI quantities shown in ``system`` (issue 26: warnings in --units).

    Numbers followed by an SI unit (``-12.5 N``, ``0.3 m/s``, ``9.8 m/s^2``, ``0.002 m``) are
    rewritten as ``-2.81 lbf (-12.5 N)`` under ``us``; the SI value stays in parentheses so
    the message still matches the file. Under ``si`` the text is returned unchanged.
    """
    global _QUANTITY_IN_TEXT
    if system != "us":
        return text
    import re

    if _QUANTITY_IN_TEXT is None:
        _QUANTITY_IN_TEXT = re.compile(
            r"(?<![\w.])(?P<num>[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?) (?P<unit>m/s\^2|m/s²|m/s|N/m|N|mm|m)(?![\w/^])"
        )

    def convert(m) -> str:
        unit, factor = shown(m.group("unit"), "us")
        if unit == m.group("unit"):
            return m.group(0)
        return f"{float(m.group('num')) * factor:.4g} {unit} ({m.group(0)})"

    return _QUANTITY_IN_TEXT.sub(convert, text)

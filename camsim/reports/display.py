"""Display units in the reports layer: the choice a table or a page is shown in.

The units themselves live in :mod:`camsim.display` (the one presentation layer under figures,
reports and the command line); these helpers turn what a caller hands over — a
:class:`~camsim.display.DisplayUnits`, ``"si"``/``"us"``/``"file"`` or nothing — into one.
Only what is printed for a reader changes; files and ``--json`` are always SI.
"""

from __future__ import annotations

from typing import Any

from camsim.display import DisplayUnits, system_units

__all__ = ["as_display", "header", "shown"]


def as_display(units: DisplayUnits | str | None = None, machine: Any = None) -> DisplayUnits:
    """``units`` as :class:`DisplayUnits`: as given, the fixed ``si``/``us`` choice, or (``None``
    or ``"file"``) the units of ``machine``'s file (SI without a machine)."""
    if isinstance(units, DisplayUnits):
        return units
    if units in (None, "file"):
        found = getattr(machine, "display_units", None)
        return found if isinstance(found, DisplayUnits) else system_units("si")
    return system_units(str(units))


def shown(si_unit: str, units: DisplayUnits | str | None = None) -> tuple[str, float]:
    """(printed unit, factor from SI) of a quantity whose SI unit is ``si_unit``."""
    return as_display(units).shown(si_unit)


def header(name: str, unit: str) -> str:
    """A column header with its unit in brackets (``"force [N]"``; no brackets for numbers)."""
    return f"{name} [{unit}]" if unit else name

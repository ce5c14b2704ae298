"""``--units file|si|us``: the display units of a command's human output (issue 36).

Every command that prints values takes it; ``file`` (the default) shows each dimension in
the unit the machine file was written in, with the units written on the command line first
(docs/units.md). Files and ``--json`` are always SI.
"""

from __future__ import annotations

from collections.abc import Iterable
from typing import TYPE_CHECKING

import typer

if TYPE_CHECKING:
    from camsim.display import DisplayUnits

#: The help text of ``--units``.
UNITS_HELP = (
    "Units of the human output: file (each dimension in the unit the machine file writes it in, "
    "units written on the command line first; the default), si (mm, N, kg, m/s, rpm, deg) or us "
    "(in, lbf, lb, in/s, rpm, deg). Files and --json are always SI."
)


def units_option(help_text: str = UNITS_HELP) -> typer.models.OptionInfo:
    """The ``--units`` option, default ``file``."""
    return typer.Option("file", "--units", metavar="file|si|us", help=help_text)


def check_units(system: str) -> str:
    """``system`` if it is one of file, si, us; otherwise InputError naming ``--units``."""
    from camsim.display import SYSTEMS
    from camsim.errors import InputError

    if system not in SYSTEMS:
        raise InputError(f"--units {system}: expected one of {', '.join(SYSTEMS)}")
    return system


#: The display units of the command being run, once it knows them: errors that quote a value
#: (composed in SI deep in the library) are printed in them (:func:`error_text`).
_ERROR_UNITS: list = []


def machine_units(system: str, machine, options: Iterable[str] = ()) -> DisplayUnits:
    """Display units of output about ``machine`` (a Machine, or None), with ``options``' units
    (the command-line values, e.g. ``element.K23.preload=20,28.12lbf``) first.

    They also become the units the command's errors are printed in (:func:`error_text`).
    """
    from camsim.display import display_units, system_units

    check_units(system)
    options = [o for o in options if o]
    if system != "file":
        shown = system_units(system)
    elif not options and machine is not None:
        shown = machine.display_units
    else:
        shown = display_units("file", getattr(machine, "text", None), options)
    _ERROR_UNITS[:] = [shown]
    return shown


def reset_error_units() -> None:
    """Forget the units of a previous command (each command starts with SI messages as composed)."""
    _ERROR_UNITS.clear()


def error_text(text: str) -> str:
    """An error message with its SI quantities in the running command's display units, once known."""
    if not _ERROR_UNITS:
        return text
    from camsim.display import in_units

    return in_units(text, _ERROR_UNITS[0])

"""The ``--report PAGE.html`` option shared by run, compare, sweep, study and fit (issue 29).

Each command checks the page can be written before it computes, and writes the page of its
result file at the end (:func:`camsim.reports.build.build_report`).
"""

from __future__ import annotations

import shlex
import sys
from pathlib import Path

from camsim.cli.app import err_console

#: Help of the ``--report`` option of run, compare, sweep and study.
REPORT_HELP = "Also write the HTML report page of the result here (as camsim report; see docs/report.md)."


def command_line() -> str:
    """The command being run, as a shell would read it (shown in the page header)."""
    return shlex.join(["camsim", *sys.argv[1:]])


def check_report_target(page: Path | None, inputs=(), force: bool = False, option: str = "--report") -> None:
    """Before a command computes: the page may be written and Bokeh is installed (exit 2 otherwise).

    The output policy of every command (:mod:`camsim.io.outputs`): ``.html``/``.htm`` only;
    never an input (``inputs``: (label, path) pairs), a file of another kind, or an HTML page
    camsim did not write (that needs ``force``).
    """
    if page is None:
        return
    from camsim.extras import require
    from camsim.io.outputs import HTML, check_output, output_format

    check_output(page, output_format(page, HTML, option), owner="report", inputs=inputs, force=force, option=option)
    require("bokeh", "report")


def write_report_page(results: list[Path], page: Path | None, quiet: bool = False, units=None) -> None:
    """The page of ``results`` at the end of another command (``--report``); one line when written.

    ``units``: the command's display units (a :class:`~camsim.display.DisplayUnits` or
    ``--units``' text; default each file's own, issue 36).
    """
    if page is None:
        return
    from camsim.reports.build import build_report

    build_report(results, page, command=command_line(), units=units)
    if not quiet:
        err_console.print(f"wrote {page}", markup=False)

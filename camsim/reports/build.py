"""Build one self-contained HTML page from result files (``camsim report``, ``--report``).

:func:`build_report` opens each result file, reads its kind and calls the section builder
registered for it (:data:`camsim.reports.page.BUILDERS`); :func:`build_report_from` does
the same for an in-memory result without a file (a fit). The builders register themselves
when their modules are imported, here, so this module sits above them and they below it
import only :mod:`camsim.reports.page`.
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from camsim.errors import ResultFileError
from camsim.reports import optimize as _optimize  # noqa: F401  (registers the optimize builder)
from camsim.reports import sections as _sections  # noqa: F401  (registers the run and compare builders)
from camsim.reports import studies as _studies  # noqa: F401  (registers the sweep, study and fit builders)
from camsim.reports.page import BUILDERS, Section, Source, render_page, write_page

__all__ = ["build_report", "build_report_from", "sections_for"]


def _kind_of(f, path: Path) -> str:
    """The kind of an open result file: its ``file_kind`` attribute, else recognised by layout."""
    from camsim.io.results import attr_text, file_kind

    kind = attr_text(f, "file_kind")
    if not kind:
        kind = file_kind(f)
    if kind not in BUILDERS:
        known = ", ".join(sorted(BUILDERS))
        raise ResultFileError(f"{path}: file_kind: no report page for a {kind!r} result (pages exist for: {known})")
    return kind


def sections_for(source: Source) -> list[Section]:
    """The sections of one source through the registry."""
    return BUILDERS[source.kind](source)


def _units(units: Any, f) -> Any:
    """The display units of one file's sections: as given (a DisplayUnits, si, us) or the file's own."""
    from camsim.display import DisplayUnits
    from camsim.io.results import file_display_units

    if isinstance(units, DisplayUnits):
        return units
    return file_display_units(f, units or "file")


def build_report(paths: Sequence[str | os.PathLike[str]], output: str | os.PathLike[str], *, command: str = "",
                 pdf: str | os.PathLike[str] | None = None, title: str | None = None, units: Any = None) -> Path:
    """Write the HTML page of one or more result files (and optionally its PDF).

    Parameters
    ----------
    paths : sequence of path
        camsim result files (run, compare, sweep, study); several files give one page
        with the sections of each in turn.
    output : path
        The ``.html`` file, written atomically; never one of the inputs.
    command : str
        The command that produced the results, shown in the header when known.
    pdf : path, optional
        Also print the page to this PDF through the local Chromium
        (:func:`camsim.reports.browser.print_pdf`).
    title : str, optional
        Page title (default: the machine name or the file name).
    units : DisplayUnits or str, optional
        Units of the values shown: ``"file"`` (default: each result's machine file's own,
        recorded in the file), ``"si"``, ``"us"``, or a :class:`~camsim.display.DisplayUnits`.

    Returns
    -------
    Path
        The written HTML file.

    Raises
    ------
    ResultFileError, InputError
        Not a camsim result, a kind without a page, an unwritable output, no browser for
        ``pdf``, or bokeh missing; nothing is written then.
    """
    from camsim.extras import require
    from camsim.io.atomic import check_writable
    from camsim.io.results import open_h5

    require("bokeh", "report")  # issue 44: the install hint (exit 2), never "internal error"
    out = Path(output)
    inputs = [Path(p) for p in paths]
    if not inputs:
        raise ResultFileError("camsim report: give at least one result file")
    for p in inputs:
        if p.exists() and out.exists() and os.path.samefile(p, out):
            raise ResultFileError(f"{out}: is an input result file; choose another output name")
    check_writable(out)
    if pdf is not None:
        from camsim.reports.browser import find_browser

        check_writable(pdf)
        find_browser(required=True)
    all_sections: list[Section] = []
    names = []
    opened = []
    try:
        for p in inputs:
            f = open_h5(p)
            opened.append(f)
            kind = _kind_of(f, p)
            names.append((p, kind, f))
        for i, (p, kind, f) in enumerate(names):
            prefix = f"f{i}-" if len(names) > 1 else ""
            all_sections += sections_for(Source(p, kind, h5=f, command=command, prefix=prefix, units=_units(units, f)))
        if title is None:
            from camsim.io.results import attr_text

            first = names[0]
            title = f"{attr_text(first[2], 'machine_name', first[0].name)} — {first[1]} report"
    finally:
        for f in opened:
            f.close()
    text = render_page(all_sections, title)
    write_page(text, out)
    if pdf is not None:
        from camsim.reports.browser import print_pdf

        print_pdf(out, pdf)
    return out


def build_report_from(obj: Any, kind: str, output: str | os.PathLike[str], *, command: str = "",
                      pdf: str | os.PathLike[str] | None = None, title: str = "", units: Any = None) -> Path:
    """The page of an in-memory result that has no result file (a fit), values in ``units``."""
    from camsim.extras import require
    from camsim.io.atomic import check_writable

    require("bokeh", "report")

    check_writable(output)
    if pdf is not None:
        from camsim.reports.browser import find_browser

        check_writable(pdf)
        find_browser(required=True)
    text = render_page(sections_for(Source(None, kind, obj=obj, command=command, units=units)), title or f"{kind} report")
    out = write_page(text, output)
    if pdf is not None:
        from camsim.reports.browser import print_pdf

        print_pdf(out, pdf)
    return out

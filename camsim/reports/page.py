"""The page model of an HTML report, its kind registry and its renderer.

A page is a list of :class:`Section` (HTML blocks and Bokeh :class:`Plot` objects); a
section builder turns one :class:`Source` (a result file, or an in-memory result) into
sections and is registered for its result kind in :data:`BUILDERS` (``kind ->
builder(source) -> [Section]``) with :func:`register`. The builders
(:mod:`camsim.reports.sections`, :mod:`camsim.reports.optimize`) sit above this module and
:mod:`camsim.reports.build` above them: it opens the files and calls the builders. Adding
a page for a new kind is one builder module with one :func:`register` call, imported by
:mod:`camsim.reports.build`; nothing else compares kind names. :func:`render_page` puts the
sections into ``page.html.jinja`` (package data) with Bokeh's runtime and the page's CSS
inlined; :func:`write_page` writes the file atomically.
"""

from __future__ import annotations

import datetime as _dt
import html
import math
import os
import sys
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path
from typing import Any

import numpy as np

__all__ = ["BUILDERS", "Column", "Plot", "Section", "Shown", "Source", "register", "render_page", "write_page"]


# ---------------------------------------------------------------------- page model
@dataclass
class Plot:
    """A Bokeh model placed on the page, with its accessible description.

    Attributes
    ----------
    model : bokeh Model
        Given a unique ``name`` (tests and scripts find it by that name).
    alt : str
        What the plot shows, for screen readers (``aria-label``) and the caption.
    """

    model: Any
    alt: str


@dataclass
class Section:
    """One titled part of a page (a printed page holds one or more sections).

    ``blocks`` are HTML strings (already escaped) and :class:`Plot` objects, in order.
    """

    id: str
    title: str
    blocks: list = field(default_factory=list)

    def add(self, *blocks) -> "Section":
        self.blocks.extend(blocks)
        return self


@dataclass
class Source:
    """What a section builder reads: one result file (open) or an in-memory result.

    Attributes
    ----------
    path : Path or None
        The result file (None for a result that was never written, e.g. a fit).
    kind : str
        The registry key.
    h5 : h5py.File or None
        The file, open read-only while the builder runs.
    obj : object
        An in-memory result (:class:`~camsim.analyses.fit.FitResult`) when there is no file.
    command : str
        The command line that produced the result, when known.
    prefix : str
        Prefix of section ids and model names (several files on one page).
    units : DisplayUnits
        The units the page shows values in (issue 36: the result's machine file's own by
        default, ``--units si|us``); SI when not given.
    """

    path: Path | None
    kind: str
    h5: Any = None
    obj: Any = None
    command: str = ""
    prefix: str = ""
    units: Any = None

    def name(self, text: str) -> str:
        return f"{self.prefix}{text}"

    # -- values: the display layer is the only way a section gets a unit text --------------
    @property
    def display(self):
        """The page's :class:`~camsim.display.DisplayUnits` (SI when none was given)."""
        from camsim.reports.display import as_display

        return as_display(self.units or "si")

    def show(self, values: Any, si_unit: str, as_unit: str = "") -> "Shown":
        """``values`` (a number or an array in ``si_unit``) converted to the page's unit, with that unit.

        ``as_unit`` picks a presentation unit of a quantity shown the same in every system:
        ``"ms"`` for a time in s, ``"%"`` for a fraction. A section never holds a unit text
        apart from the values converted to it (issue 44: the impact detail drew newtons under
        an ``[lbf]`` label).
        """
        if as_unit:
            base, factor = _PRESENTATION[as_unit]
            if si_unit != base:
                raise ValueError(f"{as_unit} shows a quantity in {base!r}, not {si_unit!r}")
            unit = as_unit
        else:
            unit, factor = self.display.shown(si_unit)
        try:
            shown = np.asarray(values, dtype=float) * factor if not np.isscalar(values) else float(values) * factor
        except (TypeError, ValueError):
            shown = float("nan")
        return Shown(shown, unit, si_unit)

    def number(self, value: Any, si_unit: str, spec: str = ".4g", key: str = "", as_unit: str = "") -> str:
        """One value as the page shows it, in a ``span.value`` that records the SI value and both
        units (``data-si``, ``data-si-unit``, ``data-unit``) so a test can read it back; no unit text."""
        shown = self.show(value, si_unit, as_unit)
        try:
            si = repr(float(value))
        except (TypeError, ValueError):
            si = "nan"
        data = f" data-key='{esc(key)}'" if key else ""
        from camsim.display import typographic

        return (f"<span class=value{data} data-si='{si}' data-si-unit='{esc(typographic(si_unit))}' data-unit='{esc(shown.unit or '-')}'>"
                f"{fmt(shown.values, spec)}</span>")

    def quantity(self, value: Any, si_unit: str, spec: str = ".4g", key: str = "", as_unit: str = "") -> str:
        """:meth:`number` followed by its unit (``50.66 lbf``), for prose and verdict tiles."""
        shown = self.show(value, si_unit, as_unit)
        return self.number(value, si_unit, spec, key, as_unit) + (f" {esc(shown.unit)}" if shown.unit else "")

    def text(self, value: Any, si_unit: str, spec: str = ".4g") -> str:
        """Plain text ``"50.66 lbf"`` (not HTML: a select option, a plot's description); ``–`` for None/NaN."""
        shown = self.show(value, si_unit)
        return f"{fmt(shown.values, spec)} {shown.unit}".rstrip() if fmt(shown.values, spec) != "–" else "–"

    def column(self, name: str, si_unit: str, as_unit: str = "") -> "Column":
        """A table column of a quantity: its header with the unit and its cells, from one conversion."""
        return Column(self, name, si_unit, as_unit)


#: Presentation units of quantities shown alike in every system: unit -> (SI unit, factor).
_PRESENTATION = {"ms": ("s", 1e3), "µs": ("s", 1e6), "%": ("", 100.0)}


@dataclass(frozen=True)
class Shown:
    """Values converted to the page's unit, and that unit (``""`` for a number): never apart.

    Attributes
    ----------
    values : float or ndarray
        In ``unit``.
    unit : str
        What the values are in, as shown.
    si_unit : str
        What they were in.
    """

    values: Any
    unit: str
    si_unit: str

    def label(self, name: str) -> str:
        """An axis label or header, ``"force [lbf]"`` (``"ratio [-]"`` for a number)."""
        return f"{name} [{self.unit or '-'}]"


@dataclass(frozen=True)
class Column:
    """A table column: ``header`` carries the unit its ``cell`` values are converted to."""

    source: Source
    name: str
    si_unit: str
    as_unit: str = ""

    @property
    def header(self) -> str:
        return self.source.show(1.0, self.si_unit, self.as_unit).label(self.name)

    def cell(self, value: Any, spec: str = ".4g", key: str = "") -> str:
        if isinstance(value, (bool, np.bool_)):
            return fmt(bool(value))
        if isinstance(value, (str, bytes)):
            return esc(value.decode() if isinstance(value, bytes) else value)
        return self.source.number(value, self.si_unit, spec, key, self.as_unit)


Builder = Callable[[Source], list[Section]]
#: kind -> section builder; filled by :mod:`camsim.reports.sections` (and by any later kind).
BUILDERS: dict[str, Builder] = {}


def register(kind: str) -> Callable[[Builder], Builder]:
    """Decorator registering the section builder of a result kind."""

    def wrap(fn: Builder) -> Builder:
        BUILDERS[kind] = fn
        return fn

    return wrap


# ---------------------------------------------------------------------- HTML helpers
def esc(text: object) -> str:
    return html.escape(str(text), quote=True)


def fmt(value: Any, spec: str = ".4g") -> str:
    """A number as the page shows it: 4 significant digits, – for NaN/None, ∞."""
    if value is None:
        return "–"
    if isinstance(value, (bool,)):
        return "yes" if value else "no"
    try:
        v = float(value)
    except (TypeError, ValueError):
        return esc(value)
    if math.isnan(v):
        return "–"
    if math.isinf(v):
        return "∞" if v > 0 else "−∞"
    return format(v, spec)


def table(headers: Sequence[str], rows: Sequence[Sequence[Any]], *, cls: str = "", id: str = "", caption: str = "",
          numeric: Sequence[bool] | None = None) -> str:
    """An HTML table; ``rows`` hold ready HTML (use :func:`fmt`/:func:`esc`)."""
    numeric = numeric or [False] * len(headers)
    head = "".join(f'<th scope="col"{" class=num" if n else ""}>{esc(h)}</th>' for h, n in zip(headers, numeric))
    body = "".join(
        "<tr>" + "".join(f'<td{" class=num" if n else ""}>{c}</td>' for c, n in zip(row, numeric)) + "</tr>"
        for row in rows
    )
    cap = f"<caption>{esc(caption)}</caption>" if caption else ""
    return (f'<div class="table-wrap"><table{f" id={esc(id)}" if id else ""} class="{esc(cls)}">{cap}'
            f"<thead><tr>{head}</tr></thead><tbody>{body}</tbody></table></div>")


def definition_list(items: Sequence[tuple[str, str]], cls: str = "facts") -> str:
    """``<dl>`` of (label, ready HTML) pairs."""
    return f'<dl class="{cls}">' + "".join(f"<dt>{esc(k)}</dt><dd>{v}</dd>" for k, v in items) + "</dl>"


def verdict(label: str, state: str, detail: str, key: str) -> str:
    """One verdict tile: ``state`` is ``ok``, ``warn`` or ``fail`` (said in words too, not by colour);
    ``nodata`` when nothing could be checked (issue 35: never OK without data)."""
    word = {"ok": "OK", "warn": "CHECK", "fail": "FAIL", "info": "INFO", "nodata": "NO DATA"}[state]
    return (f'<div class="verdict {state}" data-verdict="{esc(key)}"><span class="state">{word}</span>'
            f"<h3>{esc(label)}</h3><p>{detail}</p></div>")


# ---------------------------------------------------------------------- building
def render_page(sections: list[Section], title: str) -> str:
    """The page as HTML text: sections, Bokeh runtime and CSS inline, no external resource."""
    from camsim.reports.figures import bokeh

    bokeh()
    from bokeh.embed import file_html
    from bokeh.resources import INLINE

    models = [b.model for s in sections for b in s.blocks if isinstance(b, Plot)]
    blocks = []
    for s in sections:
        parts = []
        for b in s.blocks:
            if isinstance(b, Plot):
                parts.append({"plot": b.model.name, "alt": b.alt, "height": _stretch(b.model)})
            else:
                parts.append({"html": b})
        blocks.append({"id": s.id, "title": s.title, "parts": parts})
    template = resources.files("camsim.reports").joinpath("page.html.jinja").read_text(encoding="utf-8")
    css = resources.files("camsim.reports").joinpath("page.css").read_text(encoding="utf-8")
    toc = "".join(f'<li><a href="#{esc(s.id)}">{esc(s.title)}</a></li>' for s in sections)
    variables = {"sections": blocks, "css": css, "page_title": title, "toc": toc, "esc": esc, "empty_root": not models}
    if not models:  # a page without plots still needs a document (and its root placed) for file_html
        from bokeh.models import Div

        models = [Div(text="", name="empty", visible=False)]
    return file_html(models, INLINE, title=title, template=template, template_variables=variables)


def _stretch(model) -> int | None:
    """Let a full-width plot take its height from the page's CSS (lower when printed).

    Returns the screen height [px] for the container, or None for plots that keep their
    own size (fixed-size figures, layouts)."""
    if getattr(model, "sizing_mode", None) != "stretch_width" or not getattr(model, "height", None) or not hasattr(model, "renderers"):
        return None
    height = int(model.height)
    model.sizing_mode = "stretch_both"
    model.height = None
    return height


def write_page(text: str, output: str | os.PathLike[str]) -> Path:
    """Write the page atomically (camsim.io.atomic)."""
    from camsim.io.outputs import writing

    out = Path(output)
    with writing(out, "html", owner="report") as target:
        target.put_text(text)
    return out


# ---------------------------------------------------------------------- shared header
def provenance(source: Source, machine_name: str) -> list[tuple[str, str]]:
    """Header facts of a result file: where it comes from and what computed it."""
    from camsim import __version__
    from camsim.io.results import attr_text

    import numpy
    import scipy

    f = source.h5
    items = [("machine", esc(machine_name))]
    if f is not None:
        items.append(("result file", f"<code>{esc(source.path)}</code> ({esc(source.kind)})"))
        items.append(("machine file sha256", f"<code>{esc(attr_text(f, 'machine_sha256', '–'))}</code>"))
        items.append(("written by camsim", esc(attr_text(f, "camsim_version", "–"))))
        mtime = _dt.datetime.fromtimestamp(Path(source.path).stat().st_mtime, _dt.timezone.utc)
        items.append(("result date (file time, UTC)", esc(mtime.strftime("%Y-%m-%d %H:%M:%S"))))
    items.append(("command", f"<code>{esc(source.command)}</code>" if source.command else "not recorded in the file"))
    now = _dt.datetime.now(_dt.timezone.utc).strftime("%Y-%m-%d %H:%M:%S")
    import bokeh as _bokeh

    items.append(("page built (UTC)", esc(now)))
    items.append(("page built with", esc(f"camsim {__version__}, numpy {numpy.__version__}, scipy {scipy.__version__}, "
                                          f"bokeh {_bokeh.__version__}, Python {sys.version.split()[0]}")))
    return items

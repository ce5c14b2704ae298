"""Bokeh figures of a report page: trace plots on a linked time axis, bars, histograms.

Every plot here is a Bokeh model; :mod:`camsim.reports.page` renders them into one HTML
file with Bokeh's runtime inlined. Conventions:

* colours from Okabe and Ito's colour-blind-safe set, each series also with its own dash
  pattern and the series in order of decreasing darkness, so a greyscale printout still
  tells them apart;
* every axis label ends with the unit in brackets;
* wheel zoom acts on the time axis only; every trace plot of a page shares one x range,
  so zooming one zooms them all.
"""

from __future__ import annotations

import numpy as np

from camsim.extras import require

#: Okabe & Ito (2008) colours, darkest first (black, blue, vermillion, bluish green,
#: reddish purple, orange, sky blue); readable by the common colour-vision deficiencies.
PALETTE = ("#000000", "#0072B2", "#D55E00", "#009E73", "#CC79A7", "#E69F00", "#56B4E9")
#: Dash patterns cycled with the colours (greyscale printouts).
DASHES = ("solid", "dashed", "dotted", "dotdash", "dashdot", (8, 3, 2, 3), (2, 2))
#: Height of a trace plot [px].
TRACE_HEIGHT = 270
#: Colour of the impact markers (Okabe & Ito vermillion, light).
IMPACT_COLOUR = "#D55E00"


def bokeh():
    """The Bokeh modules a page needs (MissingExtraError with the pip hint when absent)."""
    require("bokeh", "report")
    from bokeh import models, plotting

    return plotting, models


def style(i: int) -> dict:
    """Colour and dash of the ``i``-th series of a plot."""
    return {"line_color": PALETTE[i % len(PALETTE)], "line_dash": DASHES[i % len(DASHES)]}


def _base(name: str, title: str, x_label: str, y_label: str, x_range=None, height: int = TRACE_HEIGHT, x_only: bool = True):
    plotting, models = bokeh()
    dims = "width" if x_only else "both"
    tools = [
        models.PanTool(dimensions=dims),
        models.WheelZoomTool(dimensions=dims),
        models.BoxZoomTool(dimensions=dims if x_only else "both"),
        models.ResetTool(),
        models.SaveTool(),
    ]
    kwargs = {"x_range": x_range} if x_range is not None else {}
    p = plotting.figure(
        name=name, title=title, height=height, sizing_mode="stretch_width", tools=tools,
        x_axis_label=x_label, y_axis_label=y_label, output_backend="canvas", **kwargs,
    )
    p.min_border_left = 80  # stacked plots line up their time axes
    p.toolbar.autohide = True  # shown on hover; never on paper
    p.toolbar.active_scroll = tools[1]
    p.toolbar.active_drag = tools[2]
    p.title.text_font_size = "11pt"
    # The legend sits above the plot, never over the traces: renderers added with a
    # legend_label join this legend because it exists before they are added.
    p.add_layout(models.Legend(location="top_left", orientation="horizontal", label_text_font_size="9pt",
                               click_policy="hide", border_line_alpha=0.0, padding=2, margin=2, spacing=12), "above")
    return p


def finish_legend(p) -> None:
    """Drop the legend of a plot that has no labelled series; wrap a long one into rows."""
    legends = [r for r in p.above if type(r).__name__ == "Legend"]
    for legend in legends:
        if not legend.items:
            p.above.remove(legend)
        elif len(legend.items) > 5:
            legend.ncols = 5


def trace_figure(name: str, title: str, y_label: str, series, *, x_range=None, x_label: str = "time [s]",
                 angle_axis: tuple[float, float] | None = None, impact_times=None, note: str = ""):
    """One plot of traces against time.

    Parameters
    ----------
    name : str
        Model name (tests and scripts find the plot by it).
    title, y_label : str
        Plot title; y-axis label with its unit in brackets.
    series : list of (label, x, y)
        The lines (already reduced for display).
    x_range : Range, optional
        Shared with the other plots of the page (linked zoom).
    angle_axis : (theta0 [deg], omega [deg/s]), optional
        Adds a cam-angle axis on top: angle = theta0 + omega·t, linear in time, so both
        axes follow every zoom.
    impact_times : array, optional
        Impact times [s], marked by vertical bands.
    note : str
        Shown under the plot (the envelope reduction).
    """
    _, models = bokeh()
    p = _base(name, title, x_label, y_label, x_range)
    for i, (label, x, y) in enumerate(series):
        p.line(np.asarray(x, dtype=float), np.asarray(y, dtype=float), legend_label=label, line_width=1.4, **style(i))
    if impact_times is not None and len(impact_times):
        p.vspan(x=np.asarray(impact_times, dtype=float), line_color=IMPACT_COLOUR, line_alpha=0.55, line_width=1,
                line_dash="dashed")
    if angle_axis is not None:
        theta0, omega = angle_axis
        formatter = models.CustomJSTickFormatter(
            args={"theta0": float(theta0), "omega": float(omega)},
            code="return (theta0 + omega * tick).toFixed(1);",
        )
        p.add_layout(models.LinearAxis(axis_label="cam angle [deg]", formatter=formatter), "above")
    if series:  # a plot its caller fills later finishes its legend itself
        finish_legend(p)
    if note:
        p.add_layout(models.Title(text=note, text_font_size="8pt", text_font_style="italic", text_color="#444444"), "below")
    return p


def xy_figure(name: str, title: str, x_label: str, y_label: str, series, *, markers: bool = False, equal: bool = False,
              height: int = 320, x_range=None):
    """Curves y(x) (sweep columns, cam profile): both axes zoom."""
    _, models = bokeh()
    p = _base(name, title, x_label, y_label, x_range=x_range, height=height, x_only=False)
    if equal:
        p.match_aspect = True
        p.aspect_scale = 1
        p.sizing_mode = "fixed"
        p.width = p.height = 420
    for i, (label, x, y) in enumerate(series):
        kw = style(i)
        p.line(np.asarray(x, dtype=float), np.asarray(y, dtype=float), legend_label=label, line_width=1.6, **kw)
        if markers:
            p.scatter(np.asarray(x, dtype=float), np.asarray(y, dtype=float), legend_label=label, size=6,
                      marker=("circle", "square", "triangle", "diamond", "inverted_triangle", "plus", "star")[i % 7],
                      fill_color=kw["line_color"], line_color=kw["line_color"])
    if series:
        finish_legend(p)
    return p


def bar_figure(name: str, title: str, categories: list[str], groups: dict[str, list[float]], y_label: str,
               errors: dict[str, tuple[list[float], list[float]]] | None = None, height: int = 300):
    """Grouped bars (Sobol' indices): one bar per group and category, with optional intervals."""
    plotting, models = bokeh()
    from bokeh.transform import factor_cmap, factor_hatch

    factors = [(c, g) for c in categories for g in groups]
    top = [float(groups[g][i]) for i, _ in enumerate(categories) for g in groups]
    hatch = (" ", "/", ".", "x", "-", "|")
    src = models.ColumnDataSource({"x": factors, "top": top, "group": [g for _, g in factors]})
    p = plotting.figure(name=name, title=title, x_range=models.FactorRange(*factors), height=height,
                        sizing_mode="stretch_width", tools="save", y_axis_label=y_label)
    p.vbar(x="x", top="top", width=0.85, source=src, line_color="#000000",
           fill_color=factor_cmap("group", list(PALETTE[1:len(groups) + 1]), list(groups), start=1, end=2),
           hatch_pattern=factor_hatch("group", list(hatch[:len(groups)]), list(groups), start=1, end=2),
           hatch_color="#ffffff")
    if errors:
        lo = [float(errors[g][0][i]) for i, _ in enumerate(categories) for g in groups]
        hi = [float(errors[g][1][i]) for i, _ in enumerate(categories) for g in groups]
        esrc = models.ColumnDataSource({"x": factors, "lo": lo, "hi": hi})
        p.add_layout(models.Whisker(source=esrc, base="x", lower="lo", upper="hi", line_color="#000000"))
    p.xaxis.major_label_orientation = 0.9
    p.title.text_font_size = "11pt"
    return p


def histogram_figure(name: str, title: str, values: np.ndarray, x_label: str, limits: list[tuple[str, float]] = (),
                     bins: int = 30, height: int = 260):
    """A histogram of study outputs, with vertical lines at the limits."""
    _, models = bokeh()
    values = np.asarray(values, dtype=float)
    values = values[np.isfinite(values)]
    p = _base(name, title, x_label, "runs [-]", height=height, x_only=False)
    if values.size:
        counts, edges = np.histogram(values, bins=bins)
        p.quad(left=edges[:-1], right=edges[1:], bottom=0, top=counts, fill_color=PALETTE[1], fill_alpha=0.6,
               line_color="#000000", legend_label="runs")
    for i, (label, x) in enumerate(limits):
        p.add_layout(models.Span(location=float(x), dimension="height", line_color=PALETTE[2], line_width=2,
                                 line_dash=DASHES[(i + 1) % len(DASHES)]))
        p.add_layout(models.Label(x=float(x), y=5, y_units="screen", text=label, text_font_size="9pt",
                                  text_color=PALETTE[2], x_offset=4))
    return p


def image_figure(name: str, title: str, labels: list[str], matrix: np.ndarray, height: int = 360):
    """A correlation matrix as a grey-to-colour heat map with the values written in the cells."""
    plotting, models = bokeh()
    n = len(labels)
    xs, ys, vals, texts = [], [], [], []
    for i in range(n):
        for j in range(n):
            v = float(matrix[i, j])
            xs.append(labels[j])
            ys.append(labels[i])
            vals.append(v)
            texts.append(f"{v:+.2f}")
    src = models.ColumnDataSource({"x": xs, "y": ys, "v": vals, "t": texts})
    mapper = models.LinearColorMapper(palette=_diverging(), low=-1, high=1)
    p = plotting.figure(name=name, title=title, x_range=labels, y_range=list(reversed(labels)), height=height,
                        width=max(420, 150 * n + 320), tools="save", x_axis_label="parameter [-]", y_axis_label="parameter [-]")
    p.rect(x="x", y="y", width=1, height=1, source=src, fill_color={"field": "v", "transform": mapper}, line_color="#ffffff")
    p.text(x="x", y="y", text="t", source=src, text_align="center", text_baseline="middle", text_font_size="10pt")
    p.add_layout(models.ColorBar(color_mapper=mapper, title="correlation [-]"), "right")
    p.xaxis.major_label_orientation = 0.6
    return p


def _diverging() -> list[str]:
    """Blue–white–vermillion: symmetric in lightness, so greyscale reads |r|."""
    lo, mid, hi = np.array([0, 114, 178]), np.array([255, 255, 255]), np.array([213, 94, 0])
    out = []
    for s in np.linspace(-1, 1, 21):
        c = mid + (lo - mid) * (-s) if s < 0 else mid + (hi - mid) * s
        out.append("#%02x%02x%02x" % tuple(int(round(v)) for v in c))
    return out

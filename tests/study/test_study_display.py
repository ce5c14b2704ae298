"""Issue 44, item 7: what a study shows.

* the CLI table never cuts an output name (three rows of ``peak_displacement:…`` on an
  80-column terminal looked identical);
* the page's histograms count the runs its statistics use (blocks A and B of Saltelli's design:
  2N runs, not the N (d + 2) of the whole design) and a constant output gets none;
* the Sobol' legend of ``study.png`` does not cover the bars.

Reference: the study's own statistics (``n`` of each output) and the design's definition
(Saltelli 2010: blocks A and B are the 2N draws of the input distribution).
"""

from __future__ import annotations

import io
from pathlib import Path

import numpy as np
import pytest
from rich.console import Console

ROOT = Path(__file__).resolve().parents[2]
N = 4


@pytest.fixture(scope="module")
def result(tmp_path_factory):
    from camsim.analyses.study import study

    out = tmp_path_factory.mktemp("study") / "s.h5"
    r = study(ROOT / "machines" / "cdtm.toml", ["element.K23.preload=tol:28.12:3lbf", "element.seat.gap=tol:0.0625:0.005in"],
              N, sensitivity=True, sample_rate=2000.0, warmup_cycles=0, workers=1, output=out)
    from camsim.analyses.study.files import write_study

    write_study(r, out)
    r.path = out
    return r


def test_names_are_never_cut_on_a_narrow_terminal(result):
    from camsim.cli.cmd_study import _render

    buf = io.StringIO()
    _render(result, Console(file=buf, width=80, emoji=False, highlight=False), "file")
    text = buf.getvalue()
    for name in result.stats:
        assert name in text, f"{name} cut: {[line for line in text.splitlines() if name.split(':')[0] in line][:3]}"
    assert "…" not in "".join(line.split("│")[0] for line in text.splitlines() if "│" in line)


def test_histograms_count_the_runs_of_the_statistics_and_skip_constants(result):
    pytest.importorskip("bokeh")
    from bokeh.models import GlyphRenderer, Quad

    from camsim.io.results import open_h5
    from camsim.reports.build import _units, sections_for
    from camsim.reports.page import Plot, Source

    assert result.n_runs == N * (2 + 2)
    with open_h5(result.path) as f:
        sections = sections_for(Source(result.path, "study", h5=f, units=_units(None, f)))
    hist = next(s for s in sections if s.id == "histograms")
    counted = {}
    for block in hist.blocks:
        if isinstance(block, Plot):
            for r in block.model.select({"type": GlyphRenderer}):
                if isinstance(r.glyph, Quad):
                    counted[block.model.name] = int(np.sum(r.data_source.data["top"]))
    assert counted and set(counted.values()) == {2 * N}, counted
    assert "hist-peak_displacement-M1" not in counted  # driven by the cam: the same in every run
    assert "hist-peak_transducer_force" in counted


def test_sobol_legend_does_not_cover_the_bars(result):
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.patches import Rectangle

    from camsim.figures.study import plot_study

    fig = plot_study(result)
    FigureCanvasAgg(fig).draw()
    renderer = fig.canvas.get_renderer()
    checked = 0
    for ax in fig.axes:
        legend = ax.get_legend()
        if legend is None:
            continue
        box = legend.get_window_extent(renderer)
        for patch in ax.patches:
            if isinstance(patch, Rectangle) and patch.get_width() != 0:
                from matplotlib.transforms import Bbox

                seen = Bbox.intersection(patch.get_window_extent(renderer), ax.bbox)  # what is drawn of it
                assert seen is None or not box.overlaps(seen), f"the legend of {ax.get_title()} covers a bar"
                checked += 1
    assert checked

"""Fixtures of the report-page tests: real CDTM results and one Chromium per session.

The browser is the system's Chromium driven by Playwright (no download); without either,
the browser tests skip with one line saying why (``.ci/run`` installs Chromium).
"""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest

from camsim.reports.browser import CANDIDATES

ROOT = Path(__file__).resolve().parents[2]
CDTM = ROOT / "machines" / "cdtm.toml"

#: Finds every canvas of the page, inside Bokeh's shadow roots too, with whether it has ink.
CANVASES_JS = """() => {
  const out = [];
  const walk = (root) => { for (const el of root.querySelectorAll('*')) {
      if (el.tagName === 'CANVAS') out.push(el);
      if (el.shadowRoot) walk(el.shadowRoot); } };
  walk(document);
  return out.map(c => {
    let ink = 0;
    try { const d = c.getContext('2d').getImageData(0, 0, c.width, c.height).data;
          for (let i = 3; i < d.length; i += 4) if (d[i] > 0) ink++; } catch (e) { ink = -1; }
    return {w: c.width, h: c.height, ink: ink};
  });
}"""


def _chromium() -> str | None:
    for name in CANDIDATES:
        hit = shutil.which(name)
        if hit:
            return hit
    return None


@pytest.fixture(scope="session")
def browser():
    """One headless Chromium for the whole session (skips when there is none)."""
    pytest.importorskip("bokeh", reason="bokeh not installed (pip install 'camsim[report]')")
    try:
        from playwright.sync_api import sync_playwright
    except ModuleNotFoundError:
        pytest.skip("playwright not installed (pip install playwright); browser tests skipped")
    exe = _chromium()
    if exe is None:
        pytest.skip("no Chromium on PATH (apt-get install chromium); browser tests skipped")
    from camsim.reports.browser import launch

    with sync_playwright() as p:
        b = launch(p, exe)
        yield b
        b.close()


class LoadedPage:
    """A page opened from file:// with the network blocked, its console errors and failures."""

    def __init__(self, page, errors, failed, blocked):
        self.page, self.errors, self.failed, self.blocked = page, errors, failed, blocked


@pytest.fixture(scope="session")
def open_page(browser):
    """open_page(path) -> LoadedPage; every request that is not file: is aborted and recorded.

    Pages are opened once per session and shared (loading one costs seconds): tests that
    change a page (zoom, impact choice) read only what they changed."""
    from camsim.reports.browser import wait_rendered

    contexts = []
    cache: dict = {}

    def _open(path: Path, width: int = 1280) -> LoadedPage:
        if (path, width) in cache:
            return cache[(path, width)]
        ctx = browser.new_context(viewport={"width": width, "height": 900})
        contexts.append(ctx)
        errors, failed, blocked = [], [], []

        def route(r):
            if r.request.url.startswith("file:"):
                r.continue_()
            else:
                blocked.append(r.request.url)
                r.abort()

        ctx.route("**/*", route)
        page = ctx.new_page()
        page.on("console", lambda m: errors.append(m.text) if m.type == "error" else None)
        page.on("pageerror", lambda e: errors.append(str(e)))
        page.on("requestfailed", lambda r: failed.append(r.url))
        page.goto(path.resolve().as_uri())
        wait_rendered(page)
        page.wait_for_timeout(200)
        cache[(path, width)] = LoadedPage(page, errors, failed, blocked)
        return cache[(path, width)]

    yield _open
    for ctx in contexts:
        ctx.close()


@pytest.fixture(scope="session")
def cdtm_run(tmp_path_factory):
    """The CDTM run (1 revolution, the machine file's settings) and its page."""
    pytest.importorskip("bokeh", reason="bokeh not installed (pip install 'camsim[report]')")
    from typer.testing import CliRunner

    from camsim.cli import app

    d = tmp_path_factory.mktemp("report-run")
    h5, html = d / "cdtm.h5", d / "cdtm.html"
    r = CliRunner().invoke(app, ["run", str(CDTM), "-o", str(h5), "--report", str(html), "-q"])
    assert r.exit_code == 0, r.output
    return h5, html


@pytest.fixture(scope="session")
def cdtm_compare(tmp_path_factory):
    """The CDTM comparison (impact against no impact) and its page."""
    pytest.importorskip("bokeh", reason="bokeh not installed (pip install 'camsim[report]')")
    from typer.testing import CliRunner

    from camsim.cli import app

    d = tmp_path_factory.mktemp("report-compare")
    h5, html = d / "cdtm_compare.h5", d / "cdtm_compare.html"
    r = CliRunner().invoke(app, ["compare", str(CDTM), "-o", str(h5), "--report", str(html), "-q"])
    assert r.exit_code == 0, r.output
    return h5, html


@pytest.fixture(scope="session")
def cdtm_sweep(tmp_path_factory):
    """A 3-point CDTM speed sweep across the jump (300 to 500 rpm, 5 kHz, no warm-up) and its page."""
    pytest.importorskip("bokeh", reason="bokeh not installed (pip install 'camsim[report]')")
    from typer.testing import CliRunner

    from camsim.cli import app

    d = tmp_path_factory.mktemp("report-sweep")
    h5, html = d / "sweep.h5", d / "sweep.html"
    r = CliRunner().invoke(app, ["sweep", str(CDTM), "--vary", "cam.speed=300:500:100rpm", "--sample-rate", "5 kHz", "--warmup", "0",
                                 "--workers", "1", "-o", str(h5), "--report", str(html), "-q"])
    assert r.exit_code == 0, r.output
    return h5, html


@pytest.fixture(scope="session")
def cdtm_study(tmp_path_factory):
    """A small CDTM tolerance study with Sobol' indices and a limit (4 samples, 5 kHz, no warm-up)."""
    pytest.importorskip("bokeh", reason="bokeh not installed (pip install 'camsim[report]')")
    from typer.testing import CliRunner

    from camsim.cli import app

    d = tmp_path_factory.mktemp("report-study")
    h5, html = d / "study.h5", d / "study.html"
    r = CliRunner().invoke(app, ["study", str(CDTM), "--dist", "element.K23.preload=tol:28.12:3lbf",
                                 "--dist", "element.K23.push_stiffness=uniform:6000:9000lbf/in", "--sensitivity", "-n", "4", "--warmup", "0",
                                 "--limit", "peak_transducer_force>230N", "--sample-rate", "5 kHz", "--workers", "1",
                                 "-o", str(h5), "--report", str(html), "-q"])
    assert r.exit_code == 0, r.output
    return h5, html

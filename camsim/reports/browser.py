"""The local Chromium that prints a page to PDF (``camsim report --pdf``) and runs the page tests.

No browser is downloaded: camsim drives the system's Chromium (Debian/Ubuntu package
``chromium``; ``chromium-browser`` on some systems; or ``CAMSIM_CHROMIUM=/path``) through
Playwright's Python package, which brings its own driver.
"""

from __future__ import annotations

import os
import shutil
from pathlib import Path

from camsim.errors import InputError

#: Executable names looked up on PATH, in order.
CANDIDATES = ("chromium", "chromium-browser", "google-chrome", "google-chrome-stable")

HOW_TO = ("install Chromium (Debian/Ubuntu: sudo apt-get install chromium) and Playwright "
          "(pip install playwright; no 'playwright install' is needed), or set CAMSIM_CHROMIUM to a Chromium executable")


def find_browser(required: bool = False) -> str | None:
    """Path of a Chromium executable, or None (InputError with how to get one when ``required``)."""
    env = os.environ.get("CAMSIM_CHROMIUM")
    if env:
        if Path(env).is_file() and os.access(env, os.X_OK):
            return env
        if required:
            raise InputError(f"--pdf: CAMSIM_CHROMIUM={env} is not an executable file")
        return None
    for name in CANDIDATES:
        hit = shutil.which(name)
        if hit:
            if required:
                _playwright(required=True)
            return hit
    if required:
        raise InputError(f"--pdf: no Chromium found to print the page; {HOW_TO}")
    return None


def _playwright(required: bool = True):
    try:
        from playwright.sync_api import sync_playwright
    except ModuleNotFoundError:
        if required:
            raise InputError(f"--pdf: the Python package playwright is not installed; {HOW_TO}") from None
        return None
    return sync_playwright


def launch(playwright, executable: str | None = None):
    """Launch the system Chromium headless with Playwright (``playwright`` from sync_playwright())."""
    exe = executable or find_browser(required=True)
    return playwright.chromium.launch(executable_path=exe, args=["--no-sandbox"] if os.geteuid() == 0 else [])


def wait_rendered(page, timeout_ms: float = 30000) -> None:
    """Wait until Bokeh has built every root view of the page and painted it."""
    page.wait_for_function(
        "() => window.Bokeh && Bokeh.documents.length > 0 && Bokeh.documents[0].is_idle",
        timeout=timeout_ms,
    )


def print_pdf(html: str | os.PathLike[str], pdf: str | os.PathLike[str]) -> Path:
    """Print ``html`` to ``pdf`` (A4 landscape, the page's print CSS), written atomically."""
    from camsim.io.outputs import writing

    sync_playwright = _playwright(required=True)
    exe = find_browser(required=True)
    with sync_playwright() as p:
        browser = launch(p, exe)
        try:
            page = browser.new_page(viewport={"width": 1400, "height": 1000})
            page.route("**/*", lambda route: route.continue_() if route.request.url.startswith("file:") else route.abort())
            page.goto(Path(html).resolve().as_uri())
            wait_rendered(page)
            page.emulate_media(media="print")
            page.evaluate("() => document.querySelectorAll('details').forEach(d => d.open = true)")
            page.wait_for_timeout(300)  # Bokeh re-lays out after the media change
            data = page.pdf(format="A4", landscape=True, print_background=True, prefer_css_page_size=True)
        finally:
            browser.close()
    with writing(pdf, "pdf", owner="report", option="--pdf") as target:
        target.put_bytes(data)
    return Path(pdf)


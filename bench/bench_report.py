"""Report pages (issue 29): size, build time and load time of ``camsim report`` pages.

    python bench/bench_report.py                 # CDTM 1 revolution and 100 revolutions (streamed)
    python bench/bench_report.py --revs 1 10     # other revolution counts
    python bench/bench_report.py --libraries     # also the Bokeh / Plotly comparison of docs/report.md

For each revolution count: ``camsim run machines/cdtm.toml --cycles N`` writes a streamed
result file (not timed), then ``camsim report`` builds its page in a fresh process (wall
time), and the system Chromium (Playwright) opens it from file:// with the network
blocked, until Bokeh has rendered every plot: best of 3 loads, each in a new page. Targets
(issue 29): a 100-revolution page under 20 MB that opens in under 5 s.

``--libraries`` builds the same 20 trace plots of the 1-revolution run (min/max envelope of
2000 columns) with Bokeh (INLINE resources, ``file_html``) and with Plotly (bundle embedded
once, ``to_html``), and measures size, build time (imports included) and render time the
same way; it needs plotly installed (``pip install plotly``), which camsim does not use.
The load average is printed before and after: the figures are only as quiet as the machine.
"""

from __future__ import annotations

import argparse
import os
import platform
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
CDTM = ROOT / "machines" / "cdtm.toml"


def _env() -> dict:
    env = dict(os.environ)
    env["PYTHONPATH"] = str(ROOT) + os.pathsep + env.get("PYTHONPATH", "")
    return env


def load_time(browser, html: Path, wait_js: str, repeats: int = 3) -> float:
    """Best of ``repeats`` [s]: from navigation to the plots drawn, network blocked."""
    best = float("inf")
    for _ in range(repeats):
        page = browser.new_page(viewport={"width": 1280, "height": 900})
        page.route("**/*", lambda r: r.continue_() if r.request.url.startswith("file:") else r.abort())
        t = time.perf_counter()
        page.goto(html.resolve().as_uri())
        page.wait_for_function(wait_js, timeout=120_000)
        best = min(best, time.perf_counter() - t)
        page.close()
    return best


BOKEH_READY = "() => window.Bokeh && Bokeh.documents.length > 0 && Bokeh.documents[0].is_idle"
PLOTLY_READY = ("() => document.querySelectorAll('.js-plotly-plot').length > 0 && "
                "[...document.querySelectorAll('.js-plotly-plot')].every(d => d._fullLayout)")


def pages(revs: list[int], workdir: Path, browser) -> None:
    print(f"{'revolutions':>11} {'samples/trace':>13} {'result [MB]':>11} {'page [MB]':>9} {'build [s]':>9} {'load [s]':>8}")
    for n in revs:
        h5, html = workdir / f"cdtm-{n}.h5", workdir / f"cdtm-{n}.html"
        subprocess.run([sys.executable, "-m", "camsim", "run", str(CDTM), "--cycles", str(n), "-o", str(h5), "-q"],
                       check=True, env=_env(), stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        t = time.perf_counter()
        subprocess.run([sys.executable, "-m", "camsim", "report", str(h5), "-o", str(html)], check=True, env=_env(),
                       stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        build = time.perf_counter() - t
        import h5py

        with h5py.File(h5, "r") as f:
            samples = f["time"].shape[0]
        print(f"{n:>11} {samples:>13} {h5.stat().st_size / 1e6:>11.1f} {html.stat().st_size / 1e6:>9.2f} {build:>9.2f} "
              f"{load_time(browser, html, BOKEH_READY):>8.2f}", flush=True)


def libraries(workdir: Path, browser) -> None:
    """Bokeh against Plotly on the 20 traces of one CDTM revolution."""
    h5 = workdir / "cdtm-1.h5"
    if not h5.exists():
        subprocess.run([sys.executable, "-m", "camsim", "run", str(CDTM), "-o", str(h5), "-q"], check=True, env=_env(),
                       stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    code = r'''
import sys, time
t0 = time.perf_counter()
import h5py
from camsim.io.results import list_traces
from camsim.reports.envelope import envelope
lib, h5, out = sys.argv[1:]
with h5py.File(h5, "r") as f:
    traces = list_traces(f)
    t = traces.pop("time")[()]
    data = {k: v[()] for k, v in traces.items()}
if lib == "bokeh":
    from bokeh.embed import file_html
    from bokeh.layouts import column
    from bokeh.plotting import figure
    from bokeh.resources import INLINE
    figs, xr = [], None
    for k, y in data.items():
        x, yy, _ = envelope(t, y)
        p = figure(height=250, sizing_mode="stretch_width", title=k, **({"x_range": xr} if xr else {}))
        xr = p.x_range
        p.line(x, yy)
        figs.append(p)
    html = file_html(column(*figs, sizing_mode="stretch_width"), INLINE, "bench")
else:
    import plotly.graph_objects as go
    import plotly.io as pio
    parts = []
    for i, (k, y) in enumerate(data.items()):
        x, yy, _ = envelope(t, y)
        fig = go.Figure(go.Scatter(x=x, y=yy, mode="lines"))
        fig.update_layout(title=k, height=250)
        parts.append(pio.to_html(fig, include_plotlyjs=(i == 0), full_html=False))
    html = "<!DOCTYPE html><html><head><meta charset=utf-8></head><body>" + "".join(parts) + "</body></html>"
open(out, "w", encoding="utf-8").write(html)
print(time.perf_counter() - t0, len(data))
'''
    print(f"{'library':>8} {'version':>8} {'plots':>5} {'page [MB]':>9} {'build [s]':>9} {'render [s]':>10}")
    for lib, ready in (("bokeh", BOKEH_READY), ("plotly", PLOTLY_READY)):
        try:
            mod = __import__(lib)
        except ModuleNotFoundError:
            print(f"{lib:>8} not installed: skipped")
            continue
        out = workdir / f"lib-{lib}.html"
        r = subprocess.run([sys.executable, "-c", code, lib, str(h5), str(out)], check=True, env=_env(), capture_output=True, text=True)
        build, n = r.stdout.split()
        print(f"{lib:>8} {mod.__version__:>8} {n:>5} {out.stat().st_size / 1e6:>9.2f} {float(build):>9.2f} "
              f"{load_time(browser, out, ready):>10.2f}", flush=True)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--revs", type=int, nargs="+", default=[1, 100], help="revolution counts (default 1 100)")
    ap.add_argument("--libraries", action="store_true", help="also compare Bokeh and Plotly (needs plotly)")
    args = ap.parse_args()
    from playwright.sync_api import sync_playwright

    from camsim.reports.browser import find_browser, launch

    exe = find_browser(required=True)
    print(f"{platform.node()} {platform.processor() or platform.machine()}, {os.cpu_count()} cores, Python {platform.python_version()}, "
          f"{subprocess.run([exe, '--version'], capture_output=True, text=True).stdout.strip()}")
    print(f"load average before: {os.getloadavg()}")
    with tempfile.TemporaryDirectory() as d, sync_playwright() as p:
        browser = launch(p, exe)
        try:
            pages(args.revs, Path(d), browser)
            if args.libraries:
                libraries(Path(d), browser)
        finally:
            browser.close()
    print(f"load average after: {os.getloadavg()}")


if __name__ == "__main__":
    main()

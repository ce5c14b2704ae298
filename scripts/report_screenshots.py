"""Screenshots of each report page kind for docs/report.md, taken by the system Chromium.

    python scripts/report_screenshots.py                 # writes docs/img/report-{run,compare,sweep,study,fit,optimize}.png
    python scripts/report_screenshots.py optimize        # only the kinds named

Makes the results with the CLI in a temporary directory (CDTM run, comparison, an
11-speed sweep, a small tolerance study, the fit of docs/fitting.md to the synthetic rig
trace of examples/make_rig_trace.py, a 24-candidate optimisation of two CDTM keys over
three speeds), writes each page with ``--report`` (``camsim report`` for the optimisation
history) and photographs
the top of it (1280 px wide, the first 1800 px) once Bokeh has drawn every plot.
"""

from __future__ import annotations

import os
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
CDTM = str(ROOT / "machines" / "cdtm.toml")
OUT = ROOT / "docs" / "img"


def camsim(*args: str) -> None:
    env = dict(os.environ)
    env["PYTHONPATH"] = str(ROOT) + os.pathsep + env.get("PYTHONPATH", "")
    subprocess.run([sys.executable, "-m", "camsim", *args], check=True, env=env, stdout=subprocess.DEVNULL)


KINDS = ("run", "compare", "sweep", "study", "fit", "optimize")


def make_pages(d: Path, kinds=KINDS) -> dict[str, Path]:
    pages = {k: d / f"{k}.html" for k in kinds}
    if "optimize" in kinds:
        # exit 0 (feasible) or 1 (none feasible) both leave a history with a page
        env = dict(os.environ, PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""))
        subprocess.run([sys.executable, "-m", "camsim", "optimize", CDTM, "--var", "element.K23.preload=20:60lbf",
                        "--var", "element.seat.stiffness=4e6:1.2e7N/m", "--minimize", "peak_transducer_force",
                        "--constraint", "jump<=0", "--speeds", "100,120,140rpm", "--method", "de", "--budget", "24",
                        "--sample-rate", "10 kHz", "-r", str(d / "optimize.h5"), "-o", str(d / "optimised.toml"), "-q"],
                       check=False, env=env, stdout=subprocess.DEVNULL)
        camsim("report", str(d / "optimize.h5"), "-o", str(pages["optimize"]))
    if set(kinds) <= {"optimize"}:
        return pages
    camsim("run", CDTM, "-o", str(d / "run.h5"), "-q", "--report", str(pages["run"]))
    camsim("compare", CDTM, "-o", str(d / "compare.h5"), "-q", "--report", str(pages["compare"]))
    camsim("sweep", CDTM, "--vary", "cam.speed=100:600:50rpm", "--sample-rate", "10 kHz", "-o", str(d / "sweep.h5"), "-q",
           "--report", str(pages["sweep"]))
    camsim("study", CDTM, "--dist", "element.K23.preload=tol:28.12:3lbf", "--dist", "element.seat.stiffness=tol:8.6e6:1.3e6N/m",
           "--sensitivity", "-n", "16", "--limit", "peak_transducer_force>230N", "--sample-rate", "10 kHz",
           "-o", str(d / "study.h5"), "-q", "--report", str(pages["study"]))
    rig = d / "rig.csv"
    subprocess.run([sys.executable, str(ROOT / "examples" / "make_rig_trace.py"), "-o", str(rig)], check=True,
                   stdout=subprocess.DEVNULL)
    camsim("fit", CDTM, str(rig), "--param", "element.K23.push_stiffness=6000:10000lbf/in",
           "--param", "element.seat.damping_ratio=0.01:0.3", "-o", str(d / "fitted.toml"), "--report", str(pages["fit"]))
    return pages


def main() -> None:
    from playwright.sync_api import sync_playwright

    from camsim.reports.browser import launch, wait_rendered

    kinds = tuple(sys.argv[1:]) or KINDS
    unknown = set(kinds) - set(KINDS)
    if unknown:
        raise SystemExit(f"unknown page kind(s) {sorted(unknown)}: choose from {', '.join(KINDS)}")
    OUT.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory() as tmp, sync_playwright() as p:
        pages = make_pages(Path(tmp), kinds)
        browser = launch(p)
        try:
            for kind, html in pages.items():
                page = browser.new_page(viewport={"width": 1280, "height": 1800})
                page.route("**/*", lambda r: r.continue_() if r.request.url.startswith("file:") else r.abort())
                page.goto(html.resolve().as_uri())
                wait_rendered(page)
                page.wait_for_timeout(500)
                target = OUT / f"report-{kind}.png"
                page.screenshot(path=str(target), full_page=False)
                print(f"wrote {target.relative_to(ROOT)}")
                page.close()
        finally:
            browser.close()


if __name__ == "__main__":
    main()

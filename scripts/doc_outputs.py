"""Every command output shown in README.md and docs/: made by running the command, checked by a test.

Usage::

    python scripts/doc_outputs.py                 # print every block as it would be written
    python scripts/doc_outputs.py --write         # rewrite the blocks in README.md and docs/*.md
    python scripts/doc_outputs.py --check         # exit 1, naming the stale blocks, if a page differs
    python scripts/doc_outputs.py --write readme-run cam-cdtm   # only the blocks named
    python scripts/doc_outputs.py --list          # the blocks, their pages, and which are slow
    python scripts/doc_outputs.py --commands      # run every camsim command shown in README.md and docs/

A block sits in its page between ``<!-- BEGIN doc_outputs.py:NAME -->`` and
``<!-- END doc_outputs.py:NAME -->`` and holds one fenced code block: each command as it is
shown (``$ camsim run machines/cdtm.toml``), then exactly what it printed (stderr and
stdout, in order). The commands run from a scratch copy of ``machines/``, ``examples/``,
``scripts/`` and the goldens, with this checkout's camsim (``python -m camsim``), so the
paths they print are the ones shown and nothing is written into the repository.

``tests/test_docs_snippets.py`` regenerates the blocks and compares them with the pages
(whitespace runs and table rules normalised, every other character exact): a change of
results (issue 34's located peaks) or of a table's layout fails it until
``python scripts/doc_outputs.py --write`` is run. Blocks marked slow (a 55-speed sweep, a
fit, the CI goldens check: tens of seconds each) are checked when ``CI=true`` or
``CAMSIM_SLOW=1``.

A figure quoted in prose is generated too (issue 44: "6551 in/s²" stood beside a table that
printed 6557): it sits between ``<!-- doc_outputs.py:NAME -->`` and ``<!-- /doc_outputs.py -->``
on one line, and :data:`FIGURES` says which command's ``--json`` gives it and how it is
written. ``--check`` and ``--write`` treat figures as blocks.

``--commands`` runs every ``camsim`` command line shown in README.md and docs/ (fenced or
indented blocks; synopses with placeholders such as ``MACHINE.toml`` or ``[...]`` are left
out), page by page in a scratch copy, and fails on a command that does not end as its page
shows (exit 0, or the error the page prints after it). Commands of many runs are made quick
by :data:`QUICK` (fewer samples, a smaller budget, a coarser sample rate): what is checked is
that the command, its options and its files work as shown.

Not generated here: the tables of docs/validation.md (``scripts/validation.py``, checked by
tests/test_validation.py), the machine-file reference of docs/machine-file.md
(``python -m camsim.machine.schema``), and timing records of ``bench/`` scripts
(docs/performance.md, docs/tolerance.md, docs/optimize.md): measurements of one machine on
one day, not reproducible output.
"""

from __future__ import annotations

import argparse
import os
import re
import shlex
import shutil
import subprocess
import sys
import tempfile
from dataclasses import dataclass, field
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


@dataclass(frozen=True)
class Step:
    """One command of a block: how it is shown and what is run (None: shown only, e.g. a long run)."""

    shown: str
    argv: tuple[str, ...] | None = None
    #: Keep only the output from the first line matching this (a block showing an excerpt).
    excerpt_from: str = ""

    @property
    def run(self) -> tuple[str, ...] | None:
        return self.argv if self.argv is not None else None


def camsim(shown: str, excerpt_from: str = "", run: bool = True) -> Step:
    """A camsim command as shown; run with this checkout's camsim."""
    argv = tuple(shlex.split(shown.replace("\\\n", " ")))
    return Step(shown, argv if run else None, excerpt_from)


def shell(shown: str) -> Step:
    return Step(shown, tuple(shlex.split(shown.replace("\\\n", " "))))


@dataclass(frozen=True)
class Block:
    page: str
    steps: tuple[Step, ...]
    fence: str = ""
    slow: bool = False
    #: Blocks that must run first in the same scratch directory (their files are inputs).
    after: tuple[str, ...] = field(default_factory=tuple)


TABLE6 = ('camsim impact --mass "2.029e-5 lbf*s**2/in" --drop-height "1 in" \\\n'
          '    --sphere-diameter "0.375 in" --modulus "2.9e7 psi" --stiffness "60800 lbf/in"')

#: The speed sweep of docs/press-station.md (its block and its jump-onset figures)
PRESS_SWEEP = "--vary cam.speed=100:300:10rpm --refine-jump --workers 2"

BLOCKS: dict[str, Block] = {
    "readme-run": Block("README.md", (camsim("camsim run machines/cdtm.toml"),)),
    "readme-sweep": Block("README.md", (
        camsim('camsim sweep machines/cdtm.toml --vary cam.speed=60:600:10rpm --sample-rate "10 kHz" --workers 2 '
               "-o cdtm_sweep.h5"),
        camsim("camsim plot cdtm_sweep.h5"),
    ), slow=True),
    "readme-ci-check": Block("README.md", (shell("sh scripts/ci-check.sh ci-results"),), slow=True),
    "cam-cdtm": Block("docs/cam.md", (camsim("camsim cam machines/cdtm.toml"),), fence="text"),
    "cam-design-geometry": Block("docs/cam-design.md", (
        camsim("camsim cam machines/cdtm-geometry.toml", excerpt_from=r"^cam geometry:"),), fence="text"),
    "impact-table6-json": Block("docs/impact.md", (camsim(TABLE6 + " --json"),), fence="console"),
    "impact-table6": Block("docs/impact.md", (camsim(TABLE6),)),
    "impact-pin": Block("docs/impact.md", (camsim(
        'camsim impact --mass "50 g" --velocity "1 m/s" --sphere-diameter "23 mm" --modulus "200 GPa" \\\n'
        '    --stiffness "8e7 N/m" --bar-area "20 mm**2" --bar-length "50 mm" --density "7850 kg/m**3"'),)),
    "results-max-output": Block("docs/results.md", (
        camsim("camsim run machines/cdtm.toml --set simulation.cycles=100000"),
        camsim("camsim run machines/cdtm.toml --set simulation.cycles=100000 --record-last 10   # 42 MB: runs",
               run=False),
    ), fence="console"),
    "results-extreme": Block("docs/results.md", (
        camsim('camsim run machines/dynacam-2mass.toml --set element.k12.stiffness="1e18 N/m"'),
        camsim('camsim run machines/dynacam-2mass.toml --set element.k12.stiffness="1e14 N/m" --cycles 40'),
    ), fence="console"),
    "regression-review": Block("docs/regression.md", (
        camsim("camsim run machines/cdtm.toml --sample-rate 5kHz --compress -o cdtm.h5", excerpt_from=r"^wrote "),
        camsim("camsim check cdtm.h5 --against tests/data/golden/cdtm.h5 --show 30", excerpt_from=r"^(PASS|FAIL)"),
    ), fence="console"),
    "cam-design-compare": Block("docs/cam-design.md", (
        camsim("camsim compare machines/cdtm-geometry.toml -o cdtm-geometry_compare.h5", excerpt_from=r"^cam design: impact vs"),
    ), fence="text"),
    "camshaft-cam": Block("docs/camshaft.md", (
        camsim("camsim cam machines/camshaft-line.toml", excerpt_from=r"^clearances over one revolution"),), fence="text"),
    "camshaft-run": Block("docs/camshaft.md", (
        camsim("camsim run machines/camshaft-line.toml -o line.h5", excerpt_from=r"^cams on the shaft"),), fence="text"),
    "camshaft-dynamic": Block("docs/camshaft.md", (
        camsim("camsim run machines/camshaft-line-dynamic.toml -o line-dyn.h5", excerpt_from=r"^cams on the shaft"),),
        fence="text", slow=True),
    "press-run": Block("docs/press-station.md", (camsim("camsim run machines/press-station.toml"),)),
    "press-run-bare": Block("docs/press-station.md", (
        camsim("camsim run machines/press-station-bare.toml", excerpt_from=r"^cam contact force"),)),
    "press-compare": Block("docs/press-station.md", (
        camsim("camsim compare machines/press-station.h5 machines/press-station-bare.h5"),),
        after=("press-run", "press-run-bare")),
    "press-sweep": Block("docs/press-station.md", (
        camsim(f"camsim sweep machines/press-station.toml {PRESS_SWEEP} -o press_sweep.h5"),
        camsim(f"camsim sweep machines/press-station-bare.toml {PRESS_SWEEP} -o press_bare_sweep.h5"),
    ), slow=True),
    "fitting-rig-trace": Block("docs/fitting.md", (
        shell("python examples/make_rig_trace.py"),
        shell("head -3 examples/rig_trace.csv"),
    ), fence="sh", slow=True),
    "fitting-fit": Block("docs/fitting.md", (camsim(
        "camsim fit machines/cdtm.toml examples/rig_trace.csv \\\n"
        "    --param element.K23.push_stiffness=6000:10000lbf/in \\\n"
        "    --param element.seat.damping_ratio=0.01:0.3 \\\n"
        "    --workers 2 -o cdtm_fitted.toml --report fit.png"),), fence="sh", slow=True, after=("fitting-rig-trace",)),
}


@dataclass(frozen=True)
class Figure:
    """A figure quoted in prose: the command whose ``--json`` (stdout) holds it, and how it is written."""

    page: str
    argv: tuple[str, ...]
    text: object  # Callable[[dict], str]: the payload → the text on the page
    #: A second command whose payload the figure also reads (a difference of two runs): then
    #: ``text`` takes both payloads, ``text(p, q)``.
    also: tuple[str, ...] | None = None


def _q(value: float, unit: str, si_unit: str, fmt: str = ".4g") -> str:
    """An SI value in ``unit`` (pint), written ``"6557 in/s²"``."""
    import pint

    ureg = pint.UnitRegistry()
    shown = ureg.Quantity(value, si_unit.replace("^", "**")).to(unit.replace("²", "**2").replace("·", "*")).magnitude
    return f"{format(shown, fmt)} {unit}"


def _cdtm_m2(p: dict) -> str:
    a = p["masses"]["M2"]["acceleration"]["peak"]
    return f"{_q(a, 'in/s²', 'm/s^2')} ({_q(a, 'm/s²', 'm/s^2', '.4g')})"


def _ball_peak(p: dict) -> str:
    return _q(max(e["peak_force"] for e in p["impacts"]), "lbf", "N")


def _shaft(key: str, unit: str, si_unit: str, fmt: str = ".4g"):
    def text(p: dict) -> str:
        return _q(p["camshaft"][key], unit, si_unit, fmt)
    return text


def _dynamics(key: str, unit: str, si_unit: str, fmt: str = ".6g"):
    def text(p: dict) -> str:
        return _q(p["camshaft"]["dynamics"][key], unit, si_unit, fmt)
    return text


def _residual(p: dict) -> str:
    return f"{p['periodicity_residual']:.3g}"


# ---- docs/press-station.md: the press-fit station with and without its process force and friction
PRESS_JSON = ("camsim", "run", "machines/press-station.toml", "-o", "press-json.h5", "--json")
BARE_JSON = ("camsim", "run", "machines/press-station-bare.toml", "-o", "press-bare-json.h5", "--json")
PRESS_SWEEP_JSON = ("camsim", "sweep", "machines/press-station.toml", *PRESS_SWEEP.split(), "-o", "press-sweep-json.h5",
                    "--json")
BARE_SWEEP_JSON = ("camsim", "sweep", "machines/press-station-bare.toml", *PRESS_SWEEP.split(), "-o",
                   "press-bare-sweep-json.h5", "--json")


def _angle(p: dict, t: float) -> str:
    """The shaft angle [deg] at time t [s] (rigid shaft from 0 deg), within the revolution."""
    import math

    return f"{math.degrees(p['camshaft']['mean_speed'] * t) % 360.0:.1f}°"


def _impact(p: dict, element: str) -> dict:
    return next(e for e in p["impacts"] if e["element"] == element)


def _press_figures() -> dict[str, Figure]:
    page = "docs/press-station.md"
    N = lambda v: _q(v, "N", "N")  # noqa: E731
    out: dict[str, Figure] = {}
    for tag, argv in (("press", PRESS_JSON), ("press-bare", BARE_JSON)):
        def fig(text, argv=argv):
            return Figure(page, argv, text)
        out.update({
            f"{tag}-min-fc": fig(lambda p: N(p["min_cam_contact_force"]["value"])),
            f"{tag}-min-fc-angle": fig(lambda p: _angle(p, p["min_cam_contact_force"]["time"])),
            f"{tag}-max-fc": fig(lambda p: N(p["max_cam_contact_force"]["value"])),
            f"{tag}-max-fc-angle": fig(lambda p: _angle(p, p["max_cam_contact_force"]["time"])),
            f"{tag}-stop-v": fig(lambda p: _q(_impact(p, "stop")["relative_velocity"], "m/s", "m/s")),
            f"{tag}-stop-angle": fig(lambda p: _angle(p, _impact(p, "stop")["time"])),
            f"{tag}-stop-peak": fig(lambda p: N(_impact(p, "stop")["peak_force"])),
            f"{tag}-stop-peak-angle": fig(lambda p: _angle(p, _impact(p, "stop")["peak_time"])),
            f"{tag}-stop-johnson": fig(lambda p: N(_impact(p, "stop")["johnson_upper"])),
            f"{tag}-torque": fig(_shaft("peak_torque", "N·m", "N*m")),
            f"{tag}-torque-angle": fig(lambda p: _angle(p, p["camshaft"]["peak_torque_time"])),
            f"{tag}-rms-torque": fig(_shaft("rms_torque", "N·m", "N*m")),
            f"{tag}-work": fig(_shaft("cycle_work", "J", "J")),
            f"{tag}-ek": fig(_shaft("energy_excursion", "J", "J")),
            f"{tag}-flywheel": fig(_shaft("flywheel_inertia", "kg·m²", "kg*m^2")),
        })
    out.update({
        "press-rejoin-angle": Figure(page, PRESS_JSON, lambda p: _angle(p, _impact(p, "overtravel")["time"])),
        "press-load-work": Figure(page, PRESS_JSON, lambda p: _q(-p["loads"]["press"]["work"], "J", "J")),
        "press-friction-energy": Figure(page, PRESS_JSON, lambda p: _q(p["friction"]["guide"]["energy"], "J", "J")),
        "press-min-fc-drop": Figure(page, PRESS_JSON, lambda p, q: N(q["min_cam_contact_force"]["value"]
                                                                    - p["min_cam_contact_force"]["value"]), also=BARE_JSON),
        "press-torque-rise": Figure(page, PRESS_JSON, lambda p, q: _q(p["camshaft"]["peak_torque"] - q["camshaft"]["peak_torque"],
                                                                      "N·m", "N*m"), also=BARE_JSON),
        "press-jump": Figure(page, PRESS_SWEEP_JSON, lambda p: f"{p['jump_onset_rpm']:.1f} rpm"),
        "press-bare-jump": Figure(page, BARE_SWEEP_JSON, lambda p: f"{p['jump_onset_rpm']:.1f} rpm"),
    })
    return out


CDTM_JSON = ("camsim", "run", "machines/cdtm.toml", "-o", "cdtm-json.h5", "--json")
LINE_JSON = ("camsim", "run", "machines/camshaft-line-dynamic.toml", "-o", "line-dyn-json.h5", "--json")
PRESS_FIGURES = _press_figures()
FIGURES: dict[str, Figure] = {
    "readme-m2-acceleration": Figure("README.md", CDTM_JSON, _cdtm_m2),
    "readme-ball-drop-peak": Figure("README.md", ("camsim", "run", "machines/ball-drop.toml", "-o", "ball.h5", "--json"),
                                    _ball_peak),
    "camshaft-dyn-speed": Figure("docs/camshaft.md", LINE_JSON, _dynamics("mean_drive_speed", "rpm", "rad/s")),
    "camshaft-dyn-drive-work": Figure("docs/camshaft.md", LINE_JSON, _shaft("drive_work", "J", "J")),
    "camshaft-dyn-cycle-work": Figure("docs/camshaft.md", LINE_JSON, _shaft("cycle_work", "J", "J")),
    "camshaft-dyn-residual": Figure("docs/camshaft.md", LINE_JSON, _residual),
    **PRESS_FIGURES,
}
#: Figures whose command takes tens of seconds (checked when CI=true, as the slow blocks).
SLOW_FIGURES = {"camshaft-dyn-speed", "camshaft-dyn-drive-work", "camshaft-dyn-cycle-work", "camshaft-dyn-residual",
                *(n for n, f in PRESS_FIGURES.items() if "sweep" in f.argv)}


def figure_markers(name: str) -> tuple[str, str]:
    return f"<!-- doc_outputs.py:{name} -->", "<!-- /doc_outputs.py -->"


def current_figure(name: str) -> str:
    begin, end = figure_markers(name)
    text = (ROOT / FIGURES[name].page).read_text(encoding="utf-8")
    if begin not in text:
        raise KeyError(f"{FIGURES[name].page}: no {begin} marker")
    return text.split(begin, 1)[1].split(end, 1)[0]


def replace_figure(name: str, value: str) -> bool:
    page = ROOT / FIGURES[name].page
    begin, end = figure_markers(name)
    text = page.read_text(encoding="utf-8")
    head, rest = text.split(begin, 1)
    _, tail = rest.split(end, 1)
    new = f"{head}{begin}{value}{end}{tail}"
    if new != text:
        page.write_text(new, encoding="utf-8")
        return True
    return False


def generate_figures(names: list[str]) -> dict[str, str]:
    """Each named figure, every command run once (its JSON on stdout) in a scratch copy."""
    import json

    d = scratch()
    payloads: dict[tuple[str, ...], dict] = {}
    try:
        for name in names:
            for argv in (FIGURES[name].argv, FIGURES[name].also):
                if argv is not None and argv not in payloads:
                    done = subprocess.run([sys.executable, "-m", "camsim", *argv[1:]], cwd=d, env=_env(d),
                                          stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True, timeout=1800)
                    payloads[argv] = json.loads(done.stdout)
    finally:
        shutil.rmtree(d, ignore_errors=True)
    out = {}
    for n in names:
        fig = FIGURES[n]
        out[n] = fig.text(payloads[fig.argv]) if fig.also is None else fig.text(payloads[fig.argv], payloads[fig.also])
    return out


# ---------------------------------------------------------------------- every command shown
#: Pages whose commands are run by --commands (performance.md and validation.md: bench and
#: validation scripts' records, their commands are the bench's).
COMMAND_PAGES = ("README.md", *sorted(f"docs/{p.name}" for p in (ROOT / "docs").glob("*.md")
                                      if p.name not in ("performance.md", "validation.md")))
#: Extra options that make a command of many runs quick (appended: the last value wins).
QUICK = {
    "sweep": ("--sample-rate", "5 kHz", "--warmup", "0", "--workers", "1"),
    "study": ("-n", "4", "--sample-rate", "2 kHz", "--warmup", "0", "--workers", "1"),
    "optimize": ("--budget", "3", "--sample-rate", "2 kHz", "--warmup", "0", "--workers", "1", "--speeds", "120rpm"),
    "fit": ("--max-evaluations", "3", "--accept-misfit", "--workers", "1"),
}
#: A placeholder or a synopsis: not a command to run.
_PLACEHOLDER = re.compile(r"[A-Z]{2,}[\w.]*\.(?:toml|h5|csv|html)|\s\[|\.\.\.|…|<|\bMACHINE\b|\bRESULT\b|\bKEY=")


def shown_commands(page: str) -> list[tuple[str, bool]]:
    """(command line, shown failing) of every camsim command a page shows, in page order."""
    text = (ROOT / page).read_text(encoding="utf-8")
    blocks = re.findall(r"```[a-z]*\n(.*?)```", text, re.S) + re.findall(r"(?:\n\n)((?:    \S.*\n)+)", text)
    out = []
    for block in blocks:
        lines = block.replace("\\\n", " ").splitlines()
        for i, line in enumerate(lines):
            line = line.strip().removeprefix("$ ")
            for part in line.split("&&"):
                part = part.split(" #", 1)[0].strip()
                if part.startswith("python examples/"):  # a script whose output a command reads
                    out.append((part, False))
                    continue
                if not part.startswith("camsim ") or _PLACEHOLDER.search(part):
                    continue
                following = lines[i + 1] if i + 1 < len(lines) else ""
                out.append((part, following.strip().startswith("camsim: error")))
    return out


def run_commands(pages: list[str] | None = None) -> list[str]:
    """Run every shown command; the problems (a command that did not end as its page shows).

    Commands a block shows are left out: the block check runs them and compares their output
    (or, ``run=False``, shows them only: a 100,000-revolution run)."""
    from camsim.reports.browser import find_browser

    browser = find_browser(required=False) is not None
    # a command a block shows is run there (its output compared) or, run=False, shown only
    shown_only = {" ".join(shlex.split(st.shown.split(" #", 1)[0].replace("\\\n", " "))) for b in BLOCKS.values()
                  for st in b.steps}
    problems = []
    for page in pages or COMMAND_PAGES:
        d = scratch()
        (d / "docs" / "img").mkdir(parents=True, exist_ok=True)  # a command may draw into docs/img
        _write_shown_files(page, d)
        try:
            todo = shown_commands(page)
            for attempt in (1, 2):  # a command reading a file a later one writes runs again after it
                again = []
                for line, fails in todo:
                    argv = shlex.split(line)
                    if ("--pdf" in argv and not browser) or " ".join(argv) in shown_only:
                        continue
                    if argv[0] == "python":
                        argv = [sys.executable, *argv[1:]]
                    else:
                        argv = [sys.executable, "-m", "camsim", *argv[1:], *QUICK.get(argv[1], ())]
                    done = subprocess.run(argv, cwd=d, env=_env(d),
                                          stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, timeout=1800)
                    ok = (done.returncode != 0) if fails else done.returncode == 0
                    if not ok and attempt == 1 and any(w in done.stdout.lower() for w in
                                                       ("does not exist", "no such file", "cannot open")):
                        again.append((line, fails))
                    elif not ok:
                        last = done.stdout.strip().splitlines()[-1:] or [""]
                        problems.append(f"{page}: {line}: exit {done.returncode}: {last[0][:300]}")
                todo = again
        finally:
            shutil.rmtree(d, ignore_errors=True)
    return problems


def _write_shown_files(page: str, d: Path) -> None:
    """A file a page shows in full and a command then reads (the ``[study]`` table of
    docs/tolerance.md given to ``--config``): written into the scratch copy."""
    text = (ROOT / page).read_text(encoding="utf-8")
    for name in re.findall(r"--config (\S+\.toml)", text):
        table = next((b for b in re.findall(r"```toml\n(.*?)```", text, re.S) if "[study]" in b), None)
        if table is not None:
            (d / name).write_text(table, encoding="utf-8")


def _env(cwd: Path) -> dict:
    env = dict(os.environ)
    env["PYTHONPATH"] = str(ROOT) + os.pathsep + env.get("PYTHONPATH", "")
    env["PATH"] = str(cwd / ".bin") + os.pathsep + env.get("PATH", "")
    env.pop("CAMSIM_TRACEBACK", None)
    env["COLUMNS"] = "140"
    return env


def scratch() -> Path:
    """A scratch directory laid out like the repository (machines, examples, scripts, goldens)."""
    d = Path(tempfile.mkdtemp(prefix="camsim-docs-"))
    for sub in ("machines", "examples", "scripts"):
        shutil.copytree(ROOT / sub, d / sub, ignore=shutil.ignore_patterns("*.h5", "*.csv.journal", "__pycache__"))
    (d / "tests" / "data").mkdir(parents=True)
    shutil.copytree(ROOT / "tests" / "data" / "golden", d / "tests" / "data" / "golden")
    # `camsim` on the PATH of a shell script is this checkout's
    bin_dir = d / ".bin"
    bin_dir.mkdir()
    launcher = bin_dir / "camsim"
    launcher.write_text(f'#!/bin/sh\nexec "{sys.executable}" -m camsim "$@"\n', encoding="utf-8")
    launcher.chmod(0o755)
    return d


def run_step(step: Step, cwd: Path) -> str:
    """What the command printed (stderr and stdout in order), without trailing blanks."""
    argv = list(step.argv or ())
    if "#" in argv:
        argv = argv[: argv.index("#")]
    if argv and argv[0] == "camsim":
        argv = [sys.executable, "-m", "camsim", *argv[1:]]
    elif argv and argv[0] == "python":  # this interpreter, whatever the PATH holds
        argv = [sys.executable, *argv[1:]]
    done = subprocess.run(argv, cwd=cwd, env=_env(cwd), stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
                          timeout=1800)
    # the progress lines a long command prints every 10 s off a terminal (camsim.cli.progress)
    # depend on the machine's speed and load: not part of the documented output
    progress = re.compile(r"^[\w ()-]+: [\d.e+]+/[\d.e+]+ \S+( \(\d+ %\))?, ")
    lines = [line.rstrip() for line in done.stdout.splitlines() if not progress.match(line)]
    if step.excerpt_from:
        start = next((i for i, line in enumerate(lines) if re.search(step.excerpt_from, line)), None)
        if start is None:
            raise RuntimeError(f"{step.shown}: no line matches {step.excerpt_from!r}")
        lines = ["...", *lines[start:]]
    while lines and not lines[-1]:
        lines.pop()
    return "\n".join(lines)


def render(name: str, cwd: Path) -> str:
    """The fenced block of ``name``, as it belongs between its markers."""
    block = BLOCKS[name]
    parts = []
    for step in block.steps:
        parts.append("$ " + step.shown)
        if step.argv is not None:
            out = run_step(step, cwd)
            if out:
                parts.append(out)
    return f"```{block.fence}\n" + "\n".join(parts) + "\n```"


def markers(name: str) -> tuple[str, str]:
    return f"<!-- BEGIN doc_outputs.py:{name} -->", f"<!-- END doc_outputs.py:{name} -->"


def current(name: str) -> str:
    """The block as the page holds it now (between its markers)."""
    begin, end = markers(name)
    text = (ROOT / BLOCKS[name].page).read_text(encoding="utf-8")
    if begin not in text or end not in text:
        raise KeyError(f"{BLOCKS[name].page}: no {begin} … {end} markers")
    return text.split(begin, 1)[1].split(end, 1)[0].strip("\n")


def replace(name: str, block: str) -> bool:
    """Put ``block`` between the markers of ``name``; True if the page changed."""
    page = ROOT / BLOCKS[name].page
    begin, end = markers(name)
    text = page.read_text(encoding="utf-8")
    head, rest = text.split(begin, 1)
    _, tail = rest.split(end, 1)
    new = f"{head}{begin}\n{block}\n{end}{tail}"
    if new != text:
        page.write_text(new, encoding="utf-8")
        return True
    return False


def normalised(text: str) -> str:
    """For comparing: whitespace runs as one space, runs of table-rule characters as one, and
    numbers printed to the last bit (a CSV's ``repr``) to 10 significant digits, the rest exact."""
    text = re.sub(r"([━─═┄╌]{1})[━─═┄╌]+", r"\1", text)
    text = re.sub(r"-?\d+\.\d{11,}(?:[eE][-+]?\d+)?", lambda m: f"{float(m.group(0)):.10g}", text)
    return re.sub(r"\s+", " ", text).strip()


def generate(names: list[str]) -> dict[str, str]:
    """Every named block, each with the blocks it needs run first in the same scratch copy."""
    out: dict[str, str] = {}
    d = scratch()
    try:
        for name in names:
            for before in BLOCKS[name].after:
                if before not in out:
                    out[before] = render(before, d)
            if name not in out:
                out[name] = render(name, d)
    finally:
        shutil.rmtree(d, ignore_errors=True)
    return {n: out[n] for n in names}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("names", nargs="*", help="blocks (default: all)")
    parser.add_argument("--write", action="store_true", help="rewrite the blocks in their pages")
    parser.add_argument("--check", action="store_true", help="exit 1 when a page's block differs")
    parser.add_argument("--list", action="store_true", help="list the blocks")
    parser.add_argument("--skip-slow", action="store_true", help="leave out the slow blocks")
    parser.add_argument("--commands", action="store_true", help="run every camsim command shown in README.md and docs/")
    args = parser.parse_args(argv)
    if args.commands:
        problems = run_commands()
        for p in problems:
            print(p, file=sys.stderr)
        return 1 if problems else 0
    if args.list:
        for name, b in BLOCKS.items():
            print(f"{name:22} {b.page:22} {'slow' if b.slow else ''}")
        return 0
    unknown = [n for n in args.names if n not in BLOCKS and n not in FIGURES]
    if unknown:
        parser.error(f"unknown block(s): {', '.join(unknown)} (see --list)")
    wanted = args.names or [*BLOCKS, *FIGURES]
    names = [n for n in wanted if n in BLOCKS and not (args.skip_slow and BLOCKS[n].slow)]
    figures = [n for n in wanted if n in FIGURES and not (args.skip_slow and n in SLOW_FIGURES)]
    blocks = generate(names)
    stale = []
    for name, value in generate_figures(figures).items():
        if args.write:
            if replace_figure(name, value):
                print(f"updated {FIGURES[name].page}: {name}")
        elif args.check:
            if current_figure(name) != value:
                stale.append(name)
        else:
            print(f"{figure_markers(name)[0]}  ({FIGURES[name].page}) {value}")
    for name, block in blocks.items():
        if args.write:
            if replace(name, block):
                print(f"updated {BLOCKS[name].page}: {name}")
        elif args.check:
            if normalised(current(name)) != normalised(block):
                stale.append(name)
        else:
            print(f"{markers(name)[0]}  ({BLOCKS[name].page})\n{block}\n")
    if stale:
        print("stale: " + ", ".join(f"{n} ({(BLOCKS.get(n) or FIGURES[n]).page})" for n in stale)
              + "; run: python scripts/doc_outputs.py --write",
              file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())

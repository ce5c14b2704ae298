"""Issue 44, item 3: every command's human output for an inch-pound machine shows no SI unit
and no number without its unit.

Extends tests/cli/test_units_everywhere.py (issue 36) to what it did not reach: the camshaft
output (run, cam, plot --what camshaft), a rod (validate, run), impact --materials,
optimize's progress, fit's bounds message, the sweep's CSV header, check's unit column. The
machines are written in inch-pound units by pint (an independent unit library) from the
shipped ones.

"A number without its unit" (:func:`unitless`): in a table, a numeric cell whose column header
names no unit (``[in]``) and is not a number by nature (``#``, ``ratio``, ``Δ/tol``...); in a
line of text, a number not followed by a unit, that is not a count of things (``4 impacts``),
an index, or a named dimensionless figure (``ratio 0.636``, ``rtol=1e-06``). Both searches can
fail: the control at the end finds SI units and bare numbers where they are.
"""

from __future__ import annotations

import re
from pathlib import Path

import pytest
from test_units_everywhere import ANGLES, SI_UNITS, commands, found, human_output, to_si_text  # noqa: F401
from typer.testing import CliRunner

from camsim.cli import app
from camsim.units import registry

ROOT = Path(__file__).resolve().parents[2]
MACHINES = ROOT / "machines"
runner = CliRunner()
UREG = registry()

#: Units a number may be followed by in human output (display units, times, frequencies, counts).
UNIT_WORDS = (
    "lbf·s/in", "lbf/in", "lbf·in", "in·lbf", "lb·in²", "in/s²", "in/s³", "in/s", "lbf", "lb", "in²", "in", "psi",
    "rpm", "deg", "°", "ms", "µs", "s", "kHz", "MHz", "Hz", "%", "[-]", "x",
)
#: Words that make a number a count or an index ("4 impacts", "candidate 2").
COUNTED = (
    "impact", "run", "variant", "cycle", "segment", "evaluation", "dataset", "sample", "iteration", "pair", "per million",
    "revolution", "warm-up", "event", "release", "separation", "rejoin", "jump", "row", "point", "mode", "trace", "cam",
    "column", "of ", "more", "degrees of freedom", "lines", "failed", "ok", "file", "significant", "steps", "step",
    "simulation", "candidate", "worker", "key", "parameter", "output", "limit", "process", "block", "figure", "residual",
)
#: Named dimensionless figures and indices, the number after them.
NAMED = re.compile(
    r"(ratio|residual[^:]*:|rtol=|atol=|seed|Cs =|C_s =|zeta|ζ|n =|N =|P\([^)]*\) =|intervals? of|α|a =|exponent|"
    r"Clopper-Pearson|condition|variance|cost|cam harmonic n =|index|#|@|\bk\b =|e =|restitution|Δ/peak|"
    r"speed change|tau ~|5/tau =|segments|step|sigma|σ|\(\d+\)|COLLISION|p/p_yield|rebound|nu|ν|fluctuation)\s*[=:]?\s*$")
#: Table columns whose values are numbers by nature.
UNITLESS_COLUMNS = ("#", "ratio", "rebound", "p/p_yield", "impacts", "Δ/peak", "Δ/tol", "run", "candidate", "k", "n",
                    "exponent", "restitution", "damping ratio", "zeta", "ζ", "segments", "total index", "S", "ST",
                    "mode", "f", "relaxation", "probability", "runs", "index", "correlation", "jump", "status")
_NUMBER = re.compile(r"(?<![\w.\[/^*·-])[-+−]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?(?![\w.\]/])")


def _cells(line: str, sep: str) -> list[tuple[int, int, str]]:
    """(start, end, text) of the cells of a rich table line split at ``sep``."""
    bounds = [m.start() for m in re.finditer(re.escape(sep), line)]
    return [(a + 1, b, line[a + 1:b]) for a, b in zip(bounds, bounds[1:])]


def _spans(header: str) -> list[tuple[int, int, str]]:
    """(start, end, text) of the headers of a rule-less table (columns two spaces or more apart)."""
    return [(m.start(), m.end(), m.group(0)) for m in re.finditer(r"\S+(?: \S+)*", header)]


def _has_unit(text: str, m: re.Match) -> bool:
    """The number ``m`` of ``text`` has its unit after it, counts things, or is a named number."""
    before, after = text[:m.start()], text[m.end():]
    if any(after.startswith(" " + u) or after.startswith(u + " ") or after.rstrip() == u or after.startswith(u + ")")
           or after.startswith(u + ",") or after.startswith(u + ";") or after.startswith(u + ".") or after.startswith(u + "]")
           for u in UNIT_WORDS):
        return True
    if re.match(r" [a-z]+/s\b", after):  # a rate of the progress line: 0.07 rev/s
        return True
    if any(after.lstrip(" (").startswith(w) for w in COUNTED) or after.startswith(("/", ":", "-", "…", " …", " to ")):
        return True
    if NAMED.search(before) or (before.rstrip().endswith(("of", "than", "to", "from", "and", "×", "x", "/", "(", "…"))
                                and not before.rstrip().endswith("=")):
        return True
    return bool(re.search(r"(wrote|plots?|written)\b|\.\w+$|\w/\S*$", before) or "/" in after.split(" ")[0])


def _column_ok(header: str) -> bool:
    name = header.strip().split(" [")[0].strip()
    return "[" in header or "ratio" in name or name in UNITLESS_COLUMNS or any(name.startswith(u + " ") for u in UNITLESS_COLUMNS)


def _continues(lines: list[str], k: int) -> bool:
    """Line ``k`` continues the row above it (its first cell is blank and the row above is one)."""
    above = _cells(lines[k - 1], "│")
    return bool(above) and len(above) == len(_cells(lines[k], "│"))


def unitless(text: str) -> list[str]:
    """Numbers printed without their unit (see the module docstring)."""
    hits = []
    headers: list[tuple[int, int, str]] = []
    simple = False
    lines = text.splitlines()
    for k, line in enumerate(lines):
        if not line.strip():
            simple = False
            continue
        if "┃" in line:  # a header line of a boxed rich table (several when wrapped)
            cells = _cells(line, "┃")
            if k == 0 or "┃" not in lines[k - 1]:
                headers = cells
            else:
                headers = [(a, b, h + " " + c[2]) for (a, b, h), c in zip(headers, cells)]
            continue
        if re.fullmatch(r"[\s─]+", line) and k > 0:  # the rule under the header of a rule-less table
            headers, simple = _spans(lines[k - 1]), True
            continue
        if re.match(r"^\s*[┏┌]", line):  # a new table: its own header (or none)
            headers = []
        if re.match(r"^\s*[━─═┏┗┡└┌╇╋]", line):
            continue
        boxed = "│" in line
        if boxed:
            cells = _cells(line, "│")
            # a wrapped row: the lines below whose first cell is blank continue its cells
            n = k + 1
            while n < len(lines) and "│" in lines[n] and _cells(lines[n], "│") and not _cells(lines[n], "│")[0][2].strip() \
                    and len(_cells(lines[n], "│")) == len(cells):
                cells = [(a, b, t + " " + c[2]) for (a, b, t), c in zip(cells, _cells(lines[n], "│"))]
                n += 1
            cells = [(a, b, " ".join(t.split())) for a, b, t in cells]
            if k > 0 and "│" in lines[k - 1] and cells and not cells[0][2].strip() and _continues(lines, k):
                continue  # merged into the row above
            names = [h.strip().split(" [")[0] for _, _, h in headers]
            unit_cell = cells[names.index("unit")][2].strip() if "unit" in names and names.index("unit") < len(cells) else ""
            # a row that names its unit in a cell: "displacement [in]" of the comparison table
            unit_cell = unit_cell or next((c[2] for c in cells if re.search(r"\[[^\]]+\]", c[2])), "")
        else:  # a line of text; a wrapped one goes on in the next line
            following = lines[k + 1].strip() if k + 1 < len(lines) and "│" not in lines[k + 1] else ""
            cells, unit_cell = [(0, len(line), line + (" " + following if following else ""))], ""
        for start, end, cell in cells:
            for m in _NUMBER.finditer(cell):
                if _has_unit(cell, m):
                    continue
                if boxed and (unit_cell or (cells and NAMED.search(cells[0][2].split("(")[0].rstrip() + " "))):
                    continue  # the row's unit column names it; a named number of a key/value table
                if boxed or simple:
                    at = start + m.end() if boxed else m.end()
                    if boxed:
                        header = next((h for a, b, h in headers if a <= start <= b), "")
                    else:
                        header = min(headers, key=lambda h: abs(h[1] - at))[2] if headers else ""
                    if headers and _column_ok(header):
                        continue
                    hits.append(f"column {header.strip()!r}: {m.group(0)!r} in …{line.strip()[:110]!r}")
                elif m.start() < len(line):
                    hits.append(f"{m.group(0)!r} in …{line.strip()[:120]!r}")
    return hits


def to_us_text(text: str) -> str:
    """A machine file with every quantity rewritten in inch-pound units by pint."""
    targets = {
        "[length]": "in", "[mass]": "lb", "[length] * [mass] / [time] ** 2": "lbf", "[mass] / [time] ** 2": "lbf/in",
        "[mass] / [time]": "lbf*s/in", "[length] / [time]": "in/s", "[length] / [time] ** 2": "in/s**2",
        "[mass] / [length] / [time] ** 2": "psi", "[length] ** 2 * [mass]": "lb*in**2",
        "[length] ** 2 * [mass] / [time] ** 2": "lbf*in",
    }

    def convert(m: re.Match) -> str:
        try:
            q = UREG.Quantity(m.group(1))
        except Exception:  # noqa: BLE001 - not a quantity
            return m.group(0)
        dims = dict(q.dimensionality)
        key = next((k for k in targets if dict(UREG.Quantity(1, targets[k]).dimensionality) == dims), None)
        if key is None or "rad" in m.group(1) or "deg" in m.group(1) or "rpm" in m.group(1):
            return m.group(0)
        return f'"{q.to(targets[key]).magnitude:.10g} {targets[key]}"'

    return re.sub(r'"(\d[^"]*)"', convert, text)


@pytest.fixture(scope="module")
def us(tmp_path_factory):
    d = tmp_path_factory.mktemp("us-units")
    text = (MACHINES / "cdtm-geometry.toml").read_text(encoding="utf-8")
    text = text.replace('sample_rate = "50 kHz"', 'sample_rate = "2 kHz"').replace("warmup_cycles = 1", "warmup_cycles = 0")
    (d / "cdtm.toml").write_text(text, encoding="utf-8")
    (d / "parts.toml").write_text((MACHINES / "cdtm-parts.toml").read_text(encoding="utf-8"), encoding="utf-8")
    line = to_us_text((MACHINES / "camshaft-line.toml").read_text(encoding="utf-8"))
    line = line.replace('"J"', '"jaw"')  # a mass named J reads as a joule in a table cell
    (d / "line.toml").write_text(line.replace('sample_rate = "20 kHz"', 'sample_rate = "2 kHz"'), encoding="utf-8")
    (d / "rod.toml").write_text((MACHINES / "cdtm-rod.toml").read_text(encoding="utf-8"), encoding="utf-8")
    return d


def _extra(d: Path) -> list[list]:
    return [
        ["validate", d / "rod.toml"],
        ["validate", d / "line.toml"],
        ["cam", d / "line.toml"],
        ["run", d / "line.toml", "-o", d / "line.h5", "--warmup", "0"],
        ["plot", d / "line.h5", "-o", d / "line_plots", "--what", "camshaft"],
    ]


def _output(args: list[str], result, d: Path) -> str:
    text = human_output(args, result, d)
    if args[0] == "sweep":  # the CSV written beside the sweep file: its header (issue 44)
        text += "\n" + (d / "sw.csv").read_text(encoding="utf-8").splitlines()[0].replace(",", "\n")
    if args[0] == "plot" and "camshaft" in args:
        from camsim.figures.plots import make_plots

        for fig in make_plots(d / "line.h5", what=["camshaft"]).values():
            for ax in fig.axes:
                text += f"\n{ax.get_xlabel()}\n{ax.get_ylabel()}"
    return text


@pytest.mark.slow  # the default pytest's 3 minutes: CI runs it
def test_every_command_of_an_inch_file_shows_inch_units_with_every_number(us):
    problems = []
    for args in commands(us, "us") + _extra(us):
        args = [str(a) for a in args]
        result = runner.invoke(app, args)
        assert result.exit_code in (0, 1), (args, result.output)
        text = _output(args, result, us)
        where = f"camsim {' '.join(Path(a).name if '/' in a else a for a in args[:2])}"
        problems += [f"{where}: SI unit {h}" for h in found(text, SI_UNITS + ANGLES)]
        problems += [f"{where}: unitless {h}" for h in unitless(result.output)]
    from camsim.analyses.check import check_files

    # check's unit column: each extreme in its quantity's unit (it said "quantity's")
    units = {d.units for d in check_files(us / "r.h5", us / "r.h5").diffs}
    assert "quantity's" not in units and {"m", "m/s", "N"} <= units
    assert not problems, "\n".join(problems[:30])


@pytest.mark.full  # before a release (CAMSIM_FULL=1): .ci/run's 15 minutes
def test_a_rod_run_and_its_materials_in_inch_units(us):
    """cdtm-rod (m/s, N·s/m, kg in validate and run before) and impact --materials (GPa, N, MPa,
    m/s for an inch file), about 30 s: CI."""
    problems = []
    for args in (["run", us / "rod.toml", "-o", us / "rod.h5", "--sample-rate", "5 kHz", "--warmup", "0"],
                 ["impact", "--materials", "--machine", us / "rod.toml", "--pair", "steel,steel",
                  "--set", "simulation.sample_rate=5000", "--set", "simulation.warmup_cycles=0"],
                 ["report", us / "rod.h5", "-o", us / "page.html"]):
        args = [str(a) for a in args]
        result = runner.invoke(app, args)
        assert result.exit_code == 0, (args, result.output)
        text = human_output(args, result, us)
        problems += [f"{args[0]}: SI unit {h}" for h in found(text, SI_UNITS + ANGLES)]
        problems += [f"{args[0]}: unitless {h}" for h in unitless(result.output)]
    assert not problems, "\n".join(problems[:30])


def test_optimize_progress_names_the_objectives_unit():
    """The progress line said "best: 216.496" (SI, no unit); it is the objective in the file's units."""
    from camsim.cli.cmd_optimize import _Progress
    from camsim.machine.loader import load_machine

    shown = []
    bar = _Progress(quiet=True)
    bar.bar = lambda done, total, note="": shown.append(note)  # noqa: E731 - the note the bar would print
    bar.objective("N", load_machine(MACHINES / "cdtm.toml"))
    bar(3, 10, 216.496)
    assert shown == [f"best: {216.496 / UREG.Quantity(1, 'lbf').to('N').magnitude:.6g} lbf"]


def test_the_searches_can_fail():
    """Control: the searches find an SI unit and bare numbers where they are."""
    assert found("peak |T| [N·m]\n│ 23.76 │", SI_UNITS)
    table = "┃ quantity ┃ value ┃\n┡━━━━━━━━━━╇━━━━━━━┩\n│ torque   │ 23.76 │\n"
    assert unitless(table) and unitless("best: 216.496") and unitless("optimum 3.2 at the start")
    assert not unitless("┃ t [s] ┃ force [lbf] ┃\n│ 0.1 │ 23.76 │\n") and not unitless("peak 50.7 lbf at t = 0.1 s, 4 impacts")

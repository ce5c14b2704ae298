"""Issue 36, item 5: every command, run on an inch-pound machine, prints no SI unit unless
``--units si`` is asked for; run on an SI machine, no US unit.

The inch-pound machine is machines/cdtm-geometry.toml (the thesis machine with its cam's
shape: impacts, a transducer, the cam design quantities); the SI machine is the same file
with every quantity rewritten in SI (mm, kg, N, N/m) by pint, so both exercise the same
outputs. Each command's human output (stdout and stderr; a report page's text and axis
labels; the plot's axis labels; ``export --units file``'s header) is searched for unit
texts of the other system in unit positions: in brackets (``[N]``), after a number
(``12.5 N``) or alone in a table cell (``│ mm │``). The searches can fail: under
``--units si`` (``us``) the same commands must show SI (US) units, which they find.
"""

from __future__ import annotations

import re
import shutil
from pathlib import Path

import pytest
from typer.testing import CliRunner

from camsim.cli import app
from camsim.units import registry

ROOT = Path(__file__).resolve().parents[2]
MACHINES = ROOT / "machines"
runner = CliRunner()
UREG = registry()

SI_UNITS = ("N·s/m", "N*s/m", "N/m", "N·m", "N*m", "kN", "N", "mm", "µm", "cm", "m/s²", "m/s^2", "m/s³", "m/s^3",
            "m/s", "m", "kg·m²", "kg", "MPa", "GPa", "Pa", "J")
US_UNITS = ("lbf·s/in", "lbf/in", "lbf·in", "in·lbf", "lbf", "lb·in²", "lb", "in/s²", "in/s³", "in/s", "in²", "in",
            "psi", "thou", "ft")
#: Angles are degrees and speeds rpm in every system: radians are never shown.
ANGLES = ("rad/s", "rad")


def found(text: str, units: tuple[str, ...]) -> list[str]:
    """The unit texts of ``units`` standing in a unit position of ``text``."""
    hits = []
    for unit in units:
        u = re.escape(unit)
        end = r"(?![\w/·²³^*])"
        # "in" after a number is the inch unless English goes on ("candidate 1 in the unit")
        after = rf"\d\s?{u}{end}" + (r"(?!\s+[a-z])" if unit == "in" else "")
        for pattern in (rf"\[{u}\]", after, rf"[│┃|]\s*{u}\s*(?=[│┃|]|$)"):
            for m in re.finditer(pattern, text, re.M):
                hits.append(f"{unit!r} in …{text[max(0, m.start() - 40):m.end() + 10]!r}")
    return hits


def to_si_text(text: str) -> str:
    """A machine (or parts) file with every quantity string rewritten in SI units by pint."""
    targets = {
        "[length]": "mm", "[mass]": "kg", "[length] * [mass] / [time] ** 2": "N", "[mass] / [time] ** 2": "N/m",
        "[mass] / [time]": "N*s/m", "[length] / [time]": "m/s", "[length] / [time] ** 2": "m/s**2",
        "[mass] / [length] / [time] ** 2": "MPa", "[length] ** 2 * [mass]": "kg*m**2",
    }

    def convert(m: re.Match) -> str:
        try:
            q = UREG.Quantity(m.group(1))
        except Exception:  # noqa: BLE001 - not a quantity
            return m.group(0)
        target = targets.get(str(getattr(q, "dimensionality", "")))
        if target is None:
            return m.group(0)
        return f'"{q.to(target).magnitude:.10g} {target}"'

    return re.sub(r'"(\d[^"]*)"', convert, text)


@pytest.fixture(scope="module")
def machines(tmp_path_factory):
    """(inch-pound machine, SI machine, inch-pound parts file, SI parts file), quick to run."""
    d = tmp_path_factory.mktemp("units")
    text = (MACHINES / "cdtm-geometry.toml").read_text(encoding="utf-8")
    text = text.replace('sample_rate = "50 kHz"', 'sample_rate = "2 kHz"').replace("warmup_cycles = 1", "warmup_cycles = 0")
    us, si = d / "us" / "cdtm.toml", d / "si" / "cdtm.toml"
    for path, body in ((us, text), (si, to_si_text(text))):
        path.parent.mkdir()
        path.write_text(body, encoding="utf-8")
    parts = (MACHINES / "cdtm-parts.toml").read_text(encoding="utf-8")
    (d / "us" / "parts.toml").write_text(parts, encoding="utf-8")
    (d / "si" / "parts.toml").write_text(to_si_text(parts), encoding="utf-8")
    return d


#: system -> values written on the command line in that system's units
WRITTEN = {
    "us": {"preload": "20,28.12lbf", "range": "20:40lbf", "tol": "tol:28.12:3lbf", "limit": "peak_transducer_force>52lbf",
           "target": "peak_transducer_force=45lbf", "mass": "0.3854 lb", "velocity": "7 in/s", "stiffness": "49094 lbf/in",
           "csv": "deflection [in],force [lbf]\n0.001,49\n0.002,98\n0.004,196\n"},
    "si": {"preload": "89,125N", "range": "89:178N", "tol": "tol:125:13N", "limit": "peak_transducer_force>231N",
           "target": "peak_transducer_force=200N", "mass": "0.1748 kg", "velocity": "0.178 m/s", "stiffness": "8.6e6 N/m",
           "csv": "deflection [mm],force [N]\n0.025,218\n0.05,436\n0.1,872\n"},
}


def commands(d: Path, system: str) -> list[list[str]]:
    w = WRITTEN[system]
    m, out = d / "cdtm.toml", d
    (d / "seat.csv").write_text(w["csv"], encoding="utf-8")
    return [
        ["validate", m],
        ["cam", m],
        ["run", m, "-o", out / "r.h5"],
        ["modes", m],
        ["compare", m, "-o", out / "c.h5"],
        ["check", out / "r.h5", "--against", out / "r.h5"],
        ["compare", out / "r.h5", out / "r.h5"],  # two result files: the units recorded in them
        ["sweep", m, "--values", f"element.K23.preload={w['preload']}", "--workers", "1", "-o", out / "sw.h5", "-q"],
        ["study", m, "--dist", f"element.K23.preload={w['tol']}", "-n", "4", "--limit", w["limit"], "--workers", "1",
         "-o", out / "st.h5", "-q"],
        ["optimize", m, "--var", f"element.K23.preload={w['range']}", "--minimize", "peak_transducer_force",
         "--method", "local", "--budget", "3", "--workers", "1", "-r", out / "opt.h5", "-q"],
        # speeds in rpm and segment durations in deg, never rad/s or rad (issue 36)
        ["optimize", m, "--var", "cam.speed=100:140rpm", "--var", "cam.segments[0].duration=45:55deg", "--absorb",
         "cam.segments[1].duration", "--minimize", "peak_transducer_force", "--budget", "3", "--workers", "1", "-q"],
        ["fit", m, "--param", f"element.K23.preload={w['range']}", "--target", w["target"], "--max-evaluations", "3",
         "-o", out / "fitted.toml", "--accept-misfit"],
        ["lump", d / "parts.toml"],
        ["impact", "--mass", w["mass"], "--velocity", w["velocity"], "--stiffness", w["stiffness"]],
        ["impact", "fit", d / "seat.csv"],
        ["report", out / "r.h5", "-o", out / "page.html"],
        ["plot", out / "r.h5", "-o", out / "plots", "--what", "masses", "--mass", "M3"],
        ["export", out / "r.h5", "--units", "file", "-o", out / "r.csv"],
    ]


def page_text(html: str) -> str:
    """What a reader sees of a report page: its text and its plots' axis labels and titles,
    without the machine file and the command line (the user's own text, shown as written)."""
    labels = " ".join(f"[{u}]" for u in re.findall(r'"axis_label":"[^"]*?\[([^"\]]*)\]', html))
    titles = " ".join(re.findall(r'"text":"([^"]*)"', html))
    body = re.sub(r"<script.*?</script>|<pre>.*?</pre>|<code>.*?</code>|<style.*?</style>", " ", html, flags=re.S)
    return re.sub(r"<[^>]+>", " ", body) + " " + labels + " " + titles


def human_output(args: list[str], result, d: Path) -> str:
    text = result.output
    if args[0] == "report":
        text += page_text((d / "page.html").read_text(encoding="utf-8"))
    if args[0] == "plot":
        from camsim.figures.plots import make_plots

        for fig in make_plots(d / "r.h5", what=["masses", "forces", "svaj", "design"]).values():
            for ax in fig.axes:
                text += f"\n{ax.get_xlabel()}\n{ax.get_ylabel()}\n" + "\n".join(t.get_text() for t in ax.texts)
    if args[0] == "export":
        text += "\n" + (d / "r.csv").read_text(encoding="utf-8").splitlines()[0]
        text += "\n" + (d / "r_events.csv").read_text(encoding="utf-8").splitlines()[0]
    return text


@pytest.mark.slow  # the default pytest's 3 minutes: CI runs it
@pytest.mark.parametrize("system, other", [("us", SI_UNITS), ("si", US_UNITS)])
def test_every_command_in_the_units_of_the_file(machines, system, other):
    d = machines / system
    for args in commands(d, system):
        args = [str(a) for a in args]
        result = runner.invoke(app, args)
        assert result.exit_code in (0, 1), (args, result.output)  # 1: an optimum/fit that is not feasible/matched
        text = human_output(args, result, d)
        hits = found(text, other + ANGLES)
        assert not hits, f"camsim {' '.join(args[:2])}: " + "; ".join(hits[:5])


@pytest.mark.parametrize("system, asked, own, other", [("us", "si", SI_UNITS, US_UNITS), ("si", "us", US_UNITS, SI_UNITS)])
def test_units_option_switches_every_table(machines, system, asked, own, other):
    """The control: ``--units si`` on the inch-pound machine shows SI units and no US unit
    (and ``us`` the converse), so the search above is no search that cannot find."""
    d = machines / system
    # (the report page's --units: tests/reports/test_report_polish.py)
    for args in (["validate", d / "cdtm.toml"], ["cam", d / "cdtm.toml"], ["run", d / "cdtm.toml", "-o", d / "r2.h5"]):
        args = [str(a) for a in args] + ["--units", asked]
        result = runner.invoke(app, args)
        assert result.exit_code == 0, (args, result.output)
        text = human_output(args, result, d)
        assert found(text, own), args
        assert not found(text, other + ANGLES), (args, found(text, other)[:5])


def test_a_result_keeps_the_units_of_its_machine_file(machines, tmp_path):
    """plot, report and export --units of a result file moved away from its machine use the
    display units recorded in it (the root attribute ``display_units``)."""
    import h5py

    src = tmp_path / "r.h5"  # its own run (the every-command test that also writes one is in the slow tier)
    made = runner.invoke(app, ["run", str(machines / "us" / "cdtm.toml"), "-o", str(src), "-q"])
    assert made.exit_code == 0, made.output
    moved = tmp_path / "elsewhere.h5"
    shutil.copy(src, moved)
    with h5py.File(moved, "r") as f:
        assert '"force": ["lbf"' in f.attrs["display_units"]
    result = runner.invoke(app, ["export", str(moved), "--units", "file", "--columns", "transducer/force"])
    assert result.exit_code == 0, result.output
    assert (tmp_path / "elsewhere.csv").read_text().splitlines()[0] == "time [s],transducer/force [lbf]"


@pytest.mark.slow
@pytest.mark.parametrize("system, other", [("us", SI_UNITS), ("si", US_UNITS)])
def test_every_report_page_in_the_units_of_the_file(machines, system, other):
    """The comparison, sweep, study and optimisation pages of the results made above (about
    10 s of page building, so in CI only; the run page is checked on every test run)."""
    d = machines / system
    if not (d / "opt.h5").exists():
        test_every_command_in_the_units_of_the_file(machines, system, other)
    for name in ("c", "sw", "st", "opt"):
        args = ["report", str(d / f"{name}.h5"), "-o", str(d / "page.html")]
        result = runner.invoke(app, args)
        assert result.exit_code == 0, result.output
        hits = found(human_output(args, result, d), other + ANGLES)
        assert not hits, f"{name}: " + "; ".join(hits[:5])

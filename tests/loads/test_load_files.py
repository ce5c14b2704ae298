"""Process loads (issue 43) through the machine file and every command that reads machines.

References: the machine-file contract (spec §10: ``[[load]]`` and its programs; spec §6:
every error one line naming the file and the key, exit 2, nothing written; spec §7: the
result layout, ``/loads/<name>/force`` with its ``units``), the key grammar of
``--set``/``--vary`` (``load.<name>.force``, ``load.<name>.segments[i].change``, …) and, for
the values, the closed forms of tests/loads/test_load_references.py (a constant load's force,
its work on a driven mass, zero per revolution).
"""

from __future__ import annotations

import csv
import json
from pathlib import Path

import h5py
import numpy as np
import pytest
from typer.testing import CliRunner

from camsim import load_machine, open_result, simulate
from camsim.cli import app
from camsim.machine import keys

runner = CliRunner()

MACHINE = """schema = 1
[machine]
name = "press station"
[cam]
speed = "300 rpm"
drives = "M1"
segments = [
  { motion = "rise", law = "cycloidal", duration = "120 deg", lift = "10 mm" },
  { motion = "dwell", duration = "60 deg" },
  { motion = "fall", law = "modified-sine", duration = "120 deg", lift = "10 mm" },
  { motion = "dwell", duration = "60 deg" },
]
[[mass]]
name = "M1"
mass = "1.5 kg"
[[mass]]
name = "M2"
mass = "0.4 kg"
[[element]]
name = "k12"
type = "spring"
between = ["M1", "M2"]
stiffness = "2e5 N/m"
damping_ratio = 0.05
[[element]]
name = "ret"
type = "spring"
between = ["ground", "M1"]
stiffness = "3000 N/m"
preload = "150 N"
[[element]]
name = "stop"
type = "contact"
between = ["M2", "ground"]
gap = "0.0 mm"
stiffness = "1e6 N/m"
damping_ratio = 0.1
[[load]]
name = "press"
on = "M2"
base = "-5 N"
segments = [
  { motion = "dwell", duration = "90 deg" },
  { motion = "rise", law = "poly345", duration = "40 deg", change = "60 N" },
  { motion = "dwell", duration = "30 deg" },
  { motion = "fall", law = "harmonic", duration = "60 deg" },
  { motion = "dwell", duration = "140 deg" },
]
[[load]]
name = "tool"
on = "M1"
table = "tool.csv"
[[load]]
name = "hold"
on = "M1"
force = "-20 N"
[[load]]
name = "shaker"
on = "M2"
sine = { amplitude = "4 N", frequency = "25 Hz" }
[simulation]
cycles = 1
warmup_cycles = 0
sample_rate = "5 kHz"
"""
TOOL = "angle [deg], force [N]\n0, 0\n100, 0\n120, 30\n150, 30\n150, 10\n200, 0\n360, 0\n"


@pytest.fixture
def station(tmp_path) -> Path:
    (tmp_path / "tool.csv").write_text(TOOL)
    path = tmp_path / "station.toml"
    path.write_text(MACHINE)
    return path


# ---------------------------------------------------------------------- bad input
def _variant(text: str, old: str, new: str) -> str:
    assert old in text, old
    return text.replace(old, new, 1)


_HOLD = '[[load]]\nname = "hold"\non = "M1"\nforce = "-20 N"\n'
_PRESS_SEGMENTS = '{ motion = "dwell", duration = "140 deg" },'

BAD = {
    "unknown mass": (_HOLD, _HOLD.replace('"M1"', '"M9"'), "load[2].on", "is not a mass"),
    "on ground": (_HOLD, _HOLD.replace('"M1"', '"ground"'), "load[2].on", "not on ground or a cam"),
    "on the cam": (_HOLD, _HOLD.replace('"M1"', '"cam"'), "load[2].on", "not on ground or a cam"),
    "two programs": (_HOLD, _HOLD + 'sine = { amplitude = "1 N", frequency = "1 Hz" }\n', "load[2].sine",
                     "not both force and sine"),
    "no program": (_HOLD, _HOLD.replace('force = "-20 N"\n', ""), "load[2]", "no force program"),
    "durations": (_PRESS_SEGMENTS, _PRESS_SEGMENTS.replace("140 deg", "130 deg"), "load[0].segments",
                  "not 360 deg"),
    "does not close": ('law = "harmonic", duration = "60 deg" },', 'law = "harmonic", duration = "60 deg", change = "50 N" },',
                       "load[0].segments", "does not close"),
    "frequency zero": ('frequency = "25 Hz"', 'frequency = "0 Hz"', "load[3].sine.frequency", "greater than 0"),
    "frequency negative": ('frequency = "25 Hz"', 'frequency = "-3 Hz"', "load[3].sine.frequency", "greater than 0"),
    "duplicate name": ('name = "hold"', 'name = "k12"', "load[2].name", "duplicate name"),
    "unknown cam": (_HOLD, '[[load]]\nname = "x"\non = "M1"\ncam = "feed"\ntable = "tool.csv"\n', "load[2].cam",
                    "is not a cam"),
    "not a name": ('name = "hold"', 'name = "h/old"', "load[2].name", "not a plain name"),
    "unknown key": ('name = "hold"', 'name = "hold"\nforse = "3 N"', "load[2].forse", "did you mean 'force'"),
}
BAD_TABLES = {
    "not covering": ("angle [deg], force [N]\n0, 0\n120, 30\n350, 0\n", "covers 0–360 deg"),
    "not increasing": ("angle [deg], force [N]\n0, 0\n120, 30\n110, 10\n360, 0\n", "is not increasing"),
    "written three times": ("angle [deg], force [N]\n0, 0\n120, 30\n120, 10\n120, 5\n360, 0\n", "written three times"),
    "unknown unit": ("angle [deg], force [blorp]\n0, 0\n360, 0\n", "unknown unit"),
    "not a force": ("angle [deg], force [mm]\n0, 0\n360, 0\n", "is not a force unit"),
    "not a time": ("time [deg], force [N]\n0, 0\n1, 0\n", "is not a time unit"),
    "bad header": ("angle [deg], torque [N*m]\n0, 0\n360, 0\n", "the header must be two columns"),
    "not a number": ("angle [deg], force [N]\n0, 0\n100, lots\n360, 0\n", "is not a number"),
}


def _refused(path: Path, key: str, words: str) -> None:
    out = path.parent / "out.h5"
    result = runner.invoke(app, ["run", str(path), "-o", str(out), "-q"])
    assert result.exit_code == 2, result.stderr
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1, lines
    assert str(path) in lines[0] and key in lines[0] and words in lines[0], lines[0]
    assert not out.exists() and not list(path.parent.glob("*.h5*")), "nothing written"
    check = runner.invoke(app, ["validate", str(path)])
    assert check.exit_code == 2 and key in check.stderr


@pytest.mark.parametrize("case", sorted(BAD))
def test_bad_load_tables_are_one_line_naming_file_and_key(station, case):
    """Spec §6/§10: each bad ``[[load]]`` is exit 2 with one line naming the file and the key,
    and no result file (``run``); ``validate`` refuses it the same way."""
    old, new, key, words = BAD[case]
    station.write_text(_variant(MACHINE, old, new))
    _refused(station, key, words)


@pytest.mark.parametrize("case", sorted(BAD_TABLES))
def test_bad_load_csv_is_one_line_naming_file_and_key(station, case):
    """A load's CSV: an angle table covers 0–360°, abscissae increase (twice is a step, not
    three times), the header's units are known and of the right dimension."""
    text, words = BAD_TABLES[case]
    (station.parent / "tool.csv").write_text(text)
    _refused(station, "load[1].table", words)


def test_an_angle_program_needs_a_cam(tmp_path):
    """A machine without a cam may be driven by loads alone, but not by one over the cam angle."""
    text = """schema = 1
[machine]
name = "no cam"
[[mass]]
name = "M"
mass = "1 kg"
[[element]]
name = "k"
type = "spring"
between = ["ground", "M"]
stiffness = "1000 N/m"
[[load]]
name = "F"
on = "M"
segments = [{ motion = "dwell", duration = "360 deg" }]
[simulation]
duration = "0.1 s"
"""
    path = tmp_path / "nocam.toml"
    path.write_text(text)
    _refused(path, "load[0].segments", "needs a cam")


# ---------------------------------------------------------------------- keys
def test_load_keys_address_set_and_read_back(station):
    """``--set``/``--vary`` keys of a load: ``load.<name>.force``, ``.base``,
    ``.segments[i].change``, ``.sine.amplitude``, and ``load[i].<key>``; their SI units; a
    rise's change swept with the closing fall following; a wrong key suggests the right one."""
    assert keys.unit("load.hold.force") == "N"
    assert keys.unit("load.press.segments[1].change") == "N"
    assert keys.unit("load.shaker.sine.frequency") == "Hz"
    assert keys.unit("load.press.segments[1].end.v") == "N/s"
    assert keys.unit("load[3].sine.start") == "s"
    machine = load_machine(station, ["load.hold.force=-30 N", 'load.press.segments[1].change="80 N"',
                                     "load.press.base=2N", "load.shaker.sine.amplitude=7N", "load[3].sine.phase=90"])
    hold, press, _, shaker = (machine.load(n) for n in ("hold", "press", "tool", "shaker"))
    assert hold.force == -30.0 and press.base == 2.0 and shaker.sine.amplitude == 7.0
    assert press.segments[1].lift == 80.0 and press.segments[3].lift == 80.0  # the fall closes the program
    assert shaker.sine.phase == pytest.approx(np.pi / 2)
    from camsim.machine.loader import machine_to_dict

    described = machine_to_dict(machine)
    assert keys.machine_value(described, "load.press.segments[1].change") == 80.0
    assert keys.machine_value(described, "load.shaker.sine.amplitude") == 7.0
    paths = keys.document_paths(__import__("tomllib").loads(MACHINE))
    assert {"load.hold.force", "load.press.base", "load.press.segments[1].change", "load.shaker.sine.amplitude"} <= set(paths)
    assert "load.shaker.force" not in paths  # a sine load offers its sine's keys, not a constant's
    from camsim.errors import MachineFileError

    with pytest.raises(MachineFileError, match="did you mean 'load\\[2\\].force'"):
        load_machine(station, ["load.hold.forse=3N"])
    with pytest.raises(MachineFileError, match="no load named 'hodl'; did you mean 'hold'"):
        load_machine(station, ["load.hodl.force=3N"])


# ---------------------------------------------------------------------- results and commands
def test_run_file_holds_the_loads_and_every_reader_reads_them(station):
    """``camsim run``: ``/loads/<name>/force`` (units N) beside the other traces; the summary's
    loads in --json (extremes and work per cycle: the constant on the driven mass does none,
    the closed form); ``open_result`` gives back the in-memory result's loads and work;
    ``export`` writes the columns with their units; ``check`` finds a changed load."""
    out = station.parent / "station.h5"
    result = runner.invoke(app, ["run", str(station), "-o", str(out), "--json"])
    assert result.exit_code == 0, result.stderr
    summary = json.loads(result.stdout)["loads"]
    assert set(summary) == {"press", "tool", "hold", "shaker"}
    assert summary["hold"]["max"]["value"] == -20.0 and abs(summary["hold"]["work"]) < 1e-12
    assert summary["tool"]["max"]["value"] == 30.0 and summary["tool"]["work_over"] == "revolution"
    memory = simulate(load_machine(station))
    with h5py.File(out) as f:
        for name in memory.loads:
            dset = f[f"loads/{name}/force"]
            assert dset.attrs["units"] == "N"
            assert np.array_equal(dset[()], memory.loads[name])
        assert f["summary"].attrs["units:load_work:press"] == "J"
    back = open_result(out)
    assert back.load_work == memory.load_work
    assert back.scalars()["max_load:press"] == memory.scalars()["max_load:press"] == 55.0
    csv_path = station.parent / "station.csv"
    assert runner.invoke(app, ["export", str(out), "-o", str(csv_path)]).exit_code == 0
    header = next(csv.reader(csv_path.open()))
    assert "loads/press/force [N]" in header and "loads/shaker/force [N]" in header
    other = station.parent / "other.h5"
    station.write_text(MACHINE.replace('change = "60 N"', 'change = "61 N"'))
    assert runner.invoke(app, ["run", str(station), "-o", str(other), "-q"]).exit_code == 0
    checked = runner.invoke(app, ["check", str(other), "--against", str(out)])
    assert checked.exit_code == 1 and "loads/press/force" in checked.stderr


def test_validate_shows_the_loads_in_the_files_units(station):
    """``validate``: a loads table (mass, program, values in the file's units); ``--json``
    describes each load in SI."""
    shown = runner.invoke(app, ["validate", str(station), "--units", "us"])
    assert shown.exit_code == 0, shown.stderr
    text = shown.stderr
    lbf = 0.45359237 * 9.80665
    assert "process loads" in text and f"{-20 / lbf:.6g} lbf" in text and "angle table" in text
    assert f"amplitude {4 / lbf:.6g} lbf" in text and "frequency 25 Hz" in text
    described = json.loads(runner.invoke(app, ["validate", str(station), "--json"]).stdout)
    rows = {row["name"]: row for row in described["loads"]}
    assert rows["press"]["segments"][3]["change"] == 60.0 and rows["shaker"]["sine"]["frequency"] == 25.0


def test_compare_keeps_every_load_in_the_no_impact_variant(station):
    """Spec §10: the no-impact variant keeps every load (contacts removed, loads not): both
    sides of a comparison hold the same load traces and the cam contact force of each is
    m·s̈ − Σ element forces − the loads on the driven mass."""
    out = station.parent / "cmp.h5"
    result = runner.invoke(app, ["compare", str(station), "-o", str(out), "-q"])
    assert result.exit_code == 0, result.stderr
    for side in ("impact", "no_impact"):
        run = open_result(out, side)
        assert set(run.loads) == {"press", "tool", "hold", "shaker"}
        fc = 1.5 * run.cam["acceleration"] - run.elements["k12"] + run.elements["ret"] - run.loads["tool"] - run.loads["hold"]
        assert np.max(np.abs(run.cam_contact_force - fc)) <= 1e-9
    with h5py.File(out) as f:
        assert np.array_equal(f["impact/loads/press/force"][()], f["no_impact/loads/press/force"][()])


def test_plot_and_report_show_the_loads(station):
    """``plot --what forces`` draws each load's force; the report page has the loads among the
    traces and a process-loads table whose values are the file's (``data-si``)."""
    out = station.parent / "station.h5"
    assert runner.invoke(app, ["run", str(station), "-o", str(out), "-q"]).exit_code == 0
    figures = station.parent / "figures"
    result = runner.invoke(app, ["plot", str(out), "--what", "forces", "-o", str(figures)])
    assert result.exit_code == 0, result.stderr
    assert {p.name for p in figures.glob("station_loads_*")} == {f"station_loads_{n}_force.png"
                                                                  for n in ("press", "tool", "hold", "shaker")}
    page = station.parent / "station.html"
    assert runner.invoke(app, ["report", str(out), "-o", str(page)]).exit_code == 0
    html = page.read_text()
    assert "Process loads" in html and "id=load-table" in html
    back = open_result(out)
    key = "load_work:press"
    assert f"data-key='{key}' data-si='{back.scalars()[key]!r}'" in html


def test_a_sweep_varies_a_load_and_reports_each_loads_scalars(station):
    """``sweep --values load.hold.force=…`` (and a rise's change, the closing fall following):
    each variant's row holds the load scalars (max_load, min_load, load_work with their units);
    the constant's extremes are the swept values and its work on the driven follower zero (the
    closed form), whatever the value."""
    out = station.parent / "sw.h5"
    result = runner.invoke(app, ["sweep", str(station), "--values", "load.hold.force=-10N,-40N", "--values",
                                 "load.press.segments[1].change=30N,90N", "-o", str(out), "--workers", "1", "--json"])
    assert result.exit_code == 0, result.stderr
    rows = list(csv.DictReader((station.parent / "sw.csv").open()))
    assert len(rows) == 4
    header = rows[0].keys()
    assert {"max_load:hold [N]", "min_load:hold [N]", "load_work:press [J]"} <= set(header)
    for row in rows:
        assert float(row["min_load:hold [N]"]) == float(row["param:load.hold.force [N]"])
        assert abs(float(row["load_work:hold [J]"])) < 1e-12
        assert float(row["max_load:press [N]"]) == pytest.approx(float(row["param:load.press.segments[1].change [N]"]) - 5.0)

"""Sizes bounded before they are spent, names every table can hold (issue 45, items 2 and 6).

References: the issue's reproducers. Before the fix a rod of ``youngs_modulus = "1e-30 psi"``
or ``length = "1e9 m"`` made ``camsim validate`` allocate 22 GB (OOM-killed, exit 137; under a
memory limit "internal error (MemoryError)"); ``segments = 100000`` validated and ``run`` was
killed after 85 s; 1000 ``[[cam]]`` tables validated and ``run`` ended in "internal error
(RuntimeError: H5DSattach_scale)" (HDF5 keeps a time base's attached traces in one 64 KiB
attribute: 4,085 of them, measured with h5py); a mass named ``M/3`` or ``M<3`` validated and
ran, then ``report`` failed with "internal error (StopIteration)". The memory-bound cases run in
a child process limited to 3 GB of address space (RLIMIT_AS), so a regression fails instead of
taking the machine's memory.
"""

from __future__ import annotations

import os
import resource
import subprocess
import sys
import time
from pathlib import Path

import pytest
from typer.testing import CliRunner

from camsim.cli import app
from camsim.machine.limits import MAX_CAMS, MAX_NODES, MAX_TRACES

ROOT = Path(__file__).resolve().parents[1]
MACHINES = ROOT / "machines"
runner = CliRunner()


def _limited() -> None:  # in the child: 3 GB of address space
    resource.setrlimit(resource.RLIMIT_AS, (3 * 2**30, 3 * 2**30))


@pytest.mark.parametrize("edit,estimate", [
    (('youngs_modulus = "30e6 psi"', 'youngs_modulus = "1e-30 psi"'), "1.723e+17 segments"),
    (('length = "0.4 in"', 'length = "1e9 m"'), "segments"),
    (('length = "0.4 in"', 'length = "0.4 in"\nsegments = 100000'), "segments = 100000"),
], ids=["modulus-1e-30-psi", "length-1e9-m", "segments-100000"])
def test_a_rod_too_large_is_refused_when_loaded(edit, estimate, tmp_path):
    text = (MACHINES / "cdtm-rod.toml").read_text()
    assert edit[0] in text
    machine = tmp_path / "rod.toml"
    machine.write_text(text.replace(edit[0], edit[1], 1))
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    started = time.monotonic()
    r = subprocess.run([sys.executable, "-m", "camsim", "validate", str(machine)], capture_output=True, text=True,
                       env=env, preexec_fn=_limited, timeout=120)
    took = time.monotonic() - started
    lines = [line for line in r.stderr.splitlines() if line.strip()]
    assert r.returncode == 2, r.stderr
    assert len(lines) == 1 and "rod.toml" in lines[0] and "element[3].segments" in lines[0], r.stderr
    assert estimate in lines[0] and f"limit of {MAX_NODES}" in lines[0] and "--max-nodes" in lines[0], lines[0]
    assert took < 30


def test_max_nodes_raises_the_limit(tmp_path):
    args = ["validate", str(MACHINES / "cdtm-rod.toml"), "--set", "element.screw.segments=600"]
    r = runner.invoke(app, args)
    assert r.exit_code == 2 and "603 nodes" in r.stderr, r.stderr
    r = runner.invoke(app, [*args, "--max-nodes", "1000"])
    assert r.exit_code == 0, r.stderr


def _cams(n: int) -> str:
    parts = ['schema = 1\n[machine]\nname = "many cams"\n[camshaft]\nspeed = "120 rpm"\n']
    for i in range(n):
        parts.append(f'[[cam]]\nname = "c{i}"\ndrives = "M{i}"\nsegments = [{{ motion = "rise", law = "harmonic", '
                     'duration = "180 deg", lift = "10 mm" }, { motion = "fall", law = "harmonic", '
                     'duration = "180 deg", lift = "10 mm" }]\n')
    parts += [f'[[mass]]\nname = "M{i}"\nmass = "1 kg"\n' for i in range(n)]
    return "".join(parts) + '[simulation]\ncycles = 1\nsample_rate = "1 kHz"\n'


def test_a_thousand_cams_are_refused_when_loaded(tmp_path):
    machine = tmp_path / "cams.toml"
    machine.write_text(_cams(1000))
    r = runner.invoke(app, ["validate", str(machine)])  # run loads it the same way
    assert r.exit_code == 2, r.stderr
    assert f"cams.toml: cam: 1000 [[cam]] tables, above the limit of {MAX_CAMS} cams (--max-cams)" in r.stderr


def test_more_traces_than_a_time_base_can_carry_are_refused(tmp_path):
    """1400 masses (--max-nodes raised): 4,200 mass traces and more, above the file format's 4,000."""
    n = 1400
    text = ('schema = 1\n[machine]\nname = "many masses"\n[cam]\nspeed = "60 rpm"\ndrives = "M0"\nsegments = ['
            '{ motion = "rise", law = "harmonic", duration = "180 deg", lift = "10 mm" }, '
            '{ motion = "fall", law = "harmonic", duration = "180 deg", lift = "10 mm" }]\n')
    text += "".join(f'[[mass]]\nname = "M{i}"\nmass = "1 kg"\n' for i in range(n))
    text += "".join(f'[[element]]\nname = "K{i}"\ntype = "spring"\nbetween = ["M{i - 1}", "M{i}"]\nstiffness = "1 N/mm"\n'
                    for i in range(1, n))
    machine = tmp_path / "masses.toml"
    machine.write_text(text)
    r = runner.invoke(app, ["validate", str(machine), "--max-nodes", "2000"])
    assert r.exit_code == 2, r.stderr
    assert "masses.toml: mass: the result would hold" in r.stderr and f"above the {MAX_TRACES}" in r.stderr, r.stderr


MACHINE = (MACHINES / "cdtm.toml").read_text()


@pytest.mark.parametrize("table,old,new", [
    ("mass[2]", 'name = "M3"', 'name = "M/3"'),
    ("mass[2]", 'name = "M3"', 'name = "M<3"'),
    ("mass[2]", 'name = "M3"', 'name = "M 3"'),
    ("element[3]", 'name = "seat"', 'name = "seat.1"'),
    ("element[3]", 'name = "seat"', 'name = "' + "s" * 65 + '"'),
])
def test_names_every_table_can_hold(table, old, new, tmp_path):
    """One check for the names of every named table (masses, elements, cams, materials)."""
    assert old in MACHINE
    text = MACHINE.replace(old, new, 1)
    if "M3" in old:
        text = text.replace('"M3"', new.split("=", 1)[1].strip())
    machine = tmp_path / "m.toml"
    machine.write_text(text)
    r = runner.invoke(app, ["validate", str(machine)])
    assert r.exit_code == 2, r.stderr
    lines = [line for line in r.stderr.splitlines() if line.strip()]
    assert len(lines) == 1 and f"m.toml: {table}.name:" in lines[0] and "a name is letters, digits" in lines[0], r.stderr


def test_the_named_tables_are_one_registry():
    """A new named table is one line in camsim.machine.names.TABLES ([[load]] was, issue 43; a
    hypothetical [[gauge]] here)."""
    from camsim.errors import MachineFileError
    from camsim.machine import names

    def error(key, message):
        return MachineFileError("f.toml", key, message)

    with pytest.raises(MachineFileError, match=r"load\[0\]\.name"):
        names.check_names({"load": [{"name": "L/1"}]}, error)
    doc = {"gauge": [{"name": "G/1"}]}
    names.check_names(doc, error)  # not a named table yet: nothing checked
    names.TABLES["gauge"] = "/gauges/<name>/... in the result"
    try:
        with pytest.raises(MachineFileError, match=r"gauge\[0\]\.name"):
            names.check_names(doc, error)
    finally:
        del names.TABLES["gauge"]


@pytest.mark.parametrize("command", [
    ["sweep", str(MACHINES / "cdtm.toml"), "--vary", "cam.speed=60:120:60rpm", "--workers", "1", "-o", "{tmp}/s.h5"],
    ["compare", str(MACHINES / "cdtm.toml"), "-o", "{tmp}/c.h5"],
    ["fit", str(MACHINES / "cdtm.toml"), "--target", "peak_transducer_force=200N", "--param",
     "element.K23.preload=20:40lbf", "-o", "{tmp}/f.toml"],
    ["impact", "--materials", "--machine", str(MACHINES / "ball-drop-hertz.toml")],
], ids=["sweep", "compare", "fit", "impact-materials"])
def test_runs_held_in_memory_are_bounded_before_they_start(command, tmp_path):
    """Issue 45: a run held in memory (a sweep's variant, a comparison, a fit's evaluation, a
    material pair) whose traces would exceed 2 GB is refused before it starts; only `run`
    (which streams) had the estimate. 100000 revolutions of the CDTM at 50 kHz: 840 GB."""
    args = [a.replace("{tmp}", str(tmp_path)) for a in command] + ["--set", "simulation.cycles=100000"]
    if command[0] == "impact":
        args += ["--set", "simulation.duration=1e5 s"]
        args.remove("simulation.cycles=100000")
        args.remove("--set")
    started = time.monotonic()
    r = runner.invoke(app, args)
    assert r.exit_code == 2, r.stderr
    lines = [line for line in r.stderr.splitlines() if line.strip()]
    assert len(lines) == 1 and "held in memory" in lines[0] and "above 2 GB" in lines[0], r.stderr
    assert time.monotonic() - started < 20
    assert not [p for p in tmp_path.iterdir() if not p.name.startswith(".")]

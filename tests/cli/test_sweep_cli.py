"""The ``camsim sweep`` command: output files, --json, exit codes, one-line errors, Ctrl-C.

Numbers are checked in tests/test_sweep.py against individual runs; here: the CSV equals
the HDF5 table exactly, --json has the documented keys and the same values, bad input
is one line on stderr with exit 2 and nothing written.
"""

from __future__ import annotations

import csv
import json
import math
import socket
import time
from pathlib import Path

import h5py
import pytest
from typer.testing import CliRunner

from camsim.cli import app
from camsim.io.hdf5 import read_table

MACHINES = Path(__file__).resolve().parents[2] / "machines"
BARKAN = str(MACHINES / "barkan-follower.toml")
FAST = ["--cycles", "1", "--warmup", "0", "--sample-rate", "2 kHz"]
COLUMNS = [
    "param:cam.speed", "peak_displacement:F", "peak_velocity:F", "peak_acceleration:F",
    "peak_transducer_force", "max_cam_contact_force", "min_cam_contact_force",
    "jump", "cam_separation", "cam_separation_angle", "impacts", "max_impact_velocity", "periodicity_residual", "status",
]  # fmt: skip
runner = CliRunner()


def _csv_si(header: str, cell: str, si_unit: str) -> float:
    """A CSV cell in the unit of its header (``name [unit]``, issue 44: display units) in SI, by pint."""
    import re

    import pint

    m = re.search(r"\[(.+)\]$", header)
    value = float(cell)
    if not m or not si_unit:
        return value
    unit = m.group(1).replace("²", "**2").replace("³", "**3").replace("·", "*")
    return pint.UnitRegistry().Quantity(value, unit).to(si_unit.replace("^", "**")).magnitude


def test_sweep_writes_h5_and_csv_that_agree(tmp_path):
    out = tmp_path / "s.h5"
    result = runner.invoke(app, ["sweep", BARKAN, "--vary", "cam.speed=420:480:30rpm", "-o", str(out), "--workers", "1", *FAST])
    assert result.exit_code == 0, result.stderr
    assert result.stdout == ""
    assert "wrote" in result.stderr and "lowest swept speed at which the follower jumps: 450 rpm" in result.stderr
    assert sorted(p.name for p in tmp_path.iterdir()) == ["s.csv", "s.h5"]
    with h5py.File(out) as f:
        assert f.attrs["file_kind"] == "sweep"
        table = read_table(f["sweep/summary"])
        assert math.isnan(f["sweep/summary"].attrs["jump_onset_rpm"])  # not refined
    assert list(table) == COLUMNS
    with open(tmp_path / "s.csv", newline="") as fh:
        lines = list(csv.reader(fh))
    # the header names each column's unit: the machine file's units (issue 44), speeds in rpm
    assert [h.split(" [")[0] for h in lines[0]] == COLUMNS and len(lines) == 4
    assert lines[0][0] == "param:cam.speed [rpm]" and "peak_acceleration:F [m/s²]" in lines[0]
    with h5py.File(out) as f:
        units = {n: f["sweep/summary"].attrs[f"units:{n}"] for n in COLUMNS}
    for i, line in enumerate(lines[1:]):
        assert line[COLUMNS.index("status")] == table["status"][i] == "ok"
        assert line[COLUMNS.index("jump")] == ("true" if table["jump"][i] else "false")
        for name in ("param:cam.speed", "peak_acceleration:F", "min_cam_contact_force", "max_impact_velocity"):
            j = COLUMNS.index(name)
            x, y = _csv_si(lines[0][j], line[j], units[name]), table[name][i]
            assert (math.isnan(x) and math.isnan(y)) or math.isclose(x, y, rel_tol=1e-12)


def test_sweep_json_documented_keys(tmp_path):
    out = tmp_path / "s.h5"
    result = runner.invoke(
        app, ["sweep", BARKAN, "--values", "cam.speed=440,460rpm", "-o", str(out), "--json", "--workers", "1", *FAST]
    )
    assert result.exit_code == 0, result.stderr
    payload = json.loads(result.stdout)  # only JSON on stdout
    assert {"rows", "jump_onset_rpm"} <= set(payload)
    assert payload["jump_onset_rpm"] is None  # not refined
    assert payload["first_jump_rpm"] == pytest.approx(460.0)
    assert [list(r) for r in payload["rows"]] == [COLUMNS + ["reasons"], COLUMNS + ["reasons"]]
    assert payload["rows"][0]["jump"] is False and payload["rows"][1]["jump"] is True
    assert payload["rows"][0]["max_impact_velocity"] is None  # NaN -> null
    assert payload["rows"][0]["reasons"]["max_impact_velocity"] == "no impact in the run"  # issue 26: null says why
    with h5py.File(out) as f:
        table = read_table(f["sweep/summary"])
    assert [r["peak_velocity:F"] for r in payload["rows"]] == table["peak_velocity:F"].tolist()


def test_sweep_json_refined_onset(tmp_path):
    result = runner.invoke(
        app,
        ["sweep", BARKAN, "--vary", "cam.speed=440:450:10rpm", "--refine-jump", "--json", "--workers", "1", "-o", str(tmp_path / "s.h5")],
    )
    assert result.exit_code == 0, result.stderr
    # analytic onset 447.6 rpm (machines/barkan-follower.toml; recomputed in tests/test_sweep.py)
    assert json.loads(result.stdout)["jump_onset_rpm"] == pytest.approx(447.6, abs=0.1)


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--vary", "cam.sped=400:500:50rpm"], "barkan-follower.toml: cam.sped: unknown key; did you mean 'cam.speed'?"),
        (["--vary", "cam.speed=400:500:50kg"], "barkan-follower.toml: cam.speed: expected [angle]/[time]"),
        (["--vary", "cam.speed=500:400:50rpm"], "--vary cam.speed=500:400:50rpm: empty range"),
        (["--vary", "cam.speed=400:500:0rpm"], "--vary cam.speed=400:500:0rpm: the step is zero"),
        (["--vary", "cam.speed=1:1001:1rpm"], "1001 variants exceed --max-variants 1000; pass --yes"),
        (["--vary", "cam.speed=400:500:50rpm", "--max-variants", "2"], "3 variants exceed --max-variants 2"),
        (["--vary", "cam.speed=400:500:50rpm", "--scheduler", "tcp://127.0.0.1:{port}"], "--scheduler tcp://127.0.0.1:{port}: cannot connect"),
        (["--vary", "cam.speed=400:500:50rpm", "--sample-rate", "5 kg"], "--sample-rate:"),
    ],
)
def test_bad_input_one_line_exit_2_nothing_written(tmp_path, args, message):
    port = _free_port()
    args = [a.format(port=port) for a in args]
    message = message.format(port=port)
    t0 = time.monotonic()
    result = runner.invoke(app, ["sweep", BARKAN, *args, "-o", str(tmp_path / "s.h5")])
    assert time.monotonic() - t0 < 10  # an unreachable scheduler does not hang
    assert result.exit_code == 2, result.stderr
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("camsim: error: ") and message in lines[0], result.stderr
    assert result.stdout == ""
    assert list(tmp_path.iterdir()) == []


def test_yes_runs_more_than_max_variants(tmp_path):
    result = runner.invoke(
        app, ["sweep", BARKAN, "--vary", "cam.speed=400:420:10rpm", "--max-variants", "2", "--yes", "--workers", "1", "-o", str(tmp_path / "s.h5"), *FAST]
    )
    assert result.exit_code == 0, result.stderr
    assert "3 variants" in result.stderr


def test_ctrl_c_writes_finished_rows_exit_130(tmp_path, monkeypatch):
    import camsim.analyses.sweep.runner as sweep

    real = sweep.run_variant
    calls = []

    def stop_on_second(*args):
        calls.append(1)
        if len(calls) == 2:
            raise KeyboardInterrupt
        return real(*args)

    monkeypatch.setattr(sweep, "run_variant", stop_on_second)
    out = tmp_path / "s.h5"
    result = runner.invoke(app, ["sweep", BARKAN, "--vary", "cam.speed=400:420:10rpm", "--workers", "1", "-o", str(out), *FAST])
    assert result.exit_code == 130
    assert "interrupted: kept the 1 finished variants of 3" in result.stderr
    with h5py.File(out) as f:
        assert list(read_table(f["sweep/summary"])["status"]) == ["ok", "cancelled", "cancelled"]
        assert bool(f["sweep"].attrs["interrupted"])


def test_help_explains_units():
    result = runner.invoke(app, ["sweep", "--help"])
    assert result.exit_code == 0
    assert "KEY=START:STOP:STEP[UNIT]" in result.stdout and "SI" in result.stdout

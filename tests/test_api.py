"""The Python API and the run result as the hub (issue 11).

References: the machine files themselves (a dict and a path describing the same machine
load to the same SI values), the written HDF5 file (reading it back gives the same numbers
bit for bit), and one computation shared by every command — ``run --json``, a one-point
``sweep`` and ``compare`` must report identical derived quantities for every shipped
machine (they read them from the same RunResult; a second computation anywhere would
show up here as a difference).
"""

from __future__ import annotations

import json
import math
import tomllib
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

import camsim
from camsim import MachineError, RunResult, load_machine, open_result, simulate
from camsim.cli import app
from camsim.elements.events import EventKind, EventTable
from camsim.run.runfile import write_run
from camsim.machine.loader import machine_to_dict

ROOT = Path(__file__).resolve().parents[1]
MACHINES = sorted(p for p in (ROOT / "machines").glob("*.toml") if "[lever" not in p.read_text())  # not the lump parts file
#: A sample rate every shipped machine runs at quickly (the numbers only need to agree).
RATE = 5000.0


def _same(a, b) -> bool:
    if isinstance(a, float) and isinstance(b, float) and math.isnan(a) and math.isnan(b):
        return True
    return a == b


def test_public_names():
    """``from camsim import load_machine, simulate, RunResult, open_result`` works."""
    for name in ("load_machine", "simulate", "RunResult", "open_result", "MachineError", "SimulationError"):
        assert hasattr(camsim, name), name
    assert camsim.RunResult is RunResult


def test_load_machine_dict_equals_path():
    """A dict (what tomllib reads) and the file describe the same machine, to the bit."""
    path = ROOT / "machines" / "dynacam-2mass.toml"
    doc = tomllib.loads(path.read_text())
    from_dict = machine_to_dict(load_machine(doc, base_dir=path.parent))
    from_path = machine_to_dict(load_machine(path))
    from_dict.pop("source"), from_path.pop("source")
    assert from_dict == from_path


def test_with_values_is_a_checked_copy():
    machine = load_machine(ROOT / "machines" / "cdtm.toml")
    changed = machine.with_values({"element.K12.stiffness": "1.7e6 N/m", "mass.M2.mass": 0.75})
    assert changed.element("K12").stiffness == 1.7e6
    assert changed.mass_of("M2") == 0.75
    assert machine.element("K12").stiffness == pytest.approx(9051 * 4.4482216152605 / 0.0254, rel=1e-12)
    with pytest.raises(MachineError) as info:
        machine.with_values({"element.K12.stiffness": "25 lbf"})
    assert info.value.key == "element[1].stiffness" or "stiffness" in info.value.key
    with pytest.raises(MachineError, match="no element named 'K99'"):
        machine.with_values({"element.K99.stiffness": 1.0})


def test_simulate_overrides():
    machine = load_machine(ROOT / "machines" / "barkan-follower.toml")
    result = simulate(machine, cycles=2, sample_rate=2000.0)
    period = machine.cam.period
    assert result.time[-1] == pytest.approx(2 * period, abs=1e-12)
    assert result.time[1] - result.time[0] == pytest.approx(1 / 2000.0, rel=1e-12)


@pytest.fixture(scope="module")
def cdtm_run():
    return simulate(load_machine(ROOT / "machines" / "cdtm.toml"), sample_rate=10_000.0)


def test_open_result_round_trip(cdtm_run, tmp_path):
    """Written and read back: every trace bit-identical, the events and scalars equal."""
    path = tmp_path / "cdtm.h5"
    write_run(cdtm_run, path)
    again = open_result(path)
    assert list(again.traces()) == list(cdtm_run.traces())
    for p, trace in cdtm_run.traces().items():
        assert np.array_equal(again.trace(p), trace.data), p
        assert again.units(p) == trace.units
    assert len(again.events) == len(cdtm_run.events)
    for a, b in zip(again.events, cdtm_run.events):
        assert a.kind is b.kind and a.element == b.element
        assert all(_same(getattr(a, c), getattr(b, c)) for c in ("time", "relative_velocity", "peak_force"))
    assert all(_same(again.scalars()[k], v) for k, v in cdtm_run.scalars().items())


def test_events_are_typed(cdtm_run):
    assert isinstance(cdtm_run.events, EventTable)
    assert all(isinstance(e.kind, EventKind) for e in cdtm_run.events)
    assert {e.kind for e in cdtm_run.impacts()} <= {EventKind.IMPACT, EventKind.REJOIN}
    frame = cdtm_run.events.to_pandas()
    assert list(frame["kind"]) == [e.kind.value for e in cdtm_run.events]
    assert frame.attrs["units"]["time"] == "s"


def test_to_pandas_and_xarray_keep_units(cdtm_run):
    frame = cdtm_run.to_pandas()
    assert frame.index.name == "time" and np.array_equal(frame.index.to_numpy(), cdtm_run.time)
    assert frame.attrs["units"]["masses/M3/acceleration"] == "m/s^2"
    assert np.array_equal(frame["transducer/force"].to_numpy(), cdtm_run.transducer_force)
    ds = cdtm_run.to_xarray()
    assert np.array_equal(ds["time"].values, cdtm_run.time)
    assert ds["elements/seat/force"].attrs["units"] == "N"
    assert ds["elements/seat/force"].dims == ("time",)


def test_plot_gives_the_file_figures(cdtm_run, tmp_path):
    """RunResult.plot draws what ``camsim plot`` draws from the written file."""
    from camsim.figures.plots import make_plots

    figures = camsim.plot_result(cdtm_run, what=["forces"])
    path = tmp_path / "run.h5"
    write_run(cdtm_run, path)
    from_file = make_plots(path, what=["forces"])
    assert [n.split("_", 1)[1] for n in figures] == [n.split("_", 1)[1] for n in from_file]


def test_missing_extra_is_one_line(monkeypatch):
    """A missing optional extra names the extra to install (and is bad input, exit 2)."""
    import builtins

    from camsim.extras import MissingExtraError, require

    real = builtins.__import__

    def fake(name, *args, **kwargs):
        if name == "xarray":
            raise ModuleNotFoundError("No module named 'xarray'", name="xarray")
        return real(name, *args, **kwargs)

    monkeypatch.setattr(builtins, "__import__", fake)
    monkeypatch.delitem(__import__("sys").modules, "xarray", raising=False)
    with pytest.raises(MissingExtraError, match=r"pip install 'camsim\[xarray\]'"):
        require("xarray", "xarray")


#: With CAMSIM_FULL=1 only (before a release; .ci/run's 15 minutes): a dynamic camshaft (a
#: relaxation of ~20 runs, issue 38: 42 s here) and the CDTM with its screw as a rod (the
#: screw's axial mode at 250 kHz: ~15 s a run, three runs here).
_AGREE = [pytest.param(p, marks=pytest.mark.full) if p.stem == "cdtm-rod" or "model = \"dynamic\"" in p.read_text()
          else p for p in MACHINES]


@pytest.mark.parametrize("path", _AGREE, ids=lambda p: p.stem)
def test_run_sweep_compare_agree(path, tmp_path):
    """Every shipped machine: run --json, a one-point sweep and compare report the same
    derived quantities (one computation, in RunResult)."""
    runner = CliRunner()
    rate = f"{RATE:g} Hz"
    run = runner.invoke(app, ["run", str(path), "-o", str(tmp_path / "r.h5"), "--sample-rate", rate, "--json"])
    assert run.exit_code == 0, run.output
    summary = json.loads(run.stdout)
    doc = tomllib.loads(path.read_text())
    cycles = doc.get("simulation", {}).get("cycles")
    key = "simulation.cycles" if cycles else "simulation.warmup_cycles"
    value = str(cycles or doc.get("simulation", {}).get("warmup_cycles", 1))
    sweep = runner.invoke(app, ["sweep", str(path), "--values", f"{key}={value}", "--sample-rate", rate,
                                "-o", str(tmp_path / "s.h5"), "--json", "--workers", "1"])
    assert sweep.exit_code == 0, sweep.output
    row = json.loads(sweep.stdout)["rows"][0]
    for name in ("max_cam_contact_force", "min_cam_contact_force", "peak_transducer_force"):
        from_run = summary[name]["value"] if summary[name] else None
        assert row[name] == from_run, name
    assert row["jump"] == summary["jump"]
    assert row["impacts"] == len(summary["impacts"])
    for mass, entry in summary["masses"].items():
        for quantity in ("displacement", "velocity", "acceleration"):
            assert row[f"peak_{quantity}:{mass}"] == entry[quantity]["peak"]
    comparison = runner.invoke(app, ["compare", str(path), "-o", str(tmp_path / "c.h5"), "--sample-rate", rate, "--json"])
    assert comparison.exit_code == 0, comparison.output
    rows = json.loads(comparison.stdout)["rows"]
    for r in rows:
        assert r["peak_a"] == summary["masses"][r["mass"]][r["quantity"]]["peak"]

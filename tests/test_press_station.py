"""The worked press-fit station (issue 43 item 5): machines/press-station.toml and its bare twin.

References (closed forms, not camsim against itself):

* Newton on the whole follower train: the cam pushes the three masses, and every other force
  on them is external to the train (the return spring from the frame, the guide's friction, the
  press-in force, the stop), so at every instant Fc = Σ m·ẍ + f_return + f_guide − F_press +
  F_stop (tension-positive element forces; the stop's compressive force pushes the punch toward
  −x). The elements inside the train (rod, over-travel unit) cancel.
* The friction's energy: a Coulomb pair (no Stribeck drop, no viscous term) dissipates F_C per
  metre slid, so E = F_C × the ram's path length over the revolution; the ram goes out and back
  all the way each stroke, so E ≥ 2·F_C·(x_max − x_min).
* The bare file is the station's file without the process force and the guide, and the TOML the
  docs page shows is the file's.
"""

from __future__ import annotations

import copy
import re
import tomllib
from pathlib import Path

import numpy as np
import pytest

from camsim import load_machine, simulate

ROOT = Path(__file__).resolve().parents[1]
STATION = ROOT / "machines" / "press-station.toml"
BARE = ROOT / "machines" / "press-station-bare.toml"
PAGE = ROOT / "docs" / "press-station.md"


@pytest.fixture(scope="module")
def fine():
    """One revolution at 200 kHz (the turning points of the ram's path resolved to ~1e-10 m)."""
    return simulate(load_machine(STATION, ["simulation.sample_rate=200 kHz"]))


def test_newton_on_the_whole_train(fine):
    r = fine
    machine = r.machine
    fc = r.cam_force
    inertia = sum(machine.mass_of(m) * r.trace(f"masses/{m}/acceleration") for m in ("lever", "ram", "punch"))
    external = (r.trace("elements/return/force") + r.trace("elements/guide/force")
                - r.trace("loads/press/force") + r.trace("elements/stop/force"))
    assert np.max(np.abs(fc - (inertia + external))) <= 1e-9 * np.max(np.abs(fc))
    # the forces the check rests on all act within the revolution
    assert np.min(r.trace("loads/press/force")) == pytest.approx(-1500.0)
    assert np.max(r.trace("elements/stop/force")) > 2000.0
    assert np.max(np.abs(r.trace("elements/guide/force"))) == pytest.approx(90.0, abs=5.0)  # held near F_B before it slips


def test_friction_energy_is_coulomb_force_times_the_path(fine):
    r = fine
    section = r.summary()["friction"]["guide"]
    f_c = section["coulomb_force"]
    x = r.trace("masses/ram/displacement")
    path = float(np.sum(np.abs(np.diff(x))))  # the recorded revolution: the energy's window
    assert r.time[0] == 0.0 and r.time[-1] == pytest.approx(0.5)
    assert section["over"] == "revolution"
    assert section["energy"] == pytest.approx(f_c * path, rel=1e-7)
    travel = float(x.max() - x.min())
    assert 2 * f_c * travel <= section["energy"] <= 2 * f_c * travel * (1 + 1e-3)
    assert (section["sticks"], section["slips"]) == (2, 2)  # stuck in each dwell, breaks away each stroke


def test_the_bare_file_is_the_station_without_load_and_friction():
    station = tomllib.loads(STATION.read_text(encoding="utf-8"))
    bare = tomllib.loads(BARE.read_text(encoding="utf-8"))
    expected = copy.deepcopy(station)
    del expected["load"]
    expected["element"] = [e for e in expected["element"] if e["type"] != "friction"]
    for doc in (expected, bare):
        doc.pop("machine")
    assert bare == expected
    assert [e["name"] for e in station["element"] if e["type"] == "friction"] == ["guide"]
    assert [ld["name"] for ld in station["load"]] == ["press"]


def test_the_page_shows_the_file():
    """Each line of the TOML the page quotes is a line of the machine file."""
    text = PAGE.read_text(encoding="utf-8")
    blocks = re.findall(r"```toml\n(.*?)```", text, re.S)
    assert blocks
    lines = {line.strip() for line in STATION.read_text(encoding="utf-8").splitlines()}
    for block in blocks:
        for line in block.splitlines():
            assert line.strip() in lines, line


def test_both_machines_run_at_their_file_settings():
    """The station and its twin run (the files' own settings) and differ where they should."""
    station, bare = simulate(load_machine(STATION)), simulate(load_machine(BARE))
    s, b = station.summary(), bare.summary()
    assert not s["jump"] and not b["jump"]
    assert s["friction"]["guide"]["energy"] > 0 and "friction" not in b and "loads" not in b
    assert s["loads"]["press"]["work"] < 0  # the punch does work on the pin
    assert [e["element"] for e in s["impacts"]] == [e["element"] for e in b["impacts"]] == ["stop", "overtravel"]
    # per revolution the shaft delivers the pin's work and the guide's besides what the dampers
    # take (a small positive rest, of the order of the bare machine's whole work)
    dampers = s["camshaft"]["cycle_work"] - (s["friction"]["guide"]["energy"] - s["loads"]["press"]["work"])
    assert 0.0 < dampers < 2.0 * b["camshaft"]["cycle_work"]

"""Shared fixtures: synthetic camsim result files written with camsim.io.hdf5.

The files follow the result layout of spec §7 (run, compare and sweep kinds) with simple
closed-form signals, so that tests of the readers, plots, export and regression check do
not depend on the simulator. The numbers mean nothing physically; what matters is the
layout, the units attributes and that every value is known to the test.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest

from camsim.io.hdf5 import create_file, write_table, write_time, write_trace


def pytest_collection_modifyitems(config, items):
    """Tests marked ``slow`` run in CI (``CI=true``, as ``.ci/run`` has it) or with
    ``CAMSIM_SLOW=1``; the default ``pytest`` skips them to stay under three minutes.
    Tests marked ``full`` (minutes each: the doc's wave tables, the stiff route against
    DOP853, the extreme-input grid, the memory of a long streamed run) run only with
    ``CAMSIM_FULL=1``, before a release, so that ``.ci/run`` stays under 15 minutes on two
    cores. ``pytest -m slow`` or ``-m full`` selects them explicitly."""
    import os

    selected = config.getoption("-m") or ""
    full = os.environ.get("CAMSIM_FULL") == "1" or "full" in selected
    slow = full or os.environ.get("CI", "").lower() in ("1", "true", "yes") or os.environ.get("CAMSIM_SLOW") == "1" \
        or "slow" in selected
    skip_slow = pytest.mark.skip(reason="slow: runs in CI (CI=true) or with CAMSIM_SLOW=1")
    skip_full = pytest.mark.skip(reason="full: runs with CAMSIM_FULL=1 (before a release; minutes each)")
    for item in items:
        if "full" in item.keywords and not full:
            item.add_marker(skip_full)
        elif "slow" in item.keywords and not slow:
            item.add_marker(skip_slow)


#: Cam speed of the synthetic run [rad/s]: 120 rpm, one cycle in 0.5 s.
OMEGA = 4.0 * np.pi
#: Initial cam angle of the synthetic run [deg] (so that the angle passes 360).
THETA0_DEG = 30.0
#: Cam lift [m].
LIFT = 0.01
#: Mass names of the synthetic machine.
MASSES = ("M1", "M2", "M3")
#: Element names of the synthetic machine.
ELEMENTS = ("K12", "K23", "seat")
#: Segment joins [deg].
BOUNDARIES_DEG = (0.0, 90.0, 180.0, 270.0)

#: The events of the synthetic run: (time [s], element, kind, masses, rel. velocity [m/s]).
EVENTS = (
    (0.10, "seat", "impact", "ground/M3", -0.42),
    (0.12, "seat", "release", "ground/M3", float("nan")),
    (0.25, "cam", "jump", "cam/M1", float("nan")),
    (0.30, "K23", "rejoin", "M2/M3", -0.15),
)


def write_run_layout(group, n: int = 401, scale: float = 1.0, events: bool = True, boundaries: bool = True):
    """Write the run layout of spec §7 into ``group`` (a file root or a subgroup).

    Signals (t in s, ``n`` samples over one cycle, 0 ≤ t ≤ 0.5 s): cam angle
    ``30 + 720 t`` deg, cam displacement ``LIFT (1 - cos θ)/2`` with its derivatives,
    mass ``Mk`` displacement ``scale · k · 1e-3 sin(2π·2t + k)`` and its derivatives,
    element forces ``100 k cos(...)``, cam contact force ``100 cos(4π t) + 20`` N
    (negative over part of the cycle), transducer force ``50 (1 + sin 4π t)`` N.
    """
    t = np.linspace(0.0, 0.5, n)
    time = write_time(group, t)
    theta = np.deg2rad(THETA0_DEG) + OMEGA * t
    write_trace(group, "cam/angle", np.rad2deg(theta), "deg", "cam angle", time)
    w = OMEGA
    cam = {
        "displacement": (LIFT / 2 * (1 - np.cos(theta)), "m"),
        "velocity": (LIFT / 2 * w * np.sin(theta), "m/s"),
        "acceleration": (LIFT / 2 * w**2 * np.cos(theta), "m/s^2"),
        "jerk": (-LIFT / 2 * w**3 * np.sin(theta), "m/s^3"),
    }
    for q, (values, units) in cam.items():
        write_trace(group, f"cam/{q}", values, units, f"cam {q}", time)
    if boundaries:
        write_trace(group, "cam/boundaries_deg", np.array(BOUNDARIES_DEG), "deg", "cam angles of segment joins")
    f2 = 2 * np.pi * 2.0
    for k, name in enumerate(MASSES, start=1):
        a = scale * k * 1e-3
        phase = f2 * t + k
        write_trace(group, f"masses/{name}/displacement", a * np.sin(phase), "m", f"displacement of {name}", time)
        write_trace(group, f"masses/{name}/velocity", a * f2 * np.cos(phase), "m/s", f"velocity of {name}", time)
        write_trace(
            group, f"masses/{name}/acceleration", -a * f2**2 * np.sin(phase), "m/s^2", f"acceleration of {name}", time
        )
    for k, name in enumerate(ELEMENTS, start=1):
        write_trace(group, f"elements/{name}/force", 100.0 * k * np.cos(f2 * t + k), "N", f"force in {name}", time)
    write_trace(group, "cam_contact/force", 100.0 * np.cos(OMEGA * t) + 20.0, "N", "cam contact force", time)
    write_trace(group, "transducer/force", 50.0 * (1.0 + np.sin(OMEGA * t)), "N", "transducer force", time)
    if events:
        rows = list(EVENTS)
        ev_t = np.array([r[0] for r in rows])
        nan = np.full(len(rows), np.nan)
        impact = np.array([r[2] in ("impact", "rejoin") for r in rows])
        write_table(
            group,
            "events",
            {
                "time": (ev_t, "s"),
                "angle_deg": (THETA0_DEG + np.rad2deg(OMEGA) * ev_t, "deg"),
                "element": (np.array([r[1] for r in rows]), ""),
                "kind": (np.array([r[2] for r in rows]), ""),
                "masses": (np.array([r[3] for r in rows]), ""),
                "relative_velocity": (np.array([r[4] for r in rows]), "m/s"),
                "johnson_lower": (np.where(impact, 300.0, nan), "N"),
                "johnson_upper": (np.where(impact, 500.0, nan), "N"),
                "peak_force": (np.where(impact, 410.0, nan), "N"),
                "contact_duration": (np.where(impact, 1.5e-4, nan), "s"),
            },
        )
    return t


def _root_attrs(f, kind: str) -> None:
    f.attrs["camsim_version"] = "0.1.0"
    f.attrs["schema"] = 1
    f.attrs["file_kind"] = kind
    f.attrs["machine_name"] = "synthetic"
    f.attrs["machine_toml"] = "# synthetic test file\n"
    f.attrs["machine_sha256"] = "0" * 64
    f.attrs["units_system"] = "SI"


def write_run_file(path: Path, n: int = 401, events: bool = True, boundaries: bool = True) -> Path:
    """Write a synthetic run file (see :func:`write_run_layout`) and return its path."""
    with create_file(path) as f:
        _root_attrs(f, "run")
        write_run_layout(f, n=n, events=events, boundaries=boundaries)
    return Path(path)


def write_compare_file(path: Path, n: int = 401) -> Path:
    """Write a synthetic comparison file: /impact, /no_impact (masses 10 % smaller), /difference."""
    with create_file(path) as f:
        _root_attrs(f, "compare")
        t = write_run_layout(f.create_group("impact"), n=n)
        write_run_layout(f.create_group("no_impact"), n=n, scale=0.9)
        diff = f.create_group("difference")
        time = write_time(diff, t)
        for name in MASSES:
            for q in ("displacement", "velocity", "acceleration"):
                a = f[f"impact/masses/{name}/{q}"][()]
                b = f[f"no_impact/masses/{name}/{q}"][()]
                d = 100.0 * (a - b) / np.max(np.abs(a))
                write_trace(diff, f"masses/{name}/{q}", d, "%", f"{q} difference of {name}", time)
    return Path(path)


#: Swept cam speeds of the synthetic sweep [rad/s]; the fourth point failed.
SWEEP_SPEEDS = (6.0, 8.0, 10.0, 12.0, 14.0)


def write_sweep_file(path: Path) -> Path:
    """Write a synthetic sweep file: /sweep/summary over :data:`SWEEP_SPEEDS`."""
    s = np.array(SWEEP_SPEEDS)
    ok = np.array([True, True, True, False, True])
    nan = np.where(ok, 1.0, np.nan)
    cols: dict = {"param:cam.speed": (s, "rad/s"), "param:masses.M2.mass": (np.full(s.size, 0.74), "kg")}
    for k, name in enumerate(MASSES, start=1):
        cols[f"peak_displacement:{name}"] = (k * 1e-3 * s / 10 * nan, "m")
        cols[f"peak_velocity:{name}"] = (k * 1e-2 * s * nan, "m/s")
        cols[f"peak_acceleration:{name}"] = (k * s**2 * nan, "m/s^2")
    cols["peak_transducer_force"] = (30.0 * s * nan, "N")
    cols["max_cam_contact_force"] = (40.0 * s * nan, "N")
    cols["min_cam_contact_force"] = ((200.0 - 20.0 * s) * nan, "N")
    cols["jump"] = (200.0 - 20.0 * s < 0, "")
    cols["impacts"] = (np.array([1, 1, 2, 0, 3]), "")
    cols["max_impact_velocity"] = (0.05 * s * nan, "m/s")
    cols["periodicity_residual"] = (np.full(s.size, 1e-9) * nan, "")
    cols["status"] = (np.array(["ok", "ok", "ok", "SimulationError: diverged", "ok"]), "")
    with create_file(path) as f:
        _root_attrs(f, "sweep")
        write_table(f, "sweep/summary", cols)
    return Path(path)


@pytest.fixture
def make_run_file(tmp_path: Path) -> Callable[..., Path]:
    """A factory: ``make_run_file(name="run.h5", **kw)`` writes a synthetic run file in tmp_path."""

    def make(name: str = "run.h5", **kw) -> Path:
        return write_run_file(tmp_path / name, **kw)

    return make


@pytest.fixture
def run_file(tmp_path: Path) -> Path:
    """A synthetic run file ``tmp_path/run.h5`` (401 samples, 4 events)."""
    return write_run_file(tmp_path / "run.h5")


@pytest.fixture
def compare_file(tmp_path: Path) -> Path:
    """A synthetic comparison file ``tmp_path/cmp.h5``."""
    return write_compare_file(tmp_path / "cmp.h5")


@pytest.fixture
def sweep_file(tmp_path: Path) -> Path:
    """A synthetic sweep file ``tmp_path/sweep.h5`` (5 points, one failed)."""
    return write_sweep_file(tmp_path / "sweep.h5")


@pytest.fixture
def not_camsim_h5(tmp_path: Path) -> Path:
    """An HDF5 file without the camsim root attributes."""
    import h5py

    path = tmp_path / "other.h5"
    with h5py.File(path, "w") as f:
        f["time"] = np.arange(3.0)
    return path


@pytest.fixture
def not_hdf5(tmp_path: Path) -> Path:
    """A text file with an .h5 name."""
    path = tmp_path / "text.h5"
    path.write_text("time,x\n0,1\n")
    return path

"""Tests of camsim.analyses.export and ``camsim export``.

Reference: the HDF5 datasets of the synthetic files of conftest.py. A CSV round trip must
reproduce them bit for bit (the CSV holds repr() of each double); units must equal the
datasets' ``units`` attributes.
"""

from __future__ import annotations

import json

import h5py
import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st
from typer.testing import CliRunner

from camsim.cli import app
from camsim.analyses.export import export_csv, read_csv, write_csv

runner = CliRunner()


def _same_bits(a: np.ndarray, b: np.ndarray) -> bool:
    a = np.asarray(a, dtype=np.float64)
    b = np.asarray(b, dtype=np.float64)
    if a.shape != b.shape:
        return False
    nan = np.isnan(a)
    return bool(np.array_equal(nan, np.isnan(b)) and a[~nan].tobytes() == b[~nan].tobytes())


def test_round_trip_all_traces_and_events(run_file, tmp_path):
    result = runner.invoke(app, ["export", str(run_file), "--csv"])
    assert result.exit_code == 0, result.stderr
    csv_path, events_path = tmp_path / "run.csv", tmp_path / "run_events.csv"
    assert result.stdout.splitlines() == [str(csv_path), str(events_path)]
    first = csv_path.read_text().splitlines()[0]
    assert first.startswith("time [s],cam/angle [deg],cam/displacement [m],")
    columns, units = read_csv(csv_path)
    with h5py.File(run_file, "r") as f:
        # 20 traces: time, cam angle + s,v,a,j, 3 masses x 3, 3 elements, cam contact, transducer
        assert len(columns) == 20
        for name, values in columns.items():
            assert _same_bits(values, f[name][()]), name
            assert units[name] == f[name].attrs["units"]
        events = f["events"][()]
    ev, ev_units = read_csv(events_path)
    assert list(ev) == list(events.dtype.names)
    for name in ev:
        if ev_units[name] is None:
            assert list(ev[name]) == [v.decode() for v in events[name]]
        else:
            assert _same_bits(ev[name], events[name]), name
    assert ev_units["relative_velocity"] == "m/s" and ev_units["kind"] is None


def test_columns_pick_and_json(run_file, tmp_path):
    out = tmp_path / "sub.csv"
    result = runner.invoke(
        app, ["export", str(run_file), "-o", str(out), "--columns", "masses/M2/velocity,/cam_contact/force", "--no-events", "--json"]
    )
    assert result.exit_code == 0, result.stderr
    payload = json.loads(result.stdout)
    assert payload["columns"] == ["time", "masses/M2/velocity", "cam_contact/force"]
    assert payload["rows"] == 401 and payload["events_csv"] is None
    columns, _ = read_csv(out)
    assert list(columns) == ["time", "masses/M2/velocity", "cam_contact/force"]
    assert not (tmp_path / "sub_events.csv").exists()


def test_events_csv_option(run_file, tmp_path):
    ev = tmp_path / "ev.csv"
    result = runner.invoke(app, ["export", str(run_file), "-o", str(tmp_path / "t.csv"), "--events-csv", str(ev)])
    assert result.exit_code == 0, result.stderr
    columns, _ = read_csv(ev)
    assert list(columns["kind"]) == ["impact", "release", "jump", "rejoin"]  # conftest.EVENTS


def test_missing_column_is_exit_2_and_writes_nothing(run_file, tmp_path):
    before = sorted(p.name for p in tmp_path.iterdir())
    result = runner.invoke(app, ["export", str(run_file), "--columns", "masses/M9/velocity"])
    assert result.exit_code == 2
    assert result.stderr.count("\n") == 1 and "masses/M9/velocity" in result.stderr
    assert sorted(p.name for p in tmp_path.iterdir()) == before


def test_bad_inputs_are_exit_2(not_camsim_h5, not_hdf5, sweep_file, run_file, tmp_path):
    for args in (
        ["export", str(not_camsim_h5)],
        ["export", str(not_hdf5)],
        ["export", str(tmp_path / "missing.h5")],
        ["export", str(sweep_file)],
        ["export", str(run_file), "-o", str(tmp_path / "no_dir" / "x.csv")],
        ["export", str(run_file), "--group", "impact"],
    ):
        before = sorted(p.name for p in tmp_path.iterdir())
        result = runner.invoke(app, args)
        assert result.exit_code == 2, args
        assert result.stderr.count("\n") == 1, result.stderr
        assert sorted(p.name for p in tmp_path.iterdir()) == before


def test_compare_file_needs_a_group(compare_file, tmp_path):
    result = runner.invoke(app, ["export", str(compare_file)])
    assert result.exit_code == 2 and "--group" in result.stderr
    res = export_csv(compare_file, group="difference")
    assert res.csv == tmp_path / "cmp_difference.csv" and res.events_csv is None
    columns, units = read_csv(res.csv)
    assert units["masses/M2/acceleration"] == "%"
    with h5py.File(compare_file, "r") as f:
        assert _same_bits(columns["masses/M2/acceleration"], f["difference/masses/M2/acceleration"][()])


_floats = st.floats(allow_nan=True, allow_infinity=True, width=64)


@settings(max_examples=60, deadline=None)
@given(values=st.lists(_floats, min_size=0, max_size=20), text=st.lists(st.text(max_size=8), min_size=0, max_size=20))
def test_write_read_csv_is_exact(tmp_path_factory, values, text):
    """Any doubles (subnormals, -0.0, inf, nan) and any text survive a round trip."""
    n = min(len(values), len(text))
    path = tmp_path_factory.mktemp("csv") / "x.csv"
    cols = {"x": np.array(values[:n], dtype=np.float64), "label": np.array(text[:n], dtype=object)}
    write_csv(path, cols, {"x": "m", "label": None})
    back, units = read_csv(path)
    assert units == {"x": "m", "label": None}
    assert _same_bits(back["x"], cols["x"])
    assert list(back["label"]) == [str(t) for t in text[:n]]

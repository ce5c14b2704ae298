"""Tests of camsim.analyses.check and ``camsim check``.

The files are the synthetic ones of conftest.py. The expected outcomes follow from the
tolerance rule of docs/regression.md, |r - g| <= atol + rtol * max|g|, evaluated by hand
for the perturbations below (defaults rtol = 1e-6, atol = 1e-12).
"""

from __future__ import annotations

import io
import json

from pathlib import Path

import h5py
import numpy as np
import pytest
from rich.console import Console
from typer.testing import CliRunner

from camsim.analyses.check import DEFAULT_ATOL, DEFAULT_RTOL, check_files, compare_arrays, render_report
from camsim.cli import app
from camsim.errors import ResultFileError

runner = CliRunner()


def _perturb(path, dataset: str, index: int, delta: float) -> float:
    """Add ``delta`` to one sample; return the sample's time [s]."""
    with h5py.File(path, "r+") as f:
        f[dataset][index] += delta
        return float(f["time"][index])


def _peak(path, dataset: str) -> float:
    with h5py.File(path, "r") as f:
        return float(np.max(np.abs(f[dataset][()])))


def test_identical_files_pass(make_run_file):
    a, b = make_run_file("a.h5"), make_run_file("b.h5")
    report = check_files(a, b)
    assert report.passed
    assert all(d.max_abs == 0 for d in report.diffs)
    # every trace of the run layout, cam/boundaries_deg and the 10 event columns are compared
    paths = {d.path for d in report.diffs}
    assert {"time", "masses/M2/acceleration", "cam/boundaries_deg", "events/kind", "events/peak_force"} <= paths
    result = runner.invoke(app, ["check", str(a), "--against", str(b)])
    assert result.exit_code == 0, result.stderr
    assert "PASS" in result.stderr
    assert result.stdout == ""


def test_one_sample_beyond_tolerance_fails_and_names_the_trace(make_run_file):
    a, b = make_run_file("a.h5"), make_run_file("b.h5")
    peak = _peak(a, "masses/M2/acceleration")
    # 10x the default tolerance at that trace's peak: must fail
    delta = 10 * (DEFAULT_ATOL + DEFAULT_RTOL * peak)
    t = _perturb(a, "masses/M2/acceleration", 123, delta)
    report = check_files(a, b)
    assert not report.passed
    assert [d.path for d in report.failures] == ["masses/M2/acceleration"]
    worst = report.failures[0]
    assert worst.index == 123
    assert worst.where == t
    assert worst.max_abs == pytest.approx(delta, rel=1e-6)  # float round-off of adding delta
    assert worst.max_rel == pytest.approx(delta / peak, rel=1e-6)
    result = runner.invoke(app, ["check", str(a), "--against", str(b)])
    assert result.exit_code == 1
    assert "masses/M2/acceleration" in result.stderr
    assert "FAIL" in result.stderr


def test_perturbation_within_tolerance_passes(make_run_file):
    a, b = make_run_file("a.h5"), make_run_file("b.h5")
    peak = _peak(a, "elements/seat/force")
    _perturb(a, "elements/seat/force", 7, 0.1 * DEFAULT_RTOL * peak)  # a tenth of the tolerance
    report = check_files(a, b)
    assert report.passed
    assert max(d.used for d in report.diffs) == pytest.approx(0.1, rel=1e-3)


def test_rtol_option_changes_the_verdict(make_run_file):
    a, b = make_run_file("a.h5"), make_run_file("b.h5")
    peak = _peak(a, "transducer/force")
    _perturb(a, "transducer/force", 50, 1e-4 * peak)
    assert runner.invoke(app, ["check", str(a), "--against", str(b)]).exit_code == 1
    assert runner.invoke(app, ["check", str(a), "--against", str(b), "--rtol", "1e-3"]).exit_code == 0


def test_json_report(make_run_file):
    a, b = make_run_file("a.h5"), make_run_file("b.h5")
    _perturb(a, "cam_contact/force", 3, 1.0)  # 1 N on a 120 N peak
    result = runner.invoke(app, ["check", str(a), "--against", str(b), "--json"])
    assert result.exit_code == 1
    payload = json.loads(result.stdout)
    assert payload["passed"] is False
    assert payload["failed"] == ["cam_contact/force"]
    entry = next(d for d in payload["datasets"] if d["path"] == "cam_contact/force")
    assert entry["max_abs"] == pytest.approx(1.0, rel=1e-9)
    assert entry["units"] == "N"


def test_mismatched_time_grid_is_exit_2(make_run_file):
    a, b = make_run_file("a.h5", n=401), make_run_file("b.h5", n=300)
    with pytest.raises(ResultFileError, match="different time grids"):
        check_files(a, b)
    result = runner.invoke(app, ["check", str(a), "--against", str(b)])
    assert result.exit_code == 2
    assert result.stderr.count("\n") == 1 and "/time" in result.stderr


def test_shifted_time_grid_is_exit_2(make_run_file):
    a, b = make_run_file("a.h5"), make_run_file("b.h5")
    _perturb(a, "time", 10, 1e-3)  # 1 ms on a 0.5 s grid: far beyond 5e-7 s
    result = runner.invoke(app, ["check", str(a), "--against", str(b)])
    assert result.exit_code == 2
    assert "different time grids" in result.stderr


def test_not_camsim_and_not_hdf5_are_exit_2(run_file, not_camsim_h5, not_hdf5, tmp_path):
    for other, text in ((not_camsim_h5, "not a camsim result file"), (not_hdf5, "not an HDF5 file"), (tmp_path / "none.h5", "no such file")):
        for args in (["check", str(run_file), "--against", str(other)], ["check", str(other), "--against", str(run_file)]):
            result = runner.invoke(app, args)
            assert result.exit_code == 2, args
            assert text in result.stderr
            assert result.stderr.count("\n") == 1
            assert "Traceback" not in result.output


def test_missing_dataset_is_exit_2(make_run_file):
    a, b = make_run_file("a.h5"), make_run_file("b.h5")
    with h5py.File(a, "r+") as f:
        del f["transducer/force"]
    result = runner.invoke(app, ["check", str(a), "--against", str(b)])
    assert result.exit_code == 2
    assert "/transducer/force" in result.stderr


def test_kind_mismatch_is_exit_2(run_file, compare_file):
    result = runner.invoke(app, ["check", str(run_file), "--against", str(compare_file)])
    assert result.exit_code == 2
    assert "file_kind" in result.stderr


def test_events_row_count_and_text(make_run_file):
    a, b = make_run_file("a.h5"), make_run_file("b.h5")
    with h5py.File(a, "r+") as f:
        rows = f["events"][()]
        del f["events"]
        f["events"] = rows[:3]
    report = check_files(a, b)
    assert [d.path for d in report.failures] == ["events"]
    assert "rows: 3, golden 4" in report.failures[0].note

    c = make_run_file("c.h5")
    with h5py.File(c, "r+") as f:
        rows = f["events"][()]
        rows["kind"][2] = b"stick"  # golden row 2 is a "jump" at t = 0.25 s
        del f["events"]
        f["events"] = rows
    report = check_files(c, b)
    assert [d.path for d in report.failures] == ["events/kind"]
    assert report.failures[0].where == 0.25
    result = runner.invoke(app, ["check", str(c), "--against", str(b)])
    assert result.exit_code == 1 and "events/kind" in result.stderr


def test_event_force_beyond_tolerance(make_run_file):
    a, b = make_run_file("a.h5"), make_run_file("b.h5")
    with h5py.File(a, "r+") as f:
        rows = f["events"][()]
        rows["peak_force"][3] = 411.0  # golden 410 N; tolerance 1e-6*410 N
        del f["events"]
        f["events"] = rows
    report = check_files(a, b)
    assert [d.path for d in report.failures] == ["events/peak_force"]
    assert report.failures[0].max_abs == 1.0
    assert report.failures[0].where == 0.30


def test_compare_arrays_rule():
    # hand-evaluated cases of |r - g| <= atol + rtol*max|g|
    g = np.array([0.0, 10.0, -20.0, np.nan])
    ok = compare_arrays("x", g + np.array([1.9e-5, 0, 0, 0]), g, rtol=1e-6, atol=0.0)  # tol 2e-5
    assert ok.passed and ok.index == 0
    bad = compare_arrays("x", g + np.array([2.1e-5, 0, 0, 0]), g, rtol=1e-6, atol=0.0)
    assert not bad.passed
    nan_vs_number = compare_arrays("x", np.array([0.0, 10.0, -20.0, 1.0]), g, rtol=1e-6, atol=0.0)
    assert not nan_vs_number.passed and nan_vs_number.index == 3
    zero = compare_arrays("x", np.zeros(3), np.zeros(3), rtol=0.0, atol=0.0)
    assert zero.passed and zero.max_rel == 0.0


def test_compare_and_sweep_files_check(make_run_file, tmp_path):
    # The writers of tests/conftest.py, by path: `import conftest` would find whichever
    # conftest.py (tests/, tests/fit/, ...) pytest imported first.
    import importlib.util

    spec = importlib.util.spec_from_file_location("camsim_tests_conftest", Path(__file__).parent / "conftest.py")
    conftest = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(conftest)

    a = conftest.write_compare_file(tmp_path / "c1.h5")
    b = conftest.write_compare_file(tmp_path / "c2.h5")
    assert check_files(a, b).passed
    with h5py.File(a, "r+") as f:
        f["difference/masses/M3/velocity"][5] += 1.0  # 1 % on a ~10 % peak
    assert [d.path for d in check_files(a, b).failures] == ["difference/masses/M3/velocity"]
    s1 = conftest.write_sweep_file(tmp_path / "s1.h5")
    s2 = conftest.write_sweep_file(tmp_path / "s2.h5")
    assert check_files(s1, s2).passed


def test_bad_tolerance_is_exit_2(make_run_file):
    a, b = make_run_file("a.h5"), make_run_file("b.h5")
    result = runner.invoke(app, ["check", str(a), "--against", str(b), "--rtol", "-1"])
    assert result.exit_code == 2 and "--rtol" in result.stderr


def test_render_report(make_run_file):
    a, b = make_run_file("a.h5"), make_run_file("b.h5")
    _perturb(a, "masses/M1/velocity", 0, 1.0)
    buf = io.StringIO()
    render_report(check_files(a, b), Console(file=buf, width=120), limit=3)
    text = buf.getvalue()
    assert "masses/M1/velocity" in text and "FAIL" in text
    assert text.count("ok") == 2  # limit=3: the failure and the two next rows

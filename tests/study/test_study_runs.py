"""Running studies: reproducibility, resume, failed runs, files, --json, --config, --plot (issue 15).

The numbers of a run are checked in test_study_closed_form.py; here the properties the
issue asks for: same seed -> the same rows bit for bit with 1 and 2 workers; an
interrupted (Ctrl-C or SIGKILL) study continued with --resume gives the same rows as an
uninterrupted one; a failing run is a row with its reason; the HDF5 table and the CSV
agree exactly; --json has the documented keys.
"""

from __future__ import annotations

import csv
import json
import math
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import h5py
import numpy as np
import pandas as pd
import pytest
from typer.testing import CliRunner

from camsim.cli import app
from camsim.io.hdf5 import read_table
from camsim.analyses.study import StudyInterrupted, study
from camsim.io.rowstore import journal_path_for

HERE = Path(__file__).parent
MACHINE = HERE / "driven_follower.toml"
DISTS = ["element.closure.preload=tol:20:3N", "element.closure.stiffness=normal:2000:100N/m", "mass.F.mass=uniform:0.48:0.52kg"]
runner = CliRunner()


def _same_frames(a: pd.DataFrame, b: pd.DataFrame) -> None:
    assert list(a.columns) == list(b.columns)
    for c in a.columns:
        x, y = a[c].to_numpy(), b[c].to_numpy()
        if x.dtype.kind == "f":
            assert np.array_equal(x.view(np.int64), y.view(np.int64)), c  # bit for bit, NaN included
        else:
            assert list(x) == list(y), c


def test_same_seed_same_rows_with_one_and_two_workers(tmp_path):
    one = study(MACHINE, DISTS, 6, method="lhs", seed=11, workers=1, output=tmp_path / "a.h5")
    two = study(MACHINE, DISTS, 6, method="lhs", seed=11, workers=2, output=tmp_path / "b.h5")
    _same_frames(one.rows, two.rows)
    assert (tmp_path / "a.csv").read_bytes() == (tmp_path / "b.csv").read_bytes()
    other = study(MACHINE, DISTS, 6, method="lhs", seed=12, workers=1)
    assert not np.array_equal(other.rows["param:mass.F.mass"], one.rows["param:mass.F.mass"])
    assert not journal_path_for(tmp_path / "a.h5").exists()  # the journal is gone once the files are written


def test_ctrl_c_then_resume_gives_the_uninterrupted_rows(tmp_path):
    full = study(MACHINE, DISTS, 10, seed=4, workers=1, output=tmp_path / "full.h5")
    out = tmp_path / "cut.h5"

    def stop_after_four(done, total):
        if done == 4:
            raise KeyboardInterrupt

    with pytest.raises(StudyInterrupted) as info:
        study(MACHINE, DISTS, 10, seed=4, workers=1, output=out, progress=stop_after_four)
    assert info.value.done == 4
    with h5py.File(out) as f:  # the file holds the finished rows while the study is unfinished
        assert f.attrs["file_kind"] == "study" and f["study"].attrs["interrupted"]
        assert list(read_table(f["study/rows"])["run"]) == [0, 1, 2, 3]
    seen = []
    resumed = study(MACHINE, DISTS, 10, seed=4, workers=1, output=out, resume=True, on_start=lambda n, todo, ex: seen.append((n, todo)))
    assert seen == [(10, 6)] and resumed.resumed == 4
    _same_frames(full.rows, resumed.rows)
    assert (tmp_path / "full.csv").read_bytes() == (tmp_path / "cut.csv").read_bytes()


def test_resume_refuses_another_study(tmp_path):
    out = tmp_path / "cut.h5"

    def stop(done, total):
        raise KeyboardInterrupt

    with pytest.raises(StudyInterrupted):
        study(MACHINE, DISTS, 6, seed=4, workers=1, output=out, progress=stop)
    r = runner.invoke(app, ["study", str(MACHINE), *sum((["--dist", d] for d in DISTS), []), "-n", "6", "--seed", "5", "-o", str(out), "--resume", "--workers", "1"])
    assert r.exit_code == 2 and "cannot resume" in r.stderr and "seed" in r.stderr
    r = runner.invoke(app, ["study", str(MACHINE), *sum((["--dist", d] for d in DISTS), []), "-n", "6", "--seed", "4", "-o", str(out), "--workers", "1"])
    assert r.exit_code == 2 and "--resume" in r.stderr  # an interrupted study is not overwritten silently
    r = runner.invoke(app, ["study", str(MACHINE), "--dist", DISTS[0], "-n", "6", "-o", str(tmp_path / "none.h5"), "--resume"])
    assert r.exit_code == 2 and "no interrupted study" in r.stderr


@pytest.mark.slow
def test_sigkill_then_resume_gives_the_uninterrupted_rows(tmp_path):
    """SIGKILL a `camsim study` subprocess mid-way, then --resume: the same CSV bytes."""
    args = [sys.executable, "-m", "camsim", "study", str(MACHINE), *sum((["--dist", d] for d in DISTS), []), "-n", "40", "--seed", "9", "--workers", "1"]
    env = dict(os.environ)
    subprocess.run(args + ["-o", str(tmp_path / "full.h5")], check=True, capture_output=True, env=env)
    out = tmp_path / "killed.h5"
    proc = subprocess.Popen(args + ["-o", str(out)], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, env=env)
    rows = journal_path_for(out)
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline:
        if rows.exists() and rows.read_bytes().count(b"\n") >= 12:
            break
        time.sleep(0.01)
    proc.send_signal(signal.SIGKILL)
    proc.wait()
    kept = rows.read_bytes().count(b"\n") - 1
    assert 0 < kept < 40
    with h5py.File(out) as f:  # readable after the kill, with (at least most of) the kept rows
        assert len(f["study/rows"]) <= kept
    done = subprocess.run(args + ["-o", str(out), "--resume"], capture_output=True, text=True, env=env)
    assert done.returncode == 0, done.stderr
    assert "resuming:" in done.stderr
    assert (tmp_path / "full.csv").read_bytes() == (tmp_path / "killed.csv").read_bytes()
    with h5py.File(tmp_path / "full.h5") as a, h5py.File(out) as b:
        ta, tb = read_table(a["study/rows"]), read_table(b["study/rows"])
    _same_frames(pd.DataFrame(ta), pd.DataFrame(tb))


def test_failed_runs_are_rows_with_their_reason(tmp_path):
    # a mass that the normal draws below zero: those runs fail in the loader
    res = study(MACHINE, ["mass.F.mass=normal:0.01:0.02kg"], 16, seed=1, workers=1, limits=["min_cam_contact_force<0N"])
    failed = res.rows[res.rows["status"] != "ok"]
    negative = res.rows["param:mass.F.mass"] <= 0
    assert list(failed.index) == list(res.rows.index[negative]) and len(failed) > 0
    assert all("must be greater than 0" in s for s in failed["status"])
    assert failed["min_cam_contact_force"].isna().all()
    assert res.stats["min_cam_contact_force"]["n"] == 16 - len(failed)
    assert res.limits[0]["n"] == 16 - len(failed)
    assert any("runs failed" in n for n in res.notes)


def test_cli_files_agree_and_json_schema(tmp_path):
    out = tmp_path / "s.h5"
    r = runner.invoke(
        app,
        ["study", str(MACHINE), *sum((["--dist", d] for d in DISTS), []), "-n", "8", "--method", "sobol", "--seed", "2",
         "--sensitivity", "--limit", "min_cam_contact_force<0N", "--limit", "max_cam_contact_force>=60N",
         "--reduce", "rms:cam_contact/force", "--reduce", "max:masses/F/acceleration", "-o", str(out), "--workers", "1", "--json"],
    )
    assert r.exit_code == 0, r.stderr
    payload = json.loads(r.stdout)
    assert set(payload) == {"n_samples", "n_runs", "seed", "method", "output", "csv", "failed", "not_run", "incomplete", "outputs", "limits", "sensitivity", "ranking"}
    assert payload["n_samples"] == 8 and payload["n_runs"] == 8 * 5 and payload["seed"] == 2
    assert payload["csv"] == str(tmp_path / "s.csv")
    q = payload["outputs"]["min_cam_contact_force"]
    assert set(q) == {"n", "mean", "std", "min", "max", "percentiles", "ci95"}
    assert set(q["percentiles"]) == {"1", "5", "50", "95", "99"}
    assert set(q["ci95"]) == {"mean", "std", "p1", "p5", "p50", "p95", "p99"}
    assert [lim["expr"] for lim in payload["limits"]] == ["min_cam_contact_force<0N", "max_cam_contact_force>=60N"]
    assert set(payload["limits"][0]) >= {"expr", "probability", "ci95", "per_million"}
    s = payload["sensitivity"]["min_cam_contact_force"]
    assert set(s) == {d.partition("=")[0] for d in DISTS}
    assert set(s["mass.F.mass"]) == {"first", "total", "first_ci95", "total_ci95"}
    assert payload["sensitivity"]["impacts"] is None  # the same in every run
    assert "rms:cam_contact/force" in payload["outputs"] and "max:masses/F/acceleration" in payload["outputs"]
    with h5py.File(out) as f:
        assert f.attrs["file_kind"] == "study"
        dset = f["study/rows"]
        table = read_table(dset)
        assert dset.attrs["units:param:element.closure.stiffness"] == "N/m"
        assert dset.attrs["units:rms:cam_contact/force"] == "N"
        assert list(dset.attrs["columns"]) == list(table)
        assert json.loads(f["study"].attrs["summary_json"])["n_runs"] == 40
    with open(tmp_path / "s.csv", newline="") as fh:
        lines = list(csv.reader(fh))
    assert lines[0] == list(table) and len(lines) == 41
    assert [line[1] for line in lines[1:]] == ["A"] * 8 + ["B"] * 8 + [f"AB:{d.partition('=')[0]}" for d in DISTS for _ in range(8)]
    for i, line in enumerate(lines[1:]):
        for j, name in enumerate(lines[0]):
            x = table[name][i]
            if isinstance(x, (float, np.floating)):
                assert (math.isnan(x) and line[j] == "nan") or float(line[j]) == x
    # the AB_i block takes column i from B and the rest from A
    p = [f"param:{d.partition('=')[0]}" for d in DISTS]
    for i, col in enumerate(p):
        ab = table[col][(2 + i) * 8:(3 + i) * 8]
        assert np.array_equal(ab, table[col][8:16])
        other = p[(i + 1) % 3]
        assert np.array_equal(table[other][(2 + i) * 8:(3 + i) * 8], table[other][:8])


def test_config_file_equals_the_options(tmp_path):
    cfg = tmp_path / "study.toml"
    cfg.write_text(
        f'[study]\nmachine = "{MACHINE}"\nsamples = 6\nmethod = "lhs"\nseed = 3\nlimit = ["min_cam_contact_force<0N"]\n'
        '[study.dist]\n' + "".join(f'"{d.partition("=")[0]}" = "{d.partition("=")[2]}"\n' for d in DISTS)
    )
    a = runner.invoke(app, ["study", "--config", str(cfg), "-o", str(tmp_path / "a.h5"), "--workers", "1", "--json"])
    b = runner.invoke(app, ["study", str(MACHINE), *sum((["--dist", d] for d in DISTS), []), "-n", "6", "--method", "lhs", "--seed", "3",
                            "--limit", "min_cam_contact_force<0N", "-o", str(tmp_path / "b.h5"), "--workers", "1", "--json"])
    assert a.exit_code == 0 and b.exit_code == 0, a.stderr + b.stderr
    assert (tmp_path / "a.csv").read_bytes() == (tmp_path / "b.csv").read_bytes()
    ja, jb = json.loads(a.stdout), json.loads(b.stdout)
    ja.pop("output"), jb.pop("output"), ja.pop("csv"), jb.pop("csv")
    assert ja == jb
    bad = tmp_path / "bad.toml"
    bad.write_text('[study]\nsampels = 3\n')
    r = runner.invoke(app, ["study", str(MACHINE), "--config", str(bad)])
    assert r.exit_code == 2 and r.stderr.strip() == f"camsim: error: {bad}: study.sampels: unknown key; did you mean samples?"


def test_plot_is_deterministic(tmp_path):
    res = study(MACHINE, DISTS, 4, method="sobol", seed=1, workers=1, sensitivity=True, limits=["min_cam_contact_force<0N"])
    from camsim.figures.study import plotted_outputs, save_study_plot

    shown = plotted_outputs(res)
    assert shown[0] == "min_cam_contact_force"  # limited outputs first
    assert "impacts" not in shown  # the same in every run
    save_study_plot(res, tmp_path / "a.png", dpi=50, outputs=shown[:2])
    save_study_plot(res, tmp_path / "b.png", dpi=50, outputs=shown[:2])
    assert (tmp_path / "a.png").read_bytes() == (tmp_path / "b.png").read_bytes()
    assert (tmp_path / "a.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


@pytest.mark.slow
def test_dask_local_cluster_gives_the_same_rows():
    pytest.importorskip("distributed")
    serial = study(MACHINE, DISTS, 6, seed=21, workers=1)
    dask = study(MACHINE, DISTS, 6, seed=21, dask_local=2)
    assert dask.executor.startswith("Dask LocalCluster")
    _same_frames(serial.rows, dask.rows)


def test_a_failed_worker_is_not_stored_so_resume_runs_it_again():
    """A run lost with its worker process (the executors' marked row) is not a stored row."""
    from camsim.analyses.study.runner import _run_missing
    from camsim.analyses.study.store import MemoryRowStore
    from camsim.analyses.executors import EXECUTOR_ERROR as _EXECUTOR_ERROR

    class Executor:
        name = "fake"

        def run(self, tasks, fn, failed=None):
            yield 0, ({"status": "BrokenProcessPool: a worker died", _EXECUTOR_ERROR: True}, None)
            yield 1, ({"min_cam_contact_force": 1.0, "status": "ok"}, None)

        def abort(self):
            pass

        def close(self):
            pass

    store = MemoryRowStore.create(None, [("run", ""), ("min_cam_contact_force", "N"), ("status", "")], {})
    interrupted, lost = _run_missing(Executor(), [(), ()], [5, 6], store, lambda i, row: {"run": i, **row}, 7, None, None, "fake")
    assert (interrupted, lost) == (False, 1)
    assert store.done() == {6}

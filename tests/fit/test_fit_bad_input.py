"""Bad input to ``camsim fit``: exit 2, one line on stderr naming file and column or key,
no traceback, nothing written. A fit that does not converge: exit 1, nothing written.
"""

from __future__ import annotations

import numpy as np
import pytest
from typer.testing import CliRunner

from camsim.cli import app

runner = CliRunner()
PARAM = ["--param", "element.K.stiffness=1000:10000"]


def _csv(tmp_path, text: str):
    path = tmp_path / "m.csv"
    path.write_text(text)
    return path


def _good_rows(n=20, step=0.001):
    t = np.arange(n) * step
    return "".join(f"{float(ti)!r},{float(100 + 50 * np.sin(20 * ti))!r}\n" for ti in t)


def _run(tmp_path, machine, csv, *extra):
    out = tmp_path / "fitted.toml"
    res = runner.invoke(app, ["fit", str(machine), *([str(csv)] if csv else []), *extra, "-o", str(out)])
    lines = res.stderr.strip().splitlines()
    return res, lines, out


def _assert_bad(res, lines, out, *words):
    assert res.exit_code == 2, res.stderr
    assert len(lines) == 1 and "Traceback" not in res.stderr, res.stderr
    for w in words:
        assert w in lines[0], lines[0]
    assert not out.exists() and res.stdout == ""


@pytest.mark.parametrize(
    ("header", "words"),
    [
        ("time [s],transducer/force [N]", ["m.csv", "column 2 'transducer/force [N]'", "unknown result path"]),
        ("time [s],masses/M9/acceleration [m/s^2]", ["column 2", "unknown result path 'masses/M9/acceleration'"]),
        ("time [s],cam_contact/force [m/s]", ["column 2 'cam_contact/force [m/s]'", "cannot be converted to N"]),
        ("time [s],cam_contact/force [blorps]", ["column 2", "'blorps' is not a unit"]),
        ("time [N],cam_contact/force [N]", ["column 1 'time [N]'", "cannot be converted to s"]),
        ("t [s],cam_contact/force [N]", ["column 1 't [s]'", "first column must be time"]),
        ("time [s],cam_contact/force", ["column 2 'cam_contact/force'", "expected 'NAME [UNIT]'"]),
    ],
)
def test_bad_headers(driven, tmp_path, header, words):
    csv = _csv(tmp_path, header + "\n" + _good_rows())
    _assert_bad(*_run(tmp_path, driven, csv, *PARAM), *words)


def test_times_not_increasing_and_duplicate(driven, tmp_path):
    csv = _csv(tmp_path, "time [ms],cam_contact/force [N]\n0,1\n2,2\n1,3\n5,4\n")
    _assert_bad(*_run(tmp_path, driven, csv, *PARAM), "m.csv", "column 1 'time [ms]'", "time goes backwards at line 4")
    csv = _csv(tmp_path, "time [ms],cam_contact/force [N]\n0,1\n2,2\n2,3\n5,4\n")
    _assert_bad(*_run(tmp_path, driven, csv, *PARAM), "column 1 'time [ms]'", "duplicate time at line 4")


def test_nan_cells_error_unless_drop_nan(driven, tmp_path):
    rows = _good_rows(40).splitlines()
    rows[5] = rows[5].split(",")[0] + ",nan"
    rows[9] = rows[9].split(",")[0] + ","
    csv = _csv(tmp_path, "time [s],cam_contact/force [N]\n" + "\n".join(rows) + "\n")
    _assert_bad(*_run(tmp_path, driven, csv, *PARAM), "m.csv", "line 7, column 2 'cam_contact/force [N]'", "--drop-nan")
    res, lines, out = _run(tmp_path, driven, csv, *PARAM, "--drop-nan")
    assert res.exit_code in (0, 1) and "Traceback" not in res.stderr  # the data are made up: only the reading is tested


def test_text_cell(driven, tmp_path):
    csv = _csv(tmp_path, "time [s],cam_contact/force [N]\n0,1\n0.001,abc\n0.002,3\n")
    _assert_bad(*_run(tmp_path, driven, csv, *PARAM), "line 3, column 2", "'abc' is not a number")


@pytest.mark.parametrize(
    ("param", "words"),
    [
        ("element.K9.stiffness=1:2", ["--param element.K9.stiffness=1:2", "no element named 'K9'"]),
        ("element.K.stifness=1:2", ["element.K.stifness", "unknown key"]),
        ("element.K.stiffness=9000:1000", ["empty bounds"]),
        ("element.K.stiffness=6000:10000", ["exclude the machine file's value of element.K.stiffness (5000 N/m)"]),
        ("element.K.stiffness=1000:10000:20000", ["exclude START (20000 N/m)"]),
        ("element.K.stiffness=1:2:3:4", ["expected LOW:HIGH[UNIT]"]),
        ("element.K.stiffness=1:2kg", ["element.K.stiffness", "expected [force]/[length]"]),
        ("simulation.cycles=1:3", ["simulation.cycles", "integer setting"]),
        ("element.K.stiffness", ["expected KEY=LOW:HIGH"]),
    ],
)
def test_bad_params(driven, tmp_path, param, words):
    csv = _csv(tmp_path, "time [s],cam_contact/force [N]\n" + _good_rows())
    _assert_bad(*_run(tmp_path, driven, csv, "--param", param), *words)


def test_bad_options(driven, tmp_path):
    csv = _csv(tmp_path, "time [s],cam_contact/force [N]\n" + _good_rows())
    _assert_bad(*_run(tmp_path, driven, csv, *PARAM, "--log", "element.K.preload"), "--log element.K.preload", "not one of the --param keys")
    _assert_bad(*_run(tmp_path, driven, csv, *PARAM, "--target", "peak_force=3N"), "--target peak_force=3N", "unknown scalar")
    _assert_bad(*_run(tmp_path, driven, csv, *PARAM, "--target", "max_cam_contact_force=3m"), "cannot be converted to N")
    _assert_bad(*_run(tmp_path, driven, csv, *PARAM, "--sigma", "transducer/force=1N"), "--sigma transducer/force=1N", "neither a measured column")
    _assert_bad(*_run(tmp_path, driven, csv, *PARAM, "--sigma", "cam_contact/force=-1N"), "must be positive")
    _assert_bad(*_run(tmp_path, driven, csv, *PARAM, "--window", "0.3:0.1"), "--window 0.3:0.1", "STOP must be after START")
    _assert_bad(*_run(tmp_path, driven, csv, *PARAM, "--max-shift", "1ms"), "--max-shift", "only with --align offset")
    _assert_bad(*_run(tmp_path, driven, csv, *PARAM, "--align", "phase"), "--align phase")
    _assert_bad(*_run(tmp_path, driven, None, *PARAM), "nothing to fit to")
    _assert_bad(*_run(tmp_path, driven, tmp_path / "none.csv", *PARAM), "none.csv", "no such measured-data file")
    _assert_bad(*_run(tmp_path, driven, csv, *PARAM, "--report", str(tmp_path / "r.gif")), "--report", "unknown output format")


def test_measured_times_outside_the_simulated_window(driven, tmp_path):
    # one recorded revolution lasts 0.5 s; data up to 0.6 s
    csv = _csv(tmp_path, "time [s],cam_contact/force [N]\n" + _good_rows(7, 0.1))
    _assert_bad(*_run(tmp_path, driven, csv, *PARAM), "m.csv", "time [s]", "outside the simulated window 0 to 0.5 s")
    csv = _csv(tmp_path, "time [s],cam_contact/force [N]\n-0.01,1\n0,2\n0.01,3\n")
    _assert_bad(*_run(tmp_path, driven, csv, *PARAM), "outside the simulated window")


def test_not_converged_exits_1_and_writes_nothing(driven, tmp_path):
    t = np.arange(0, 501) / 1000.0
    s = 0.005 * (1 - np.cos(4 * np.pi * t))
    y = 2.0 * 0.005 * (4 * np.pi) ** 2 * np.cos(4 * np.pi * t) + 40 + 7000 * s
    csv = _csv(tmp_path, "time [s],cam_contact/force [N]\n" + "".join(f"{float(a)!r},{float(b)!r}\n" for a, b in zip(t, y)))
    report = tmp_path / "r.png"
    res, lines, out = _run(tmp_path, driven, csv, *PARAM, "--max-evaluations", "1", "--report", str(report), "--json")
    assert res.exit_code == 1, res.stderr
    assert '"converged": false' in res.stdout
    assert "did not converge" in lines[-1] and "Traceback" not in res.stderr
    assert not out.exists() and not report.exists()

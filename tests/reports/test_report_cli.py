"""``camsim report`` on bad input: exit 2, one line naming the file, nothing written.

No browser is needed: these fail before any page is built.
"""

from __future__ import annotations

from pathlib import Path

import h5py
import pytest
from typer.testing import CliRunner

from camsim.cli import app

ROOT = Path(__file__).resolve().parents[2]

pytest.importorskip("bokeh", reason="bokeh not installed (pip install 'camsim[report]')")


def _invoke(*args):
    return CliRunner().invoke(app, ["report", *map(str, args)])


def _camsim_file(path, kind):
    """A file with the root attributes of a camsim result (spec §7) and the given kind."""
    with h5py.File(path, "w") as f:
        f.attrs["camsim_version"] = "0.1.0"
        f.attrs["schema"] = 1
        f.attrs["file_kind"] = kind
    return path


def _one_error_line(result, *needles):
    lines = [ln for ln in result.output.splitlines() if ln.strip()]
    assert len(lines) == 1, result.output
    assert lines[0].startswith("camsim: error: ")
    for n in needles:
        assert n in lines[0]
    assert "Traceback" not in result.output


def test_not_a_camsim_result(tmp_path):
    """A text file and an HDF5 file without camsim attributes are refused."""
    text = tmp_path / "notes.h5"
    text.write_text("not hdf5")
    plain = tmp_path / "plain.h5"
    with h5py.File(plain, "w") as f:
        f["x"] = [1.0]
    for bad in (text, plain):
        out = tmp_path / "page.html"
        r = _invoke(bad, "-o", out)
        assert r.exit_code == 2
        _one_error_line(r, str(bad))
        assert not out.exists()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["notes.h5", "plain.h5"]


def test_kind_without_a_page(tmp_path):
    """A result kind the page builder has no section builder for is named in the error."""
    from pathlib import Path

    machine = Path(__file__).resolve().parents[2] / "machines" / "cdtm.toml"
    bad = tmp_path / "cam.h5"  # `camsim cam -o` writes one; no page for it
    assert CliRunner().invoke(app, ["cam", str(machine), "--points", "20", "-o", str(bad)]).exit_code == 0
    out = tmp_path / "page.html"
    r = _invoke(bad, "-o", out)
    assert r.exit_code == 2
    _one_error_line(r, "cam.h5", "no report page for a 'cam' result")
    assert not out.exists()


def test_unwritable_output(tmp_path, cdtm_run):
    """A missing output directory, an output that is a directory, the input itself."""
    h5, _ = cdtm_run
    for out in (tmp_path / "missing" / "page.html", tmp_path):
        r = _invoke(h5, "-o", out)
        assert r.exit_code == 2
        _one_error_line(r, str(out))
    before = h5.read_bytes()
    r = _invoke(h5, "-o", h5)  # issue 35: the suffix says HTML first (the input rule stands behind it)
    assert r.exit_code == 2
    _one_error_line(r, "unknown output format '.h5'")
    assert h5.read_bytes() == before
    assert list(tmp_path.iterdir()) == []


def test_pdf_without_browser_says_how(tmp_path, cdtm_run, monkeypatch):
    """--pdf with no Chromium: exit 2, one line saying how to get one, no page written."""
    h5, _ = cdtm_run
    monkeypatch.setenv("PATH", str(tmp_path))  # no chromium on this PATH
    monkeypatch.delenv("CAMSIM_CHROMIUM", raising=False)
    r = _invoke(h5, "-o", tmp_path / "page.html", "--pdf", tmp_path / "page.pdf")
    assert r.exit_code == 2
    _one_error_line(r, "Chromium", "apt-get install chromium")
    assert list(tmp_path.iterdir()) == []


def test_run_report_option_refuses_before_running(tmp_path):
    """``run --report`` into a missing directory fails before the simulation: no .h5 either."""
    from conftest import CDTM

    h5 = tmp_path / "r.h5"
    r = CliRunner().invoke(app, ["run", str(CDTM), "-o", str(h5), "--report", str(tmp_path / "no" / "r.html"), "-q"])
    assert r.exit_code == 2
    assert not h5.exists()


def test_report_without_bokeh_is_the_install_hint(tmp_path, monkeypatch):
    """Issue 44: `camsim report` without the report extra said "internal error (ModuleNotFoundError:
    bokeh); this is a bug", exit 1; docs/report.md promises exit 2 and the install hint, nothing written."""
    import sys

    from typer.testing import CliRunner

    from camsim.cli import app

    h5 = tmp_path / "r.h5"
    r = CliRunner().invoke(app, ["run", str(ROOT / "machines" / "ball-drop.toml"), "-o", str(h5), "-q"])
    assert r.exit_code == 0, r.output
    monkeypatch.setitem(sys.modules, "bokeh", None)  # as if it were not installed
    for name in [m for m in sys.modules if m.startswith("bokeh.")]:
        monkeypatch.setitem(sys.modules, name, None)
    r = CliRunner().invoke(app, ["report", str(h5), "-o", str(tmp_path / "r.html")])
    assert r.exit_code == 2, r.output
    assert "pip install 'camsim[report]'" in r.output and "internal error" not in r.output
    assert not (tmp_path / "r.html").exists()

"""Tests of camsim.figures.plots and ``camsim plot``.

Expected counts come from the synthetic files of conftest.py: masses M1, M2, M3; elements
K12, K23, seat; segment joins at 0, 90, 180, 270 deg with the cam angle running from 30
to 390 deg (so joins at 90, 180, 270, 360 deg are drawn); impacts: seat on ground/M3 at
t = 0.10 s and the K23 rejoin of M2/M3 at t = 0.30 s (the jump at 0.25 s is no impact).

The figures are checked by what was drawn (artists, their data against the file's arrays
and conftest's closed forms, axis labels with units, legends, marked impacts), never by
comparing rendered pixels with a baseline image: a renderer's pixels change between
matplotlib releases and say nothing about whether the right data was plotted.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from matplotlib.collections import LineCollection, PathCollection, PolyCollection
from typer.testing import CliRunner

from camsim.cli import app
from camsim.errors import InputError, ResultFileError
from camsim.io.results import open_h5
from camsim.figures.plots import make_plots, plot_compare, plot_force, plot_mass, plot_svaj, plot_sweep_mass, save_figures

runner = CliRunner()
PNG_MAGIC = b"\x89PNG\r\n\x1a\n"


def _ylabels(fig):
    return [ax.get_ylabel() for ax in fig.axes]


def test_svaj_figure(run_file):
    with open_h5(run_file) as f:
        fig = plot_svaj(f)
    assert len(fig.axes) == 4
    assert _ylabels(fig) == ["displacement [m]", "velocity [m/s]", "acceleration [m/s²]", "jerk [m/s³]"]
    assert fig.axes[-1].get_xlabel() == "cam angle [deg]"
    for ax in fig.axes:
        assert len(ax.get_lines()) == 1
        joins = [c for c in ax.collections if isinstance(c, LineCollection)]
        assert len(joins) == 1
        xs = sorted(seg[0][0] for seg in joins[0].get_segments())
        assert xs == [90.0, 180.0, 270.0, 360.0]


def test_svaj_angle_window(run_file):
    with open_h5(run_file) as f:
        fig = plot_svaj(f, angle_window=(90.0, 180.0))
    x = fig.axes[0].get_lines()[0].get_xdata()
    assert x.min() >= 90.0 and x.max() <= 180.0 and x.size > 10
    joins = fig.axes[0].collections[0].get_segments()
    assert sorted(seg[0][0] for seg in joins) == [90.0, 180.0]


def test_mass_figure_marks_impacts(run_file):
    with open_h5(run_file) as f:
        fig = plot_mass(f, "M3", "acceleration")
        data = f["masses/M3/acceleration"][()]
    (ax,) = fig.axes
    assert ax.get_xlabel() == "time [s]" and ax.get_ylabel() == "acceleration [m/s²]"
    assert len(ax.get_lines()) == 1
    assert np.array_equal(ax.get_lines()[0].get_ydata(), data)
    marks = [c for c in ax.collections if isinstance(c, PathCollection)]
    assert len(marks) == 1
    assert sorted(marks[0].get_offsets()[:, 0]) == [0.10, 0.30]
    labels = " ".join(t.get_text() for t in ax.texts)
    assert "seat" in labels and "K23" in labels and "0.42 m/s" in labels


def test_mass_without_impacts_has_no_marks(run_file):
    with open_h5(run_file) as f:
        fig = plot_mass(f, "M1", "velocity")
    assert len(fig.axes[0].collections) == 0 and len(fig.axes[0].texts) == 0


def test_time_window_keeps_impacts_inside(run_file):
    with open_h5(run_file) as f:
        fig = plot_mass(f, "M3", "displacement", time_window=(0.2, None))
    ax = fig.axes[0]
    t = ax.get_lines()[0].get_xdata()
    assert t.min() >= 0.2 and t.max() == 0.5
    assert list(ax.collections[0].get_offsets()[:, 0]) == [0.30]


def test_cam_contact_force_shades_jump(run_file):
    with open_h5(run_file) as f:
        contact = plot_force(f, "cam_contact/force")
        transducer = plot_force(f, "transducer/force")
        seat = plot_force(f, "elements/seat/force")
    assert contact.axes[0].get_ylabel() == "force [N]"
    assert len([c for c in contact.axes[0].collections if isinstance(c, PolyCollection)]) == 1
    assert not any(isinstance(c, PolyCollection) for c in transducer.axes[0].collections)
    # the seat's impact (t = 0.10 s) is marked on its force
    assert list(seat.axes[0].collections[0].get_offsets()[:, 0]) == [0.10]


def test_compare_figure(compare_file):
    with open_h5(compare_file) as f:
        fig = plot_compare(f, "M2", "velocity")
        diff = f["difference/masses/M2/velocity"][()]
    top, bottom = fig.axes
    assert len(top.get_lines()) == 2 and len(bottom.get_lines()) == 1
    assert top.get_ylabel() == "velocity [m/s]"
    assert bottom.get_ylabel() == "difference [%]" and bottom.get_xlabel() == "time [s]"
    assert np.array_equal(bottom.get_lines()[0].get_ydata(), diff)


def test_sweep_figure_skips_failed_points(sweep_file):
    with open_h5(sweep_file) as f:
        fig = plot_sweep_mass(f, "M2")
    assert len(fig.axes) == 3
    # speeds are stored in rad/s and shown in rpm (× 60/2π)
    assert fig.axes[-1].get_xlabel() == "cam.speed [rpm]"
    rpm = 60.0 / (2.0 * np.pi)
    for ax in fig.axes:
        (line,) = ax.get_lines()
        assert np.allclose(line.get_xdata(), np.array([6.0, 8.0, 10.0, 14.0]) * rpm, rtol=1e-15)  # 12 rad/s failed
    # peak_acceleration:M2 = 2 * s^2 in conftest
    assert list(fig.axes[2].get_lines()[0].get_ydata()) == [72.0, 128.0, 200.0, 392.0]
    assert fig.axes[2].get_ylabel() == "peak acceleration M2 [m/s²]"


def test_make_plots_names(run_file, compare_file, sweep_file):
    names = list(make_plots(run_file))
    assert len(names) == 1 + 3 * 3 + 3 + 2
    assert names[0] == "run_cam_svaj"
    assert "run_masses_M2_acceleration" in names
    assert {"run_elements_seat_force", "run_cam_contact_force", "run_transducer_force"} <= set(names)
    assert list(make_plots(compare_file, masses=["M2"], quantities=["acceleration"])) == ["cmp_compare_M2_acceleration"]
    assert list(make_plots(sweep_file)) == [
        "sweep_sweep_M1",
        "sweep_sweep_M2",
        "sweep_sweep_M3",
        "sweep_sweep_forces",
        "sweep_sweep_impacts",
    ]


@pytest.mark.parametrize(
    ("kwargs", "error"),
    [
        ({"what": ["compare"]}, ResultFileError),
        ({"what": ["nonsense"]}, InputError),
        ({"masses": ["M9"]}, InputError),
        ({"quantities": ["jerk"]}, InputError),
        ({"time_window": (1.0, 2.0)}, InputError),
        ({"time_window": (0.0, 0.1), "angle_window": (0.0, 10.0)}, InputError),
    ],
)
def test_make_plots_rejects(run_file, kwargs, error):
    with pytest.raises(error):
        make_plots(run_file, **kwargs)


def test_cli_writes_images(run_file, tmp_path):
    result = runner.invoke(app, ["plot", str(run_file), "--what", "masses", "--mass", "M2", "--quantity", "acceleration"])
    assert result.exit_code == 0, result.stderr
    path = tmp_path / "run_plots" / "run_masses_M2_acceleration.png"
    assert result.stdout.splitlines() == [str(path)]
    data = path.read_bytes()
    assert data.startswith(PNG_MAGIC) and len(data) > 10_000
    assert not list(path.parent.glob(".*.tmp"))


@pytest.mark.parametrize(("fmt", "magic"), [("svg", b"<?xml"), ("pdf", b"%PDF")])
def test_cli_formats_and_json(compare_file, tmp_path, fmt, magic):
    out = tmp_path / "figs"
    result = runner.invoke(
        app, ["plot", str(compare_file), "--mass", "M1", "--quantity", "velocity", "--format", fmt, "-o", str(out), "--json"]
    )
    assert result.exit_code == 0, result.stderr
    paths = json.loads(result.stdout)
    assert paths == [str(out / f"cmp_compare_M1_velocity.{fmt}")]
    assert Path(paths[0]).read_bytes().startswith(magic)


@pytest.mark.parametrize(
    "args",
    [
        ["--what", "compare"],
        ["--what", "sweep"],
        ["--mass", "M9"],
        ["--quantity", "jerk"],
        ["--time", "0.1-0.3"],
        ["--time", "0.3:0.1"],
        ["--format", "bmp"],
        ["--dpi", "0"],
        ["--dpi", "1"],  # positive, but its fonts are under a pixel: FreeType refused them (fuzz, CI)
        ["--dpi", "1e5"],
    ],
)
def test_cli_bad_requests_exit_2_and_write_nothing(run_file, tmp_path, args):
    before = sorted(p.name for p in tmp_path.iterdir())
    result = runner.invoke(app, ["plot", str(run_file), *args])
    assert result.exit_code == 2, args
    assert result.stderr.count("\n") == 1 and result.stderr.startswith("camsim: error:")
    assert result.stdout == ""
    assert sorted(p.name for p in tmp_path.iterdir()) == before


def test_cli_unwritable_output_and_bad_files(run_file, not_camsim_h5, not_hdf5, tmp_path):
    blocker = tmp_path / "a_file"
    blocker.write_text("x")
    for args in (
        ["plot", str(run_file), "--what", "svaj", "-o", str(blocker)],
        ["plot", str(run_file), "--what", "svaj", "-o", str(blocker / "sub")],
        ["plot", str(not_camsim_h5)],
        ["plot", str(not_hdf5)],
    ):
        result = runner.invoke(app, args)
        assert result.exit_code == 2, args
        assert result.stderr.count("\n") == 1
    assert not (tmp_path / "run_plots").exists()


def test_save_is_deterministic(run_file, tmp_path):
    """The same file plotted twice gives the same bytes (no dates, fixed SVG ids)."""
    with open_h5(run_file) as f:
        fig1, fig2 = plot_svaj(f), plot_svaj(f)
    (a,) = save_figures({"x": fig1}, tmp_path / "a", "svg")
    (b,) = save_figures({"x": fig2}, tmp_path / "b", "svg")
    assert a.read_bytes() == b.read_bytes()


def test_mass_figure_draws_the_file(run_file):
    """What the mass figure draws, checked against the file and conftest's closed forms.

    Reference: conftest's M3 displacement ``3e-3 sin(2π·2t + 3)`` m on 0 ≤ t ≤ 0.5 s and
    its event table (seat impact at 0.10 s, |Δv| 0.42 m/s; K23 rejoin at 0.30 s,
    0.15 m/s). Tolerance: the line's data equal to the file's arrays exactly (plotted as
    read); the impact marks on the curve at the closed-form value to 1e-12 m (both impact
    times are sample times of the 401-point grid, so no interpolation error)."""
    with open_h5(run_file) as f:
        fig = plot_mass(f, "M3", "displacement")
        t = f["time"][()]
        x = f["masses/M3/displacement"][()]
    (ax,) = fig.axes
    assert ax.get_xlabel() == "time [s]" and ax.get_ylabel() == "displacement [m]"
    assert ax.get_title() == "displacement of M3"
    (line,) = ax.get_lines()
    assert line.get_label() == "displacement of M3"
    assert np.array_equal(line.get_xdata(), t) and np.array_equal(line.get_ydata(), x)
    assert np.allclose(x, 3e-3 * np.sin(2 * np.pi * 2.0 * t + 3), rtol=0, atol=1e-15)
    # the axes show the whole trace
    lo, hi = ax.get_xlim()
    assert lo <= 0.0 and hi >= 0.5
    lo, hi = ax.get_ylim()
    assert lo <= x.min() and hi >= x.max()
    (marks,) = [c for c in ax.collections if isinstance(c, PathCollection)]
    assert marks.get_label() == "impact"
    offsets = np.asarray(marks.get_offsets())
    assert np.array_equal(offsets[:, 0], [0.10, 0.30])
    assert np.allclose(offsets[:, 1], 3e-3 * np.sin(2 * np.pi * 2.0 * offsets[:, 0] + 3), rtol=0, atol=1e-12)
    notes = {t.get_text(): t.xy for t in ax.texts}
    assert set(notes) == {"seat\n0.42 m/s", "K23\n0.15 m/s"}
    assert np.allclose([notes["seat\n0.42 m/s"], notes["K23\n0.15 m/s"]], offsets, rtol=0, atol=0)


def test_legends_name_what_is_drawn(run_file, compare_file):
    """Legends: the shaded jump of the cam contact force and the compare overlay.

    Reference: conftest's cam contact force ``100 cos(4π t) + 20`` N, negative where
    cos(4π t) < −0.2; the shaded region covers exactly those samples (exact)."""
    with open_h5(run_file) as f:
        contact = plot_force(f, "cam_contact/force")
        t = f["time"][()]
    ax = contact.axes[0]
    assert [x.get_text() for x in ax.get_legend().get_texts()] == ["cam contact force", "jump (force < 0)"]
    (shade,) = [c for c in ax.collections if isinstance(c, PolyCollection)]
    negative = t[100.0 * np.cos(4 * np.pi * t) + 20.0 < 0]
    xs = np.concatenate([p.vertices[:, 0] for p in shade.get_paths()])
    assert xs.min() == pytest.approx(negative.min(), abs=0) and xs.max() == pytest.approx(negative.max(), abs=0)
    with open_h5(compare_file) as f:
        top = plot_compare(f, "M2", "velocity").axes[0]
    assert [x.get_text() for x in top.get_legend().get_texts()] == ["with impact", "without impact"]

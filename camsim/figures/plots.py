"""Figures from camsim result files: cam SVAJ, mass motions, forces, comparisons, sweeps.

Every ``plot_*`` function returns a :class:`matplotlib.figure.Figure` and draws nothing
on a screen: figures are built with the object-oriented API (``Figure()``, never
``pyplot``), so no display and no GUI backend is involved and a user's own pyplot backend
is left alone. :func:`make_plots` builds every figure a file calls for, keyed by a stable
name, and :func:`save_figures` writes them (each to a temporary name, then renamed).

Figure names are ``<stem>_<what>``, where ``<stem>`` is the input file's stem and
``<what>`` mirrors the HDF5 path, e.g. ``cdtm_masses_M2_acceleration``,
``cdtm_elements_seat_force``, ``cdtm_cam_svaj``, ``cdtm_compare_M2_acceleration``,
``sweep_sweep_M2``.

Values are plotted in display units (:mod:`camsim.display`): by default the units of the
result's machine file, recorded in the file (``display_units``); every axis label carries them.
"""

from __future__ import annotations

import os
import re
from collections.abc import Iterable, Sequence
from pathlib import Path
from typing import TYPE_CHECKING

import h5py
import matplotlib
import numpy as np
from matplotlib.figure import Figure

from camsim.errors import InputError, ResultFileError
from camsim.figures.style import shown
from camsim.figures.style import _METADATA, _STYLE, _WIDTH, _in, _sample_mask, _window_text, axis_label, displayed, pretty_units  # noqa: F401 - shared with the other figure modules
from camsim.figures.sweep import plot_sweep_columns, plot_sweep_mass, sweep_masses  # noqa: F401 - part of this module's API
from camsim.io.results import (
    file_kind,
    long_name_of,
    names_with,
    open_h5,
    read_events,
    require,
    units_of,
)

if TYPE_CHECKING:
    from camsim.display import DisplayUnits

#: Plot families, in the order :func:`make_plots` builds them.
PLOT_KINDS = ("svaj", "masses", "forces", "compare", "sweep", "design", "camshaft")  # design: issue 14; camshaft: 38
#: Mass quantities that can be chosen with ``quantities``.
QUANTITIES = ("displacement", "velocity", "acceleration")
#: Output formats of :func:`save_figures`.
FORMATS = ("png", "svg", "pdf")
#: Event kinds marked as impacts on the traces.
IMPACT_KINDS = ("impact", "rejoin")
#: At most this many impacts are labelled with text on one axes (all are marked).
MAX_LABELS = 12

#: Which plot families each file kind offers, and which it draws by default.
_OFFERS = {
    "run": ("svaj", "masses", "forces", "design", "camshaft"),
    "cam": ("svaj", "design"),
    "compare": ("compare",),
    "sweep": ("sweep",),
}



# --------------------------------------------------------------------------------------
# Windows and small helpers


def parse_window(text: str | None, what: str = "window") -> tuple[float | None, float | None] | None:
    """Parse ``"a:b"`` (either end may be empty) into ``(a, b)``; ``None`` stays ``None``.

    Raises
    ------
    InputError
        For anything else, or ``a >= b``.
    """
    if text is None:
        return None
    parts = text.split(":")
    if len(parts) != 2:
        raise InputError(f"{what}: expected START:END (e.g. 0.1:0.3), got {text!r}")
    bounds: list[float | None] = []
    for part in parts:
        part = part.strip()
        if not part:
            bounds.append(None)
            continue
        try:
            value = float(part)
        except ValueError:
            raise InputError(f"{what}: {part!r} is not a number (expected START:END)") from None
        if not np.isfinite(value):
            raise InputError(f"{what}: {part!r} is not a finite number")
        bounds.append(value)
    lo, hi = bounds
    if lo is not None and hi is not None and lo >= hi:
        raise InputError(f"{what}: start {lo:g} is not before end {hi:g}")
    return lo, hi


def _safe(text: str) -> str:
    return re.sub(r"[^A-Za-z0-9._-]+", "_", text).strip("_") or "x"


def _new_figure(height: float, nrows: int = 1, sharex: bool = True) -> tuple[Figure, list]:
    fig = Figure(figsize=(_WIDTH, height), layout="constrained")
    axes = fig.subplots(nrows, 1, sharex=sharex, squeeze=False)[:, 0]
    return fig, list(axes)


def _impact_rows(events: dict[str, np.ndarray] | None, *, mass: str | None = None, element: str | None = None):
    """Indices of impact/rejoin events that involve ``mass`` or ``element``."""
    if not events or "kind" not in events or len(events["kind"]) == 0:
        return []
    rows = []
    involved = events.get("masses")
    for i, kind in enumerate(events["kind"]):
        if kind not in IMPACT_KINDS:
            continue
        if mass is not None and (involved is None or mass not in str(involved[i]).split("/")):
            continue
        if element is not None and str(events["element"][i]) != element:
            continue
        rows.append(i)
    return rows


def _mark_impacts(ax, t: np.ndarray, y: np.ndarray, events, rows: Sequence[int], units: DisplayUnits | None = None) -> None:
    """Mark impacts at their times on the curve (t, y) and label them (element, |Δv|)."""
    times = np.array([float(events["time"][i]) for i in rows])
    keep = (times >= t[0]) & (times <= t[-1]) if t.size else np.zeros(times.shape, bool)
    rows = [r for r, k in zip(rows, keep) if k]
    if not rows:
        return
    times = times[keep]
    values = np.interp(times, t, y)
    ax.scatter(times, values, marker="v", s=36, color="tab:red", zorder=5, label="impact")
    for n, (i, ti, yi) in enumerate(zip(rows, times, values)):
        if n >= MAX_LABELS:
            break
        text = str(events["element"][i])
        if "relative_velocity" in events and np.isfinite(events["relative_velocity"][i]):
            unit, k = shown("m/s", units)
            text += f"\n{abs(float(events['relative_velocity'][i])) * k:.3g} {unit}"
        ax.annotate(
            text,
            (ti, yi),
            xytext=(4, 8),
            textcoords="offset points",
            fontsize=8,
            color="tab:red",
        )


# --------------------------------------------------------------------------------------
# Run files


def plot_svaj(group: h5py.Group, time_window=None, angle_window=None, title: str = "", units: DisplayUnits | None = None) -> Figure:
    """Cam displacement, velocity, acceleration and jerk against cam angle (four panels).

    Segment joins (``cam/boundaries_deg``, in [0, 360)) are drawn as vertical lines at
    every cycle the plotted angle range passes through.

    Parameters
    ----------
    group : h5py.Group
        A run layout (file root) or a cam file.
    time_window : (float or None, float or None), optional
        Only samples with time in this range [s].
    angle_window : (float or None, float or None), optional
        Only samples with cam angle in this range [deg] (the continuing angle).
    title : str
        Figure title.
    """
    if "cam/angle" not in group and "cams" in group:  # issue 38: every cam against the shaft angle
        return _plot_svaj_cams(group, time_window, angle_window, title, units)
    angle_ds = require(group, "cam/angle", "cam angle for the SVAJ plot")
    angle = angle_ds[()]
    if time_window is not None or angle_window is not None:
        if time_window is not None and "time" not in group:
            raise InputError(f"{group.file.filename}: --time: this file has no time axis; use --angle")
        mask = _sample_mask(group, time_window, angle_window) if "time" in group else _in(angle, angle_window)
        if not mask.any():
            raise InputError(f"{group.file.filename}: {_window_text(time_window, angle_window)}: no samples in the window")
    else:
        mask = np.ones(angle.shape, dtype=bool)
    x = angle[mask]
    names = ("displacement", "velocity", "acceleration", "jerk")
    dsets = [require(group, f"cam/{q}", "cam SVAJ") for q in names]
    boundaries = group["cam/boundaries_deg"][()] if "cam/boundaries_deg" in group else np.array([])
    marks = np.array([])
    if boundaries.size and x.size:
        lo, hi = float(x.min()), float(x.max())
        if angle_window is not None:  # joins at the window's edges are drawn too
            lo = angle_window[0] if angle_window[0] is not None else lo
            hi = angle_window[1] if angle_window[1] is not None else hi
        cycles = np.arange(np.floor(lo / 360.0), np.floor(hi / 360.0) + 1)
        marks = (boundaries[None, :] + 360.0 * cycles[:, None]).ravel()
        marks = np.unique(marks[(marks >= lo) & (marks <= hi)])
    with matplotlib.rc_context(_STYLE):
        fig, axes = _new_figure(8.0, 4)
        for ax, q, ds in zip(axes, names, dsets):
            label, scale = displayed(q, units_of(ds), units)
            ax.plot(x, ds[()][mask] * scale, color="tab:blue")
            ax.set_ylabel(label)
            if marks.size:
                ax.vlines(marks, 0, 1, transform=ax.get_xaxis_transform(), colors="0.5", linestyles=":", linewidth=0.9)
        axes[-1].set_xlabel(axis_label("cam angle", units_of(angle_ds)))
        fig.suptitle(title or "cam displacement, velocity, acceleration, jerk")
    return fig


def _plot_svaj_cams(group: h5py.Group, time_window=None, angle_window=None, title: str = "",
                    units: DisplayUnits | None = None) -> Figure:
    """s, v, a, j of every cam of a machine with ``[[cam]]`` tables against the shaft's angle."""
    shaft = require(group, "camshaft/angle", "shaft angle for the SVAJ plot")
    mask = _sample_mask(group, time_window, angle_window) if "time" in group else _in(shaft[()], angle_window)
    x = shaft[()][mask]
    names = ("displacement", "velocity", "acceleration", "jerk")
    with matplotlib.rc_context(_STYLE):
        fig, axes = _new_figure(8.0, 4)
        for cam in group["cams"]:
            for ax, q in zip(axes, names):
                ds = require(group, f"cams/{cam}/{q}", "cam SVAJ")
                label, scale = displayed(q, units_of(ds), units)
                ax.plot(x, ds[()][mask] * scale, label=cam)
                ax.set_ylabel(label)
        axes[0].legend(loc="best", fontsize="small")
        axes[-1].set_xlabel(axis_label("shaft angle", units_of(shaft)))
        fig.suptitle(title or "every cam's displacement, velocity, acceleration, jerk")
    return fig


def plot_camshaft(group: h5py.Group, time_window=None, angle_window=None, title: str = "",
                  units: DisplayUnits | None = None) -> Figure:
    """The camshaft (issue 38): each cam's torque and the shaft's, the motor's torque, and the
    shaft's speed when it varies (a dynamic shaft), in the display units ``units`` (issue 44:
    the speed was drawn in rad/s)."""
    mask = _sample_mask(group, time_window, angle_window)
    t = group["time"][()][mask]
    speed = group["camshaft/speed"][()][mask] if "camshaft/speed" in group else None
    varies = speed is not None and np.ptp(speed) > 1e-12 * max(float(np.max(np.abs(speed))), 1.0)
    with matplotlib.rc_context(_STYLE):
        fig, axes = _new_figure(6.5 if varies else 3.8, 2 if varies else 1)
        ax = axes[0]
        torque = require(group, "camshaft/torque")
        t_label, t_scale = displayed("torque", units_of(torque), units)
        if "cams" in group:
            for cam in group["cams"]:
                if f"cams/{cam}/torque" in group:
                    ax.plot(t, group[f"cams/{cam}/torque"][()][mask] * t_scale, linewidth=0.9, label=f"cam {cam}")
        ax.plot(t, torque[()][mask] * t_scale, color="k", linewidth=1.2, linestyle="--", label="shaft (sum)")
        if "camshaft/motor_torque" in group and varies:
            ax.plot(t, group["camshaft/motor_torque"][()][mask] * t_scale, color="tab:red", linestyle="--", label="drive")
        ax.set_ylabel(t_label)
        ax.legend(loc="best", fontsize="small")
        if varies:
            s_label, s_scale = displayed("shaft speed", units_of(group["camshaft/speed"]), units)
            axes[1].plot(t, speed * s_scale, color="tab:blue")
            axes[1].set_ylabel(s_label)
        axes[-1].set_xlabel(axis_label("time", units_of(group["time"])))
        fig.suptitle(title or "camshaft torque" + (" and speed" if varies else ""))
    return fig


def plot_trace(
    group: h5py.Group,
    path: str,
    time_window=None,
    angle_window=None,
    events: dict[str, np.ndarray] | None = None,
    impacts_of_mass: str | None = None,
    impacts_of_element: str | None = None,
    shade_negative: bool = False,
    title: str = "",
    units: DisplayUnits | None = None,
) -> Figure:
    """One trace of a run layout against time, impacts marked and labelled.

    Parameters
    ----------
    group : h5py.Group
        The run layout (file root or ``/impact`` etc.).
    path : str
        Trace path relative to ``group``, e.g. ``"masses/M2/acceleration"``.
    events : dict, optional
        The events table (:func:`camsim.io.results.read_events`).
    impacts_of_mass, impacts_of_element : str, optional
        Mark the impact/rejoin events whose ``masses`` include this mass or whose
        ``element`` is this element.
    shade_negative : bool
        Shade where the trace is negative (a cam contact force below zero: jump).
    units : DisplayUnits, optional
        Units drawn in (default SI).
    """
    ds = require(group, path)
    mask = _sample_mask(group, time_window, angle_window)
    time_ds = group["time"]
    t = time_ds[()][mask]
    y_label, scale = displayed(path.rsplit("/", 1)[-1], units_of(ds), units)
    y = ds[()][mask] * scale
    with matplotlib.rc_context(_STYLE):
        fig, (ax,) = _new_figure(3.6)
        ax.plot(t, y, color="tab:blue", label=long_name_of(ds))
        if shade_negative and np.any(y < 0):
            ax.fill_between(t, y, 0.0, where=y < 0, color="tab:red", alpha=0.3, linewidth=0, label="jump (force < 0)")
            ax.legend(loc="best")
        if events is not None and (impacts_of_mass or impacts_of_element):
            rows = _impact_rows(events, mass=impacts_of_mass, element=impacts_of_element)
            _mark_impacts(ax, t, y, events, rows, units)
        ax.set_xlabel(axis_label("time", units_of(time_ds)))
        ax.set_ylabel(y_label)
        ax.set_title(title or long_name_of(ds))
    return fig


def plot_mass(group: h5py.Group, mass: str, quantity: str, time_window=None, angle_window=None, title: str = "",
              units: DisplayUnits | None = None) -> Figure:
    """Displacement, velocity or acceleration of one mass against time, its impacts marked."""
    _check_quantity(quantity)
    return plot_trace(
        group,
        f"masses/{mass}/{quantity}",
        time_window,
        angle_window,
        events=read_events(group),
        impacts_of_mass=mass,
        title=title or f"{quantity} of {mass}",
        units=units,
    )


def plot_force(group: h5py.Group, path: str, time_window=None, angle_window=None, title: str = "",
               units: DisplayUnits | None = None) -> Figure:
    """An element, cam-contact, transducer or process-load force against time.

    Impacts of the element are marked on element forces; a negative cam contact force
    (the follower leaves the cam: jump) is shaded.
    """
    element = path.split("/")[1] if path.startswith("elements/") else None
    return plot_trace(
        group,
        path,
        time_window,
        angle_window,
        events=read_events(group),
        impacts_of_element=element,
        shade_negative=path == "cam_contact/force" or path.endswith("/contact_force"),
        title=title,
        units=units,
    )


# --------------------------------------------------------------------------------------
# Comparison files


def plot_compare(f: h5py.Group, mass: str, quantity: str, time_window=None, angle_window=None,
                 units: DisplayUnits | None = None) -> Figure:
    """Impact vs no-impact overlay with the percent difference under it (thesis figs 8.21-8.26).

    Top panel: ``/impact/masses/<mass>/<quantity>`` and ``/no_impact/...`` against their
    own time; bottom panel: ``/difference/masses/<mass>/<quantity>`` [%], defined as
    100·(impact − no_impact)/max|impact|.
    """
    _check_quantity(quantity)
    path = f"masses/{mass}/{quantity}"
    groups = {}
    for name in ("impact", "no_impact", "difference"):
        if name not in f:
            raise ResultFileError(f"{f.file.filename}: /{name}: not in the file (not a comparison file?)")
        groups[name] = f[name]
    data = {}
    for name, g in groups.items():
        ds = require(g, path)
        mask = _sample_mask(g, time_window, angle_window, angle_source=groups["impact"])
        data[name] = (g["time"][()][mask], ds[()][mask], ds)
    with matplotlib.rc_context(_STYLE):
        fig = Figure(figsize=(_WIDTH, 5.0), layout="constrained")
        top, bottom = fig.subplots(2, 1, sharex=True, height_ratios=(2, 1))
        t, y, ds = data["impact"]
        label, scale = displayed(quantity, units_of(ds), units)
        top.plot(t, y * scale, color="tab:blue", label="with impact")
        t2, y2, _ = data["no_impact"]
        top.plot(t2, y2 * scale, color="tab:orange", linestyle="--", label="without impact")
        top.set_ylabel(label)
        top.legend(loc="best")
        top.set_title(f"{quantity} of {mass}: with and without impact")
        td, d, dds = data["difference"]
        bottom.plot(td, d, color="tab:green")
        bottom.set_ylabel(axis_label("difference", units_of(dds) or "%"))
        bottom.set_xlabel(axis_label("time", units_of(groups["impact"]["time"])))
    return fig


# --------------------------------------------------------------------------------------
# Everything a file calls for


def _check_quantity(quantity: str) -> None:
    if quantity not in QUANTITIES:
        raise InputError(f"--quantity: unknown quantity {quantity!r} (one of {', '.join(QUANTITIES)})")


def _split(values: Iterable[str] | None) -> list[str]:
    out: list[str] = []
    for v in values or ():
        out.extend(p.strip() for p in str(v).split(",") if p.strip())
    return out


def _pick_masses(f: h5py.File, available: list[str], wanted: list[str], where: str) -> list[str]:
    if not available:
        raise ResultFileError(f"{f.filename}: {where}: no masses in the file")
    if not wanted:
        return available
    for m in wanted:
        if m not in available:
            raise InputError(f"{f.filename}: --mass {m}: no such mass in the file (has {', '.join(available)})")
    return wanted


def make_plots(
    path: str | os.PathLike[str],
    what: Iterable[str] | None = None,
    masses: Iterable[str] | None = None,
    quantities: Iterable[str] | None = None,
    time_window: tuple[float | None, float | None] | None = None,
    angle_window: tuple[float | None, float | None] | None = None,
    units: str | DisplayUnits = "file",
) -> dict[str, Figure]:
    """Build every figure requested from a result file, keyed by stable names.

    Parameters
    ----------
    path : path
        A camsim result file (run, compare, sweep or cam).
    what : iterable of str, optional
        Plot families (:data:`PLOT_KINDS`; comma-separated strings allowed). Default:
        everything the file kind offers (run: svaj, masses, forces; compare: compare;
        sweep: sweep; cam: svaj).
    masses : iterable of str, optional
        Masses to plot (default all).
    quantities : iterable of str, optional
        Among displacement, velocity, acceleration (default all three).
    time_window : (float or None, float or None), optional
        Time range [s].
    angle_window : (float or None, float or None), optional
        Cam-angle range [deg] of the continuing angle ``/cam/angle``.
    units : str or DisplayUnits
        Units drawn in: ``"file"`` (the result's machine file's, the default), ``"si"``,
        ``"us"``, or a :class:`~camsim.display.DisplayUnits`.

    Returns
    -------
    dict
        ``{"<stem>_masses_M2_acceleration": Figure, ...}`` in a stable order.

    Raises
    ------
    InputError, ResultFileError
        For a file that is not a camsim result, a plot family the file does not hold,
        an unknown mass or quantity, an empty window. No figure is returned then.
    """
    with open_h5(path) as f:
        return figures_for_file(f, what, masses, quantities, time_window, angle_window, stem=Path(path).stem, units=units)


def figures_for_file(
    f: h5py.File,
    what: Iterable[str] | None = None,
    masses: Iterable[str] | None = None,
    quantities: Iterable[str] | None = None,
    time_window: tuple[float | None, float | None] | None = None,
    angle_window: tuple[float | None, float | None] | None = None,
    stem: str = "run",
    units: str | DisplayUnits = "file",
) -> dict[str, Figure]:
    """The figures of :func:`make_plots` from an open result file (or an in-memory image
    of a :class:`~camsim.run.result.RunResult`); figure names start with ``stem``."""
    from camsim.display import DisplayUnits
    from camsim.io.results import file_display_units

    units = units if isinstance(units, DisplayUnits) else file_display_units(f, units)
    if time_window is not None and angle_window is not None:
        raise InputError("--time and --angle: give one window, not both")
    stem = _safe(stem)
    wanted_masses = _split(masses)
    wanted_q = _split(quantities) or list(QUANTITIES)
    for q in wanted_q:
        _check_quantity(q)
    kinds = _split(what)
    for k in kinds:
        if k not in PLOT_KINDS:
            raise InputError(f"--what: unknown plot {k!r} (one of {', '.join(PLOT_KINDS)})")
    figs: dict[str, Figure] = {}
    kind = file_kind(f)
    offers = _OFFERS[kind]
    explicit = bool(kinds)
    if not kinds:
        kinds = list(offers)
    for k in kinds:
        if k not in offers:
            raise ResultFileError(
                f"{f.filename}: --what {k}: not available in a {kind} file (this file offers {', '.join(offers)})"
            )
    kinds = [k for k in PLOT_KINDS if k in kinds]
    for k in kinds:
        if k == "svaj":
            figs[f"{stem}_cam_svaj"] = plot_svaj(f, time_window, angle_window, units=units)
        elif k == "masses":
            chosen = _pick_masses(f, names_with(f, "masses", wanted_q[0]), wanted_masses, "/masses")
            for m in chosen:
                for q in wanted_q:
                    figs[f"{stem}_masses_{_safe(m)}_{q}"] = plot_mass(f, m, q, time_window, angle_window, units=units)
        elif k == "forces":
            paths = [f"elements/{e}/force" for e in names_with(f, "elements", "force")]
            paths += [p for p in ("cam_contact/force", "transducer/force") if p in f]
            paths += [f"cams/{c}/contact_force" for c in (f["cams"] if "cams" in f else ()) if f"cams/{c}/contact_force" in f]
            paths += [f"loads/{name}/force" for name in names_with(f, "loads", "force")]  # issue 43: process loads
            if not paths and explicit:
                raise ResultFileError(f"{f.filename}: --what forces: no element, cam-contact or transducer forces in the file")
            for p in paths:
                figs[f"{stem}_{_safe(p.replace('/', '_'))}"] = plot_force(f, p, time_window, angle_window, units=units)
        elif k == "compare":
            if "impact" not in f:
                raise ResultFileError(f"{f.filename}: /impact: not in the file (not a comparison file?)")
            chosen = _pick_masses(f, names_with(f["impact"], "masses", wanted_q[0]), wanted_masses, "/impact/masses")
            for m in chosen:
                for q in wanted_q:
                    figs[f"{stem}_compare_{_safe(m)}_{q}"] = plot_compare(f, m, q, time_window, angle_window, units=units)
        elif k == "camshaft":  # issue 38: several cams, or a [camshaft]
            if "camshaft/torque" not in f:
                if explicit:
                    raise ResultFileError(f"{f.filename}: --what camshaft: no /camshaft/torque (one cam and no [camshaft])")
                continue
            figs[f"{stem}_camshaft"] = plot_camshaft(f, time_window, angle_window, units=units)
        elif k == "design":  # issue 14: cam design datasets ([cam.geometry])
            if "cam/pressure_angle" not in f:
                if explicit:
                    raise ResultFileError(f"{f.filename}: --what design: no /cam/pressure_angle (the machine has no [cam.geometry])")
                continue
            from camsim.figures.cam import plot_design_file

            figs[f"{stem}_cam_design"] = plot_design_file(f, time_window, angle_window, units=units)
        elif k == "sweep":
            if time_window is not None or angle_window is not None:
                raise InputError("--time/--angle: a sweep plot has no time axis")
            chosen = _pick_masses(f, sweep_masses(f), wanted_masses, "/sweep/summary")
            for m in chosen:
                figs[f"{stem}_sweep_{_safe(m)}"] = plot_sweep_mass(f, m, wanted_q, units=units)
            extra = {
                "forces": (("peak_transducer_force", "max_cam_contact_force", "min_cam_contact_force"), "peak forces"),
                "impacts": (("impacts", "max_impact_velocity"), "impacts"),
                # issue 14: the design chart (pressure angle, radius, stress, torque vs the parameter)
                "design": (("max_pressure_angle", "min_surface_radius", "peak_hertz_stress", "peak_torque"), "cam design"),
            }
            if not wanted_masses:
                for name, (cols, title) in extra.items():
                    fig = plot_sweep_columns(f, cols, title, units=units)
                    if fig is not None:
                        figs[f"{stem}_sweep_{name}"] = fig
    return figs




def default_output_dir(path: str | os.PathLike[str]) -> Path:
    """``<dir of input>/<stem>_plots``."""
    p = Path(path)
    return p.parent / f"{p.stem}_plots"


def prepare_output_dir(out_dir: str | os.PathLike[str]) -> Path:
    """Create ``out_dir`` if needed and check that files can be written in it.

    Raises
    ------
    InputError
        One line naming the directory.
    """
    d = Path(out_dir)
    if d.exists() and not d.is_dir():
        raise InputError(f"{d}: output directory is a file")
    if not d.exists():
        try:
            d.mkdir(parents=True)
        except OSError as exc:
            raise InputError(f"{d}: cannot create the output directory ({exc.strerror or exc})") from None
    if not os.access(d, os.W_OK | os.X_OK):
        raise InputError(f"{d}: output directory is not writable")
    return d


#: Resolutions [dots per inch] a png may be written at (``--dpi``).
DPI_RANGE = (20.0, 2400.0)


def save_figures(figures: dict[str, Figure], out_dir: str | os.PathLike[str], fmt: str = "png", dpi: float = 150.0) -> list[Path]:
    """Write each figure as ``out_dir/<name>.<fmt>``, each to a temporary name then renamed.

    Parameters
    ----------
    figures : dict
        Name -> Figure, as returned by :func:`make_plots`.
    out_dir : path
        Created if missing.
    fmt : str
        ``png``, ``svg`` or ``pdf``.
    dpi : float
        Resolution of raster output [dots per inch].

    Returns
    -------
    list of Path
        The files written, in the order of ``figures``.
    """
    if fmt not in FORMATS:
        raise InputError(f"--format: unknown format {fmt!r} (one of {', '.join(FORMATS)})")
    if not (DPI_RANGE[0] <= dpi <= DPI_RANGE[1]):
        # below ~20 dpi the fonts are under a pixel (FreeType refuses them); above 2400 an
        # image of these figures takes gigabytes
        raise InputError(f"--dpi: must lie between {DPI_RANGE[0]:g} and {DPI_RANGE[1]:g}, got {dpi:g}")
    d = prepare_output_dir(out_dir)
    from camsim.io.outputs import check_output

    for name in figures:  # every image is checked before the first is written (docs/results.md)
        check_output(d / f"{name}.{fmt}", fmt, owner="figure", option="-o")
    from camsim.figures.style import save_figure

    return [save_figure(fig, d / f"{name}.{fmt}", fmt, dpi=dpi) for name, fig in figures.items()]


def plot_result(result, out_dir: str | os.PathLike[str] | None = None, **options) -> dict:
    """The ``camsim plot`` figures of a run result (``camsim.plot_result(result)``).

    Parameters
    ----------
    result : camsim.run.result.RunResult
        The run, in memory.
    out_dir : path, optional
        Where to save them (PNG); without it the matplotlib figures are returned.
    **options
        As :func:`camsim.figures.plots.make_plots` (``what``, ``masses``, ``quantities``,
        ``time_window``, ``angle_window``).

    Returns
    -------
    dict
        Figure name → :class:`matplotlib.figure.Figure` (or → saved path with ``out_dir``).
    """
    import h5py

    from camsim.run.runfile import write_root_attributes, write_run_group

    # The figures are drawn from the result layout (the same code as for a file),
    # here an in-memory HDF5 image that never touches the disk.
    with h5py.File(f"camsim-{id(result)}.h5", "w", driver="core", backing_store=False) as f:
        write_root_attributes(f, result.machine, "run")
        write_run_group(f, result)
        figures = figures_for_file(f, **options)
    if out_dir is None:
        return figures
    return dict(zip(figures, save_figures(figures, out_dir)))

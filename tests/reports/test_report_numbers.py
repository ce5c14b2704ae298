"""Issue 44, item 1: a page shows only what a test has read.

Every section of every report kind (run, comparison, sweep, study, optimisation history) is
built for an inch-pound machine file and for the same machine written in SI, and every number
on it is compared with the result file:

* a value in a table or a verdict tile is a ``span.value`` that records the SI value it shows
  (``data-si``, ``data-si-unit``) and the unit it is shown in (``data-unit``): the digits shown
  must be that value converted by **pint** (an independent unit library), and the SI value must
  be one the file holds (a dataset, an attribute, the JSON of an attribute, the machine of its
  ``machine_toml``) or one the run result hub computes from the file (its summary, the cam
  design summary, the camshaft summary, the checks of camsim.run.checks);
* any other digit in the text of a table or a tile fails: a number printed without going
  through the display layer (``camsim.reports.page.Source``); stated limits (``span.rule``),
  derived percentages (``span.derived``), the run's own messages (``span.message``), headers,
  captions and notes are text, not values;
* every plotted array, converted back from its axis label's unit by pint, must hold values of
  the file (the traces are drawn as min/max envelopes of stored samples, so each point is a
  sample); a histogram's range and count must be those of the runs its statistics use.

The impact detail drew newtons under an ``[lbf]`` axis before this test (K23's impact read
about 128 "lbf" where it is 29.2 lbf); the camshaft section showed N·m and rad/s on an inch
page. Reference: the file as written (h5py), pint for the units; tolerance: the digits shown.
"""

from __future__ import annotations

import html
import json
import math
import re
from pathlib import Path

import h5py
import numpy as np
import pint
import pytest
from typer.testing import CliRunner

from camsim.cli import app

pytest.importorskip("bokeh", reason="bokeh not installed (pip install 'camsim[report]')")

ROOT = Path(__file__).resolve().parents[2]
MACHINES = ROOT / "machines"
UREG = pint.UnitRegistry()
runner = CliRunner()

#: Quick settings for every run of this test.
QUICK = ["--sample-rate", "2 kHz", "--warmup", "0"]


# ---------------------------------------------------------------------- machines and results
def _si_text(text: str) -> str:
    """A machine file with every quantity rewritten in SI units by pint (as test_units_everywhere)."""
    targets = {
        "[length]": "mm", "[mass]": "kg", "[length] * [mass] / [time] ** 2": "N", "[mass] / [time] ** 2": "N/m",
        "[mass] / [time]": "N*s/m", "[length] / [time]": "m/s", "[length] / [time] ** 2": "m/s**2",
        "[mass] / [length] / [time] ** 2": "MPa", "[length] ** 2 * [mass]": "kg*m**2",
    }

    def convert(m: re.Match) -> str:
        try:
            q = UREG.Quantity(m.group(1))
        except Exception:  # noqa: BLE001 - not a quantity
            return m.group(0)
        target = targets.get(str(getattr(q, "dimensionality", "")))
        return m.group(0) if target is None else f'"{q.to(target).magnitude:.10g} {target}"'

    return re.sub(r'"(\d[^"]*)"', convert, text)


def _machine(d: Path, name: str, system: str) -> Path:
    text = (MACHINES / name).read_text(encoding="utf-8")
    path = d / system / name
    path.parent.mkdir(exist_ok=True)
    path.write_text(text if system == "us" else _si_text(text), encoding="utf-8")
    return path


def _invoke(*args) -> None:
    r = runner.invoke(app, [str(a) for a in args])
    assert r.exit_code == 0, (args, r.output)


@pytest.fixture(scope="module")
def results(tmp_path_factory):
    """result kind -> {system: path}, made on first use."""
    d = tmp_path_factory.mktemp("numbers")
    made: dict = {}

    def get(kind: str, system: str) -> Path:
        if (kind, system) in made:
            return made[kind, system]
        m = _machine(d, "cdtm-geometry.toml", system)
        out = d / system / f"{kind}.h5"
        if kind == "run":
            _invoke("run", m, "-o", out, "-q", *QUICK)
        elif kind == "compare":
            _invoke("compare", m, "-o", out, "-q", *QUICK)
        elif kind == "sweep":
            _invoke("sweep", m, "--vary", "cam.speed=300:500:100rpm", "--workers", "1", "-o", out, "-q", *QUICK)
        elif kind == "study":
            _invoke("study", m, "--dist", "element.K23.preload=tol:28.12:3lbf", "--dist",
                    "element.K23.push_stiffness=uniform:6000:9000lbf/in", "--sensitivity", "-n", "4",
                    "--limit", "peak_transducer_force>52lbf", "--workers", "1", "-o", out, "-q", *QUICK)
        elif kind == "optimize":
            _invoke("optimize", m, "--var", "element.K23.preload=20:40lbf", "--minimize", "peak_transducer_force",
                    "--constraint", "max_cam_contact_force<=300lbf", "--method", "local", "--budget", "3",
                    "--workers", "1", "-r", out, "-q", *QUICK)
        elif kind == "rod":  # a rod, a Hertz contact that yields, run warnings
            _invoke("run", _machine(d, "cdtm-rod.toml", system), "-o", out, "-q", "--sample-rate", "10 kHz")
        elif kind == "camshaft":
            _invoke("run", _machine(d, "camshaft-line-dynamic.toml", system), "-o", out, "-q", "--sample-rate", "5 kHz")
        made[kind, system] = out
        return out

    return get


# ---------------------------------------------------------------------- what the file holds
class FileValues:
    """Every number a result file holds, and what the hub computes from it, sorted for lookup."""

    def __init__(self, path: Path):
        values: list[float] = []
        with h5py.File(path, "r") as f:
            def visit(name, item):
                self._attrs(item.attrs, values)
                if isinstance(item, h5py.Dataset):
                    data = item[()]
                    if getattr(data, "dtype", None) is not None and data.dtype.names:
                        for c in data.dtype.names:
                            if data[c].dtype.kind in "fiub":
                                values.extend(np.asarray(data[c], dtype=float).ravel())
                    elif getattr(data, "dtype", None) is not None and data.dtype.kind in "fiub":
                        values.extend(np.asarray(data, dtype=float).ravel())

            self._attrs(f.attrs, values)
            f.visititems(visit)
            kind = f.attrs.get("file_kind")
            kind = kind.decode() if isinstance(kind, bytes) else str(kind)
            groups = {"run": [None], "compare": ["impact", "no_impact"]}.get(kind, [])
        from camsim.machine.loader import load_machine_text, machine_to_dict

        with h5py.File(path, "r") as f:
            text = f.attrs["machine_toml"]
        machine = load_machine_text(text.decode() if isinstance(text, bytes) else str(text), base_dir=path.parent)
        _numbers(machine_to_dict(machine), values)
        for group in groups:  # what the hub computes from the file
            from camsim.run.checks import contact_stress_rows, johnson_rows
            from camsim.run.result import open_result

            result = open_result(path, group)
            _numbers(result.summary(), values)
            if machine.cam is not None and machine.cam.geometry is not None:
                _numbers(result.design_summary(), values)
            if "camshaft" in result.summary():
                _numbers(result.camshaft_summary(), values)
            _numbers(johnson_rows(machine, result.events), values)
            _numbers(contact_stress_rows(machine, result.events), values)
        array = np.asarray(values, dtype=float)
        array = array[np.isfinite(array)]
        self.values = np.unique(np.concatenate([array, -array]))  # magnitudes too (|relative velocity|)

    @staticmethod
    def _attrs(attrs, values):
        for key, v in attrs.items():
            if isinstance(v, bytes):
                v = v.decode()
            if isinstance(v, str):
                try:
                    _numbers(json.loads(v), values)
                except ValueError:
                    pass
                continue
            a = np.asarray(v)
            if a.dtype.kind in "fiub":
                values.extend(a.astype(float).ravel())
                if key.endswith("_rpm"):  # sweep attributes in rpm: their SI value
                    values.extend((a.astype(float) * 2 * math.pi / 60).ravel())

    def holds(self, x: np.ndarray, rtol: float = 1e-9) -> np.ndarray:
        """Which of ``x`` are values of the file (to ``rtol``, or 1e-300 absolute)."""
        x = np.asarray(x, dtype=float).ravel()
        i = np.clip(np.searchsorted(self.values, x), 1, max(self.values.size - 1, 1))
        near = np.minimum(np.abs(self.values[i - 1] - x), np.abs(self.values[np.minimum(i, self.values.size - 1)] - x))
        return near <= rtol * np.abs(x) + 1e-300


def _numbers(obj, out: list) -> None:
    if isinstance(obj, bool) or obj is None:
        return
    if isinstance(obj, (int, float, np.number)):
        out.append(float(obj))
    elif isinstance(obj, dict):
        for v in obj.values():
            _numbers(v, out)
    elif isinstance(obj, (list, tuple, np.ndarray)):
        for v in obj:
            _numbers(v, out)


# ---------------------------------------------------------------------- what the page shows
_SPAN = re.compile(r"<span class=value(?: data-key='[^']*')? data-si='([^']*)' data-si-unit='([^']*)' data-unit='([^']*)'>"
                   r"([^<]*)</span>")
_NUMBER = re.compile(r"(?<![\w.\[])[-+−]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?(?![\w.\]])")
#: Text that is not a value: stated limits, derived percentages, the run's messages, headers,
#: captions, notes, buttons, code, the header's provenance.
_TEXT = re.compile(r"<span class=rule>.*?</span>|<span class=derived[^>]*>.*?</span>|<span class=message>.*?</span>"
                   r"|<th[^>]*>.*?</th>|<caption>.*?</caption>|<p class=note>.*?</p>|<button.*?</button>"
                   r"|<code>.*?</code>|<h3>.*?</h3>", re.S)


def _pint_unit(text: str) -> str:
    text = {"-": "", "%": "percent", "in": "inch", "lb": "pound", "psi": "psi"}.get(text, text)
    return text.replace("²", "**2").replace("³", "**3").replace("·", "*").replace("µ", "u")


def _to_si(value, unit: str, si_unit: str):
    """``value`` shown in ``unit`` back in ``si_unit`` (pint)."""
    if _pint_unit(unit) == _pint_unit(si_unit):
        return value
    if unit == "%" and si_unit == "":
        return np.asarray(value) / 100.0
    return UREG.Quantity(np.asarray(value, dtype=float), _pint_unit(unit)).to(_pint_unit(si_unit).replace("^", "**")).magnitude


def _digits_tolerance(text: str) -> float:
    """Half a unit of the last digit printed."""
    mantissa = re.split(r"[eE]", text)[0]
    decimals = len(mantissa.split(".")[1]) if "." in mantissa else 0
    exponent = int(re.split(r"[eE]", text)[1]) if re.search(r"[eE]", text) else 0
    return 0.5 * 10.0 ** (exponent - decimals)


def check_html(block: str, file: FileValues, where: str) -> list[str]:
    problems = []
    for si_text, si_unit, unit, shown in _SPAN.findall(block):
        shown = html.unescape(shown).strip().replace("−", "-")
        si = float(si_text)
        if shown in ("–", "") or not math.isfinite(si):
            if math.isfinite(si) and shown == "–":
                problems.append(f"{where}: {si} {si_unit} shown as –")
            continue
        if shown in ("∞", "-∞"):
            continue
        value = float(shown)
        expected = float(_to_si(1.0, si_unit, unit) * si) if unit != "-" else si
        if unit == "%" and si_unit == "":
            expected = 100.0 * si
        if abs(value - expected) > _digits_tolerance(shown) * 1.0001 + 1e-12 * abs(expected):
            problems.append(f"{where}: shows {shown} {unit} for {si} {si_unit} (pint: {expected:.6g} {unit})")
        if not file.holds(np.array([si]))[0] and si != 0.0 and not float(si).is_integer():
            problems.append(f"{where}: {si} {si_unit} (shown {shown} {unit}) is not a value of the file")
    text = _TEXT.sub(" ", _SPAN.sub(" ", block))
    text = html.unescape(re.sub(r"<[^>]+>", " ", text))
    for m in _NUMBER.finditer(text):
        problems.append(f"{where}: a number not shown through the display layer: …{text[max(0, m.start() - 50):m.end() + 20]!r}")
    return problems


def _label_unit(label: str) -> str | None:
    m = re.search(r"\[([^\]]*)\]\s*$", label or "")
    return m.group(1) if m else None


def check_plot(model, file: FileValues, where: str, runs: int | None) -> list[str]:
    """Every plotted array, back in SI by its axis label's unit, holds values of the file."""
    from bokeh.models import ColumnDataSource, GlyphRenderer, Plot

    problems = []
    for fig in model.select({"type": Plot}):
        x_unit = _label_unit(fig.below[0].axis_label) if fig.below else None
        y_unit = _label_unit(fig.left[0].axis_label) if fig.left else None
        for r in fig.select({"type": GlyphRenderer}):
            glyph, data = r.glyph, r.data_source.data if isinstance(r.data_source, ColumnDataSource) else {}
            kind = type(glyph).__name__
            if kind == "Quad":  # a histogram: range of the runs, count of the runs
                left, right = np.asarray(data["left"], float), np.asarray(data["right"], float)
                ends = _to_si(np.array([left.min(), right.max()]), x_unit, _si_of(x_unit))
                if not file.holds(ends, 1e-7).all():
                    problems.append(f"{where}: histogram {fig.name} spans {ends} [{_si_of(x_unit)}], not the file's values")
                if runs is not None and int(np.sum(data["top"])) != runs:
                    problems.append(f"{where}: histogram {fig.name} counts {int(np.sum(data['top']))} runs, the statistics {runs}")
                continue
            for attr, unit in (("x", x_unit), ("y", y_unit), ("top", y_unit)):
                field = getattr(glyph, attr, None)
                if not isinstance(field, str) or field not in data or unit is None:
                    continue
                values = np.asarray(data[field], dtype=float)
                values = values[np.isfinite(values)]
                if not values.size or (kind == "VBar" and attr == "x"):
                    continue
                si = _to_si(values, unit, _si_of(unit))
                missing = ~file.holds(si, 1e-7)
                if missing.any():
                    problems.append(f"{where}: {fig.name} {kind}.{attr} [{unit}]: {int(missing.sum())} of {si.size} values "
                                    f"are not the file's (e.g. {values[missing][:3]} {unit} = {si[missing][:3]} SI)")
    return problems


def _si_of(unit: str) -> str:
    """The unit the file stores a quantity shown in ``unit`` in (angles in deg, speeds in rad/s)."""
    if unit in ("deg", "s", "-", "%", "Hz", "ms"):
        return {"ms": "s"}.get(unit, unit)
    if unit == "rpm":
        return "rad/s"
    q = UREG.Quantity(1.0, _pint_unit(unit)).to_base_units()
    return f"{q.units:~}".replace(" ", "")


def check_page(path: Path, system: str) -> None:
    from camsim.io.results import open_h5
    from camsim.reports.build import _kind_of, _units
    from camsim.reports.page import Plot, Source
    from camsim.reports.build import sections_for

    file = FileValues(path)
    with open_h5(path) as f:
        kind = _kind_of(f, path)
        sections = sections_for(Source(path, kind, h5=f, units=_units(None, f)))
        runs = None
        if kind == "study":
            runs = json.loads(f["study"].attrs["summary_json"])["n_samples"] * 2  # blocks A and B (--sensitivity)
    problems = []
    assert sections
    for s in sections:
        if s.id.endswith(("header", "machine")):
            continue
        for block in s.blocks:
            if isinstance(block, Plot):
                problems += check_plot(block.model, file, f"{system} {kind} {s.id}", runs)
            else:
                problems += check_html(block, file, f"{system} {kind} {s.id}")
    assert not problems, "\n".join(problems[:15])


@pytest.mark.parametrize("system", ["us", "si"])
@pytest.mark.parametrize("kind", ["run", "compare"])
def test_every_number_of_the_run_and_comparison_pages_is_the_files(results, kind, system):
    check_page(results(kind, system), system)


@pytest.mark.slow
@pytest.mark.parametrize("system", ["us", "si"])
@pytest.mark.parametrize("kind", ["sweep", "study", "optimize", "rod", "camshaft"])
def test_every_number_of_every_page_is_the_files(results, kind, system):
    """The sweep, study and optimisation pages, a rod with a yielding Hertz contact, a dynamic camshaft
    (about a minute in all: CI)."""
    check_page(results(kind, system), system)


def test_the_impact_detail_draws_the_force_in_the_axis_unit(results):
    """The defect of the issue, alone: K23's rejoin at t ≈ 0.023 s drawn in the impact detail of an
    inch page must peak at the event table's simulated peak in lbf (38.8 lbf), not in N."""
    from camsim.io.results import open_h5
    from camsim.reports.build import _units, sections_for
    from camsim.reports.page import Source

    path = results("run", "us")
    with open_h5(path) as f:
        sections = sections_for(Source(path, "run", h5=f, units=_units(None, f)))
        peak_n = float(f["events"]["peak_force"][0])
        preload = 28.12 * UREG.Quantity(1.0, "lbf").to("N").magnitude
    detail = next(s for s in sections if s.id == "detail")
    box = next(b for b in detail.blocks if not isinstance(b, str)).model
    fig = next(m for m in box.select({"name": "impact-detail-force"}))
    assert fig.left[0].axis_label == "force [lbf]"
    drawn = np.asarray(fig.renderers[0].data_source.data["force"], dtype=float)
    # the element force of a preloaded link: preload − interface force, in lbf; the samples of a
    # 2 kHz run straddle the located peak (within 1 %), the force in N would be 4.45 times it
    lbf = UREG.Quantity(1.0, "lbf").to("N").magnitude
    assert np.nanmin(drawn) == pytest.approx((preload - peak_n) / lbf, rel=0.01)


def test_every_summary_scalar_names_its_unit(tmp_path):
    """/summary gives each scalar its unit, the camshaft's and the cam design's too (the page read
    "peak_camshaft_torque 23.76 -": N·m shown as a bare number). Reference: the hub's column
    tables (camsim.run.camshaft.camshaft_columns, camsim.cam.design.DESIGN_COLUMNS)."""
    out = tmp_path / "line.h5"
    _invoke("run", MACHINES / "camshaft-line.toml", "-o", out, "-q", *QUICK)
    with h5py.File(out, "r") as f:
        attrs = f["summary"].attrs
        units = {k[6:]: (v.decode() if isinstance(v, bytes) else str(v)) for k, v in attrs.items() if k.startswith("units:")}
    assert units["peak_camshaft_torque"] == "N*m" and units["energy_excursion"] == "J"
    assert units["flywheel_inertia"] == "kg*m^2" and units["min_clearance:pusher-lane"] == "m"
    assert units["peak_cam_torque:feeder"] == "N*m"

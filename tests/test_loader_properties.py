"""Property tests of the machine-file loader (hypothesis).

1. Random valid segment tables (any number of rows, any laws, durations that add up to
   360 deg, lifts that close and never go below the base circle, mixed units) always
   load, and the loaded rows equal the generated ones (relative tolerance 1e-12, the
   round-off of the unit conversions).
2. Random single corruptions of machines/cdtm.toml (a required key deleted, an unknown key
   inserted, a quantity given in a unit of the wrong dimension, a mass negated) always end
   in exit code 2 with one stderr line that names the file and exactly the corrupted key.
"""

from __future__ import annotations

import pytest
import math
import re
import tempfile
import tomllib
from pathlib import Path

import tomli_w
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from typer.testing import CliRunner

from camsim.cli import app
from camsim.machine.loader import (
    CAM_KEYS,
    ELEMENT_COMMON_KEYS,
    ELEMENT_TYPE_KEYS,
    INITIAL_KEYS,
    MACHINE_KEYS,
    MASS_KEYS,
    SEGMENT_KEYS,
    SIMULATION_KEYS,
    TOP_KEYS,
    load_machine_text,
)
from camsim.machine.description import LAWS

MACHINES = Path(__file__).resolve().parents[1] / "machines"
CDTM = tomllib.loads((MACHINES / "cdtm.toml").read_text())
runner = CliRunner()

# --------------------------------------------------------------------------------------
# 1. random valid segment tables
# --------------------------------------------------------------------------------------
_LENGTH_UNITS = {"mm": 1e-3, "in": 0.0254, "m": 1.0, "bare": 1.0}


@st.composite
def segment_tables(draw):
    """Rows (motion, law, duration [deg], lift [m]) that form a valid closed cam."""
    n_steps = draw(st.integers(min_value=1, max_value=9))
    rows = []
    level = 0.0
    for _ in range(n_steps):
        options = ["rise", "dwell"] + (["fall"] if level > 0 else [])
        motion = draw(st.sampled_from(options))
        if motion == "rise":
            lift = draw(st.floats(min_value=1e-4, max_value=0.05))
            level += lift
        elif motion == "fall":
            fraction = draw(st.floats(min_value=0.05, max_value=1.0))
            lift = level if fraction > 0.95 else level * fraction
            level -= lift
        else:
            lift = 0.0
        rows.append([motion, lift])
    if level > 0:
        rows.append(["fall", level])
    if not any(r[0] == "rise" for r in rows):
        rows = [["rise", 0.01], ["fall", 0.01]] + rows
    weights = draw(st.lists(st.floats(min_value=0.05, max_value=1.0), min_size=len(rows), max_size=len(rows)))
    total = sum(weights)
    durations = [360.0 * w / total for w in weights]
    result = []
    for (motion, lift), duration in zip(rows, durations):
        law = None if motion == "dwell" else draw(st.sampled_from(LAWS))
        result.append((motion, law, duration, lift, draw(st.sampled_from(sorted(_LENGTH_UNITS))),
                       draw(st.sampled_from(["deg", "rad", "bare"]))))
    return result


def _segment_toml(rows) -> str:
    segments = []
    for motion, law, duration, lift, lift_unit, angle_unit in rows:
        seg = {"motion": motion}
        if law is not None:
            seg["law"] = law
        if angle_unit == "deg":
            seg["duration"] = f"{duration!r} deg"
        elif angle_unit == "rad":
            seg["duration"] = f"{math.radians(duration)!r} rad"
        else:
            seg["duration"] = duration  # bare number: degrees
        if motion != "dwell":
            if lift_unit == "bare":
                seg["lift"] = lift
            else:
                seg["lift"] = f"{lift / _LENGTH_UNITS[lift_unit]!r} {lift_unit}"
        segments.append(seg)
    doc = {
        "schema": 1,
        "machine": {"name": "random cam"},
        "cam": {"speed": "100 rpm", "drives": "M1", "segments": segments},
        "mass": [{"name": "M1", "mass": "1 kg"}, {"name": "M2", "mass": "1 kg"}],
        "element": [{"name": "k", "type": "spring", "between": ["M1", "M2"], "stiffness": 1e5}],
    }
    return tomli_w.dumps(doc)


@settings(max_examples=150, deadline=None)
@given(segment_tables())
def test_random_valid_segment_tables_load(rows):
    machine = load_machine_text(_segment_toml(rows))
    loaded = machine.cam.segments
    assert len(loaded) == len(rows)
    for seg, (motion, law, duration, lift, _, _) in zip(loaded, rows):
        assert (seg.motion, seg.law) == (motion, law)
        assert math.isclose(seg.duration, math.radians(duration), rel_tol=1e-12)
        assert math.isclose(seg.lift, lift, rel_tol=1e-12, abs_tol=0.0)


# --------------------------------------------------------------------------------------
# 2. random corruptions of a valid file
# --------------------------------------------------------------------------------------
def _required_paths(doc) -> list[tuple]:
    """Paths (as tuples of dict keys / list indices) of keys whose deletion is an error."""
    paths = [("schema",), ("machine", "name"), ("cam", "speed"), ("cam", "segments")]
    for i, seg in enumerate(doc["cam"]["segments"]):
        paths += [("cam", "segments", i, "motion"), ("cam", "segments", i, "duration")]
        if seg["motion"] != "dwell":
            paths += [("cam", "segments", i, "law"), ("cam", "segments", i, "lift")]
    for i, _ in enumerate(doc["mass"]):
        paths += [("mass", i, "name"), ("mass", i, "mass")]
    required = {"spring": ("stiffness",), "preloaded": ("push_stiffness", "pull_stiffness", "preload"),
                "contact": ("stiffness",)}
    for i, e in enumerate(doc["element"]):
        paths += [("element", i, k) for k in ("name", "type", "between") + required[e["type"]]]
    return paths


def _quantity_paths(doc) -> list[tuple[tuple, str]]:
    """(path, dimension) of every quantity in the document."""
    paths = [(("cam", "speed"), "angular_speed"), (("cam", "arm"), "length"),
             (("simulation", "sample_rate"), "frequency")]
    for i, seg in enumerate(doc["cam"]["segments"]):
        paths.append((("cam", "segments", i, "duration"), "angle"))
        if "lift" in seg:
            paths.append((("cam", "segments", i, "lift"), "length"))
    for i, _ in enumerate(doc["mass"]):
        paths.append((("mass", i, "mass"), "mass"))
    dims = {"stiffness": "stiffness", "push_stiffness": "stiffness", "pull_stiffness": "stiffness",
            "preload": "force", "gap": "length"}
    for i, e in enumerate(doc["element"]):
        paths += [(("element", i, k), dims[k]) for k in e if k in dims]
    return paths


#: Units of a known dimension, to put where another dimension belongs.
_WRONG_UNITS = {"kg": "mass", "s": "time", "N": "force", "m": "length", "N/m": "stiffness",
                "m/s": "velocity", "Pa": "pressure", "m^2": "area"}

_ALL_KEYS = set(TOP_KEYS + MACHINE_KEYS + CAM_KEYS + SEGMENT_KEYS + MASS_KEYS + ELEMENT_COMMON_KEYS
                + SIMULATION_KEYS + INITIAL_KEYS).union(*ELEMENT_TYPE_KEYS.values())


def _key_text(path: tuple) -> str:
    """('element', 3, 'stiffness') -> 'element[3].stiffness'."""
    text = ""
    for part in path:
        text += f"[{part}]" if isinstance(part, int) else (f".{part}" if text else part)
    return text


def _parent(doc, path):
    node = doc
    for part in path[:-1]:
        node = node[part]
    return node


@st.composite
def corruptions(draw):
    doc = tomllib.loads(tomli_w.dumps(CDTM))  # deep copy
    kind = draw(st.sampled_from(["delete", "unknown", "dimension", "negate"]))
    if kind == "delete":
        path = draw(st.sampled_from(_required_paths(doc)))
        del _parent(doc, path)[path[-1]]
    elif kind == "unknown":
        tables = [("machine",), ("cam",), ("simulation",)]
        tables += [("cam", "segments", i) for i in range(len(doc["cam"]["segments"]))]
        tables += [("mass", i) for i in range(len(doc["mass"]))]
        tables += [("element", i) for i in range(len(doc["element"]))]
        table = draw(st.sampled_from(tables))
        key = draw(st.from_regex(r"[a-z][a-z_]{0,14}", fullmatch=True).filter(lambda k: k not in _ALL_KEYS))
        node = doc
        for part in table:
            node = node[part]
        node[key] = draw(st.sampled_from([1, "2 kg", True]))
        path = table + (key,)
    elif kind == "dimension":
        path, dimension = draw(st.sampled_from(_quantity_paths(doc)))
        unit = draw(st.sampled_from([u for u, d in _WRONG_UNITS.items() if d != dimension]))
        _parent(doc, path)[path[-1]] = f"{draw(st.floats(min_value=0.1, max_value=100))!r} {unit}"
    else:
        i = draw(st.integers(min_value=0, max_value=len(doc["mass"]) - 1))
        path = ("mass", i, "mass")
        doc["mass"][i]["mass"] = "-" + doc["mass"][i]["mass"]
    return tomli_w.dumps(doc), _key_text(path)


@pytest.mark.slow  # the default pytest's 3 minutes: CI runs it
@settings(max_examples=120, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(corruptions())
def test_random_corruption_exits_2_naming_the_key(case):
    text, key = case
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "corrupt.toml"
        path.write_text(text)
        result = runner.invoke(app, ["validate", str(path)])
    assert result.exit_code == 2, result.stderr
    assert result.stdout == ""
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in result.stderr
    match = re.match(rf"camsim: error: {re.escape(str(path))}: (\S+): \S", lines[0])
    assert match, lines[0]
    assert match.group(1) == key, lines[0]

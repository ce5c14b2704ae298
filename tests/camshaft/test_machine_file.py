"""The machine file of several cams (issue 38, spec §9): `[[cam]]`, `[camshaft]`,
`[[clearance]]`, their errors (one line naming the key, exit 2) and the `--set` grammar that
addresses a cam by name."""

from __future__ import annotations

import re
import tomllib
from pathlib import Path

import numpy as np
import pytest
import tomli_w

from camsim.cam.program import CamProgram
from camsim.errors import MachineFileError
from camsim.machine.loader import load_machine, load_machine_text, override_keys

from .stations import multi_toml

ROOT = Path(__file__).resolve().parents[2]


def _doc(**kw) -> dict:
    return tomllib.loads(multi_toml(stations=("feed", "clamp"), **kw))


def _load(doc: dict):
    return load_machine_text(tomli_w.dumps(doc), source="m.toml")


def _error(doc: dict, overrides=()) -> MachineFileError:
    with pytest.raises(MachineFileError) as info:
        load_machine_text(tomli_w.dumps(doc), source="m.toml", overrides=overrides)
    return info.value


def test_cams_names_phases_and_the_shaft():
    m = _load(_doc(phases={"feed": 0.0, "clamp": 120.0}))
    assert m.multi_cam and m.cam_names == ("feed", "clamp") and m.cam is m.cams[0]
    assert m.cams[1].phase == pytest.approx(np.radians(120.0))
    assert all(c.speed == pytest.approx(300 * np.pi / 30) for c in m.cams)
    assert m.driven_masses == {"A1": "feed"}
    assert [m.name for m in m.free_masses] == ["A2", "B"]
    assert m.element("rollB").at_cam and not m.element("gB").at_cam
    # the speed in the first [[cam]] instead of [camshaft]
    doc = _doc()
    doc["cam"][0]["speed"] = doc.pop("camshaft")["speed"]
    assert _load(doc).cams[1].speed == pytest.approx(300 * np.pi / 30)


@pytest.mark.parametrize("edit, key, words", [
    (lambda d: d["cam"][0].__setitem__("speed", "200 rpm"), "cam[0].speed", "given twice"),
    (lambda d: d["cam"][1].__setitem__("speed", "200 rpm"), "cam[1].speed", "share the shaft's speed"),
    (lambda d: d.pop("camshaft"), "camshaft.speed", "missing required key"),
    (lambda d: d["cam"][1].__setitem__("name", "feed"), "cam[1].name", 'duplicate cam name "feed"'),
    (lambda d: d["cam"][1].__setitem__("name", "A2"), "cam[1].name", "already a node"),
    (lambda d: d["cam"][1].__setitem__("name", "ratio"), "cam[1].name", "a key of a cam table"),
    (lambda d: d["cam"][1].__setitem__("name", "a.b"), "cam[1].name", "is not a plain name"),
    (lambda d: d["cam"][1].__setitem__("drives", "A1"), "cam[1].drives", "driven by cam feed already"),
    (lambda d: d["cam"][1].__setitem__("phase", "1 m"), "cam[1].phase", "expected [angle]"),
    (lambda d: d["cam"][1]["segments"][0].__setitem__("lift", "-1 mm"), "cam[1].segments[0].lift", "positive lift"),
    (lambda d: d["element"][2].__setitem__("between", ["feed", "clamp"]), "element[2].between", "at least one end"),
    (lambda d: d["element"][2].__setitem__("between", ["cam", "B"]), "element[2].between", 'unknown node "cam"'),
    (lambda d: d["camshaft"].__setitem__("model", "dynamic"), "camshaft.inertia", "needs the drive side's inertia"),
    (lambda d: d["camshaft"].update(model="dynamic", inertia="1 kg*m^2"), "camshaft.drive_stiffness",
     "missing required key"),
    (lambda d: d["camshaft"].update(model="dynamic", inertia="1 kg*m^2", drive="motor", stall_torque="5 N*m",
                                    no_load_speed="200 rpm"), "camshaft.no_load_speed", "must exceed the shaft's speed"),
    (lambda d: d["camshaft"].update(drive="motor", drive_stiffness="1e3 N*m/rad"), "camshaft.drive_stiffness",
     'not used with drive = "motor"'),
    (lambda d: d["camshaft"].__setitem__("section", [{"cam": "press", "stiffness": "1e4 N*m/rad",
                                                      "inertia": "0.01 kg*m^2"}]),
     "camshaft.section[0].cam", '"press" is not a cam'),
    (lambda d: d["camshaft"].__setitem__("section", [{"cam": "feed", "stiffness": "1e4 N",
                                                      "inertia": "0.01 kg*m^2"}]),
     "camshaft.section[0].stiffness", "expected [force]*[length]/[angle]"),
    (lambda d: d.__setitem__("clearance", [{"name": "x", "between": ["A1", "Z"]}]), "clearance[0].between[1]",
     '"Z" is not a mass or a cam'),
    (lambda d: d.__setitem__("clearance", [{"name": "x", "between": ["A1", "A1"]}]), "clearance[0].between",
     "both parts"),
    (lambda d: d.__setitem__("clearance", [{"name": "x", "between": ["A1", {"part": "B", "gap": "1 mm"}]}]),
     "clearance[0].between[1].gap", "unknown key"),
])
def test_errors_name_the_key(edit, key, words):
    doc = _doc()
    edit(doc)
    exc = _error(doc)
    assert exc.key == key, (exc.key, exc.message)
    assert words in exc.message, exc.message
    assert "\n" not in str(exc)


def test_camshaft_with_one_cam_table():
    """A [cam] file may add [camshaft] (no speed: [cam] gives it) and keeps /cam/..."""
    text = (ROOT / "machines" / "barkan-follower.toml").read_text()
    m = load_machine_text(text + "\n[camshaft]\nspeed_fluctuation = 0.05\n")
    assert not m.multi_cam and m.camshaft.speed == m.cam.speed
    with pytest.raises(MachineFileError, match=r"camshaft\.speed: the \[cam\] table gives the shaft's speed"):
        load_machine_text(text + '\n[camshaft]\nspeed = "100 rpm"\n')
    no_cam = tomllib.loads(text)
    no_cam.pop("cam")
    no_cam["simulation"] = {"duration": "1 ms"}
    no_cam["camshaft"] = {"speed_fluctuation": 0.05}
    with pytest.raises(MachineFileError, match=r"camshaft: a \[camshaft\] needs cams"):
        load_machine(no_cam)


def test_overrides_address_cams_by_name():
    doc = _doc()
    text = tomli_w.dumps(doc)
    m = load_machine_text(text, overrides=['cam.clamp.phase="30 deg"', 'cam.speed="600 rpm"',
                                           'cam.feed.segments[0].lift="12 mm"', 'cam.feed.segments[2].lift="12 mm"', "cam[1].ratio=0.5",
                                           'camshaft.speed_fluctuation=0.05'])
    assert m.cams[1].phase == pytest.approx(np.radians(30.0)) and m.cams[1].ratio == 0.5
    assert m.cams[0].speed == pytest.approx(600 * np.pi / 30) == m.camshaft.speed
    assert m.cams[0].segments[0].lift == pytest.approx(0.012) and m.camshaft.speed_fluctuation == 0.05
    with pytest.raises(MachineFileError, match="the cams share the shaft's speed"):
        load_machine_text(text, overrides=['cam.clamp.speed="100 rpm"'])
    with pytest.raises(MachineFileError, match="no cam named 'clmp'; did you mean 'clamp'"):
        load_machine_text(text, overrides=['cam.clmp.phase="30 deg"'])
    with pytest.raises(MachineFileError) as info:
        load_machine_text(text, overrides=['cam.clamp.phase="1 kg"'])
    assert info.value.key == "cam[1].phase" and "(value from --set cam.clamp.phase" in info.value.message
    keys = override_keys(doc)
    assert {"cam.speed", "cam.clamp.phase", "cam.feed.segments[0].lift", "camshaft.flywheel"} <= set(keys)
    assert "cam.clamp.speed" not in keys


def test_a_compensated_cam_on_the_shaft_is_the_one_cam_compensation():
    """cdtm-compensated.toml's cam as a [[cam]] beside another station: the same profile."""
    path = ROOT / "machines" / "cdtm-compensated.toml"
    alone = load_machine(path)
    doc = tomllib.loads(path.read_text())
    cam = doc.pop("cam")
    doc["camshaft"] = {"speed": cam.pop("speed")}
    cam["compensation"] = cam.pop("compensation")
    doc["cam"] = [{"name": "cdtm", **cam}, {"name": "other", "phase": "90 deg", "drives": "X", "segments": [
        {"motion": "rise", "law": "cycloidal", "duration": "180 deg", "lift": "5 mm"},
        {"motion": "fall", "law": "cycloidal", "duration": "180 deg", "lift": "5 mm"}]}]
    doc["mass"].append({"name": "X", "mass": "1 kg"})
    multi = load_machine(doc, base_dir=path.parent)
    theta = np.linspace(0.0, 2 * np.pi, 2001)
    a, b = CamProgram(alone.cam).lift(theta), CamProgram(multi.cams[0]).lift(theta)
    for x, y in zip(a, b):
        np.testing.assert_allclose(y, x, rtol=0, atol=1e-12 * np.max(np.abs(x)))
    doc["element"].append({"name": "tie", "type": "spring", "between": ["other", "M3"], "stiffness": "1e3 N/m"})
    with pytest.raises(MachineFileError, match=r"cam\[0\]\.compensation\.output: element tie joins the compensation path"):
        load_machine(doc, base_dir=path.parent)

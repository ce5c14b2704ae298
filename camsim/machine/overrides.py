"""Command-line overrides (``--set KEY=VALUE``) applied to a parsed machine document.

The key grammar addresses masses and elements by name and segments by index::

    cam.speed=150 rpm            cam.segments[2].lift=0.4 in
    mass.M2.mass=1.7 lb          element.seat.stiffness=9e6
    simulation.cycles=3          initial.M3.velocity=-0.2 m/s

and, in a file with ``[[cam]]`` tables, cams by name (``cam.speed`` stays the shaft's)::

    cam.feed.phase=30 deg        cam.feed.segments[0].lift=6 mm
    camshaft.flywheel=0.4 kg*m^2 camshaft.section.feed.stiffness=2e4 N*m/rad

An overridden value is then checked by the validator exactly like one in the file.
"""

from __future__ import annotations

import re
import tomllib
from collections.abc import Sequence
from typing import Any

from camsim import elements as element_kinds
from camsim.errors import MachineFileError
from camsim.machine.validator import (
    CAM_KEYS,
    MULTI_CAM_KEYS,
    ELEMENT_COMMON_KEYS,
    INITIAL_KEYS,
    MACHINE_KEYS,
    MASS_KEYS,
    SEGMENT_KEYS,
    SIMULATION_KEYS,
    TOP_KEYS,
    _suggest,
)


# --------------------------------------------------------------------------------------
# Overrides
# --------------------------------------------------------------------------------------
_PART = re.compile(r"^([A-Za-z_][\w\-]*)(?:\[(\d+)\])?$")


def _parse_value(text: str) -> Any:
    """VALUE of ``KEY=VALUE``: a TOML value if it parses as one, else the string."""
    try:
        return tomllib.loads(f"v = {text}")["v"]
    except tomllib.TOMLDecodeError:
        return text.strip()


def _named_rows(rows: Any) -> dict[str, dict]:
    if not isinstance(rows, list):
        return {}
    return {r["name"]: r for r in rows if isinstance(r, dict) and isinstance(r.get("name"), str)}


def _apply_override(doc: dict, assignment: str, source: str) -> str:
    """Apply ``assignment``; return the canonical key path it set (for messages)."""
    if "=" not in assignment:
        raise MachineFileError(source, assignment, 'override must be KEY=VALUE, e.g. cam.speed="150 rpm"')
    key, _, raw = assignment.partition("=")
    key = key.strip()
    value = _parse_value(raw)
    parts = key.split(".")
    matches = [_PART.match(p) for p in parts]
    if not key or not all(matches):
        raise MachineFileError(source, key, "malformed override key (write e.g. cam.segments[2].lift)")
    names = [(m.group(1), None if m.group(2) is None else int(m.group(2))) for m in matches]

    def unknown(valid: Sequence[str], word: str) -> MachineFileError:
        return MachineFileError(source, key, f"unknown key; {_suggest(word, valid)}")

    head, head_index = names[0]
    if head not in TOP_KEYS:
        raise unknown(TOP_KEYS, head)
    if head == "schema":
        if len(names) != 1 or head_index is not None:
            raise MachineFileError(source, key, "schema takes a number: schema=1")
        doc["schema"] = value
        return "schema"
    if len(names) == 1:
        raise MachineFileError(source, key, f"name a key inside [{head}], e.g. {_example(head)}")

    if head in ("machine", "simulation"):
        valid = MACHINE_KEYS if head == "machine" else SIMULATION_KEYS
        (leaf, leaf_index), rest = names[1], names[2:]
        if head_index is not None or leaf_index is not None or rest or leaf not in valid:
            raise unknown([f"{head}.{k}" for k in valid], key)
        _table(doc, head, source)[leaf] = value
        return f"{head}.{leaf}"

    if head == "cam" and isinstance(doc.get("cam"), list):  # issue 38: [[cam]] tables
        return _multi_cam_override(doc, key, names, value, source)
    if head == "cam":
        if head_index is not None:
            raise unknown([f"cam.{k}" for k in CAM_KEYS], key)
        return _cam_override(_table(doc, "cam", source), "cam", CAM_KEYS, key, names[1], names[2:], value, source)
    if head == "camshaft":  # issue 38
        return _camshaft_override(doc, key, names, value, source)
    if head == "clearance":  # issue 38
        return _clearance_override(doc, key, names, value, source)

    # mass.<name>.<key>, element.<name>.<key>, initial.<mass>.<key>
    # (mass[1].mass and element[3].stiffness, as in error messages, are accepted too)
    if head in ("mass", "element"):
        rows = doc.get(head)
        if not isinstance(rows, list):
            raise MachineFileError(source, key, f"the file has no [[{head}]]")
        if head_index is not None:
            if head_index >= len(rows) or not isinstance(rows[head_index], dict):
                raise MachineFileError(
                    source, key, f"no {head}[{head_index}]: the file has {len(rows)} (indices start at 0)"
                )
            index, rest = head_index, names[1:]
        else:
            row_name = names[1][0]
            by_name = [i for i, r in enumerate(rows) if isinstance(r, dict) and r.get("name") == row_name]
            if names[1][1] is not None or not by_name:
                existing = list(_named_rows(rows))
                raise MachineFileError(
                    source, key, f"no {head} named '{row_name}'; {_suggest(row_name, existing)}"
                )
            index, rest = by_name[0], names[2:]
        row = rows[index]
        if head == "mass":
            valid = MASS_KEYS
        else:
            kind = row.get("type")
            valid = ELEMENT_COMMON_KEYS + (element_kinds.type_keys(kind) if isinstance(kind, str) else ())
        prefix = f"{head}[{index}]" if head_index is not None else f"{head}.{names[1][0]}"
        if len(rest) != 1 or rest[0][1] is not None or rest[0][0] not in valid:
            word = rest[0][0] if rest else ""
            raise unknown([f"{prefix}.{k}" for k in valid], f"{prefix}.{word}")
        row[rest[0][0]] = value
        return f"{head}[{index}].{rest[0][0]}"

    # initial.<mass>.<key>
    mass_name = names[1][0]
    masses = list(_named_rows(doc.get("mass")))
    if head_index is not None or names[1][1] is not None:
        raise MachineFileError(source, key, "address initial conditions as initial.<mass>.<key>")
    if mass_name not in masses:
        raise MachineFileError(source, key, f"no mass named '{mass_name}'; {_suggest(mass_name, masses)}")
    rest = names[2:]
    if len(rest) != 1 or rest[0][1] is not None or rest[0][0] not in INITIAL_KEYS:
        word = rest[0][0] if rest else ""
        raise unknown([f"initial.{mass_name}.{k}" for k in INITIAL_KEYS], f"initial.{mass_name}.{word}")
    initial = _table(doc, "initial", source)
    entry = initial.setdefault(mass_name, {})
    if not isinstance(entry, dict):
        raise MachineFileError(source, f"initial.{mass_name}", "expected a table")
    entry[rest[0][0]] = value
    return f"initial.{mass_name}.{rest[0][0]}"


def _cam_override(cam: dict, prefix: str, valid: Sequence[str], key: str, leaf_part, rest: list, value: Any,
                  source: str) -> str:
    """One cam table's key: ``<prefix>.<leaf>``, ``<prefix>.segments[i].<key>`` …; returns the key path set."""
    leaf, leaf_index = leaf_part

    def unknown(word: str) -> MachineFileError:
        return MachineFileError(source, key, f"unknown key; {_suggest(word, [f'{prefix}.{k}' for k in valid])}")

    if leaf not in valid:
        raise unknown(key)
    if leaf == "geometry" and leaf_index is None:  # issue 14: cam.geometry.<key>[.<key>]
        from camsim.cam.arrangement import apply_geometry_override

        path = apply_geometry_override(cam, key, rest, value, source)
        return prefix + path[3:] if path.startswith("cam.") else path
    if leaf == "compensation" and leaf_index is None and rest:  # issue 27: cam.compensation.<key>
        return prefix + _compensation_override(cam, key, rest, value, source)[3:]
    if leaf != "segments":
        if leaf_index is not None or rest:
            raise unknown(key)
        cam[leaf] = value
        return f"{prefix}.{leaf}"
    segments = cam.get("segments")
    if leaf_index is not None and len(rest) == 2 and isinstance(segments, list) \
            and leaf_index < len(segments):  # issue 27: cam.segments[i].end.v, .points[k].s
        return prefix + _synthesis_override(segments, leaf_index, key, rest, value, source)[3:]
    if leaf_index is None or len(rest) != 1 or rest[0][1] is not None:
        raise MachineFileError(source, key, f"address one segment key, e.g. {prefix}.segments[2].lift")
    if not isinstance(segments, list) or leaf_index >= len(segments):
        count = len(segments) if isinstance(segments, list) else 0
        raise MachineFileError(
            source, key, f"no segment {leaf_index}: the file has {count} (indices start at 0)"
        )
    seg_key = rest[0][0]
    if seg_key not in SEGMENT_KEYS:
        raise MachineFileError(source, key, "unknown key; " + _suggest(
            key, [f"{prefix}.segments[{leaf_index}].{k}" for k in SEGMENT_KEYS]))
    if not isinstance(segments[leaf_index], dict):
        raise MachineFileError(source, key, "that segment is not a table")
    segments[leaf_index][seg_key] = value
    return f"{prefix}.segments[{leaf_index}].{seg_key}"


def _multi_cam_override(doc: dict, key: str, names: list, value: Any, source: str) -> str:
    """``cam.speed`` / ``cam.start_angle`` (the shaft's), ``cam.<name>.<key>`` or ``cam[i].<key>``
    of a file with ``[[cam]]`` tables (issue 38)."""
    rows = doc["cam"]
    head_index = names[0][1]
    cam_names = [r.get("name") for r in rows if isinstance(r, dict)]
    if head_index is None and len(names) == 2 and names[1][0] in ("speed", "start_angle") and names[1][1] is None:
        leaf = names[1][0]
        shaft = doc.get("camshaft")
        first = rows[0] if rows and isinstance(rows[0], dict) else {}
        if leaf in first and not (isinstance(shaft, dict) and leaf in shaft):
            first[leaf] = value
            return f"cam[0].{leaf}"
        _table(doc, "camshaft", source)[leaf] = value
        return f"camshaft.{leaf}"
    if head_index is not None:
        index, rest = head_index, names[1:]
        if index >= len(rows) or not isinstance(rows[index], dict):
            raise MachineFileError(source, key, f"no cam[{index}]: the file has {len(rows)} (indices start at 0)")
    else:
        name = names[1][0]
        if name not in cam_names or names[1][1] is not None:
            raise MachineFileError(source, key, f"no cam named '{name}'; {_suggest(name, [str(n) for n in cam_names])} "
                                   "(address a cam as cam.<name>.<key>; cam.speed is the shaft's speed)")
        index, rest = cam_names.index(name), names[2:]
    if not rest:
        raise MachineFileError(source, key, f"name a key of the cam, e.g. cam.{cam_names[index]}.phase")
    if rest[0][0] in ("speed", "start_angle") and rest[0][1] is None and len(rest) == 1:
        raise MachineFileError(source, key, f"the cams share the shaft's {rest[0][0]}: set cam.{rest[0][0]} "
                               f"(or camshaft.{rest[0][0]})")
    return _cam_override(rows[index], f"cam[{index}]", MULTI_CAM_KEYS, key, rest[0], rest[1:], value, source)


def _camshaft_override(doc: dict, key: str, names: list, value: Any, source: str) -> str:
    """``camshaft.<key>``, ``camshaft.section.<cam>.<key>`` or ``camshaft.section[i].<key>`` (issue 38)."""
    from camsim.machine import schema

    valid = [k for k in schema.keys("camshaft") if k != "section"]
    if names[0][1] is not None or len(names) < 2:
        raise MachineFileError(source, key, "address a camshaft key as camshaft.<key>, e.g. camshaft.flywheel")
    leaf, leaf_index = names[1]
    shaft = _table(doc, "camshaft", source)
    if leaf != "section":
        if leaf_index is not None or len(names) != 2 or leaf not in valid:
            raise MachineFileError(source, key, f"unknown key; {_suggest(leaf, [f'camshaft.{k}' for k in valid])}")
        shaft[leaf] = value
        return f"camshaft.{leaf}"
    rows = shaft.get("section")
    if not isinstance(rows, list):
        raise MachineFileError(source, key, "the file has no [[camshaft.section]]")
    section_keys = schema.keys("camshaft.section")
    if leaf_index is not None:
        index, rest = leaf_index, names[2:]
        if index >= len(rows):
            raise MachineFileError(source, key, f"no camshaft.section[{index}]: the file has {len(rows)}")
    else:
        if len(names) < 3:
            raise MachineFileError(source, key, "address a section as camshaft.section.<cam>.<key>")
        cam = names[2][0]
        found = [i for i, r in enumerate(rows) if isinstance(r, dict) and r.get("cam") == cam]
        if not found:
            existing = [str(r.get("cam")) for r in rows if isinstance(r, dict)]
            raise MachineFileError(source, key, f"no section of cam '{cam}'; {_suggest(cam, existing)}")
        index, rest = found[0], names[3:]
    if len(rest) != 1 or rest[0][1] is not None or rest[0][0] not in section_keys:
        word = rest[0][0] if rest else ""
        raise MachineFileError(source, key, f"unknown key; {_suggest(word, [f'camshaft.section.<cam>.{k}' for k in section_keys])}")
    rows[index][rest[0][0]] = value
    return f"camshaft.section[{index}].{rest[0][0]}"


def _clearance_override(doc: dict, key: str, names: list, value: Any, source: str) -> str:
    """``clearance.<name>.minimum`` (issue 38)."""
    rows = doc.get("clearance")
    by_name = _named_rows(rows)
    if names[0][1] is not None or len(names) != 3 or names[1][0] not in by_name or names[2] != ("minimum", None):
        raise MachineFileError(source, key, "address a clearance as clearance.<name>.minimum"
                               + (f"; {_suggest(names[1][0], list(by_name))}" if len(names) > 1 and names[1][0] not in by_name else ""))
    index = [i for i, r in enumerate(rows) if isinstance(r, dict) and r.get("name") == names[1][0]][0]
    rows[index]["minimum"] = value
    return f"clearance[{index}].minimum"


def _compensation_override(cam: dict, key: str, rest: list, value: Any, source: str) -> str:
    """``cam.compensation.output`` / ``cam.compensation.speed`` (issue 27)."""
    from camsim.machine import schema

    valid = schema.keys("cam.compensation")
    if len(rest) != 1 or rest[0][1] is not None or rest[0][0] not in valid:
        word = rest[0][0] if rest else ""
        raise MachineFileError(source, key, f"unknown key; {_suggest(word, [f'cam.compensation.{k}' for k in valid])}")
    table = cam.setdefault("compensation", {})
    if not isinstance(table, dict):
        raise MachineFileError(source, "cam.compensation", "expected a table")
    table[rest[0][0]] = value
    return f"cam.compensation.{rest[0][0]}"


def _synthesis_override(segments: list, index: int, key: str, rest: list, value: Any, source: str) -> str:
    """``cam.segments[i].start.v``, ``cam.segments[i].end.a``, ``cam.segments[i].points[k].s`` (issue 27)."""
    from camsim.machine import schema

    (table_name, table_index), (leaf, leaf_index) = rest
    row = segments[index]
    if not isinstance(row, dict):
        raise MachineFileError(source, key, "that segment is not a table")
    prefix = f"cam.segments[{index}]"
    if table_name in ("start", "end") and table_index is None and leaf_index is None:
        valid = schema.keys("cam.segments.end")
        if leaf not in valid:
            raise MachineFileError(source, key, f"unknown key; {_suggest(leaf, [f'{prefix}.{table_name}.{k}' for k in valid])}")
        table = row.setdefault(table_name, {})
        if not isinstance(table, dict):
            raise MachineFileError(source, f"{prefix}.{table_name}", "expected a table")
        table[leaf] = value
        return f"{prefix}.{table_name}.{leaf}"
    if table_name == "points" and table_index is not None and leaf_index is None:
        valid = schema.keys("cam.segments.points")
        points = row.get("points")
        if not isinstance(points, list) or table_index >= len(points) or not isinstance(points[table_index], dict):
            count = len(points) if isinstance(points, list) else 0
            raise MachineFileError(source, key, f"no point {table_index}: the segment has {count} (indices start at 0)")
        if leaf not in valid:
            raise MachineFileError(source, key, f"unknown key; {_suggest(leaf, [f'{prefix}.points[{table_index}].{k}' for k in valid])}")
        points[table_index][leaf] = value
        return f"{prefix}.points[{table_index}].{leaf}"
    raise MachineFileError(source, key, "address a segment key, e.g. cam.segments[2].lift, cam.segments[2].end.v "
                           "or cam.segments[1].points[0].s")


def _example(head: str) -> str:
    return {
        "machine": "machine.name=...",
        "cam": 'cam.speed="150 rpm"',
        "camshaft": 'camshaft.flywheel="0.4 kg*m^2"',
        "clearance": 'clearance.<name>.minimum="2 mm"',
        "mass": 'mass.M2.mass="1.7 lb"',
        "element": "element.seat.stiffness=9e6",
        "simulation": "simulation.cycles=3",
        "initial": 'initial.M3.velocity="-0.2 m/s"',
    }[head]


def _table(doc: dict, name: str, source: str) -> dict:
    table = doc.setdefault(name, {})
    if not isinstance(table, dict):
        raise MachineFileError(source, name, "expected a table")
    return table

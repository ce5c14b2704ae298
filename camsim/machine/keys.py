"""The key-path grammar of a machine file: one module owns it (issue 44).

A key path names one value of a machine document, as ``--set``, ``--vary``, ``--values``,
``--dist``, ``--var``, ``--param``, ``Machine.with_values`` and the fitted file all write it::

    cam.speed                    cam.segments[2].lift           cam.segments[1].points[0].s
    mass.M2.mass                 element.seat.stiffness         element[3].gap
    simulation.cycles            initial.M3.velocity            cam.geometry.base_radius
    cam.feed.phase               camshaft.section.feed.stiffness
    clearance.jaw_pusher.minimum load.press.force               load.press.segments[1].change
    load.shaker.sine.amplitude   load[0].base

The first part names a **table kind** (:class:`TableKind`, registered by its head in
:data:`KINDS`): it knows where a path lands in a parsed document (:meth:`TableKind.address`:
the table and the leaf, created when missing, with one-line errors naming the key and
suggesting the nearest valid one), which schema key it is (:meth:`TableKind.param`: its
dimension and SI unit), its value in a loaded machine (:meth:`TableKind.value`, over
:func:`camsim.machine.loader.machine_to_dict`) and every path a document offers
(:meth:`TableKind.paths`). A new table is one subclass registered here (``[[load]]`` with
``load.<name>.force``, issue 43: :class:`_Load`); nothing else parses key paths.

A bare number where a key has a unit is SI by the file format; :func:`bare_number_note` is
the one warning that says so, with the value in the file's units
(``cam.speed = 120 → 120 rad/s = 1146 rpm``); :mod:`camsim.machine.notes` gives it for every
value of a document and of the command line.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any, ClassVar

from camsim import elements as element_kinds
from camsim.elements import Param
from camsim.machine import schema
from camsim.machine.keypath import (  # noqa: F401 - the framework, re-exported
    KINDS,
    Address,
    Part,
    TableFactory,
    TableKind,
    _Context,
    _dict_table,
    _find,
    _named_rows,
    bare_number_note,
    is_bare_number,
    parse,
    register,
    try_parse,
)
from camsim.machine.reading import _suggest

__all__ = [
    "Address", "KINDS", "Part", "TableKind", "address", "bare_number_note", "document_paths",
    "is_bare_number", "machine_value", "param", "parse", "register", "try_parse", "unit",
]


# ---------------------------------------------------------------------- schema, machine, simulation
@register
class _Schema(TableKind):
    head, example = "schema", "schema=1"

    def address(self, ctx, parts):
        if len(parts) != 1 or parts[0][1] is not None:
            raise ctx.error("schema takes a number: schema=1")
        return Address(ctx.doc, "schema", "schema")

    def param(self, parts):
        return None

    def value(self, machine, parts):
        return None

    def paths(self, doc):
        return ["schema"]


class _Flat(TableKind):
    """A table of fixed keys: ``[machine]``, ``[simulation]``."""

    def address(self, ctx, parts):
        valid = schema.keys(self.head)
        (leaf, leaf_index), rest = parts[1], parts[2:]
        if parts[0][1] is not None or leaf_index is not None or rest or leaf not in valid:
            raise ctx.unknown([f"{self.head}.{k}" for k in valid], ctx.key)
        return Address(ctx.table(ctx.doc, self.head), leaf, f"{self.head}.{leaf}")

    def param(self, parts):
        return _find(schema.TABLES[self.head], parts[-1][0])

    def value(self, machine, parts):
        return machine.get(self.head, {}).get(parts[1][0]) if isinstance(machine.get(self.head), dict) else None

    def paths(self, doc):
        return [f"{self.head}.{k}" for k in schema.keys(self.head)]


@register
class _Machine(_Flat):
    head, example = "machine", "machine.name=..."


@register
class _Simulation(_Flat):
    head, example = "simulation", "simulation.cycles=3"


# ---------------------------------------------------------------------- cams
@register
class _Cam(TableKind):
    """``cam.<key>``, ``cam.segments[i].<key>`` (``.start.v``, ``.points[k].s``), ``cam.geometry.<key>``,
    ``cam.compensation.<key>``; with ``[[cam]]`` tables ``cam.<name>.<key>`` (``cam.speed`` and
    ``cam.start_angle`` are the shaft's) or ``cam[i].<key>``."""

    head, example = "cam", 'cam.speed="150 rpm"'

    # -- the document -------------------------------------------------------------
    def address(self, ctx, parts):
        if isinstance(ctx.doc.get("cam"), list):  # issue 38: [[cam]] tables
            return self._multi(ctx, parts)
        if parts[0][1] is not None:
            raise ctx.unknown([f"cam.{k}" for k in schema.keys("cam")], ctx.key)
        return self._one(ctx, ctx.table(ctx.doc, "cam"), "cam", schema.keys("cam"), parts[1], parts[2:])

    def _one(self, ctx, cam: Any, prefix: str, valid: Sequence[str], leaf_part: Part, rest: list[Part]) -> Address:
        leaf, leaf_index = leaf_part
        if leaf not in valid:
            raise ctx.unknown([f"{prefix}.{k}" for k in valid], ctx.key)
        if leaf == "geometry" and leaf_index is None:  # issue 14: cam.geometry.<key>[.<key>]
            return self._geometry(ctx, cam, prefix, rest)
        if leaf == "compensation" and leaf_index is None and rest:  # issue 27: cam.compensation.<key>
            comp = schema.keys("cam.compensation")
            if len(rest) != 1 or rest[0][1] is not None or rest[0][0] not in comp:
                raise ctx.unknown([f"cam.compensation.{k}" for k in comp], rest[0][0] if rest else "")
            return Address(ctx.table(cam, "compensation", "cam.compensation"), rest[0][0], f"{prefix}.compensation.{rest[0][0]}")
        if leaf != "segments":
            if leaf_index is not None or rest:
                raise ctx.unknown([f"{prefix}.{k}" for k in valid], ctx.key)
            return Address(cam, leaf, f"{prefix}.{leaf}")
        segments = cam.get("segments")
        if leaf_index is not None and len(rest) == 2 and isinstance(segments, list) and leaf_index < len(segments):
            return self._synthesis(ctx, segments, leaf_index, prefix, rest)  # issue 27
        if leaf_index is None or len(rest) != 1 or rest[0][1] is not None:
            raise ctx.error(f"address one segment key, e.g. {prefix}.segments[2].lift")
        if not isinstance(segments, list) or leaf_index >= len(segments):
            count = len(segments) if isinstance(segments, list) else 0
            raise ctx.error(f"no segment {leaf_index}: the file has {count} (indices start at 0)")
        seg_key, seg_keys = rest[0][0], schema.keys("cam.segments")
        if seg_key not in seg_keys:
            raise ctx.unknown([f"{prefix}.segments[{leaf_index}].{k}" for k in seg_keys], ctx.key)
        if not isinstance(segments[leaf_index], dict):
            raise ctx.error("that segment is not a table")
        return Address(segments[leaf_index], seg_key, f"{prefix}.segments[{leaf_index}].{seg_key}")

    def _geometry(self, ctx, cam, prefix: str, rest: list[Part]) -> Address:
        from camsim.cam.arrangement import GEOMETRY_KEYS, MATERIAL_KEYS

        if not rest or any(index is not None for _, index in rest):
            raise ctx.error("address one geometry key, e.g. cam.geometry.base_radius=40mm")
        name = rest[0][0]
        if name not in GEOMETRY_KEYS:
            raise ctx.unknown(GEOMETRY_KEYS, name)
        geometry = ctx.table(cam, "geometry", "cam.geometry")
        if name in ("cam_material", "follower_material") and len(rest) == 1:  # issue 39: a material name
            return Address(geometry, name, f"{prefix}.geometry.{name}")
        if name in ("cam_material", "follower_material"):
            if len(rest) != 2 or rest[1][0] not in MATERIAL_KEYS:
                raise ctx.unknown(MATERIAL_KEYS, rest[1][0] if len(rest) > 1 else "")
            material = ctx.table(geometry, name, f"cam.geometry.{name}")
            return Address(material, rest[1][0], f"{prefix}.geometry.{name}.{rest[1][0]}")
        if len(rest) != 1:
            raise ctx.error(f"cam.geometry.{name} has no sub-keys")
        return Address(geometry, name, f"{prefix}.geometry.{name}")

    def _synthesis(self, ctx, segments: list, index: int, prefix: str, rest: list[Part]) -> Address:
        """``cam.segments[i].start.v``, ``cam.segments[i].end.a``, ``cam.segments[i].points[k].s`` (issue 27)."""
        (table_name, table_index), (leaf, leaf_index) = rest
        row = segments[index]
        if not isinstance(row, dict):
            raise ctx.error("that segment is not a table")
        where = f"{prefix}.segments[{index}]"
        if table_name in ("start", "end") and table_index is None and leaf_index is None:
            valid = schema.keys("cam.segments.end")
            if leaf not in valid:
                raise ctx.unknown([f"{where}.{table_name}.{k}" for k in valid], leaf)
            return Address(ctx.table(row, table_name, f"{where}.{table_name}"), leaf, f"{where}.{table_name}.{leaf}")
        if table_name == "points" and table_index is not None and leaf_index is None:
            valid = schema.keys("cam.segments.points")
            points = row.get("points")
            if not isinstance(points, list) or table_index >= len(points) or not isinstance(points[table_index], dict):
                count = len(points) if isinstance(points, list) else 0
                raise ctx.error(f"no point {table_index}: the segment has {count} (indices start at 0)")
            if leaf not in valid:
                raise ctx.unknown([f"{where}.points[{table_index}].{k}" for k in valid], leaf)
            return Address(points[table_index], leaf, f"{where}.points[{table_index}].{leaf}")
        raise ctx.error("address a segment key, e.g. cam.segments[2].lift, cam.segments[2].end.v "
                        "or cam.segments[1].points[0].s")

    def _multi(self, ctx, parts) -> Address:
        """``cam.speed`` / ``cam.start_angle`` (the shaft's), ``cam.<name>.<key>`` or ``cam[i].<key>`` (issue 38)."""
        rows = ctx.doc["cam"]
        head_index = parts[0][1]
        cam_names = [r.get("name") for r in rows if isinstance(r, dict)]
        if head_index is None and len(parts) == 2 and parts[1][0] in ("speed", "start_angle") and parts[1][1] is None:
            leaf = parts[1][0]
            shaft = ctx.doc.get("camshaft")
            first = rows[0] if rows and isinstance(rows[0], dict) else {}
            if leaf in first and not (isinstance(shaft, dict) and leaf in shaft):
                return Address(first, leaf, f"cam[0].{leaf}")
            return Address(ctx.table(ctx.doc, "camshaft"), leaf, f"camshaft.{leaf}")
        if head_index is not None:
            index, rest = head_index, parts[1:]
            if index >= len(rows) or not isinstance(rows[index], dict):
                raise ctx.error(f"no cam[{index}]: the file has {len(rows)} (indices start at 0)")
        else:
            name = parts[1][0]
            if name not in cam_names or parts[1][1] is not None:
                raise ctx.error(f"no cam named '{name}'; {_suggest(name, [str(n) for n in cam_names])} "
                                "(address a cam as cam.<name>.<key>; cam.speed is the shaft's speed)")
            index, rest = cam_names.index(name), parts[2:]
        if not rest:
            raise ctx.error(f"name a key of the cam, e.g. cam.{cam_names[index]}.phase")
        if rest[0][0] in ("speed", "start_angle") and rest[0][1] is None and len(rest) == 1:
            raise ctx.error(f"the cams share the shaft's {rest[0][0]}: set cam.{rest[0][0]} (or camshaft.{rest[0][0]})")
        return self._one(ctx, rows[index], f"cam[{index}]", schema.keys("cams"), rest[0], rest[1:])

    # -- the schema ---------------------------------------------------------------
    def param(self, parts):
        names = [n for n, _ in parts]
        leaf = names[-1]
        if len(names) >= 3 and names[1] not in schema.keys("cams"):  # issue 38: cam.<name>.<key>
            if len(names) == 3 and leaf in ("name", "phase"):
                return _find(schema.TABLES["cams"], leaf)
            return self.param([parts[0], *parts[2:]])
        if len(names) == 3 and names[1] == "segments":
            table = "cam.segments"
        elif len(names) == 4 and names[1] == "segments":  # issue 27
            table = "cam.segments.points" if names[2] == "points" else "cam.segments.end"
        elif len(names) == 3 and names[1] == "compensation":  # issue 27
            table = "cam.compensation"
        elif len(names) >= 3 and names[1] == "geometry":  # issue 14
            table = "cam.geometry" if len(names) == 3 else "cam.geometry.material"
        else:
            table = "cam"
        return _find(schema.TABLES.get(table, ()), leaf)

    # -- a loaded machine ---------------------------------------------------------
    def value(self, machine, parts):
        cam_dict = machine.get("cam")
        head_index = parts[0][1]
        if "cams" in machine:  # issue 38: cam.<name>.<key> (cam.speed is the shaft's)
            names = [c["name"] for c in machine["cams"]]
            if head_index is not None:
                cam_dict = machine["cams"][head_index]
            elif parts[1][0] in names and len(parts) > 2:
                cam_dict, parts = machine["cams"][names.index(parts[1][0])], parts[:1] + parts[2:]
        leaf, index = parts[1]
        if leaf == "phase":
            return cam_dict[leaf]
        if leaf == "segments":
            value = cam_dict["segments"][index][parts[2][0]]
            if len(parts) == 4:  # issue 27: cam.segments[i].end.v, .start.a, .points[k].s
                from camsim.cam.description import DERIVATIVE_KEYS

                name = parts[3][0]
                if parts[2][0] == "points":
                    point = value[parts[2][1]]
                    return point[name] if name in ("at", "s") else point.get(f"d{DERIVATIVE_KEYS[name]}")
                return value.get(DERIVATIVE_KEYS[name])
            return value
        if leaf in ("geometry", "compensation"):  # issue 14: cam.geometry.<key>[.<key>]; 27
            value = cam_dict[leaf]
            for name, _ in parts[2:]:
                value = value[name]
            return value
        return cam_dict[leaf]

    def paths(self, doc):
        from camsim.cam.arrangement import GEOMETRY_KEYS, MATERIAL_KEYS  # issue 14

        cam = doc.get("cam")

        def cam_paths(prefix: str, table, valid) -> list[str]:
            out = [f"{prefix}.{k}" for k in valid if k not in ("segments", "geometry", "speed", "start_angle")
                   or (prefix == "cam" and k in ("speed", "start_angle"))]
            out += [f"{prefix}.geometry.{k}" for k in GEOMETRY_KEYS if not k.endswith("_material")]
            out += [f"{prefix}.geometry.{m}.{k}" for m in ("cam_material", "follower_material") for k in MATERIAL_KEYS]
            if isinstance(table, dict) and isinstance(table.get("segments"), list):
                for i, _ in enumerate(table["segments"]):
                    out += [f"{prefix}.segments[{i}].{k}" for k in schema.keys("cam.segments")]
            return out

        if isinstance(cam, list):  # issue 38: [[cam]] tables, by name; cam.speed is the shaft's
            out = ["cam.speed", "cam.start_angle"]
            for name, row in _named_rows(cam).items():
                out += cam_paths(f"cam.{name}", row, schema.keys("cams"))
            return out
        return cam_paths("cam", cam, schema.keys("cam"))


@register
class _Camshaft(TableKind):
    """``camshaft.<key>``, ``camshaft.section.<cam>.<key>`` or ``camshaft.section[i].<key>`` (issue 38)."""

    head, example = "camshaft", 'camshaft.flywheel="0.4 kg*m^2"'

    def address(self, ctx, parts):
        valid = [k for k in schema.keys("camshaft") if k != "section"]
        if parts[0][1] is not None or len(parts) < 2:
            raise ctx.error("address a camshaft key as camshaft.<key>, e.g. camshaft.flywheel")
        leaf, leaf_index = parts[1]
        shaft = ctx.table(ctx.doc, "camshaft")
        if leaf != "section":
            if leaf_index is not None or len(parts) != 2 or leaf not in valid:
                raise ctx.unknown([f"camshaft.{k}" for k in valid], leaf)
            return Address(shaft, leaf, f"camshaft.{leaf}")
        rows = shaft.get("section")
        if not isinstance(rows, list):
            raise ctx.error("the file has no [[camshaft.section]]")
        section_keys = schema.keys("camshaft.section")
        if leaf_index is not None:
            index, rest = leaf_index, parts[2:]
            if index >= len(rows):
                raise ctx.error(f"no camshaft.section[{index}]: the file has {len(rows)}")
        else:
            if len(parts) < 3:
                raise ctx.error("address a section as camshaft.section.<cam>.<key>")
            cam = parts[2][0]
            found = [i for i, r in enumerate(rows) if isinstance(r, dict) and r.get("cam") == cam]
            if not found:
                existing = [str(r.get("cam")) for r in rows if isinstance(r, dict)]
                raise ctx.error(f"no section of cam '{cam}'; {_suggest(cam, existing)}")
            index, rest = found[0], parts[3:]
        if len(rest) != 1 or rest[0][1] is not None or rest[0][0] not in section_keys:
            raise ctx.unknown([f"camshaft.section.<cam>.{k}" for k in section_keys], rest[0][0] if rest else "")
        return Address(rows[index], rest[0][0], f"camshaft.section[{index}].{rest[0][0]}")

    def param(self, parts):
        if len(parts) >= 3 and parts[1][0] == "section":  # camshaft.section.<cam>.<key>, section[i].<key>
            return _find(schema.TABLES["camshaft.section"], parts[-1][0])
        return _find(schema.TABLES["camshaft"], parts[-1][0]) if len(parts) == 2 else None

    def value(self, machine, parts):
        if parts[1][0] == "section":
            rows = machine["camshaft"]["sections"]
            if parts[1][1] is not None:
                return rows[parts[1][1]][parts[2][0]]
            return next(r for r in rows if r["cam"] == parts[2][0])[parts[3][0]]
        return machine["camshaft"][parts[1][0]]

    def paths(self, doc):
        if not isinstance(doc.get("cam"), list):
            return []
        out = [f"camshaft.{k}" for k in schema.keys("camshaft") if k != "section"]
        shaft = doc.get("camshaft") if isinstance(doc.get("camshaft"), dict) else {}
        for row in shaft.get("section", []) if isinstance(shaft.get("section"), list) else []:
            if isinstance(row, dict) and isinstance(row.get("cam"), str):
                out += [f"camshaft.section.{row['cam']}.{k}" for k in schema.keys("camshaft.section") if k != "cam"]
        return out


@register
class _Clearance(TableKind):
    """``clearance.<name>.minimum`` (issue 38)."""

    head, example = "clearance", 'clearance.<name>.minimum="2 mm"'

    def address(self, ctx, parts):
        rows = ctx.doc.get("clearance")
        by_name = _named_rows(rows)
        if parts[0][1] is not None or len(parts) != 3 or parts[1][0] not in by_name or parts[2] != ("minimum", None):
            raise ctx.error("address a clearance as clearance.<name>.minimum"
                            + (f"; {_suggest(parts[1][0], list(by_name))}" if len(parts) > 1 and parts[1][0] not in by_name else ""))
        index = [i for i, r in enumerate(rows) if isinstance(r, dict) and r.get("name") == parts[1][0]][0]
        return Address(rows[index], "minimum", f"clearance[{index}].minimum")

    def param(self, parts):
        return _find(schema.TABLES["clearance"], parts[-1][0]) if len(parts) == 3 else None

    def value(self, machine, parts):
        return next(c for c in machine["clearances"] if c["name"] == parts[1][0])[parts[2][0]]

    def paths(self, doc):
        return [f"clearance.{name}.minimum" for name in _named_rows(doc.get("clearance"))]


# ---------------------------------------------------------------------- masses, elements, initial state
class _Rows(TableKind):
    """``<head>.<name>.<key>`` or ``<head>[i].<key>`` of an array of named tables."""

    #: The list in machine_to_dict's description.
    described: ClassVar[str]

    def valid(self, row: Mapping[str, Any]) -> tuple[str, ...]:
        raise NotImplementedError

    def address(self, ctx, parts):
        head, head_index = parts[0]
        rows = ctx.doc.get(head)
        if not isinstance(rows, list):
            raise ctx.error(f"the file has no [[{head}]]")
        if head_index is not None:
            if head_index >= len(rows) or not isinstance(rows[head_index], dict):
                raise ctx.error(f"no {head}[{head_index}]: the file has {len(rows)} (indices start at 0)")
            index, rest = head_index, parts[1:]
        else:
            row_name = parts[1][0]
            by_name = [i for i, r in enumerate(rows) if isinstance(r, dict) and r.get("name") == row_name]
            if parts[1][1] is not None or not by_name:
                raise ctx.error(f"no {head} named '{row_name}'; {_suggest(row_name, list(_named_rows(rows)))}")
            index, rest = by_name[0], parts[2:]
        row = rows[index]
        valid = self.valid(row)
        prefix = f"{head}[{index}]" if head_index is not None else f"{head}.{parts[1][0]}"
        if len(rest) == 2 and rest[0][1] is None and rest[1][1] is None and rest[0][0] in self.sub_tables(row):
            # a key of a table inside the row (a lash's side: element.<name>.upper.stiffness)
            name, leaf = rest[0][0], rest[1][0]
            sub_valid = self.sub_valid(row, name)
            if leaf not in sub_valid:
                raise ctx.unknown([f"{prefix}.{name}.{k}" for k in sub_valid], f"{prefix}.{name}.{leaf}")
            return Address(ctx.table(row, name, f"{head}[{index}].{name}"), leaf, f"{head}[{index}].{name}.{leaf}")
        if len(rest) != 1 or rest[0][1] is not None or rest[0][0] not in valid:
            raise ctx.unknown([f"{prefix}.{k}" for k in valid], f"{prefix}.{rest[0][0] if rest else ''}")
        return Address(row, rest[0][0], f"{head}[{index}].{rest[0][0]}")

    def sub_tables(self, row: Mapping[str, Any]) -> tuple[str, ...]:
        """Keys of ``row`` that hold a table of keys of their own (none by default)."""
        return ()

    def sub_valid(self, row: Mapping[str, Any], name: str) -> tuple[str, ...]:
        """The keys the table ``name`` inside ``row`` may hold."""
        return ()

    def value(self, machine, parts):
        rows = machine[self.described]
        if parts[0][1] is not None:
            row, leaf = rows[parts[0][1]], parts[1][0]
        else:
            row, leaf = next(r for r in rows if r["name"] == parts[1][0]), parts[2][0]
        return row[leaf]

    def paths(self, doc):
        out = []
        for name, row in _named_rows(doc.get(self.head)).items():
            out += [f"{self.head}.{name}.{k}" for k in self.valid(row) if k != "name"]
        return out


@register
class _Mass(_Rows):
    head, example, described = "mass", 'mass.M2.mass="1.7 lb"', "masses"

    def valid(self, row):
        return schema.keys("mass")

    def param(self, parts):
        return _find(schema.TABLES["mass"], parts[-1][0])


@register
class _Element(_Rows):
    head, example, described = "element", "element.seat.stiffness=9e6", "elements"

    def valid(self, row):
        kind = row.get("type")
        return tuple(p.key for p in element_kinds.COMMON_PARAMS) + (
            element_kinds.type_keys(kind) if isinstance(kind, str) else ())

    def param(self, parts):
        return schema.ELEMENT_PARAMS.get(parts[-1][0])

    # a lash's sides (spec §10): element.<name>.lower.<key>, element.<name>.upper.<key>
    def sub_tables(self, row):
        kind = row.get("type")
        if not isinstance(kind, str):
            return ()
        return tuple(p.key for cls in element_kinds.variants(kind) for p in cls.params if p.dimension == "law_table")

    def sub_valid(self, row, name):
        kind = row["type"]
        own = {p.key for cls in element_kinds.variants(kind) for p in cls.params}
        return tuple(k for k in element_kinds.type_keys(kind) if k not in own)

    def value(self, machine, parts):
        rest = parts[1:] if parts[0][1] is not None else parts[2:]
        if len(rest) == 2:  # a side's key: the description's "sides"
            rows = machine[self.described]
            row = rows[parts[0][1]] if parts[0][1] is not None else next(r for r in rows if r["name"] == parts[1][0])
            return row["sides"][rest[0][0]][rest[1][0]]
        return super().value(machine, parts)

    def paths(self, doc):
        out = super().paths(doc)
        for name, row in _named_rows(doc.get(self.head)).items():
            for table in self.sub_tables(row):
                if isinstance(row.get(table), dict):
                    out += [f"{self.head}.{name}.{table}.{k}" for k in self.sub_valid(row, table)]
        return out


@register
class _Initial(TableKind):
    """``initial.<mass>.<key>``."""

    head, example = "initial", 'initial.M3.velocity="-0.2 m/s"'

    def address(self, ctx, parts):
        mass_name = parts[1][0]
        masses = list(_named_rows(ctx.doc.get("mass")))
        if parts[0][1] is not None or parts[1][1] is not None:
            raise ctx.error("address initial conditions as initial.<mass>.<key>")
        if mass_name not in masses:
            raise ctx.error(f"no mass named '{mass_name}'; {_suggest(mass_name, masses)}")
        rest, valid = parts[2:], schema.keys("initial")
        if len(rest) != 1 or rest[0][1] is not None or rest[0][0] not in valid:
            raise ctx.unknown([f"initial.{mass_name}.{k}" for k in valid], f"initial.{mass_name}.{rest[0][0] if rest else ''}")
        initial = ctx.table(ctx.doc, "initial", super_table=True)
        entry = ctx.table(initial, mass_name, f"initial.{mass_name}")
        return Address(entry, rest[0][0], f"initial.{mass_name}.{rest[0][0]}")

    def param(self, parts):
        return _find(schema.TABLES["initial"], parts[-1][0])

    def value(self, machine, parts):
        return next(r for r in machine["initial"] if r["mass"] == parts[1][0])[parts[2][0]]

    def paths(self, doc):
        cam = doc.get("cam")
        rows = cam if isinstance(cam, list) else [cam]
        driven = {r.get("drives") for r in rows if isinstance(r, dict)}
        return [f"initial.{name}.{k}" for name in _named_rows(doc.get("mass")) if name not in driven
                for k in schema.keys("initial")]


@register
class _Load(TableKind):
    """``load.<name>.<key>`` or ``load[i].<key>``; ``.segments[i].<key>`` (``.start.v``, ``.points[k].s``) and
    ``.sine.<key>`` (issue 43)."""

    head, example = "load", 'load.<name>.force="150 N"'
    _TOP = ("name", "on", "force", "base", "table", "cam")

    def _rest(self, parts: list[Part]) -> list[Part]:
        return parts[1:] if parts[0][1] is not None else parts[2:]

    def address(self, ctx, parts):
        rows = ctx.doc.get("load")
        if not isinstance(rows, list):
            raise ctx.error("the file has no [[load]]")
        if parts[0][1] is not None:
            index = parts[0][1]
            if index >= len(rows) or not isinstance(rows[index], dict):
                raise ctx.error(f"no load[{index}]: the file has {len(rows)} (indices start at 0)")
        else:
            found = [i for i, r in enumerate(rows) if isinstance(r, dict) and r.get("name") == parts[1][0]]
            if parts[1][1] is not None or not found:
                raise ctx.error(f"no load named '{parts[1][0]}'; {_suggest(parts[1][0], list(_named_rows(rows)))}")
            index = found[0]
        row, rest, prefix = rows[index], self._rest(parts), f"load[{index}]"
        if not rest:
            raise ctx.error(f"name a key of the load, e.g. {self.example}")
        (leaf, leaf_index), more = rest[0], rest[1:]
        if leaf == "sine" and leaf_index is None and len(more) == 1 and more[0][1] is None:
            if more[0][0] not in schema.keys("load.sine"):
                raise ctx.unknown([f"{prefix}.sine.{k}" for k in schema.keys("load.sine")], more[0][0])
            return Address(ctx.table(row, "sine", f"{prefix}.sine"), more[0][0], f"{prefix}.sine.{more[0][0]}")
        if leaf == "segments" and leaf_index is not None and more:
            segments = row.get("segments")
            if not isinstance(segments, list) or leaf_index >= len(segments) or not isinstance(segments[leaf_index], dict):
                count = len(segments) if isinstance(segments, list) else 0
                raise ctx.error(f"no segment {leaf_index}: the load has {count} (indices start at 0)")
            return self._segment(ctx, segments[leaf_index], f"{prefix}.segments[{leaf_index}]", more)
        if leaf not in self._TOP or leaf_index is not None or more:
            raise ctx.unknown([f"{prefix}.{k}" for k in self._TOP] + [f"{prefix}.segments[0].change",
                                                                       f"{prefix}.sine.amplitude"], ctx.key)
        return Address(row, leaf, f"{prefix}.{leaf}")

    def _segment(self, ctx, seg: dict, where: str, more: list[Part]) -> Address:
        (name, index) = more[0]
        if len(more) == 1 and index is None:
            if name not in schema.keys("load.segments"):
                raise ctx.unknown([f"{where}.{k}" for k in schema.keys("load.segments")], name)
            return Address(seg, name, f"{where}.{name}")
        if len(more) == 2 and more[1][1] is None:
            leaf = more[1][0]
            if name in ("start", "end") and index is None and leaf in schema.keys("load.segments.end"):
                return Address(ctx.table(seg, name, f"{where}.{name}"), leaf, f"{where}.{name}.{leaf}")
            points = seg.get("points")
            if name == "points" and index is not None and isinstance(points, list) and index < len(points) \
                    and isinstance(points[index], dict) and leaf in schema.keys("load.segments.points"):
                return Address(points[index], leaf, f"{where}.points[{index}].{leaf}")
        raise ctx.error(f"address a segment key, e.g. {where}.change, {where}.end.v or {where}.points[0].s")

    def param(self, parts):
        names = [n for n, _ in self._rest(parts)]
        if len(names) == 1:
            return _find(schema.TABLES["load"], names[0])
        table = {("sine", 2): "load.sine", ("segments", 2): "load.segments"}.get((names[0], len(names)))
        if names[0] == "segments" and len(names) == 3:
            table = "load.segments.points" if names[1] == "points" else "load.segments.end"
        return _find(schema.TABLES[table], names[-1]) if table else None

    def value(self, machine, parts):
        rows = machine["loads"]
        row = rows[parts[0][1]] if parts[0][1] is not None else next(r for r in rows if r["name"] == parts[1][0])
        rest = self._rest(parts)
        (leaf, index), more = rest[0], rest[1:]
        if leaf == "sine":
            return row["sine"][more[0][0]]
        if leaf == "segments":
            seg = row["segments"][index]
            if len(more) == 1:
                return seg[more[0][0]]
            from camsim.cam.description import DERIVATIVE_KEYS

            name, k = more[1][0], more[0][1]
            if more[0][0] == "points":
                point = seg["points"][k]
                return point[name] if name in ("at", "s") else point.get(f"d{DERIVATIVE_KEYS[name]}")
            return seg[more[0][0]].get(DERIVATIVE_KEYS[name])
        return row[leaf]

    def paths(self, doc):
        out = []
        for name, row in _named_rows(doc.get("load")).items():
            wanted = {"on": True, "force": "force" in row, "base": "segments" in row,
                      "cam": "segments" in row or "table" in row}
            out += [f"load.{name}.{k}" for k, offered in wanted.items() if offered]
            segments = row.get("segments")
            for i, _ in enumerate(segments if isinstance(segments, list) else ()):
                out += [f"load.{name}.segments[{i}].{k}" for k in schema.keys("load.segments")
                        if k not in ("start", "end", "points")]
            if isinstance(row.get("sine"), dict):
                out += [f"load.{name}.sine.{k}" for k in schema.keys("load.sine")]
        return out


# ---------------------------------------------------------------------- the entry points
def address(doc: Any, key: str, source: str = "<string>", make_table: TableFactory = _dict_table) -> Address:
    """Where ``key`` lands in the parsed document ``doc`` (a dict, or a tomlkit document edited in place).

    Tables the path needs and the document lacks are made with ``make_table``. Raises
    :class:`MachineFileError` naming the key, with the nearest valid key, for a path the
    schema or the document does not have.
    """
    parts = parse(key.strip(), source)
    ctx = _Context(doc, key.strip(), source, make_table)
    head = parts[0][0]
    kind = KINDS.get(head)
    if kind is None:
        raise ctx.unknown(schema.keys("top"), head)
    if len(parts) == 1 and head != "schema":
        raise ctx.error(f"name a key inside [{head}], e.g. {kind.example}")
    return kind.address(ctx, parts)


def param(key: str) -> Param | None:
    """The :class:`Param` (dimension, SI unit) a key path names, or None (unknown or malformed).

    Needs no document: ``cam.speed``, ``cam.segments[2].lift``, ``mass.M2.mass``,
    ``element.seat.stiffness``, ``simulation.cycles``, ``initial.M3.velocity``,
    ``mass[1].mass``, ``element[3].gap``, ``cam.feed.phase``, ``clearance.gap.minimum``.
    """
    parts = try_parse(key)
    if parts is None or len(parts) < 2 and parts[0][0] != "schema":
        return None
    kind = KINDS.get(parts[0][0])
    return kind.param(parts) if kind is not None else None


def unit(key: str) -> str:
    """SI unit of a key path's value (``""`` for numbers, strings and unknown keys)."""
    p = param(key)
    return p.unit if p is not None else ""


def machine_value(described: Mapping[str, Any], key: str) -> Any:
    """The SI value of ``key`` in a machine's description (:func:`~camsim.machine.loader.machine_to_dict`),
    or None when the machine has no such value."""
    parts = try_parse(key)
    if parts is None or len(parts) < 2 or parts[0][0] not in KINDS:
        return None
    try:
        return KINDS[parts[0][0]].value(described, parts)
    except (KeyError, IndexError, StopIteration, TypeError, AttributeError):
        return None


def document_paths(doc: Mapping[str, Any]) -> list[str]:
    """Every key path of ``doc``, keys the schema allows and the file leaves at their default included."""
    out: list[str] = []
    for kind in KINDS.values():
        out += kind.paths(doc)
    return out



class _Absent(Exception):
    """A table the path needs is not in the document (so neither is the value)."""


def _no_table(super_table: bool = False) -> dict:
    raise _Absent

"""Reading the camshaft of a machine file: ``[cam]`` or ``[[cam]]``, ``[camshaft]``, ``[[clearance]]``.

Spec §9. A file holds one ``[cam]`` table (its node is ``cam``; it means exactly what it
always meant) or several ``[[cam]]`` tables on one shaft, each with a ``name`` (its node) and
a ``phase``; the shaft's ``speed`` and ``start_angle`` are given once, in ``[camshaft]`` or
in the first ``[[cam]]``. ``[camshaft]`` also sizes the flywheel (``speed_fluctuation``) and
describes the shaft's own dynamics (``model = "dynamic"``: the drive, its inertia and the
torsional sections to the cams). ``[[clearance]]`` pairs name two parts (a mass or a cam
node and the offset of its edge) whose distance is checked over the cycle.
"""

from __future__ import annotations

from camsim.elements import CAM, GROUND
from camsim.machine import schema
from camsim.machine.camreader import CAM_KEYS, CamReader
from camsim.machine.description import (
    Cam,
    Camshaft,
    CamshaftSection,
    Clearance,
    ClearancePart,
)
from camsim.machine.reading import _fmt, _suggest

CAMSHAFT_KEYS = schema.keys("camshaft")
SECTION_KEYS = schema.keys("camshaft.section")
CLEARANCE_KEYS = schema.keys("clearance")


class ShaftReader(CamReader):
    """The cam tables, the camshaft and the clearances of a document."""

    # -- the cams ------------------------------------------------------------------
    def cam_tables(self, doc: dict, mass_names: list[str]) -> tuple[list[Cam], Camshaft | None, bool]:
        """(the cams, the camshaft or None, whether the file uses ``[[cam]]`` tables)."""
        value = doc.get("cam")
        shaft_table = self.table(doc, "camshaft", "camshaft")
        if shaft_table is not None:
            self.check_keys(shaft_table, CAMSHAFT_KEYS, "camshaft")
        if value is None:
            if shaft_table is not None:
                raise self.error("camshaft", "a [camshaft] needs cams: add a [cam] table or [[cam]] tables")
            return [], None, False
        if isinstance(value, dict):
            cam = self.cam(value, mass_names)
            if shaft_table is not None:
                for key in ("speed", "start_angle"):
                    if key in shaft_table:
                        raise self.error(f"camshaft.{key}", f"the [cam] table gives the shaft's {key}: remove "
                                         f"camshaft.{key} (it belongs in [camshaft] with [[cam]] tables)")
            shaft = self.camshaft(shaft_table, cam.speed, cam.start_angle, [cam]) if shaft_table is not None else None
            return [cam], shaft, False
        if not isinstance(value, list) or not value or not all(isinstance(r, dict) for r in value):
            raise self.error("cam", "expected a [cam] table or [[cam]] tables")
        first = value[0]
        shaft_table = shaft_table or {}
        for key in ("speed", "start_angle"):
            if key in shaft_table and key in first:
                raise self.error(f"cam[0].{key}", f"the shaft's {key} is given twice (camshaft.{key}); keep one")
        for i, row in enumerate(value[1:], start=1):
            for key in ("speed", "start_angle"):
                if key in row:
                    raise self.error(f"cam[{i}].{key}", f"the cams share the shaft's {key}: give it once, in "
                                     "[camshaft] (or in the first [[cam]])")
        if "speed" in shaft_table:
            speed = self.shaft_speed(shaft_table, "camshaft")
        elif "speed" in first:
            speed = self.shaft_speed(first, "cam[0]")
        else:
            raise self.error("camshaft.speed", 'missing required key: the shaft\'s speed (e.g. speed = "120 rpm" '
                             "in [camshaft])")
        where = ("camshaft", shaft_table) if "start_angle" in shaft_table else ("cam[0]", first)
        start = self.quantity(where[1], "start_angle", where[0], "angle", default=0.0, bare_unit="deg")
        cams: list[Cam] = []
        for i, row in enumerate(value):
            cam = self.cam(row, mass_names, f"cam[{i}]", shaft=(speed, start))
            self.check_cam_name(cam.name, i, mass_names, cams)
            if cam.drives is not None:
                other = next((c for c in cams if c.drives == cam.drives), None)
                if other is not None:
                    raise self.error(f"cam[{i}].drives", f"{cam.drives} is driven by cam {other.name} already: a "
                                     "mass follows one cam at most")
            cams.append(cam)
        self.cam_path = "cam"
        shaft = self.camshaft(shaft_table, speed, start, cams)
        return cams, shaft, True

    def check_cam_name(self, name: str, index: int, mass_names: list[str], cams: list[Cam]) -> None:
        """A ``[[cam]]`` name is a node name: unique among masses, cams and ``ground``."""
        where = f"cam[{index}].name"
        if not name.strip():
            raise self.error(where, "must not be empty")
        if name == GROUND or name in mass_names:
            raise self.error(where, f'"{name}" is already a node ({"ground" if name == GROUND else "a mass"}); '
                             "names are unique among masses, cams and ground")
        if any(c.name == name for c in cams):
            raise self.error(where, f'duplicate cam name "{name}"')
        if name in CAM_KEYS or name in ("name", "phase"):
            raise self.error(where, f'"{name}" is a key of a cam table; name the cam otherwise (it is addressed '
                             f"as cam.<name>.<key>)")
        # what a name may hold is checked once for every table (camsim.machine.names, issue 45)

    # -- the camshaft --------------------------------------------------------------
    def camshaft(self, table: dict, speed: float, start: float, cams: list[Cam]) -> Camshaft:
        """``[camshaft]`` (its speed and start angle already read, from it or a cam)."""
        path = "camshaft"
        model = self.choice(table, "model", path, ("rigid", "dynamic"), required=False) or "rigid"
        cs = self.number(table, "speed_fluctuation", path, minimum=0.0, strict=True, maximum=1.0)
        inertia = self.quantity(table, "inertia", path, "inertia", default=0.0, minimum=0.0)
        flywheel = self.quantity(table, "flywheel", path, "inertia", default=0.0, minimum=0.0)
        drive = self.choice(table, "drive", path, ("speed", "motor"), required=False) or "speed"
        k_d = self.quantity(table, "drive_stiffness", path, "torsional_stiffness", minimum=0.0, strict=True)
        c_d = self.quantity(table, "drive_damping", path, "torsional_damping", default=0.0, minimum=0.0)
        stall = self.quantity(table, "stall_torque", path, "torque", minimum=0.0, strict=True)
        no_load = self.quantity(table, "no_load_speed", path, "angular_speed", minimum=0.0, strict=True)
        sections = self.sections(table, [c.name for c in cams])
        if model == "dynamic":
            if not inertia + flywheel > 0.0:
                raise self.error("camshaft.inertia", 'model = "dynamic" needs the drive side\'s inertia > 0 '
                                 "(camshaft.inertia and/or camshaft.flywheel)")
            if drive == "speed" and k_d is None:
                raise self.error("camshaft.drive_stiffness", 'missing required key: drive = "speed" drives the '
                                 'shaft through a compliance (e.g. drive_stiffness = "2e4 N*m/rad")')
            if drive == "motor":
                if stall is None:
                    raise self.error("camshaft.stall_torque", 'missing required key for drive = "motor"')
                if no_load is None:
                    raise self.error("camshaft.no_load_speed", 'missing required key for drive = "motor"')
                if not no_load > speed:
                    raise self.error("camshaft.no_load_speed", f"must exceed the shaft's speed ({speed:.6g} rad/s): "
                                     "the motor runs between stall and no load")
        for key in ("drive_stiffness", "drive_damping") if drive == "motor" else ("stall_torque", "no_load_speed"):
            if key in table:
                raise self.error(f"camshaft.{key}", f'not used with drive = "{drive}"')
        return Camshaft(speed=speed, start_angle=start, model=model, speed_fluctuation=cs, inertia=inertia,
                        flywheel=flywheel, drive=drive, drive_stiffness=k_d, drive_damping=c_d, stall_torque=stall,
                        no_load_speed=no_load, sections=tuple(sections))

    def sections(self, table: dict, cam_names: list[str]) -> list[CamshaftSection]:
        rows = self.rows(table, "section", "camshaft.section")
        out: list[CamshaftSection] = []
        for i, row in enumerate(rows):
            path = f"camshaft.section[{i}]"
            self.check_keys(row, SECTION_KEYS, path)
            cam = self.string(row, "cam", path, required=True)
            if cam not in cam_names:
                raise self.error(f"{path}.cam", f'"{cam}" is not a cam; {_suggest(cam, cam_names)}')
            if any(s.cam == cam for s in out):
                raise self.error(f"{path}.cam", f"cam {cam} has a section already (one per cam)")
            out.append(CamshaftSection(
                cam=cam,
                stiffness=self.quantity(row, "stiffness", path, "torsional_stiffness", required=True, minimum=0.0,
                                        strict=True, example='"5e4 N*m/rad"'),
                inertia=self.quantity(row, "inertia", path, "inertia", required=True, minimum=0.0, strict=True,
                                      example='"2e-3 kg*m^2"'),
                damping_ratio=self.number(row, "damping_ratio", path, default=0.0, minimum=0.0),
            ))
        return out

    # -- clearances ----------------------------------------------------------------
    def clearances(self, doc: dict, mass_names: list[str], cams: list[Cam]) -> list[Clearance]:
        rows = self.rows(doc, "clearance", "clearance")
        nodes = [*mass_names, *(c.name for c in cams)]
        out: list[Clearance] = []
        for i, row in enumerate(rows):
            path = f"clearance[{i}]"
            self.check_keys(row, CLEARANCE_KEYS, path)
            name = self.string(row, "name", path, required=True)
            if not name.strip():
                raise self.error(f"{path}.name", "must not be empty")
            if any(c.name == name for c in out):
                raise self.error(f"{path}.name", f'duplicate clearance name "{name}"')
            between = row.get("between")
            if between is None:
                raise self.error(f"{path}.between", 'missing required key (e.g. between = ["M3", { part = "M5", '
                                 'offset = "12 mm" }])')
            if not isinstance(between, list) or len(between) != 2:
                raise self.error(f"{path}.between", f"expected two parts [A, B], got {_fmt(between)}")
            parts = [self.part(entry, f"{path}.between[{k}]", nodes) for k, entry in enumerate(between)]
            if parts[0].node == parts[1].node:
                raise self.error(f"{path}.between", f'both parts are "{parts[0].node}": a clearance is between two')
            minimum = self.quantity(row, "minimum", path, "length", default=0.0)
            out.append(Clearance(name=name, a=parts[0], b=parts[1], minimum=minimum))
        return out

    def part(self, entry, path: str, nodes: list[str]) -> ClearancePart:
        """One side of a clearance: ``"M3"`` or ``{ part = "M3", offset = "5 mm" }``."""
        if isinstance(entry, str):
            node, offset = entry, 0.0
        elif isinstance(entry, dict):
            self.check_keys(entry, ("part", "offset"), path)
            node = self.string(entry, "part", path, required=True)
            offset = self.quantity(entry, "offset", path, "length", default=0.0)
        else:
            raise self.error(path, f'expected a node name or {{ part = "M3", offset = "5 mm" }}, got {_fmt(entry)}')
        if node not in nodes:
            raise self.error(path, f'"{node}" is not a mass or a cam; {_suggest(node, nodes)}')
        return ClearancePart(node=node, offset=offset)


__all__ = ["ShaftReader", "CAMSHAFT_KEYS", "SECTION_KEYS", "CLEARANCE_KEYS", "CAM"]

"""Checking a parsed machine document and building the :class:`~camsim.machine.description.Machine` in SI.

Every value is parsed with :func:`camsim.units.to_si` and checked for its dimension and
range against the schema; every problem raises :class:`camsim.errors.MachineFileError`
naming the file and the key path (``element[3].stiffness``, ``cam.segments[2].lift``) with a
one-line message. :mod:`camsim.machine.loader` is the entry point.
"""

from __future__ import annotations

import csv
import difflib
import math
import re
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from camsim import elements as element_kinds
from camsim.machine import schema
from camsim.elements import CAM, FIXED_NODES, GROUND, Damping, Element, Param
from camsim.errors import MachineFileError
from camsim.machine.description import (
    DERIVATIVE_KEYS,
    LAWS,
    SYNTHESIS_LAWS,
    Compensation,
    SegmentPoint,
    MOTIONS,
    STANDARD_GRAVITY,
    Cam,
    CamTable,
    InitialCondition,
    Machine,
    Mass,
    Segment,
    Simulation,
)
from camsim.machine.materials import MaterialKeys
from camsim.units import QuantityError, to_si, ureg

# --------------------------------------------------------------------------------------
# Which keys each table may hold: the schema (camsim/machine/schema.py and the element kinds)
# --------------------------------------------------------------------------------------
TOP_KEYS = schema.keys("top")
MACHINE_KEYS = schema.keys("machine")
CAM_KEYS = schema.keys("cam")
SEGMENT_KEYS = schema.keys("cam.segments")
MASS_KEYS = schema.keys("mass")
SIMULATION_KEYS = schema.keys("simulation")
INITIAL_KEYS = schema.keys("initial")
ELEMENT_COMMON_KEYS = tuple(p.key for p in element_kinds.COMMON_PARAMS)
_DAMPING_KEYS = ("damping", "damping_ratio", "reference_mass")

#: Tolerance on the sum of segment durations [deg].
DURATION_TOLERANCE_DEG = 1e-6
#: Relative tolerance on the net lift of a segment table (of the total rise).
LIFT_TOLERANCE = 1e-9

_TABLE_COLUMNS = ("angle", "displacement", "velocity", "acceleration")
#: The machine-file schema this loader reads (top-level ``schema = 1``).
SCHEMA_VERSION = 1


def _suggest(word: str, choices: Sequence[str]) -> str:
    """``"did you mean 'x'?"`` or a list of the valid choices."""
    close = difflib.get_close_matches(word, list(choices), n=1, cutoff=0.6)
    if close:
        return f"did you mean '{close[0]}'?"
    return "valid: " + ", ".join(choices) if choices else "there is none"


# --------------------------------------------------------------------------------------
# Validation
# --------------------------------------------------------------------------------------
def _fmt(value: Any) -> str:
    """A value as written in TOML, for messages."""
    if isinstance(value, str):
        return f'"{value}"'
    if isinstance(value, bool):
        return "true" if value else "false"
    return repr(value)


def _si_text(value: float, unit: str) -> str:
    return f"{value:.6g} {unit}".strip()


def _has_unit(value: Any) -> bool:
    """True if ``value`` is a string that carries a unit (``"4.4 deg"``; not ``"50"``)."""
    if not isinstance(value, str):
        return False
    try:
        quantity = ureg.Quantity(value.strip())
    except Exception:  # not parsable: let to_si produce the message
        return True
    return not getattr(quantity, "unitless", True)


def _is_angular(value: str) -> bool:
    """True if the unit of ``value`` contains an angle (rpm, rad/s, deg/s; not Hz, 1/s)."""
    try:
        return "radian" in dict(ureg.Quantity(value.strip()).to_root_units()._units)
    except Exception:  # unparsable: to_si reports it
        return True


def _angle_to_si(value: Any) -> float:
    """An angle [rad]; a bare number (or a number in a string) means degrees.

    Works around pint treating the radian as dimensionless: ``"3.1 rad"`` must stay
    radians rather than be re-read as degrees.
    """
    if _has_unit(value):
        return to_si(value, "angle")
    return to_si(value, "angle", bare_unit="deg")


class _Validator(MaterialKeys):
    """Walk a parsed document and build the Machine, raising on the first problem."""

    def __init__(self, source: str, base_dir: Path):
        self.source = source
        self.base_dir = base_dir
        self.materials: dict = {}  # the file's [[material]] tables (issue 39)

    # -- helpers ------------------------------------------------------------------
    def error(self, path: str, message: str) -> MachineFileError:
        return MachineFileError(self.source, path, message)

    def check_keys(self, table: dict, valid: Sequence[str], path: str, what: str = "") -> None:
        for key in table:
            if key not in valid:
                where = f"{path}.{key}" if path else key
                suffix = f" {what}" if what else ""
                raise self.error(where, f"unknown key{suffix}; {_suggest(key, valid)}")

    def table(self, parent: dict, key: str, path: str, required: bool = False) -> dict | None:
        value = parent.get(key)
        if value is None:
            if required:
                raise self.error(path, f"missing required table [{path}]")
            return None
        if not isinstance(value, dict):
            raise self.error(path, f"expected a table [{path}], got {_fmt(value)}")
        return value

    def rows(self, parent: dict, key: str, path: str) -> list[dict]:
        value = parent.get(key)
        if value is None:
            return []
        if not isinstance(value, list) or not all(isinstance(r, dict) for r in value):
            raise self.error(path, f"expected an array of tables ([[{key}]])")
        return value

    def quantity(
        self,
        table: dict,
        key: str,
        path: str,
        dimension: str,
        *,
        required: bool = False,
        default: float | None = None,
        bare_unit: str | None = None,
        minimum: float | None = None,
        strict: bool = False,
        example: str = "",
    ) -> float | None:
        """Read ``table[key]`` as a quantity of ``dimension`` in SI, checked against a minimum."""
        where = f"{path}.{key}"
        if key not in table:
            if required:
                hint = f" (e.g. {key} = {example})" if example else ""
                raise self.error(where, f"missing required key{hint}")
            return default
        value = table[key]
        try:
            if dimension == "angle" and bare_unit == "deg":
                number = _angle_to_si(value)
            else:
                number = to_si(value, dimension, bare_unit=bare_unit)
        except QuantityError as exc:
            raise self.error(where, str(exc)) from None
        self.check_min(number, minimum, strict, where, value)
        return number

    def number(
        self,
        table: dict,
        key: str,
        path: str,
        *,
        required: bool = False,
        default: float | None = None,
        minimum: float | None = None,
        strict: bool = False,
        maximum: float | None = None,
    ) -> float | None:
        """Read a dimensionless number (int, float or a string such as ``"6 %"``)."""
        where = f"{path}.{key}"
        if key not in table:
            if required:
                raise self.error(where, "missing required key (a number)")
            return default
        value = table[key]
        if isinstance(value, (int, float)) and not isinstance(value, bool):
            number = float(value)
            if not math.isfinite(number):
                raise self.error(where, f"expected a finite number, got {_fmt(value)}")
        else:
            try:
                number = to_si(value, "dimensionless")
            except QuantityError:
                raise self.error(where, f"expected a number, got {_fmt(value)}") from None
        self.check_min(number, minimum, strict, where, value)
        if maximum is not None and number > maximum:
            raise self.error(where, f"must be at most {maximum:g}, got {_fmt(value)}")
        return number

    def integer(self, table: dict, key: str, path: str, default: int, minimum: int) -> int:
        where = f"{path}.{key}"
        if key not in table:
            return default
        value = table[key]
        if isinstance(value, bool) or not isinstance(value, int):
            raise self.error(where, f"expected a whole number, got {_fmt(value)}")
        if value < minimum:
            raise self.error(where, f"must be at least {minimum}, got {value}")
        return value

    def string(self, table: dict, key: str, path: str, *, required: bool = False) -> str | None:
        where = f"{path}.{key}"
        if key not in table:
            if required:
                raise self.error(where, "missing required key (a string)")
            return None
        value = table[key]
        if not isinstance(value, str):
            raise self.error(where, f"expected a string, got {_fmt(value)}")
        return value

    def choice(self, table: dict, key: str, path: str, choices: Sequence[str], *, required: bool) -> str | None:
        value = self.string(table, key, path, required=required)
        if value is not None and value not in choices:
            raise self.error(f"{path}.{key}", f'unknown {key} "{value}"; {_suggest(value, choices)}')
        return value

    def check_min(self, number: float, minimum: float | None, strict: bool, where: str, value: Any) -> None:
        if minimum is None:
            return
        if strict and not number > minimum:
            raise self.error(where, f"must be greater than {minimum:g}, got {_fmt(value)}")
        if not strict and number < minimum:
            raise self.error(where, f"must not be negative, got {_fmt(value)}" if minimum == 0
                             else f"must be at least {minimum:g}, got {_fmt(value)}")

    # -- document -----------------------------------------------------------------
    def machine(self, doc: dict) -> Machine:
        self.check_keys(doc, TOP_KEYS, "")
        if "schema" not in doc:
            raise self.error("schema", f"missing required key (write schema = {SCHEMA_VERSION} at the top)")
        schema = doc["schema"]
        if isinstance(schema, bool) or schema != SCHEMA_VERSION:
            raise self.error("schema", f"this camsim reads schema {SCHEMA_VERSION}, got {_fmt(schema)}")
        head = self.table(doc, "machine", "machine", required=True)
        self.check_keys(head, MACHINE_KEYS, "machine")
        name = self.string(head, "name", "machine", required=True)
        if not name.strip():
            raise self.error("machine.name", "must not be empty")
        self.string(head, "description", "machine")

        self.materials = self.material_tables(doc)  # issue 39: [[material]]
        masses = self.masses(doc)
        mass_names = [m.name for m in masses]
        cam_table = self.table(doc, "cam", "cam")
        cam = self.cam(cam_table, mass_names) if cam_table is not None else None
        elements = self.elements(doc, mass_names, masses, cam)
        simulation = self.simulation(doc, cam)
        initial = self.initial(doc, mass_names, cam)
        self.connectivity(masses, elements, cam)
        elements = self.distributed(elements, masses, cam, simulation, initial)  # issue 39: rods
        return Machine(
            name=name,
            cam=cam,
            masses=tuple(masses),
            elements=tuple(elements),
            simulation=simulation,
            initial=tuple(initial),
            source=self.source,
        )

    # -- cam ----------------------------------------------------------------------
    def cam(self, table: dict, mass_names: list[str]) -> Cam:
        self.check_keys(table, CAM_KEYS, "cam")
        speed = self.quantity(table, "speed", "cam", "angular_speed", required=True, minimum=0.0,
                              strict=True, example='"120 rpm"')
        value = table.get("speed")
        if _has_unit(value) and not _is_angular(value):
            raise self.error("cam.speed", f'expected an angular speed such as "120 rpm" or "12.57 rad/s", '
                             f"got {_fmt(value)} (a frequency without an angle unit is ambiguous: "
                             "pint would read 1 Hz as 1 rad/s)")
        ratio = self.number(table, "ratio", "cam", default=1.0, minimum=0.0, strict=True)
        arm = self.quantity(table, "arm", "cam", "length", minimum=0.0, strict=True)
        start = self.quantity(table, "start_angle", "cam", "angle", default=0.0, bare_unit="deg")
        drives = self.string(table, "drives", "cam")
        if drives is not None and drives not in mass_names:
            raise self.error("cam.drives", f'"{drives}" is not a mass; {_suggest(drives, mass_names)}')
        has_segments, has_table = "segments" in table, "table" in table
        if has_segments and has_table:
            raise self.error("cam.table", "give either cam.segments or cam.table, not both")
        if not has_segments and not has_table:
            raise self.error("cam.segments", "missing required key: give cam.segments (a segment table) "
                             "or cam.table (a CSV profile)")
        segments: tuple[Segment, ...] = ()
        profile = None
        if has_segments:
            segments = self.segments(table["segments"], arm, speed)
        else:
            profile = self.cam_table(table["table"], arm)
        geometry = None
        if "geometry" in table:  # issue 14: [cam.geometry]
            from camsim.cam.arrangement import parse_geometry

            geometry = parse_geometry(table["geometry"], self.source, cam_arm=arm, materials=self.materials)
        compensation = None
        if "compensation" in table:  # issue 27
            compensation = self.compensation(table["compensation"], speed, drives, mass_names)
        cam = Cam(speed=speed, segments=segments, table=profile, ratio=ratio, arm=arm,
                  drives=drives, start_angle=start, geometry=geometry, compensation=compensation)
        if any(s.law in SYNTHESIS_LAWS for s in segments):  # issue 27: solve now, errors name the segment
            from camsim.cam.program import CamProgram
            from camsim.cam.synthesis import SynthesisError

            try:
                CamProgram(cam)
            except SynthesisError as exc:
                key = f"cam.segments[{exc.segment}]" + (f".{exc.key}" if exc.key else "")
                raise self.error(key, exc.message) from None
        return cam

    def lift(self, row: dict, path: str, arm: float | None) -> float:
        """A lift at the roller [m]: a length, or an angle times the follower arm."""
        value = row["lift"]
        where = f"{path}.lift"
        try:
            return to_si(value, "length")
        except QuantityError as length_error:
            if _has_unit(value) and not str(length_error).startswith('"mil"'):
                try:
                    angle = to_si(value, "angle")
                except QuantityError:
                    pass
                else:
                    if arm is None:
                        raise self.error(where, f"an angular lift {_fmt(value)} needs cam.arm "
                                         "(the follower arm that turns it into arc length)") from None
                    return arm * angle
            message = str(length_error)
            if arm is not None:
                message = message.replace("expected [length]", "expected [length] or [angle]", 1)
            raise self.error(where, message) from None

    # -- issue 27: motion synthesis ------------------------------------------------------
    _SYNTHESIS_KEYS = {"continuity": ("polynomial",), "start": ("polynomial", "spline"),
                       "end": ("polynomial", "spline"), "points": ("polynomial", "spline"),
                       "velocity": ("constant-velocity",), "degree": ("spline",)}
    _DERIVATIVE_DIMENSIONS = {1: "velocity", 2: "acceleration", 3: "jerk", 4: "length/time^4",
                              5: "length/time^5", 6: "length/time^6"}

    def synthesis_keys(self, row: dict, path: str, law: str | None, duration: float, speed: float) -> dict:
        """The keys of a polynomial, constant-velocity or spline segment, in SI (Segment fields)."""
        out: dict[str, Any] = {}
        for key, laws in self._SYNTHESIS_KEYS.items():
            if key in row and law not in laws:
                takes = " or ".join(f'law = "{x}"' for x in laws)
                raise self.error(f"{path}.{key}", f"only used with {takes}")
        if "continuity" in row:
            out["continuity"] = self.integer(row, "continuity", path, 3, 0)
        if "degree" in row:
            degree = self.integer(row, "degree", path, 5, 3)
            if degree % 2 == 0:
                raise self.error(f"{path}.degree", f"must be odd (3, 5, 7, …), got {degree}")
            out["degree"] = degree
        if "velocity" in row:
            out["velocity"] = self.quantity(row, "velocity", path, "velocity", minimum=0.0, strict=True)
        for side in ("start", "end"):
            if side in row:
                table = row[side]
                where = f"{path}.{side}"
                if not isinstance(table, dict):
                    raise self.error(where, f"expected a table {{ v = ..., a = ... }}, got {_fmt(table)}")
                self.check_keys(table, tuple(DERIVATIVE_KEYS), where)
                out[side] = tuple(sorted(
                    (order, self.quantity(table, key, where, self._DERIVATIVE_DIMENSIONS[order]))
                    for key, order in DERIVATIVE_KEYS.items() if key in table))
        if "points" in row:
            points = row["points"]
            if not isinstance(points, list) or not all(isinstance(p, dict) for p in points):
                raise self.error(f"{path}.points", 'expected an array of tables [{ at = "30 deg", s = "4 mm" }, ...]')
            result = []
            for k, point in enumerate(points):
                where = f"{path}.points[{k}]"
                self.check_keys(point, schema.keys("cam.segments.points"), where)
                at = self.quantity(point, "at", where, "angle", required=True, bare_unit="deg", example='"30 deg"')
                if not 0.0 < at < duration:
                    raise self.error(f"{where}.at", f"{math.degrees(at):.6g} deg is outside the segment "
                                     f"(strictly between 0 and its duration {math.degrees(duration):.6g} deg)")
                s = self.quantity(point, "s", where, "length")
                derivs = tuple((order, self.quantity(point, key, where, self._DERIVATIVE_DIMENSIONS[order]))
                               for key, order in (("v", 1), ("a", 2)) if key in point)
                if law == "spline" and (s is None or derivs):
                    raise self.error(where, "a spline point gives s only (the lift there)")
                if s is None and not derivs:
                    raise self.error(where, "gives no condition: add s (and/or v, a)")
                if result and not at > result[-1].at:
                    raise self.error(f"{where}.at", "points must be in increasing order of `at`")
                result.append(SegmentPoint(at=at, s=s, derivatives=derivs))
            out["points"] = tuple(result)
        return out

    def compensation(self, table: Any, speed: float, drives: str | None, mass_names: list[str]) -> Compensation:
        """``[cam.compensation]`` (issue 27)."""
        if not isinstance(table, dict):
            raise self.error("cam.compensation", f"expected a table [cam.compensation], got {_fmt(table)}")
        self.check_keys(table, schema.keys("cam.compensation"), "cam.compensation")
        output = self.string(table, "output", "cam.compensation", required=True)
        if output not in mass_names:
            raise self.error("cam.compensation.output", f'"{output}" is not a mass; {_suggest(output, mass_names)}')
        if output == drives:
            raise self.error("cam.compensation.output", f"{output} is the driven mass (cam.drives): its motion is "
                             "the cam's, there is nothing to compensate; name a mass the cam moves through elements")
        design = self.quantity(table, "speed", "cam.compensation", "angular_speed", minimum=0.0, strict=True)
        return Compensation(output=output, speed=speed if design is None else design)

    def segments(self, value: Any, arm: float | None, speed: float = 1.0) -> tuple[Segment, ...]:
        if not isinstance(value, list) or not all(isinstance(r, dict) for r in value):
            raise self.error("cam.segments", "expected an array of tables "
                             '([{ motion = "rise", law = "cycloidal", duration = "90 deg", lift = "1 in" }, ...])')
        if not value:
            raise self.error("cam.segments", "the segment table is empty")
        result = []
        for i, row in enumerate(value):
            path = f"cam.segments[{i}]"
            self.check_keys(row, SEGMENT_KEYS, path)
            motion = self.choice(row, "motion", path, MOTIONS, required=True)
            if motion == "dwell":
                if "law" in row:
                    raise self.error(f"{path}.law", "a dwell has no law; remove it")
                law = None
            else:
                law = self.choice(row, "law", path, LAWS + SYNTHESIS_LAWS, required=True)
            duration = self.quantity(row, "duration", path, "angle", required=True, bare_unit="deg",
                                     minimum=0.0, strict=True, example='"50 deg"')
            extra = self.synthesis_keys(row, path, law, duration, speed)  # issue 27
            if "velocity" in extra:
                if "lift" in row:
                    raise self.error(f"{path}.lift", "a constant-velocity segment given velocity takes no lift "
                                     "(it follows: velocity·duration/speed); remove one of them")
                lift = extra["velocity"] * duration / speed
            elif "lift" in row:
                lift = self.lift(row, path, arm)
            elif motion == "dwell":
                lift = 0.0
            else:
                raise self.error(f"{path}.lift", 'missing required key (e.g. lift = "0.5 in")')
            if motion == "dwell" and lift != 0.0:
                raise self.error(f"{path}.lift", f"a dwell has no lift, got {_fmt(row['lift'])}")
            if motion != "dwell" and not lift > 0.0:
                raise self.error(f"{path}.lift", f"a {motion} needs a positive lift (a fall's lift is the "
                                 f"distance it descends), got {_fmt(row['lift'])}")
            result.append(Segment(motion=motion, law=law, duration=duration, lift=lift, **extra))

        total_deg = math.degrees(sum(s.duration for s in result))
        if abs(total_deg - 360.0) > DURATION_TOLERANCE_DEG:
            raise self.error("cam.segments", f"durations add up to {total_deg:.9g} deg, not 360 deg")
        rises = [i for i, s in enumerate(result) if s.motion == "rise"]
        falls = [i for i, s in enumerate(result) if s.motion == "fall"]
        total_rise = sum(result[i].lift for i in rises)
        tolerance = LIFT_TOLERANCE * max(total_rise, 1e-3)
        level = 0.0
        for i, s in enumerate(result):
            if s.motion == "rise":
                level += s.lift
            elif s.motion == "fall":
                if s.lift > level + tolerance:
                    raise self.error(
                        f"cam.segments[{i}].lift",
                        f"a fall larger than the preceding lift: it descends {_si_text(s.lift, 'm')} from "
                        f"{_si_text(level, 'm')} above the base circle (the table starts on the base "
                        "circle; to start elsewhere rotate the rows and set cam.start_angle)",
                    )
                level -= s.lift
        if abs(level) > tolerance:
            total_fall = sum(result[i].lift for i in falls)
            raise self.error(
                "cam.segments",
                f"net lift over the cycle is {_si_text(level, 'm')}, not zero: rises (rows "
                f"{', '.join(map(str, rises))}) total {_si_text(total_rise, 'm')}, falls (rows "
                f"{', '.join(map(str, falls)) or 'none'}) total {_si_text(total_fall, 'm')}",
            )
        return tuple(result)

    def cam_table(self, value: Any, arm: float | None) -> CamTable:
        where = "cam.table"
        if not isinstance(value, str) or not value.strip():
            raise self.error(where, f"expected the path of a CSV file, got {_fmt(value)}")
        path = Path(value)
        if not path.is_absolute():
            path = self.base_dir / path
        try:
            text = path.read_text(encoding="utf-8-sig")
        except FileNotFoundError:
            raise self.error(where, f"no such file: {path}") from None
        except (OSError, UnicodeDecodeError) as exc:
            raise self.error(where, f"cannot read {path}: {getattr(exc, 'strerror', None) or exc}") from None
        lines = [(n, line) for n, line in enumerate(text.splitlines(), start=1)
                 if line.strip() and not line.lstrip().startswith("#")]
        if not lines:
            raise self.error(where, f"{value}: the file is empty")
        header_line, header = lines[0][0], next(csv.reader([lines[0][1]]))
        columns: dict[str, tuple[int, str | None]] = {}
        for index, cell in enumerate(header):
            match = re.fullmatch(r"\s*([A-Za-z_]+)\s*(?:\[([^\]]*)\])?\s*", cell)
            name = match.group(1).lower() if match else cell.strip()
            if not match or name not in _TABLE_COLUMNS:
                raise self.error(where, f"{value} line {header_line}: unknown column {cell.strip()!r}; "
                                 f"{_suggest(name, _TABLE_COLUMNS)} (header: angle [deg], displacement [in], "
                                 "optional velocity, acceleration)")
            if name in columns:
                raise self.error(where, f"{value} line {header_line}: column '{name}' appears twice")
            unit = match.group(2).strip() if match.group(2) is not None else None
            columns[name] = (index, unit or None)
        for required in ("angle", "displacement"):
            if required not in columns:
                raise self.error(where, f"{value}: missing column '{required}' "
                                 f"(header has: {', '.join(c.strip() for c in header)})")
        factors = {name: self.column_factor(name, unit, arm, value) for name, (_, unit) in columns.items()}
        data: dict[str, list[float]] = {name: [] for name in columns}
        for line_no, line in lines[1:]:
            cells = next(csv.reader([line]))
            if len(cells) != len(header):
                raise self.error(where, f"{value} line {line_no}: {len(cells)} values, the header has {len(header)}")
            for name, (index, _) in columns.items():
                try:
                    number = float(cells[index])
                except ValueError:
                    raise self.error(where, f"{value} line {line_no}: {name} {cells[index].strip()!r} "
                                     "is not a number") from None
                if not math.isfinite(number):
                    raise self.error(where, f"{value} line {line_no}: {name} is not finite")
                data[name].append(number * factors[name])
        angles = data["angle"]
        if len(angles) < 4:
            raise self.error(where, f"{value}: {len(angles)} data rows; a periodic spline needs at least 4")
        data_lines = [n for n, _ in lines[1:]]
        for k in range(1, len(angles)):
            if not angles[k] > angles[k - 1]:
                raise self.error(where, f"{value} line {data_lines[k]}: angle {math.degrees(angles[k]):.6g} deg "
                                 f"does not increase (previous row {math.degrees(angles[k - 1]):.6g} deg); "
                                 "angles must increase strictly")
        span = math.degrees(angles[-1] - angles[0])
        if not span < 360.0:
            raise self.error(where, f"{value}: angles span {span:.6g} deg; a table covers less than one "
                             "revolution (leave out the row at 360 deg, the spline is periodic)")
        return CamTable(
            angle=tuple(angles),
            displacement=tuple(data["displacement"]),
            velocity=tuple(data["velocity"]) if "velocity" in data else None,
            acceleration=tuple(data["acceleration"]) if "acceleration" in data else None,
            source=value,
        )

    def column_factor(self, name: str, unit: str | None, arm: float | None, file: str) -> float:
        """SI factor of a table column's unit (angle column → rad; others → m, m/s, m/s^2)."""
        where = "cam.table"
        if name == "angle":
            try:
                return to_si(1.0, "angle", bare_unit=unit or "deg")
            except Exception:
                raise self.error(where, f"{file}: column angle [{unit}] is not an angle unit") from None
        if unit is None:
            return 1.0
        linear = {"displacement": "m", "velocity": "m/s", "acceleration": "m/s**2"}[name]
        angular = {"displacement": "rad", "velocity": "rad/s", "acceleration": "rad/s**2"}[name]
        if re.search(r"(?<![A-Za-z_])mils?(?![A-Za-z_])", unit):
            raise self.error(where, f'{file}: column {name} [{unit}]: "mil" is ambiguous (pint reads it '
                             'as an angle); write "thou" or "0.001 in"')
        try:
            quantity = ureg.Quantity(1.0, unit)
        except Exception:
            raise self.error(where, f"{file}: column {name} [{unit}]: unknown unit") from None
        # pint treats the radian as dimensionless: try the length dimension first.
        try:
            return float(quantity.to(linear).magnitude)
        except Exception:
            pass
        try:
            factor = float(quantity.to(angular).magnitude)
        except Exception:
            raise self.error(where, f"{file}: column {name} [{unit}] is not a {linear} unit "
                             f"(or {angular} with cam.arm)") from None
        if arm is None:
            raise self.error(where, f"{file}: column {name} [{unit}] is angular; set cam.arm (the "
                             "follower arm) to turn it into arc length")
        return factor * arm

    # -- masses -------------------------------------------------------------------
    def masses(self, doc: dict) -> list[Mass]:
        rows = self.rows(doc, "mass", "mass")
        if not rows:
            raise self.error("mass", 'the machine has no masses: add [[mass]] tables (name = "M1", mass = "2 kg")')
        result: list[Mass] = []
        for i, row in enumerate(rows):
            path = f"mass[{i}]"
            self.check_keys(row, MASS_KEYS, path)
            name = self.string(row, "name", path, required=True)
            if not name.strip():
                raise self.error(f"{path}.name", "must not be empty")
            if name in FIXED_NODES:
                raise self.error(f"{path}.name", f'"{name}" is a reserved node name (ground, cam)')
            if any(m.name == name for m in result):
                raise self.error(f"{path}.name", f'duplicate mass name "{name}"')
            # 0 kg is allowed for a node that only holds a rod end (checked in distributed())
            mass = self.quantity(row, "mass", path, "mass", required=True, example='"1.6388 lb"')
            if not mass >= 0.0:
                raise self.error(f"{path}.mass", f"must be greater than 0, got {_fmt(row['mass'])}")
            result.append(Mass(name=name, mass=mass))
        return result

    # -- elements -----------------------------------------------------------------
    def elements(self, doc: dict, mass_names: list[str], masses: list[Mass], cam: Cam | None) -> list[Element]:
        rows = self.rows(doc, "element", "element")
        nodes = [GROUND, CAM, *mass_names]
        driven = cam.drives if cam is not None else None
        result: list[Element] = []
        for i, row in enumerate(rows):
            path = f"element[{i}]"
            name = self.string(row, "name", path, required=True)
            if not name.strip():
                raise self.error(f"{path}.name", "must not be empty")
            if any(e.name == name for e in result):
                raise self.error(f"{path}.name", f'duplicate element name "{name}"')
            kind = self.choice(row, "type", path, element_kinds.element_types(), required=True)
            self.check_keys(row, ELEMENT_COMMON_KEYS + element_kinds.type_keys(kind), path, f"for a {kind} element")
            lower, upper = self.between(row, path, nodes)
            laws = element_kinds.laws_of(kind)
            law = None
            if laws:
                law = self.choice(row, "law", path, laws, required=False) or element_kinds.element_class(kind).law_name
                key_laws = element_kinds.key_laws(kind)
                for key in row:
                    if key in key_laws and law not in key_laws[key]:
                        takes = " or ".join(f'law = "{x}"' for x in key_laws[key])
                        raise self.error(f"{path}.{key}", f'not used by a {kind} with law = "{law}" (only {takes})'
                                         + self.law_hint(kind, law, key))
            cls = element_kinds.element_class(kind, law)
            values: dict[str, Any] = dict(name=name, lower=lower, upper=upper)
            values["damping"] = self.damping(row, path, lower, upper, mass_names)
            for p in cls.params:
                if p.dimension == "string" or p.key in _DAMPING_KEYS:
                    continue
                values[p.attribute] = self.param(row, p, path, values)
            cls.check(values, lambda key, message: self.error(f"{path}.{key}", message), driven)
            element = cls(**values)
            if driven is not None and CAM in (lower, upper) and driven in (lower, upper):
                raise self.error(f"{path}.between", f"{driven} is driven by the cam (cam.drives), so an "
                                 f"element between it and the cam never deflects")
            result.append(element)
        return result

    @staticmethod
    def law_hint(kind: str, law: str, key: str) -> str:
        """Why a key is refused for a law, when the law's class says (``refused_hints``)."""
        hints = element_kinds.element_class(kind, law).refused_hints
        hint = next((text for prefix, text in hints.items() if key.startswith(prefix)), "")
        return f"; {hint}" if hint else ""

    def param(self, row: dict, p: Param, path: str, values: dict[str, Any]) -> Any:
        """One key of an element table, read and checked as its schema says."""
        if p.dimension == "bool":
            value = row.get(p.key, p.default)
            if not isinstance(value, bool):
                raise self.error(f"{path}.{p.key}", f"expected true or false, got {_fmt(value)}")
            return value
        if p.dimension == "number":
            return self.number(row, p.key, path, required=p.required, default=p.default, minimum=p.minimum,
                               strict=p.strict, maximum=p.maximum)
        if p.dimension == "choice":
            value = self.choice(row, p.key, path, p.choices, required=p.required)
            return p.default if value is None else value
        if p.dimension == "integer":
            if p.key not in row:
                if p.required:
                    raise self.error(f"{path}.{p.key}", "missing required key (a whole number)")
                return p.default
            return self.integer(row, p.key, path, p.default, int(p.minimum or 0))
        if p.dimension in ("material", "materials"):  # issue 39
            return self.material_value(row, p, path)
        dimension = f"power_coefficient:{values['exponent']!r}" if p.dimension == "power_coefficient" else p.dimension
        return self.quantity(row, p.key, path, dimension, required=p.required, default=p.default, minimum=p.minimum,
                             strict=p.strict, example=p.example)

    def between(self, row: dict, path: str, nodes: list[str]) -> tuple[str, str]:
        where = f"{path}.between"
        if "between" not in row:
            raise self.error(where, 'missing required key (e.g. between = ["M2", "M3"], lower node first)')
        value = row["between"]
        if not (isinstance(value, list) and len(value) == 2 and all(isinstance(v, str) for v in value)):
            raise self.error(where, f'expected two node names, [lower, upper], got {_fmt(value)}')
        for node in value:
            if node not in nodes:
                raise self.error(where, f'unknown node "{node}"; {_suggest(node, nodes)} '
                                 "(nodes are ground, cam and the mass names)")
        lower, upper = value
        if lower == upper:
            raise self.error(where, f'an element joins two different nodes, got "{lower}" twice')
        if lower in FIXED_NODES and upper in FIXED_NODES:
            raise self.error(where, f'joins "{lower}" and "{upper}": at least one end must be a mass')
        return lower, upper

    def damping(self, row: dict, path: str, lower: str, upper: str, mass_names: list[str]) -> Damping:
        if "damping" in row and "damping_ratio" in row:
            raise self.error(f"{path}.damping_ratio", "give damping (a coefficient) or damping_ratio, not both")
        coefficient = self.quantity(row, "damping", path, "damping", minimum=0.0)
        ratio = self.number(row, "damping_ratio", path, minimum=0.0)
        reference = self.string(row, "reference_mass", path)
        if reference is not None:
            if reference not in mass_names:
                raise self.error(f"{path}.reference_mass", f'"{reference}" is not a mass; '
                                 f"{_suggest(reference, mass_names)}")
            if ratio is None:
                raise self.error(f"{path}.reference_mass", "only used with damping_ratio")
        return Damping(coefficient=coefficient, ratio=ratio, reference_mass=reference)

    # -- simulation and initial state -------------------------------------------------
    def simulation(self, doc: dict, cam: Cam | None) -> Simulation:
        table = self.table(doc, "simulation", "simulation") or {}
        self.check_keys(table, SIMULATION_KEYS, "simulation")
        cycles = self.integer(table, "cycles", "simulation", 1, 1)
        warmup = self.integer(table, "warmup_cycles", "simulation", 1, 0)
        rate = self.quantity(table, "sample_rate", "simulation", "frequency", default=50_000.0,
                             minimum=0.0, strict=True)
        gravity_value = table.get("gravity", False)
        if isinstance(gravity_value, bool):
            gravity = STANDARD_GRAVITY if gravity_value else 0.0
        else:
            gravity = self.quantity(table, "gravity", "simulation", "acceleration", minimum=0.0)
        duration = self.quantity(table, "duration", "simulation", "time", minimum=0.0, strict=True)
        if duration is not None and "cycles" in table:
            raise self.error("simulation.duration", "give cycles or duration, not both")
        if cam is None and duration is None:
            raise self.error("simulation.duration", 'missing required key: a machine without [cam] has no '
                             'cycle, give the recorded time (e.g. duration = "5 ms")')
        return Simulation(cycles=cycles, warmup_cycles=warmup, sample_rate=rate, gravity=gravity,
                          duration=duration)

    def initial(self, doc: dict, mass_names: list[str], cam: Cam | None) -> list[InitialCondition]:
        table = self.table(doc, "initial", "initial")
        if table is None:
            return []
        driven = cam.drives if cam is not None else None
        result = []
        for name, entry in table.items():
            path = f"initial.{name}"
            if name not in mass_names:
                raise self.error(path, f'"{name}" is not a mass; {_suggest(name, mass_names)}')
            if name == driven:
                raise self.error(path, f"{name} is driven by the cam (cam.drives): its motion is prescribed, "
                                 "so it takes no initial condition")
            if not isinstance(entry, dict):
                raise self.error(path, f"expected a table [initial.{name}], got {_fmt(entry)}")
            self.check_keys(entry, INITIAL_KEYS, path)
            if not entry:
                raise self.error(path, "empty: give displacement and/or velocity")
            result.append(InitialCondition(
                mass=name,
                displacement=self.quantity(entry, "displacement", path, "length"),
                velocity=self.quantity(entry, "velocity", path, "velocity"),
            ))
        return result

    def connectivity(self, masses: list[Mass], elements: list[Element], cam: Cam | None) -> None:
        driven = cam.drives if cam is not None else None
        for i, m in enumerate(masses):
            if m.name == driven:
                continue
            if not any(m.name in e.nodes for e in elements):
                raise self.error(f"mass[{i}]", f"{m.name} is connected to no element: a free mass needs at "
                                 "least one element (spring, link or contact)")

"""Reading the cam tables of a machine file: one ``[cam]`` or several ``[[cam]]``, and ``[camshaft]``.

A machine has one cam (``[cam]``, the node ``cam``) or several cams on one shaft
(``[[cam]]`` tables, spec §9: each its own node, named by ``name``, with its ``phase`` on
the shaft) — each with its program (segments, a table, synthesis, compensation), linkage
and geometry — and an optional ``[camshaft]`` with the shaft's speed and its own dynamics
(:mod:`camsim.machine.shaft`). Error paths name the table as written: ``cam.segments[2].lift``
or ``cam[1].segments[2].lift``.
"""

from __future__ import annotations

import csv
import math
import re
from pathlib import Path
from typing import Any

from camsim.elements import CAM
from camsim.machine import schema
from camsim.machine.description import (
    DERIVATIVE_KEYS,
    LAWS,
    MOTIONS,
    SYNTHESIS_LAWS,
    Cam,
    CamTable,
    Compensation,
    Segment,
    SegmentPoint,
)
from camsim.machine.reading import Reader, _fmt, _has_unit, _is_angular, _si_text, _suggest
from camsim.units import QuantityError, to_si, ureg

CAM_KEYS = schema.keys("cam")
#: The keys of a [[cam]] table: a [cam]'s and its name and phase.
MULTI_CAM_KEYS = schema.keys("cams")
SEGMENT_KEYS = schema.keys("cam.segments")

#: Tolerance on the sum of segment durations [deg].
DURATION_TOLERANCE_DEG = 1e-6
#: Relative tolerance on the net lift of a segment table (of the total rise).
LIFT_TOLERANCE = 1e-9

_TABLE_COLUMNS = ("angle", "displacement", "velocity", "acceleration")


class CamReader(Reader):
    """The cam tables of a document (mixed into the machine's validator)."""

    #: Key path of the cam table being read (``cam`` or ``cam[i]``).
    cam_path = "cam"

    # -- one cam ----------------------------------------------------------------
    def cam(self, table: dict, mass_names: list[str], path: str = "cam", *,
            shaft: tuple[float, float] | None = None) -> Cam:
        """One cam: the ``[cam]`` table (``path`` "cam"), or one ``[[cam]]`` table (``path``
        "cam[i]") of a camshaft whose (speed [rad/s], start angle [rad]) is ``shaft``."""
        self.cam_path = path
        self.check_keys(table, CAM_KEYS if shaft is None else MULTI_CAM_KEYS, path)
        if shaft is None:
            speed = self.shaft_speed(table, path)
            start = self.quantity(table, "start_angle", path, "angle", default=0.0, bare_unit="deg")
            name, phase = CAM, 0.0
        else:
            speed, start = shaft
            name = self.string(table, "name", path, required=True)
            phase = self.quantity(table, "phase", path, "angle", default=0.0, bare_unit="deg")
        ratio = self.number(table, "ratio", path, default=1.0, minimum=0.0, strict=True)
        arm = self.quantity(table, "arm", path, "length", minimum=0.0, strict=True)
        drives = self.string(table, "drives", path)
        if drives is not None and drives not in mass_names:
            raise self.error(f"{path}.drives", f'"{drives}" is not a mass; {_suggest(drives, mass_names)}')
        has_segments, has_table = "segments" in table, "table" in table
        if has_segments and has_table:
            raise self.error(f"{path}.table", f"give either {path}.segments or {path}.table, not both")
        if not has_segments and not has_table:
            raise self.error(f"{path}.segments", f"missing required key: give {path}.segments (a segment table) "
                             f"or {path}.table (a CSV profile)")
        segments: tuple[Segment, ...] = ()
        profile = None
        if has_segments:
            segments = self.segments(table["segments"], arm, speed)
        else:
            profile = self.cam_table(table["table"], arm)
        geometry = None
        if "geometry" in table:  # issue 14: [cam.geometry]
            from camsim.cam.arrangement import parse_geometry

            geometry = parse_geometry(table["geometry"], self.source, cam_arm=arm, path=f"{path}.geometry",
                                      materials=getattr(self, "materials", {}))
        compensation = None
        if "compensation" in table:  # issue 27
            compensation = self.compensation(table["compensation"], speed, drives, mass_names)
        cam = Cam(speed=speed, segments=segments, table=profile, ratio=ratio, arm=arm,
                  drives=drives, start_angle=start, geometry=geometry, compensation=compensation,
                  name=name, phase=phase)
        if any(s.law in SYNTHESIS_LAWS for s in segments):  # issue 27: solve now, errors name the segment
            from camsim.cam.program import CamProgram
            from camsim.cam.synthesis import SynthesisError

            try:
                CamProgram(cam)
            except SynthesisError as exc:
                key = f"{path}.segments[{exc.segment}]" + (f".{exc.key}" if exc.key else "")
                raise self.error(key, exc.message) from None
        return cam

    def shaft_speed(self, table: dict, path: str, required: bool = True) -> float | None:
        """The ``speed`` key of a cam or camshaft table: an angular speed > 0 [rad/s]."""
        speed = self.quantity(table, "speed", path, "angular_speed", required=required, minimum=0.0,
                              strict=True, example='"120 rpm"')
        value = table.get("speed")
        if _has_unit(value) and not _is_angular(value):
            raise self.error(f"{path}.speed", f'expected an angular speed such as "120 rpm" or "12.57 rad/s", '
                             f"got {_fmt(value)} (a frequency without an angle unit is ambiguous: "
                             "pint would read 1 Hz as 1 rad/s)")
        return speed

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
                        raise self.error(where, f"an angular lift {_fmt(value)} needs {self.cam_path}.arm "
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

    def synthesis_keys(self, row: dict, path: str, law: str | None, duration: float, speed: float,
                       dimensions: dict[int, str] | None = None, value: str = "length") -> dict:
        """The keys of a polynomial, constant-velocity or spline segment, in SI (Segment fields).

        ``dimensions``: order → dimension of the derivative conditions (default the cam's: velocity,
        acceleration, …); ``value``: the dimension of a point's ``s`` (a load's program: ``force``,
        its rates force/time^k, issue 43)."""
        dims = dimensions or self._DERIVATIVE_DIMENSIONS
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
            out["velocity"] = self.quantity(row, "velocity", path, dims[1], minimum=0.0, strict=True)
        for side in ("start", "end"):
            if side in row:
                table = row[side]
                where = f"{path}.{side}"
                if not isinstance(table, dict):
                    raise self.error(where, f"expected a table {{ v = ..., a = ... }}, got {_fmt(table)}")
                self.check_keys(table, tuple(DERIVATIVE_KEYS), where)
                out[side] = tuple(sorted(
                    (order, self.quantity(table, key, where, dims[order]))
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
                s = self.quantity(point, "s", where, value)
                derivs = tuple((order, self.quantity(point, key, where, dims[order]))
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
        where = f"{self.cam_path}.compensation"
        if not isinstance(table, dict):
            raise self.error(where, f"expected a table [{where}], got {_fmt(table)}")
        self.check_keys(table, schema.keys("cam.compensation"), where)
        output = self.string(table, "output", where, required=True)
        if output not in mass_names:
            raise self.error(f"{where}.output", f'"{output}" is not a mass; {_suggest(output, mass_names)}')
        if output == drives:
            raise self.error(f"{where}.output", f"{output} is the driven mass ({self.cam_path}.drives): its motion is "
                             "the cam's, there is nothing to compensate; name a mass the cam moves through elements")
        design = self.quantity(table, "speed", where, "angular_speed", minimum=0.0, strict=True)
        return Compensation(output=output, speed=speed if design is None else design)

    def segments(self, value: Any, arm: float | None, speed: float = 1.0) -> tuple[Segment, ...]:
        if not isinstance(value, list) or not all(isinstance(r, dict) for r in value):
            raise self.error(f"{self.cam_path}.segments", "expected an array of tables "
                             '([{ motion = "rise", law = "cycloidal", duration = "90 deg", lift = "1 in" }, ...])')
        if not value:
            raise self.error(f"{self.cam_path}.segments", "the segment table is empty")
        result = []
        for i, row in enumerate(value):
            path = f"{self.cam_path}.segments[{i}]"
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
            raise self.error(f"{self.cam_path}.segments", f"durations add up to {total_deg:.9g} deg, not 360 deg")
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
                        f"{self.cam_path}.segments[{i}].lift",
                        f"a fall larger than the preceding lift: it descends {_si_text(s.lift, 'm')} from "
                        f"{_si_text(level, 'm')} above the base circle (the table starts on the base "
                        f"circle; to start elsewhere rotate the rows and set {self.cam_path}.start_angle or phase)",
                    )
                level -= s.lift
        if abs(level) > tolerance:
            total_fall = sum(result[i].lift for i in falls)
            raise self.error(
                f"{self.cam_path}.segments",
                f"net lift over the cycle is {_si_text(level, 'm')}, not zero: rises (rows "
                f"{', '.join(map(str, rises))}) total {_si_text(total_rise, 'm')}, falls (rows "
                f"{', '.join(map(str, falls)) or 'none'}) total {_si_text(total_fall, 'm')}",
            )
        return tuple(result)

    def cam_table(self, value: Any, arm: float | None) -> CamTable:
        where = f"{self.cam_path}.table"
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
        where = f"{self.cam_path}.table"
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
                             f"(or {angular} with {self.cam_path}.arm)") from None
        if arm is None:
            raise self.error(where, f"{file}: column {name} [{unit}] is angular; set {self.cam_path}.arm (the "
                             "follower arm) to turn it into arc length")
        return factor * arm

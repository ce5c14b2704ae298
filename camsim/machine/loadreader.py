"""Reading the ``[[load]]`` tables of a machine file (issue 43, spec §10).

A load is an external force on one mass with exactly one program: ``force`` (a constant),
``segments`` (the cam's segment table with ``change`` in place of ``lift``, over the cam
angle), ``table`` (a CSV of the force against ``angle`` or ``time``) or ``sine``. Every
problem is one :class:`~camsim.errors.MachineFileError` naming the file and the key path
(``load[2].segments``, ``load[0].table``, ``load[1].sine.frequency``).
"""

from __future__ import annotations

import csv
import math
import re
from pathlib import Path
from typing import Any

from camsim.elements import FIXED_NODES
from camsim.loads.description import KINDS, Load, LoadTable, Sine
from camsim.machine import schema
from camsim.machine.camreader import DURATION_TOLERANCE_DEG, LIFT_TOLERANCE, CamReader
from camsim.machine.description import LAWS, MOTIONS, SYNTHESIS_LAWS, Segment
from camsim.machine.reading import _fmt, _si_text, _suggest
from camsim.units import ureg

LOAD_KEYS = schema.keys("load")
LOAD_SEGMENT_KEYS = schema.keys("load.segments")
SINE_KEYS = schema.keys("load.sine")
#: The dimensions of a load program's derivative conditions, by order (force rates).
FORCE_RATES = {1: "force/time", 2: "force/time^2", 3: "force/time^3", 4: "force/time^4", 5: "force/time^5",
               6: "force/time^6"}
#: The abscissa columns of a load table and the unit of a bare one.
_ABSCISSAE = {"angle": "deg", "time": "s"}


class LoadReader(CamReader):
    """The ``[[load]]`` tables of a document (mixed into the machine's validator)."""

    def loads(self, doc: dict, mass_names: list[str], cams: list, element_names: list[str]) -> list[Load]:
        """Every ``[[load]]`` table, in file order."""
        rows = self.rows(doc, "load", "load")
        cam_names = [c.name for c in cams]
        speed = float(cams[0].speed) if cams else None
        out: list[Load] = []
        for i, row in enumerate(rows):
            path = f"load[{i}]"
            self.check_keys(row, LOAD_KEYS, path)
            name = self.string(row, "name", path, required=True)
            if not name.strip():
                raise self.error(f"{path}.name", "must not be empty")
            if name in element_names or any(load.name == name for load in out):
                raise self.error(f"{path}.name", f'duplicate name "{name}": a load\'s name is unique among elements '
                                 "and loads")
            on = self.string(row, "on", path, required=True)
            if on not in mass_names:
                fixed = on in FIXED_NODES or on in cam_names
                raise self.error(f"{path}.on", f'"{on}" is not a mass' + (" (a load acts on a mass, not on ground or a "
                                 "cam)" if fixed else f"; {_suggest(on, mass_names)}"))
            kind, values, cam = self.force_program(row, path, speed, cam_names)
            out.append(Load(name=name, on=on, kind=kind, cam=cam, **values))
        return out

    def force_program(self, row: dict, path: str, speed: float | None, cam_names: list[str]) -> tuple[str, dict, str | None]:
        """A force program from a table holding exactly one of ``force``, ``segments`` (with
        ``base``), ``table``, ``sine`` (and ``cam``): (kind, the :class:`Load` fields, cam) —
        a load's, or a friction pair's ``normal_force = { … }`` (spec §10)."""
        given = [k for k in KINDS if k in row]
        if not given:
            raise self.error(path, "no force program: give exactly one of force, segments, table, sine")
        if len(given) > 1:
            raise self.error(f"{path}.{given[1]}", f"give one force program, not both {given[0]} and {given[1]}")
        kind = given[0]
        if "base" in row and kind != "segments":
            raise self.error(f"{path}.base", "only used with segments (the program's force at its 0°)")
        values: dict[str, Any] = {}
        if kind == "force":
            values["force"] = self.quantity(row, "force", path, "force", required=True)
        elif kind == "segments":
            self._needs_cam(f"{path}.segments", speed)
            values["segments"] = self.load_segments(row["segments"], path, speed)
            values["base"] = self.quantity(row, "base", path, "force", default=0.0)
        elif kind == "table":
            values["table"] = self.load_table(row["table"], path)
            if values["table"].over == "angle":
                self._needs_cam(f"{path}.table", speed)
        else:
            values["sine"] = self.sine(row["sine"], path)
        cam = self.string(row, "cam", path)
        if cam is not None:
            if cam not in cam_names:
                raise self.error(f"{path}.cam", f'"{cam}" is not a cam; {_suggest(cam, cam_names)}')
            if kind in ("force", "sine") or (kind == "table" and values["table"].over == "time"):
                raise self.error(f"{path}.cam", "only used with a program over the cam angle (segments, an "
                                 "angle table)")
        return kind, values, cam

    def _needs_cam(self, where: str, speed: float | None) -> None:
        if speed is None:
            raise self.error(where, "a program over the cam angle needs a cam (the machine has none): give a "
                             "time table, a sine or a constant force")

    # -- segments -----------------------------------------------------------------
    def load_segments(self, value: Any, path: str, speed: float) -> tuple[Segment, ...]:
        """A segment program over the cam angle: each row's ``lift`` is its force change [N]."""
        where = f"{path}.segments"
        if not isinstance(value, list) or not value or not all(isinstance(r, dict) for r in value):
            raise self.error(where, 'expected a non-empty array of tables ([{ motion = "rise", law = "cycloidal", '
                             'duration = "30 deg", change = "200 N" }, ...])')
        result = []
        closing = None  # the one rise or fall without a change: it closes the program
        for j, row in enumerate(value):
            p = f"{where}[{j}]"
            self.check_keys(row, LOAD_SEGMENT_KEYS, p)
            motion = self.choice(row, "motion", p, MOTIONS, required=True)
            if motion == "dwell":
                if "law" in row:
                    raise self.error(f"{p}.law", "a dwell has no law; remove it")
                law = None
            else:
                law = self.choice(row, "law", p, LAWS + SYNTHESIS_LAWS, required=True)
            duration = self.quantity(row, "duration", p, "angle", required=True, bare_unit="deg", minimum=0.0,
                                     strict=True, example='"30 deg"')
            extra = self.synthesis_keys(row, p, law, duration, speed, dimensions=FORCE_RATES, value="force")
            if "velocity" in extra:
                if "change" in row:
                    raise self.error(f"{p}.change", "a constant-velocity segment given velocity takes no change "
                                     "(it follows: velocity·duration/speed); remove one of them")
                change = extra["velocity"] * duration / speed
            elif "change" in row:
                change = self.quantity(row, "change", p, "force")
            elif motion == "dwell":
                change = 0.0
            elif closing is None:
                closing, change = j, 1.0  # the row that closes the program: its change follows below
            else:
                raise self.error(f"{p}.change", f'missing required key (e.g. change = "200 N"); only one rise or fall '
                                 f"may leave it out to close the program, and {where}[{closing}] does")
            if motion == "dwell" and change != 0.0:
                raise self.error(f"{p}.change", f"a dwell has no change, got {_fmt(row['change'])}")
            if motion != "dwell" and not change > 0.0:
                raise self.error(f"{p}.change", f"a {motion} needs a positive change (a fall's change is how much "
                                 f"the force decreases), got {_fmt(row['change'])}")
            result.append(Segment(motion=motion, law=law, duration=duration, lift=change, **extra))
        total_deg = math.degrees(sum(s.duration for s in result))
        if abs(total_deg - 360.0) > DURATION_TOLERANCE_DEG:
            raise self.error(where, f"durations add up to {total_deg:.9g} deg, not 360 deg")
        if closing is not None:
            others = [s for k, s in enumerate(result) if k != closing]
            net = sum(s.lift for s in others if s.motion == "rise") - sum(s.lift for s in others if s.motion == "fall")
            row = result[closing]
            change = net if row.motion == "fall" else -net
            if not change > 0.0:
                raise self.error(f"{where}[{closing}]", f"a {row.motion} without a change closes the program, but the "
                                 f"other rows already leave it at {_si_text(net, 'N')} above its start: it would "
                                 f"need a change of {_si_text(change, 'N')}")
            from dataclasses import replace

            result[closing] = replace(row, lift=change)
        rises = sum(s.lift for s in result if s.motion == "rise")
        falls = sum(s.lift for s in result if s.motion == "fall")
        if abs(rises - falls) > LIFT_TOLERANCE * max(rises, falls, 1e-6):
            raise self.error(where, f"the program does not close: its net change over the cycle is "
                             f"{_si_text(rises - falls, 'N')} (rises {_si_text(rises, 'N')}, falls "
                             f"{_si_text(falls, 'N')}), not zero")
        if any(s.law in SYNTHESIS_LAWS for s in result):  # solve now: errors name the segment
            from camsim.cam.description import Cam
            from camsim.cam.program import CamProgram
            from camsim.cam.synthesis import SynthesisError

            try:
                CamProgram(Cam(speed=speed, segments=tuple(result)))
            except SynthesisError as exc:
                key = f"{where}[{exc.segment}]" + (f".{exc.key}" if exc.key else "")
                raise self.error(key, exc.message.replace("lift", "change")) from None
        return tuple(result)

    # -- a CSV table --------------------------------------------------------------
    def load_table(self, value: Any, path: str) -> LoadTable:
        """A CSV of ``angle [deg]`` or ``time [s]`` against ``force [N]``."""
        where = f"{path}.table"
        if not isinstance(value, str) or not value.strip():
            raise self.error(where, f"expected the path of a CSV file, got {_fmt(value)}")
        file = Path(value)
        if not file.is_absolute():
            file = self.base_dir / file
        try:
            text = file.read_text(encoding="utf-8-sig")
        except FileNotFoundError:
            raise self.error(where, f"no such file: {file}") from None
        except (OSError, UnicodeDecodeError) as exc:
            raise self.error(where, f"cannot read {file}: {getattr(exc, 'strerror', None) or exc}") from None
        lines = [(n, line) for n, line in enumerate(text.splitlines(), start=1)
                 if line.strip() and not line.lstrip().startswith("#")]
        if not lines:
            raise self.error(where, f"{value}: the file is empty")
        header_line, header = lines[0][0], next(csv.reader([lines[0][1]]))
        cells = []
        for cell in header:
            match = re.fullmatch(r"\s*([A-Za-z_]+)\s*(?:\[([^\]]*)\])?\s*", cell)
            cells.append((match.group(1).lower(), (match.group(2) or "").strip() or None) if match else (cell.strip(), None))
        names = [c[0] for c in cells]
        if len(cells) != 2 or names[0] not in _ABSCISSAE or names[1] != "force":
            raise self.error(where, f"{value} line {header_line}: the header must be two columns, 'angle [deg]' or "
                             f"'time [s]', then 'force [N]' (any force unit); got {', '.join(c.strip() for c in header)}")
        over = names[0]
        factors = [self._factor(over, cells[0][1], value, header_line, where),
                   self._factor("force", cells[1][1], value, header_line, where)]
        xs: list[float] = []
        fs: list[float] = []
        data_lines = []
        for line_no, line in lines[1:]:
            row = next(csv.reader([line]))
            if len(row) != 2:
                raise self.error(where, f"{value} line {line_no}: {len(row)} values, the header has 2")
            numbers = []
            for cell, (name, _) in zip(row, cells):
                try:
                    number = float(cell)
                except ValueError:
                    raise self.error(where, f"{value} line {line_no}: {name} {cell.strip()!r} is not a number") from None
                if not math.isfinite(number):
                    raise self.error(where, f"{value} line {line_no}: {name} is not finite")
                numbers.append(number)
            xs.append(numbers[0] * factors[0])
            fs.append(numbers[1] * factors[1])
            data_lines.append(line_no)
        if len(xs) < 2:
            raise self.error(where, f"{value}: {len(xs)} data rows; a table needs at least 2")
        shown = (lambda x: f"{math.degrees(x):.6g} deg") if over == "angle" else (lambda x: f"{x:.6g} s")
        for k in range(1, len(xs)):
            if xs[k] < xs[k - 1]:
                raise self.error(where, f"{value} line {data_lines[k]}: {over} {shown(xs[k])} is not increasing "
                                 f"(previous row {shown(xs[k - 1])}); a value written twice is a step")
            if k >= 2 and xs[k] == xs[k - 1] == xs[k - 2]:
                raise self.error(where, f"{value} line {data_lines[k]}: {over} {shown(xs[k])} written three times "
                                 "(twice is a step)")
        if over == "angle":
            tol = math.radians(DURATION_TOLERANCE_DEG)
            if abs(xs[0]) > tol or abs(xs[-1] - 2.0 * math.pi) > tol:
                raise self.error(where, f"{value}: an angle table covers 0–360 deg (periodic), its angles run from "
                                 f"{shown(xs[0])} to {shown(xs[-1])}")
            xs[0], xs[-1] = 0.0, 2.0 * math.pi
        return LoadTable(over=over, x=tuple(xs), force=tuple(fs), source=value)

    def _factor(self, name: str, unit: str | None, file: str, line: int, where: str) -> float:
        """SI factor of a column's unit (angle → rad, time → s, force → N); a bare column is
        deg, s or N."""
        dimension = {"angle": "radian", "time": "second", "force": "newton"}[name]
        text = unit if unit is not None else _ABSCISSAE.get(name, "N")
        if re.search(r"(?<![A-Za-z_])mils?(?![A-Za-z_])", text):
            raise self.error(where, f'{file} line {line}: column {name} [{text}]: "mil" is ambiguous (pint reads it '
                             "as an angle)")
        try:
            quantity = ureg.Quantity(1.0, text)
        except Exception:
            raise self.error(where, f"{file} line {line}: column {name} [{text}]: unknown unit") from None
        try:
            return float(quantity.to(dimension).magnitude)
        except Exception:
            raise self.error(where, f"{file} line {line}: column {name} [{text}] is not {'a' if name != 'angle' else 'an'} "
                             f"{name} unit") from None

    # -- a sine -------------------------------------------------------------------
    def sine(self, value: Any, path: str) -> Sine:
        where = f"{path}.sine"
        if not isinstance(value, dict):
            raise self.error(where, 'expected a table { amplitude = "25 N", frequency = "2 Hz" }, got ' + _fmt(value))
        self.check_keys(value, SINE_KEYS, where)
        return Sine(
            amplitude=self.quantity(value, "amplitude", where, "force", required=True, example='"25 N"'),
            frequency=self.quantity(value, "frequency", where, "frequency", required=True, minimum=0.0, strict=True,
                                    example='"2 Hz"'),
            phase=self.quantity(value, "phase", where, "angle", default=0.0, bare_unit="deg"),
            offset=self.quantity(value, "offset", where, "force", default=0.0),
            start=self.quantity(value, "start", where, "time", default=0.0),
        )

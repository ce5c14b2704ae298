"""Load a TOML machine file into a :class:`camsim.machine.description.Machine` in SI units.

The entry point: read the text, apply command-line overrides (:mod:`camsim.machine.overrides`)
to the parsed document, check it and build the machine (:mod:`camsim.machine.validator`, which
reads the key lists from the schema). Every problem raises
:class:`camsim.errors.MachineFileError` naming the file and the key path
(``element[3].stiffness``, ``cam.segments[2].lift``, ``initial.M3.velocity``; array
indices are 0-based) with a one-line message. An overridden value is checked exactly
like one in the file.
The key grammar addresses masses and elements by name and segments by index::

    cam.speed=150 rpm            cam.segments[2].lift=0.4 in
    mass.M2.mass=1.7 lb          element.seat.stiffness=9e6
    simulation.cycles=3          initial.M3.velocity=-0.2 m/s

See ``docs/machine-file.md`` for the full reference.
"""

from __future__ import annotations

import copy
import functools

import os
import tomllib
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from camsim import elements as element_kinds
from camsim.elements import FIXED_NODES, Element
from camsim.errors import MachineFileError
from camsim.machine.description import Machine
from camsim.machine.overrides import _apply_override, _named_rows
from camsim.machine.validator import (  # noqa: F401 - the key lists, re-exported
    CAM_KEYS,
    MULTI_CAM_KEYS,
    DURATION_TOLERANCE_DEG,
    ELEMENT_COMMON_KEYS,
    INITIAL_KEYS,
    LIFT_TOLERANCE,
    MACHINE_KEYS,
    MASS_KEYS,
    SCHEMA_VERSION,
    SEGMENT_KEYS,
    SIMULATION_KEYS,
    TOP_KEYS,
    _Validator,
)

__all__ = [
    "SCHEMA_VERSION",
    "load_machine",
    "load_machine_text",
    "apply_override",
    "override_keys",
    "machine_to_dict",
    "damping_coefficients",
]


# Element tables: the keys come from each kind's schema (camsim/elements/).
ELEMENT_TYPES = element_kinds.element_types()
ELEMENT_TYPE_KEYS = {kind: element_kinds.type_keys(kind) for kind in ELEMENT_TYPES}
# (These two are the kinds registered when the loader was imported; the loader itself asks
# the registry each time, so a kind registered later — a plug-in — is accepted too.)


# --------------------------------------------------------------------------------------
# Public API
# --------------------------------------------------------------------------------------
def load_machine(
    path: str | os.PathLike[str] | dict, overrides: Sequence[str] | dict[str, Any] = (), *, base_dir: str | Path | None = None
) -> Machine:
    """Read and validate a machine file (or a machine given as a dict).

    Parameters
    ----------
    path : str, Path or dict
        The TOML machine file — a cam ``table`` CSV is looked up relative to it — or the
        machine document itself as a dict (what ``tomllib.load`` would return; values may
        be strings with units, as in a file).
    overrides : sequence of str, or dict
        ``"KEY=VALUE"`` assignments (as from ``--set``), or ``{KEY: VALUE}``, applied
        before validation.
    base_dir : path, optional
        For a dict: where a cam ``table`` path is relative to (default: the current
        directory).

    Returns
    -------
    Machine
        The machine in SI units; ``source`` is ``str(path)`` (``"<dict>"`` for a dict).

    Raises
    ------
    MachineFileError
        Missing or unreadable file, invalid TOML, or any invalid key or value.
    """
    if isinstance(overrides, dict):
        overrides = assignments(overrides)
    if isinstance(path, dict):
        import tomli_w

        try:
            text = tomli_w.dumps(path)
        except TypeError as exc:
            raise MachineFileError("<dict>", "", f"not a machine document: {exc}") from None
        return load_machine_text(text, source="<dict>", base_dir=Path(base_dir or "."), overrides=overrides)
    text = read_machine_text(path)
    return load_machine_text(text, source=str(path), base_dir=Path(path).parent, overrides=overrides)


def assignments(values: dict[str, Any]) -> list[str]:
    """``{KEY: VALUE}`` → ``["KEY=VALUE", ...]`` in the ``--set`` grammar.

    A value may be a number, a bool or a string with units (``"1.7e6 N/m"``); strings are
    quoted so that they reach the loader as written.
    """
    out = []
    for key, value in values.items():
        if isinstance(value, bool):
            text = "true" if value else "false"
        elif isinstance(value, (int, float)):
            text = repr(value)
        elif isinstance(value, (list, tuple)):  # e.g. a contact's materials (issue 39)
            import tomli_w

            text = tomli_w.dumps({"v": list(value)}).split("=", 1)[1].strip()
        else:
            text = '"' + str(value).replace("\\", "\\\\").replace('"', '\\"') + '"'
        out.append(f"{key}={text}")
    return out


def read_machine_text(path: str | os.PathLike[str]) -> str:
    """The text of a machine file, or a one-line :class:`MachineFileError` naming the file."""
    source = str(path)
    try:
        return Path(path).read_text(encoding="utf-8")
    except FileNotFoundError:
        raise MachineFileError(source, "", "no such machine file") from None
    except IsADirectoryError:
        raise MachineFileError(source, "", "is a directory, not a machine file") from None
    except UnicodeDecodeError as exc:
        raise MachineFileError(source, "", f"not UTF-8 text ({exc.reason} at byte {exc.start})") from None
    except OSError as exc:
        raise MachineFileError(source, "", f"cannot read machine file: {exc.strerror or exc}") from None


def _with_values(machine: Machine, values: dict[str, Any]) -> Machine:
    """``machine`` loaded again from its own text with ``values`` as ``--set`` overrides."""
    return load_machine_text(machine.text, source=machine.source, base_dir=Path(machine.base_dir), overrides=assignments(values))


def load_machine_text(
    text: str,
    source: str = "<string>",
    base_dir: Path = Path("."),
    overrides: Sequence[str] = (),
) -> Machine:
    """Parse and validate machine-file text.

    Parameters
    ----------
    text : str
        TOML text of a machine file.
    source : str
        Name used in error messages and stored as ``Machine.source``.
    base_dir : Path
        Directory that a cam ``table`` path is relative to.
    overrides : sequence of str
        ``"KEY=VALUE"`` assignments applied to the document before validation.

    Returns
    -------
    Machine
        The machine in SI. ``Machine.text`` is ``text``; with overrides it is the
        overridden document re-serialised as TOML (so that it reproduces the machine).

    Raises
    ------
    MachineFileError
    """
    doc = _parsed(text, source)
    origin: dict[str, str] = {}
    for assignment in overrides:
        path = _apply_override(doc, assignment, source)
        origin[path] = assignment
    try:
        machine = _Validator(source, Path(base_dir)).machine(doc)
    except MachineFileError as exc:
        message = _in_file_units(exc.message, text, overrides)
        if exc.key in origin:
            message += f" (value from --set {origin[exc.key]})"
        if message == exc.message:
            raise
        raise MachineFileError(exc.file, exc.key, message) from None
    if any(c.compensation is not None for c in machine.cams):  # issue 27 (each cam: issue 38)
        from camsim.machine.compensation import CompensationError, compensate_cams

        try:
            machine = compensate_cams(machine)
        except CompensationError as exc:
            message = _in_file_units(exc.message, text, overrides)
            if exc.key in origin:
                message += f" (value from --set {origin[exc.key]})"
            raise MachineFileError(source, exc.key, message) from None
    notes = _bare_number_notes(doc, text, overrides, origin)
    if overrides:
        import tomli_w

        header = "".join(f"# --set {a}\n" for a in overrides)
        text = f"# {source} with command-line overrides:\n{header}" + tomli_w.dumps(doc)
    return _replace_text(machine, text, base_dir, notes)


def _parsed(text: str, source: str) -> dict:
    """The TOML document of ``text``, a copy of its own (the overrides edit it in place);
    parsed once per text in a process (issue 42: an analysis loads the same file with other
    overrides for every run)."""
    try:
        return copy.deepcopy(_parse_once(text))
    except tomllib.TOMLDecodeError as exc:
        raise MachineFileError(source, "", f"invalid TOML: {exc}") from None


@functools.lru_cache(maxsize=8)
def _parse_once(text: str) -> dict:
    return tomllib.loads(text)


@functools.lru_cache(maxsize=8)
def _file_value_notes(text: str, shown) -> tuple:
    """:func:`camsim.machine.notes.value_notes` of the file's own document (no override), per
    text and display units: an analysis's runs differ from it only in their overrides' values."""
    from camsim.machine import notes

    return tuple(notes.value_notes(_parse_once(text), shown))


def _bare_number_notes(doc: dict, text: str, overrides: Sequence[str], origin: dict[str, str]) -> tuple[str, ...]:
    """Issue 44: each bare number read as SI where the file otherwise writes units, and each one
    given with ``--set``, in one line with its value in the file's units (camsim.machine.keys)."""
    from camsim.display import option_quantities, written_units
    from camsim.machine import keys
    from camsim.machine.overrides import _parse_value

    shown = written_units(text, option_quantities(overrides))
    notes = []
    for path, assignment in origin.items():
        key, _, raw = assignment.partition("=")
        note = keys.bare_number_note(f"--set {key.strip()}", _parse_value(raw), keys.unit(path), shown)
        if note:
            notes.append(note)
    return tuple(_document_notes(doc, text, shown, origin) + notes)


def _document_notes(doc: dict, text: str, shown, origin: dict[str, str]) -> list[str]:
    """The bare-number notes of the document's own values (the overridden ones skipped), from
    the file's rows computed once per text (:func:`camsim.machine.notes.document_notes`)."""
    from camsim.machine import notes

    return notes.document_notes(doc, _parse_once(text), _file_value_notes(text, shown), origin, shown)


def _in_file_units(message: str, text: str, overrides: Sequence[str]) -> str:
    """An error message with the SI quantities it quotes in the units the file is written in
    (issue 36: ``roller_radius ... (0.9843 in >= 0.7874 in)`` for an inch file)."""
    from camsim.display import in_units, option_quantities, written_units

    try:
        shown = written_units(text, option_quantities(overrides))
    except Exception:  # noqa: BLE001 - the message as composed rather than no message
        return message
    return in_units(message, shown)


def apply_override(doc: dict, assignment: str, source: str) -> None:
    """Apply one ``KEY=VALUE`` assignment to a parsed machine document, in place.

    Parameters
    ----------
    doc : dict
        The document as returned by :func:`tomllib.loads`.
    assignment : str
        ``"cam.speed=150 rpm"``, ``"mass.M2.mass=1.7 lb"``, ``"cam.segments[2].lift=0.4 in"``,
        ``"element.seat.stiffness=9e6"``, ``"initial.M3.velocity=-0.2 m/s"``. VALUE is read
        as a TOML value when it parses as one (``3``, ``true``, ``"150 rpm"``), otherwise
        taken as a string.
    source : str
        The machine file's name, for error messages.

    Raises
    ------
    MachineFileError
        A malformed assignment, or a key the schema does not have (with a suggestion), or
        a mass, element or segment that the document does not contain.
    """
    _apply_override(doc, assignment, source)


def override_keys(doc: dict) -> list[str]:
    """List every key of ``doc`` that an override can address.

    Parameters
    ----------
    doc : dict
        A parsed machine document.

    Returns
    -------
    list of str
        Keys in override syntax (``cam.segments[0].lift``, ``mass.M1.mass``,
        ``element.K12.stiffness``, ``initial.M2.velocity``...), including keys that the
        schema allows but the file leaves at their default.
    """
    from camsim.machine.keys import document_paths

    return document_paths(doc)


def damping_coefficients(machine: Machine, element: Element) -> dict[str, float]:
    """Viscous damping coefficient(s) of an element [N·s/m].

    With ``damping_ratio`` ζ, c = 2ζ·√(k·m_ref) (spec §3), m_ref being
    ``reference_mass`` or the upper node's mass (the lower node's when the upper is
    ground or the cam).

    Returns
    -------
    dict
        ``{"c": ...}`` for a spring or linear contact, ``{"c_push": ..., "c_pull": ...}``
        for a preloaded link, ``{"c_lower": ..., "c_upper": ...}`` for a lash with a table
        per side, ``{}`` for power-law and restitution contacts (which take
        no viscous damping).
    """
    from camsim.physics.restitution import reduced_mass

    return element.damping_coefficients(lambda name=None: machine.mass_of(name or reference_mass_of(element)),
                                        lambda: reduced_mass(machine, element))


def reference_mass_of(element: Element) -> str:
    """Name of the mass whose value sets c = 2ζ√(k·m) for ``element`` (spec §3)."""
    if element.damping.reference_mass is not None:
        return element.damping.reference_mass
    fixed = (*FIXED_NODES, *element.cam_nodes)  # several cams (issue 38): every cam node
    return element.lower if element.upper in fixed else element.upper


def _cam_dict(cam) -> dict[str, Any]:
    """One cam as :func:`machine_to_dict` describes it (SI)."""
    cam_dict = {
        "speed": cam.speed,
        "period": cam.period,
        "ratio": cam.ratio,
        "arm": cam.arm,
        "drives": cam.drives,
        "start_angle": cam.start_angle,
        "segments": [
            {"motion": s.motion, "law": s.law, "duration": s.duration, "lift": s.lift,
             # issue 27: synthesised segments (None/empty for the standard laws)
             "continuity": s.continuity, "degree": s.degree, "velocity": s.velocity,
             "start": dict(s.start), "end": dict(s.end),
             "points": [{"at": p.at, "s": p.s, **{f"d{k}": v for k, v in p.derivatives}} for p in s.points]}
            for s in cam.segments
        ],
        "compensation": None if cam.compensation is None else {
            "output": cam.compensation.output, "speed": cam.compensation.speed,
            "kind": cam.compensated.kind if cam.compensated is not None else None},
        "table": None,
    }
    if cam.geometry is not None:  # issue 14
        from camsim.cam.arrangement import geometry_to_dict

        cam_dict["geometry"] = geometry_to_dict(cam.geometry)
    if cam.table is not None:
        t = cam.table
        cam_dict["table"] = {
            "source": t.source,
            "angle": list(t.angle),
            "displacement": list(t.displacement),
            "velocity": None if t.velocity is None else list(t.velocity),
            "acceleration": None if t.acceleration is None else list(t.acceleration),
        }
    return cam_dict


def machine_to_dict(machine: Machine) -> dict[str, Any]:
    """A JSON-able description of a machine in SI units.

    Returns
    -------
    dict
        ``name``, ``source``, ``units`` (the SI unit of every quantity key used below),
        ``cam`` (or None), ``masses``, ``elements`` (with the derived damping
        coefficients ``c`` or ``c_push``/``c_pull``), ``simulation``, ``initial``.
    """
    cam = machine.cam
    cam_dict = _cam_dict(cam) if cam is not None else None
    elements = []
    for e in machine.elements:
        row: dict[str, Any] = e.describe()
        row["damping"] = e.damping.coefficient
        row["damping_ratio"] = e.damping.ratio
        row["reference_mass"] = (
            reference_mass_of(e) if e.damping.ratio is not None else e.damping.reference_mass
        )
        row.update(damping_coefficients(machine, e))
        elements.append(row)
    sim = machine.simulation
    return {
        "name": machine.name,
        "source": machine.source,
        "units": {
            "speed": "rad/s",
            "period": "s",
            "arm": "m",
            "start_angle": "rad",
            "duration": "rad (segments) or s (simulation)",
            "lift": "m (at the roller)",
            "angle": "rad",
            "displacement": "m",
            "velocity": "m/s",
            "acceleration": "m/s^2",
            "mass": "kg",
            "stiffness": "N/m",
            "push_stiffness": "N/m",
            "pull_stiffness": "N/m",
            "preload": "N",
            "separation_deflection": "m",
            "gap": "m",
            "coefficient": "N/m^exponent",
            "damping": "N*s/m",
            "c": "N*s/m",
            "c_push": "N*s/m",
            "c_pull": "N*s/m",
            "c_lower": "N*s/m",
            "c_upper": "N*s/m",
            "quadratic_damping": "N*s^2/m^2",
            "sample_rate": "Hz",
            "gravity": "m/s^2",
            "force": "N",
            "change": "N",
            "base": "N",
            "amplitude": "N",
            "offset": "N",
            "frequency": "Hz",
        },
        "cam": cam_dict,
        "masses": [
            {"name": m.name, "mass": m.mass, "driven": m.name in machine.driven_masses}
            for m in machine.masses
        ],
        "elements": elements,
        "simulation": {
            "cycles": sim.cycles,
            "warmup_cycles": sim.warmup_cycles,
            "sample_rate": sim.sample_rate,
            "gravity": sim.gravity,
            "duration": sim.duration,
            "steady_state": sim.steady_state,
        },
        "initial": [
            {"mass": i.mass, "displacement": i.displacement, "velocity": i.velocity}
            for i in machine.initial
        ],
        **_shaft_dict(machine),
        "loads": [_load_dict(load) for load in machine.loads],  # issue 43
    }


def _load_dict(load) -> dict[str, Any]:
    """One ``[[load]]`` as :func:`machine_to_dict` describes it (SI: N, rad, s, Hz)."""
    import dataclasses

    return {
        "name": load.name, "on": load.on, "kind": load.kind, "force": load.force, "base": load.base, "cam": load.cam,
        "table": load.table.source if load.table is not None else None,
        "segments": [{"motion": s.motion, "law": s.law, "duration": s.duration, "change": s.lift,
                      "continuity": s.continuity, "degree": s.degree, "velocity": s.velocity,
                      "start": dict(s.start), "end": dict(s.end),
                      "points": [{"at": p.at, "s": p.s, **{f"d{k}": v for k, v in p.derivatives}} for p in s.points]}
                     for s in load.segments],
        "sine": dataclasses.asdict(load.sine) if load.sine is not None else None,
    }


def _shaft_dict(machine: Machine) -> dict[str, Any]:
    """The cams, camshaft and clearances of a machine with ``[[cam]]`` tables or a ``[camshaft]``
    (issue 38); nothing for a one-cam file without them (its description is unchanged)."""
    import dataclasses

    out: dict[str, Any] = {}
    if machine.multi_cam:
        out["cams"] = [{"name": c.name, "phase": c.phase, **_cam_dict(c)} for c in machine.cams]
    if machine.camshaft is not None:
        shaft = dataclasses.asdict(machine.camshaft)
        shaft["drive_inertia"] = machine.camshaft.drive_inertia
        out["camshaft"] = shaft
    if machine.clearances:
        out["clearances"] = [dataclasses.asdict(c) for c in machine.clearances]
    return out


def _replace_text(machine: Machine, text: str, base_dir: Path, notes: tuple[str, ...] = ()) -> Machine:
    import dataclasses

    return dataclasses.replace(machine, text=text, base_dir=str(base_dir), rebuild=_with_values, notes=notes)

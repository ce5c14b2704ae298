"""Command-line overrides (``--set KEY=VALUE``) applied to a parsed machine document.

The key grammar (:mod:`camsim.machine.keys`, its one owner) addresses masses and elements by name and segments by index::

    cam.speed=150 rpm            cam.segments[2].lift=0.4 in
    mass.M2.mass=1.7 lb          element.seat.stiffness=9e6
    simulation.cycles=3          initial.M3.velocity=-0.2 m/s

and, in a file with ``[[cam]]`` tables, cams by name (``cam.speed`` stays the shaft's)::

    cam.feed.phase=30 deg        cam.feed.segments[0].lift=6 mm
    camshaft.flywheel=0.4 kg*m^2 camshaft.section.feed.stiffness=2e4 N*m/rad

An overridden value is then checked by the validator exactly like one in the file.
"""

from __future__ import annotations

import tomllib
from typing import Any

from camsim.errors import MachineFileError
from camsim.machine import keys


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
    """Apply ``assignment``; return the canonical key path it set (for messages).

    Where the key lands is :func:`camsim.machine.keys.address`'s answer (the one grammar)."""
    if "=" not in assignment:
        raise MachineFileError(source, assignment, 'override must be KEY=VALUE, e.g. cam.speed="150 rpm"')
    key, _, raw = assignment.partition("=")
    return keys.address(doc, key.strip(), source).set(_parse_value(raw))

"""Writing a lumped machine as a commented TOML machine file (``camsim lump -o``).

The bottom of the lump package: it reads a lump result's fields (``machine``, ``parts``,
``source`` and the comments) and imports nothing of the package, so the result
(:class:`camsim.analyses.lump.values.LumpResult`) renders itself through it
(:meth:`~camsim.analyses.lump.values.LumpResult.to_toml`) without an import circle.
"""

from __future__ import annotations

import re
from typing import Any

import tomli_w


def _key(name: str) -> str:
    return name if re.fullmatch(r"[A-Za-z0-9_-]+", name) else '"' + name.replace("\\", "\\\\").replace('"', '\\"') + '"'


def _comment(text: str) -> str:
    return "# " + " ".join(text.split())


def _table_lines(header: str, path: tuple[str, ...], table: dict[str, Any], comments) -> list[str]:
    lines = [header] if header else []
    lines.extend(_comment(c) for c in comments.get((*path, ""), []))
    subtables = []
    for k, v in table.items():
        if isinstance(v, dict):
            subtables.append((k, v))
            continue
        for c in comments.get((*path, k), []):
            lines.append(_comment(c))
        lines.append(_dump_value(k, v))
    for k, v in subtables:
        dotted = ".".join(_key(p) for p in (*[p for p in path if not p.isdigit()], k))
        lines.append("")
        lines.extend(_table_lines(f"[{dotted}]", (*path, k), v, comments))
    return lines


def _dump_value(key: str, value: Any) -> str:
    """``key = value``; a short list of plain values stays on one line."""
    if isinstance(value, list) and value and all(isinstance(v, (str, int, float, bool)) for v in value):
        items = [tomli_w.dumps({"v": v}).rstrip("\n")[4:] for v in value]
        line = f"{tomli_w.dumps({key: 0}).split(' = ')[0]} = [{', '.join(items)}]"
        if len(line) <= 100:
            return line
    return tomli_w.dumps({key: value}).rstrip("\n")


def render_machine(result: Any) -> str:
    """The commented machine file of a :class:`~camsim.analyses.lump.values.LumpResult`."""
    m = result.machine
    c = result._comments
    out = [
        _comment(f"Machine file written by `camsim lump {result.source}`: the lumped masses and elements"),
        _comment("below were computed from the parts file; a comment above each computed value says how."),
        _comment("Edit the parts file and run `camsim lump` again rather than editing the numbers here."),
        "#",
        _comment("Parts:"),
    ]
    for part in result.parts.values():
        out.append(_comment(f"  {part.provenance}" + (f"  [{part.note}]" if part.note else "")))
        if part.unused is not None:
            out.append(_comment(f"    (not used: {part.unused})"))
    out.append("")
    out.append(tomli_w.dumps({"schema": m["schema"]}).rstrip("\n"))
    for section in ("machine", "cam"):
        if section in m:
            out.append("")
            out.extend(_table_lines(f"[{section}]", (section,), m[section], c))
    for section in ("mass", "element"):
        for i, entry in enumerate(m.get(section, [])):
            out.append("")
            out.extend(_table_lines(f"[[{section}]]", (section, str(i)), entry, c))
    for section in ("simulation", "initial"):
        if section in m:
            out.append("")
            out.extend(_table_lines(f"[{section}]", (section,), m[section], c))
    return "\n".join(out) + "\n"

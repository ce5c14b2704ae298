"""Writing the fitted machine file: the input text with the fitted values replaced in place.

The machine file is edited with tomlkit, so every comment, blank line and the layout stay
as written; only the fitted values change. A value written with a unit keeps that unit
(``push_stiffness = "8144 lbf/in"`` becomes ``"7712.455 lbf/in"``); a bare number stays a
bare SI number. Each changed line gets a comment with the old value and the 95 %
interval, in the same unit, in front of any comment the line had::

    push_stiffness = "7712.455 lbf/in" # fitted: was "8144 lbf/in"; 95 % CI 7650.1 to 7774.8 lbf/in

A key that the file leaves at its default is added at the end of its table. A value
inside an inline table (a cam segment) gets its comment at the end of that line. Keys are
addressed as on the command line (``--set`` grammar): ``element.K23.push_stiffness`` is the
``[[element]]`` whose ``name`` is ``K23``; ``element[2].stiffness`` the third;
``cam.segments[2].lift``, ``mass.M3.mass``, ``initial.M3.velocity``, ``cam.speed``.
"""

from __future__ import annotations

import math
import os
import re
from pathlib import Path

from camsim.errors import InputError, MachineFileError
from camsim.machine import keys

__all__ = ["edited_text", "fitted_text", "write_fitted", "VALUE_DIGITS"]

#: Significant digits of a fitted value written into the file.
VALUE_DIGITS = 7
_NUMBER = re.compile(r"^\s*([-+]?(?:\d+(?:\.\d*)?|\.\d+)(?:[eE][-+]?\d+)?)\s*(.*?)\s*$")


def _locate(doc, key: str):
    """(container, leaf, inline) of ``key`` in the tomlkit document ``doc``
    (:func:`camsim.machine.keys.address`, the one owner of the key grammar)."""
    import tomlkit
    from tomlkit.items import InlineTable

    def make_table(super_table: bool = False):
        return tomlkit.table(is_super_table=super_table)

    found = keys.address(doc, key, make_table=make_table)
    return found.table, found.leaf, isinstance(found.table, InlineTable)


def _number(value: float) -> str:
    text = format(value, f".{VALUE_DIGITS}g")
    return text


def _pint_unit(si: str) -> str:
    m = re.match(r"^N/m\^([-+0-9.eE]+)$", si)
    return f"N / m ** {m.group(1)}" if m else (si or "dimensionless")


def _in_unit(value_si: float, unit: str, si_unit: str) -> float | None:
    """``value_si`` [si_unit] expressed in ``unit`` (None when pint cannot convert)."""
    from camsim.units import ureg

    try:
        return float(ureg.Quantity(value_si, _pint_unit(si_unit)).to(unit).magnitude)
    except Exception:  # noqa: BLE001 - e.g. a lift given as an angle (needs the arm)
        return None


def fitted_text(text: str, result, source: str = "<string>") -> str:
    """The machine file ``text`` with the fitted values of ``result`` written in place.

    Parameters
    ----------
    text : str
        The machine file as read.
    result : FitResult
    source : str
        The file name (for messages).

    Returns
    -------
    str
        The fitted machine file (same comments and layout; see the module docstring).
    """
    entries = []
    for i, key in enumerate(result.keys):
        if key == "align.offset":
            continue
        lo, hi = (float(v) for v in result.ci95[i])

        def note(was, shown, shown_unit, lo=lo, hi=hi):
            if math.isfinite(lo) and math.isfinite(hi):
                interval = f"95 % CI {shown(lo)} to {shown(hi)}{shown_unit}"
            else:
                interval = "95 % CI not determined by the data"
            return f"fitted: {was}; {interval}"

        entries.append((key, float(result.values[i]), result.units[i], float(result.file_values[i]), note))
    return edited_text(text, entries, source, "fitted")


def edited_text(text: str, entries, source: str = "<string>", what: str = "fitted") -> str:
    """The machine file ``text`` with values written in place, each line commented.

    Shared by ``fit`` (FITTED.toml) and ``optimize`` (OPTIMISED.toml).

    Parameters
    ----------
    text : str
        The machine file as read.
    entries : sequence of (key, value, si_unit, file_value, note)
        ``value`` an SI float (written in the unit the file used for it) or a string (a
        choice such as a law, written as is); ``note(was, shown, shown_unit)`` returns the
        comment, ``was`` being ``'was <old value as written>'``.
    source : str
        The file name (for messages).
    what : str
        What the values are, for messages.
    """
    import tomlkit

    doc = tomlkit.parse(text)
    inline_notes: list[tuple[str, str, str]] = []
    for i, (key, value, si_unit, file_value, note_of) in enumerate(entries):
        try:
            table, leaf, inline = _locate(doc, key)
        except (KeyError, IndexError, StopIteration, TypeError, MachineFileError):
            raise InputError(f"{source}: {key}: not found in the machine file to write the {what} value") from None
        old = table.get(leaf)
        # Table.item() is tomlkit >= 0.13.1; the table's container has had .item() far longer.
        old_item = table.value.item(leaf) if leaf in table else None
        unit = ""
        if isinstance(old, str) and not isinstance(value, str):
            m = _NUMBER.match(old)
            unit = m.group(2) if m else ""
        if isinstance(value, str):
            new_value = tomlkit.string(value)
            shown = str
            shown_unit = ""
        elif unit and _in_unit(1.0, unit, si_unit) is not None:
            new_value = tomlkit.string(f"{_number(_in_unit(value, unit, si_unit))} {unit}")
            shown = lambda v: _number(_in_unit(v, unit, si_unit))  # noqa: E731
            shown_unit = f" {unit}"
        else:
            new_value = tomlkit.item(float(_number(value)))
            shown = _number
            shown_unit = f" {si_unit}" if si_unit else ""
        if old is not None:
            was = f"was {tomlkit.item(old).as_string()}"
        elif isinstance(file_value, str):
            was = f"was the default {file_value}"
        else:
            was = f"was the default {_number(float(file_value))}{shown_unit}"
        note = note_of(was, shown, shown_unit)
        if inline:
            marker = f"@@camsim-{what}-{i}@@"
            inline_notes.append((marker, new_value.as_string(), note))
            table[leaf] = marker
            continue
        if old_item is not None:
            trivia = old_item.trivia
            new_value.trivia.indent = trivia.indent
            new_value.trivia.trail = trivia.trail
            previous = trivia.comment.lstrip("#").strip()
            new_value.trivia.comment_ws = trivia.comment_ws or " "
            new_value.trivia.comment = "# " + note + (f" | {previous}" if previous else "")
        else:
            new_value.comment(note)
        table[leaf] = new_value
    out = tomlkit.dumps(doc)
    if inline_notes:
        out = _annotate_inline(out, inline_notes)
    return out


def _annotate_inline(text: str, notes: list[tuple[str, str, str]]) -> str:
    """Put each inline-table value (held by a unique marker) in place, with its note at the line's end."""
    lines = text.splitlines(keepends=True)
    for marker, value_text, note in notes:
        quoted = f'"{marker}"'
        j = next(k for k, line in enumerate(lines) if quoted in line)
        line = lines[j].replace(quoted, value_text)
        body = line.rstrip("\r\n")
        end = line[len(body):]
        sep = " | " if _has_comment(body) else "  # "
        lines[j] = body + sep + note + end
    return "".join(lines)


def _has_comment(line: str) -> bool:
    """Whether a TOML line ends in a comment (a ``#`` outside strings)."""
    quote = None
    for ch in line:
        if quote:
            if ch == quote:
                quote = None
        elif ch in "\"'":
            quote = ch
        elif ch == "#":
            return True
    return False


def write_fitted(path: str | os.PathLike[str], text: str, result, source: str = "<string>") -> Path:
    """Write :func:`fitted_text` to ``path`` atomically (temporary name, then rename)."""
    from camsim.io.outputs import writing

    content = fitted_text(text, result, source)
    target = Path(path)
    with writing(target, "toml", owner="fit") as out:
        out.put_text(content)
    return target

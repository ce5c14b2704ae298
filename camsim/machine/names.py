"""The names of a machine file's tables, checked once for every table (issue 45).

A name becomes a path of the result file (``/masses/<name>/velocity``, ``/elements/<name>/force``,
``/cam/<name>/...``), a key of ``--set`` (``mass.<name>.mass``), a column of sweeps and studies
(``peak_velocity:<name>``) and an id and a label of the report page. So every name of every
named table is one HDF5 link name that needs no escaping, one ``--set`` key part and one HTML
id: letters, digits, ``_`` and ``-``, starting with a letter or ``_``, at most
:data:`MAX_LENGTH` characters (before, ``M/3`` validated and ran, then ``report`` failed with
"internal error (StopIteration)" and ``plot`` left it out silently).

:data:`TABLES` lists the named tables; a new table of named rows (``[[load]]``, issue 43) is one
line there.
"""

from __future__ import annotations

import re
from collections.abc import Callable
from typing import Any

__all__ = ["TABLES", "MAX_LENGTH", "NAME", "check_names"]

#: Longest name [characters].
MAX_LENGTH = 64
#: What a name may hold.
NAME = re.compile(r"[A-Za-z_][A-Za-z0-9_\-]*\Z")
#: Table -> what its names become (for the message).
TABLES: dict[str, str] = {
    "mass": "/masses/<name>/... in the result",
    "element": "/elements/<name>/... in the result",
    "cam": "/cam/<name>/... in the result",
    "material": "materials = [...] of a contact",
    "load": "/loads/<name>/force in the result",
}


def check_names(doc: dict[str, Any], error: Callable[[str, str], Exception]) -> None:
    """Raise ``error(key, message)`` for the first name of a named table that a result file, a
    ``--set`` key or a report page could not hold. Other problems (a name that is not a string,
    a missing one) are left to the table's reader."""
    for table, becomes in TABLES.items():
        rows = doc.get(table)
        if not isinstance(rows, list):
            continue  # [cam] as one table has no name; a wrong type is the reader's to report
        for i, row in enumerate(rows):
            name = row.get("name") if isinstance(row, dict) else None
            if not isinstance(name, str) or not name.strip():
                continue
            if len(name) > MAX_LENGTH or not NAME.match(name):
                why = f"longer than {MAX_LENGTH} characters" if len(name) > MAX_LENGTH else "not a plain name"
                raise error(f"{table}[{i}].name", f"{name[:80]!r} is {why}: a name is letters, digits, '_' and '-', "
                            f"starting with a letter or '_' (at most {MAX_LENGTH} characters), because it names "
                            f"{becomes}, --set keys and the report's pages")

"""Machines the derandomized CI profile draws on which an invariant fails, beyond the known
limits of the tolerances (invariant_tests.KNOWN_LIMIT): the engine's open defects (issue 34).

Each is kept in ``machines/known-*.toml`` with a strict xfail in test_regressions.py that
checks the invariant on it (so a fix makes that test pass, strict, and fails until the entry
is removed here). When the suite draws one of them, the test reports an expected failure
naming it, never a pass. A machine is recognised by its parsed content (key order and
formatting aside).
"""

from __future__ import annotations

import hashlib
import json
import tomllib
from pathlib import Path

MACHINES = Path(__file__).parent / "machines"

#: machine file → (the invariant it breaks, what is wrong, measured)
KNOWN = {
}


def fingerprint(text: str) -> str:
    """A machine's identity: the hash of its parsed content."""
    return hashlib.sha256(json.dumps(tomllib.loads(text), sort_keys=True).encode()).hexdigest()


_BY_PRINT = {fingerprint((MACHINES / name).read_text()): (name, *why) for name, why in KNOWN.items()}


def known(text: str) -> tuple[str, str, str] | None:
    """(file, invariant, reason) when ``text`` is a known failure, else None."""
    return _BY_PRINT.get(fingerprint(text))

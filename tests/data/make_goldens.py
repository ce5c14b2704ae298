"""Regenerate the golden result files the regression tests compare against.

    python tests/data/make_goldens.py

Runs each machine listed in tests/data/golden/goldens.txt with the options given there
and writes tests/data/golden/<name>.h5 (scripts/ci-check.sh reads the same list). Run it deliberately, after a change that is meant to move
the numbers, and say why in the commit message. Takes a few seconds.
"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
OUT = ROOT / "tests" / "data" / "golden"



def read_goldens() -> dict[str, list[str]]:
    """name -> camsim run arguments, from goldens.txt (kept small: coarse sample rates)."""
    goldens = {}
    for line in (OUT / "goldens.txt").read_text().splitlines():
        if line.strip() and not line.lstrip().startswith("#"):
            name, *args = line.split()
            goldens[name] = args
    return goldens


GOLDENS = read_goldens()


def main() -> int:
    OUT.mkdir(parents=True, exist_ok=True)
    for name, args in GOLDENS.items():
        target = OUT / f"{name}.h5"
        cmd = [sys.executable, "-m", "camsim", "run", *args, "-o", str(target), "--json"]
        subprocess.run(cmd, cwd=ROOT, check=True, stdout=subprocess.DEVNULL)
        print(f"wrote {target.relative_to(ROOT)} ({target.stat().st_size} bytes)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

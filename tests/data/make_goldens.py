"""Regenerate the golden result files the regression tests compare against.

    python tests/data/make_goldens.py

Runs each shipped machine with the settings in GOLDENS and writes
tests/data/golden/<name>.h5. Run it deliberately, after a change that is meant to move
the numbers, and say why in the commit message. Takes a few seconds.
"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
OUT = ROOT / "tests" / "data" / "golden"

#: name -> camsim run arguments (kept small: a coarse sample rate, one recorded cycle).
GOLDENS: dict[str, list[str]] = {
    "cdtm": ["machines/cdtm.toml", "--sample-rate", "5 kHz"],
    "dynacam-2mass": ["machines/dynacam-2mass.toml", "--sample-rate", "2 kHz"],
    "barkan-follower": ["machines/barkan-follower.toml", "--sample-rate", "2 kHz"],
}


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

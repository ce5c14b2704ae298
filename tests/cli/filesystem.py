"""What the file-system tests of tests/cli share (issue 35): a fast machine, a full disk,
a read-only folder, an injected ENOSPC."""

from __future__ import annotations

import errno
import os
import shutil
import subprocess
from pathlib import Path

#: The machine of most examples: one driven mass on a spring (tests/fit/machines.py), fast.
MACHINE = """\
schema = 1

[machine]
name = "conformance machine"

[cam]
speed = "120 rpm"
drives = "M"
segments = [
  { motion = "rise", law = "harmonic", duration = "180 deg", lift = "10 mm" },
  { motion = "fall", law = "harmonic", duration = "180 deg", lift = "10 mm" },
]

[[mass]]
name = "M"
mass = "2 kg"

[[element]]
name = "K"
type = "spring"
between = ["ground", "M"]
stiffness = "5 N/mm"
preload = "40 N"
damping = 0

[simulation]
cycles = 1
warmup_cycles = 0
sample_rate = "500 Hz"
"""


def mount_tmpfs(path: Path, options: str) -> bool:
    """Mount a tmpfs at ``path`` (root only); False when it cannot."""
    if os.geteuid() != 0 or shutil.which("mount") is None:
        return False
    path.mkdir(parents=True, exist_ok=True)
    r = subprocess.run(["mount", "-t", "tmpfs", "-o", options, "tmpfs", str(path)], capture_output=True)
    return r.returncode == 0


def umount(path: Path) -> None:
    subprocess.run(["umount", "-l", str(path)], capture_output=True)


def fill(folder: Path) -> None:
    """Fill the file system of ``folder`` to the last block."""
    with open(folder / "filler", "wb") as fh:
        try:
            while True:
                fh.write(b"\0" * 65536)
                fh.flush()
        except OSError:
            pass


def inject_enospc(monkeypatch) -> None:
    """Every byte camsim writes goes through camsim.io.atomic.raw_write: make it fail."""
    import camsim.io.atomic as atomic

    def enospc(fd, data, offset=None):
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

    monkeypatch.setattr(atomic, "raw_write", enospc)

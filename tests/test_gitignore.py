"""Issue 44, item 7: the README's commands leave no untracked file behind.

Every file the commands shown in README.md write in the checkout (their -o, -r, --plot,
--report, --profile outputs, the CSV beside a sweep or study, the journal beside a result, the
image directory of ``camsim plot``) is ignored by .gitignore (``git check-ignore``).
"""

from __future__ import annotations

import re
import shlex
import shutil
import subprocess
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


def _written() -> list[str]:
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    out = []
    for block in re.findall(r"```[a-z]*\n(.*?)```", text, re.S):
        for line in block.replace("\\\n", " ").splitlines():
            line = line.strip().removeprefix("$ ")
            if not line.startswith("camsim "):
                continue
            argv = shlex.split(line.split(" #", 1)[0])
            for i, a in enumerate(argv[:-1]):
                if a in ("-o", "--output", "-r", "--plot", "--report", "--profile", "--dxf", "--pdf"):
                    out.append(argv[i + 1])
            if argv[1] in ("sweep", "study") and "-o" in argv:
                h5 = argv[argv.index("-o") + 1]
                out += [str(Path(h5).with_suffix(".csv")), h5 + ".journal"]
            if argv[1] == "plot":
                out.append(f"{Path(argv[2]).stem}_plots/x.png")
            if argv[1] == "run" and "-o" not in argv:
                out.append(str(Path(argv[2]).with_suffix(".h5")))
    return out


def test_every_file_the_readme_writes_is_ignored():
    if shutil.which("git") is None or not (ROOT / ".git").exists():
        pytest.skip("not a git checkout")
    written = _written()
    assert len(written) >= 8 and "study.png" in written and "cdtm_sweep.csv" in written
    done = subprocess.run(["git", "check-ignore", "--no-index", "-v", "-n", *written], cwd=ROOT, capture_output=True, text=True)
    unmatched = [line.split("\t")[-1] for line in done.stdout.splitlines() if line.startswith("::")]
    assert not unmatched, f"not ignored: {unmatched}"

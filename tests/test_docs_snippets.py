"""The code on docs/python-api.md, docs/architecture.md and docs/cam-design.md runs as printed.

Each page's ```python blocks run in order, in one namespace, in a fresh interpreter
(a page may register an element kind; the registry is per process) from the repository
root. The pages' own asserts are the checks: closed forms in the toy-law walkthrough,
round trips on the API page.
"""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


def _blocks(page: Path) -> str:
    return "\n\n".join(re.findall(r"```python\n(.*?)```", page.read_text(encoding="utf-8"), re.S))


@pytest.mark.parametrize("page", ["python-api.md", "architecture.md", "cam-design.md"])
def test_page_snippets_run(page):
    code = _blocks(ROOT / "docs" / page)
    assert code.strip(), f"no python blocks in docs/{page}"
    done = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, f"docs/{page}:\n{done.stderr[-3000:]}"


def test_machine_file_reference_is_current():
    """docs/machine-file.md's generated tables equal what the schema renders today."""
    from camsim.machine.schema import render_reference

    text = (ROOT / "docs" / "machine-file.md").read_text(encoding="utf-8")
    assert "<!-- schema:element -->" in text
    assert render_reference(text) == text, "run: python -m camsim.machine.schema docs/machine-file.md"

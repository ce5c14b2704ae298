"""The package's shape (issue 11): element kinds live only under camsim/elements/.

These are structural checks, not numbers: each fails on a concrete line of code that
breaks the architecture (docs/architecture.md) and names it.
"""

from __future__ import annotations

import ast
import re
from pathlib import Path

import camsim

PACKAGE = Path(camsim.__file__).parent
KIND_NAMES = ("restitution", "power", "linear", "preloaded", "contact", "spring", "lash", "adams-impact")
#: `x == "power"`, `"power" != law`, `law in ("linear", ...)` with element kind or law names.
_COMPARISON = re.compile(
    r"""([=!]=\s*["'](%s)["'])|(["'](%s)["']\s*[=!]=)|(\bin\s*[(\[{][^)\]}]*["'](%s)["'])"""
    % (("|".join(KIND_NAMES),) * 3)
)
_ELEMENT_CLASSES = ("Spring", "PreloadedLink", "Contact", "LinearContact", "PowerContact", "RigidContact")


def _sources(outside_elements: bool = True):
    for path in sorted(PACKAGE.rglob("*.py")):
        rel = path.relative_to(PACKAGE).as_posix()
        if outside_elements and rel.startswith("elements/"):
            continue
        yield rel, path.read_text(encoding="utf-8")


def test_no_kind_or_law_name_comparison_outside_elements():
    """Nothing outside camsim/elements/ compares an element kind or contact-law name."""
    hits = []
    for rel, text in _sources():
        for n, line in enumerate(text.splitlines(), 1):
            code = re.sub(r"\bfor\s+[\w, ]+\s+in\b", "", line.split("#", 1)[0])  # a loop is no comparison
            if _COMPARISON.search(code):
                hits.append(f"camsim/{rel}:{n}: {line.strip()}")
    assert not hits, "kind/law names compared outside camsim/elements/:\n" + "\n".join(hits)


def test_no_isinstance_on_element_classes_outside_elements():
    """Outside camsim/elements/ an element is used through its protocol, not its class."""
    hits = []
    for rel, text in _sources():
        for node in ast.walk(ast.parse(text)):
            if isinstance(node, ast.Call) and getattr(node.func, "id", "") == "isinstance" and len(node.args) == 2:
                names = {n.id for n in ast.walk(node.args[1]) if isinstance(n, ast.Name)}
                names |= {n.attr for n in ast.walk(node.args[1]) if isinstance(n, ast.Attribute)}
                if names & set(_ELEMENT_CLASSES):
                    hits.append(f"camsim/{rel}:{node.lineno}")
    assert not hits, "isinstance on element classes outside camsim/elements/: " + ", ".join(hits)


def test_cli_command_modules_do_not_import_each_other():
    """A command module imports the library and camsim.cli.app, never another command."""
    hits = []
    for rel, text in _sources():
        if not rel.startswith("cli/cmd_"):
            continue
        for node in ast.walk(ast.parse(text)):
            if isinstance(node, ast.ImportFrom) and (node.module or "").startswith("camsim.cli.cmd_"):
                hits.append(f"camsim/{rel}:{node.lineno} imports {node.module}")
    assert not hits, "\n".join(hits)


def test_cli_package_does_not_swallow_import_errors():
    """camsim/cli/__init__.py must not catch ModuleNotFoundError (a broken import surfaces)."""
    text = (PACKAGE / "cli" / "__init__.py").read_text(encoding="utf-8")
    handlers = [n for n in ast.walk(ast.parse(text)) if isinstance(n, ast.ExceptHandler)]
    assert not handlers, "camsim/cli/__init__.py catches exceptions while importing commands"

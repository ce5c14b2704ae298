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


# --------------------------------------------------------------------------------------
# Layers and cycles (issue 25): the contracts in pyproject.toml, and no import cycle at all.

ROOT = PACKAGE.parent


def test_import_linter_contracts_hold(tmp_path):
    """``lint-imports`` with the contracts of pyproject.toml ([tool.importlinter]): every layer
    imports only downward, function-level imports included. Reference: the layer list of
    docs/architecture.md, written as those contracts."""
    import os
    import subprocess
    import sys

    pytest = __import__("pytest")
    pytest.importorskip("importlinter")
    exe = Path(sys.executable).with_name("lint-imports")
    cmd = [str(exe)] if exe.exists() else [sys.executable, "-c", "import sys; from importlinter.cli import lint_imports_command; sys.exit(lint_imports_command())"]
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    out = subprocess.run([*cmd, "--no-cache"], cwd=ROOT, capture_output=True, text=True, env=env, timeout=120)
    assert out.returncode == 0, out.stdout[-4000:] + out.stderr[-2000:]
    assert "0 broken" in out.stdout


def _module_graph():
    grimp = __import__("pytest").importorskip("grimp")
    graph = grimp.build_graph("camsim", exclude_type_checking_imports=True, cache_dir=None)
    return {m: graph.find_modules_directly_imported_by(m) for m in graph.modules}


def _cycles(edges: dict[str, set[str]]) -> list[list[str]]:
    """Strongly connected components with more than one module (Tarjan), iteratively."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on: set[str] = set()
    found: list[list[str]] = []
    counter = 0
    for root in sorted(edges):
        if root in index:
            continue
        work = [(root, iter(sorted(edges[root])))]
        index[root] = low[root] = counter
        counter += 1
        stack.append(root)
        on.add(root)
        while work:
            v, children = work[-1]
            for w in children:
                if w not in index:
                    index[w] = low[w] = counter
                    counter += 1
                    stack.append(w)
                    on.add(w)
                    work.append((w, iter(sorted(edges.get(w, ())))))
                    break
                if w in on:
                    low[v] = min(low[v], index[w])
            else:
                work.pop()
                if work:
                    low[work[-1][0]] = min(low[work[-1][0]], low[v])
                if low[v] == index[v]:
                    component = []
                    while True:
                        w = stack.pop()
                        on.discard(w)
                        component.append(w)
                        if w == v:
                            break
                    if len(component) > 1:
                        found.append(sorted(component))
    return found


def test_cycle_finder_finds_a_known_cycle():
    """The cycle finder itself, on a hand-made graph with one three-module cycle and a tail."""
    edges = {"a": {"b"}, "b": {"c"}, "c": {"a", "d"}, "d": set(), "e": {"a"}}
    assert _cycles(edges) == [["a", "b", "c"]]


def test_no_import_cycle_anywhere_in_camsim():
    """No module of camsim reaches itself through imports (function-level imports count;
    ``if TYPE_CHECKING`` imports do not run and do not count)."""
    cycles = _cycles(_module_graph())
    assert not cycles, "import cycles: " + "; ".join(" -> ".join(c) for c in cycles)

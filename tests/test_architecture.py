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
    graph = grimp.build_graph("camsim", exclude_type_checking_imports=False, cache_dir=None)
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
    """No module of camsim reaches itself through imports. Function-level imports count, and
    so do ``if TYPE_CHECKING`` ones: they do not run, but a type one module needs from a
    module that needs it back belongs one module down (the sweep's result types in
    analyses/sweep/result.py; farm-studio drew three such circles before)."""
    cycles = _cycles(_module_graph())
    assert not cycles, "import cycles: " + "; ".join(" -> ".join(c) for c in cycles)


# --------------------------------------------------------------------------------------
# One way to write a file (issue 35): the output policy.

#: Modules that may touch the file system's write primitives: the policy and its mechanics.
_WRITERS = {"io/atomic.py", "io/outputs.py", "io/locks.py", "io/hdf5.py"}
#: Calls that write a file (or put one in place) by themselves.
_WRITE_CALLS = {"write_text", "write_bytes", "savefig", "saveas", "savetxt", "to_csv", "to_hdf", "create_file",
                "atomic_path", "temp_path_for", "pwrite", "ftruncate", "mkstemp", "NamedTemporaryFile", "move", "copy",
                "copyfile", "copy2"}


def _writes_a_file(node: ast.Call) -> str | None:
    """The write primitive ``node`` calls, or None."""
    func = node.func
    name = func.attr if isinstance(func, ast.Attribute) else getattr(func, "id", "")
    if name in ("savefig", "savetxt", "saveas"):
        # to an opened file of the policy (a Target's binary()/text()) only: the first
        # argument is then a name bound by `with ... as fh`, never a path expression
        first = node.args[0] if node.args else None
        return None if isinstance(first, ast.Name) and first.id in ("fh", "out", "buffer") else name
    if name in ("replace", "rename") and isinstance(func, ast.Attribute):
        owner = getattr(func.value, "id", "")
        if owner == "os" or (len(node.args) == 1 and not node.keywords):  # os.replace(a, b), path.replace(target)
            return f"{owner or '<path>'}.{name}"
        return None  # str.replace(old, new), dataclasses.replace(obj, **changes)
    if name in ("move", "copy", "copyfile", "copy2"):
        return f"shutil.{name}" if isinstance(func, ast.Attribute) and getattr(func.value, "id", "") == "shutil" else None
    if name in _WRITE_CALLS - {"savefig", "savetxt", "saveas"}:
        return name
    if name == "open" and isinstance(func, ast.Name):
        mode = node.args[1] if len(node.args) > 1 else next((k.value for k in node.keywords if k.arg == "mode"), None)
        if isinstance(mode, ast.Constant) and isinstance(mode.value, str) and set(mode.value) & set("wax+"):
            return f"open(..., {mode.value!r})"
    if name == "open" and isinstance(func, ast.Attribute) and getattr(func.value, "id", "") == "os":
        flags = ast.unparse(node.args[1]) if len(node.args) > 1 else ""
        if any(f in flags for f in ("O_WRONLY", "O_RDWR", "O_CREAT", "O_APPEND")):
            return "os.open(..., write flags)"
    if name == "File" and any(isinstance(a, ast.Constant) and a.value in ("w", "a", "r+", "x", "w-") for a in node.args[1:2]):
        if not any(k.arg == "backing_store" and isinstance(k.value, ast.Constant) and k.value.value is False for k in node.keywords):
            return "h5py.File(..., write mode)"
    return None


def test_every_file_is_written_through_the_output_policy():
    """No module writes a file except through camsim.io.outputs.writing (issue 35): a writer
    is handed an opened temporary file (its lock, rename and file-system errors owned by the
    policy), never a path to write itself. Allowed: the policy's modules; the row store's
    journal (opened and appended through camsim.io.atomic); an in-memory HDF5 image."""
    hits = []
    for rel, text in _sources(outside_elements=False):
        if rel in _WRITERS:
            continue
        for node in ast.walk(ast.parse(text)):
            if isinstance(node, ast.Call):
                what = _writes_a_file(node)
                if what is not None and not (rel == "io/rowstore.py" and what == "ftruncate"):
                    hits.append(f"camsim/{rel}:{node.lineno}: {what}")
    assert not hits, "files written outside the output policy (camsim.io.outputs.writing):\n" + "\n".join(hits)

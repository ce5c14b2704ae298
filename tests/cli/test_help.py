"""Issue 44, item 6: ``--help`` of every command has examples, shows its defaults and names no
internal type.

Before: only ``impact`` had an example; options read ``<list[str]>``, ``<list[Path]>``,
``<int range>`` and a required argument ``{machine}``; ``--cycles``, ``--warmup``,
``--sample-rate``, ``--rtol``, ``--atol`` and ``--cs`` did not say what they default to.
The examples are parsed here by the command they show (an unknown option fails), and the
shipped files they name exist.
"""

from __future__ import annotations

import re
import shlex
from pathlib import Path

import pytest
import typer
from typer.testing import CliRunner

from camsim.cli import app
from camsim.cli.helptext import EXAMPLES

ROOT = Path(__file__).resolve().parents[2]
runner = CliRunner()

#: Options whose value has a default the command uses (shown, or said in the help text).
DEFAULTED = ("--cycles", "--warmup", "--sample-rate", "--rtol", "--atol", "--cs", "--workers", "--samples", "--seed",
             "--method", "--tol-sigma", "--budget", "--points", "--show", "--max-runs", "--max-output",
             "--max-variants", "--units")


def _commands() -> list[str]:
    group = typer.main.get_command(app)
    out = []
    for name, cmd in group.commands.items():
        out.append(name)
        out += [f"{name} {sub}" for sub in getattr(cmd, "commands", {})]
    return out


def _help(path: str) -> str:
    r = runner.invoke(app, [*path.split(), "--help"], env={"COLUMNS": "200"})
    assert r.exit_code == 0, r.output
    return r.output


@pytest.mark.parametrize("path", _commands())
def test_help_has_examples_defaults_and_plain_names(path):
    text = _help(path)
    assert "Examples:" in text, f"camsim {path} --help has no Examples section"
    internal = re.findall(r"<(?:path|int|float|str|bool|text|list\[[^>]*\]|(?:int|float) range)>", text, re.I)
    assert not internal, internal
    assert not re.search(r"\{\w+\}", text), re.search(r"\{\w+\}", text).group(0)
    options = text.split("Options:", 1)[1].split("Examples:", 1)[0]
    rows = re.split(r"\n  (?=-)", options)
    for row in rows:
        name = re.match(r"(?:-\w, )?(--[\w-]+)", row.strip())
        if name and name.group(1) in DEFAULTED:
            assert "[default:" in row or "default" in row.lower(), f"camsim {path} {name.group(1)}: no default said:\n{row}"


@pytest.mark.parametrize("path", [p for p in EXAMPLES])
def test_every_example_parses_and_names_files_that_exist(path):
    group = typer.main.get_command(app)
    cmd = group
    for part in path.split():
        cmd = cmd.commands[part]
    for line in EXAMPLES[path]:
        if line.startswith("#"):
            continue
        argv = shlex.split(line.split(" #", 1)[0])
        assert argv[:len(path.split()) + 1] == ["camsim", *path.split()]
        args = argv[len(path.split()) + 1:]
        cmd.make_context(path, list(args), resilient_parsing=False)  # an unknown option raises
        for a in args:
            if a.startswith(("machines/", "tests/")) and not a.endswith((".h5", ".html")):
                assert (ROOT / a).exists(), f"{path}: {a} does not exist"


def test_study_output_is_the_file_and_a_reduction_says_reduce(tmp_path):
    """``study --output`` was a trace reduction while every other command's --output is its file;
    it names the study file now (as -o), and a reduction given there says --reduce."""
    r = runner.invoke(app, ["study", str(ROOT / "machines" / "cdtm.toml"), "--dist", "element.K23.preload=tol:28.12:3lbf",
                            "--output", "max:masses/M3/acceleration", "-n", "2"])
    assert r.exit_code == 2
    assert "-o/--output" in r.output and "--reduce max:masses/M3/acceleration" in r.output
    assert "--reduce REDUCER:PATH" in _help("study") and "-o, --output, --out PATH" in _help("study")

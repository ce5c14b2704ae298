"""Every positional file argument of every command refuses an empty name (camsim.cli.file_arguments).

Reference: the fuzzer's case ``camsim report ''`` (tests/cli/test_fuzz.py), which ended in
"internal error (ValueError: PosixPath('.') has an empty name)", exit 1. The rule of bad input:
one line on stderr naming the argument, exit 2, nothing written. Every command is walked, so a
new one is covered without a line here.
"""

from __future__ import annotations

import pytest
import typer.main
from typer.testing import CliRunner

import camsim.cli  # noqa: F401 - registers every command
from camsim.cli.app import app
from camsim.cli.helptext import _walk

runner = CliRunner()


def _commands_with_file_arguments():
    out = []
    for path, cmd in _walk(typer.main.get_command(app)):
        arguments = [p for p in cmd.params if getattr(p, "param_type_name", "") == "argument"]
        if arguments and getattr(cmd, "callback", None) is not None:
            # a required option (check's --against) given a value, so that the arguments are reached
            required = [w for p in cmd.params if getattr(p, "param_type_name", "") == "option" and p.required
                        for w in (p.opts[0], "x.h5")]
            out.append((path, len(arguments), tuple(required)))
    return out


COMMANDS = _commands_with_file_arguments()


def test_every_command_with_a_file_argument_is_walked():
    names = {path for path, _, _ in COMMANDS}
    assert {"run", "validate", "report", "compare", "export", "plot", "check", "impact fit"} <= names, names


@pytest.mark.parametrize("path,n,required", COMMANDS, ids=[p for p, _, _ in COMMANDS])
@pytest.mark.parametrize("word", ["", ".", "/"])
def test_a_nameless_file_argument_is_one_line_and_exit_2(path, n, required, word, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    r = runner.invoke(app, [*path.split(), *required, *([word] * n)])
    lines = [line for line in r.stderr.splitlines() if line.strip()]
    assert r.exit_code == 2, (r.exit_code, r.stderr)
    assert len(lines) == 1 and "names no file" in lines[0] and "internal error" not in lines[0], r.stderr
    assert not list(tmp_path.iterdir())  # nothing written

"""Every file a command takes as an argument names a file: one guard for all commands.

A shell passes an empty word (``camsim report ''``, an unset variable in a script) as an empty
argument, which ``pathlib.Path`` reads as ``.``, the current folder; ``/`` is read the same
way. Each command then failed wherever it first used the name -- ``report`` in computing its
default output (``with_suffix`` of an empty name: "internal error (ValueError)", found by
tests/cli/test_fuzz.py). Every positional argument of every camsim command is a file (a
machine file, a result, a CSV table, a parts table), so the guard sits on the command group,
not in each command: a path argument with no file name is a usage error, one line, exit 2,
before the command runs.
"""

from __future__ import annotations

from functools import wraps
from pathlib import PurePath
from typing import Any


def _nameless(value: Any) -> bool:
    # a typer that converts after the callback is entered (typer < 0.25 on click) hands the
    # raw strings over: every positional argument is a file name either way
    values = value if isinstance(value, (list, tuple)) else (value,)
    return any(isinstance(v, (str, PurePath)) and PurePath(v).name == "" for v in values)


def guard_file_arguments(group: Any, usage_error: type[Exception]) -> None:
    """Wrap the callback of every command under ``group`` (idempotent): a positional path
    argument without a file name raises ``usage_error`` naming the argument."""
    if getattr(group, "_camsim_file_arguments", False):
        return
    stack = [group]
    while stack:
        cmd = stack.pop()
        stack.extend(getattr(cmd, "commands", {}).values())
        callback = getattr(cmd, "callback", None)
        arguments = [p for p in getattr(cmd, "params", []) if getattr(p, "param_type_name", "") == "argument"]
        if callback is None or not arguments:
            continue

        def checked(*args, __callback=callback, __arguments=arguments, **kwargs):
            for p in __arguments:
                if _nameless(kwargs.get(p.name)):
                    shown = (p.metavar or p.name.upper()).removesuffix("...")
                    raise usage_error(f"{shown}: an empty name (or a folder such as '.' or '/') names no file; "
                                      "give the file's name")
            return __callback(*args, **kwargs)

        cmd.callback = wraps(callback)(checked)
    group._camsim_file_arguments = True

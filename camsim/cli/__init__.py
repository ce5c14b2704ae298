"""The ``camsim`` command line. See :mod:`camsim.cli.app` for the shared conventions."""

from __future__ import annotations

import importlib

from camsim.cli.app import app

# Each command module registers itself on ``app`` when imported.
_COMMANDS = (
    "validate",
    "cam",
    "run",
    "modes",
    "impact",
    "compare",
    "plot",
    "export",
    "check",
    "sweep",
    "lump",
    "fit",
    "study",
    "optimize",
    "report",
)
for _name in _COMMANDS:
    # Every command is part of camsim: an import error is a bug and must surface. (A
    # missing optional extra is reported when the command needs it, by camsim.extras.)
    importlib.import_module(f"camsim.cli.cmd_{_name}")


def main() -> None:
    """Console entry point."""
    app()


__all__ = ["app", "main"]

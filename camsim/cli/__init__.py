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
    "study",
)
for _name in _COMMANDS:
    try:
        importlib.import_module(f"camsim.cli.cmd_{_name}")
    except ModuleNotFoundError as _exc:  # a command still being written is simply absent
        if _exc.name != f"camsim.cli.cmd_{_name}":
            raise


def main() -> None:
    """Console entry point."""
    app()


__all__ = ["app", "main"]

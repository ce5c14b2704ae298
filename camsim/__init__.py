"""camsim — exact, event-driven simulation of cam-driven machinery with impact.

The command-line tool ``camsim`` is a thin layer over this package; everything it does
can be done from Python::

    from camsim import load_machine, simulate
    machine = load_machine("machines/cdtm.toml")
    result = simulate(machine)
"""

from importlib.metadata import PackageNotFoundError, version

try:
    __version__ = version("camsim")
except PackageNotFoundError:  # running from a source tree that was not installed
    __version__ = "0.0.0+unknown"

__all__ = ["__version__"]


def __getattr__(name: str):  # hook(issue 15): `camsim.study(...)` without importing scipy at startup
    if name == "study":
        import importlib

        return importlib.import_module("camsim.study")
    raise AttributeError(f"module 'camsim' has no attribute {name!r}")

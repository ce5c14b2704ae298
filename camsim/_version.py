"""The installed version of camsim (a module of its own, so that writers low in the layers can
stamp it on files without importing the package's public namespace).

``__version__`` is looked up on first use: ``importlib.metadata`` costs tens of
milliseconds at start-up, which ``camsim --help`` and ``camsim validate`` need not pay
(issue 25, fast start). ``from camsim._version import __version__`` works as before.
"""

from __future__ import annotations

_VERSION: str | None = None


def _lookup() -> str:
    global _VERSION
    if _VERSION is None:
        from importlib.metadata import PackageNotFoundError, version

        try:
            _VERSION = version("camsim")
        except PackageNotFoundError:  # running from a source tree that was not installed
            _VERSION = "0.0.0+unknown"
    return _VERSION


def __getattr__(name: str) -> str:
    if name == "__version__":
        return _lookup()
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")

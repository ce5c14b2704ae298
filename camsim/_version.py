"""The installed version of camsim (a module of its own, so that writers low in the layers can
stamp it on files without importing the package's public namespace)."""

from importlib.metadata import PackageNotFoundError, version

try:
    __version__ = version("camsim")
except PackageNotFoundError:  # running from a source tree that was not installed
    __version__ = "0.0.0+unknown"

"""Optional extras: import them with a one-line hint when they are missing.

camsim's core needs only its listed dependencies; a few views need more
(``RunResult.to_pandas`` needs pandas, ``to_xarray`` xarray, the Dask executors
dask.distributed). A missing extra is bad input of the environment, not a crash.
"""

from __future__ import annotations

import importlib
from types import ModuleType

from camsim.errors import InputError


class MissingExtraError(InputError):
    """An optional dependency is not installed (exit code 2, with the pip command)."""


def require(module: str, extra: str) -> ModuleType:
    """Import ``module`` or raise :class:`MissingExtraError` naming the camsim extra.

    Only the module itself being absent becomes the hint; any other import error (a
    broken installation) surfaces as it is.
    """
    try:
        return importlib.import_module(module)
    except ModuleNotFoundError as exc:
        if exc.name != module.split(".")[0] and exc.name != module:
            raise
        raise MissingExtraError(
            f"{module} is not installed; it comes with the optional extra: pip install 'camsim[{extra}]'"
        ) from None

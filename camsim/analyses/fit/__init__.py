"""Calibrating a machine file to measured traces (``camsim fit``).

``camsim.analyses.fit(machine, measured, params, ...)`` (the package is callable; it is
``camsim.analyses.fit.fit``) returns a :class:`FitResult`; the fitted machine file is written by
:func:`write_fitted`. See ``docs/fitting.md``.
"""

import sys
import types

from camsim.analyses.fit.calibrate import fit
from camsim.analyses.fit.result import FitResult
from camsim.analyses.fit.tomledit import fitted_text, write_fitted

__all__ = ["fit", "FitResult", "fitted_text", "write_fitted"]


class _CallableModule(types.ModuleType):
    """``camsim.analyses.fit(...)`` calls :func:`fit` while ``camsim.analyses.fit.<module>`` stays importable."""

    def __call__(self, *args, **kwargs):
        return fit(*args, **kwargs)


sys.modules[__name__].__class__ = _CallableModule

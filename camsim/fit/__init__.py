"""Calibrating a machine file to measured traces (``camsim fit``).

``camsim.fit.fit(machine, measured, params, ...)`` returns a :class:`FitResult`; the
fitted machine file is written by :func:`write_fitted`. See ``docs/fitting.md``.
"""

from camsim.fit.calibrate import fit
from camsim.fit.result import FitResult
from camsim.fit.tomledit import fitted_text, write_fitted

__all__ = ["fit", "FitResult", "fitted_text", "write_fitted"]

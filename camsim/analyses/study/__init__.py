"""Tolerance studies: Monte Carlo statistics, limit probabilities and Sobol' sensitivity.

``camsim study`` is a thin layer over :func:`study`::

    from camsim.analyses.study import study
    res = study("machines/cdtm.toml", ["element.K01.preload=tol:223.5:10lbf"], 256,
                limits=["peak_transducer_force>600N"])
    res.rows        # pandas DataFrame, one row per run (SI)
    res.stats       # output -> mean, std, percentiles, bootstrap intervals
    res.limits      # probability of each limit being crossed
    res.sensitivity # output -> input -> Sobol' indices (with sensitivity=True)

Modules: :mod:`.distributions` (``--dist`` SPECs), :mod:`.sampling` (mc/lhs/sobol,
copula, Saltelli design), :mod:`.outputs` (what a run records), :mod:`.statistics`,
:mod:`.sensitivity`, :mod:`.store` (crash-safe rows), :mod:`.files` (HDF5/CSV),
:mod:`.config` (the ``[study]`` table), :mod:`.plot`, :mod:`.runner`. See
``docs/tolerance.md``.
"""

import sys
import types

from camsim.analyses.study.runner import StudyInterrupted, StudyResult, study

__all__ = ["study", "StudyResult", "StudyInterrupted"]



class _CallableModule(types.ModuleType):
    """Lets ``camsim.study(...)`` call :func:`study` while ``camsim.analyses.study`` stays the package."""

    def __call__(self, *args, **kwargs):
        return study(*args, **kwargs)


sys.modules[__name__].__class__ = _CallableModule

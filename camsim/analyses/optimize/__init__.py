"""Design optimisation of a machine (``camsim optimize``): the inverse of run/sweep/study.

``camsim.optimize(machine, variables, minimize=..., constraints=..., ...)`` (the package is
callable; it is :func:`camsim.analyses.optimize.run.optimize`) returns an
:class:`OptimizeResult`. Modules: :mod:`.problem` (parsing and checks), :mod:`.evaluate`
(candidates -> runs over the speeds and robust samples, cached, stored), :mod:`.robust`
(violation probabilities on common random numbers), :mod:`.solvers` (de, local, pareto),
:mod:`.files` (``OPTIMISED.toml``, the HDF5 history), :mod:`.policy` (where it may write),
:mod:`.run`. See ``docs/optimize.md``.
"""

import sys
import types

from camsim.analyses.optimize.run import OptimizeInterrupted, OptimizeResult, optimize

__all__ = ["optimize", "OptimizeResult", "OptimizeInterrupted"]


class _CallableModule(types.ModuleType):
    """``camsim.optimize(...)`` calls :func:`optimize` while ``camsim.analyses.optimize.<module>`` stays importable."""

    def __call__(self, *args, **kwargs):
        return optimize(*args, **kwargs)


sys.modules[__name__].__class__ = _CallableModule

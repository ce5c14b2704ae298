"""camsim — exact, event-driven simulation of cam-driven machinery with impact.

The command-line tool ``camsim`` is a thin layer over this package; everything it does
can be done from Python::

    from camsim import load_machine, simulate
    machine = load_machine("machines/cdtm.toml")
    result = simulate(machine, cycles=2)
    result.scalars()["peak_transducer_force"]       # [N]
    stiffer = machine.with_values({"element.K12.stiffness": "1.7e6 N/m"})

See ``docs/python-api.md``. Errors a user can cause derive from :class:`InputError`
(:class:`MachineError` names the file and the key); a run that cannot be completed
raises :class:`SimulationError`.
"""

from camsim.errors import CamsimError, InputError, MachineError, MachineFileError, ResultFileError, SimulationError

#: Public names imported on first use, so that ``import camsim`` (and the CLI) stays light.
_LAZY = {
    "load_machine": "camsim.machine.loader",
    "Machine": "camsim.machine.description",
    "simulate": "camsim.run.simulation",
    "simulate_to_file": "camsim.run.stream",
    "RunResult": "camsim.run.result",
    "open_result": "camsim.run.result",
    "EventKind": "camsim.elements.events",
    "plot_result": "camsim.figures.plots",
}
#: Subpackages that are also callables: ``camsim.analyses.fit(...)``.
_LAZY_PACKAGES = {"fit": "camsim.analyses.fit", "study": "camsim.analyses.study", "optimize": "camsim.analyses.optimize"}

__all__ = [
    "__version__",
    "CamsimError",
    "InputError",
    "MachineError",
    "MachineFileError",
    "ResultFileError",
    "SimulationError",
    *_LAZY,
    *_LAZY_PACKAGES,
]


def __getattr__(name: str):
    import importlib

    if name == "__version__":  # importlib.metadata, looked up on first use (camsim._version)
        from camsim import _version

        return _version.__version__
    if name in _LAZY_PACKAGES:
        return importlib.import_module(_LAZY_PACKAGES[name])
    module = _LAZY.get(name)
    if module is None:
        raise AttributeError(f"module 'camsim' has no attribute {name!r}")
    value = getattr(importlib.import_module(module), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(__all__)

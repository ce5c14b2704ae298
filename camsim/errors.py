"""The exception hierarchy of camsim.

Every error a user can cause by what they feed camsim derives from :class:`InputError`
(exit code 2 on the command line); trouble that arises while a valid machine runs
derives from :class:`SimulationError` (exit code 1).
"""

from __future__ import annotations


class CamsimError(Exception):
    """Base class of all camsim errors."""


class InputError(CamsimError):
    """Bad input: a machine file, an option, a data file. Exit code 2."""


class MachineFileError(InputError):
    """An error in a machine file, located by file and key path.

    Parameters
    ----------
    file : str
        The file name as the user gave it (or ``"<string>"``).
    key : str
        The key path inside the file, e.g. ``element[3].stiffness``; empty for errors
        about the whole file.
    message : str
        What is wrong, in one line.
    """

    def __init__(self, file: str, key: str, message: str):
        self.file = file
        self.key = key
        self.message = message
        where = f"{file}: {key}: " if key else f"{file}: "
        super().__init__(where + message)


#: The name the Python API documents for machine-file errors.
MachineError = MachineFileError


class ResultFileError(InputError):
    """A result file that cannot be read or compared (not HDF5, not camsim, other grid)."""


class SimulationError(CamsimError):
    """A run that cannot be completed: divergence, unresolved chatter. Exit code 1."""


class ZenoError(SimulationError):
    """Events accumulate without a resolution (a chatter the model cannot stick)."""

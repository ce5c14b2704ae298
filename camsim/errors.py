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


class OutputLockedError(InputError):
    """Another live process is writing the same output (its advisory lock is held). Exit code 2."""


class FileSystemError(CamsimError):
    """The file system refused a read or a write: no space, a quota, a permission, a
    read-only file system, an I/O error. The user's to fix, not a bug: exit code 1.

    Parameters
    ----------
    path : str
        The file concerned.
    error : OSError
        What the operating system said.
    doing : str
        ``"write"`` or ``"read"``.
    advice : str
        What is kept and what to do (appended to the message).
    """

    #: errno -> the cause in words (the errors that are the environment's, not camsim's).
    CAUSES = {
        "ENOSPC": "no space left on the device",
        "EDQUOT": "the disk quota is exceeded",
        "EFBIG": "the file is larger than the file system allows",
        "EACCES": "permission denied",
        "EPERM": "operation not permitted",
        "EROFS": "the file system is read-only",
        "EIO": "input/output error (the disk or the network file system failed)",
        "ESTALE": "stale network file handle",
    }

    def __init__(self, path: str, error: OSError, doing: str = "write", advice: str = ""):
        import errno as _errno

        self.path = str(path)
        self.error = error
        self.doing = doing
        self.advice = advice
        name = _errno.errorcode.get(error.errno or 0, "")
        cause = self.CAUSES.get(name, error.strerror or str(error))
        self.cause = cause
        tail = f"; {advice}" if advice else ""
        super().__init__(f"{path}: cannot {doing}: {cause}" + (f" ({name})" if name else "") + tail)

    def with_advice(self, advice: str) -> "FileSystemError":
        """The same error with ``advice`` appended (what is kept, what to do)."""
        joined = f"{self.advice}; {advice}" if self.advice else advice
        return FileSystemError(self.path, self.error, self.doing, joined)

    @classmethod
    def applies(cls, error: BaseException) -> bool:
        """True for an OSError whose errno is the environment's (space, quota, permission, I/O)."""
        import errno as _errno

        return isinstance(error, OSError) and _errno.errorcode.get(error.errno or 0, "") in cls.CAUSES


class SimulationError(CamsimError):
    """A run that cannot be completed: divergence, unresolved chatter. Exit code 1."""


class ZenoError(SimulationError):
    """Events accumulate without a resolution (a chatter the model cannot stick)."""

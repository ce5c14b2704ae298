"""What each command reads and writes: the declarations the conformance suite is generated from.

Every command declares, next to its definition, the files it reads (:class:`Reads`) and
the files it writes (:class:`Writes`) with :func:`declare`. The declarations are data,
not documentation: ``tests/cli/test_conformance.py`` builds its cases from them (every
output × {onto an input, over a file of another kind, over a file camsim did not write, in
a read-only folder, onto a full disk, beside a concurrent writer, SIGKILL, SIGINT and SIGTERM
at a random moment, locked from the command's checks}; every input × {truncated, empty,
foreign HDF5, a CSV, attributes only, a missing dataset, flipped metadata bytes, a non-finite
trace, a reversed time base}) and fails for a command, or a file parameter of one, that
declares nothing. The outcomes it checks are the output policy's (docs/results.md):

=========================  =================================================================
case                       outcome
=========================  =================================================================
onto an input              exit 2, one line, the input untouched
over another kind          exit 2, the file untouched (``--force`` or not)
not written by camsim      HDF5, TOML, HTML: exit 2 without ``--force``; CSV, figures, PDF,
                           DXF: replaced (camsim never holds a user's only copy there)
read-only folder           exit 2 before anything is computed
full disk                  exit 1, one line naming the file and the cause, nothing under the
                           output's name (or its previous content), no temporary file
concurrent writer          exit 2 naming the other writer's process id
locked from the checks     every file written was locked by the command's checks, before
                           anything was computed (a journal or view: with its job's output)
SIGKILL                    the output absent, previous or complete; the next run succeeds
SIGINT, SIGTERM            exit 130 (or 0 when it finished first), no temporary file left
damaged input              exit 2, one line naming the file (and the dataset), nothing written
=========================  =================================================================
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

__all__ = ["Reads", "Writes", "Contract", "CONTRACTS", "declare", "PROTECTED"]

#: Formats whose existing files camsim replaces only when it wrote them (or with --force).
PROTECTED = ("hdf5", "toml", "html")


@dataclass(frozen=True)
class Reads:
    """One file a command reads.

    Attributes
    ----------
    param : str
        The command function's parameter that names it (``"machine"``, ``"results"``).
    kind : str
        ``"machine"`` (TOML machine file), ``"result"`` (camsim HDF5 result), ``"csv"``
        (measured or force-deflection samples), ``"parts"`` (lump's parts file),
        ``"config"`` (a TOML table of options).
    results : tuple of str
        For a result: the ``file_kind`` values it takes.
    fixture : str
        The example file the suite gives it (default: ``kind``): ``machine``, ``geometry``
        (a machine with ``[cam.geometry]``), ``run``, ``measured``, ``parts``,
        ``deflection``, ``config``.
    example : tuple of str
        An invocation reading this input, when the command's own example does not.
    """

    param: str
    kind: str
    results: tuple[str, ...] = ()
    fixture: str = ""
    example: tuple[str, ...] = ()


@dataclass(frozen=True)
class Writes:
    """One file a command writes.

    Attributes
    ----------
    param : str or None
        The parameter naming it; None for a file written beside another (``beside``).
    option : str
        The option as the user types it (``"-o"``, ``"--report"``).
    formats : mapping
        Suffix → format (:mod:`camsim.io.outputs`); the first is the one examples use.
    owner : str
        What the command writes there (:func:`camsim.io.outputs.check_output`'s owner).
    beside : str
        For a companion file: the option it is written beside and the suffix it gets
        (``"-o:.csv"``: the CSV with the stem of ``-o``).
    directory : str
        For an option naming a folder of files: the name of one file in it, from the input's
        stem and the first format (``"{stem}_masses.{fmt}"``).
    journal : bool
        A journal ``<file>.journal`` goes with it while the job runs (``--resume``).
    optional : bool
        Written only when its option is given (the suite leaves it out of the other cases).
    transient : bool
        Kept only while the job runs (a fit's evaluation store): removed when it completes.
    """

    param: str | None
    option: str
    formats: Mapping[str, str]
    owner: str
    beside: str = ""
    directory: str = ""
    journal: bool = False
    optional: bool = False
    transient: bool = False

    @property
    def format(self) -> str:
        return next(iter(self.formats.values()))

    @property
    def suffix(self) -> str:
        return next(iter(self.formats))


@dataclass(frozen=True)
class Contract:
    """What one command reads and writes, and a quick invocation that does it.

    ``example`` is the argument list of a fast run of the command, with ``{in:<param>}``
    for each input and ``{out:<option>}`` for each output it writes (the suite fills them).
    """

    command: str
    reads: tuple[Reads, ...] = ()
    writes: tuple[Writes, ...] = ()
    example: tuple[str, ...] = ()
    force: bool = False
    slow: bool = False
    notes: str = ""


#: Command path (``"run"``, ``"impact fit"``) → its contract.
CONTRACTS: dict[str, Contract] = {}


def declare(command: str, *, reads=(), writes=(), example=(), force: bool = False, slow: bool = False,
            notes: str = "") -> Contract:
    """Record what ``command`` reads and writes (called next to the command's definition)."""
    contract = Contract(command, tuple(reads), tuple(writes), tuple(example), force, slow, notes)
    CONTRACTS[command] = contract
    return contract

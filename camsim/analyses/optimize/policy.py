"""Where ``camsim optimize`` may write: the shared output policy (:mod:`camsim.io.outputs`)
applied to its three outputs.

* the suffix says the format: ``-o`` must be ``.toml``, ``-r`` ``.h5``/``.hdf5``,
  ``--plot`` ``.png``/``.svg``/``.pdf``;
* an output never overwrites an input (the machine file), a file of another kind, or a
  result of another command (without ``--force``); two outputs are never the same file;
* a journal left by an interrupted job is never discarded silently: the same command
  without ``--resume`` refuses (exit 2) naming ``--resume`` (continue) and ``--fresh``
  (discard it and start again).
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from pathlib import Path

from camsim.errors import InputError
from camsim.io.outputs import FIGURES, HDF5, TOML, check_journal, check_output, output_format, same_file

__all__ = ["FORMATS", "check_outputs"]

#: Accepted suffixes per output option.
FORMATS = {"-o": TOML, "-r": HDF5, "--plot": FIGURES}
#: What each option holds (the owner :func:`camsim.io.outputs.check_output` compares).
_OWNERS = {"-o": "optimize", "-r": "optimize", "--plot": "figure"}


def check_outputs(
    inputs: Sequence[str | os.PathLike[str]],
    outputs: dict[str, str | os.PathLike[str] | None],
    journal: str | os.PathLike[str] | None = None,
    resume: bool = False,
    fresh: bool = False,
    force: bool = False,
) -> None:
    """Refuse (InputError, one line) any output that breaks the rules of the module docstring.

    Parameters
    ----------
    inputs : paths read by the command.
    outputs : option -> path (None: not written).
    journal : the job journal that ``--resume`` would continue (None: the job keeps none).
    resume, fresh : the ``--resume`` and ``--fresh`` flags (``--fresh`` deletes the journal).
    force : replace an existing result of another command.
    """
    if resume and fresh:
        raise InputError("--resume and --fresh: give one of them, not both")
    seen: dict[str, Path] = {}
    for option, path in outputs.items():
        if path is None:
            continue
        fmt = output_format(path, FORMATS[option], option)
        for other, earlier in seen.items():
            if same_file(path, earlier):
                raise InputError(f"{option} {path}: the same file as {other}")
        # The history path holds the row store's view of finished runs while a job runs.
        check_output(path, fmt, owner=_OWNERS[option], inputs=[("machine file", p) for p in inputs], force=force,
                     option=option, owners=("rows",) if option == "-r" else ())
        seen[option] = Path(path)
    if journal is not None:
        if resume and not Path(journal).exists():
            raise InputError(f"--resume: no journal {journal} to continue (the job was never started here, or it completed)")
        check_journal(outputs.get("-r") or journal, journal, resume=resume, fresh=fresh, what="optimisation")
    elif resume:
        raise InputError("--resume: needs the history file (-r HISTORY.h5) whose journal it continues")

"""Where ``camsim optimize`` may write: one small function, so the project-wide output
policy (another issue) can replace it at merge.

Rules (the same as the shared policy will apply to every command):

* an output never overwrites an input (the machine file, a cam table it reads);
* the suffix says the format: ``-o`` must be ``.toml``, ``-r`` ``.h5``/``.hdf5``,
  ``--plot`` ``.png``/``.svg``/``.pdf``;
* an output's directory must exist and be writable (:func:`camsim.io.atomic.check_writable`);
* a journal left by an interrupted job is never discarded silently: the same command
  without ``--resume`` refuses (exit 2) naming ``--resume`` (continue) and ``--fresh``
  (discard it and start again).
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from pathlib import Path

from camsim.errors import InputError

__all__ = ["check_outputs", "FORMATS"]

#: Accepted suffixes per output option.
FORMATS = {"-o": (".toml",), "-r": (".h5", ".hdf5"), "--plot": (".png", ".svg", ".pdf")}


def check_outputs(
    inputs: Sequence[str | os.PathLike[str]],
    outputs: dict[str, str | os.PathLike[str] | None],
    journal: str | os.PathLike[str] | None = None,
    resume: bool = False,
    fresh: bool = False,
) -> None:
    """Refuse (InputError, one line) any output that breaks the rules of the module docstring.

    Parameters
    ----------
    inputs : paths read by the command.
    outputs : option -> path (None: not written).
    journal : the job journal that ``--resume`` would continue (None: the job keeps none).
    resume, fresh : the ``--resume`` and ``--fresh`` flags.
    """
    from camsim.io.atomic import check_writable

    if resume and fresh:
        raise InputError("--resume and --fresh: give one of them, not both")
    read = {Path(p).resolve() for p in inputs}
    seen: dict[Path, str] = {}
    for option, path in outputs.items():
        if path is None:
            continue
        p = Path(path)
        allowed = FORMATS.get(option)
        if allowed and p.suffix.lower() not in allowed:
            raise InputError(f"{option} {p}: unknown format '{p.suffix or '(none)'}' (use {', '.join(allowed)})")
        if p.resolve() in read:
            raise InputError(f"{option} {p}: would overwrite an input file; choose another name")
        if p.resolve() in seen:
            raise InputError(f"{option} {p}: the same file as {seen[p.resolve()]}")
        seen[p.resolve()] = option
        check_writable(p)
    if journal is not None:
        j = Path(journal)
        if resume and not j.exists():
            raise InputError(f"--resume: no journal {j} to continue (the job was never started here, or it completed)")
        if j.exists() and not resume and not fresh:
            raise InputError(f"{j}: an interrupted optimisation left this journal; add --resume to continue it, "
                             "or --fresh to discard it and start again")
    elif resume:
        raise InputError("--resume: needs the history file (-r HISTORY.h5) whose journal it continues")

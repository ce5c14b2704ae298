"""Lumped-parameter reduction: from a designer's parts file to a camsim machine file.

A *parts file* (TOML, documented in ``docs/lumping.md``) lists the components of a
machine — masses, moments of inertia about pivots, helical springs, axial rods, stiffnesses
from a load and a deflection, series and parallel combinations — the levers that transfer
them to the model axis, and which parts become each lumped mass and each element. This
module computes the lumped values as in the thesis (appendix A: lumping techniques,
appendices D–F, chapter 6.1–6.2) and returns a complete machine (spec §6) as a dict ready
for ``tomli_w``, with a provenance text for every computed value.

Formulas (every value in SI inside):

* rotating part: m = I / r²                                   (thesis eq. A.1)
* lever transfer from arm r_a to arm r_b of the same rigid lever: mass and stiffness
  × (r_a/r_b)², force × (r_a/r_b), motion × (r_b/r_a)          (thesis appendix A, fig 6.4/6.6)
* helical spring: k = G·d⁴ / (8·D³·N)                        (thesis appendix E, eq. 1)
* axial rod: k = A·E / L                                      (thesis eq. A.3)
* stiffness from a load and its deflection: k = F / δ         (thesis eq. A.2)
* series 1/k = Σ 1/kᵢ, parallel k = Σ kᵢ                      (thesis appendices E, F)
* spring preload: P = k·(L − L0) + F_initial                  (thesis appendix E)

This module is the API and the result; the parts are evaluated in :mod:`camsim.analyses.lump.parts`
and the machine file is written by :mod:`camsim.analyses.lump.files`.
"""

from __future__ import annotations

import tomllib
from pathlib import Path
from typing import Any

from camsim.analyses.lump.parts import Lumper
from camsim.analyses.lump.values import UNIT_SYSTEMS, LumpResult  # noqa: F401 - the API's names
from camsim.errors import InputError, MachineFileError


def load_parts(path: str | Path, *, units: str = "us") -> LumpResult:
    """Read a parts file and reduce it to a machine.

    Parameters
    ----------
    path : path
        The parts file (TOML).
    units : {"us", "si", "file"}
        Units of the computed values in the machine: lb, lbf/in, lbf (the thesis's) or
        kg, N/m, N.

    Returns
    -------
    LumpResult

    Raises
    ------
    MachineFileError
        An error in the parts file, naming the file and the key path.
    InputError
        The file cannot be read.
    """
    name = str(path)
    try:
        text = Path(path).read_text(encoding="utf-8")
    except FileNotFoundError:
        raise InputError(f"{name}: no such file") from None
    except OSError as exc:
        raise InputError(f"{name}: cannot read: {exc.strerror}") from None
    except UnicodeDecodeError:
        from camsim.io.outputs import sniff_kind

        kind = sniff_kind(path)
        what = f"an {kind.upper()} file" if kind == "hdf5" else "not UTF-8 text"
        raise InputError(f"{name}: {what}, not a parts file (TOML)") from None
    return lump_text(text, file=name, units=units, base_dir=Path(path).parent)


def lump_text(
    text: str, *, file: str = "<string>", units: str = "us", base_dir: str | Path = "."
) -> LumpResult:
    """Reduce the parts file given as TOML text (see :func:`load_parts`).

    ``base_dir`` is the directory a relative cam ``table`` path is relative to.
    """
    try:
        document = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise MachineFileError(file, "", f"not valid TOML: {exc}") from None
    if units == "file":
        units = written_unit_table(text)
    return lump(document, file=file, units=units, base_dir=base_dir)


def written_unit_table(text: str) -> dict[str, str]:
    """The units the parts file is written in, per kind of lumped value (``units="file"``, issue 36):
    the most frequent unit written for each dimension (docs/units.md)."""
    from camsim.display import written_units
    from camsim.display.units import pint_text

    shown = written_units(text)
    table = {kind: pint_text(shown.unit(kind).text) for kind in ("mass", "stiffness", "force", "length")}
    return {**table, "dimensionless": ""}


def lump(
    document: dict[str, Any], *, file: str = "<string>", units: str | dict[str, str] = "us", base_dir: str | Path = "."
) -> LumpResult:
    """Reduce a parsed parts file to a machine (see :func:`load_parts`).

    The machine is then validated with :func:`camsim.machine.loader.load_machine_text` when that
    loader exists (errors name the parts file and the same key path).
    """
    if isinstance(units, str) and units not in UNIT_SYSTEMS:
        raise InputError(f"units must be one of {', '.join((*UNIT_SYSTEMS, 'file'))}, got {units!r}")

    result = Lumper(document, file, units).run()
    result.base_dir = Path(base_dir)
    result.checked = _validate_text(result, result.to_toml(), result.base_dir)
    return result


def write_machine(result: LumpResult, target: str | Path, *, validate: bool = True) -> Path:
    """Write the machine file atomically; check it with the machine loader first if present.

    Parameters
    ----------
    result : LumpResult
    target : path
        The machine file to write (replaced if it exists).
    validate : bool
        Load the written text with :func:`camsim.machine.loader.load_machine` before renaming it
        into place, when that loader exists; its errors are reported against the parts file.

    Returns
    -------
    Path
        ``target``.
    """
    import os

    from camsim.io.outputs import writing

    table = result.machine.get("cam", {}).get("table")
    if isinstance(table, str) and not Path(table).is_absolute():
        # keep a relative CSV path pointing at the same file from the output's directory
        where = Path(os.path.relpath(result.base_dir / table, Path(target).parent or Path(".")))
        result.machine["cam"]["table"] = where.as_posix()
    text = result.to_toml()
    if validate:  # the text as the output's folder will read it, before anything is written
        _validate_text(result, text, Path(target).parent)
    with writing(target, "toml", owner="lump") as out:
        out.put_text(text)
    return Path(target)


def check_with_loader(result: LumpResult, machine_path: str | Path) -> bool:
    """Load ``machine_path`` with :func:`camsim.machine.loader.load_machine`, if the loader exists.

    Returns
    -------
    bool
        True if the file was loaded, False if there is no loader to check with.

    Raises
    ------
    MachineFileError
        The loader rejected the machine; the message names the parts file and the key.
    """
    path = Path(machine_path)
    return _validate_text(result, path.read_text(encoding="utf-8"), path.parent)


def _validate_text(result: LumpResult, text: str, base_dir: Path) -> bool:
    try:
        from camsim.machine.loader import load_machine_text
    except ImportError:  # the loader is optional for lumping
        return False
    try:
        load_machine_text(text, source=result.source, base_dir=base_dir)
    except MachineFileError as exc:
        raise MachineFileError(result.source, exc.key, f"{exc.message} (in the lumped machine)") from None
    except InputError as exc:
        raise MachineFileError(result.source, "", f"lumped machine rejected: {exc}") from None
    return True

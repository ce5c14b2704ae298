"""The ``[study]`` table of a TOML file (``camsim study --config FILE``): a study under version control.

Example::

    [study]
    machine = "cdtm.toml"                 # relative to this file; or give MACHINE
    samples = 1024
    method = "sobol"                      # mc | lhs | sobol
    seed = 1
    tol_sigma = 3
    sensitivity = true
    set = ["simulation.sample_rate=20kHz"]
    limit = ["peak_transducer_force>2000N"]
    reduce = ["rms:transducer/force"]
    correlate = []
    cycles = 1
    warmup = 1
    sample_rate = "20 kHz"                # or a number [Hz]

    [study.dist]                          # or: dist = ["KEY=SPEC", ...]
    "element.K23.preload" = "tol:28.12:2.8lbf"
    "element.seat.gap" = "tol:0.0625:0.005in"

Options given on the command line win over the file's: a scalar replaces it, a
``--dist`` for a key the file also gives replaces that entry, and ``--set``,
``--correlate``, ``--limit`` and ``--reduce`` are added after the file's.
"""

from __future__ import annotations

import os
import tomllib
from pathlib import Path
from typing import Any

from camsim.errors import InputError

__all__ = ["STUDY_KEYS", "read_config"]

#: Keys of the ``[study]`` table and the type each holds.
STUDY_KEYS: dict[str, type | tuple[type, ...]] = {
    "machine": str,
    "dist": (dict, list),
    "samples": int,
    "method": str,
    "seed": int,
    "tol_sigma": (int, float),
    "correlate": list,
    "reduce": list,
    "output": list,  # the name of "reduce" before issue 44, still read
    "limit": list,
    "sensitivity": bool,
    "set": list,
    "cycles": int,
    "warmup": int,
    "sample_rate": (str, int, float),
    "workers": int,
}


def read_config(path: str | os.PathLike[str]) -> dict[str, Any]:
    """Read the ``[study]`` table of ``path`` into option values.

    Returns
    -------
    dict
        The keys of :data:`STUDY_KEYS` that the file gives; ``dist`` as a list of
        ``KEY=SPEC`` texts, ``machine`` as a path resolved against the file's folder.

    Raises
    ------
    InputError
        ``file: study.key: message`` for an unreadable file, a missing table, an
        unknown key or a value of the wrong type.
    """
    p = Path(path)
    try:
        with open(p, "rb") as fh:
            doc = tomllib.load(fh)
    except FileNotFoundError:
        raise InputError(f"{p}: --config: no such file") from None
    except tomllib.TOMLDecodeError as exc:
        raise InputError(f"{p}: not valid TOML ({exc})") from None
    except UnicodeDecodeError:
        raise InputError(f"{p}: not a TOML file (not UTF-8 text: a binary or HDF5 file?)") from None
    except OSError as exc:
        raise InputError(f"{p}: cannot read ({exc.strerror})") from None
    table = doc.get("study")
    if not isinstance(table, dict):
        raise InputError(f"{p}: study: the file has no [study] table")
    out: dict[str, Any] = {}
    for key, value in table.items():
        if key not in STUDY_KEYS:
            import difflib

            close = difflib.get_close_matches(key, list(STUDY_KEYS), n=1)
            hint = f"; did you mean {close[0]}?" if close else ""
            raise InputError(f"{p}: study.{key}: unknown key{hint}")
        want = STUDY_KEYS[key]
        if isinstance(value, bool) and want is not bool:
            ok = False
        else:
            ok = isinstance(value, want)
        if not ok:
            names = "/".join(t.__name__ for t in (want if isinstance(want, tuple) else (want,)))
            raise InputError(f"{p}: study.{key}: expected {names.replace('dict', 'table').replace('list', 'array')}, got {value!r}")
        if isinstance(value, list) and key != "dist" or key == "dist" and isinstance(value, list):
            for k, item in enumerate(value):
                if not isinstance(item, str):
                    raise InputError(f"{p}: study.{key}[{k}]: expected a string, got {item!r}")
        if key == "dist" and isinstance(value, dict):
            texts = []
            for k, spec in value.items():
                if not isinstance(spec, str):
                    raise InputError(f"{p}: study.dist.{k}: expected a SPEC string, got {spec!r}")
                texts.append(f"{k}={spec}")
            value = texts
        if key == "machine":
            value = str((p.parent / value)) if not Path(value).is_absolute() else value
        out[key] = value
    return out


def merge_dists(config: list[str], given: list[str]) -> list[str]:
    """The file's ``KEY=SPEC`` list with each key given on the command line replaced."""
    keys = {g.partition("=")[0].strip() for g in given}
    return [c for c in config if c.partition("=")[0].strip() not in keys] + list(given)

"""How large a machine may be: sizes estimated when the machine is loaded (issue 45).

Every size that follows from the machine file is counted before anything is allocated, and a
machine beyond a limit is refused with one line naming the key and the estimate:

* **nodes** -- masses and the interior nodes of every rod (``segments`` N gives N - 1 of
  them, the default N is chosen from the rod's wave speed). The model is dense: 2 states per
  node, a step map of (2·nodes)² per configuration. Default :data:`MAX_NODES`; ``--max-nodes``
  raises it (``camsim run``, ``camsim validate``). A rod of ``youngs_modulus = "1e-30 psi"`` or
  ``length = "1e9 m"`` asked for 1e15 segments and ``validate`` allocated 22 GB.
* **cams** -- ``[[cam]]`` tables. Default :data:`MAX_CAMS`; ``--max-cams``.
* **traces** -- the traces of a result on one time base: time, 5 per cam, 3 per node, one per
  element (3 per rod), the cam contact and transducer forces. HDF5 keeps the list of the
  traces attached to a time base in one 64 KiB attribute (4,085 entries); above
  :data:`MAX_TRACES` a run could not write its file (1000 cams ended in "internal error
  (RuntimeError: H5DSattach_scale)"). A file-format limit: it cannot be raised.

The samples, bytes and integration steps of a run are estimated by :mod:`camsim.run.budget`
(``--max-output``, ``--yes``) once the run's settings are known.
"""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass, replace

__all__ = ["MAX_NODES", "MAX_CAMS", "MAX_TRACES", "Limits", "current", "raised"]

#: Default largest number of nodes (masses and rod interior nodes).
MAX_NODES = 500
#: Default largest number of cams.
MAX_CAMS = 100
#: Largest number of traces on one time base (HDF5: 4,085 attached datasets).
MAX_TRACES = 4000


@dataclass(frozen=True)
class Limits:
    """The limits in force: ``nodes``, ``cams`` (raisable), ``traces`` (the file format's)."""

    nodes: int = MAX_NODES
    cams: int = MAX_CAMS
    traces: int = MAX_TRACES


_CURRENT = [Limits()]


def current() -> Limits:
    """The limits the loader applies now."""
    return _CURRENT[0]


@contextmanager
def raised(nodes: int | None = None, cams: int | None = None) -> Iterator[Limits]:
    """Within the block, load machines with these limits (``--max-nodes``, ``--max-cams``)."""
    before = _CURRENT[0]
    _CURRENT[0] = replace(before, **{k: v for k, v in (("nodes", nodes), ("cams", cams)) if v is not None})
    try:
        yield _CURRENT[0]
    finally:
        _CURRENT[0] = before

"""HDF5 primitives shared by every camsim file: traces with units on a time scale.

Every trace is a 1-D dataset with a ``units`` and a ``long_name`` attribute, compressed
with gzip + shuffle, and ``/time`` attached to it as a dimension scale so that generic
HDF5 and netCDF tools show it against time. Output is deterministic: no timestamps are
stored, and datasets are created in a fixed order with fixed chunking.
"""

from __future__ import annotations

import hashlib
from collections.abc import Mapping
from typing import TYPE_CHECKING, Any

import h5py
import numpy as np

from camsim._version import __version__

if TYPE_CHECKING:
    from camsim.display import DisplayUnits
    from camsim.machine.description import Machine

#: Compression used for every trace (lossless; shuffle helps the float bytes compress).
COMPRESSION = {"compression": "gzip", "compression_opts": 4, "shuffle": True}


#: Result-file schema written by this version.
SCHEMA = 1


def write_root_attributes(f: h5py.File, machine: Machine, file_kind: str, display: DisplayUnits | None = None) -> None:
    """Root attributes every camsim file carries (spec §7): the version, the schema, the file's
    kind, the machine it came from (name, TOML text, its SHA-256) and the display units of its
    human output (``display_units``, JSON: default the machine file's, docs/units.md)."""
    f.attrs["camsim_version"] = __version__
    f.attrs["schema"] = SCHEMA
    f.attrs["file_kind"] = file_kind
    f.attrs["machine_name"] = machine.name
    f.attrs["machine_toml"] = machine.text
    f.attrs["machine_sha256"] = hashlib.sha256(machine.text.encode()).hexdigest()
    f.attrs["units_system"] = "SI"
    # The units human output shows this file's values in (issue 36): the machine file's own,
    # so that plot, report, export --units and compare of the file use them.
    f.attrs["display_units"] = (display if display is not None else machine.display_units).to_json()


def create_file(path: Any, **options: Any) -> h5py.File:
    """Open a new HDF5 file for writing with settings that make output reproducible.

    ``options`` go to :class:`h5py.File` (access settings such as ``rdcc_nbytes``, the
    chunk cache, which do not change the bytes written)."""
    # track_order keeps attribute/group order stable; libver pins the on-disk format.
    return h5py.File(path, "w", track_order=True, libver=("earliest", "v110"), **options)


def write_time(group: h5py.Group, time: np.ndarray, name: str = "time") -> h5py.Dataset:
    """Write the time axis [s] and make it a dimension scale."""
    dset = write_trace(group, name, time, "s", "time", scale=None)
    dset.make_scale("time")
    return dset


def write_trace(
    group: h5py.Group,
    path: str,
    data: np.ndarray,
    units: str,
    long_name: str,
    scale: h5py.Dataset | None = None,
) -> h5py.Dataset:
    """Write one 1-D trace with its ``units`` and ``long_name``; attach ``scale`` to it.

    Parameters
    ----------
    group : h5py.Group
        Where ``path`` is relative to; intermediate groups are created.
    path : str
        Dataset path, e.g. ``"masses/M2/velocity"``.
    data : ndarray
        The samples (stored as float64).
    units : str
        SI unit text, e.g. ``"m/s"``.
    long_name : str
        Human description, e.g. ``"velocity of M2"``.
    scale : h5py.Dataset, optional
        The time scale to attach as dimension 0.
    """
    array = np.ascontiguousarray(data, dtype=np.float64)
    chunks = (min(max(array.size, 1), 65536),) if array.ndim == 1 else True
    kwargs = dict(COMPRESSION) if array.size else {}
    dset = group.create_dataset(path, data=array, chunks=chunks if array.size else None, **kwargs)
    dset.attrs["units"] = units
    dset.attrs["long_name"] = long_name
    if scale is not None:
        dset.dims[0].attach_scale(scale)
    return dset


def write_table(group: h5py.Group, path: str, columns: Mapping[str, tuple[np.ndarray, str]]) -> h5py.Dataset:
    """Write a table as a compound dataset, units of each column in attribute ``units:<col>``.

    Parameters
    ----------
    columns : mapping
        Column name -> (values, units). String columns are stored as UTF-8.
    """
    names = list(columns)
    arrays = []
    dtypes = []
    for name in names:
        values, _ = columns[name]
        values = np.asarray(values)
        if values.dtype.kind in "UOS":
            dtypes.append((name, h5py.string_dtype("utf-8")))
            arrays.append(np.array([str(v) for v in values], dtype=object))
        elif values.dtype.kind == "b":
            dtypes.append((name, np.bool_))
            arrays.append(values)
        elif values.dtype.kind in "iu":
            dtypes.append((name, np.int64))
            arrays.append(values.astype(np.int64))
        else:
            dtypes.append((name, np.float64))
            arrays.append(values.astype(np.float64))
    length = len(arrays[0]) if arrays else 0
    table = np.empty(length, dtype=dtypes)
    for name, values in zip(names, arrays):
        table[name] = values
    dset = group.create_dataset(path, data=table)
    for name in names:
        dset.attrs[f"units:{name}"] = columns[name][1]
    return dset


def read_table(dset: h5py.Dataset) -> dict[str, np.ndarray]:
    """Read a table written by :func:`write_table` as a dict of column arrays."""
    data = dset[()]
    out: dict[str, np.ndarray] = {}
    for name in data.dtype.names or ():
        column = data[name]
        if column.dtype.kind == "O":
            column = np.array([v.decode() if isinstance(v, bytes) else str(v) for v in column], dtype=object)
        out[name] = column
    return out

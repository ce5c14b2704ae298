"""Writing a run's traces to HDF5 while it runs (``camsim run``, camsim.run.stream).

The datasets of the result layout (spec §7, the order of
:meth:`camsim.run.result.RunResult.traces`) are created empty, resizable and chunked before
the integration starts, and each piece of samples the run produces is appended to them.
So the file, not memory, holds the traces: memory does not grow with the run. The event
table, the group attributes and the summary are written when the run ends.

The values are those of the in-memory writer (:func:`camsim.run.runfile.write_run_group`)
bit for bit; only the storage differs (chunks of :data:`CHUNK` samples, gzip only with
``compress``). The caller writes into a temporary file that is renamed when complete
(:func:`camsim.io.outputs.writing`); a full disk stops the run at the next piece.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence

import h5py
import numpy as np

from camsim.io.hdf5 import COMPRESSION
from camsim.run.runfile import write_events, write_extremes, write_run_attributes, write_summary

#: Samples per HDF5 chunk of a streamed trace (512 kB of float64).
CHUNK = 65536


class TraceStreamWriter:
    """Append-only writer of a run's traces into ``group``.

    Parameters
    ----------
    group : h5py.Group
        Where the run goes (the file root for ``camsim run``).
    layout : mapping
        Path → :class:`~camsim.run.result.Trace` of every trace the run has, in file order
        (the data may be empty: only units and long names are read).
    record : sequence of str
        The paths to store (a subset of ``layout``; ``time`` is stored with any other).
    keep_from : float, optional
        Store only samples at or after this output time [s] (``--record-last``).
    boundaries_deg : ndarray
        Cam segment joins [deg], stored as ``cam/boundaries_deg`` after the cam traces.
    compress : bool
        gzip + shuffle the traces (smaller file, more CPU).
    check : callable, optional
        Called after every piece written: raises when the file system refused a write
        (:meth:`camsim.io.atomic.Target.check`), so a run onto a full disk stops there.
    """

    def __init__(self, group: h5py.Group, layout: Mapping, record: Sequence[str], keep_from: float | None,
                 boundaries_deg: np.ndarray, compress: bool = False, check: Callable[[], None] | None = None):
        self.group = group
        self._check = check
        self.keep_from = keep_from
        self.paths = [p for p in layout if p in set(record)]
        self.samples = 0
        self._datasets: dict[str, h5py.Dataset] = {}
        self._pending: dict[str, list[np.ndarray]] = {path: [] for path in self.paths}
        self._waiting = 0
        options = dict(COMPRESSION) if compress else {}
        cam_paths = [p for p in self.paths if p.startswith("cam/")]
        time = None
        for path in self.paths:
            trace = layout[path]
            tail = tuple(np.shape(trace.data)[1:])  # (2,) for the x-y traces of a cam's shape
            dset = group.create_dataset(path, shape=(0, *tail), maxshape=(None, *tail), chunks=(CHUNK, *tail),
                                        dtype=np.float64, **options)
            dset.attrs["units"] = trace.units
            dset.attrs["long_name"] = trace.long_name
            if path == "time":
                dset.make_scale("time")
                time = dset
            elif time is not None:
                dset.dims[0].attach_scale(time)
            self._datasets[path] = dset
            if cam_paths and path == cam_paths[-1]:  # the joins sit with the cam traces (spec §7 order)
                group.create_dataset("cam/boundaries_deg", data=np.asarray(boundaries_deg, dtype=float)).attrs["units"] = "deg"
            elif not cam_paths and path == "camshaft/angle":  # several cams (issue 38): the shaft's angles
                group.create_dataset("camshaft/boundaries_deg", data=np.asarray(boundaries_deg, dtype=float)).attrs["units"] = "deg"

    def append(self, traces: Mapping) -> None:
        """Append one piece of every stored trace (path → Trace, all on one time base).

        Samples are written in whole chunks (the rest waits for the next piece or
        :meth:`finish`), so HDF5 never rereads a partial chunk and needs no chunk cache."""
        if not self.paths:
            return
        keep = None
        if self.keep_from is not None:
            time = traces["time"].data
            if time[-1] < self.keep_from:
                return
            if time[0] < self.keep_from:
                keep = time >= self.keep_from
        for path in self.paths:
            data = traces[path].data
            self._pending[path].append(np.asarray(data[keep] if keep is not None else data, dtype=np.float64))
        self._waiting += self._pending[self.paths[0]][-1].shape[0]
        if self._waiting >= CHUNK:
            self._write(self._waiting // CHUNK * CHUNK)

    def _write(self, n: int) -> None:
        """Write the first ``n`` waiting samples of every trace."""
        if n <= 0:
            return
        for path in self.paths:
            parts = self._pending[path]
            data = np.concatenate(parts) if len(parts) > 1 else parts[0]
            dset = self._datasets[path]
            dset.resize(self.samples + n, axis=0)
            dset[self.samples:] = data[:n]
            self._pending[path] = [data[n:]] if n < data.shape[0] else []
        self.samples += n
        self._waiting -= n
        if self._check is not None:
            self._check()

    def finish(self, result) -> None:
        """The event table, the run attributes and the summary (after the last piece)."""
        self._write(self._waiting)
        write_events(self.group, result.events)
        write_extremes(self.group, result)
        write_run_attributes(self.group, result)
        write_summary(self.group, result)

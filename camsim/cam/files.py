"""Writing one revolution of a cam program: HDF5 (``file_kind = "cam"``) or CSV."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from camsim.cam import CamProgram, sample_revolution
from camsim.io.outputs import writing
from camsim.io.hdf5 import write_time, write_trace
from camsim.io.hdf5 import write_root_attributes

TRACES = (
    ("displacement", "m", "cam displacement on the model axis"),
    ("velocity", "m/s", "cam velocity on the model axis"),
    ("acceleration", "m/s^2", "cam acceleration on the model axis"),
    ("jerk", "m/s^3", "cam jerk on the model axis"),
)


def write_cam_hdf5(path: str | os.PathLike[str], machine, program: CamProgram, points: int = 3600) -> Path:
    """Write one revolution of the cam program as a camsim HDF5 file (``file_kind = "cam"``).

    Layout: ``/time`` [s] (a dimension scale attached to every trace), ``/cam/angle``
    [deg], ``/cam/displacement`` [m], ``/cam/velocity`` [m/s], ``/cam/acceleration``
    [m/s^2], ``/cam/jerk`` [m/s^3] on the model axis, ``/cam/boundaries_deg`` (segment
    start angles [deg], segment cams only); with ``[cam.geometry]`` also
    ``/cam/pressure_angle`` [deg], ``/cam/pitch_radius_of_curvature``,
    ``/cam/surface_radius_of_curvature`` [m], ``/cam/pitch_curve``, ``/cam/surface``
    (N, 2) [m]; with ``[cam.compensation]`` (issue 27) ``/cam/...`` is the compensated cam and
    ``/cam/output_program/{displacement,velocity,acceleration}`` the wanted output motion;
    root attributes as in a run file.
    Written through the output policy (:func:`camsim.io.outputs.writing`).
    """
    data = sample_revolution(program, points)
    with writing(path, "hdf5", owner="cam") as target, target.h5() as f:
        write_root_attributes(f, machine, "cam")
        time = write_time(f, data["time"])
        write_trace(f, "cam/angle", data["angle"], "deg", "cam angle", time)
        for name, units, long_name in TRACES:
            write_trace(f, f"cam/{name}", data[name], units, long_name, time)
        geometry = getattr(machine.cam, "geometry", None)
        if geometry is not None:  # issue 14: the spec's /cam/... design datasets
            from camsim.cam.geometry import geometry_datasets

            for path_, (values, units, long_name) in geometry_datasets(
                geometry, program, np.radians(data["angle"])
            ).items():
                write_trace(f, path_, values, units, long_name, time)
        compensated = getattr(machine.cam, "compensated", None)
        if compensated is not None:  # issue 27: the wanted output motion, same time base
            from camsim.cam import CamProgram

            out = CamProgram(machine.cam.output_program).svaj(data["time"])
            for (name, units, _), values in zip(TRACES[:3], out[:3]):
                write_trace(f, f"cam/output_program/{name}", values, units,
                            f"wanted {name} of {compensated.output} (the written program) on the model axis",
                            time)
        if program.kind == "segments":
            write_trace(
                f, "cam/boundaries_deg", np.degrees(program.boundary_angles()), "deg", "cam angles of segment joins"
            )
    return Path(path)


def write_cam_csv(path: str | os.PathLike[str], program: CamProgram, points: int = 3600) -> Path:
    """Write one revolution of the cam program as CSV, units in the header.

    Columns: ``time [s]``, ``angle [deg]``, ``displacement [m]``, ``velocity [m/s]``,
    ``acceleration [m/s^2]``, ``jerk [m/s^3]`` (12 significant digits).
    """
    data = sample_revolution(program, points)
    header = ",".join(["time [s]", "angle [deg]"] + [f"{name} [{units}]" for name, units, _ in TRACES])
    columns = np.column_stack([data["time"], data["angle"]] + [data[name] for name, _, _ in TRACES]) + 0.0  # no "-0"
    with writing(path, "csv", owner="csv") as target, target.text() as fh:
        np.savetxt(fh, columns, fmt="%.12g", delimiter=",", header=header, comments="")
    return Path(path)

"""Cam kinematics: motion laws, the segment/table cam program, table splines.

>>> from camsim.cam import CamProgram
>>> program = CamProgram(machine.cam)      # doctest: +SKIP
>>> s, v, a, j = program.svaj(t)           # doctest: +SKIP
"""

from camsim.cam.laws import LAWS, NORTON_PEAKS, evaluate_law, fall, rise
from camsim.cam.peaks import law_peaks, sample_revolution
from camsim.cam.program import CamProgram


def __getattr__(name: str):
    # TableSpline pulls in scipy.interpolate; load it only when a table cam needs it.
    if name == "TableSpline":
        from camsim.cam.spline import TableSpline

        return TableSpline
    raise AttributeError(name)


__all__ = ["LAWS", "NORTON_PEAKS", "CamProgram", "TableSpline", "evaluate_law", "fall", "law_peaks", "rise", "sample_revolution"]

"""The engine's whole input: the cams' channels, then one group of four per load.

The engine reads its input u through three calls (``channels``, ``channels_at``,
``break_times``; :mod:`camsim.engine.context`) and knows nothing of what makes it. A machine
without loads hands it its cam input (a :class:`~camsim.cam.program.CamProgram` or a
:class:`~camsim.cam.camshaft.CamshaftInput`); a machine with loads hands it a
:class:`LoadedInput`: the cam input's 4·c columns followed by [F, Ḟ, F̈, F⃛] of each load
(:mod:`camsim.loads.programs`), in the order of the machine file's ``[[load]]`` tables, and
the break times of all of them merged. Everything else (the angle, the speed, the cams'
programs, the warnings) is the cam input's.
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ["LoadedInput", "engine_input"]


class LoadedInput:
    """A cam input with the loads' channel groups after its own.

    Parameters
    ----------
    cam : CamProgram or CamshaftInput
        The cam input (4·c columns).
    programs : sequence
        One load program per load (:mod:`camsim.loads.programs`).
    """

    def __init__(self, cam, programs):
        self.cam = cam
        self.programs = list(programs)

    def __getattr__(self, name: str):
        # the angle, the speed, the period, the cams' programs, ... are the cam input's
        if name in ("cam", "programs"):
            raise AttributeError(name)
        return getattr(self.cam, name)

    def channels(self, t, side: str = "right") -> np.ndarray:
        """The cam input's channels, then each load's [F, Ḟ, F̈, F⃛]: (N, 4·(c + loads))."""
        return np.concatenate([self.cam.channels(t, side=side), *(p.channels(t, side) for p in self.programs)], axis=1)

    def channels_at(self, t: float, side: str = "right") -> np.ndarray:
        """:meth:`channels` at one instant t [s]: (4·(c + loads),)."""
        return np.concatenate([self.cam.channels_at(t, side=side), *(p.channels_at(t, side) for p in self.programs)])

    def break_times(self, t_start: float, t_end: float) -> np.ndarray:
        """Times in (t_start, t_end) where the cams' motion or a load is not smooth, merged: two
        a rounding apart (1e-12 of a revolution, or of the window without a cam) are one."""
        parts = [self.cam.break_times(t_start, t_end), *(p.break_times(t_start, t_end) for p in self.programs)]
        times = np.unique(np.concatenate(parts))
        if times.size < 2:
            return times
        period = self.cam.period if math.isfinite(self.cam.period) else max(abs(t_end), abs(t_start), 1.0)
        keep = np.concatenate([[True], np.diff(times) > 1e-12 * period])
        return times[keep]

    def boundary_times(self, t_start: float, t_end: float) -> np.ndarray:
        """:meth:`break_times` (every instant the input is not smooth)."""
        return self.break_times(t_start, t_end)


def engine_input(cam, programs):
    """The engine's input of a machine: its cam input alone without loads, else a
    :class:`LoadedInput`."""
    return LoadedInput(cam, programs) if programs else cam

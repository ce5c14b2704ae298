"""The cam's significant harmonic: the highest harmonic of its acceleration that matters.

A cam turning at ω excites the follower train at the harmonics n·ω/2π of its motion. The
*significant* harmonic is the highest n whose amplitude in the acceleration spectrum is at
least :data:`SIGNIFICANT_FRACTION` of the largest harmonic's (Norton, *Cam Design and
Manufacturing Handbook*, ch. 9 on the Fourier content of cam functions: the smoother the
law, the faster its harmonics fall). A rod's default discretisation keeps its highest mode
above ten times it (camsim.elements.rod).
"""

from __future__ import annotations

import math

import numpy as np

from camsim.cam.peaks import sample_revolution
from camsim.cam.program import CamProgram

__all__ = ["SIGNIFICANT_FRACTION", "significant_harmonic"]

#: A harmonic counts when its amplitude is at least this share of the largest one.
SIGNIFICANT_FRACTION = 0.01


def significant_harmonic(program: CamProgram, points: int = 8192) -> tuple[int, float]:
    """(n, frequency [Hz]) of the highest significant harmonic of the cam's acceleration.

    The acceleration is sampled at ``points`` equal steps over one revolution and
    transformed (numpy's rfft); (0, 0.0) without a cam or for a cam that does not move.
    """
    if program.kind == "none" or not program.speed:
        return 0, 0.0
    accel = sample_revolution(program, points)["acceleration"]
    amplitude = np.abs(np.fft.rfft(accel))[1:]
    if not amplitude.size or amplitude.max() <= 0.0:
        return 0, 0.0
    n = int(np.nonzero(amplitude >= SIGNIFICANT_FRACTION * amplitude.max())[0][-1]) + 1
    return n, n * program.speed / (2.0 * math.pi)

"""A cam program's peaks and its revolution sampled: the design tables of ``camsim cam``.

:func:`law_peaks` gives a normalised law's peaks of |y′|, |y″|, |y‴| (dense sampling refined by
bounded Brent minimisation), :func:`segment_peaks` a program's per segment on the model axis,
:func:`sample_revolution` its motion over one revolution. They read a
:class:`camsim.cam.program.CamProgram` and are imported by it, not the other way round.
"""

from __future__ import annotations

import math
from functools import lru_cache

import numpy as np

from camsim.cam.laws import rise
from camsim.cam.description import SYNTHESIS_LAWS

__all__ = ["law_peaks", "sample_revolution", "sampled_peaks", "segment_peaks"]

_TWO_PI = 2.0 * math.pi
#: Samples of u ∈ [0, 1] used to bracket a law's peaks before refining them.
_PEAK_SAMPLES = 4001


def _refine_peak(func, lo: float, hi: float, samples: int) -> tuple[float, float]:
    """Largest |func| on [lo, hi] and where: dense sampling, then bounded Brent refinement.

    ``func`` maps an array of abscissae to values. Of samples within 1e-9 (relative) of
    the largest, the first is refined, so ties (a plateau, equal peaks) report the first.
    Returns (peak, abscissa).
    """
    x = np.linspace(lo, hi, samples)
    f = np.abs(func(x))
    top = float(f.max())
    if top == 0.0:
        return 0.0, float(lo)
    k = int(np.argmax(f >= top * (1.0 - 1e-9)))
    best_x, best_f = float(x[k]), float(f[k])
    a, b = x[max(k - 1, 0)], x[min(k + 1, samples - 1)]
    from scipy.optimize import minimize_scalar  # only for the peaks table; keeps start-up light

    res = minimize_scalar(
        lambda z: -abs(float(func(np.array([z]))[0])),
        bounds=(a, b),
        method="bounded",
        options={"xatol": 1e-13 * max(1.0, abs(hi - lo))},
    )
    if -res.fun > best_f * (1.0 + 1e-12):
        best_x, best_f = float(res.x), float(-res.fun)
    return best_f, best_x


@lru_cache(maxsize=None)
def law_peaks(law: str) -> tuple[tuple[float, float], tuple[float, float], tuple[float, float]]:
    """Peaks of |y′|, |y″|, |y‴| of a normalised rise and the u where each first occurs.

    Found by sampling u at 4001 points and refining the best sample with bounded Brent
    minimisation (``xatol`` 1e-13); peaks at u = 0 or 1 and plateaus report their first
    point. Returns ((Cv, u_v), (Ca, u_a), (Cj, u_j)).
    """
    out = []
    for order in (1, 2, 3):
        out.append(_refine_peak(lambda u, o=order: rise(law, u)[o], 0.0, 1.0, _PEAK_SAMPLES))
    return tuple(out)  # type: ignore[return-value]


def segment_peaks(program) -> list[dict]:
    """Per segment: lift and the peaks of |v|, |a|, |j| on the model axis, with angles.

    Peaks are the law's normalised peaks (:func:`law_peaks`: dense sampling refined
    by bounded Brent minimisation) scaled by h·ω/β, h·(ω/β)², h·(ω/β)³ and ``ratio``.
    A table cam is reported as one segment, its peaks found the same way on the
    spline (16 samples per table interval, at least 7200). A harmonic law's jerk is
    the finite peak inside the segment (the jerk is infinite at a join where its
    acceleration jumps). Empty without a cam.

    Parameters
    ----------
    program : camsim.cam.program.CamProgram

    Returns
    -------
    list of dict
        Keys: ``index`` (1-based), ``motion``, ``law`` (None for a dwell),
        ``start_deg``, ``duration_deg`` [deg], ``lift_m`` [m, model axis],
        ``peak_velocity`` [m/s], ``peak_acceleration`` [m/s^2], ``peak_jerk``
        [m/s^3], and ``peak_velocity_deg``, ``peak_acceleration_deg``,
        ``peak_jerk_deg``: the cam angle [deg] where each first occurs (None for a
        dwell).
    """
    if program.kind == "none":
        return []
    r, w = abs(program.ratio), program.speed
    if getattr(program, "_comp", None) is not None:  # issue 27: sampled on the compensated cam
        return sampled_peaks(program)
    if program._table is not None:
        spline = program._table
        n = max(7200, 16 * len(program.cam.table.angle))  # type: ignore[union-attr]
        entry = {
            "index": 1,
            "motion": "table",
            "law": "spline",
            "start_deg": math.degrees(spline.theta0),
            "duration_deg": 360.0,
        }
        lo, hi = spline.theta0, spline.theta0 + _TWO_PI
        lift = spline(np.linspace(lo, hi, n))[0]
        below, above = float(lift.min()), float(lift.max())
        span = max(above - below, 1e-300)
        # Refine the highest and lowest lift: extrema of |lift − c| with c outside the range.
        top = _refine_peak(lambda x: spline(x)[0] - (below - span), lo, hi, n)[0] + below - span
        bottom = above + span - _refine_peak(lambda x: spline(x)[0] - (above + span), lo, hi, n)[0]
        entry["lift_m"] = r * (top - bottom)
        for order, key in ((1, "velocity"), (2, "acceleration"), (3, "jerk")):
            peak, where = _refine_peak(
                lambda x, o=order: spline(x)[o], spline.theta0, spline.theta0 + _TWO_PI, n
            )
            entry[f"peak_{key}"] = r * peak * w**order
            entry[f"peak_{key}_deg"] = math.degrees(where) % 360.0
        return [entry]
    out = []
    for i, seg in enumerate(program.cam.segments):  # type: ignore[union-attr]
        beta, start = float(program._betas[i]), float(program._starts[i])
        h = abs(float(program._signed[i]))
        entry = {
            "index": i + 1,
            "motion": seg.motion,
            "law": program._laws[i],
            "start_deg": math.degrees(start),
            "duration_deg": math.degrees(beta),
            "lift_m": r * h,
        }
        law = program._laws[i]
        for order, key in ((1, "velocity"), (2, "acceleration"), (3, "jerk")):
            if law is None or h == 0.0:
                entry[f"peak_{key}"] = 0.0
                entry[f"peak_{key}_deg"] = None
                continue
            if law in SYNTHESIS_LAWS:
                coeff, u = _refine_peak(lambda x, i=i, o=order: program._shape_values(i, x, o)[o], 0.0, 1.0,
                                        _PEAK_SAMPLES)
            else:
                coeff, u = law_peaks(law)[order - 1]
            entry[f"peak_{key}"] = r * h * coeff * (w / beta) ** order
            entry[f"peak_{key}_deg"] = math.degrees(start + u * beta)
        out.append(entry)
    return out


def sampled_peaks(program) -> list[dict]:
    """Peaks of a compensated cam, per written segment (or one row for a table), sampled."""
    r, w = abs(program.ratio), program.speed
    written = program._written
    rows = segment_peaks(written) if written.kind == "segments" else [{"index": 1, "motion": "table",
                                                                        "law": "spline", "start_deg": 0.0,
                                                                        "duration_deg": 360.0}]
    out = []
    for row in rows:
        lo = math.radians(row["start_deg"])
        hi = lo + math.radians(row["duration_deg"])
        entry = {k: row[k] for k in ("index", "motion", "law", "start_deg", "duration_deg")}
        entry["law"] = f"compensated {row['law']}" if row["law"] else "compensated"
        theta = np.linspace(lo, hi, 2001)
        lift = program.lift(theta, side="left")[0]
        entry["lift_m"] = r * float(np.ptp(lift))
        for order, key in ((1, "velocity"), (2, "acceleration"), (3, "jerk")):
            peak, where = _refine_peak(lambda x, o=order: program.lift(x, side="left")[o], lo, hi, 2001)
            entry[f"peak_{key}"] = r * peak * w**order
            entry[f"peak_{key}_deg"] = math.degrees(where) % 360.0
        out.append(entry)
    return out


def sample_revolution(program, points: int = 3600) -> dict[str, np.ndarray]:
    """The cam program over one revolution from t = 0, at ``points`` equal time steps.

    Parameters
    ----------
    program : camsim.cam.program.CamProgram
        A program with a cam (finite period).
    points : int
        Number of samples [-]; t = k·T/points for k = 0 … points − 1 (the end of the
        revolution, equal to its start, is not repeated).

    Returns
    -------
    dict of ndarray
        ``time`` [s], ``angle`` [deg] (θ0 + ω·t, not wrapped), ``displacement`` [m],
        ``velocity`` [m/s], ``acceleration`` [m/s^2], ``jerk`` [m/s^3] on the model axis.

    Raises
    ------
    ValueError
        Without a cam, or with fewer than 2 points.
    """
    if program.kind == "none":
        raise ValueError("the machine has no cam")
    if points < 2:
        raise ValueError(f"points must be at least 2, got {points}")
    t = np.arange(points) * (program.period / points)
    s, v, a, j = program.svaj(t)
    return {
        "time": t,
        "angle": np.degrees(program.angle(t)),
        "displacement": s,
        "velocity": v,
        "acceleration": a,
        "jerk": j,
    }

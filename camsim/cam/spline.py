"""Table cams: a periodic quintic spline through a measured or exported cam profile.

The thesis imported its cam functions from DYNACAM as tables of s, v, a against cam
angle. camsim interpolates the displacement column with a periodic interpolating spline
of degree 5 (scipy's ``make_interp_spline(..., k=5, bc_type="periodic")``) on the cam
angle, the first point repeated one revolution later. The spline and its first four
derivatives are continuous all the way round, so s, v, a and the jerk j have no jumps.
Velocity and acceleration columns, when given, are not interpolated: they only check the
spline (a warning when they differ by more than 1 % of their peak).
"""

from __future__ import annotations

import math

import numpy as np
from scipy.interpolate import BSpline, make_interp_spline

from camsim.cam.description import CamTable

__all__ = ["TableSpline", "CHECK_TOLERANCE"]

#: Relative difference (to the column's peak) above which a given velocity or
#: acceleration column is reported as disagreeing with the spline.
CHECK_TOLERANCE = 0.01

_TWO_PI = 2.0 * math.pi


class TableSpline:
    """Periodic spline of roller lift against cam angle.

    Parameters
    ----------
    table : CamTable
        Angles [rad] (strictly increasing, spanning less than one revolution; a last
        point exactly one revolution after the first is dropped when its lift equals the
        first) and roller lift [m].
    speed : float
        Camshaft speed ω [rad/s], used to compare the optional velocity [m/s] and
        acceleration [m/s^2] columns with the spline.

    Attributes
    ----------
    theta0 : float
        First table angle [rad]; the spline is defined on [theta0, theta0 + 2π].
    warnings : list of str
        Disagreements between the spline and the given velocity/acceleration columns.

    Raises
    ------
    ValueError
        If the table is too short, not increasing, or spans a revolution or more.
    """

    def __init__(self, table: CamTable, speed: float):
        angle = np.asarray(table.angle, dtype=float)
        lift = np.asarray(table.displacement, dtype=float)
        velocity = None if table.velocity is None else np.asarray(table.velocity, dtype=float)
        acceleration = None if table.acceleration is None else np.asarray(table.acceleration, dtype=float)
        if angle.ndim != 1 or angle.shape != lift.shape:
            raise ValueError("cam table: angle and displacement columns must have the same length")
        if angle.size < 4:
            raise ValueError("cam table: at least 4 points are needed for a periodic spline")
        if not np.all(np.diff(angle) > 0):
            raise ValueError("cam table: angles must be strictly increasing")
        span = angle[-1] - angle[0]
        if abs(span - _TWO_PI) <= 1e-9 * _TWO_PI and abs(lift[-1] - lift[0]) <= 1e-12 * max(np.ptp(lift), 1e-300):
            # The table repeats its first point one revolution later: drop the repeat.
            angle, lift = angle[:-1], lift[:-1]
            velocity = None if velocity is None else velocity[:-1]
            acceleration = None if acceleration is None else acceleration[:-1]
            span = angle[-1] - angle[0]
        if span >= _TWO_PI:
            raise ValueError("cam table: the angles must span less than one revolution (360 deg)")
        self.theta0 = float(angle[0])
        x = np.append(angle, angle[0] + _TWO_PI)
        y = np.append(lift, lift[0])
        self._spline: BSpline = make_interp_spline(x, y, k=5, bc_type="periodic")
        self._derivs = [self._spline.derivative(n) for n in (1, 2, 3)]
        self.warnings: list[str] = []
        for column, order, name, unit in (
            (velocity, 1, "velocity", "m/s"),
            (acceleration, 2, "acceleration", "m/s^2"),
        ):
            if column is None:
                continue
            if column.shape != angle.shape:
                raise ValueError(f"cam table: the {name} column must have as many rows as the angles")
            fitted = self._derivs[order - 1](angle) * speed**order
            peak = float(np.max(np.abs(column)))
            diff = np.abs(fitted - column)
            worst = int(np.argmax(diff))
            if diff[worst] > CHECK_TOLERANCE * peak:
                where = f"{math.degrees(angle[worst]):g} deg"
                source = f"{table.source}: " if table.source else ""
                self.warnings.append(
                    f"{source}{name} column differs from the spline of the displacement by "
                    f"{diff[worst]:.3g} {unit} ({100 * diff[worst] / peak:.2g} % of its peak) at {where}"
                )

        # A lift below 0 is below the base circle (a segment cam starts on it): a row below 0
        # or the spline dipping between rows. The follower then runs inside the base circle,
        # which no real cam allows: worth a warning (issue 26).
        fine = self.theta0 + np.linspace(0.0, _TWO_PI, max(7200, 16 * angle.size), endpoint=False)
        dip = self._spline(fine)
        k = int(np.argmin(dip))
        if dip[k] < -1e-9 * max(float(np.ptp(lift)), 1e-12):
            source = f"{table.source}: " if table.source else ""
            rows = int(np.count_nonzero(lift < 0))
            cause = f"{rows} rows are below 0" if rows else "the spline dips below 0 between rows"
            self.warnings.append(
                f"{source}the lift goes below the base circle (lift 0): {dip[k]:.4g} m at "
                f"{math.degrees(fine[k]) % 360.0:.4g} deg ({cause}); the follower would run inside the base circle"
            )

    def phase(self, theta: np.ndarray) -> np.ndarray:
        """Map cam angles θ [rad] into the spline's revolution [theta0, theta0 + 2π)."""
        return self.theta0 + np.mod(np.asarray(theta, dtype=float) - self.theta0, _TWO_PI)

    def __call__(self, theta: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Roller lift and its derivatives with respect to cam angle.

        Parameters
        ----------
        theta : ndarray
            Cam angle [rad], any value (wrapped to one revolution).

        Returns
        -------
        s, ds, d2s, d3s : ndarray
            Lift [m], ds/dθ [m/rad], d²s/dθ² [m/rad²], d³s/dθ³ [m/rad³].
        """
        phi = self.phase(theta)
        return (self._spline(phi), self._derivs[0](phi), self._derivs[1](phi), self._derivs[2](phi))

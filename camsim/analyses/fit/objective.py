"""The fit's objective: weighted residuals between a simulation and the measurements.

For every measured channel c and sample k inside the comparison window the residual is

    r_ck = (y_sim,c(t_k + shift) - y_meas,c(t_k)) / sigma_c

where ``y_sim`` is the simulated trace linearly interpolated at the measured time moved by
the fitted time shift (0 unless ``--align offset``), and ``sigma_c`` is the channel's
noise level [its SI unit], so that channels in different units count fairly. A scalar
target adds ``(value_sim - value_target) / sigma_target``.

Noise level estimated from the data (when ``--sigma`` does not give it): for white noise
e_k of standard deviation sigma the second difference e_{k+1} - 2 e_k + e_{k-1} has
standard deviation sqrt(6)·sigma; a smooth signal sampled finely contributes little to
it. The median absolute deviation (scaled by 1.4826 to a standard deviation for Gaussian
noise) of the second differences of the measured samples, divided by sqrt(6), is the
estimate. The median makes it insensitive to the few samples around an impact. It
overestimates sigma when the signal itself is not smooth on the scale of three samples
(undersampled data): then give ``--sigma``.

Simulated window: the recorded cycles, time 0 at the start of the first one (the measured
time zero means the same instant). With ``--align offset``, a measured time moved outside
the recorded window is wrapped by one cam period (the motion after warm-up is periodic;
the run's periodicity residual says how well).
"""

from __future__ import annotations

import math
import re
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from camsim.errors import InputError

__all__ = [
    "SCALAR_UNITS",
    "Target",
    "Objective",
    "estimate_sigma",
    "parse_sigma",
    "parse_target",
    "parse_window",
    "parse_max_shift",
    "run_scalars",
    "scalar_units",
]

#: Gaussian scale of the median absolute deviation: sigma = MAD_SCALE · MAD.
MAD_SCALE = 1.482602218505602
#: Default standard deviation of a scalar target, relative to its value.
TARGET_RELATIVE_SIGMA = 0.01
#: Smallest noise level used for a channel whose estimate is zero, relative to its RMS.
SIGMA_FLOOR = 1e-6

_NUMBER = re.compile(r"^\s*([-+]?(?:\d+(?:\.\d*)?|\.\d+)(?:[eE][-+]?\d+)?)\s*(.*?)\s*$")

#: Scalar names accepted under another spelling (the issue's wording).
ALIASES = {"max_transducer_force": "peak_transducer_force"}
#: Scalars with their SI units (per mass / per element names are added by :func:`scalar_units`).
SCALAR_UNITS = {
    "peak_transducer_force": "N",
    "peak_transducer_force_time": "s",
    "max_cam_contact_force": "N",
    "min_cam_contact_force": "N",
    "max_impact_velocity": "m/s",
    "first_impact_time": "s",
}


def scalar_units(machine) -> dict[str, str]:
    """Every scalar a ``--target`` can name for ``machine``, with its SI unit.

    ``peak_<quantity>:<mass>`` (largest absolute sampled value), ``peak_transducer_force``
    (alias ``max_transducer_force``) and ``peak_transducer_force_time``,
    ``max_cam_contact_force``, ``min_cam_contact_force``, ``max_impact_velocity``,
    ``first_impact_time`` and ``first_impact_time:<element>`` (the first impact or rejoin
    event of the recorded window).
    """
    units = dict(SCALAR_UNITS)
    for m in machine.masses:
        for q, u in (("displacement", "m"), ("velocity", "m/s"), ("acceleration", "m/s^2")):
            units[f"peak_{q}:{m.name}"] = u
    for e in machine.elements:
        units[f"first_impact_time:{e.name}"] = "s"
    from camsim.run import families  # the design's, the camshaft's, the loads', the friction pairs'

    units.update(families.columns(machine))
    return units


def run_scalars(result) -> dict[str, float]:
    """The scalars of :func:`scalar_units` for one RunResult (NaN where they do not exist).

    :meth:`RunResult.scalars` (the numbers among them) plus the impact times and the time
    of the peak transducer force.
    """
    row = {k: v for k, v in result.scalars().items() if isinstance(v, float)}
    nan = math.nan
    tf = result.transducer_force
    row["peak_transducer_force_time"] = float(result.time[int(np.argmax(tf))]) if tf is not None and tf.size else nan
    impacts = result.impacts()
    row["first_impact_time"] = float(impacts[0].time) if impacts else nan
    for e in result.machine.elements:
        times = [ev.time for ev in impacts if ev.element == e.name]
        row[f"first_impact_time:{e.name}"] = float(times[0]) if times else nan
    return row


def _split(text: str, where: str) -> tuple[float, str]:
    m = _NUMBER.match(text)
    if not m:
        raise InputError(f"{where}: '{text.strip()}' is not a number (with an optional unit)")
    return float(m.group(1)), m.group(2)


def _to(value: float, unit: str, target: str, where: str) -> float:
    import pint

    from camsim.units import ureg

    if not unit:
        return value
    if re.search(r"(?<![A-Za-z_])mils?(?![A-Za-z_])", unit):
        raise InputError(f'{where}: "mil" is ambiguous (pint reads it as an angle); write "thou"')
    try:
        q = ureg.Quantity(value, unit)
    except Exception:  # pint raises several unrelated types for unparsable text
        raise InputError(f"{where}: '{unit}' is not a unit") from None
    try:
        return float(q.to(target or "dimensionless").magnitude)
    except pint.DimensionalityError:
        raise InputError(f"{where}: unit '{unit}' cannot be converted to {target or 'a number'}") from None


@dataclass(frozen=True)
class Target:
    """A scalar the fitted run should reproduce.

    Attributes
    ----------
    name : str
        Scalar name (:func:`scalar_units`).
    value : float
        Target value [SI].
    sigma : float
        Its standard deviation [SI] (weight 1/sigma).
    unit : str
        SI unit.
    """

    name: str
    value: float
    sigma: float
    unit: str


def parse_target(text: str, units: dict[str, str]) -> tuple[str, float]:
    """``NAME=VALUE[UNIT]`` → (canonical name, SI value).

    Raises
    ------
    InputError
        Malformed text, an unknown scalar name, a unit of the wrong dimension.
    """
    where = f"--target {text}"
    name, sep, spec = text.partition("=")
    name = name.strip()
    if not sep or not name:
        raise InputError(f"{where}: expected NAME=VALUE[UNIT], e.g. max_transducer_force=148lbf")
    name = ALIASES.get(name, name)
    if name not in units:
        raise InputError(f"{where}: unknown scalar '{name}' (known: {', '.join(sorted(units))})")
    value, unit = _split(spec, where)
    return name, _to(value, unit, units[name], where)


def parse_sigma(text: str, units: dict[str, str]) -> tuple[str, float]:
    """``PATH=VALUE[UNIT]`` (a measured path or a target name) → (name, sigma [SI]).

    Raises
    ------
    InputError
        Malformed text, a name that is neither a measured column nor a target, a unit of
        the wrong dimension, a value that is not positive.
    """
    where = f"--sigma {text}"
    name, sep, spec = text.partition("=")
    name = ALIASES.get(name.strip(), name.strip())
    if not sep or not name:
        raise InputError(f"{where}: expected PATH=VALUE[UNIT], e.g. transducer/force=0.5lbf")
    if name not in units:
        raise InputError(f"{where}: '{name}' is neither a measured column nor a --target (those are: {', '.join(units)})")
    value, unit = _split(spec, where)
    si = _to(value, unit, units[name], where)
    if not si > 0:
        raise InputError(f"{where}: the noise level must be positive")
    return name, si


def parse_window(text: str) -> tuple[float, float]:
    """``START:STOP[UNIT]`` (default seconds) → (start, stop) [s] on the measured time base.

    Raises
    ------
    InputError
        Malformed text, or STOP not above START.
    """
    where = f"--window {text}"
    parts = text.split(":")
    if len(parts) != 2:
        raise InputError(f"{where}: expected START:STOP[UNIT], e.g. 0.1:0.3 or 100:300ms")
    (a, ua), (b, ub) = (_split(p, where) for p in parts)
    unit_b = ub or "s"
    start = _to(a, ua or unit_b, "s", where)
    stop = _to(b, unit_b, "s", where)
    if not stop > start:
        raise InputError(f"{where}: STOP must be after START")
    return start, stop


def parse_max_shift(text: str) -> float:
    """``--max-shift VALUE[UNIT]`` (default seconds) → shift bound [s] (positive)."""
    where = f"--max-shift {text}"
    value, unit = _split(text, where)
    si = _to(value, unit or "s", "s", where)
    if not si > 0:
        raise InputError(f"{where}: must be positive")
    return si


def estimate_sigma(values: np.ndarray) -> float:
    """Noise level of a uniformly sampled signal: 1.4826·MAD(second differences)/√6.

    Parameters
    ----------
    values : ndarray
        Samples (any unit); at least 3.

    Returns
    -------
    float
        Estimated standard deviation of white measurement noise [same unit].
    """
    d2 = np.diff(np.asarray(values, dtype=float), 2)
    if d2.size == 0:
        return 0.0
    mad = float(np.median(np.abs(d2 - np.median(d2))))
    return MAD_SCALE * mad / math.sqrt(6.0)


@dataclass
class Objective:
    """Residuals of a fit, given the simulated traces and scalars.

    Attributes
    ----------
    paths : list of str
        Measured channel paths, in order.
    times : list of ndarray
        Each channel's compared sample times [s] (measured base, inside the window).
    values : list of ndarray
        Each channel's compared samples [SI].
    sigmas : list of float
        Each channel's noise level [SI].
    targets : list of Target
    t_end : float
        End of the simulated window [s].
    period : float or None
        Cam period [s] for wrapping shifted times (``None``: no wrapping).
    align : bool
        Whether a time shift is fitted.
    """

    paths: list[str]
    times: list[np.ndarray]
    values: list[np.ndarray]
    sigmas: list[float]
    targets: list[Target] = field(default_factory=list)
    t_end: float = 0.0
    period: float | None = None
    align: bool = False

    @property
    def size(self) -> int:
        """Number of residuals."""
        return sum(t.size for t in self.times) + len(self.targets)

    def _times(self, t: np.ndarray, shift: float) -> np.ndarray:
        ts = t + shift
        if self.align and self.period:
            ts = np.where(ts < 0.0, ts + self.period, ts)
            ts = np.where(ts > self.t_end, ts - self.period, ts)
        return ts

    def simulated(self, sim_time: np.ndarray, traces: dict[str, np.ndarray], shift: float = 0.0) -> list[np.ndarray]:
        """Each channel's simulated values at its compared times [SI]."""
        return [np.interp(self._times(t, shift), sim_time, traces[p]) for p, t in zip(self.paths, self.times)]

    def residuals(self, sim_time: np.ndarray, traces: dict[str, np.ndarray], scalars: dict[str, float], shift: float = 0.0) -> np.ndarray:
        """The weighted residual vector (dimensionless)."""
        parts = [(s - y) / sg for s, y, sg in zip(self.simulated(sim_time, traces, shift), self.values, self.sigmas)]
        if self.targets:
            parts.append(np.array([(scalars[t.name] - t.value) / t.sigma for t in self.targets], dtype=float))
        return np.concatenate(parts) if parts else np.zeros(0)

    def rms(self, sim_time: np.ndarray, traces: dict[str, np.ndarray], scalars: dict[str, float], shift: float = 0.0) -> dict[str, float]:
        """RMS of the unweighted residual of each channel and target [SI]."""
        out = {}
        for p, s, y in zip(self.paths, self.simulated(sim_time, traces, shift), self.values):
            out[p] = float(np.sqrt(np.mean((s - y) ** 2)))
        for t in self.targets:
            out[t.name] = float(abs(scalars[t.name] - t.value))
        return out


def build_objective(
    measured,
    targets: Sequence[tuple[str, float]],
    target_units: dict[str, str],
    sigmas: dict[str, float],
    window: tuple[float, float] | None,
    t_end: float,
    period: float | None,
    max_shift: float | None,
    warnings: list[str],
) -> Objective:
    """Assemble the :class:`Objective` and check the measured times against the window.

    Parameters
    ----------
    measured : Measured or None
    targets : sequence of (name, SI value)
    target_units : dict
        Scalar name → SI unit.
    sigmas : dict
        Given noise levels, by path or target name [SI].
    window : (float, float) or None
        Compared measured times [s].
    t_end : float
        End of the simulated (recorded) window [s].
    period : float or None
        Cam period [s].
    max_shift : float or None
        Time-shift bound with ``--align offset`` [s].
    warnings : list of str
        Appended to (e.g. a zero noise estimate).

    Raises
    ------
    InputError
        A channel with fewer than 3 samples in the window; measured times outside the
        simulated window; a target of value 0 without ``--sigma``.
    """
    paths, times, values, sig = [], [], [], []
    eps = 1e-9 * max(t_end, 1.0)
    if measured is not None:
        for c in measured.channels:
            t, y = c.time, c.values
            if window is not None:
                keep = (t >= window[0]) & (t <= window[1])
                t, y = t[keep], y[keep]
                if t.size < 3:
                    raise InputError(f"--window: {measured.source}: column {c.column} '{c.path}' keeps {t.size} samples in the window (need 3)")
            lo, hi = float(t[0]), float(t[-1])
            if max_shift is None or period is None:
                if lo < -eps or hi > t_end + eps:
                    raise InputError(
                        f"{measured.source}: {measured.time_header}: measured times {lo:.6g} to {hi:.6g} s lie outside the "
                        f"simulated window 0 to {t_end:.6g} s (time 0 is the start of the first recorded cycle; "
                        "use --cycles for more cycles or --window to compare part of the data)"
                    )
            elif lo - max_shift < -period - eps or hi + max_shift > t_end + period + eps or hi - lo > t_end + eps:
                raise InputError(
                    f"{measured.source}: {measured.time_header}: measured times {lo:.6g} to {hi:.6g} s (shifted by up to "
                    f"±{max_shift:.6g} s) do not fit in the simulated window 0 to {t_end:.6g} s"
                )
            if c.path in sigmas:
                s = sigmas[c.path]
            else:
                s = estimate_sigma(y)
                rms = float(np.sqrt(np.mean(y**2)))
                if not s > 0:
                    s = max(SIGMA_FLOOR * rms, 1e-300)
                    warnings.append(
                        f"{c.path}: the noise level estimated from the data is 0 (noise-free data?); "
                        f"using {s:.3g} {c.unit}; give --sigma {c.path}=VALUE for a meaningful weighting"
                    )
            paths.append(c.path)
            times.append(t)
            values.append(y)
            sig.append(s)
    tlist = []
    for name, value in targets:
        if name in sigmas:
            s = sigmas[name]
        elif value != 0:
            s = TARGET_RELATIVE_SIGMA * abs(value)
        else:
            raise InputError(f"--target {name}: a target of 0 needs its uncertainty: --sigma {name}=VALUE[UNIT]")
        tlist.append(Target(name=name, value=value, sigma=s, unit=target_units[name]))
    return Objective(paths=paths, times=times, values=values, sigmas=sig, targets=tlist, t_end=t_end, period=period, align=max_shift is not None)

"""Input distributions of a tolerance study: parsing ``--dist KEY=SPEC`` into SI.

A study varies machine keys of the ``--set`` grammar (``element.seat.stiffness``,
``mass.M2.mass``, ...). Each is given a distribution by a SPEC; numbers carry the unit
written after the last number (it applies to all of them; an earlier number may repeat
it), as in ``sweep --vary``:

===========================================  =============================================
SPEC                                          distribution
===========================================  =============================================
``normal:MEAN:STD[UNIT]``                     normal
``uniform:LOW:HIGH[UNIT]``                    uniform on [LOW, HIGH]
``lognormal:MEDIAN:GSD[UNIT]``                ln X normal, median MEDIAN, geometric std
                                              GSD (a factor > 1, no unit; UNIT is MEDIAN's)
``truncnormal:MEAN:STD:LOW:HIGH[UNIT]``       normal truncated to [LOW, HIGH]
``tol:NOMINAL:PLUSMINUS[UNIT]``               drawing-office tolerance: normal with
                                              mean NOMINAL, σ = PLUSMINUS / s, truncated
                                              at NOMINAL ± PLUSMINUS (s = ``--tol-sigma``,
                                              default 3)
``tol:NOMINAL:+UP:-DOWN[UNIT]``               asymmetric limits NOMINAL+UP, NOMINAL-DOWN:
                                              normal centred between the limits, σ =
                                              (limit range) / (2 s), truncated at them
===========================================  =============================================

Every value is converted to SI with the one unit registry (:mod:`camsim.units`), in the
SI unit of the key's ``param:`` column (:func:`camsim.machine.keys.unit`); a bare number is
SI. Errors are :class:`~camsim.errors.InputError` naming the option, in one line.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass
from typing import Any

import numpy as np

from camsim.errors import InputError

__all__ = ["Distribution", "parse_dist", "KINDS", "DEFAULT_TOL_SIGMA"]

#: Distribution names a SPEC may start with.
KINDS = ("normal", "uniform", "lognormal", "truncnormal", "tol")
#: Number of standard deviations a drawing-office tolerance spans (``--tol-sigma``).
DEFAULT_TOL_SIGMA = 3.0

_NUMBER = re.compile(r"^\s*([-+]?(?:\d+(?:\.\d*)?|\.\d+)(?:[eE][-+]?\d+)?)\s*(.*?)\s*$")


@dataclass(frozen=True)
class Distribution:
    """One input of a study: a machine key and its distribution, in SI.

    Attributes
    ----------
    key : str
        Machine key of the ``--set`` grammar, e.g. ``element.seat.stiffness``.
    kind : str
        One of :data:`KINDS`.
    params : tuple of float
        The SPEC's numbers in SI (GSD stays a factor), in the SPEC's order.
    unit : str
        SI unit of the key ('' for a number).
    text : str
        The option as written (``KEY=SPEC``), for messages and the study's identity.
    low, high : float
        Support [SI]: ±inf for normal and lognormal (low 0).
    """

    key: str
    kind: str
    params: tuple[float, ...]
    unit: str
    text: str
    low: float = -math.inf
    high: float = math.inf
    tol_sigma: float = DEFAULT_TOL_SIGMA

    def frozen(self) -> Any:
        """The ``scipy.stats`` frozen distribution in SI."""
        from scipy import stats

        p = self.params
        if self.kind == "normal":
            return stats.norm(loc=p[0], scale=p[1])
        if self.kind == "uniform":
            return stats.uniform(loc=p[0], scale=p[1] - p[0])
        if self.kind == "lognormal":
            return stats.lognorm(s=math.log(p[1]), scale=p[0])
        if self.kind == "truncnormal":
            mean, std, low, high = p
            return stats.truncnorm((low - mean) / std, (high - mean) / std, loc=mean, scale=std)
        # tol: normal centred between the limits, ±tol_sigma σ to the limits
        mid, sigma = 0.5 * (self.low + self.high), (self.high - self.low) / (2.0 * self.tol_sigma)
        return stats.truncnorm(-self.tol_sigma, self.tol_sigma, loc=mid, scale=sigma)

    def ppf(self, u: np.ndarray) -> np.ndarray:
        """Inverse CDF: values [SI] at probabilities ``u`` in (0, 1)."""
        return np.asarray(self.frozen().ppf(u), dtype=float)

    @property
    def nominal(self) -> float:
        """The value of the nominal machine [SI]: NOMINAL, MEAN, MEDIAN or the mid-range."""
        p = self.params
        if self.kind == "uniform":
            return 0.5 * (p[0] + p[1])
        if self.kind == "truncnormal":
            return min(max(p[0], p[2]), p[3])
        return p[0]


def _number(text: str, where: str) -> tuple[float, str]:
    m = _NUMBER.match(text)
    if not m:
        raise InputError(f"{where}: '{text.strip()}' is not a number (with an optional unit)")
    return float(m.group(1)), m.group(2).replace(" ", "")


def _to_si(value: float, unit: str, si_unit: str, where: str) -> float:
    """``value`` in ``unit`` converted to ``si_unit`` (bare number: already SI)."""
    if not unit:
        return value
    import pint

    from camsim.units import ureg

    if re.search(r"(?<![A-Za-z_])mils?(?![A-Za-z_])", unit):
        raise InputError(f'{where}: "mil" is ambiguous (pint reads it as an angle); write "thou" or "0.001 in"')
    try:
        q = ureg.Quantity(value, unit)
    except Exception:  # noqa: BLE001 - pint raises several types for unknown units
        raise InputError(f"{where}: unknown unit '{unit}'") from None
    try:
        if si_unit:
            return float(q.to(si_unit).magnitude)
        if q.dimensionless:
            return float(q.to("").magnitude)
        return float(q.to_base_units().magnitude)
    except pint.DimensionalityError:
        raise InputError(f"{where}: unit '{unit}' does not fit this key (its SI unit is {si_unit or 'none'})") from None


def parse_dist(text: str, tol_sigma: float = DEFAULT_TOL_SIGMA, option: str = "--dist") -> Distribution:
    """Parse ``KEY=SPEC`` (see the module docstring) into a :class:`Distribution`.

    Parameters
    ----------
    text : str
        e.g. ``"element.K01.stiffness=tol:25.62:2.5lbf/in"``.
    tol_sigma : float
        Standard deviations between a ``tol:`` nominal and its limits.
    option : str
        How the option is named in messages.

    Raises
    ------
    InputError
        Unknown distribution, wrong count of numbers, a unit that does not fit the key,
        STD ≤ 0, GSD ≤ 1, LOW ≥ HIGH, a non-positive median, a nominal outside its own
        tolerance, a non-finite number.
    """
    from camsim.machine.keys import unit as key_unit

    where = f"{option} {text}"
    key, sep, spec = text.partition("=")
    key = key.strip()
    if not sep or not key or not spec.strip():
        raise InputError(f"{where}: expected KEY=SPEC, e.g. element.seat.stiffness=tol:8.6e6:0.5e6N/m")
    if not (tol_sigma > 0 and math.isfinite(tol_sigma)):
        raise InputError(f"--tol-sigma {tol_sigma}: must be a positive number")
    kind, _, rest = spec.strip().partition(":")
    kind = kind.strip().lower()
    if kind not in KINDS:
        raise InputError(f"{where}: unknown distribution '{kind}' (one of {', '.join(KINDS)})")
    parts = rest.split(":") if rest else []
    counts = {"normal": (2,), "uniform": (2,), "lognormal": (2,), "truncnormal": (4,), "tol": (2, 3)}
    forms = {
        "normal": "normal:MEAN:STD[UNIT]",
        "uniform": "uniform:LOW:HIGH[UNIT]",
        "lognormal": "lognormal:MEDIAN:GSD[UNIT]",
        "truncnormal": "truncnormal:MEAN:STD:LOW:HIGH[UNIT]",
        "tol": "tol:NOMINAL:PLUSMINUS[UNIT] or tol:NOMINAL:+UP:-DOWN[UNIT]",
    }
    if len(parts) not in counts[kind]:
        raise InputError(f"{where}: expected {forms[kind]}")
    raw = [_number(p, where) for p in parts]
    if kind == "lognormal":
        # the unit is written after GSD but belongs to MEDIAN; GSD is a factor
        (median, u0), (gsd, unit) = raw
        unit = unit or u0
        if u0 and u0 != unit:
            raise InputError(f"{where}: MEDIAN may only repeat the unit written after GSD ('{unit}')")
        numbers, units = [median], [unit]
    else:
        unit = raw[-1][1]
        for _, given in raw[:-1]:
            if given and given != unit:
                raise InputError(f"{where}: numbers before the last may only repeat its unit ('{unit or 'none'}'), not '{given}'")
        numbers, units = [v for v, _ in raw], [unit] * len(raw)
    if not all(math.isfinite(v) for v, _ in raw):
        raise InputError(f"{where}: numbers must be finite")
    si_unit = key_unit(key)
    si = [_to_si(v, u, si_unit, where) for v, u in zip(numbers, units)]
    if kind in ("normal", "truncnormal") and not si[1] > 0:
        raise InputError(f"{where}: STD must be > 0")
    if kind == "uniform" and not si[0] < si[1]:
        raise InputError(f"{where}: LOW must be below HIGH")
    if kind == "truncnormal" and not si[2] < si[3]:
        raise InputError(f"{where}: LOW must be below HIGH")
    low, high = -math.inf, math.inf
    if kind == "lognormal":
        if not si[0] > 0:
            raise InputError(f"{where}: MEDIAN must be > 0")
        if not raw[1][0] > 1:
            raise InputError(f"{where}: GSD (geometric standard deviation, a factor) must be > 1")
        si.append(raw[1][0])
        low = 0.0
    elif kind == "uniform":
        low, high = si
    elif kind == "truncnormal":
        low, high = si[2], si[3]
    elif kind == "tol":
        nominal = si[0]
        if len(si) == 2:
            if not si[1] > 0:
                raise InputError(f"{where}: PLUSMINUS must be > 0")
            low, high = nominal - si[1], nominal + si[1]
        else:
            up_text, down_text = parts[1].strip(), parts[2].strip()
            if not (up_text.startswith(("+", "-")) and down_text.startswith(("+", "-"))):
                raise InputError(f"{where}: write the asymmetric limits with their signs, tol:NOMINAL:+UP:-DOWN[UNIT]")
            # signed deviations; a lower limit above the nominal (or an upper one below)
            # puts the nominal outside its own tolerance
            a, b = nominal + si[1], nominal + si[2]
            low, high = min(a, b), max(a, b)
            if not low < high:
                raise InputError(f"{where}: the two limits are equal")
            if not low <= nominal <= high:
                raise InputError(f"{where}: the nominal {parts[0].strip()} lies outside its own tolerance")
    return Distribution(key=key, kind=kind, params=tuple(float(v) for v in si), unit=si_unit, text=text.strip(),
                        low=low, high=high, tol_sigma=float(tol_sigma))

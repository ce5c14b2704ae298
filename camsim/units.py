"""The one unit registry of camsim, and parsing of quantities at the input boundary.

Quantities are parsed once, when a machine file or an option is read, and converted to
SI floats; nothing below the loader sees a pint object.
"""

from __future__ import annotations

import math
import re
from typing import Any

_REGISTRY = None


def registry() -> Any:
    """The one pint ``UnitRegistry`` of camsim, created on first use.

    Building it costs about 0.2 s, so commands that never parse a unit (``--help``,
    ``plot``, ``check``) do not pay for it. ``camsim.units.ureg`` is the same object.
    """
    global _REGISTRY
    if _REGISTRY is None:
        import pint

        _REGISTRY = pint.UnitRegistry(autoconvert_offset_to_baseunit=True)
    return _REGISTRY


def __getattr__(name: str) -> Any:
    if name == "ureg":
        return registry()
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")

#: Dimension names used in messages, and the SI unit each is converted to.
DIMENSIONS: dict[str, str] = {
    "length": "m",
    "mass": "kg",
    "force": "N",
    "stiffness": "N/m",
    "damping": "N*s/m",
    "slowness": "s/m",
    "angle": "rad",
    "angular_speed": "rad/s",
    "frequency": "Hz",
    "time": "s",
    "velocity": "m/s",
    "acceleration": "m/s**2",
    "jerk": "m/s**3",  # issue 27: polynomial end conditions
    "length/time^4": "m/s**4",
    "length/time^5": "m/s**5",
    "length/time^6": "m/s**6",
    "pressure": "Pa",
    "density": "kg/m**3",
    "area": "m**2",
    "dimensionless": "",
}

#: How a dimension is spelled in messages (pint's own notation).
_DIMENSION_TEXT = {
    "length": "[length]",
    "mass": "[mass]",
    "force": "[force]",
    "stiffness": "[force]/[length]",
    "damping": "[force]*[time]/[length]",
    "slowness": "[time]/[length]",
    "angle": "[angle]",
    "angular_speed": "[angle]/[time]",
    "frequency": "1/[time]",
    "time": "[time]",
    "velocity": "[length]/[time]",
    "acceleration": "[length]/[time]^2",
    "jerk": "[length]/[time]^3",
    "length/time^4": "[length]/[time]^4",
    "length/time^5": "[length]/[time]^5",
    "length/time^6": "[length]/[time]^6",
    "pressure": "[force]/[length]^2",
    "density": "[mass]/[length]^3",
    "area": "[length]^2",
    "dimensionless": "a number",
}

_MIL = re.compile(r"(?<![A-Za-z_])mils?(?![A-Za-z_])")


class QuantityError(ValueError):
    """A value that is not a quantity of the expected dimension (message is one line)."""


def dimension_text(dimension: str) -> str:
    """Return how ``dimension`` is written in error messages, e.g. ``[force]/[length]``."""
    return _DIMENSION_TEXT.get(dimension, dimension)


def to_si(value: object, dimension: str, *, bare_unit: str | None = None) -> float:
    """Convert a machine-file value to an SI float.

    Parameters
    ----------
    value : str, int or float
        ``"25.6 lbf/in"``, ``"120 rpm"`` or a bare number.
    dimension : str
        A key of :data:`DIMENSIONS`, or ``"power_coefficient:<a>"`` for the coefficient
        of a power-law contact ``F = C·δ^a`` (converted to N/m^a).
    bare_unit : str, optional
        Unit of a bare number; default SI. Cam-table angles use ``"deg"``.

    Returns
    -------
    float
        The value in SI units (angles in rad, speeds in rad/s).

    Raises
    ------
    QuantityError
        When the value is not a finite quantity of that dimension.
    """
    if dimension.startswith("power_coefficient:"):
        exponent = float(dimension.split(":", 1)[1])
        target = f"N / m**{exponent!r}"
        shown = f"[force]/[length]^{exponent:g}"
    else:
        target = DIMENSIONS[dimension]
        shown = dimension_text(dimension)
    if isinstance(value, bool) or not isinstance(value, (int, float, str)):
        raise QuantityError(f"expected {shown}, got {value!r}")
    if isinstance(value, (int, float)):
        number = float(value)
        if not math.isfinite(number):
            raise QuantityError(f"expected a finite {shown}, got {value!r}")
        if bare_unit is None:
            return number
        return float(registry().Quantity(number, bare_unit).to(target).magnitude)
    import pint

    ureg = registry()
    text = value.strip()
    if _MIL.search(text):
        raise QuantityError(
            f'"mil" is ambiguous (pint reads it as an angle); write "thou" or "0.001 in", got "{value}"'
        )
    try:
        quantity = ureg.Quantity(text)
    except Exception:  # pint raises several unrelated types for unparsable text
        raise QuantityError(f'expected {shown}, got "{value}" (not a quantity)') from None
    if not isinstance(quantity, ureg.Quantity) or quantity.units == ureg.dimensionless:
        # A number without a unit, even inside a string: the bare unit, or SI.
        number = float(quantity.magnitude if isinstance(quantity, ureg.Quantity) else quantity)
        return to_si(number, dimension, bare_unit=bare_unit)
    try:
        number = float(quantity.to(target).magnitude)
    except pint.DimensionalityError:
        raise QuantityError(f'expected {shown}, got "{value}"') from None
    if not math.isfinite(number):
        raise QuantityError(f'expected a finite {shown}, got "{value}"')
    return number


#: One pound-force in newtons (exact: 0.45359237 kg × 9.80665 m/s²), for human tables.
LBF = 0.45359237 * 9.80665

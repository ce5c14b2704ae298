"""The one unit registry of camsim, and parsing of quantities at the input boundary.

Quantities are parsed once, when a machine file or an option is read, and converted to
SI floats; nothing below the loader sees a pint object.
"""

from __future__ import annotations

import math
import os
import re
import sys
from pathlib import Path
from typing import Any

_REGISTRY = None

#: Environment variable naming the folder of camsim's on-disk caches (default: the user's
#: cache folder, e.g. ~/.cache/camsim on Linux); an empty value turns the caches off.
CACHE_ENV = "CAMSIM_CACHE_DIR"


def cache_folder() -> Path | None:
    """Folder of pint's parsed-definitions cache, or None when it cannot be used.

    Per user (``platformdirs.user_cache_path("camsim")``, or ``$CAMSIM_CACHE_DIR``), in a
    ``pint`` subfolder. None -- build the registry from its definitions, as without a
    cache -- when the folder cannot be created or written (a read-only home, a shared
    account) or ``$CAMSIM_CACHE_DIR`` is empty.
    """
    env = os.environ.get(CACHE_ENV)
    if env is not None and not env.strip():
        return None
    try:
        if env:
            base = Path(env).expanduser()
        else:
            import platformdirs  # a dependency of pint

            base = platformdirs.user_cache_path("camsim", appauthor=False)
        folder = base / "pint"
        folder.mkdir(parents=True, exist_ok=True)
    except (OSError, ImportError):
        return None
    return folder if os.access(folder, os.W_OK | os.X_OK) else None


def _import_pint():
    """``import pint``, without letting it import dask.

    pint imports ``dask.base`` at import time when dask is installed (0.4 s on the 2-core
    test machine, half of pint's import), for Quantities that wrap dask arrays, which camsim
    never makes. Unless dask is already loaded, it is hidden while pint is imported (a
    ``None`` entry in ``sys.modules`` makes ``find_spec("dask")`` return None); dask itself
    stays importable afterwards (``camsim study --executor dask`` imports it then).
    """
    if "pint" in sys.modules or "dask" in sys.modules:
        import pint

        return pint
    sys.modules["dask"] = None  # type: ignore[assignment]
    try:
        import pint
    finally:
        if sys.modules.get("dask", 0) is None:
            del sys.modules["dask"]
    return pint


def build_registry(folder: Path | None) -> Any:
    """A camsim pint registry, its parsed definitions cached in ``folder`` (None: no cache).

    pint's own disk cache (``UnitRegistry(cache_folder=...)``) keeps the parsed definition
    files, keyed by a hash of their content, so a new pint version or definitions file
    never reads a stale entry. A cache that cannot be read (a file half-written by a
    concurrent run, a pickle of another Python) falls back to building without it: the
    registry is the same either way (tests/test_units_cache.py).
    """
    pint = _import_pint()
    if folder is not None:
        try:
            return pint.UnitRegistry(autoconvert_offset_to_baseunit=True, cache_folder=folder)
        except Exception:  # noqa: BLE001 - any cache trouble: build from the definitions
            pass
    return pint.UnitRegistry(autoconvert_offset_to_baseunit=True)


def registry() -> Any:
    """The one pint ``UnitRegistry`` of camsim, created on first use.

    Building it from pint's definition files costs about 0.5 s, so it is cached on disk
    (:func:`cache_folder`, :func:`build_registry`: about 0.1 s from the cache), and commands
    that never parse a unit (``--help``, ``plot``, ``check``) do not build it at all.
    ``camsim.units.ureg`` is the same object.
    """
    global _REGISTRY
    if _REGISTRY is None:
        _REGISTRY = build_registry(cache_folder())
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
    "quadratic_damping": "N*s^2/m^2",
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
    # issue 43: a load's segment program (a force over the cam angle) and its end conditions
    "force/time": "N/s",
    "force/time^2": "N/s**2",
    "force/time^3": "N/s**3",
    "force/time^4": "N/s**4",
    "force/time^5": "N/s**5",
    "force/time^6": "N/s**6",
    "pressure": "Pa",
    "density": "kg/m**3",
    "area": "m**2",
    "torque": "N*m",  # issue 38: the camshaft
    "torsional_stiffness": "N*m/rad",
    "torsional_damping": "N*m*s/rad",
    "inertia": "kg*m**2",
    "dimensionless": "",
}

#: How a dimension is spelled in messages (pint's own notation).
_DIMENSION_TEXT = {
    "length": "[length]",
    "mass": "[mass]",
    "force": "[force]",
    "stiffness": "[force]/[length]",
    "damping": "[force]*[time]/[length]",
    "quadratic_damping": "[force]*[time]^2/[length]^2",
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
    "force/time": "[force]/[time]",
    "force/time^2": "[force]/[time]^2",
    "force/time^3": "[force]/[time]^3",
    "force/time^4": "[force]/[time]^4",
    "force/time^5": "[force]/[time]^5",
    "force/time^6": "[force]/[time]^6",
    "pressure": "[force]/[length]^2",
    "density": "[mass]/[length]^3",
    "area": "[length]^2",
    "torque": "[force]*[length]",
    "torsional_stiffness": "[force]*[length]/[angle]",
    "torsional_damping": "[force]*[length]*[time]/[angle]",
    "inertia": "[mass]*[length]^2",
    "dimensionless": "a number",
}

_MIL = re.compile(r"(?<![A-Za-z_])mils?(?![A-Za-z_])")


class QuantityError(ValueError):
    """A value that is not a quantity of the expected dimension (message is one line)."""


def dimension_text(dimension: str) -> str:
    """Return how ``dimension`` is written in error messages, e.g. ``[force]/[length]``."""
    return _DIMENSION_TEXT.get(dimension, dimension)


#: The largest magnitude camsim computes with (issue 45): a value read (in SI) or a trace
#: written beyond it is refused. Products and powers of a few such values stay far from
#: float64's overflow (1.8e308): 1e300 for a speed or a gap overflowed inside numpy and printed
#: its warnings, or ran to a peak of 1.2e299 m. (Tiny values are kept: a vanishing damping of
#: 1e-57 is a machine the engine must integrate, tests/invariants.)
LARGEST = 1e30


def check_range(number: float, shown: str, value: object) -> float:
    """``number`` when its magnitude is within camsim's range (:data:`LARGEST`), else QuantityError."""
    if abs(number) > LARGEST:
        raise QuantityError(f"{value!r} ({number:.3g} in SI units) is beyond the range camsim computes with "
                            f"(a {shown} of magnitude at most {LARGEST:g} in SI units)")
    return number


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
            return check_range(number, shown, value)
        return check_range(float(registry().Quantity(number, bare_unit).to(target).magnitude), shown, value)
    text = value.strip()
    hit = _CONVERTED.get((text, target, bare_unit))
    if hit is not None:
        return hit
    number = _text_to_si(text, value, dimension, target, shown, bare_unit)
    if len(_CONVERTED) >= _CONVERTED_MAX:
        _CONVERTED.clear()
    _CONVERTED[(text, target, bare_unit)] = number
    return number


#: Quantity texts converted before, by (text, SI unit, bare unit): an analysis loads the
#: same machine file thousands of times with a few values changed, and pint's parse is most
#: of a load (issue 42: 4 ms of a 5 ms load of the CDTM).
_CONVERTED: dict[tuple[str, str, str | None], float] = {}
_CONVERTED_MAX = 4096


def _text_to_si(text: str, value: str, dimension: str, target: str, shown: str, bare_unit: str | None) -> float:
    """:func:`to_si` of a text (no cache)."""
    ureg = registry()
    import pint  # loaded by registry()

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
    return check_range(number, shown, value)


#: One pound-force in newtons (exact: 0.45359237 kg × 9.80665 m/s²), for human tables.
LBF = 0.45359237 * 9.80665

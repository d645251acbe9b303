"""Physical quantities at the scene boundary.

Scene files may write a quantity as a plain number (meaning SI) or as a string
with units (``"215 mm"``, ``"2460 rpm"``, ``"0.0285 kg m^2"``). Strings are
parsed once, here, with pint; everything past this module is plain SI floats.
pint is imported lazily because building its registry costs ~0.2 s and a scene
written in SI numbers does not need it.
"""

from __future__ import annotations

import math
from functools import lru_cache

#: SI unit of each dimension a scene can ask for, as pint understands it.
SI_UNITS: dict[str, str] = {
    "length": "m",
    "mass": "kg",
    "angle": "rad",
    "speed": "rad/s",
    "inertia": "kg m^2",
    "unbalance": "kg m",
    "force": "N",
    "moment": "N m",
    "dimensionless": "",
}


class QuantityError(ValueError):
    """A value that is not a finite quantity of the expected dimension."""


@lru_cache(maxsize=1)
def _registry():
    import pint

    return pint.UnitRegistry()


def to_si(value: object, dimension: str) -> float:
    """Convert a scene value to a float in SI units.

    Parameters
    ----------
    value : float, int or str
        A plain number (taken as SI) or a string such as ``"215 mm"``.
    dimension : str
        One of the keys of :data:`SI_UNITS`.

    Returns
    -------
    float
        The value in the SI unit of `dimension`.

    Raises
    ------
    QuantityError
        If the value is not a number or a parsable string, has the wrong
        dimension, or is not finite.
    """
    if isinstance(value, bool) or not isinstance(value, (int, float, str)):
        raise QuantityError(f"expected a number or a quantity string, got {type(value).__name__}")
    if isinstance(value, str):
        si = _parse_string(value, dimension)
    else:
        si = float(value)
    if not math.isfinite(si):
        raise QuantityError("must be finite")
    return si


@lru_cache(maxsize=4096)
def _parse_string(text: str, dimension: str) -> float:
    # Cached: scenes repeat the same strings ("0.5 kg") across cylinders and
    # pint's parser costs ~50 µs a call. Errors are not cached and re-raise.
    import pint

    ureg = _registry()
    try:
        quantity = ureg.Quantity(text)
    except Exception as exc:  # pint raises several unrelated types for bad text
        raise QuantityError(f"cannot read {text!r} as a quantity ({exc})") from None
    unit = SI_UNITS[dimension]
    if dimension == "speed" and not _names_an_angle(ureg, quantity):
        # pint treats the radian as dimensionless, so "50 Hz" would silently
        # become 50 rad/s; a rotational speed must say what turns.
        raise QuantityError(
            f"{text!r} is ambiguous for a rotational speed: write rpm, rad/s or turn/s"
        )
    try:
        if unit:
            return float(quantity.to(unit).magnitude)
        return float(quantity.to("dimensionless").magnitude)
    except pint.DimensionalityError:
        expected = f"[{dimension}] (e.g. {unit})" if unit else "dimensionless"
        given = f"has units {quantity.units:~}" if not quantity.unitless else "has no units"
        raise QuantityError(f"{given} but {expected} is expected") from None


def _names_an_angle(ureg, quantity) -> bool:
    for name, _ in quantity.unit_items():
        if name.startswith("revolutions_per_") or not ureg.get_dimensionality(name):
            return True
    return False

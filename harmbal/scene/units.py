"""Physical quantities at the scene boundary.

Scene files may write a quantity as a plain number (meaning SI) or as a string
with units (``"215 mm"``, ``"2460 rpm"``, ``"0.0285 kg m^2"``). Strings are
parsed once, here; everything past this module is plain SI floats.

pint defines what a unit string means. Building its registry costs 0.1-0.3 s,
more than reading a whole scene, so the unit expressions scenes write (a
number, then units from :data:`_NAMES` joined by spaces, ``*`` or ``/``, with
integer powers ``^n`` or ``**n``) are read by a small parser that repeats
pint's own arithmetic: the same definitions (:data:`_DERIVED`, taken from
pint's default registry), the same order of operations, so the same float to
the last bit (tests/test_units_fast.py checks it against pint). Everything
else goes to pint, imported on first need: other units or syntax, and every
string that is refused, so that the messages are pint's.
"""

from __future__ import annotations

import math
import re
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
    "pressure": "Pa",
    "time": "s",
    "density": "kg/m^3",
    "stiffness": "N/m",
    "damping": "N s/m",
    "acceleration": "m/s^2",
    "frequency": "Hz",
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
    # Cached: scenes repeat the same strings ("0.5 kg") across cylinders.
    # Errors are not cached and re-raise.
    si = _fast(text, dimension)
    return _parse_with_pint(text, dimension) if si is None else si


def _parse_with_pint(text: str, dimension: str) -> float:
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
    if dimension == "frequency" and _names_an_angle(ureg, quantity):
        # the same trap the other way: pint would read "800 rpm" as 2π·800/60 = 83.8 Hz, not 13.3 Hz.
        try:
            turns = f": {text} is {float(quantity.to('Hz').magnitude) / (2 * math.pi):.6g} Hz"
        except pint.DimensionalityError:
            turns = ""
        raise QuantityError(f"{text!r} names an angle or a revolution: write a frequency in Hz (cycles per "
                            f"second){turns}")
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


# --------------------------------------------------------------------------
# The fast path: pint's arithmetic for the units scenes write

#: Base units and their dimension ("" for the radian, which pint treats as
#: dimensionless).
_BASE: dict[str, str] = {"meter": "[length]", "gram": "[mass]", "second": "[time]", "radian": ""}

#: Every other unit the fast path knows: pint's canonical name -> (scale,
#: reference), exactly as pint's default registry defines them (values and
#: types: ``minute`` has the int scale 60, ``hertz`` the float 1.0).
_DERIVED: dict[str, tuple[float, tuple[tuple[str, int], ...]]] = {
    "millimeter": (0.001, (("meter", 1),)),
    "centimeter": (0.01, (("meter", 1),)),
    "kilometer": (1000.0, (("meter", 1),)),
    "micrometer": (1e-06, (("meter", 1),)),
    "inch": (0.027777777777777776, (("yard", 1),)),
    "foot": (0.3333333333333333, (("yard", 1),)),
    "yard": (0.9144, (("meter", 1),)),
    "kilogram": (1000.0, (("gram", 1),)),
    "pi": (3.141592653589793, ()),
    "degree": (0.005555555555555556, (("pi", 1), ("radian", 1))),
    "turn": (2, (("pi", 1), ("radian", 1))),
    "millisecond": (0.001, (("second", 1),)),
    "minute": (60, (("second", 1),)),
    "hour": (60, (("minute", 1),)),
    "hertz": (1.0, (("second", -1),)),
    "revolutions_per_minute": (1.0, (("turn", 1), ("minute", -1))),
    "revolutions_per_second": (1.0, (("turn", 1), ("second", -1))),
    "newton": (1.0, (("kilogram", 1), ("meter", 1), ("second", -2))),
    "kilonewton": (1000.0, (("newton", 1),)),
    "pascal": (1.0, (("newton", 1), ("meter", -2))),
    "kilopascal": (1000.0, (("pascal", 1),)),
    "megapascal": (1000000.0, (("pascal", 1),)),
    "bar": (100000.0, (("pascal", 1),)),
    "millibar": (0.001, (("bar", 1),)),
}

#: The unit names a scene may write on the fast path -> pint's canonical name.
_NAMES: dict[str, str] = {
    "m": "meter", "meter": "meter", "meters": "meter", "metre": "meter", "metres": "meter",
    "mm": "millimeter", "millimeter": "millimeter", "millimeters": "millimeter", "millimetre": "millimeter",
    "millimetres": "millimeter",
    "cm": "centimeter", "centimeter": "centimeter", "centimeters": "centimeter", "centimetre": "centimeter",
    "centimetres": "centimeter",
    "km": "kilometer", "um": "micrometer",
    "in": "inch", "inch": "inch", "inches": "inch", "ft": "foot", "foot": "foot", "feet": "foot",
    "kg": "kilogram", "kilogram": "kilogram", "kilograms": "kilogram", "g": "gram", "gram": "gram", "grams": "gram",
    "rad": "radian", "radian": "radian", "radians": "radian",
    "deg": "degree", "degree": "degree", "degrees": "degree",
    "turn": "turn", "turns": "turn", "revolution": "turn", "revolutions": "turn",
    "s": "second", "sec": "second", "second": "second", "seconds": "second", "ms": "millisecond",
    "min": "minute", "minute": "minute", "minutes": "minute", "h": "hour", "hr": "hour", "hour": "hour",
    "hours": "hour",
    "Hz": "hertz", "hertz": "hertz", "rpm": "revolutions_per_minute", "rps": "revolutions_per_second",
    "N": "newton", "newton": "newton", "newtons": "newton", "kN": "kilonewton",
    "Pa": "pascal", "pascal": "pascal", "kPa": "kilopascal", "MPa": "megapascal", "bar": "bar", "mbar": "millibar",
}

#: The SI units of :data:`SI_UNITS` as pint parses them (names in pint's order).
_SI: dict[str, tuple[tuple[str, int], ...]] = {
    "length": (("meter", 1),),
    "mass": (("kilogram", 1),),
    "angle": (("radian", 1),),
    "speed": (("radian", 1), ("second", -1)),
    "inertia": (("kilogram", 1), ("meter", 2)),
    "unbalance": (("kilogram", 1), ("meter", 1)),
    "force": (("newton", 1),),
    "moment": (("newton", 1), ("meter", 1)),
    "pressure": (("pascal", 1),),
    "time": (("second", 1),),
    "density": (("kilogram", 1), ("meter", -3)),
    "stiffness": (("newton", 1), ("meter", -1)),
    "damping": (("newton", 1), ("second", 1), ("meter", -1)),
    "acceleration": (("meter", 1), ("second", -2)),
    "frequency": (("hertz", 1),),
    "dimensionless": (),
}

# A number as Python's tokenizer (and so pint) reads it, after an optional
# sign: an integer without leading zeros, or a decimal / exponent float; no
# underscores.
_NUMBER = re.compile(r"([+-]?)((0|[1-9][0-9]*)(?![0-9.eE])|[0-9]+\.[0-9]*(?:[eE][+-]?[0-9]+)?"
                     r"|\.[0-9]+(?:[eE][+-]?[0-9]+)?|[0-9]+[eE][+-]?[0-9]+)")
# One unit with an optional integer power, then what joins it to the next.
_FACTOR = re.compile(r"([A-Za-z]+)(?: *(?:\^|\*\*) *([+-]?(?:0|[1-9][0-9]*)))?(?= |\*|/|$)")
_JOIN = re.compile(r" *(\*|/) *| +(?=[A-Za-z])")
# A reciprocal unit after the number: "50 1/s".
_ONE_OVER = re.compile(r" +1 */ *(?=[A-Za-z])")


def _fast(text: str, dimension: str) -> float | None:
    """``text`` in the SI unit of ``dimension`` as pint computes it, or None
    where pint must decide (unknown syntax or units, or a refusal)."""
    number = _NUMBER.match(text)
    if number is None or dimension not in _SI:
        return None
    sign, digits, integer = number.groups()
    value: float = int(digits) if integer else float(digits)
    if sign == "-":
        value = value * -1  # pint's unary minus
    position = number.end()
    one_over = _ONE_OVER.match(text, position)
    if position == len(text):
        units: dict[str, int] = {}
    elif one_over is not None:  # "50 1/s": pint's 50 × 1, then divided by the units
        value, evaluated = _evaluate(text, one_over.end(), value * 1, reciprocal=True)
        if evaluated is None:
            return None
        units = evaluated
    else:
        # "5 mm", "5mm" (pint inserts the "*"), "5*mm"; not "1e3mm"
        gap = _JOIN.match(text, position)
        if gap is not None:
            if gap.group(1) == "/":
                return None
            position = gap.end()
        elif "e" in digits.lower() or text[position] in "eE":
            return None  # pint's preprocessing reads these its own way
        value, evaluated = _evaluate(text, position, value)
        if evaluated is None:
            return None
        units = evaluated
    if dimension == "speed" and not any(name.startswith("revolutions_per_") or not _dimension(name) for name in units):
        return None  # ambiguous ("50 Hz"): pint words the refusal
    if dimension == "frequency" and any(name.startswith("revolutions_per_") or not _dimension(name) for name in units):
        return None  # "800 rpm" as a frequency: refused in pint's path
    target = dict(_SI[dimension])
    if units == target:
        return float(value)
    ratio = _divide(units, target)
    if _dimension_of(ratio):
        return None  # the wrong dimension: pint words the refusal
    return float(value * _factor(ratio))


def _evaluate(text: str, position: int, value: float,
              reciprocal: bool = False) -> tuple[float, dict[str, int] | None]:
    """The magnitude and units of ``value`` times the unit expression from
    ``position`` (divided by it if ``reciprocal``), evaluated left to right
    as pint's expression tree does: ``5 kg m/s^2`` is ((5·kg)·m)/(s²), each
    unit a quantity of magnitude 1."""
    units: dict[str, int] = {}
    operator = "/" if reciprocal else "*"
    first = not reciprocal
    while True:
        factor = _FACTOR.match(text, position)
        if factor is None or factor.group(1) not in _NAMES:
            return value, None
        name = _NAMES[factor.group(1)]
        power = int(factor.group(2)) if factor.group(2) is not None else 1
        if power == 1:
            magnitude, own = 1, {name: 1}
        elif power == 0:
            magnitude, own = 1 ** 0, {}
        else:
            magnitude, own = 1 ** power, {name: 1 * power}
        if first:  # number × quantity
            value = magnitude * value
            units = dict(own)
        elif operator == "*":
            value = value * magnitude
            units = _multiply(units, own)
        else:  # pint divides an int as a float
            value = ((float(value) if isinstance(value, int) else value)
                     / (float(magnitude) if isinstance(magnitude, int) else magnitude))
            units = _divide(units, own)
        first = False
        position = factor.end()
        if position == len(text):
            return value, units
        join = _JOIN.match(text, position)
        if join is None:
            return value, None
        operator = join.group(1) or "*"
        position = join.end()


def _multiply(left: dict[str, int], right: dict[str, int]) -> dict[str, int]:
    """pint's UnitsContainer product: left's order, then right's new names."""
    new = dict(left)
    for key, exponent in right.items():
        new[key] = new.get(key, 0) + exponent
        if new[key] == 0:
            del new[key]
    return new


def _divide(left: dict[str, int], right: dict[str, int]) -> dict[str, int]:
    """pint's UnitsContainer quotient, in pint's order."""
    new = dict(left)
    for key, exponent in right.items():
        new[key] = new.get(key, 0) - exponent
        if new[key] == 0:
            del new[key]
    return new


def _dimension(name: str) -> dict[str, int]:
    """The dimensionality of one unit."""
    return _dimension_of({name: 1})


def _dimension_of(units: dict[str, int]) -> dict[str, int]:
    dims: dict[str, int] = {}

    def walk(reference, exponent):
        for key, power in reference:
            if key in _BASE:
                if _BASE[key]:
                    dims[_BASE[key]] = dims.get(_BASE[key], 0) + exponent * power
            else:
                walk(_DERIVED[key][1], exponent * power)

    walk(units.items(), 1)
    return {k: v for k, v in dims.items() if v}


def _factor(units: dict[str, int]) -> float:
    """The conversion factor of dimensionless ``units`` (source / target), as
    pint's ``_get_root_units`` computes it: scales collected by value into a
    numerator and a denominator, equal ones cancelled, then multiplied in
    order of first appearance."""
    numerator: dict[float, int] = {}
    denominator: dict[float, int] = {}

    def walk(reference, exponent):
        for key, power in reference:
            exp2 = exponent * power
            if key in _BASE:
                continue
            scale, below = _DERIVED[key]
            if exp2 < 0:
                denominator[scale] = denominator.get(scale, 0) - exp2
            else:
                numerator[scale] = numerator.get(scale, 0) + exp2
            walk(below, exp2)

    walk(units.items(), 1)
    fraction = {"numerator": numerator, "denominator": denominator}

    def terms_are_unique(fraction):
        return not any(n_factor in fraction["denominator"] for n_factor in fraction["numerator"])

    while not terms_are_unique(fraction):  # pint's cancellation, step for step
        for n_factor, n_exponent in fraction["numerator"].items():
            if n_factor in fraction["denominator"]:
                if n_exponent >= fraction["denominator"][n_factor]:
                    fraction["numerator"][n_factor] -= fraction["denominator"][n_factor]
                    del fraction["denominator"][n_factor]
                    continue
        for d_factor, d_exponent in fraction["denominator"].items():
            if d_factor in fraction["numerator"]:
                if d_exponent >= fraction["numerator"][d_factor]:
                    fraction["denominator"][d_factor] -= fraction["numerator"][d_factor]
                    del fraction["numerator"][d_factor]
                    continue

    factor: float = 1
    for n_factor, n_exponent in fraction["numerator"].items():
        if n_exponent != 0:
            factor *= n_factor**n_exponent
    for d_factor, d_exponent in fraction["denominator"].items():
        if d_exponent != 0:
            factor *= d_factor**-d_exponent
    return factor

"""The values a sweep is given and the units they are typed and shown in.

A key's values are plain numbers (SI) or quantity strings (``"128 mm"``).
Where the key is known they are converted in its dimension, the one the
scene reader reads it in (:func:`harmbal.studies.keys.key_dimension`); a
value without a key (a command-line range, a tolerance's sigma) is read as
a quantity of whichever dimension its units have (:func:`any_quantity`).
"""

from __future__ import annotations

import math
import re
from collections.abc import Set as AbstractSet
from numbers import Real
from typing import Any

import numpy as np

from ..scene.units import SI_UNITS, QuantityError, to_si
from .keys import key_error

#: A quantity string: a number as the scene reader reads it, then its units.
_QUANTITY = re.compile(r"\s*[+-]?(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?\s*(.*?)\s*")


def any_quantity(value: Any) -> tuple[float, str | None]:
    """A plain number (SI) or a unit string as an SI float and its dimension
    (a key of :data:`~harmbal.scene.units.SI_UNITS`, the first whose units
    parse; None for a plain number).

    Raises
    ------
    QuantityError
        If ``value`` is neither.
    """
    if isinstance(value, Real) and not isinstance(value, bool):
        return float(value), None
    if isinstance(value, str):
        for dimension in SI_UNITS:
            if dimension == "dimensionless":
                continue
            try:
                return to_si(value, dimension), dimension
            except QuantityError:
                continue
    raise QuantityError(f"not a number or a quantity with units: {value!r}")


def typed_units(value: Any) -> str | None:
    """The units a quantity string is written in (``"mm"`` of ``"128 mm"``),
    or None for a plain number (SI)."""
    match = _QUANTITY.fullmatch(value) if isinstance(value, str) else None
    return (match[1] or None) if match else None


def quantity_value(value: Any) -> tuple[float, str | None]:
    """A number (SI) or a quantity string (``"128 mm"``) as an SI float and
    its SI units (None for a plain number).

    Raises
    ------
    QuantityError
        If ``value`` is neither, or not finite.
    """
    if isinstance(value, str):
        try:
            value = float(value)
        except ValueError:
            pass
    si, dimension = any_quantity(value)
    if not math.isfinite(si):
        raise QuantityError(f"not finite: {value!r}")
    return si, None if dimension is None else SI_UNITS[dimension]


def display_factor(units: str | None) -> float:
    """SI value of one of ``units`` (1 for None or ``"1"``): a value in SI
    divided by it is in ``units``."""
    return 1.0 if units in (None, "", "1") else quantity_value(f"1 {units}")[0]


def key_units(dimension: str | None,
              typed: AbstractSet[str | None] = frozenset({None})) -> tuple[str | None, str | None]:
    """The SI units of a key's values (CF ``units``; ``"1"`` for a
    dimensionless key) and the units to show them in: the units the values
    were typed in if they were all typed in one, else the SI units (plain
    numbers are SI, as documented for each key in docs/scenes.md).

    Parameters
    ----------
    dimension : str or None
        The key's dimension, as the scene reader reads it
        (:func:`harmbal.studies.keys.key_dimension`); None if it does not
        read the key as a quantity.
    typed : set of str or None
        The units each value was typed in (:func:`typed_units`; None for a
        plain number).

    Returns
    -------
    tuple of (str or None, str or None)
        None, None if the dimension is None.
    """
    if dimension is None:
        return None, None
    si_units = SI_UNITS[dimension] or "1"
    return si_units, next(iter(typed)) if len(typed) == 1 and None not in typed else si_units


def given_values(values) -> np.ndarray | list:
    """A key's values: a numeric array if they are all plain numbers (taken as
    SI without a loop over them), else a list of numbers and unit strings."""
    if isinstance(values, np.ndarray) and values.dtype.kind in "iuf":  # as given: no Python object per value
        return values if values.ndim == 1 else np.atleast_1d(values).ravel()
    array = np.atleast_1d(np.asarray(values, dtype=object))
    if array.size and all(isinstance(v, Real) and not isinstance(v, (bool, np.bool_)) for v in array):
        return np.array(array.tolist())
    return list(array)


def si_values(source: str, key: str, values, dimension: str | None) -> tuple[np.ndarray, set[str | None]]:
    """A key's values in SI and the units they were typed in (None for a
    plain number, :func:`typed_units`).

    A numeric array (Monte Carlo draws) is taken as SI without a loop over
    its items; other values are converted in the key's ``dimension`` (if the
    reader does not read the key as a quantity, in their own: the reader
    refuses the key when the variants are read).

    Raises
    ------
    SceneError
        A value that is not a finite quantity of the key's dimension.
    """
    if isinstance(values, np.ndarray) and values.dtype.kind in "iuf":
        si = values.astype(float)
        bad = np.flatnonzero(~np.isfinite(si))
        if bad.size:
            raise key_error(source, key, values[bad[0]], "must be finite")
        return si, {None}
    converted = []
    for v in values:
        try:
            value = any_quantity(v)[0] if dimension is None else _in_dimension(v, dimension)
        except QuantityError as exc:
            raise key_error(source, key, v, str(exc)) from None
        if not math.isfinite(value):
            raise key_error(source, key, v, "must be finite")
        converted.append(value)
    return np.array(converted), {typed_units(v) for v in values}


def _in_dimension(value: Any, dimension: str) -> float:
    """``value`` in SI: a plain number as given (a bool is not one), a string in ``dimension``."""
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (Real, str)):
        raise QuantityError(f"not a number or a quantity with units: {value!r}")
    return float(value) if isinstance(value, Real) else to_si(value, dimension)

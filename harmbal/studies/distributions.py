"""Distributions of production tolerances for :func:`harmbal.monte_carlo`, and drawing them.

:class:`Normal` and :class:`Uniform` are deviations from the nominal value
the scene file writes; :class:`WeightClasses` are the values themselves.
Their quantities are SI numbers or unit strings, which must have the
dimension the scene reader reads the key in.
"""

from __future__ import annotations

import math
import tomllib
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from ..scene import Scene, SceneError
from ..scene.schema import MISSING, Problem
from ..scene.units import SI_UNITS, QuantityError
from .keys import get_key, key_dimension, key_error, parse_path
from .quantities import any_quantity, typed_units


@dataclass(frozen=True)
class Normal:
    """Normally distributed deviation from the scene's nominal value, standard
    deviation ``sigma`` in SI units (or a unit string such as ``"2 g"``)."""

    sigma: float | str

    def quantities(self) -> tuple:
        return (self.sigma,)

    def draw(self, rng: np.random.Generator, nominal: float, n: int, key: str) -> np.ndarray:
        sigma = _si_strict(key, self.sigma)
        if sigma < 0:
            raise key_error("<monte carlo>", key, self.sigma, "sigma must not be negative")
        return nominal + rng.normal(0.0, sigma, n)


@dataclass(frozen=True)
class Uniform:
    """Uniformly distributed deviation from the scene's nominal value in
    [``low``, ``high``) (SI units or unit strings), e.g. ``Uniform(-1e-3, 1e-3)``."""

    low: float | str
    high: float | str

    def quantities(self) -> tuple:
        return (self.low, self.high)

    def draw(self, rng: np.random.Generator, nominal: float, n: int, key: str) -> np.ndarray:
        low, high = _si_strict(key, self.low), _si_strict(key, self.high)
        if not low <= high:
            raise key_error("<monte carlo>", key, [self.low, self.high], "low must not exceed high")
        return nominal + rng.uniform(low, high, n)


@dataclass(frozen=True)
class WeightClasses:
    """Discrete values (not deviations: the classes themselves, SI units or
    unit strings) drawn with the given probabilities, e.g. piston weight
    classes ``WeightClasses(["398 g", "400 g", "402 g"], [0.25, 0.5, 0.25])``."""

    values: Sequence[float | str]
    probabilities: Sequence[float]

    def quantities(self) -> tuple:
        return tuple(self.values)

    def draw(self, rng: np.random.Generator, nominal: float, n: int, key: str) -> np.ndarray:
        values = np.array([_si_strict(key, v) for v in self.values])
        p = np.asarray(self.probabilities, dtype=float)
        if p.shape != values.shape or np.any(p < 0) or not math.isclose(p.sum(), 1.0, rel_tol=1e-9):
            raise SceneError([Problem("<monte carlo>", key, list(self.probabilities),
                                      f"{len(values)} probabilities ≥ 0 summing to 1 are needed")])
        return rng.choice(values, n, p=p / p.sum())


DISTRIBUTIONS = (Normal, Uniform, WeightClasses)


def _si_strict(key: str, value: Any) -> float:
    """A distribution's quantity in SI (its dimension was checked against the key's, :func:`draw_tolerances`)."""
    try:
        si = any_quantity(value)[0]
    except QuantityError as exc:
        raise key_error("<monte carlo>", key, value, str(exc)) from None
    if not math.isfinite(si):
        raise key_error("<monte carlo>", key, value, "must be finite")
    return si


def draw_tolerances(scene: Scene, tolerances: Mapping[str, Normal | Uniform | WeightClasses], n: int,
                    rng: np.random.Generator) -> tuple[dict[str, np.ndarray], dict[str, set[str | None]]]:
    """``n`` draws of every toleranced key, in the order given, and the units
    each key's quantities were typed in.

    Raises
    ------
    TypeError
        A tolerance that is not one of the distributions.
    SceneError
        A key that is not a key path, a deviation from a nominal value the
        scene does not write, or a quantity that is not one of the key's
        dimension (naming the scene's file).
    """
    raw = tomllib.loads(scene.source_text) if scene.source_text else {}
    values, typed = {}, {}
    for key, dist in tolerances.items():
        if not isinstance(dist, DISTRIBUTIONS):
            raise TypeError(f"{key}: a Normal, Uniform or WeightClasses, not {type(dist).__name__}")
        parse_path(scene.source, key)
        nominal = get_key(raw, key)
        if nominal is None and key.startswith("cylinder["):
            # A cylinder without its own value takes the shared table's, as the reader merges them.
            nominal = get_key(raw, key.partition(".")[2])
        if nominal is None and not isinstance(dist, WeightClasses):
            raise key_error(scene.source, key, MISSING, "not written in the scene: a tolerance is a deviation from "
                            "the nominal value, write the nominal in the scene file")
        try:
            centre, dimension = (0.0, None) if nominal is None else any_quantity(nominal)
        except QuantityError as exc:
            raise key_error(scene.source, key, nominal, str(exc)) from None
        probe = dist.quantities()[0] if nominal is None else nominal
        dimension = key_dimension(raw, key, probe, dict(scene.files)) or dimension
        _check_dimension(scene.source, key, dist, dimension)
        typed[key] = {typed_units(v) for v in dist.quantities()}
        try:
            values[key] = dist.draw(rng, centre, int(n), key)
        except SceneError as exc:
            raise SceneError([replace(p, source=scene.source) for p in exc.problems]) from None
    return values, typed


def _check_dimension(source: str, key: str, dist, dimension: str | None) -> None:
    """Refuse a quantity with units of another dimension than the key's: it would be added as if it were SI."""
    if dimension is None:
        return
    for value in (v for v in dist.quantities() if isinstance(v, str)):
        try:
            given = any_quantity(value)[1] or "dimensionless"  # (a string always has a dimension)
        except QuantityError as exc:
            raise key_error(source, key, value, str(exc)) from None
        if given != dimension:
            raise key_error(source, key, value, f"is in {SI_UNITS[given]}, the key in "
                            f"{SI_UNITS[dimension] or '1 (dimensionless)'}")

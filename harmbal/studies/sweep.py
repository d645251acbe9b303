"""Design-space sweeps and production-tolerance Monte Carlo, vectorised over a
``variant`` axis.

A sweep sets numeric keys of the scene file (key paths as the user writes
them, ``geometry.rod_length``, ``cylinder[2].piston.mass``) to many values.
Each key is first tried through the scene reader (validation and units as
for a scene file) and sorted into one of two kinds:

* a *linear* key changes only masses, rod inertias or unbalance sizes (the
  slots of :mod:`harmbal.orders.linear`), in proportion to its value: its
  values enter every variant by one matrix product, without reading or
  evaluating anything again;
* any other key is a *geometry* key: each distinct combination of the
  geometry keys' values is read (and validated) as a scene and evaluated
  once (:func:`harmbal.orders.linear.linear_phasors`).

The phasors of all the variants of one geometry are then one matrix product
(:func:`harmbal.orders.linear.combine`), which works on any block of
variants, so the variant axis can be chunked.
"""

from __future__ import annotations

import copy
import math
import os
import re
import tomllib
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, replace
from numbers import Real
from typing import TYPE_CHECKING, Any

import numpy as np

from ..labelled import CONVENTIONS, Speeds, dataset, variable
from ..model.budget import check_budget
from ..model.evaluate import evaluate
from ..orders.linear import LinearPhasors, combine, geometry_key, linear_phasors, peaks, slot_values, time_basis
from ..orders.spectrum import ROTATION, ZERO_RTOL, negligible_level
from ..scene import Scene, SceneError, load_scene
from ..scene.schema import _MISSING, Problem
from ..scene.units import SI_UNITS, QuantityError, to_si

if TYPE_CHECKING:
    from ..balance.variants import DesignBasis

MODES = ("grid", "zip")

#: The dimension (a key of :data:`~harmbal.scene.units.SI_UNITS`) of every numeric scene key, by the key's
#: last name, as the scene reader reads it (docs/scenes.md; a test checks it against the reader's source).
#: A plain number given for a key is in the SI unit of its dimension.
KEY_DIMENSIONS = {
    **dict.fromkeys(("crank_radius", "rod_length", "pin_offset", "cylinder_offset", "axial_position", "axial_offset",
                     "cg_from_big_end", "cg_offset", "radius", "pin_radius", "coupler_length", "rocker_length",
                     "height", "heights", "lateral", "planes", "thickness", "width", "reference_point", "centre",
                     "cg", "pivot", "bearings", "axial_range", "main_bearings", "vertices", "bore"), "length"),
    **dict.fromkeys(("mass", "mass_big_end", "mass_small_end"), "mass"),
    **dict.fromkeys(("throw", "bank", "angle", "phase", "couple_angle", "direction", "half_angle", "pin_angle",
                     "start_angle", "end_angle", "start", "duration"), "angle"),
    **dict.fromkeys(("inertia", "couple", "xy", "xz"), "inertia"),
    **dict.fromkeys(("unbalance", "max_unbalance"), "unbalance"),
    **dict.fromkeys(("balance_factor", "negligible", "accuracy", "target_coefficient", "tolerance",
                     "compression_ratio", "compression_exponent", "expansion_exponent", "shape", "efficiency"),
                    "dimensionless"),
    **dict.fromkeys(("speed", "from", "to", "max_speed"), "speed"),
    **dict.fromkeys(("intake_pressure", "exhaust_pressure", "crankcase_pressure", "peak_pressure", "imep"),
                    "pressure"),
    "force": "force", "load_torque": "moment", "time": "time", "density": "density",
}

#: Variants whose peaks are rebuilt at a time (bounds the memory of the time-domain blocks).
_PEAK_BLOCK = 4096
#: Variants evaluated at a time when only the amplitudes are kept (phasors of 13 orders: 80 MB a block).
_BLOCK = 65536


# -- distributions of Monte Carlo -----------------------------------------------------------------


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
            raise _fail("<monte carlo>", key, self.sigma, "sigma must not be negative")
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
            raise _fail("<monte carlo>", key, [self.low, self.high], "low must not exceed high")
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


# -- key paths ------------------------------------------------------------------------------------


def _fail(source: str, key: str, value: Any, rule: str):
    value = value.item() if isinstance(value, np.generic) else value  # as written, not np.float64(…)
    return SceneError([Problem(source, key, value, rule)])


def _parse_path(source: str, key: str) -> list[tuple[str, int | None]]:
    import re

    parts = []
    for part in key.split("."):
        match = re.fullmatch(r"([A-Za-z_][A-Za-z0-9_]*)(?:\[([1-9][0-9]*)\])?", part)
        if match is None:
            raise _fail(source, key, key, "not a key path: write e.g. geometry.rod_length or "
                        "cylinder[2].piston.mass (tables by name, arrays by 1-based index)")
        parts.append((match[1], None if match[2] is None else int(match[2])))
    return parts


def _set(raw: dict, source: str, key: str, value: Any) -> None:
    """Set ``key`` in the raw scene mapping, creating missing tables on the way."""
    node: Any = raw
    parts = _parse_path(source, key)
    for depth, (name, index) in enumerate(parts):
        last = depth == len(parts) - 1
        where = ".".join(f"{n}" + ("" if i is None else f"[{i}]") for n, i in parts[: depth + 1])
        if not isinstance(node, dict):
            raise _fail(source, key, value, f"{where.rpartition('.')[0]} is not a table")
        if index is None:
            if last:
                node[name] = value
                return
            if isinstance(node.get(name), list):
                raise _fail(source, key, value, f"{where} is an array: name an entry, e.g. {where}[1]")
            node = node.setdefault(name, {})
            continue
        entries = node.get(name)
        if not isinstance(entries, list) or index > len(entries):
            count = len(entries) if isinstance(entries, list) else 0
            raise _fail(source, key, value, f"the scene has no {where} ({count} entr{'y' if count == 1 else 'ies'} "
                        f"of {name})")
        if last:
            entries[index - 1] = value
            return
        node = entries[index - 1]


def _get(raw: dict, key: str) -> Any:
    """The raw value of ``key`` in the scene mapping, or None if it is not written there."""
    node: Any = raw
    for name, index in _parse_path("", key):
        if not isinstance(node, dict) or name not in node:
            return None
        node = node[name]
        if index is not None:
            if not isinstance(node, list) or index > len(node):
                return None
            node = node[index - 1]
    return node


def _si(value: Any) -> tuple[float, str | None]:
    """A plain number (SI) or a unit string as an SI float and its dimension
    (a key of :data:`~harmbal.scene.units.SI_UNITS`; None for a plain number)."""
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


#: A quantity string: a number as the scene reader reads it, then its units.
_QUANTITY = re.compile(r"\s*[+-]?(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?\s*(.*?)\s*")


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
    si, dimension = _si(value)
    if not math.isfinite(si):
        raise QuantityError(f"not finite: {value!r}")
    return si, None if dimension is None else SI_UNITS[dimension]


def key_units(key: str, typed: set[str | None] = frozenset({None})) -> tuple[str | None, str | None]:
    """The SI units of ``key``'s values (CF ``units``; ``"1"`` for a
    dimensionless key) and the units to show them in: the units the values
    were typed in if they were all typed in one, else the SI units (plain
    numbers are SI, as documented for each key in docs/scenes.md).

    Parameters
    ----------
    key : str
        A key path (``geometry.rod_length``); its dimension is
        :data:`KEY_DIMENSIONS` of its last name, or, for a key not there,
        that of the units typed.
    typed : set of str or None
        The units each value was typed in (:func:`typed_units`; None for a
        plain number).

    Returns
    -------
    tuple of (str or None, str or None)
        None, None if the key's dimension is unknown.
    """
    dimension = KEY_DIMENSIONS.get(_parse_path("", key)[-1][0])
    if dimension is None:
        found = {_si(f"1 {units}")[1] for units in typed if units is not None}
        dimension = found.pop() if len(found) == 1 else None
    if dimension is None:
        return None, None
    si_units = SI_UNITS[dimension] or "1"
    return si_units, next(iter(typed)) if len(typed) == 1 and None not in typed else si_units


def display_factor(units: str | None) -> float:
    """SI value of one of ``units`` (1 for None or ``"1"``): a value in SI
    divided by it is in ``units``."""
    return 1.0 if units in (None, "", "1") else quantity_value(f"1 {units}")[0]


def _si_strict(key: str, value: Any) -> float:
    try:
        si = _si(value)[0]
    except QuantityError as exc:
        raise _fail("<monte carlo>", key, value, str(exc)) from None
    if not math.isfinite(si):
        raise _fail("<monte carlo>", key, value, "must be finite")
    return si


def _toml_value(value: Any) -> Any:
    """A value the reader takes: Python floats and ints, strings as given."""
    if isinstance(value, str):
        return value
    if isinstance(value, (bool, np.bool_)):
        raise QuantityError(f"not a number: {value!r}")
    if isinstance(value, (int, np.integer)):
        return int(value)
    return float(value)


# -- the plan: which key is which, the geometries, the slot values of every variant ---------------


class _Reader:
    """Reads variants of one scene through the scene reader, naming the scene's file in errors.

    The variants keep the given scene's speeds (a scene from ``with_speeds`` sweeps at its own speeds,
    one from ``with_negligible`` is judged by its own level); any other difference between the scene and
    its source text is refused, since the variants are read from that text."""

    def __init__(self, scene: Scene):
        if not scene.source_text:
            raise _fail(scene.source, "(scene)", None, "the scene has no source text to vary: load it with "
                        "harmbal.load_scene")
        self.scene = scene
        self.raw = tomllib.loads(scene.source_text)
        self.cache: dict[tuple, Scene] = {}
        self.file = self._load(self.raw)
        # Neither the speeds nor the negligible level change the loads per unit speed (with_speeds, with_negligible).
        model = replace(self.file.model, negligible=scene.model.negligible)
        if geometry_key(replace(self.file, speeds=scene.speeds, model=model)) != geometry_key(scene) or \
                not np.array_equal(slot_values(self.file)[1], slot_values(scene)[1]):
            raise _fail(scene.source, "(scene)", None, "the scene differs from its source text (changed after it "
                        "was read): write the change into the scene file to sweep it")
        self.cache[()] = scene

    def _load(self, raw: dict) -> Scene:
        try:
            return load_scene(raw)
        except SceneError as exc:
            raise SceneError([replace(p, source=self.scene.source) for p in exc.problems]) from None

    def read(self, values: dict[str, Any]) -> Scene:
        key = tuple(sorted((k, repr(v)) for k, v in values.items()))
        if key not in self.cache:
            raw = copy.deepcopy(self.raw)
            for k, v in values.items():
                _set(raw, self.scene.source, k, v)
            scene = self._load(raw)
            if (scene.speeds, scene.sampling.max_order) != (self.file.speeds, self.file.sampling.max_order):
                raise _fail(self.scene.source, ", ".join(values), list(values.values()),
                            "a sweep cannot change the speeds or max_order (every variant is reported at the "
                            "scene's speeds and orders)")
            self.cache[key] = replace(scene, speeds=self.scene.speeds, source=self.scene.source)
        return self.cache[key]


def _linear_coefficients(reader: _Reader, key: str, values: list, si: np.ndarray, base_key: Scene,
                         base_slots: np.ndarray, design: bool) -> dict[int, float] | None:
    """{slot: slot value per SI unit of the key} if ``key`` moves only slots, in
    proportion to its value, else None (a geometry key). The key is read at its
    smallest, median and largest value, which validates those values; the
    slots' rules (positive) then hold for every value between."""
    order = np.argsort(si, kind="stable")
    probes = sorted({int(order[0]), int(order[len(order) // 2]), int(order[-1])})
    scenes = [reader.read({key: _toml_value(values[p])}) for p in probes]
    slots = np.array([slot_values(s)[1] for s in scenes])
    if any(geometry_key(s) != base_key for s in scenes):
        if (slots == base_slots).all() and all(_outputs_key(s, design) == _outputs_key(base_key, design)
                                               for s in scenes):
            hint = "; design=True (--design) designs the balancers per variant" if key.startswith("design.") else ""
            raise _fail(reader.scene.source, key, values[probes[-1]], "changes nothing a sweep reports (the free "
                        f"forces and moments{', the design' if design else ''}){hint}")
        return None
    moved = np.flatnonzero((slots != base_slots).any(axis=0))
    x = si[probes]
    if moved.size and np.any(x == 0):
        return None
    coefficients = {}
    for s in moved:
        a = slots[:, s] / x
        if not np.allclose(a, a[0], rtol=1e-14, atol=0):
            return None
        coefficients[int(s)] = float(a[0])
    return coefficients


def _outputs_key(scene: Scene, design: bool) -> Scene:
    """The scene without what the sweep's results do not depend on: requests ([design] unless the sweep
    designs, [verify], [loads]), outlines, the flywheel (the speed fluctuation is refused), names and the
    firing order."""
    return replace(geometry_key(scene), design=scene.design if design else None, verify=None, loads=None,
                   outlines=(), flywheel=None, name="", description="", firing_order=None)


def _unsupported(scene: Scene) -> str | None:
    effects = scene.model.effects
    if "gas" in effects or any(c.gas is not None for c in scene.cylinders):
        return "gas loads are not linear in the masses: sweep a scene without [gas]"
    if "speed_fluctuation" in effects:
        return "the speed fluctuation is not swept yet: leave out the effect"
    if scene.levers and "balancers" in effects:
        return "lever balancers are not swept yet: leave them out or drop the balancers effect"
    return None


@dataclass(frozen=True)
class _Variants:
    """Which of each key's values every variant takes: ``index(start, stop)``
    gives a block's (variant, key) value numbers, never the whole table (10⁷
    variants of 4 keys would hold 320 MB of it)."""

    lengths: tuple[int, ...]
    mode: str

    @property
    def count(self) -> int:
        return math.prod(self.lengths) if self.mode == "grid" else self.lengths[0]

    def index(self, start: int, stop: int) -> np.ndarray:
        numbers = np.arange(start, stop)
        if self.mode == "grid":  # the first key varies slowest
            return np.stack(np.unravel_index(numbers, self.lengths), axis=-1)
        return np.repeat(numbers[:, None], len(self.lengths), axis=1)

    def combination(self, index: np.ndarray, columns: list[int]) -> np.ndarray:
        """The number of each variant's combination of the values of the keys
        in ``columns`` (of a grid: its flat index among all combinations; of
        zip: the value number, the same for every key)."""
        if self.mode == "grid":
            return np.ravel_multi_index(tuple(index[:, c] for c in columns), tuple(self.lengths[c] for c in columns))
        return index[:, 0]

    def combinations(self, columns: list[int]) -> np.ndarray:
        """The sorted numbers of the combinations that occur (one, of no keys)."""
        if not columns:
            return np.zeros(1, dtype=int)
        return np.arange(math.prod(self.lengths[c] for c in columns) if self.mode == "grid" else self.count)

    def values_of(self, combination: int, columns: list[int]) -> tuple[int, ...]:
        """The value number of each key in ``columns`` in a combination."""
        if self.mode == "grid":
            return tuple(int(i) for i in np.unravel_index(combination, tuple(self.lengths[c] for c in columns)))
        return (int(combination),) * len(columns)


@dataclass
class _Plan:
    """Everything a block of variants needs, small whatever the number of variants."""

    keys: tuple[str, ...]
    si: dict[str, np.ndarray]            # SI value of each of a key's values
    units: dict[str, tuple[str | None, str | None]]  # SI units and the units to show the values in
    linear: dict[str, dict[int, float]]  # linear key -> {slot: slot value per SI unit of the key}
    geometry: tuple[str, ...]
    variants: _Variants
    combos: np.ndarray                   # sorted flat numbers of the geometry combinations, one per basis
    bases: list[LinearPhasors]           # one per distinct geometry
    base_slots: np.ndarray               # (geometry, slot) the slot values each geometry was read with
    sense: int
    designs: list[DesignBasis] | None    # one per geometry, if the sweep designs the balancers

    def block(self, start: int, stop: int) -> tuple[np.ndarray, np.ndarray, dict[str, np.ndarray]]:
        """Geometry (variant,), slot values (variant, slot) and key values {key: (variant,)} of a block."""
        index = self.variants.index(start, stop)
        if self.geometry:
            columns = [self.keys.index(k) for k in self.geometry]
            group = np.searchsorted(self.combos, self.variants.combination(index, columns))
        else:
            group = np.zeros(len(index), dtype=int)
        slots = self.base_slots[group]
        coords = {k: self.si[k][index[:, i]] for i, k in enumerate(self.keys)}
        for key, coefficients in self.linear.items():
            for s, a in coefficients.items():
                slots[:, s] = coords[key] if a == 1.0 else a * coords[key]
        return group, slots, coords


def _si_values(source: str, key: str, vals) -> tuple[np.ndarray, set[str | None]]:
    """A key's values in SI and the units they were typed in (None for a
    plain number, :func:`typed_units`); a numeric array (Monte Carlo draws)
    is taken as SI without a loop over its items."""
    if isinstance(vals, np.ndarray) and vals.dtype.kind in "iuf":
        si = vals.astype(float)
        bad = np.flatnonzero(~np.isfinite(si))
        if bad.size:
            raise _fail(source, key, vals[bad[0]], "must be finite")
        return si, {None}
    converted = []
    for v in vals:
        try:
            value = _si(v)[0]
        except QuantityError as exc:
            raise _fail(source, key, v, str(exc)) from None
        if not math.isfinite(value):
            raise _fail(source, key, v, "must be finite")
        converted.append(value)
    return np.array(converted), {typed_units(v) for v in vals}


def _plan(scene: Scene, values: dict[str, Sequence], variants: _Variants, backend: str,
          progress: Callable[[int, int], None] | None = None, geometry_keys: frozenset = frozenset(),
          design: bool = False, typed: Mapping[str, set] | None = None, budget: dict | None = None) -> _Plan:
    """Sort the keys, read each distinct geometry once and keep what every
    block of variants needs (``values``: each key's values; ``variants``:
    which of them each variant takes; ``geometry_keys``: keys to treat as
    geometry whatever they move; ``design``: also each geometry's design
    as maps of its slot values; ``typed``: the units each key's values were
    typed in, if not in ``values`` themselves)."""
    reason = _unsupported(scene)
    if reason:
        raise _fail(scene.source, "(scene)", scene.name, reason)
    if design and scene.design is None:
        raise _fail(scene.source, "design", _MISSING, "designing per variant needs the scene's [design] table "
                    "(docs/design.md)")
    reader = _Reader(scene)
    keys = tuple(values)
    si, units = {}, {}
    for key, vals in values.items():
        _parse_path(scene.source, key)
        si[key], typed_here = _si_values(scene.source, key, vals)
        units[key] = key_units(key, (typed or {}).get(key, typed_here))

    base_key = geometry_key(scene)
    names, base_slots = slot_values(scene)
    linear: dict[str, dict[int, float]] = {}
    for key in (k for k in keys if k not in geometry_keys):
        coefficients = _linear_coefficients(reader, key, values[key], si[key], base_key, base_slots, design)
        if coefficients is not None:
            linear[key] = coefficients
    # A slot moved by two keys (mass and radius of one unbalance) is their product, not linear.
    owners: dict[int, list[str]] = {}
    for key, coefficients in linear.items():
        for s in coefficients:
            owners.setdefault(s, []).append(key)
    for shared in (ks for ks in owners.values() if len(ks) > 1):
        for key in shared:
            linear.pop(key, None)
    geometry = tuple(k for k in keys if k not in linear)

    columns = [keys.index(k) for k in geometry]
    combos = variants.combinations(columns)
    if budget is not None:  # now that the distinct geometries are known, before any of them is read
        check_budget(scene, "sweep", sweep={**budget, "geometries": len(combos), "geometry_key": ", ".join(geometry)})
    bases, slot_rows, designs = [], [], []
    for combo in combos:
        numbers = variants.values_of(combo, columns)
        variant = reader.read({k: _toml_value(values[k][i]) for k, i in zip(geometry, numbers)})
        reason = _unsupported(variant)
        if reason:
            raise _fail(scene.source, ", ".join(geometry), None, reason)
        names_here, slots_here = slot_values(variant)
        if names_here != names:
            raise _fail(scene.source, ", ".join(geometry), None, "changes the scene's cylinders or unbalances")
        # A geometry key that also moves a linear key's slot (a rod split and a rod mass): both are geometry.
        clash = {k for k, coefficients in linear.items() if any(slots_here[s] != base_slots[s] for s in coefficients)}
        if clash:
            return _plan(scene, values, variants, backend, progress, geometry_keys | clash, design, typed, budget)
        bases.append(linear_phasors(variant, backend=backend))
        if design:
            designs.append(_design_basis(variant, bases[-1], designs[0] if designs else None, geometry))
        if progress is not None:
            progress(len(bases), len(combos))
        slot_rows.append(bases[-1].values)
    return _Plan(keys=keys, si=si, units=units, linear=linear, geometry=geometry, variants=variants, combos=combos,
                 bases=bases, base_slots=np.array(slot_rows), sense=scene.sense, designs=designs if design else None)


def _design_basis(scene: Scene, basis: LinearPhasors, first: DesignBasis | None, keys: tuple[str, ...]) -> DesignBasis:
    """The design of one geometry as maps of its slot values; every geometry
    must design the same elements for the same orders (one ``element`` and
    ``design_order`` axis for all variants)."""
    from ..balance.variants import design_basis

    try:
        made = design_basis(scene, basis)
    except ValueError as exc:  # DesignError: a request the maps cannot follow (e.g. the peak objective)
        raise _fail(scene.source, "design", None, str(exc)) from None
    if first is not None and (made.elements, made.orders) != (first.elements, first.orders):
        raise _fail(scene.source, ", ".join(keys), None, "changes the designed elements or orders: sweep them as "
                    "separate scenes")
    return made


# -- evaluation and the Dataset -------------------------------------------------------------------


def order_amplitude(phasor: np.ndarray) -> np.ndarray:
    """Peak over a revolution of the magnitude of a vector Re(C·e^{ikθ}), C
    complex per axis (axis last): √((Σ|C_a|² + |Σ C_a²|)/2), the semi-major
    axis of the ellipse it traces (|P_co| + |P_counter| for a transverse
    vector)."""
    # Written out over the three axes: a sum over a length-3 last axis is numpy's slowest reduction.
    x, y, z = phasor[..., 0], phasor[..., 1], phasor[..., 2]
    square = x * x + y * y + z * z
    power = (x * x.conj() + y * y.conj() + z * z.conj()).real
    return np.sqrt((power + np.abs(square)) / 2)


def rotating(phasor: np.ndarray, orders: np.ndarray, sense: int) -> np.ndarray:
    """Co- and counter-rotating phasors (..., order, rotation) of the
    transverse part of ``phasor`` (..., order, axis), w = z + i·t with
    t = −sense·y (:func:`harmbal.orders.spectrum.rotating_split`; order 0 is a
    fixed vector, reported as co-rotating)."""
    z, t = phasor[..., 2], -sense * phasor[..., 1]
    out = np.empty(phasor.shape[:-1] + (2,), dtype=complex)
    out[..., 0] = (z + 1j * t) / 2
    out[..., 1] = np.conj(z - 1j * t) / 2
    fixed = orders == 0
    out[..., fixed, 0] = z[..., fixed] + 1j * t[..., fixed]
    out[..., fixed, 1] = 0
    return out


def evaluate_plan(bases: Sequence[LinearPhasors], group: np.ndarray, slots: np.ndarray, orders: np.ndarray,
                  peak_samples: int | None = None, w2: float = 1.0,
                  designs: Sequence[DesignBasis] | None = None) -> dict[str, np.ndarray]:
    """Phasors (and peaks, and designs) of a block of variants at one speed.

    Parameters
    ----------
    bases : sequence of LinearPhasors
        One per geometry.
    group : ndarray of int
        (variant,) the geometry of each variant.
    slots : ndarray
        (variant, slot) slot values [kg, kg m², kg m].
    orders : ndarray of int
        Orders to report.
    peak_samples : int, optional
        Angles per revolution on which the peaks are taken; None: no peaks.
    w2 : float
        Square of the crank speed [rad²/s²]; the loads scale with it exactly
        (applied to each geometry's basis, not to the variants' arrays).
    designs : sequence of DesignBasis, optional
        One per geometry (:func:`harmbal.balance.variants.design_basis`):
        also design the balancers of every variant.

    Returns
    -------
    dict
        ``force``, ``moment`` (variant, order, axis) complex [N], [N m];
        ``peak_force``, ``peak_moment`` (variant,) if asked; with ``designs``,
        ``design_unbalance`` (variant, element) complex [kg m],
        ``design_residual`` (variant, design order, component) complex [N or
        N m], ``design_cancelled`` (same) bool, and ``residual_force``,
        ``residual_moment`` (variant, order, axis): the free phasors of the
        variant with its designed elements.
    """
    count = len(group)
    force = np.empty((count, len(orders), 3), dtype=complex)
    moment = np.empty_like(force)
    out = {"force": force, "moment": moment}
    if peak_samples:
        out["peak_force"], out["peak_moment"] = np.empty(count), np.empty(count)
    if designs:
        first = designs[0]
        shape = (count, len(first.orders), len(first.components))
        out.update(design_unbalance=np.empty((count, len(first.elements)), dtype=complex),
                   design_residual=np.empty(shape, dtype=complex), design_cancelled=np.empty(shape, dtype=bool),
                   residual_force=np.empty_like(force), residual_moment=np.empty_like(moment))
    # The variants of each geometry that occurs in the block: slices if the block is sorted by geometry (a
    # grid's blocks are, its geometry keys varying slowest), fancy indices otherwise.
    ordered = bool(np.all(group[1:] >= group[:-1]))
    by_group = None if ordered else np.argsort(group, kind="stable")
    present, starts = np.unique(group if ordered else group[by_group], return_index=True)
    for g, start, stop in zip(present, starts, np.append(starts[1:], count)):
        rows = slice(start, stop) if ordered else by_group[start:stop]
        basis = bases[g]
        if w2 != 1.0:
            basis = replace(basis, force=w2 * basis.force, moment=w2 * basis.moment,
                            constant_force=w2 * basis.constant_force, constant_moment=w2 * basis.constant_moment)
        f, m = combine(basis, slots[rows], orders)
        force[rows], moment[rows] = f.swapaxes(-1, -2), m.swapaxes(-1, -2)
        if peak_samples:
            waves = time_basis(basis, peak_samples)
            where = np.arange(count)[rows]
            for first in range(0, len(where), _PEAK_BLOCK):
                block = where[first: first + _PEAK_BLOCK]
                out["peak_force"][block], out["peak_moment"][block] = peaks(*waves, slots[block])
        if designs:
            from ..balance.variants import design_variants

            designed = design_variants(designs[g], slots[rows], orders)
            out["design_unbalance"][rows] = designed["unbalance"]
            out["design_residual"][rows] = w2 * designed["residual"]
            out["design_cancelled"][rows] = designed["cancelled"]
            out["residual_force"][rows] = w2 * designed["force"].swapaxes(-1, -2)
            out["residual_moment"][rows] = w2 * designed["moment"].swapaxes(-1, -2)
    return out


def _evaluate_block(plan: _Plan, start: int, stop: int, orders: np.ndarray, peak_samples: int | None, w2: float,
                    phasors: bool) -> dict[str, np.ndarray]:
    """Every array of the variants ``start`` … ``stop - 1``: key values, order
    amplitudes, peaks if asked, and with ``phasors`` the phasors and their
    co/counter split (a function of the plan and the block alone, so that
    dask can run it on any worker)."""
    group, slots, out = plan.block(start, stop)
    arrays = evaluate_plan(plan.bases, group, slots, orders, peak_samples, w2, plan.designs)
    for name in ("force", "moment", "residual_force", "residual_moment"):
        if name not in arrays:
            continue
        phasor = arrays.pop(name)
        out[f"{name}_amplitude"] = order_amplitude(phasor)
        if phasors:
            out[name] = phasor
            out[f"{name}_rotating"] = rotating(phasor, orders, plan.sense)
    out.update(arrays)  # the peaks and the designs
    return out


def _evaluate(plan: _Plan, block: int, **options) -> dict[str, np.ndarray]:
    """All variants, ``block`` at a time (bounding the phasors' temporaries)."""
    count = plan.variants.count
    arrays = {}
    for start in range(0, count, block):
        stop = min(start + block, count)
        for name, part in _evaluate_block(plan, start, stop, **options).items():
            if name not in arrays:
                arrays[name] = np.empty((count,) + part.shape[1:], dtype=part.dtype)
            arrays[name][start:stop] = part
    return arrays


def _chunked(plan: _Plan, chunk: int, **options) -> dict:
    """All variants as dask arrays of ``chunk`` variants per chunk, one task per
    chunk evaluating all of its arrays (nothing is evaluated here but the
    first variant, for the arrays' shapes and types)."""
    try:
        import dask
        import dask.array as da
    except ImportError:
        raise ImportError("chunked sweeps need dask: pip install dask distributed zarr (the extra harmbal[dask])") from None
    count = plan.variants.count
    template = _evaluate_block(plan, 0, 1, **options)
    shared = dask.delayed(plan, traverse=False)  # one copy of the bases in the graph, not one per chunk
    evaluate = dask.delayed(_evaluate_block, pure=True)
    starts = range(0, count, chunk)
    blocks = [(evaluate(shared, start, min(start + chunk, count), **options), min(start + chunk, count) - start)
              for start in starts]
    return {name: da.concatenate([da.from_delayed(task[name], (size,) + t.shape[1:], dtype=t.dtype)
                                  for task, size in blocks]) for name, t in template.items()}


def _dataset(scene: Scene, plan: _Plan, arrays: dict, orders: np.ndarray, dim: str, attrs: dict, speeds: Speeds):
    """The Dataset of ``arrays`` (at the scene's one speed, or at unit speed if
    it has several: then ω² products over ``speed``, lazy)."""
    def var(dims, values, var_attrs):
        if not speeds.several:
            return variable(dims, values, var_attrs)
        if isinstance(values, np.ndarray):
            return speeds.variable(dims, values, var_attrs)
        return variable(speeds.lead + dims, speeds.w2.reshape((-1,) + (1,) * values.ndim) * values[None], var_attrs)

    data = {}
    for name, units, what in (("force", "N", "the free shaking force"), ("moment", "N m", "the free shaking moment"),
                              ("residual_force", "N", "the free force with the designed balancers"),
                              ("residual_moment", "N m", "the free moment with the designed balancers")):
        if f"{name}_amplitude" not in arrays:
            continue
        if name in arrays:
            data[name] = var((dim, "order", "axis"), arrays[name], {
                "units": units, "long_name": f"order phasor of {what}",
                "description": "C_k with signal(theta) = sum_k Re(C_k exp(i k theta)); |C_k| peak amplitude"})
            data[f"{name}_rotating"] = var((dim, "order", "rotation"), arrays[f"{name}_rotating"], {
                "units": units, "long_name": f"co- and counter-rotating phasors of the transverse part of {what}",
                "description": "w = z + i t = P_co exp(i k theta) + P_counter exp(-i k theta)"})
        data[f"{name}_amplitude"] = var((dim, "order"), arrays[f"{name}_amplitude"], {
            "units": units, "long_name": f"peak over a revolution of the order's vector of {what}",
            "description": "sqrt((sum_a |C_a|^2 + |sum_a C_a^2|) / 2)"})
        if f"peak_{name}" in arrays:
            data[f"peak_{name}"] = var((dim,), arrays[f"peak_{name}"], {
                "units": units, "long_name": f"largest magnitude of the {name} vector over a revolution",
                "description": f"maximum over {attrs['peak_samples']} angles of the orders 0..max_order "
                               "rebuilt from the phasors"})
    data.update(_levels(scene, speeds))
    coords = {dim: variable((dim,), np.arange(plan.variants.count), {"long_name": f"{dim} number"})}
    if plan.designs:
        design = plan.designs[0]
        unbalance = arrays["design_unbalance"]
        data["design_unbalance"] = variable((dim, "element"), abs(unbalance), {
            "units": "kg m", "long_name": "designed unbalance (mass x radius) of each element, as harmbal.design sizes it"})
        data["design_unbalance_angle"] = variable((dim, "element"), _angle(unbalance), {
            "units": "rad", "long_name": "direction of the designed unbalance at theta = 0"})
        data["design_residual"] = var((dim, "design_order", "component"), arrays["design_residual"], {
            "units_by_component": "component_units", "long_name": "residual phasor the design predicts",
            "description": "harmbal.design's predicted; 0 where cancelled (round-off)"})
        data["design_cancelled"] = variable((dim, "design_order", "component"), arrays["design_cancelled"], {
            "long_name": "targeted component cancelled by the design"})
        data["design_targeted"] = variable(("design_order", "component"), np.array(
            [[(k, n) in design.solver.targets for n in design.components] for k in design.orders]), {
            "long_name": "component the [design] table asks to cancel"})
        coords.update({
            "element": variable(("element",), np.array(design.elements), {"long_name": "designed balancer element"}),
            "design_order": variable(("design_order",), np.array(design.orders), {"long_name": "order designed for"}),
            "component": variable(("component",), np.array(design.components)),
            "component_units": variable(("component",), np.array(["N" if c.startswith("force") else "N m"
                                                                  for c in design.components])),
        })
    for key in plan.keys:
        key_attrs = {"long_name": f"scene key {key}", "kind": "linear" if key in plan.linear else "geometry"}
        si_units, display_units = plan.units[key]
        if si_units is not None:
            key_attrs.update(units=si_units, display_units=display_units)
        coords[key] = variable((dim,), arrays[key], key_attrs)
    coords.update({
        "order": variable(("order",), orders, {"long_name": "order of crank speed", "units": "1"}),
        "axis": variable(("axis",), np.array(["x", "y", "z"]), {"long_name": "engine axis"}),
        "rotation": variable(("rotation",), np.array(ROTATION), {"long_name": "sense of rotation relative to the crank"}),
    })
    if speeds.several:
        coords.update(speeds.coords())
    attrs = {
        "harmbal_conventions": CONVENTIONS, "engine": scene.name, "rotation": scene.rotation,
        "speed_rad_s": list(scene.speeds), "max_order": scene.sampling.max_order,
        "linear_keys": list(plan.linear), "geometry_keys": list(plan.geometry), "geometries": len(plan.bases),
        "samples_per_rev": sorted({b.samples_per_rev for b in plan.bases}), "zero_rtol": ZERO_RTOL,
        "negligible": float(scene.model.negligible), "cylinders": len(scene.cylinders), "classes": _CLASSES_NOTE,
        **attrs,
    }
    return dataset(data, coords, attrs)


#: How a sweep's loads are classed (the ``classes`` attribute; docs/sweeps.md).
_CLASSES_NOTE = ("zero (round-off): at most zero_rtol x nominal_<force|moment>_scale; negligible: at most "
                 "<force|moment>_negligible_level; free: above it. Every variant is judged against the levels of the "
                 "nominal scene (the scene swept), so that variants compare on one footing: "
                 "harmbal.orders.spectrum.classify(amplitude, nominal_force_scale, force_negligible_level)")


def _levels(scene: Scene, speeds: Speeds) -> dict:
    """The nominal scene's load scales and negligible levels at the sweep's
    speeds (inertial loads and their scales go with ω²)."""
    def at_speeds(unit_value: float, attrs: dict):
        if speeds.several:
            return speeds.variable((), np.asarray(unit_value), attrs)
        return variable((), np.asarray(float(speeds.w2) * unit_value), attrs)

    unit = evaluate(scene)
    data = {}
    for name, units, scale in (("force", "N", unit.force_scale), ("moment", "N m", unit.moment_scale)):
        data[f"nominal_{name}_scale"] = at_speeds(scale, {
            "units": units, "long_name": f"sum of the single bodies' peak {name}s of the nominal scene (the scene "
                                         "swept): the scale its zero class is judged by"})
        level = float(negligible_level(scale, len(scene.cylinders), scene.model.negligible))
        data[f"{name}_negligible_level"] = at_speeds(level, {
            "units": units, "long_name": f"{name} amplitude at or below which a load is negligible: [model] "
                                         "negligible x the nominal scale / cylinders"})
    return data


def _angle(values):
    """np.angle for numpy and dask arrays alike (np.angle would compute a dask array)."""
    return np.arctan2(values.imag, values.real)


def _run(scene: Scene, values: dict, variants: _Variants, orders, peaks: bool, peak_samples: int, backend: str,
         progress: Callable[[int, int], None] | None, phasors: bool, chunks: int | None, dim: str, attrs: dict,
         design: bool = False, typed: Mapping[str, set] | None = None, budget: dict | None = None):
    kept = _orders(scene, orders)
    if chunks is not None and (isinstance(chunks, bool) or not isinstance(chunks, (int, np.integer)) or chunks < 1):
        raise ValueError(f"chunks must be a positive number of variants: {chunks!r}")
    plan = _plan(scene, values, variants, backend, progress, design=design, typed=typed, budget=budget)
    speeds = Speeds(scene.speeds)
    options = {"orders": kept, "peak_samples": peak_samples if peaks else None,
               "w2": 1.0 if speeds.several else float(speeds.w2), "phasors": phasors}
    arrays = _evaluate(plan, _BLOCK, **options) if chunks is None else _chunked(plan, int(chunks), **options)
    if peaks:
        attrs["peak_samples"] = peak_samples
    attrs["phasors"] = "yes" if phasors else "no (order amplitudes only)"
    if chunks is not None:
        attrs["chunks"] = int(chunks)
    return _dataset(scene, plan, arrays, kept, dim, attrs, speeds)


def _given_values(values) -> np.ndarray | list:
    """A key's values: a numeric array if they are all plain numbers (taken as
    SI without a loop over them), else a list of numbers and unit strings."""
    if isinstance(values, np.ndarray) and values.dtype.kind in "iuf":  # as given: no Python object per value
        return values if values.ndim == 1 else np.atleast_1d(values).ravel()
    array = np.atleast_1d(np.asarray(values, dtype=object))
    if array.size and all(isinstance(v, Real) and not isinstance(v, (bool, np.bool_)) for v in array):
        return np.array(array.tolist())
    return list(array)


def _orders(scene: Scene, orders) -> np.ndarray:
    kmax = scene.sampling.max_order
    if orders is None:
        return np.arange(kmax + 1)
    chosen = np.unique(np.asarray(orders, dtype=int))
    if chosen.size == 0 or chosen[0] < 0 or chosen[-1] > kmax:
        raise ValueError(f"orders must lie in 0..{kmax} (the scene's max_order): {list(orders)}")
    return chosen


def _as_scene(scene: Scene | str | os.PathLike) -> Scene:
    return scene if isinstance(scene, Scene) else load_scene(scene)


def sweep(scene: Scene | str | os.PathLike, parameters: Mapping[str, Sequence], *, mode: str = "grid",
          orders: Sequence[int] | None = None, peaks: bool = False, peak_samples: int = 360,
          backend: str = "scipy", progress: Callable[[int, int], None] | None = None, phasors: bool = True,
          chunks: int | None = None, design: bool = False):
    """Free forces and moments of many variants of a scene, vectorised.

    Parameters
    ----------
    scene : Scene or path-like
        The nominal scene (from :func:`harmbal.load_scene`, or its file).
        Scenes with gas, lever balancers or the speed fluctuation are refused.
    parameters : mapping of str to sequence
        Key path → values. A key path addresses the scene file as written:
        ``geometry.rod_length``, ``piston.mass``, ``rod.mass``,
        ``cylinder[2].piston.mass``, ``cylinder[1].bank``,
        ``crankshaft_unbalance[1].unbalance`` (1-based array indices; missing
        tables are created, so ``cylinder[2].piston.mass`` overrides the shared
        [piston] for cylinder 2 only). Values are plain numbers in SI units
        (radians for angles, as in a scene file) or unit strings (``"128 mm"``).
    mode : {"grid", "zip"}
        ``grid``: every combination (the first key varies slowest); ``zip``:
        the i-th values of all keys together (equal lengths).
    orders : sequence of int, optional
        Orders to report (default 0 … max_order).
    peaks : bool
        Also the largest magnitude of the force and moment vectors over a
        revolution (``peak_force``, ``peak_moment``).
    peak_samples : int
        Angles per revolution for the peaks (their accuracy: see docs/sweeps.md).
    backend : {"scipy", "numpy", "pyfftw"}
        FFT implementation of the single-cylinder spectra.
    progress : callable, optional
        Called as ``progress(done, total)`` after each distinct geometry is
        read and evaluated (the part of a sweep whose cost grows with the
        number of geometries, about 0.7 ms each).
    phasors : bool
        False: keep only the order amplitudes (and peaks), evaluating the
        phasors in blocks of variants and dropping them: a sweep of 10⁷
        variants then needs about 1 GB instead of 40 (for 2 orders, 4).
    chunks : int, optional
        Variants per chunk: the result's arrays are then dask arrays, chunked
        along ``variant``, evaluated only when computed or written (one task
        per chunk; on the threaded scheduler by default, on a
        ``distributed.Client`` if one is active), so a sweep larger than the
        memory can be reduced or written chunk by chunk (docs/sweeps.md).
        Needs the ``dask`` extra. The distinct geometries are still read and
        evaluated here, before returning.
    design : bool
        Also design the balancers of every variant as :func:`harmbal.design`
        does with the scene's ``[design]`` table (least-squares objective;
        the designed elements and orders must be the same in every variant),
        and give the free force and moment of each variant with its designed
        elements (:mod:`harmbal.balance.variants`). ``[design]`` keys (e.g.
        ``design.counterweights[1].balance_factor``) can then be swept.

    Returns
    -------
    xarray.Dataset
        Dims ``variant``, ``order``, ``axis``, ``rotation`` (and ``speed`` if the
        scene has several speeds). Complex ``force`` [N] and ``moment`` [N m]
        (variant, order, axis) at the scene's speed, about its reference
        point; ``force_rotating``/``moment_rotating`` (variant, order,
        rotation); real ``force_amplitude``/``moment_amplitude`` (variant,
        order), the peak of each order's vector over a revolution; with
        ``peaks``, ``peak_force``/``peak_moment`` (variant,). Each key is a
        coordinate along ``variant`` (SI values, SI ``units``, and
        ``display_units``: the units the values were typed in, or the SI
        units for plain numbers). ``nominal_force_scale``,
        ``nominal_moment_scale`` and ``force_negligible_level``,
        ``moment_negligible_level`` are the swept scene's load scales and
        negligible levels at its speed, by which every variant's loads are
        classed (:func:`harmbal.orders.spectrum.classify`). In grid mode
        ``ds.set_index(variant=list(parameters)).unstack("variant")`` gives one
        dimension per key (attribute ``grid_shape``). With ``design``:
        ``design_unbalance`` [kg m] and ``design_unbalance_angle`` [rad]
        (variant, element), ``design_residual`` (complex) and
        ``design_cancelled`` (variant, design_order, component) as in
        :func:`harmbal.design`'s Dataset, and ``residual_force``,
        ``residual_moment`` (with their ``_rotating`` split and
        ``_amplitude``) as ``force`` and ``moment`` but with the designed
        elements: what :func:`harmbal.verify` of the designed scene checks
        (the moment with its roll about the crank axis, which [design]
        targets only if its ``cancel`` lists ``roll``).

    Raises
    ------
    SceneError
        A key that is not a key path or not in the scene, a value the scene
        reader refuses (naming the key), a scene the sweep cannot vary, or a
        sweep whose estimated memory or time exceeds the budget
        (:func:`harmbal.model.budget.check_budget`; ``chunks`` holds only a
        few chunks at once).
    """
    if mode not in MODES:
        raise ValueError(f"mode must be one of {', '.join(MODES)}: {mode!r}")
    scene = _as_scene(scene)
    if not parameters:
        raise ValueError("give at least one key to sweep")
    values = {k: _given_values(v) for k, v in parameters.items()}
    for key, vals in values.items():
        if len(vals) == 0:
            raise _fail(scene.source, key, [], "no values to sweep")
    lengths = [len(v) for v in values.values()]
    if mode == "zip" and len(set(lengths)) > 1:
        raise ValueError(f"zip mode needs equally many values of every key: {dict(zip(values, lengths))}")
    variants = _Variants(tuple(lengths), mode)
    largest = max(values, key=lambda k: len(values[k]))
    budget = _budget(scene, variants.count, largest, f"{len(values[largest])} values", orders, peaks, peak_samples,
                     phasors, chunks, design, sum(lengths))
    attrs = {"title": f"harmbal sweep: {scene.name}", "mode": mode, "parameters": list(values)}
    if mode == "grid":
        attrs["grid_shape"] = lengths
    return _run(scene, values, variants, orders, peaks, peak_samples, backend, progress,
                phasors, chunks, "variant", attrs, design, budget=budget)


def _budget(scene: Scene, variants: int, key: str, value: Any, orders, peaks: bool, peak_samples: int, phasors: bool,
            chunks: int | None, design: bool, values: int) -> dict:
    """Refuse a sweep whose variants alone exceed the memory or time budget
    (:func:`harmbal.model.budget.check_budget`); the estimate's keywords, for
    :func:`_plan` to check again with the number of distinct geometries."""
    chunked = isinstance(chunks, (int, np.integer)) and not isinstance(chunks, bool) and chunks >= 1  # else: _run says
    budget = {"variants": int(variants), "key": key, "value": value, "phasors": bool(phasors), "peaks": bool(peaks),
              "peak_samples": int(peak_samples), "design": bool(design), "chunks": int(chunks) if chunked else None,
              "values": int(values),
              "orders": scene.sampling.max_order + 1 if orders is None else len(set(np.atleast_1d(orders).tolist()))}
    check_budget(scene, "sweep", sweep=budget)
    return budget


def monte_carlo(scene: Scene | str | os.PathLike, tolerances: Mapping[str, Normal | Uniform | WeightClasses],
                n: int, *, seed: int | np.random.SeedSequence | None = None, orders: Sequence[int] | None = None,
                peaks: bool = False, peak_samples: int = 360, percentiles: Sequence[float] = (5, 50, 95, 99),
                force_limit: float | None = None, moment_limit: float | None = None, backend: str = "scipy",
                progress: Callable[[int, int], None] | None = None, phasors: bool = True,
                chunks: int | None = None, design: bool = False):
    """Production scatter: the free forces and moments of ``n`` random variants.

    Parameters
    ----------
    scene : Scene or path-like
        The nominal scene; each toleranced key must be written in its file
        (the nominal value).
    tolerances : mapping of str to Normal, Uniform or WeightClasses
        Key path (as in :func:`sweep`) → distribution: :class:`Normal` and
        :class:`Uniform` are deviations from the nominal, :class:`WeightClasses`
        the values themselves. Keys are drawn independently, in the order given.
    n : int
        Samples.
    seed : int or SeedSequence, optional
        Seed of :func:`numpy.random.default_rng`: the same seed gives
        bit-identical results.
    orders, peaks, peak_samples, backend, progress, phasors, chunks, design
        As in :func:`sweep` (with ``chunks``, the summary statistics are lazy too;
        with ``design``, they include the residual amplitudes after the design).
    percentiles : sequence of float
        Percentiles [%] of the order amplitudes (and peaks) to summarise.
    force_limit, moment_limit : float, optional
        Limits [N], [N m] of the order amplitudes (at the scene's speed):
        ``p_exceed_force``/``p_exceed_moment`` per order give the share of
        samples above them.

    Returns
    -------
    xarray.Dataset
        As :func:`sweep` with dim ``sample`` instead of ``variant``, plus
        ``force_amplitude_percentile``/``moment_amplitude_percentile``
        (percentile, order) (and ``peak_*_percentile``), ``force_amplitude_mean``,
        ``force_amplitude_std`` (and the moment's) per order, the exceedance
        shares if limits are given, and ``force_sensitivity``/``moment_sensitivity``
        (parameter, order): the share of the variance of each order amplitude
        that each tolerance explains (squared standardised regression
        coefficients of a linear fit, :func:`sensitivity`; ``*_sensitivity_r2``
        the fit's R², near 1 where the response is near linear).
    """
    scene = _as_scene(scene)
    if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n < 1:
        raise ValueError(f"n must be a positive integer: {n!r}")
    if not tolerances:
        raise ValueError("give at least one toleranced key")
    # Before any draw: n samples of every key, and the variants they make.
    budget = _budget(scene, int(n), "n", int(n), orders, peaks, peak_samples, phasors, chunks, design,
                     int(n) * len(tolerances))
    rng = np.random.default_rng(seed)
    raw = tomllib.loads(scene.source_text) if scene.source_text else {}
    values, typed = {}, {}
    for key, dist in tolerances.items():
        if not isinstance(dist, (Normal, Uniform, WeightClasses)):
            raise TypeError(f"{key}: a Normal, Uniform or WeightClasses, not {type(dist).__name__}")
        _parse_path(scene.source, key)
        nominal = _get(raw, key)
        if nominal is None and key.startswith("cylinder["):
            # A cylinder without its own value takes the shared table's, as the reader merges them.
            nominal = _get(raw, key.partition(".")[2])
        if nominal is None and not isinstance(dist, WeightClasses):
            raise _fail(scene.source, key, _MISSING, "not written in the scene: a tolerance is a deviation from "
                        "the nominal value, write the nominal in the scene file")
        try:
            centre, dimension = (0.0, None) if nominal is None else _si(nominal)
        except QuantityError as exc:
            raise _fail(scene.source, key, nominal, str(exc)) from None
        # A quantity with units of another dimension would be added as if it were SI: refuse it.
        dimension = KEY_DIMENSIONS.get(_parse_path(scene.source, key)[-1][0], dimension)
        strings = [v for v in dist.quantities() if isinstance(v, str)]
        for value in (v for v in strings if dimension is not None):
            try:
                given = _si(value)[1]
            except QuantityError as exc:
                raise _fail(scene.source, key, value, str(exc)) from None
            if given != dimension:
                raise _fail(scene.source, key, value, f"is in {SI_UNITS[given]}, the key in "
                            f"{SI_UNITS[dimension] or '1 (dimensionless)'}")
        typed[key] = {typed_units(v) for v in dist.quantities()}
        try:
            values[key] = dist.draw(rng, centre, int(n), key)
        except SceneError as exc:
            raise SceneError([replace(p, source=scene.source) for p in exc.problems]) from None
    attrs = {"title": f"harmbal Monte Carlo: {scene.name}", "mode": "monte carlo", "parameters": list(values),
             "samples": int(n), "seed": "none" if seed is None else str(seed),
             "tolerances": [f"{k}: {d!r}" for k, d in tolerances.items()]}
    ds = _run(scene, values, _Variants((int(n),) * len(values), "zip"), orders, peaks, peak_samples, backend,
              progress, phasors, chunks, "sample", attrs, design, typed, budget)
    return _summarise(ds, percentiles, force_limit, moment_limit)


def _summarise(ds, percentiles, force_limit, moment_limit):
    """Percentiles, mean and standard deviation over ``sample`` of the order
    amplitudes (and peaks), the share of samples above the limits, and the
    sensitivity of each order amplitude to each toleranced key."""
    import xarray as xr

    q = np.asarray(percentiles, dtype=float)
    out = ds.assign_coords(percentile=("percentile", q, {"units": "%"}))
    names = [v for v in ("force_amplitude", "moment_amplitude", "residual_force_amplitude", "residual_moment_amplitude",
                         "peak_force", "peak_moment") if v in ds]
    for name in names:
        values = ds[name]
        units = values.attrs.get("units", "")
        stats = values.quantile(q / 100, dim="sample").rename(quantile="percentile").assign_coords(percentile=q)
        out[f"{name}_percentile"] = stats.assign_attrs(units=units, long_name=f"percentiles of {name} over the samples")
        out[f"{name}_mean"] = values.mean("sample").assign_attrs(units=units, long_name=f"mean of {name}")
        out[f"{name}_std"] = values.std("sample", ddof=1).assign_attrs(
            units=units, long_name=f"sample standard deviation of {name}")
    for name, limit in (("force", force_limit), ("moment", moment_limit)):
        if limit is not None:
            out[f"p_exceed_{name}"] = (ds[f"{name}_amplitude"] > limit).mean("sample").assign_attrs(
                units="1", long_name=f"share of samples whose order {name} amplitude exceeds {limit:g}",
                limit=float(limit))
    keys = list(ds.attrs["parameters"])
    out = out.assign_coords(parameter=("parameter", np.array(keys), {"long_name": "toleranced scene key"}))
    x = xr.DataArray(xr.Variable.concat([ds[k].variable for k in keys], dim="parameter"))
    x = x - x.mean("sample")
    for name in ("force", "moment"):
        amplitude = ds[f"{name}_amplitude"]
        # ω² scales every sample alike: the shares do not depend on the speed.
        y = (amplitude.isel(speed=0) if "speed" in amplitude.dims else amplitude).variable
        y = xr.DataArray(y) - y.mean("sample")
        share, r2 = xr.apply_ufunc(
            _shares, xr.dot(x, x.rename(parameter="parameter_"), dim="sample"), xr.dot(x, y, dim="sample"),
            (y * y).sum("sample"), input_core_dims=[["parameter", "parameter_"], ["parameter", "order"], ["order"]],
            output_core_dims=[["parameter", "order"], ["order"]], dask="parallelized", output_dtypes=[float, float],
            dask_gufunc_kwargs={"allow_rechunk": True})  # the sums are small: one chunk each
        out[f"{name}_sensitivity"] = (("parameter", "order"), share.data, {
            "units": "1", "long_name": f"share of the variance of the order {name} amplitude due to each tolerance",
            "description": "squared standardised regression coefficient of a linear least-squares fit on the "
                           "samples; for independent tolerances the shares sum to about the fit's R^2"})
        out[f"{name}_sensitivity_r2"] = (("order",), r2.data, {
            "units": "1", "long_name": f"R^2 of the linear fit of the order {name} amplitude on the tolerances"})
    return out


def sensitivity(inputs: np.ndarray, outputs: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Squared standardised regression coefficients of a linear fit.

    Parameters
    ----------
    inputs : ndarray
        (sample, parameter) drawn values.
    outputs : ndarray
        (sample, quantity) results.

    Returns
    -------
    share : ndarray
        (parameter, quantity): (b_k·σ_k/σ_y)², b the least-squares slopes; for
        independent inputs and a near-linear response, the share of the
        variance of y each input explains. A constant input or output has 0.
    r2 : ndarray
        (quantity,) the fit's coefficient of determination.
    """
    x = inputs - inputs.mean(axis=0)
    y = outputs - outputs.mean(axis=0)
    return _shares(x.T @ x, x.T @ y, (y * y).sum(axis=0))


def _shares(sxx: np.ndarray, sxy: np.ndarray, syy: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """:func:`sensitivity` from the centred sums of products (sums over the
    samples, so that a chunked Monte Carlo run reduces its chunks to them):
    slopes b = Sxx⁻¹·Sxy (normal equations: the inputs are few and, centred,
    well conditioned), share b_k²·Sxx_kk/Syy, R² = b·Sxy/Syy."""
    varying = np.diag(sxx) > 0
    slopes = np.zeros(sxy.shape)
    if varying.any():
        slopes[varying] = np.linalg.solve(sxx[np.ix_(varying, varying)], sxy[varying])
    with np.errstate(divide="ignore", invalid="ignore"):
        share = np.where(syy > 0, slopes**2 * np.diag(sxx)[:, None] / syy, 0.0)
        r2 = np.where(syy > 0, (slopes * sxy).sum(axis=0) / syy, 0.0)
    return share, r2

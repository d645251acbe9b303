"""Geometry keys as arrays: how each key sets the scene's geometry fields
(:func:`harmbal.orders.linear.geometry_fields`: every cylinder's radius,
rod length, offsets, CG positions, throw, bank and axial position, the
unbalances' angles and positions, the reference point), the fields of any
block of geometry combinations, and their validation for the whole range of
values, without reading the scene file once per geometry.

Each geometry key is read through the scene reader at its smallest, median
and largest value and at its smallest nonzero magnitude (the reader's
checks at the extremes of its range: a rule on one key is a bound on its
value or its magnitude). The fields a key moves must follow its SI value
exactly (the identity) or affinely (a two-point rod's CG with its length, a
throw unbalance's position with its cylinder's), the key must move nothing
else (no mass, no balancer element, no model setting) and no field may be
moved by two keys; otherwise :func:`field_map` gives None and the sweep
reads every geometry as a scene (:mod:`harmbal.studies.plan`). The rules
that join several keys (a rod long enough for the crank and offsets, a rod
CG within the rod, two cylinders in one place) are checked on every
combination as arrays, and a combination they flag is read through the
reader, whose refusal names the key (:func:`check_geometries`).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from ..orders.linear import geometry_fields, geometry_key, slot_values, with_geometry_fields
from ..scene import Scene
from .keys import toml_value
from .variants import SceneVariants, Variants

#: Combinations validated (their fields made and checked) at a time.
CHECK_BLOCK = 65536
#: Relative slack of the array checks: they flag a superset of what the reader refuses (the reader decides).
_FLAG = 1e-9
#: Largest relative misfit of a field to an affine function of its key (round-off of the reader's arithmetic).
_AFFINE_RTOL = 1e-13


@dataclass(frozen=True)
class FieldMap:
    """How the geometry keys set the geometry fields.

    Attributes
    ----------
    base : ndarray
        (field,) the swept scene's geometry fields.
    keys : tuple of str
        The geometry keys, in the plan's order.
    moved : tuple of ndarray
        Per key, the fields it sets (no field is set by two keys).
    slope, intercept : tuple of ndarray or None
        Per key, field = slope · value + intercept over its moved fields
        (value in SI); None for the identity (field = value).
    """

    base: np.ndarray
    keys: tuple[str, ...]
    moved: tuple[np.ndarray, ...]
    slope: tuple[np.ndarray | None, ...]
    intercept: tuple[np.ndarray | None, ...]

    def fields(self, values: Sequence[np.ndarray]) -> np.ndarray:
        """(combination, field) from each key's SI values (combination,)."""
        out = np.repeat(self.base[None], len(values[0]), axis=0)
        for x, moved, a, b in zip(values, self.moved, self.slope, self.intercept):
            out[:, moved] = x[:, None] if a is None else a * x[:, None] + b
        return out


def field_map(reader: SceneVariants, values: Mapping[str, Sequence | np.ndarray], si: Mapping[str, np.ndarray],
              geometry: Sequence[str]) -> FieldMap | None:
    """The :class:`FieldMap` of the ``geometry`` keys, or None if one of them
    is not a field key (module docstring). Reads each key at its probes
    (:func:`probes`), which validates those values and refuses a bad one
    naming the key."""
    scene = reader.scene
    names, base = geometry_fields(scene)
    rest, slots = _rest(scene), slot_values(scene)[1]
    moved, slope, intercept = [], [], []
    for key in geometry:
        x = si[key]
        at = probes(x)
        rows = []
        for p in at:
            variant = reader.read({key: toml_value(values[key][p])})
            here, fields = geometry_fields(variant)
            if here != names or _rest(variant) != rest or not np.array_equal(slot_values(variant)[1], slots):
                return None
            rows.append(fields)
        columns = np.flatnonzero((np.array(rows) != base).any(axis=0))
        fit = _affine(np.array(rows)[:, columns], x[at])
        if fit is None:
            return None
        moved.append(columns)
        slope.append(fit[0])
        intercept.append(fit[1])
    every = np.concatenate(moved) if moved else np.zeros(0, dtype=int)
    if len(np.unique(every)) < len(every):  # a shared key and a cylinder's override of it: not additive
        return None
    return FieldMap(base, tuple(geometry), tuple(moved), tuple(slope), tuple(intercept))


def probes(x: np.ndarray) -> list[int]:
    """The value numbers a key is read at: its smallest, median and largest
    value (as for a linear key) and its smallest nonzero magnitude (the
    ranges bound magnitudes: 0 or between a smallest and a largest)."""
    order = np.argsort(x, kind="stable")
    chosen = {int(order[0]), int(order[len(order) // 2]), int(order[-1])}
    nonzero = np.flatnonzero(x != 0)
    if nonzero.size:
        chosen.add(int(nonzero[np.argmin(np.abs(x[nonzero]))]))
    return sorted(chosen)


def _rest(scene: Scene) -> Scene:
    """The scene without its geometry fields and slots: what a field key must leave as it is."""
    return geometry_key(with_geometry_fields(scene, np.zeros(len(geometry_fields(scene)[1]))))


def _affine(rows: np.ndarray, x: np.ndarray) -> tuple[np.ndarray | None, np.ndarray | None] | None:
    """(slope, intercept) of fields ``rows`` (probe, field) as a function of
    the key's values ``x`` (probe,); (None, None) for the identity; None if
    they are not affine in it."""
    if (rows == x[:, None]).all():
        return None, None
    low, high = int(np.argmin(x)), int(np.argmax(x))
    if x[high] == x[low]:
        return np.zeros(rows.shape[1]), rows[low].copy()
    slope = (rows[high] - rows[low]) / (x[high] - x[low])
    intercept = rows[low] - slope * x[low]
    scale = np.abs(rows).max(axis=0) + np.abs(slope) * np.abs(x).max()
    if np.any(np.abs(slope * x[:, None] + intercept - rows) > _AFFINE_RTOL * scale):
        return None
    return slope, intercept


def combination_values(variants: Variants, columns: list[int], si: Sequence[np.ndarray],
                       combinations: np.ndarray) -> tuple[np.ndarray, list[np.ndarray]]:
    """Value numbers (combination, key) and SI values of the keys in
    ``columns`` (their ``si`` values, in that order) in each of
    ``combinations``."""
    numbers = variants.value_numbers(combinations, columns)
    return numbers, [x[numbers[:, k]] for k, x in enumerate(si)]


def check_geometries(reader: SceneVariants, fields_map: FieldMap, values: Mapping[str, Sequence | np.ndarray],
                     si: Mapping[str, np.ndarray], variants: Variants, columns: list[int],
                     combinations: np.ndarray) -> np.ndarray:
    """Validate every combination of the geometry keys, :data:`CHECK_BLOCK`
    at a time; the samples per revolution of each (as the reader's scene of
    it would choose them).

    Raises
    ------
    SceneError
        The reader's refusal of the first combination it refuses, naming the key.
    """
    from ..orders.linear import samples_per_geometry

    keys = fields_map.keys
    samples = np.empty(len(combinations), dtype=int)
    for start in range(0, len(combinations), CHECK_BLOCK):
        block = combinations[start: start + CHECK_BLOCK]
        numbers, x = combination_values(variants, columns, [si[k] for k in keys], block)
        fields = fields_map.fields(x)
        for row in flagged(reader.scene, fields):
            reader.read({k: toml_value(values[k][int(i)]) for k, i in zip(keys, numbers[row])})  # refuses or passes
        samples[start: start + len(block)] = samples_per_geometry(reader.scene, fields)
    return samples


def flagged(scene: Scene, fields: np.ndarray) -> np.ndarray:
    """Rows of ``fields`` that may break a rule joining several keys (a
    superset: the reader decides): a rod not longer than the crank radius
    plus the offsets, a rod CG beyond the rod, a length that must be
    positive, two cylinders at one throw, bank and axial position."""
    names = geometry_fields(scene)[0]
    count = len(scene.cylinders)

    def field(name: str) -> np.ndarray:  # (row, cylinder)
        return fields[:, [names.index(f"cylinder[{i}].{name}") for i in range(1, count + 1)]]

    r, l, cg = field("crank_radius"), field("rod_length"), field("rod.cg_from_big_end")
    offset = np.abs(field("pin_offset") + field("cylinder_offset"))
    bad = (l <= (r + offset) * (1 + _FLAG)) | (cg >= l * (1 - _FLAG)) | (r <= 0) | (cg < 0)
    bad = bad.any(axis=1)
    throw, bank, x = field("throw"), field("bank"), field("x")
    size = np.maximum(np.abs(x).max(axis=1), l.max(axis=1))
    for i in range(count):
        for j in range(i):
            same = (_turns_apart(throw[:, i] - throw[:, j]) & _turns_apart(bank[:, i] - bank[:, j])
                    & (np.abs(x[:, i] - x[:, j]) <= _FLAG * size))
            bad |= same
    return np.flatnonzero(bad)


def _turns_apart(angle: np.ndarray) -> np.ndarray:
    """Whether an angle difference is a whole number of turns (to :data:`_FLAG`)."""
    return np.abs(angle - 2 * np.pi * np.round(angle / (2 * np.pi))) <= _FLAG * 2 * np.pi

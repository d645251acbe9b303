"""Reading the powertrain and its mounts: [powertrain] (mass, CG and inertia
tensor, or the [[powertrain.part]] tables to build them from; named
[[powertrain.point]]s), the [[mount]] tables and [mount_design].

The format is documented in ``docs/scenes.md`` ("Powertrain and mounts"),
the conventions in ``docs/mounts.md``; the dataclasses are in :mod:`.mounts`.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

import numpy as np

from .collector import Collector
from .mounts import (
    MOUNT_OBJECTIVES,
    PRELOAD_AXES,
    STANDARD_GRAVITY,
    Matrix,
    Mount,
    MountDesignRequest,
    MountTable,
    MountVariable,
    Powertrain,
    RigidPart,
    Vector,
    inertia_from_parts,
)
from .schema import MISSING, closest_match, key_path

_POWERTRAIN_KEYS = {"mass", "cg", "inertia", "products", "idle_speed", "drive_torque", "gravity", "part", "point",
                    "spinning_inertia"}
_TOTAL_KEYS = ("mass", "cg", "inertia")
_PART_KEYS = {"name", "mass", "cg", "inertia"}
_POINT_KEYS = {"name", "position"}
_INERTIA_KEYS = {"xx", "yy", "zz", "xy", "xz", "yz"}
_PRODUCTS = ("tensor", "integral")
_MOUNT_KEYS = {"name", "position", "axes", "stiffness", "loss_factor", "damping", "preload_axis", "table"}
_AXES = ("u", "v", "w")
_TABLE_KEYS = {"frequency", "stiffness", "loss_factor"}
_DESIGN_KEYS = {"decoupling", "frequency_band", "max_static_roll", "max_tra_angle", "objective", "variable"}
_VARIABLE_KEYS = {"mount", "stiffness", "position", "angle", "bounds", "group"}
#: Per variable kind: the letters naming its axis, the bounds' dimension, and how a value is shown.
_KINDS: dict[str, tuple[tuple[str, ...], str, str, float]] = {
    "stiffness": (_AXES, "stiffness", "N/mm", 1e3),
    "position": (("x", "y", "z"), "length", "mm", 1e-3),
    "angle": (("x", "y", "z"), "angle", "deg", math.pi / 180),
}
#: Right-handed axes: w = u × v, u = v × w, v = w × u.
_COMPLEMENT = {"w": ("u", "v"), "u": ("v", "w"), "v": ("w", "u")}
#: How far from orthogonal two given mount axes may be (cosine of their angle).
AXES_TOLERANCE = 1e-6
_ZERO = (0.0, 0.0, 0.0)


# -- [powertrain] ----------------------------------------------------------------------------------

def read_powertrain(reader: Collector, data: Mapping) -> Powertrain | None:
    """The [powertrain] table, None if the scene has none."""
    if "powertrain" not in data:
        return None
    table = reader.table(data, "powertrain", "powertrain", _POWERTRAIN_KEYS)
    products = (reader.choice(table, "products", "powertrain", _PRODUCTS, None) if "products" in table else None)
    if "part" in table:
        given = [k for k in _TOTAL_KEYS if k in table]
        if given:
            reader.fail("powertrain", given, "give mass, cg and inertia, or [[powertrain.part]] tables to build "
                        "them from, not both")
        parts = tuple(_part(reader, path, entry, products)
                      for path, entry in reader.array(table["part"], "powertrain.part"))
        _unique(reader, "powertrain.part", [p.name for p in parts], "[[powertrain.part]]")
        if not parts and isinstance(table["part"], list):
            reader.fail("powertrain.part", table["part"], "give at least one [[powertrain.part]]")
        mass, cg, inertia = combine_parts(parts)
        if parts and all(math.isfinite(v) for v in np.ravel(inertia)):
            _check_inertia(reader, "powertrain.part", np.array(inertia), strict=True)
    else:
        parts = ()
        mass = reader.quantity(table, "mass", "powertrain", "mass", positive=True)
        cg = _vector(reader, table, "cg", "powertrain", "length")
        inertia = _inertia(reader, table, "powertrain", products, strict=True)
    idle = reader.quantity(table, "idle_speed", "powertrain", "speed", positive=True) if "idle_speed" in table else None
    torque = (reader.quantity(table, "drive_torque", "powertrain", "moment", positive=True)
              if "drive_torque" in table else None)
    gravity = _vector(reader, table, "gravity", "powertrain", "acceleration", list(STANDARD_GRAVITY))
    spinning = (reader.quantity(table, "spinning_inertia", "powertrain", "inertia", nonnegative=True)
                if "spinning_inertia" in table else None)
    points = tuple(_point(reader, path, entry) for path, entry in reader.array(table.get("point", []),
                                                                              "powertrain.point"))
    _unique(reader, "powertrain.point", [name for name, _ in points], "[[powertrain.point]]")
    return Powertrain(mass, cg, inertia, parts, idle, torque, gravity, points, spinning)


def combine_parts(parts: tuple[RigidPart, ...]) -> tuple[float, Vector, Matrix]:
    """Mass, CG and inertia tensor about the CG of rigid ``parts`` (each
    tensor about its own CG): m = Σ mᵢ, c = Σ mᵢcᵢ/m, I = Σ [Iᵢ + mᵢ(|d|²I₃ − d dᵀ)],
    d = cᵢ − c. NaNs (after a problem) where the parts give none."""
    if not parts:
        return math.nan, (math.nan,) * 3, _matrix(np.full((3, 3), math.nan))
    mass, cg, inertia = inertia_from_parts([p.mass for p in parts], [p.cg for p in parts], [p.inertia for p in parts])
    return mass, (float(cg[0]), float(cg[1]), float(cg[2])), _matrix(inertia)


def _part(reader: Collector, path: str, entry: Mapping, products: str | None) -> RigidPart:
    reader.unknown(entry, path, _PART_KEYS)
    name = reader.string(entry, "name", path)
    mass = reader.quantity(entry, "mass", path, "mass", positive=True)
    cg = _vector(reader, entry, "cg", path, "length")
    inertia = _inertia(reader, entry, path, products, strict=False) if "inertia" in entry else (_ZERO,) * 3
    return RigidPart(name, mass, cg, inertia)


def _point(reader: Collector, path: str, entry: Mapping) -> tuple[str, Vector]:
    reader.unknown(entry, path, _POINT_KEYS)
    return reader.string(entry, "name", path), _vector(reader, entry, "position", path, "length")


def _inertia(reader: Collector, table: Mapping, path: str, products: str | None, strict: bool) -> Matrix:
    """The inertia table at ``path``.inertia as a tensor (products converted
    from the convention ``products`` names), checked to be a body's."""
    where = key_path(path, "inertia")
    raw = reader.table(table, "inertia", where, _INERTIA_KEYS, required=True)
    if not raw:
        return _matrix(np.full((3, 3), math.nan))
    diagonal = [reader.quantity(raw, k, where, "inertia", positive=strict, nonnegative=not strict)
                for k in ("xx", "yy", "zz")]
    xy, xz, yz = (reader.quantity(raw, k, where, "inertia", default=0.0) for k in ("xy", "xz", "yz"))
    nonzero = [k for k, v in (("xy", xy), ("xz", xz), ("yz", yz)) if v != 0]
    if nonzero and products is None:
        reader.fail("powertrain.products", MISSING, f"missing: {where} has nonzero products of inertia "
                    f"({', '.join(nonzero)}): say products = \"tensor\" (xy is the tensor element −∫xy dm) or "
                    "\"integral\" (xy = +∫xy dm, what most CAD tools list as products of inertia)")
    sign = -1.0 if products == "integral" else 1.0
    tensor = np.array([[diagonal[0], sign * xy, sign * xz], [sign * xy, diagonal[1], sign * yz],
                       [sign * xz, sign * yz, diagonal[2]]])
    if np.isfinite(tensor).all():
        _check_inertia(reader, where, tensor, strict)
    return _matrix(tensor)


def _check_inertia(reader: Collector, where: str, tensor: np.ndarray, strict: bool) -> None:
    """Refuse a tensor no body has: a moment larger than the sum of the other
    two (about the given axes, then the principal ones), or not positive
    definite (``strict``; semi-definite allowed for a part: a point mass)."""
    names = ("xx", "yy", "zz")
    diagonal = np.diag(tensor)
    for i, name in enumerate(names):
        others = diagonal.sum() - diagonal[i]
        if diagonal[i] > others * (1 + 1e-12):
            j, k = (n for n in names if n != name)
            reader.fail(f"{where}.{name}", float(diagonal[i]), f"exceeds {j} + {k} = {others:.6g} kg m^2: no body "
                        f"has this inertia (I_{name} ≤ I_{j} + I_{k}); check the values and their units")
            return
    principal = np.linalg.eigvalsh(tensor)
    scale = max(abs(principal).max(), 1e-300)
    shown = ", ".join(f"{p:.6g}" for p in principal)
    if principal[0] < (1e-12 * scale if strict else -1e-12 * scale):
        reader.fail(where, MISSING, f"not positive definite (principal moments {shown} kg m^2): the products of "
                    "inertia are too large for the moments; check them and their sign convention (products = "
                    "\"tensor\" or \"integral\")")
    elif principal[2] > (principal[0] + principal[1]) * (1 + 1e-12):
        reader.fail(where, MISSING, f"principal moments {shown} kg m^2: the largest exceeds the sum of the other two, "
                    "which no body has; check the products of inertia and their sign convention (products = "
                    "\"tensor\" or \"integral\")")


# -- [[mount]] -------------------------------------------------------------------------------------

def read_mounts(reader: Collector, data: Mapping, powertrain: Powertrain | None) -> tuple[Mount, ...]:
    """The [[mount]] tables (at least three, names unique); they need the
    [powertrain] they carry. A [powertrain] without mounts is read and does
    nothing."""
    if "mount" not in data:
        return ()
    mounts = tuple(_mount(reader, path, entry, i) for i, (path, entry) in enumerate(reader.array(data["mount"],
                                                                                                  "mount"), 1))
    if powertrain is None and "powertrain" not in data:
        reader.fail("powertrain", MISSING, "missing required table: the [[mount]] tables need the powertrain they "
                    "carry (mass, cg and inertia, or its parts)")
    if mounts and len(mounts) < 3:
        reader.fail("mount", [m.name for m in mounts], "give at least 3 mounts: a rigid body on fewer point "
                    "mounts is not held in all six degrees of freedom")
    _unique(reader, "mount", [m.name for m in mounts], "[[mount]]")
    return mounts


def _mount(reader: Collector, path: str, entry: Mapping, number: int) -> Mount:
    reader.unknown(entry, path, _MOUNT_KEYS)
    name = reader.string(entry, "name", path, f"mount {number}")
    position = _vector(reader, entry, "position", path, "length")
    axes = _axes(reader, entry, path)
    stiffness = _vector(reader, entry, "stiffness", path, "stiffness", nonnegative=True)
    if all(k == 0 for k in stiffness):
        reader.fail(key_path(path, "stiffness"), entry["stiffness"], "at least one stiffness must be positive")
    loss = _triple(reader, entry, "loss_factor", path, "dimensionless")
    damping = _triple(reader, entry, "damping", path, "damping")
    table = _table(reader, entry, key_path(path, "table"), loss) if "table" in entry else None
    preload = reader.choice(entry, "preload_axis", path, PRELOAD_AXES, "w")
    return Mount(name, position, axes, stiffness, loss, damping, table, preload)


def _axes(reader: Collector, entry: Mapping, path: str) -> Matrix:
    """The mount's axes: two (or three) of u, v, w as plain numbers,
    normalised; the first given is kept, the second made exactly orthogonal
    to it, the third their right-handed complement. Identity if not given."""
    where = key_path(path, "axes")
    if "axes" not in entry:
        return ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0))
    raw = reader.table(entry, "axes", where, set(_AXES))
    found = {k: _direction(reader, raw[k], key_path(where, k)) for k in _AXES if k in raw}
    nan = _matrix(np.full((3, 3), math.nan))
    if len(found) < 2:
        if isinstance(entry["axes"], Mapping):
            reader.fail(where, entry["axes"], "give two of u, v, w (the third follows, right-handed)")
        return nan
    vectors = {k: v for k, v in found.items() if v is not None}
    if len(vectors) < len(found) or not _perpendicular(reader, where, entry["axes"], vectors):
        return nan
    given = list(vectors)
    first, second = given[0], given[1]
    kept = vectors[first]
    other = vectors[second] - np.dot(kept, vectors[second]) * kept
    rows = {first: kept, second: other / np.linalg.norm(other)}
    third = next(k for k in _AXES if k not in (first, second))
    left, right = _COMPLEMENT[third]
    rows[third] = np.cross(rows[left], rows[right])
    if len(given) == 3 and float(np.dot(rows[third], vectors[third])) < 1 - AXES_TOLERANCE:
        reader.fail(where, entry["axes"], f"{third} is not {'×'.join(k for k in _AXES if k != third)} (the axes "
                    "must be right-handed); give two of u, v, w")
        return nan
    return _matrix(np.array([rows[k] for k in _AXES]))


def _perpendicular(reader: Collector, where: str, raw: Any, vectors: dict[str, np.ndarray]) -> bool:
    """Whether the given unit ``vectors`` are perpendicular to :data:`AXES_TOLERANCE` (else a problem)."""
    names = list(vectors)
    for i, first in enumerate(names):
        for second in names[i + 1:]:
            cosine = float(np.dot(vectors[first], vectors[second]))
            if abs(cosine) > 1 - AXES_TOLERANCE:
                reader.fail(where, raw, f"{first} and {second} are parallel: give two perpendicular directions")
                return False
            if abs(cosine) > AXES_TOLERANCE:
                reader.fail(where, raw, f"{first} and {second} are not perpendicular (cosine {cosine:.3g}, at most "
                            f"{AXES_TOLERANCE:g})")
                return False
    return True


def _direction(reader: Collector, raw: Any, where: str) -> np.ndarray | None:
    """A direction: a list of 3 plain numbers, not all 0, normalised."""
    if (not isinstance(raw, list) or len(raw) != 3
            or not all(isinstance(x, (int, float)) and not isinstance(x, bool) and math.isfinite(x) for x in raw)):
        reader.fail(where, raw, "must be a list of 3 finite plain numbers (a direction in the engine frame)")
        return None
    norm = math.hypot(*raw)
    if norm == 0 or not math.isfinite(norm):
        reader.fail(where, raw, "must not be the zero vector" if norm == 0 else "too large to normalise")
        return None
    return np.array([x / norm for x in raw])


def _table(reader: Collector, entry: Mapping, where: str, loss: Vector) -> MountTable:
    """[mount.table]: stiffness and loss factor at increasing frequencies."""
    raw = reader.table(entry, "table", where, _TABLE_KEYS)
    frequency = raw.get("frequency", MISSING)
    if not isinstance(frequency, list) or len(frequency) < 2:
        reader.fail(key_path(where, "frequency"), frequency, "must be a list of at least two frequencies")
        return MountTable((), (), ())
    count = len(frequency)
    freqs = _items(reader, raw, "frequency", where, "frequency", nonnegative=True)
    finite = [f for f in freqs if math.isfinite(f)]
    if len(finite) == count and any(b <= a for a, b in zip(finite, finite[1:])):
        reader.fail(key_path(where, "frequency"), frequency, "frequencies must be strictly increasing")
    stiffness = _rows(reader, raw, "stiffness", where, "stiffness", count, MISSING)
    row = list(loss) if all(math.isfinite(x) for x in loss) else [0.0] * 3  # (a problem of the mount's own)
    losses = _rows(reader, raw, "loss_factor", where, "dimensionless", count, [row] * count)
    return MountTable(tuple(freqs), stiffness, losses)


def _rows(reader: Collector, raw: Mapping, key: str, where: str, dimension: str, count: int,
          default: Any) -> tuple[Vector, ...]:
    """A list of ``count`` rows, each 3 quantities along u, v, w (a loss
    factor's row may be one number)."""
    value = raw.get(key, default)
    if value is MISSING:
        reader.fail(key_path(where, key), MISSING, "missing required key")
        return ()
    if not isinstance(value, list) or len(value) != count:
        reader.fail(key_path(where, key), value, f"must be a list of {count} rows, one per frequency")
        return ()
    rows = {f"{key}[{i}]": row for i, row in enumerate(value, 1)}
    return tuple(_triple(reader, rows, k, where, dimension, required=True) for k in rows)


# -- [mount_design] --------------------------------------------------------------------------------

def read_mount_design(reader: Collector, data: Mapping, mounts: tuple[Mount, ...]) -> MountDesignRequest | None:
    """The [mount_design] table, None if the scene has none; its variables
    name the scene's mounts."""
    if "mount_design" not in data:
        return None
    table = reader.table(data, "mount_design", "mount_design", _DESIGN_KEYS)
    if not mounts and "mount" not in data:
        reader.fail("mount_design", MISSING, "needs the [[mount]] tables it designs (and the [powertrain])")
    decoupling = reader.quantity(table, "decoupling", "mount_design", "dimensionless", default=0.9)
    band = None
    if "frequency_band" in table:
        band = reader.pair(table, "frequency_band", "mount_design", "frequency", MISSING)
        if all(math.isfinite(f) for f in band) and not 0 <= band[0] < band[1]:
            reader.fail("mount_design.frequency_band", table["frequency_band"], "must be [low, high] with 0 ≤ low < "
                        "high")
    roll = (reader.quantity(table, "max_static_roll", "mount_design", "angle", positive=True)
            if "max_static_roll" in table else None)
    tra = (reader.quantity(table, "max_tra_angle", "mount_design", "angle", positive=True)
           if "max_tra_angle" in table else None)
    if tra is not None and tra > math.pi / 2 * (1 + 1e-12):
        reader.fail("mount_design.max_tra_angle", table["max_tra_angle"], "must be at most 90 deg (the angle "
                    "between two axes)")
    objective = reader.choice(table, "objective", "mount_design", MOUNT_OBJECTIVES, "transmitted_force")
    variables = tuple(v for path, entry in reader.array(table.get("variable", []), "mount_design.variable")
                      if (v := _variable(reader, path, entry, mounts)) is not None)
    if "variable" not in table:
        reader.fail("mount_design.variable", MISSING, "give at least one [[mount_design.variable]] (what the "
                    "design may change)")
    _check_groups(reader, variables)
    return MountDesignRequest(variables, None if decoupling == 0 else decoupling, band, roll, tra, objective)


def _variable(reader: Collector, path: str, entry: Mapping, mounts: tuple[Mount, ...]) -> MountVariable | None:
    reader.unknown(entry, path, _VARIABLE_KEYS)
    name = reader.string(entry, "mount", path)
    mount = next((m for m in mounts if m.name == name), None)
    if name and mount is None:
        hint = closest_match(name, {m.name for m in mounts})
        reader.fail(key_path(path, "mount"), name, "names no [[mount]] of the scene"
                    + (f" (did you mean {hint!r}?)" if hint else "")
                    + f"; mounts: {', '.join(repr(m.name) for m in mounts) or 'none'}")
    kinds = [k for k in _KINDS if k in entry]
    if len(kinds) != 1:
        reader.fail(path, sorted(entry), "give one of stiffness = \"u\"|\"v\"|\"w\", position = \"x\"|\"y\"|\"z\" "
                    "or angle = \"x\"|\"y\"|\"z\"")
        return None
    kind = kinds[0]
    letters, dimension, unit, scale = _KINDS[kind]
    letter = reader.choice(entry, kind, path, letters, None)
    if letter is None:
        return None
    axis = letters.index(letter)
    lower, upper = reader.pair(entry, "bounds", path, dimension, MISSING)
    where = key_path(path, "bounds")
    if kind == "stiffness" and not (lower > 0 or math.isnan(lower)):
        reader.fail(where, entry["bounds"], "stiffness bounds must be positive")
    elif math.isfinite(lower) and math.isfinite(upper):
        if not lower < upper:
            reader.fail(where, entry["bounds"], "must be [lower, upper] with lower < upper")
        elif mount is not None:
            nominal = {"stiffness": mount.stiffness[axis], "position": mount.position[axis], "angle": 0.0}[kind]
            if math.isfinite(nominal) and not lower <= nominal <= upper:
                reader.fail(where, entry["bounds"], f"the value as written, {nominal / scale:.6g} {unit}"
                            + (" (angles are relative to the axes as written)" if kind == "angle" else "")
                            + ", lies outside the bounds: widen them or change the mount")
    group = reader.string(entry, "group", path) if "group" in entry else None
    return MountVariable(name, kind, axis, lower, upper, group)


def _check_groups(reader: Collector, variables: tuple[MountVariable, ...]) -> None:
    """Variables named twice; groups whose members differ in kind or bounds."""
    seen: set[tuple[str, str, int]] = set()
    for variable in variables:
        key = (variable.mount, variable.kind, variable.axis)
        if key in seen:
            reader.fail("mount_design.variable", f"{variable.mount}: {variable.kind} {variable.axis + 1}",
                        "this variable is given twice")
        seen.add(key)
    groups: dict[str, list[MountVariable]] = {}
    for variable in variables:
        if variable.group is not None:
            groups.setdefault(variable.group, []).append(variable)
    for group, members in sorted(groups.items()):
        if len({m.kind for m in members}) > 1:
            reader.fail("mount_design.variable", group, "the variables of a group share one value: they must be "
                        f"of one kind (this group mixes {', '.join(sorted({m.kind for m in members}))})")
        elif len({(m.lower, m.upper) for m in members}) > 1:
            reader.fail("mount_design.variable", group, "the variables of a group share one value: give them the "
                        "same bounds")


# -- shared ----------------------------------------------------------------------------------------

def _vector(reader: Collector, table: Mapping, key: str, path: str, dimension: str, default: Any = MISSING,
            nonnegative: bool = False) -> Vector:
    """A list of 3 quantities (engine x, y, z or local u, v, w); nans after a problem."""
    if key not in table and default is MISSING:
        reader.fail(key_path(path, key), MISSING, "missing required key")
        return (math.nan,) * 3
    value = table.get(key, default)
    if not isinstance(value, list) or len(value) != 3:
        reader.fail(key_path(path, key), value, "must be a list of 3 quantities")
        return (math.nan,) * 3
    first, second, third = _items(reader, {key: value}, key, path, dimension, nonnegative)
    return first, second, third


def _triple(reader: Collector, table: Mapping, key: str, path: str, dimension: str,
            required: bool = False) -> Vector:
    """A number for all of u, v, w or a list of 3, each ≥ 0 (default 0)."""
    if key not in table:
        if required:
            reader.fail(key_path(path, key), MISSING, "missing required key")
        return _ZERO
    value = table[key]
    if isinstance(value, list):
        return _vector(reader, table, key, path, dimension, nonnegative=True)
    single = reader.quantity(table, key, path, dimension, nonnegative=True)
    return single, single, single


def _items(reader: Collector, table: Mapping, key: str, path: str, dimension: str,
           nonnegative: bool = False) -> list[float]:
    """The quantities of the list ``table[key]``, keyed ``key[1]``, ``key[2]`` …"""
    items = {f"{key}[{i}]": v for i, v in enumerate(table[key], 1)}
    return [reader.quantity(items, k, path, dimension, nonnegative=nonnegative) for k in items]


def _unique(reader: Collector, path: str, names: list[str], tables: str) -> None:
    for name in sorted({n for n in names if n and names.count(n) > 1}):
        reader.fail(path, name, f"two {tables} tables have this name; names must be unique")


def _matrix(values: np.ndarray) -> Matrix:
    rows = [tuple(float(x) + 0.0 for x in row) for row in values]  # + 0.0: no −0.0 from a cross product
    return (rows[0][0], rows[0][1], rows[0][2]), (rows[1][0], rows[1][1], rows[1][2]), (rows[2][0], rows[2][1],
                                                                                       rows[2][2])

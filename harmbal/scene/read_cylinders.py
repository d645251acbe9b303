"""Reading the crank train: the shared [geometry], [piston], [rod] and
[[throw_unbalance]] tables, each [[cylinder]] with its overrides, static
unbalances (also those of [[crankshaft_unbalance]]) and the checks that no
two cylinders coincide."""

from __future__ import annotations

import math
from typing import Any, Mapping

from .collector import Collector, SceneContext
from .read_gas import GAS_KEYS, merge_gas, read_gas
from .schema import MISSING, ConRod, Cylinder, Model, Piston, Unbalance, key_path

_GEOMETRY_KEYS = {"crank_radius", "rod_length", "pin_offset", "cylinder_offset"}
_PISTON_KEYS = {"mass", "cg_offset"}
_ROD_RIGID_KEYS = {"mass", "cg_from_big_end", "cg_offset", "inertia"}
_ROD_SPLIT_KEYS = {"mass_big_end", "mass_small_end"}
_CYLINDER_KEYS = {"label", "throw", "bank", "axial_position", "geometry", "piston", "rod", "throw_unbalance", "gas"}
_UNBALANCE_KEYS = {"unbalance", "mass", "radius", "angle"}


def read_shared_tables(reader: Collector, data: Mapping) -> dict[str, dict | None]:
    """The shared [geometry], [piston], [rod] and [gas] tables every cylinder overrides."""
    return {
        "geometry": reader.table(data, "geometry", "geometry", _GEOMETRY_KEYS),
        "piston": reader.table(data, "piston", "piston", _PISTON_KEYS),
        "rod": reader.table(data, "rod", "rod", _ROD_RIGID_KEYS | _ROD_SPLIT_KEYS),
        "gas": reader.table(data, "gas", "gas", GAS_KEYS) if "gas" in data else None,
    }


def read_cylinders(reader: Collector, context: SceneContext, raw: Any, shared: dict, shared_unbalances: Any,
                   model: Model, cycle: int = 4) -> tuple[Cylinder, ...]:
    """Every [[cylinder]] (``raw``) with the ``shared`` tables
    (:func:`read_shared_tables`) and [[throw_unbalance]] it overrides; their
    gas tables share ``context``'s trace files and gases."""
    if raw is MISSING:
        reader.fail("cylinder", MISSING, "missing: give at least one [[cylinder]]")
        return ()
    if not isinstance(raw, list) or not raw or not all(isinstance(c, Mapping) for c in raw):
        reader.fail("cylinder", raw, "must be a non-empty array of tables ([[cylinder]])")
        return ()
    cylinders = []
    for i, entry in enumerate(raw):
        path = f"cylinder[{i + 1}]"
        reader.unknown(entry, path, _CYLINDER_KEYS)
        cylinders.append(_cylinder(reader, context, entry, path, i, shared, shared_unbalances, model, cycle))
    _check_distinct(reader, cylinders)
    return tuple(cylinders)


def _cylinder(reader: Collector, context: SceneContext, entry: Mapping, path: str, index: int, shared: dict,
              shared_unbalances: Any, model: Model, cycle: int = 4) -> Cylinder:
    label = entry.get("label", str(index + 1))
    if not isinstance(label, (str, int)) or isinstance(label, bool):
        reader.fail(key_path(path, "label"), label, "must be a string")
    label = str(label)
    throw = reader.quantity(entry, "throw", path, "angle", default=0.0)
    bank = reader.quantity(entry, "bank", path, "angle", default=0.0)
    x = reader.quantity(entry, "axial_position", path, "length", default=0.0)

    def merged(name: str, allowed: set[str]) -> tuple[dict, dict[str, str]]:
        """Shared table overlaid by the cylinder's own, with the section
        each key was written in (missing keys are reported at the shared
        section, once for all cylinders)."""
        own = reader.table(entry, name, key_path(path, name), allowed)
        where = {k: key_path(path, name) if k in own else name for k in {**shared[name], **own}}
        return {**shared[name], **own}, where

    geometry, gwhere = merged("geometry", _GEOMETRY_KEYS)
    r = reader.quantity(geometry, "crank_radius", gwhere.get("crank_radius", "geometry"), "length", positive=True)
    l = reader.quantity(geometry, "rod_length", gwhere.get("rod_length", "geometry"), "length", positive=True)
    e = reader.quantity(geometry, "pin_offset", gwhere.get("pin_offset", "geometry"), "length", default=0.0)
    h = reader.quantity(geometry, "cylinder_offset", gwhere.get("cylinder_offset", "geometry"), "length", default=0.0)
    if all(math.isfinite(v) for v in (r, l, e, h)) and r > 0 and l > 0 and not l > r + abs(e + h):
        own = sorted(k for k, w in gwhere.items() if w != "geometry")
        if own and "rod_length" not in own:  # the cylinder's own radius or offsets break it: name them
            key, value = key_path(path, "geometry"), {k: geometry[k] for k in own}
        else:
            key, value = key_path(gwhere["rod_length"], "rod_length"), geometry["rod_length"]
        reader.fail(key, value,
                    f"the crank train cannot assemble: rod length {l * 1e3:.6g} mm must exceed crank radius "
                    f"+ |pin offset + cylinder offset| = {(r + abs(e + h)) * 1e3:.6g} mm")

    piston_t, pwhere = merged("piston", _PISTON_KEYS)
    piston_mass = reader.quantity(piston_t, "mass", pwhere.get("mass", "piston"), "mass", positive=True)
    pcg = _pair_at(reader, piston_t, "cg_offset", pwhere, "piston")
    piston = Piston(piston_mass, *pcg)

    rod_t, rwhere = merged("rod", _ROD_RIGID_KEYS | _ROD_SPLIT_KEYS)
    rod = _rod(reader, rod_t, rwhere, path, l, model)

    unbalances = entry.get("throw_unbalance", shared_unbalances)
    upath = key_path(path, "throw_unbalance") if "throw_unbalance" in entry else "throw_unbalance"
    throw_unbalances = tuple(
        Unbalance(u.unbalance, u.angle, x + u.x) for u in read_unbalances(reader, unbalances, upath, "axial_offset")
    )
    gas = read_gas(reader, context, merge_gas(reader, shared["gas"], entry, path), cycle)
    return Cylinder(label=label, throw=throw, bank=bank, x=x, crank_radius=r, rod_length=l, pin_offset=e,
                    cylinder_offset=h, piston=piston, rod=rod, throw_unbalances=throw_unbalances, gas=gas)


def _pair_at(reader: Collector, table: dict, key: str, where: dict[str, str], section: str) -> tuple[float, float]:
    return reader.pair(table, key, where.get(key, section), "length", [0, 0])


def _rod(reader: Collector, table: dict, where: dict[str, str], path: str, length: float, model: Model) -> ConRod:
    """A rigid rod, or a two-point split converted to mass and CG."""
    split_keys = _ROD_SPLIT_KEYS & table.keys()
    rigid_keys = _ROD_RIGID_KEYS & table.keys()
    # Problems of the rod as a whole go where the cylinder wrote its rod
    # table, or to the shared [rod] table.
    section = key_path(path, "rod") if key_path(path, "rod") in where.values() else "rod"
    if split_keys and rigid_keys:
        reader.fail(section, sorted(table), "give the rod either as a rigid body (mass, cg_from_big_end, "
                    "inertia) or as a two-point split (mass_big_end, mass_small_end), not both")
        return ConRod(math.nan, math.nan)
    if split_keys:
        big = reader.quantity(table, "mass_big_end", where.get("mass_big_end", "rod"), "mass", positive=True)
        small = reader.quantity(table, "mass_small_end", where.get("mass_small_end", "rod"), "mass", positive=True)
        if model.rod != "two_point":
            reader.fail("model.rod", model.rod, f"{section} is given as a two-point split, which has no moment "
                        "of inertia; use rod = \"two_point\" or give mass, cg_from_big_end and inertia")
        return ConRod(big + small, length * small / (big + small))
    mass = reader.quantity(table, "mass", where.get("mass", "rod"), "mass", positive=True)
    cg = reader.quantity(table, "cg_from_big_end", where.get("cg_from_big_end", "rod"), "length", nonnegative=True)
    if math.isfinite(cg) and math.isfinite(length) and cg > length:
        reader.fail(key_path(where["cg_from_big_end"], "cg_from_big_end"), table["cg_from_big_end"],
                    f"must not exceed the rod length of {path} ({length * 1e3:.6g} mm)")
    lateral = reader.quantity(table, "cg_offset", where.get("cg_offset", "rod"), "length", default=0.0)
    inertia = None
    if "inertia" in table:
        inertia = reader.quantity(table, "inertia", where.get("inertia", "rod"), "inertia", positive=True)
    elif model.rod != "two_point":
        reader.fail(key_path(section, "inertia"), MISSING,
                    f"missing: model.rod = {model.rod!r} needs the rod's moment of inertia about its CG")
    return ConRod(mass, cg, lateral, inertia)


def read_unbalance_size(reader: Collector, entry: Mapping, where: str) -> float:
    """Mass × radius [kg m], given as ``unbalance`` or as ``mass`` and ``radius``."""
    if "unbalance" in entry and ("mass" in entry or "radius" in entry):
        reader.fail(where, sorted(entry), "give unbalance (mass x radius) or mass and radius, not both")
        return math.nan
    if "unbalance" in entry or not ("mass" in entry or "radius" in entry):
        return reader.quantity(entry, "unbalance", where, "unbalance", positive=True)
    return (reader.quantity(entry, "mass", where, "mass", positive=True)
            * reader.quantity(entry, "radius", where, "length", positive=True))


def read_unbalances(reader: Collector, raw: Any, path: str, position_key: str) -> list[Unbalance]:
    """Static unbalances (a table or an array of tables at ``path``), each at
    its ``position_key`` (an axial position or offset)."""
    entries = [raw] if isinstance(raw, Mapping) else raw
    if not isinstance(entries, list) or not all(isinstance(u, Mapping) for u in entries):
        reader.fail(path, raw, "must be a table or an array of tables")
        return []
    result = []
    for i, entry in enumerate(entries):
        where = path if isinstance(raw, Mapping) else f"{path}[{i + 1}]"
        reader.unknown(entry, where, _UNBALANCE_KEYS | {position_key})
        u = read_unbalance_size(reader, entry, where)
        angle = reader.quantity(entry, "angle", where, "angle", default=0.0)
        x = reader.quantity(entry, position_key, where, "length", default=0.0)
        result.append(Unbalance(u, angle, x))
    return result


def _check_distinct(reader: Collector, cylinders: list[Cylinder]) -> None:
    seen_labels: dict[str, int] = {}
    seen_places: dict[tuple, int] = {}
    # Axial positions compare to 1e-12 of the engine's size, which may be anything in the lengths' range.
    size = max((abs(v) for c in cylinders for v in (c.x, c.rod_length) if math.isfinite(v)), default=1.0) or 1.0
    for i, c in enumerate(cylinders, start=1):
        if c.label in seen_labels:
            reader.fail(f"cylinder[{i}].label", c.label, f"duplicate of cylinder[{seen_labels[c.label]}]")
        seen_labels.setdefault(c.label, i)
        place = (round(math.remainder(c.throw, 2 * math.pi), 12), round(math.remainder(c.bank, 2 * math.pi), 12),
                 round(c.x / size, 12))
        if place in seen_places:
            reader.fail(f"cylinder[{i}]", {"throw": c.throw, "bank": c.bank, "axial_position": c.x},
                        f"duplicate cylinder: same throw, bank and axial position as cylinder[{seen_places[place]}]")
        seen_places.setdefault(place, i)

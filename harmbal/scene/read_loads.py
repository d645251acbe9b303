"""Reading [loads]: main-bearing positions, static loads on the crankshaft,
balancer interface data ([[loads.element]], naming a balancer element by its
label), the fastener speed and a speed ramp ([loads.ramp]).

The format is documented in ``docs/scenes.md`` and the method in ``docs/loads.md``.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

from .collector import Collector
from .elements import Shaft
from .interfaces import GRAVITY, ElementLoads, LoadsRequest, Ramp, StaticLoad
from .schema import MISSING, key_path

_LOADS_KEYS = {"main_bearings", "static_load", "element", "max_speed", "ramp"}
_STATIC_KEYS = {"label", "force", "mass", "axial_position"}
_ELEMENT_KEYS = {"label", "bearings", "inertia", "fasteners", "static_load"}
_RAMP_KEYS = {"from", "to", "time"}


def read_loads(reader: Collector, data: Mapping, shafts: tuple[Shaft, ...]) -> LoadsRequest | None:
    """The [loads] table, None if the scene has none; element labels are
    resolved against ``shafts`` (the scene's balancer elements)."""
    if "loads" not in data:
        return None
    table = reader.table(data, "loads", "loads", _LOADS_KEYS)
    bearings: tuple[float, ...] = ()
    if "main_bearings" in table:
        raw = table["main_bearings"]
        if not isinstance(raw, list) or len(raw) < 2:
            reader.fail("loads.main_bearings", raw, "must be a list of at least two axial positions")
        else:
            bearings = reader.quantity_list(table, "main_bearings", "loads", "length", len(raw), MISSING)
            _distinct(reader, "loads.main_bearings", raw, bearings)
    static = _static_loads(reader, table.get("static_load", []), "loads.static_load")
    if static and not bearings:
        reader.fail("loads.static_load", table["static_load"], "needs loads.main_bearings (the crankshaft's "
                    "bearings carry it)")
    elements = tuple(_element(reader, path, entry, shafts) for path, entry in reader.array(table.get("element", []),
                                                                                           "loads.element"))
    labels = [e.label for e in elements]
    for label in sorted({x for x in labels if labels.count(x) > 1}):
        reader.fail("loads.element", label, "two [[loads.element]] entries name this element")
    max_speed = (reader.quantity(table, "max_speed", "loads", "speed", positive=True)
                 if "max_speed" in table else None)
    ramp = None
    if "ramp" in table:
        ramp_table = reader.table(table, "ramp", "loads.ramp", _RAMP_KEYS)
        start = reader.quantity(ramp_table, "from", "loads.ramp", "speed", nonnegative=True)
        end = reader.quantity(ramp_table, "to", "loads.ramp", "speed", nonnegative=True)
        time = reader.quantity(ramp_table, "time", "loads.ramp", "time", positive=True)
        ramp = Ramp(start, end, time)
        if not any(e.inertia is not None for e in elements):
            reader.fail("loads.ramp", table["ramp"], "needs the inertia of at least one balancer element "
                        "([[loads.element]] inertia)")
    return LoadsRequest(bearings, static, elements, max_speed, ramp)


def _distinct(reader: Collector, key: str, raw: Any, positions: tuple[float, ...]) -> None:
    finite = [p for p in positions if math.isfinite(p)]
    if len(set(finite)) != len(finite):
        reader.fail(key, raw, "axial positions must be distinct")


def _static_loads(reader: Collector, raw: Any, path: str) -> tuple[StaticLoad, ...]:
    """Static forces given as ``force`` = [y, z] or as a ``mass`` (its
    weight, along −z), at an ``axial_position``."""
    loads: list[StaticLoad] = []
    for where, entry in reader.array(raw, path):
        reader.unknown(entry, where, _STATIC_KEYS)
        label = reader.string(entry, "label", where, f"static load {len(loads) + 1}")
        if ("force" in entry) == ("mass" in entry):
            reader.fail(where, sorted(entry), "give force = [y, z] or mass (its weight along −z), one of them")
            force = (math.nan, math.nan)
        elif "force" in entry:
            force = reader.pair(entry, "force", where, "force", MISSING)
        else:
            force = (0.0, -GRAVITY * reader.quantity(entry, "mass", where, "mass", positive=True))
        x = reader.quantity(entry, "axial_position", where, "length")
        loads.append(StaticLoad(label, force, x))
    return tuple(loads)


def _element(reader: Collector, path: str, entry: Mapping, shafts: tuple[Shaft, ...]) -> ElementLoads:
    """One [[loads.element]]: the balancer element it names (a Lanchester
    pair's label names both its shafts) and its interface data."""
    reader.unknown(entry, path, _ELEMENT_KEYS)
    label = reader.string(entry, "label", path)
    named = tuple(s for s in shafts if s.label == label or (s.label.startswith(label + " (")
                                                            and s.label.endswith("×)")))
    if label and not named:
        known = ", ".join(repr(s.label) for s in shafts) or "none"
        reader.fail(key_path(path, "label"), label, f"names no balancer element of the scene (elements: {known})")
    on_crank = any(s.on_crank for s in named)
    bearings = None
    if "bearings" in entry:
        bearings = reader.pair(entry, "bearings", path, "length", MISSING)
        _distinct(reader, key_path(path, "bearings"), entry["bearings"], bearings)
    inertia = reader.quantity(entry, "inertia", path, "inertia", positive=True) if "inertia" in entry else None
    fasteners = reader.integer(entry, "fasteners", path, None, 1)
    static = _static_loads(reader, entry.get("static_load", []), key_path(path, "static_load"))
    if on_crank:
        for key in ("bearings", "static_load"):
            if key in entry:
                reader.fail(key_path(path, key), entry[key], "the element turns with the crankshaft: its loads go "
                            "to the main bearings (loads.main_bearings, loads.static_load)")
    elif static and bearings is None:
        reader.fail(key_path(path, "static_load"), entry["static_load"], "needs the shaft's bearings")
    return ElementLoads(label, tuple(s.label for s in named), bearings, inertia, fasteners, static)

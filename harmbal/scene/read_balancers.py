"""Reading the balancer elements: [crankshaft] (CAD mass data),
[[counterweight]], [[balance_shaft]], [[lanchester_pair]] and
[[lever_balancer]] (refused unless its loop closes), with the checks that
span them all (unique labels, no aliasing into the orders kept)."""

from __future__ import annotations

import math
from typing import Any, Mapping

from .collector import Collector
from .elements import (
    ASSEMBLY_MODES,
    PRODUCT_CONVENTIONS,
    TRANSMISSION_WARNING,
    LeverBalancer,
    LinkBody,
    Shaft,
    ShaftUnbalance,
    closure,
    closure_message,
    couple_from_moment,
    couple_from_products,
)
from .ranges import KEY_RANGES, MAX_RATIO
from .read_cylinders import read_unbalance_size
from .read_shapes import BLANK_KEYS, read_blank
from .schema import MISSING, Model, Sampling, key_path

_PRODUCT_KEYS = {"xy", "xz", "convention"}
_SHAFT_KEYS = {"label", "ratio", "axis_position", "unbalance", "couple", "couple_angle", "products_of_inertia"}
_CRANKSHAFT_KEYS = {"mass", "cg_offset", "axial_position", "products_of_inertia"}
_LANCHESTER_KEYS = {"label", "order", "unbalance", "mass", "radius", "angle", "phase", "axial_position", "heights",
                    "lateral"} | BLANK_KEYS
#: Keys of one of a balance shaft's unbalances: mass × radius or a blank.
_SHAFT_UNBALANCE_KEYS = {"unbalance", "mass", "radius", "angle", "axial_position"} | BLANK_KEYS
_LEVER_KEYS = {"label", "axial_position", "pin_radius", "pin_angle", "pivot", "rocker_length", "coupler_length",
               "assembly", "rocker", "coupler"}
_LINK_KEYS = {"mass", "cg", "inertia"}
_COUNTERWEIGHT_KEYS = {"label", "unbalance", "mass", "radius", "angle", "axial_position"} | BLANK_KEYS


def read_balancer_elements(reader: Collector, data: Mapping, sense: int, model: Model,
                           sampling: Sampling) -> tuple[tuple[Shaft, ...], tuple[LeverBalancer, ...]]:
    """Every balancer element of the scene: the shafts (crankshaft data,
    counterweights, balance shafts, Lanchester pairs) and the levers."""
    shafts = (_crankshaft(reader, data, sense) + _counterweights(reader, data.get("counterweight", []))
              + _balance_shafts(reader, data.get("balance_shaft", []), sense)
              + _lanchester_pairs(reader, data.get("lanchester_pair", [])))
    levers = _lever_balancers(reader, data.get("lever_balancer", []), sense)
    # Ratios are at most MAX_RATIO and max_order at most MAX_SAMPLES / 4 (their ranges), so the sampling
    # harmbal chooses always resolves the elements; samples_per_rev given may not (checked once it is valid).
    fastest = max((abs(s.ratio) for s in shafts), default=0)
    samples, max_order = sampling.samples_per_rev, sampling.max_order
    if (shafts and samples is not None and samples >= 2 * max_order + 2 and "balancers" in model.effects
            and samples <= fastest + max_order):
        reader.fail("sampling.samples_per_rev", samples,
                    f"a balancer element turning at {fastest}× would alias into the orders kept: must be more "
                    f"than its |ratio| + max_order = {fastest + max_order}")
    labels = [s.label for s in shafts] + [lever.label for lever in levers]
    for label in sorted({x for x in labels if labels.count(x) > 1}):
        reader.fail("balancer elements", label, "two balancer elements have this label; labels must be unique")
    return shafts, levers


def _couple(reader: Collector, entry: Mapping, path: str, sense: int) -> complex:
    """A couple unbalance as a moment with its angle or as products of
    inertia with a named convention (not both)."""
    if "couple" in entry and "products_of_inertia" in entry:
        reader.fail(path, sorted(entry), "give couple (with couple_angle) or products_of_inertia, not both")
        return 0j
    if "couple" in entry:
        size = reader.quantity(entry, "couple", path, "inertia", nonnegative=True)
        return couple_from_moment(size, reader.quantity(entry, "couple_angle", path, "angle", default=0.0))
    if "couple_angle" in entry:
        reader.fail(key_path(path, "couple_angle"), entry["couple_angle"], "only with couple")
    if "products_of_inertia" not in entry:
        return 0j
    where = key_path(path, "products_of_inertia")
    products = reader.table(entry, "products_of_inertia", where, _PRODUCT_KEYS)
    if "convention" not in products:
        reader.fail(key_path(where, "convention"), MISSING,
                    "missing: name the sign convention, 'integral' (J_xy = +∫xy dm) or 'tensor' (−∫xy dm)")
        return 0j
    convention = reader.choice(products, "convention", where, PRODUCT_CONVENTIONS, "integral")
    j_xy = reader.quantity(products, "xy", where, "inertia", default=0.0)
    j_xz = reader.quantity(products, "xz", where, "inertia", default=0.0)
    return couple_from_products(j_xy, j_xz, convention, sense)


def _crankshaft(reader: Collector, data: Mapping, sense: int) -> tuple[Shaft, ...]:
    """The crankshaft's CAD mass data as a shaft turning with the crank."""
    if "crankshaft" not in data:
        return ()
    entry = reader.table(data, "crankshaft", "crankshaft", _CRANKSHAFT_KEYS)
    mass = reader.quantity(entry, "mass", "crankshaft", "mass", positive=True)
    y, z = reader.position(entry, "cg_offset", "crankshaft")
    x = reader.quantity(entry, "axial_position", "crankshaft", "length", default=0.0)
    w = complex(z, -sense * y)  # w = z + i·t, t = −sense·y
    unbalances = (ShaftUnbalance(mass * abs(w), math.atan2(w.imag, w.real), x),) if w else ()
    return (Shaft("crankshaft", 1, 0.0, 0.0, unbalances, _couple(reader, entry, "crankshaft", sense)),)


def _counterweights(reader: Collector, raw: Any) -> tuple[Shaft, ...]:
    """Crank counterweights: static unbalances turning with the crank on
    its axis, angles relative to throw 1."""
    shafts: list[Shaft] = []
    for path, entry in reader.array(raw, "counterweight"):
        reader.unknown(entry, path, _COUNTERWEIGHT_KEYS)
        label = reader.string(entry, "label", path, f"counterweight {len(shafts) + 1}")
        u, angle = _weight(reader, entry, path)
        x = reader.quantity(entry, "axial_position", path, "length", default=0.0)
        shafts.append(Shaft(label, 1, 0.0, 0.0, (ShaftUnbalance(u, angle, x),)))
    return tuple(shafts)


def _weight(reader: Collector, entry: Mapping, path: str) -> tuple[float, float]:
    """Size [kg m] and angle [rad] of a static unbalance given as
    ``unbalance`` or ``mass`` × ``radius`` at ``angle``, or as a blank
    whose u axis points at ``angle`` (its unbalance then turned by its own
    direction in the blank's frame)."""
    angle = reader.quantity(entry, "angle", path, "angle", default=0.0)
    if not BLANK_KEYS & set(entry):
        return read_unbalance_size(reader, entry, path), angle
    if {"unbalance", "mass", "radius"} & set(entry):
        reader.fail(path, sorted(entry), "give the unbalance (or mass and radius) or a blank (density, "
                    "thickness and [[...shape]] tables), not both")
        return math.nan, angle
    blank = read_blank(reader, entry, path)
    if blank is None:
        return math.nan, angle
    return blank.unbalance, angle + blank.unbalance_angle


def _shaft_unbalances(reader: Collector, raw: Any, path: str) -> tuple[ShaftUnbalance, ...]:
    """A balance shaft's static unbalances (a table or an array of tables), each as mass × radius or a blank."""
    entries = [raw] if isinstance(raw, Mapping) else raw
    if not isinstance(entries, list) or not all(isinstance(u, Mapping) for u in entries):
        reader.fail(path, raw, "must be a table or an array of tables")
        return ()
    result = []
    for i, entry in enumerate(entries):
        where = path if isinstance(raw, Mapping) else f"{path}[{i + 1}]"
        reader.unknown(entry, where, _SHAFT_UNBALANCE_KEYS)
        u, angle = _weight(reader, entry, where)
        result.append(ShaftUnbalance(u, angle, reader.quantity(entry, "axial_position", where, "length", default=0.0)))
    return tuple(result)


def _balance_shafts(reader: Collector, raw: Any, sense: int) -> tuple[Shaft, ...]:
    shafts: list[Shaft] = []
    for path, entry in reader.array(raw, "balance_shaft"):
        reader.unknown(entry, path, _SHAFT_KEYS)
        label = entry.get("label", f"shaft {len(shafts) + 1}")
        ratio = entry.get("ratio", MISSING)
        if ratio is MISSING:
            reader.fail(key_path(path, "ratio"), ratio, "missing: the speed ratio n (negative turns against the crank)")
            ratio = 1
        elif isinstance(ratio, bool) or not isinstance(ratio, int) or ratio == 0:
            reader.fail(key_path(path, "ratio"), ratio, "must be a non-zero integer (negative turns against the crank)")
            ratio = 1
        elif abs(ratio) > MAX_RATIO:
            reader.fail(key_path(path, "ratio"), ratio,
                        f"|ratio| must be at most {MAX_RATIO}: {KEY_RANGES['ratio'].why}")
            ratio = 1
        y, z = reader.position(entry, "axis_position", path)
        unbalances = _shaft_unbalances(reader, entry.get("unbalance", []), key_path(path, "unbalance"))
        shafts.append(Shaft(str(label), ratio, y, z, unbalances, _couple(reader, entry, path, sense)))
    return tuple(shafts)


def _lanchester_pairs(reader: Collector, raw: Any) -> tuple[Shaft, ...]:
    """Each pair: two shafts at +n and −n with equal unbalances pointing
    the same way at θ = 0, at given heights (z) and lateral positions (y)."""
    shafts: list[Shaft] = []
    for path, entry in reader.array(raw, "lanchester_pair"):
        reader.unknown(entry, path, _LANCHESTER_KEYS)
        label = str(entry.get("label", f"Lanchester pair {len(shafts) // 2 + 1}"))
        if "order" in entry:
            order = reader.integer(entry, "order", path, 1, 1, maximum=MAX_RATIO)
        else:
            reader.fail(key_path(path, "order"), MISSING, "missing: the order n the pair cancels (shafts at ±n×)")
            order = 1
        u, angle = _weight(reader, entry, path)
        phase = reader.quantity(entry, "phase", path, "angle", default=0.0)
        x = reader.quantity(entry, "axial_position", path, "length", default=0.0)
        heights = reader.pair(entry, "heights", path, "length", [0, 0])
        lateral = reader.pair(entry, "lateral", path, "length", [0, 0])
        for ratio, y, z, side, sign in ((order, lateral[0], heights[0], "+", 1), (-order, lateral[1], heights[1],
                                                                                  "−", -1)):
            shafts.append(Shaft(f"{label} ({side}{order}×)", ratio, y, z,
                                (ShaftUnbalance(u, angle + sign * phase, x),)))
    return tuple(shafts)


def _lever_balancers(reader: Collector, raw: Any, sense: int) -> tuple[LeverBalancer, ...]:
    """Four-bar lever balancers, refused unless the loop closes at every
    crank angle (with the link lengths and the failing angle named)."""
    levers: list[LeverBalancer] = []
    for path, entry in reader.array(raw, "lever_balancer"):
        reader.unknown(entry, path, _LEVER_KEYS)
        label = reader.string(entry, "label", path, f"lever balancer {len(levers) + 1}")
        x = reader.quantity(entry, "axial_position", path, "length", default=0.0)
        radius = reader.quantity(entry, "pin_radius", path, "length", positive=True)
        angle = reader.quantity(entry, "pin_angle", path, "angle")
        pivot = reader.pair(entry, "pivot", path, "length", MISSING)
        rocker_length = reader.quantity(entry, "rocker_length", path, "length", positive=True)
        coupler_length = reader.quantity(entry, "coupler_length", path, "length", positive=True)
        assembly = "ahead"
        if "assembly" in entry:
            assembly = reader.choice(entry, "assembly", path, tuple(ASSEMBLY_MODES), "ahead")
        else:
            reader.fail(key_path(path, "assembly"), MISSING, "missing: the assembly mode, \"ahead\" or \"behind\" "
                        "(B ahead of or behind the line from the pivot A to the pin C, in the direction of rotation)")
        bodies = {}
        for name in ("rocker", "coupler"):
            where = key_path(path, name)
            table = reader.table(entry, name, where, _LINK_KEYS, required=True)
            bodies[name] = LinkBody(reader.quantity(table, "mass", where, "mass", nonnegative=True),
                                    reader.pair(table, "cg", where, "length", [0, 0]),
                                    reader.quantity(table, "inertia", where, "inertia", nonnegative=True))
        lever = LeverBalancer(label, x, radius, angle, pivot, rocker_length, coupler_length, assembly,
                              bodies["rocker"], bodies["coupler"])
        values = (x, radius, angle, *pivot, rocker_length, coupler_length)
        if all(math.isfinite(v) for v in values) and radius > 0 and rocker_length > 0 and coupler_length > 0:
            check = closure(lever, sense)
            if check.failure is not None:
                reader.fail(path, {"pivot": entry.get("pivot"), "pin_radius": entry.get("pin_radius"),
                                   "rocker_length": entry.get("rocker_length"),
                                   "coupler_length": entry.get("coupler_length")}, closure_message(lever, check))
            elif check.min_transmission_angle < TRANSMISSION_WARNING and check.distance[1] > check.distance[0]:
                # (a pivot on the crank axis turns the links rigidly: a constant γ is no toggle)
                reader.warnings.append(
                    f"{reader.source}: {path} ({label}): minimum transmission angle "
                    f"{math.degrees(check.min_transmission_angle):.3g}° at θ = "
                    f"{math.degrees(check.min_transmission_theta):.6g}° (below "
                    f"{math.degrees(TRANSMISSION_WARNING):.0f}°): close to the toggle position, where the links' "
                    "accelerations and the joint forces grow without bound")
        levers.append(lever)
    return tuple(levers)

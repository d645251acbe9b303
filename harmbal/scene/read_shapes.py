"""Reading shapes: a counterweight's blank (density, thickness and
[[...shape]] tables) and the [[outline]] tables of the clearance check."""

from __future__ import annotations

import math
from typing import Any, Mapping

from .collector import Collector
from .schema import MISSING, key_path
from .shapes import (
    OUTLINE_BODIES,
    SOLVABLE,
    AreaShape,
    Blank,
    Box,
    Disc,
    Outline,
    PointMass,
    Sector,
    Segment,
    Strip,
    convex_ccw,
    sector_polygon,
)

#: Keys of a blank in a [[counterweight]] or [[design.counterweights]] table.
BLANK_KEYS = {"density", "thickness", "shape"}
_COMMON = {"kind", "direction", "centre", "thickness", "hole", "solve", "solve_range"}
_SHAPE_KEYS = {
    "sector": _COMMON | {"outer_radius", "inner_radius", "half_angle", "start_angle", "end_angle"},
    "half_disc": _COMMON | {"radius"},
    "segment": _COMMON | {"radius", "chord"},
    "strip": _COMMON | {"radius", "near", "far"},
    "box": _COMMON | {"width", "height"},
    "circle": _COMMON | {"radius"},
    "fastener": {"kind", "mass", "radius", "angle", "solve", "solve_range"},
}
_OUTLINE_KEYS = {"part", "body", "cylinder", "kind", "centre", "radius", "vertices", "width", "height", "direction",
                 "half_angle", "axial_range"}
_OUTLINE_SHAPES = ("circle", "polygon", "rectangle", "sector")


def read_blank(reader: Collector, entry: Mapping, path: str, sizing: bool = False) -> Blank | None:
    """The blank of a counterweight table, None if it gives none. With
    ``sizing`` (a design candidate) exactly one dimension carries
    ``solve`` and may be left out; otherwise none may."""
    if not BLANK_KEYS & set(entry):
        return None
    density = reader.quantity(entry, "density", path, "density", positive=True)
    thickness = reader.quantity(entry, "thickness", path, "length", positive=True)
    parts: list[AreaShape | PointMass] = []
    solve: list[tuple[int, str]] = []
    solve_range = None
    for where, table in reader.array(entry.get("shape", MISSING), key_path(path, "shape")):
        part, free, bounds = _shape(reader, table, where, sizing)
        if free is not None:
            solve.append((len(parts), free))
            solve_range = bounds
        if part is not None:
            parts.append(part)
    if not parts and not reader.problems_at(key_path(path, "shape")):
        reader.fail(key_path(path, "shape"), entry.get("shape", MISSING), "give at least one [[...shape]] table")
    if sizing and len(solve) != 1:
        reader.fail(key_path(path, "shape"), [s for _, s in solve] or MISSING,
                    "exactly one shape must name the dimension to size with solve = \"NAME\"")
    if parts and not reader.problems_at(path):
        blank = Blank(density, thickness, tuple(parts), solve[0] if len(solve) == 1 else None, solve_range)
        if not sizing and not blank.mass > 0:
            reader.fail(path, f"{blank.mass:.6g} kg", "the blank's mass must be positive (holes remove more "
                        "than its shapes hold)")
        return blank
    return None


def _shape(reader: Collector, table: Mapping, path: str, sizing: bool):
    """One shape of a blank: (shape, name of its free dimension or None, its solve_range or None)."""
    kind = table.get("kind", MISSING)
    if kind not in _SHAPE_KEYS:
        reader.fail(key_path(path, "kind"), kind, "must be one of " + ", ".join(map(repr, _SHAPE_KEYS)))
        return None, None, None
    reader.unknown(table, path, _SHAPE_KEYS[kind])
    free = table.get("solve")
    target = "sector" if kind == "half_disc" else kind
    if free is not None:
        if not sizing:
            reader.fail(key_path(path, "solve"), free, "only in a [[design.counterweights]] blank, to size it")
            free = None
        elif (free != "radius") if kind == "half_disc" else free not in SOLVABLE[target]:
            options = ["radius"] if kind == "half_disc" else list(SOLVABLE[target])
            reader.fail(key_path(path, "solve"), free, "must name a dimension of this shape that can be sized: "
                        + ", ".join(map(repr, options)))
            free = None
    bounds = None
    if "solve_range" in table:
        if free is None:
            reader.fail(key_path(path, "solve_range"), table["solve_range"], "only with solve")
        else:
            dimension = "angle" if free == "half_angle" else "mass" if free == "mass" else "length"
            bounds = reader.pair(table, "solve_range", path, dimension, MISSING)
            if not bounds[0] < bounds[1]:
                reader.fail(key_path(path, "solve_range"), table["solve_range"], "must be [low, high], low < high")

    def length(key, default=MISSING, positive=True):
        if key == free and key not in table:
            return math.nan
        return reader.quantity(table, key, path, "length", default, positive=positive, nonnegative=not positive)

    if kind == "fastener":
        mass = (math.nan if free == "mass" and "mass" not in table
                else reader.quantity(table, "mass", path, "mass", nonnegative=True))
        part = PointMass(mass, length("radius", positive=False),
                         reader.quantity(table, "angle", path, "angle", default=0.0))
        return part, free, bounds
    common: dict[str, Any] = {"direction": reader.quantity(table, "direction", path, "angle", default=0.0),
              "centre": reader.pair(table, "centre", path, "length", [0, 0]),
              "thickness": (reader.quantity(table, "thickness", path, "length", positive=True)
                            if "thickness" in table else None),
              "hole": _flag(reader, table, "hole", path)}
    if kind in ("sector", "half_disc"):
        outer = length("outer_radius" if kind == "sector" else "radius")
        inner = length("inner_radius", 0.0, positive=False) if kind == "sector" else 0.0
        half = math.pi / 2
        if kind == "sector":
            half, direction = _sector_angles(reader, table, path, free == "half_angle")
            if direction is not None:
                common["direction"] = direction
        if inner >= outer:
            reader.fail(key_path(path, "inner_radius"), table.get("inner_radius"), "must be below outer_radius")
        return Sector(outer, half, inner, **common), free and ("outer_radius" if kind == "half_disc"
                                                               else free), bounds
    if kind in ("segment", "strip"):
        radius = length("radius")
        if kind == "segment":
            chord = length("chord", positive=False)
            if abs(chord) > radius:
                reader.fail(key_path(path, "chord"), table.get("chord"), "must lie within ±radius")
            return Segment(radius, chord, **common), free, bounds
        near, far = length("near", 0.0, positive=False), length("far", positive=False)
        if all(map(math.isfinite, (radius, near, far))) and not -radius <= near < far <= radius:
            reader.fail(path, {"near": table.get("near", 0), "far": table.get("far")},
                        "the chords must satisfy −radius ≤ near < far ≤ radius")
        return Strip(radius, near, far, **common), free, bounds
    if kind == "box":
        return Box(length("width"), length("height"), **common), free, bounds
    return Disc(length("radius"), **common), free, bounds


def _sector_angles(reader: Collector, table: Mapping, path: str, free: bool) -> tuple[float, float | None]:
    """A sector's half-angle and, from start/end angles, its direction."""
    if "start_angle" in table or "end_angle" in table:
        if "half_angle" in table or "direction" in table or free:
            reader.fail(path, sorted(table), "give half_angle (and direction) or start_angle and end_angle")
            return math.nan, None
        start = reader.quantity(table, "start_angle", path, "angle")
        end = reader.quantity(table, "end_angle", path, "angle")
        if not 0 < end - start <= 2 * math.pi:
            reader.fail(key_path(path, "end_angle"), table.get("end_angle"),
                        "must lie after start_angle, by at most a full turn")
        return (end - start) / 2, (start + end) / 2
    if free and "half_angle" not in table:
        return math.nan, None
    half = reader.quantity(table, "half_angle", path, "angle", positive=True)
    if half > math.pi:
        reader.fail(key_path(path, "half_angle"), table["half_angle"], "must not exceed 180°")
    return half, None


def _flag(reader: Collector, table: Mapping, key: str, path: str) -> bool:
    value = table.get(key, False)
    if not isinstance(value, bool):
        reader.fail(key_path(path, key), value, "must be true or false")
        return False
    return value


def read_outlines(reader: Collector, raw: Any, cylinders, shafts) -> tuple[Outline, ...]:
    """The [[outline]] tables: parts' 2-D outlines on moving bodies."""
    outlines = []
    labels = [c.label for c in cylinders]
    shaft_labels = {s.label for s in shafts}
    for path, entry in reader.array(raw, "outline"):
        reader.unknown(entry, path, _OUTLINE_KEYS)
        part = reader.string(entry, "part", path)
        body = reader.string(entry, "body", path)
        if body and body not in OUTLINE_BODIES and body not in shaft_labels:
            reader.fail(key_path(path, "body"), body, "must be one of " + ", ".join(map(repr, OUTLINE_BODIES))
                        + " or the label of a balancer shaft" + (f" ({', '.join(map(repr, sorted(shaft_labels)))})"
                                                                 if shaft_labels else ""))
        cylinder = entry.get("cylinder", 1)
        if isinstance(cylinder, str) and cylinder in labels:
            plane = labels.index(cylinder)
        elif not isinstance(cylinder, bool) and isinstance(cylinder, int) and 1 <= cylinder <= len(labels):
            plane = cylinder - 1
        else:
            reader.fail(key_path(path, "cylinder"), cylinder, f"must be a cylinder number 1 … {len(labels)} or label")
            plane = 0
        kind = reader.choice(entry, "kind", path, _OUTLINE_SHAPES, "circle") if "kind" in entry else None
        if kind is None:
            reader.fail(key_path(path, "kind"), MISSING, "missing: " + ", ".join(map(repr, _OUTLINE_SHAPES)))
            continue
        points, radius = _outline_shape(reader, entry, path, kind)
        axial = None
        if "axial_range" in entry:
            axial = reader.pair(entry, "axial_range", path, "length", MISSING)
            if not axial[0] < axial[1]:
                reader.fail(key_path(path, "axial_range"), entry["axial_range"],
                            "must be [x_min, x_max], x_min < x_max")
        if points is not None:
            outlines.append(Outline(part, body, plane, points, radius, axial))
    names = [o.part for o in outlines]
    for name in sorted({n for n in names if names.count(n) > 1}):
        reader.fail("outline", name, "two outlines have this part name; part names must be unique")
    return tuple(outlines)


def _outline_shape(reader: Collector, entry: Mapping, path: str, kind: str):
    """(counterclockwise convex points, radius) of one outline, or (None, 0) if refused."""
    allowed = {"circle": {"centre", "radius"}, "polygon": {"vertices", "radius"},
               "rectangle": {"centre", "width", "height", "direction"},
               "sector": {"centre", "radius", "half_angle", "direction"}}[kind]
    for key in sorted(set(entry) & (_OUTLINE_KEYS - {"part", "body", "cylinder", "kind", "axial_range"}) - allowed):
        reader.fail(key_path(path, key), entry[key], f"not a key of a {kind} outline; allowed: "
                    + ", ".join(sorted(allowed)))
    centre = reader.pair(entry, "centre", path, "length", [0, 0])
    direction = reader.quantity(entry, "direction", path, "angle", default=0.0)
    if kind == "circle":
        return (centre,), reader.quantity(entry, "radius", path, "length", positive=True)
    if kind == "rectangle":
        w = reader.quantity(entry, "width", path, "length", positive=True)
        h = reader.quantity(entry, "height", path, "length", positive=True)
        c, s = math.cos(direction), math.sin(direction)
        corners = [(w / 2, -h / 2), (w / 2, h / 2), (-w / 2, h / 2), (-w / 2, -h / 2)]
        return tuple((centre[0] + c * u - s * v, centre[1] + s * u + c * v) for u, v in corners), 0.0
    if kind == "sector":
        radius = reader.quantity(entry, "radius", path, "length", positive=True)
        half = reader.quantity(entry, "half_angle", path, "angle", positive=True)
        if not half <= math.pi / 2:
            reader.fail(key_path(path, "half_angle"), entry.get("half_angle"),
                        "must not exceed 90° (a convex sector; split a wider one into two outlines)")
            return None, 0.0
        if not (radius > 0 and half > 0):
            return None, 0.0
        return sector_polygon(radius, half, direction, centre), 0.0
    raw = entry.get("vertices", MISSING)
    radius = reader.quantity(entry, "radius", path, "length", default=0.0, nonnegative=True)
    if not isinstance(raw, list) or not raw:
        reader.fail(key_path(path, "vertices"), raw, "must be a list of [u, v] points (lengths)")
        return None, 0.0
    points = [reader.pair({f"vertices[{i + 1}]": p}, f"vertices[{i + 1}]", path, "length", MISSING)
              for i, p in enumerate(raw)]
    if not all(math.isfinite(c) for p in points for c in p):
        return None, 0.0
    ccw = convex_ccw(points)
    if ccw is None:
        reader.fail(key_path(path, "vertices"), raw, "must be the corners of a convex polygon in order (split a "
                    "concave outline into convex ones)")
        return None, 0.0
    return ccw, radius

"""Writing scene TOML text: quantities with units, inline values, tables,
and edits of an existing scene's text that keep its comments."""

from __future__ import annotations

import math
import re


def quantity_text(value: float, units: str) -> str:
    """A value at full precision with its units, e.g. '0.0123 kg m'."""
    return f"{float(value)!r} {units}"


def length_text(value: float) -> str:
    """A length [m] written in mm at full precision."""
    return f"{value * 1e3:.15g} mm"


def angle_text(value: float) -> str:
    """Degrees in [0, 360), with round-off next to 0 written as 0."""
    degrees = math.degrees(float(value)) % 360.0
    if min(degrees, 360.0 - degrees) < 1e-10:
        degrees = 0.0
    return f"{degrees!r} deg"


def signed_angle_text(value: float) -> str:
    """Degrees in (−180, 180], round-off next to 0 written as 0."""
    degrees = math.degrees(math.remainder(float(value), 2 * math.pi))
    return f"{0.0 if abs(degrees) < 1e-10 else degrees!r} deg"


def inline(value) -> str:
    """A TOML value on one line."""
    import tomli_w

    if isinstance(value, list):
        return "[" + ", ".join(inline(v) for v in value) + "]"
    if isinstance(value, dict):
        return "{ " + ", ".join(f"{k} = {inline(v)}" for k, v in value.items()) + " }"
    return tomli_w.dumps({"v": value})[4:].strip()


def toml_tables(tables: dict) -> str:
    """Top-level tables and arrays of tables, values inline, arrays of tables
    inside them as [[parent.child]] blocks."""
    lines = []

    def block(header: str, path: str, table: dict) -> None:
        lines.append(header)
        nested = {k: v for k, v in table.items() if isinstance(v, list) and v and isinstance(v[0], dict)}
        lines.extend(f"{k} = {inline(v)}" for k, v in table.items() if k not in nested)
        for key, entries in nested.items():
            for entry in entries:
                lines.append("")
                block(f"[[{path}.{key}]]", f"{path}.{key}", entry)

    for key, value in tables.items():
        for entry in value if isinstance(value, list) else [value]:
            lines.append("")
            block(f"[[{key}]]" if isinstance(value, list) else f"[{key}]", key, entry)
    return "\n".join(lines) + "\n"


HEADER = re.compile(r"^\s*\[\[?\s*([A-Za-z0-9_\-.\" ]+?)\s*\]\]?\s*(#.*)?$")


def without_tables(text: str, names: set[str]) -> str:
    """The TOML text without the tables (and their sub-tables) ``names``."""
    out, skipping = [], False
    for line in text.splitlines():
        match = HEADER.match(line)
        if match:
            skipping = match.group(1).split(".")[0].strip() in names
        if not skipping:
            out.append(line)
    return "\n".join(out).rstrip() + "\n"


def with_engine(text: str, engine: dict[str, str]) -> str:
    """Replace the string values of [engine] keys (``name``, ``description``).

    The first 'key = "..."' line is [engine]'s: [engine] is required first."""
    for key, value in engine.items():
        # re.sub calls the lambda before the next iteration: the value it reads is this key's
        text = re.sub(rf'(?m)^(\s*{key}\s*=\s*)"[^"\n]*"', lambda m: m.group(1) + inline(value), text, count=1)  # noqa: B023
    return text


def blank_table(blank) -> dict:
    """A counterweight blank (:class:`~.shapes.Blank`) as the keys of its
    [[counterweight]] table: density, thickness and the [[...shape]] tables,
    at full precision (lengths in mm, angles in degrees)."""
    from dataclasses import fields

    angles = {"direction", "half_angle", "angle"}
    shapes = []
    for part in blank.parts:
        table = {"kind": part.kind}
        for f in fields(part):
            value = getattr(part, f.name)
            if f.name == "hole":
                if value:
                    table["hole"] = True
            elif f.name == "thickness":
                if value is not None:
                    table["thickness"] = length_text(value)
            elif f.name == "centre":
                if any(value):
                    table["centre"] = [length_text(c) for c in value]
            elif f.name == "mass":
                table["mass"] = quantity_text(value, "kg")
            elif f.name in ("direction", "inner_radius") and value == 0:
                continue  # the defaults
            elif f.name in angles:
                table[f.name] = f"{math.degrees(float(value))!r} deg"
            else:
                table[f.name] = length_text(value)
        shapes.append(table)
    return {"density": quantity_text(blank.density, "kg/m^3"), "thickness": length_text(blank.thickness),
            "shape": shapes}

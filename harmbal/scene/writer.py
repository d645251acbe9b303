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


def _mount_values(mount) -> dict:
    """A mount's position, axes and stiffness (and its table, if any) as
    [[mount]] keys, in mm and N/mm at full precision (axes u and w as plain
    numbers; v follows)."""
    values = {"position": [length_text(v) for v in mount.position],
              "axes": {"u": [float(x) for x in mount.axes[0]], "w": [float(x) for x in mount.axes[2]]},
              "stiffness": [quantity_text(k / 1e3, "N/mm") for k in mount.stiffness]}
    if mount.table is not None:  # a designed stiffness scales the table's column: the table is written too
        table = mount.table
        values["table"] = {"frequency": [quantity_text(f, "Hz") for f in table.frequency],
                           "stiffness": [[quantity_text(k / 1e3, "N/mm") for k in row] for row in table.stiffness],
                           "loss_factor": [[float(x) for x in row] for row in table.loss_factor]}
    return values


def mounts_scene_text(scene, mounts, name: str | None = None) -> str:
    """The scene's TOML text with each [[mount]]'s position, axes and
    stiffness replaced by those of ``mounts`` (matched by name), and without
    [mount_design] (the result is a designed scene, as ``harmbal design``
    writes one); comments kept.

    Parameters
    ----------
    scene : Scene
        The scene read (its ``source_text`` is edited).
    mounts : iterable of Mount
        The mounts to write; each names a [[mount]] of the scene.
    name : str, optional
        A new ``engine.name``.

    Returns
    -------
    str
        TOML text that reads back to ``mounts``' values (lengths in mm,
        stiffnesses in N/mm, at full precision). Falls back to a plain TOML
        dump if the text cannot be edited safely (a value written over
        several lines, an inline array of mounts).
    """
    import tomllib

    import tomli_w

    values = {m.name: _mount_values(m) for m in mounts}
    original = tomllib.loads(scene.source_text)
    expected = {k: v for k, v in original.items() if k != "mount_design"}
    names = [m.name for m in scene.mounts]
    unknown = sorted(set(values) - set(names))
    if unknown:
        raise ValueError(f"mounts not in the scene: {', '.join(map(repr, unknown))}")
    expected["mount"] = [{**entry, **values.get(names[i], {})} for i, entry in enumerate(original["mount"])]
    if name is not None:
        expected["engine"] = {**expected["engine"], "name": name}
    engine = {} if name is None else {"name": name}
    text = _with_mount_values(with_engine(without_tables(scene.source_text, {"mount_design"}), engine),
                              [values.get(n) for n in names])
    try:
        if tomllib.loads(text) == expected:
            return text
    except tomllib.TOMLDecodeError:
        pass
    return tomli_w.dumps(expected)


def _with_mount_values(text: str, values: list) -> str:
    """``text`` with the keys of ``values[i]`` replaced in the i-th [[mount]]
    table (the old value kept as a comment), or added after its header."""
    lines: list[str] = []
    entry, header, body = -1, 0, False
    pending: dict = {}

    def add_missing() -> None:
        lines[header + 1:header + 1] = [f"{k} = {inline(v)}" for k, v in pending.items()]
        pending.clear()

    for line in text.splitlines():
        match = HEADER.match(line)
        if match:
            section = match.group(1).replace(" ", "")
            body = section == "mount" and line.lstrip().startswith("[[")
            if body or not section.startswith("mount."):  # the table of the last mount ends
                add_missing()
            if body:
                entry += 1
                header = len(lines)
                pending = dict(values[entry] or {}) if entry < len(values) else {}
        elif body and "=" in line and line.split("=", 1)[0].strip() in pending:
            key, old = line.split("=", 1)[0].strip(), line.split("=", 1)[1].split("#", 1)[0].strip()
            line = f"{key} = {inline(pending.pop(key))}  # was {old}"
        lines.append(line)
    add_missing()
    return "\n".join(lines) + "\n"

"""Key paths of a scene file, as a sweep names them, and edits of the raw TOML mapping.

A key path addresses the scene file as written: tables by name, arrays by
1-based index (``geometry.rod_length``, ``cylinder[2].piston.mass``,
``engine.reference_point[3]``). A sweep writes each variant's values into a
copy of the scene's raw mapping (:func:`set_key`) and reads it again through
the scene reader; what dimension a key has is asked of the reader itself
(:func:`key_dimension`), never of a table kept here.
"""

from __future__ import annotations

import copy
import re
from collections.abc import Mapping
from typing import Any

import numpy as np

from ..scene import SceneError
from ..scene.reader import quantity_dimensions
from ..scene.schema import Problem
from ..scene.units import QuantityError

#: One part of a key path: a name, then an optional 1-based index.
_PART = re.compile(r"([A-Za-z_][A-Za-z0-9_]*)(?:\[([1-9][0-9]*)\])?")


def key_error(source: str, key: str, value: Any, rule: str) -> SceneError:
    """A :class:`~harmbal.scene.SceneError` of one problem with ``key``,
    showing ``value`` as written (a numpy scalar as its Python number)."""
    value = value.item() if isinstance(value, np.generic) else value  # as written, not np.float64(…)
    return SceneError([Problem(source, key, value, rule)])


def parse_path(source: str, key: str) -> list[tuple[str, int | None]]:
    """The (name, index or None) parts of a key path.

    Raises
    ------
    SceneError
        If ``key`` is not a key path (naming ``source``).
    """
    parts = []
    for part in key.split("."):
        match = _PART.fullmatch(part)
        if match is None:
            raise key_error(source, key, key, "not a key path: write e.g. geometry.rod_length or "
                            "cylinder[2].piston.mass (tables by name, arrays by 1-based index)")
        parts.append((match[1], None if match[2] is None else int(match[2])))
    return parts


def set_key(raw: dict, source: str, key: str, value: Any) -> None:
    """Set ``key`` in the raw scene mapping, creating missing tables on the way.

    Raises
    ------
    SceneError
        If the path runs through a value that is not a table, names an array
        without an index, or an entry the array does not have.
    """
    node: Any = raw
    parts = parse_path(source, key)
    for depth, (name, index) in enumerate(parts):
        last = depth == len(parts) - 1
        where = ".".join(f"{n}" + ("" if i is None else f"[{i}]") for n, i in parts[: depth + 1])
        if not isinstance(node, dict):
            raise key_error(source, key, value, f"{where.rpartition('.')[0]} is not a table")
        if index is None:
            if last:
                node[name] = value
                return
            if isinstance(node.get(name), list):
                raise key_error(source, key, value, f"{where} is an array: name an entry, e.g. {where}[1]")
            node = node.setdefault(name, {})
            continue
        entries = node.get(name)
        if not isinstance(entries, list) or index > len(entries):
            count = len(entries) if isinstance(entries, list) else 0
            raise key_error(source, key, value, f"the scene has no {where} ({count} "
                            f"entr{'y' if count == 1 else 'ies'} of {name})")
        if last:
            entries[index - 1] = value
            return
        node = entries[index - 1]


def get_key(raw: dict, key: str) -> Any:
    """The raw value of ``key`` in the scene mapping, or None if it is not written there."""
    node: Any = raw
    for name, index in parse_path("", key):
        if not isinstance(node, dict) or name not in node:
            return None
        node = node[name]
        if index is not None:
            if not isinstance(node, list) or index > len(node):
                return None
            node = node[index - 1]
    return node


def toml_value(value: Any) -> Any:
    """A value the reader takes: Python floats and ints, strings as given.

    Raises
    ------
    QuantityError
        For a boolean.
    """
    if isinstance(value, str):
        return value
    if isinstance(value, (bool, np.bool_)):
        raise QuantityError(f"not a number: {value!r}")
    if isinstance(value, (int, np.integer)):
        return int(value)
    return float(value)


def key_dimension(raw: dict, key: str, value: Any, files: Mapping[str, str] | None = None) -> str | None:
    """The dimension the scene reader reads ``key`` in, or None if it does not
    read it as a quantity.

    ``value`` is written at ``key`` first (in a copy of ``raw``), so that a
    key the scene does not write yet (``cylinder[2].piston.mass`` of a
    cylinder that takes the shared [piston]) is read where a sweep will write
    it (:func:`harmbal.scene.reader.quantity_dimensions`).

    Parameters
    ----------
    raw : dict
        The scene's raw mapping (left unchanged).
    key : str
        A key path.
    value : number or str
        A value of the key (one the sweep will write; its own validity does
        not matter).
    files : mapping of str to str, optional
        The scene's trace files (``Scene.files``): no file is opened.

    Returns
    -------
    str or None
        A key of :data:`~harmbal.scene.units.SI_UNITS`; None also if ``value``
        cannot be written there (the sweep refuses it, with its reason, where
        it writes the variants).
    """
    probe = copy.deepcopy(raw)
    try:
        set_key(probe, "", key, toml_value(value))
    except (ValueError, TypeError):  # SceneError, QuantityError, or not a number at all
        return None
    return quantity_dimensions(probe, files=files).get(key)

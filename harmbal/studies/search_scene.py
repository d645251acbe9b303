"""The search's scenes (:mod:`.search`): the representative cylinder taken
from a template scene, the one-cylinder scene of each bank angle that the
search evaluates with harmbal's exact model, and the scene of a chosen
candidate, written from the template.

The template gives the engine's parts and settings: ``[engine]`` (cycle,
rotation, speeds, reference point), ``[model]``, ``[sampling]``,
``[geometry]``, ``[piston]``, ``[rod]``, the shared ``throw_unbalance``,
``[gas]`` and ``[flywheel]``, and its first ``[[cylinder]]`` table (its own
overrides and throw unbalances) stands for every cylinder. Its cylinders'
throws, banks and positions, its firing order and its balancers
(crankshaft unbalances, counterweights, shafts, levers) and requests
(``[design]``, ``[verify]``, ``[loads]``, ``[[outline]]``) belong to another
crank and are left out: the search compares bare crank trains.
"""

from __future__ import annotations

import copy
import tomllib
from typing import Any

import numpy as np

from ..scene import Scene, scene_from_text

#: The template's tables a candidate keeps (the rest belong to the template's own crank).
KEPT_TABLES = ("engine", "model", "sampling", "geometry", "piston", "rod", "throw_unbalance", "gas", "flywheel")


def template_raw(scene: Scene) -> dict[str, Any]:
    """The template's TOML as a mapping, reduced to :data:`KEPT_TABLES` and its
    first cylinder's table (without the engine's firing order)."""
    raw = tomllib.loads(scene.source_text)
    kept = {key: copy.deepcopy(raw[key]) for key in KEPT_TABLES if key in raw}
    kept.setdefault("engine", {}).pop("firing_order", None)
    first = raw["cylinder"][0] if isinstance(raw.get("cylinder"), list) and raw["cylinder"] else {}
    kept["cylinder"] = [{k: copy.deepcopy(v) for k, v in first.items()
                         if k not in ("label", "throw", "bank", "axial_position")}]
    return kept


def degrees_text(value: float) -> str:
    """An angle [deg] as scene text at full precision (the search and the
    scene it writes read the same number)."""
    return f"{float(value)!r} deg"


def metres_text(value: float) -> str:
    """A length [m] as scene text at full precision."""
    return f"{float(value)!r} m"


def single_cylinder_scene(scene: Scene, raw: dict[str, Any], bank: float) -> Scene:
    """The template's representative cylinder alone, at throw 0, ``bank``
    [deg] and the origin, moments about the origin, no flywheel."""
    import tomli_w

    single = copy.deepcopy({k: v for k, v in raw.items() if k != "flywheel"})
    single["engine"]["reference_point"] = ["0 m", "0 m", "0 m"]
    single["cylinder"] = [dict(single["cylinder"][0], label="1", throw="0 deg", bank=degrees_text(bank),
                               axial_position="0 m")]
    return scene_from_text(tomli_w.dumps(single), scene.source, files=dict(scene.files))


def candidate_raw(raw: dict[str, Any], *, throws: np.ndarray, banks: np.ndarray, x: np.ndarray,
                  firing_order: list[int], name: str, description: str) -> dict[str, Any]:
    """The template with the candidate's cylinders (throw, bank [deg], axial
    position [m]) and firing order."""
    out = copy.deepcopy(raw)
    out["engine"].update(name=name, description=description, firing_order=list(firing_order))
    base = out["cylinder"][0]
    out["cylinder"] = [dict(copy.deepcopy(base), label=str(i + 1), throw=degrees_text(t), bank=degrees_text(b),
                            axial_position=metres_text(p))
                       for i, (t, b, p) in enumerate(zip(throws, banks, x))]
    return out

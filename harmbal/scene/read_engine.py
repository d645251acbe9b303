"""Reading [engine] (name, cycle, rotation, speeds or a speed sweep, the
reference point, the firing order), [model] and [sampling]."""

from __future__ import annotations

import math
from typing import Any, Mapping

import numpy as np

from .collector import Collector
from .schema import (
    DEFAULT_ACCURACY,
    DEFAULT_MAX_ORDER,
    DEFAULT_NEGLIGIBLE,
    EFFECTS,
    INERTIA_EFFECTS,
    MISSING,
    PISTON_MODELS,
    ROD_MODELS,
    ROTATIONS,
    Cylinder,
    Model,
    Sampling,
    closest_match,
)

_ENGINE_KEYS = {"name", "description", "cycle", "rotation", "speed", "reference_point", "firing_order"}
_SWEEP_KEYS = {"from", "to", "points"}
_MODEL_KEYS = {"effects", "piston", "series_harmonics", "rod", "negligible"}
_SAMPLING_KEYS = {"samples_per_rev", "accuracy", "max_order"}


def read_engine(reader: Collector, data: Mapping) -> tuple[dict, dict[str, Any]]:
    """The raw [engine] table (the firing order is read from it once the
    cylinders are known) and the Scene fields it gives."""
    engine = reader.table(data, "engine", "engine", _ENGINE_KEYS, required=True)
    name = reader.string(engine, "name", "engine")
    description = reader.string(engine, "description", "engine", "")
    cycle = engine.get("cycle", 4)
    if not isinstance(cycle, int) or isinstance(cycle, bool) or cycle not in (2, 4):
        reader.fail("engine.cycle", cycle, "must be 2 or 4 (strokes)")
        cycle = 4
    rotation = reader.choice(engine, "rotation", "engine", ROTATIONS, "clockwise")
    speeds = _speeds(reader, engine)
    reference = reader.quantity_list(engine, "reference_point", "engine", "length", 3, [0, 0, 0])
    return engine, {"name": name, "description": description, "cycle": cycle, "rotation": rotation,
                    "speeds": speeds, "reference_point": reference}


def _speeds(reader: Collector, engine: Mapping) -> tuple[float, ...]:
    raw = engine.get("speed", MISSING)
    if isinstance(raw, Mapping):
        return _speed_sweep(reader, raw)
    if isinstance(raw, list):
        if not raw:
            reader.fail("engine.speed", raw, "give at least one speed")
        items = {f"speed[{i + 1}]": v for i, v in enumerate(raw)}
        speeds = tuple(reader.quantity(items, key, "engine", "speed", positive=True) for key in items)
    else:
        speeds = (reader.quantity(engine, "speed", "engine", "speed", positive=True),)
    finite = [s for s in speeds if math.isfinite(s)]
    if len(set(finite)) != len(finite):
        reader.fail("engine.speed", raw, "speeds must be distinct")
    return speeds


def _speed_sweep(reader: Collector, table: Mapping) -> tuple[float, ...]:
    """``speed = {from = ..., to = ..., points = N}``: N speeds evenly spaced."""
    reader.unknown(table, "engine.speed", _SWEEP_KEYS)
    low = reader.quantity(table, "from", "engine.speed", "speed", positive=True)
    high = reader.quantity(table, "to", "engine.speed", "speed", positive=True)
    if "points" not in table:
        reader.fail("engine.speed.points", MISSING, "missing required key")
        return (math.nan,)
    points = reader.integer(table, "points", "engine.speed", None, minimum=2)  # at most MAX_SPEEDS
    if points is None:
        return (math.nan,)
    if not (math.isfinite(low) and math.isfinite(high)):
        return (math.nan,)
    if not low < high:
        reader.fail("engine.speed.to", table.get("to"), "must be above engine.speed.from")
        return (math.nan,)
    return tuple(np.linspace(low, high, points).tolist())


def read_firing_order(reader: Collector, engine: Mapping, cylinders: tuple[Cylinder, ...],
                      cycle: int) -> tuple[int, ...] | None:
    """The firing order as cylinder indices, checked against the geometry."""
    from .firing import ANGLE_TOL, FiringOrderError, FiringWarning, cylinder_firing

    raw = engine.get("firing_order", MISSING)
    if raw is MISSING:
        return None
    key = "engine.firing_order"
    labels = [c.label for c in cylinders]
    if not isinstance(raw, list) or any(isinstance(v, bool) or not isinstance(v, (str, int)) for v in raw):
        reader.fail(key, raw, "must be a list of cylinder labels")
        return None
    given = [str(v) for v in raw]
    if sorted(given) != sorted(labels):
        reader.fail(key, raw, f"must name every cylinder exactly once: {', '.join(labels)}")
        return None
    order = tuple(labels.index(v) for v in given)
    if reader.problems:  # the geometry may be invalid; check the order once it is not
        return order
    try:
        firing = cylinder_firing(cylinders, cycle, order)
    except FiringOrderError as exc:
        reader.fail(key, raw, f"not possible with these throws and banks: {exc}")
        return None
    # An order whose consecutive cylinders share a TDC that the crank could fire apart (its most even firing
    # has no two at once) lists as successive two firings that come at the same instant: possible (cams can
    # do it), but rarely what was meant.
    together = [i for i, gap in enumerate(firing.interval) if gap <= ANGLE_TOL]
    derived = cylinder_firing(cylinders, cycle)
    if together and min(derived.interval) > ANGLE_TOL:
        first, second = firing.sequence[together[0]], firing.sequence[(together[0] + 1) % len(firing.sequence)]
        best = "-".join(labels[i] for i in derived.sequence)
        reader.warn(FiringWarning(
            f"{reader.source}: {key} = {raw!r}: cylinders {labels[first]} and {labels[second]} fire at the same "
            f"instant, not one after the other (this crank has them at TDC together); it fires most evenly as "
            f"{best}"))
    return order


def read_model(reader: Collector, data: Mapping, has_gas: bool = False) -> Model:
    """[model]; the default effects are those of inertia, plus "gas" if
    the scene has a [gas] table (``has_gas``), which "gas" requires."""
    table = reader.table(data, "model", "model", _MODEL_KEYS)
    effects_raw = table.get("effects", list(INERTIA_EFFECTS) + (["gas"] if has_gas else []))
    effects: set[str] = set()
    if not isinstance(effects_raw, list) or not all(isinstance(e, str) for e in effects_raw):
        reader.fail("model.effects", effects_raw, "must be a list of effect names")
    else:
        for effect in effects_raw:
            if effect not in EFFECTS:
                hint = closest_match(effect, set(EFFECTS))
                reader.fail("model.effects", effect, "unknown effect" + (f" (did you mean {hint!r}?)" if hint else "")
                            + f"; known: {', '.join(EFFECTS)}")
            effects.add(effect)
        if len(effects) != len(effects_raw):
            reader.fail("model.effects", effects_raw, "an effect is listed twice")
        if "speed_fluctuation" in effects and "gas" not in effects:
            reader.fail("model.effects", effects_raw, 'the effect "speed_fluctuation" is driven by the gas torque: '
                        'it needs the effect "gas"')
        if "gas" in effects and not has_gas:
            reader.fail("model.effects", effects_raw, 'the effect "gas" needs a [gas] table (bore and pressure '
                        "trace)")
    piston = reader.choice(table, "piston", "model", PISTON_MODELS, "exact")
    harmonics = reader.integer(table, "series_harmonics", "model", 2, minimum=1)
    if "series_harmonics" in table and piston != "series":
        reader.fail("model.series_harmonics", table["series_harmonics"], 'only used with piston = "series"')
    rod = reader.choice(table, "rod", "model", ROD_MODELS, "rigid")
    negligible = DEFAULT_NEGLIGIBLE
    if "negligible" in table:  # within NEGLIGIBLE_RANGE (harmbal.scene.ranges), else nan and a problem
        negligible = reader.quantity(table, "negligible", "model", "dimensionless", positive=True)
        if not math.isfinite(negligible):
            negligible = DEFAULT_NEGLIGIBLE
    return Model(effects=frozenset(effects & set(EFFECTS)), piston=piston, series_harmonics=harmonics or 2, rod=rod,
                 negligible=negligible)


def read_sampling(reader: Collector, data: Mapping) -> Sampling:
    """[sampling]: samples per revolution (or the accuracy to choose them for) and the orders kept."""
    table = reader.table(data, "sampling", "sampling", _SAMPLING_KEYS)
    max_order = reader.integer(table, "max_order", "sampling", DEFAULT_MAX_ORDER, minimum=1)
    samples = reader.integer(table, "samples_per_rev", "sampling", None, minimum=8)
    accuracy = None
    if "accuracy" in table:
        if samples is not None:
            reader.fail("sampling.accuracy", table["accuracy"], "give samples_per_rev or accuracy, not both")
        accuracy = reader.quantity(table, "accuracy", "sampling", "dimensionless", positive=True)  # [1e-16, 0.1)
    elif samples is None:
        accuracy = DEFAULT_ACCURACY
    # (max_order is at most MAX_SAMPLES / 4 and samples_per_rev at most MAX_SAMPLES: their ranges)
    if samples is not None and max_order is not None and samples < 2 * max_order + 2:
        reader.fail("sampling.samples_per_rev", samples,
                    f"must be at least 2*max_order + 2 = {2 * max_order + 2} to resolve order {max_order}")
    return Sampling(samples_per_rev=samples, accuracy=accuracy, max_order=max_order or DEFAULT_MAX_ORDER)

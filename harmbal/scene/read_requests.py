"""Reading what ``harmbal design`` designs ([design], with its candidate
elements or a [design.lever] balance weight) and what ``harmbal verify``
checks ([verify], with the predicted residuals)."""

from __future__ import annotations

import math
from typing import Any, Mapping

from .collector import Collector
from .ranges import KEY_RANGES, MAX_RATIO
from .read_shapes import BLANK_KEYS, read_blank
from .requests import (
    CANCEL,
    COMPONENTS,
    LEVER_OBJECTIVES,
    LEVER_SIGNALS,
    OBJECTIVES,
    PEAK_SIGNALS,
    Candidate,
    DesignRequest,
    LeverDesignRequest,
    VerifyRequest,
)
from .schema import MISSING, key_path

_DESIGN_KEYS = {"orders", "cancel", "objective", "peak", "counterweights", "balance_shaft", "moment_shaft",
                "lanchester_pair", "lever"}
_LEVER_DESIGN_KEYS = {"label", "signals", "weights", "mass", "cg_x", "cg_y"}
_CANDIDATE_KEYS = {
    "counterweights": {"label", "planes", "balance_factor", "max_unbalance"} | BLANK_KEYS,
    "balance_shaft": {"label", "ratio", "axis_position", "planes", "max_unbalance"} | BLANK_KEYS,
    "moment_shaft": {"label", "ratio", "axis_position", "planes", "max_unbalance"} | BLANK_KEYS,
    "lanchester_pair": {"label", "order", "axial_position", "heights", "lateral", "max_unbalance"} | BLANK_KEYS,
}
_VERIFY_KEYS = {"orders", "cancel", "speed", "tolerance", "predicted"}
_PREDICTED_KEYS = {"order"} | {name for name, _ in COMPONENTS}


def read_requests(reader: Collector, data: Mapping,
                  max_order: int) -> tuple[DesignRequest | LeverDesignRequest | None, VerifyRequest | None]:
    """The [design] and [verify] requests, None where the scene has none."""
    requests: dict[str, Any] = {}  # design and verify requests, of different types
    for key, allowed, read in (("design", _DESIGN_KEYS, _design), ("verify", _VERIFY_KEYS, _verify)):
        table = reader.table(data, key, key, allowed)  # reports a non-table and unknown keys
        requests[key] = read(reader, table, max_order) if isinstance(data.get(key), Mapping) else None
    return requests["design"], requests["verify"]


def _design(reader: Collector, raw: dict, max_order: int) -> DesignRequest | LeverDesignRequest:
    if "lever" in raw:
        return _lever_design(reader, raw, max_order)
    orders = _orders(reader, raw, "design", max_order)
    cancel = _names(reader, raw, "cancel", "design", CANCEL, ("force", "moment"))
    objective = reader.choice(raw, "objective", "design", OBJECTIVES, "least_squares")
    peak = _names(reader, raw, "peak", "design", PEAK_SIGNALS, ("moment_y", "moment_z"))
    if "peak" in raw and objective != "peak":
        reader.fail("design.peak", raw["peak"], 'only used with objective = "peak"')
    candidates = [_candidate(reader, kind, path, entry, max_order) for kind in _CANDIDATE_KEYS
                  for path, entry in reader.array(raw.get(kind, []), f"design.{kind}")]
    if not candidates:
        reader.fail("design", sorted(raw), "give at least one candidate element: "
                    + ", ".join(f"[[design.{k}]]" for k in _CANDIDATE_KEYS))
    labels = [c.label for c in candidates]
    for label in sorted({x for x in labels if labels.count(x) > 1}):
        reader.fail("design", label, "two candidate elements have this label; labels must be unique")
    return DesignRequest(orders, tuple(candidates), cancel, objective, peak)


def _lever_design(reader: Collector, raw: dict, max_order: int) -> LeverDesignRequest:
    """[design] with a [design.lever] table: the optimal balance weight."""
    others = sorted(set(raw) & (set(_CANDIDATE_KEYS) | {"cancel", "peak"}))
    if others:
        reader.fail("design", others, "a lever design optimises the balance weight alone; design other elements "
                    "in a separate [design] run")
    objective = reader.choice(raw, "objective", "design", LEVER_OBJECTIVES, "peak_to_peak")
    orders = _orders(reader, raw, "design", max_order) if "orders" in raw else (1,)
    if "orders" in raw and objective != "orders":
        reader.fail("design.orders", raw["orders"], 'only used with objective = "orders"')
    lever = reader.table(raw, "lever", "design.lever", _LEVER_DESIGN_KEYS)
    label = reader.string(lever, "label", "design.lever", None) if "label" in lever else None
    signals = _names(reader, lever, "signals", "design.lever", LEVER_SIGNALS, ("force_y", "force_z"))
    weights: tuple[float, ...] = ()
    if "weights" in lever:
        raw_weights = lever["weights"]
        if (objective != "orders" or not isinstance(raw_weights, list) or len(raw_weights) != len(orders)
                or any(isinstance(w, bool) or not isinstance(w, (int, float)) or w not in KEY_RANGES["weights"]
                       for w in raw_weights)):
            reader.fail("design.lever.weights", raw_weights, f"one number in {KEY_RANGES['weights'].interval()} "
                        'per order of design.orders, with objective = "orders"')
        else:
            weights = tuple(float(w) for w in raw_weights)
    bounds = {}
    for key, dimension in (("mass", "mass"), ("cg_x", "length"), ("cg_y", "length")):
        if key in lever:
            low, high = reader.pair(lever, key, "design.lever", dimension, MISSING)
            if math.isfinite(low) and math.isfinite(high) and not low <= high:
                reader.fail(f"design.lever.{key}", lever[key], "must be [low, high] with low <= high")
            if key == "mass" and math.isfinite(low) and low < 0:
                reader.fail("design.lever.mass", lever[key], "masses must not be negative")
            bounds[key] = (low, high)
    return LeverDesignRequest(label, objective, signals, orders, weights, bounds.get("mass"), bounds.get("cg_x"),
                              bounds.get("cg_y"))


def _candidate(reader: Collector, kind: str, path: str, entry: Mapping, max_order: int) -> Candidate:
    reader.unknown(entry, path, _CANDIDATE_KEYS[kind])
    number = path.rsplit("[", 1)[-1].rstrip("]")
    label = reader.string(entry, "label", path, "counterweights" if kind == "counterweights"
                          else f"{kind.replace('_', ' ')} {number}")
    bound = (reader.quantity(entry, "max_unbalance", path, "unbalance", positive=True)
             if "max_unbalance" in entry else None)
    if kind == "counterweights":
        factor = None
        if "balance_factor" in entry:
            factor = reader.quantity(entry, "balance_factor", path, "dimensionless")  # in [0, 1]
        return Candidate(kind, label, 1, _lengths(reader, entry, "planes", path), balance_factor=factor,
                         max_unbalance=bound, blank=read_blank(reader, entry, path, sizing=True))
    if kind == "lanchester_pair":
        order = 1
        if "order" in entry:
            order = reader.integer(entry, "order", path, 1, 1, maximum=MAX_RATIO)
            if order > max_order:
                reader.fail(key_path(path, "order"), order, f"must not exceed sampling.max_order = {max_order}")
        else:
            reader.fail(key_path(path, "order"), MISSING, "missing: the order n the pair cancels (shafts at ±n×)")
        x = reader.quantity(entry, "axial_position", path, "length", default=0.0)
        heights = reader.pair(entry, "heights", path, "length", [0, 0])
        lateral = reader.pair(entry, "lateral", path, "length", [0, 0])
        return Candidate(kind, label, order, (x,), heights=heights, lateral=lateral, max_unbalance=bound,
                         blank=read_blank(reader, entry, path, sizing=True))
    y, z = reader.position(entry, "axis_position", path)
    planes = _lengths(reader, entry, "planes", path, 2 if kind == "moment_shaft" else None)
    ratio = _ratio(reader, entry, "ratio", path)
    if abs(ratio) > max_order:
        reader.fail(key_path(path, "ratio"), ratio, f"|ratio| must not exceed sampling.max_order = {max_order}")
    return Candidate(kind, label, ratio, planes, y=y, z=z, max_unbalance=bound,
                     blank=read_blank(reader, entry, path, sizing=True))


def _orders(reader: Collector, table: Mapping, path: str, max_order: int) -> tuple[int, ...]:
    raw = table.get("orders", MISSING)
    where = key_path(path, "orders")
    if raw is MISSING:
        reader.fail(where, raw, "missing: the orders to balance, e.g. [1, 2]")
        return ()
    if (not isinstance(raw, list) or not raw
            or any(isinstance(k, bool) or not isinstance(k, int) or not 1 <= k <= max_order for k in raw)):
        reader.fail(where, raw, f"must be a non-empty list of orders from 1 to sampling.max_order = {max_order}")
        return ()
    if len(set(raw)) != len(raw):
        reader.fail(where, raw, "an order is listed twice")
    return tuple(sorted(set(raw)))


def _names(reader: Collector, table: Mapping, key: str, path: str, options: tuple[str, ...],
           default: tuple) -> tuple[str, ...]:
    raw = table.get(key, list(default))
    if not isinstance(raw, list) or not raw or any(v not in options for v in raw):
        reader.fail(key_path(path, key), raw, f"must be a non-empty list of {', '.join(map(repr, options))}")
        return default
    return tuple(v for v in options if v in raw)


def _lengths(reader: Collector, table: Mapping, key: str, path: str, count: int | None = None) -> tuple[float, ...]:
    """A list of lengths (any number ≥ 1, or exactly ``count``), distinct."""
    raw = table.get(key, MISSING)
    where = key_path(path, key)
    if not isinstance(raw, list) or not raw or (count is not None and len(raw) != count):
        reader.fail(where, raw, f"must be a list of {count or 'one or more'} axial positions (lengths)")
        return ()
    values = tuple(reader.quantity({f"{key}[{i + 1}]": v}, f"{key}[{i + 1}]", path, "length")
                   for i, v in enumerate(raw))
    if len(set(values)) != len(values):
        reader.fail(where, raw, "planes must be at distinct axial positions")
    return values


def _ratio(reader: Collector, entry: Mapping, key: str, path: str) -> int:
    ratio = entry.get(key, MISSING)
    if ratio is MISSING:
        reader.fail(key_path(path, key), ratio, "missing: the speed ratio n (negative turns against the crank)")
    elif isinstance(ratio, bool) or not isinstance(ratio, int) or ratio == 0:
        reader.fail(key_path(path, key), ratio, "must be a non-zero integer (negative turns against the crank)")
    elif abs(ratio) > MAX_RATIO:
        reader.fail(key_path(path, key), ratio, f"|ratio| must be at most {MAX_RATIO}: {KEY_RANGES['ratio'].why}")
    else:
        return ratio
    return 1


def _verify(reader: Collector, raw: dict, max_order: int) -> VerifyRequest:
    orders = _orders(reader, raw, "verify", max_order)
    cancel = _names(reader, raw, "cancel", "verify", CANCEL, ("force", "moment"))
    speed = reader.quantity(raw, "speed", "verify", "speed", positive=True) if "speed" in raw else None
    tolerance = reader.quantity(raw, "tolerance", "verify", "dimensionless", default=0.0, nonnegative=True)  # [0, 1)
    predicted = []
    if "predicted" in raw and speed is None:
        reader.fail("verify.predicted", MISSING, "needs verify.speed, the speed the predictions are given at")
    for path, entry in reader.array(raw.get("predicted", []), "verify.predicted"):
        reader.unknown(entry, path, _PREDICTED_KEYS)
        order = reader.integer(entry, "order", path, 0, 1)  # one of verify.orders
        if order not in orders:
            reader.fail(key_path(path, "order"), entry.get("order"), "must be one of verify.orders")
        for name, group in COMPONENTS:
            if name in entry:
                dimension = "N" if group == "force" else "N m"
                amplitude, phase = _phasor(reader, entry, name, path, dimension)
                predicted.append((order, name, amplitude * complex(math.cos(phase), math.sin(phase))))
    return VerifyRequest(orders, cancel, speed, tuple(predicted), tolerance)


def _phasor(reader: Collector, entry: Mapping, key: str, path: str, units: str) -> tuple[float, float]:
    """A phasor written as [amplitude, phase], e.g. ["12.5 N", "30 deg"]."""
    raw = entry[key]
    if not isinstance(raw, list) or len(raw) != 2:
        reader.fail(key_path(path, key), raw, f'must be [amplitude, phase], e.g. ["1.5 {units}", "30 deg"]')
        return math.nan, 0.0
    dimension = "force" if units == "N" else "moment"
    amplitude = reader.quantity({key: raw[0]}, key, path, dimension, nonnegative=True)
    phase = reader.quantity({key: raw[1]}, key, path, "angle")
    return amplitude, phase

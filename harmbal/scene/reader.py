"""Scene files: schema, units, defaults with per-cylinder overrides, validation.

A scene is a TOML file (or an equivalent mapping) describing one engine. It is
read once into a frozen :class:`Scene` holding plain SI floats; nothing
downstream parses units or checks input again. Every problem found is
collected and reported together in a :class:`SceneError`, each naming the
source, the key path, the offending value and the rule it breaks.

The format is documented in ``docs/scenes.md``; keep the two in step.
"""

from __future__ import annotations

import math
import os
import tomllib
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any, Mapping

import numpy as np

from .elements import PRODUCT_CONVENTIONS, Shaft, ShaftUnbalance, couple_from_moment, couple_from_products
from .requests import (CANCEL, COMPONENTS, LEVER_OBJECTIVES, LEVER_SIGNALS, OBJECTIVES, PEAK_SIGNALS, Candidate, DesignRequest, LeverDesignRequest, VerifyRequest)
from .elements import (ASSEMBLY_MODES, TRANSMISSION_WARNING, LeverBalancer, LinkageWarning, LinkBody, closure, closure_message)
from .units import QuantityError, to_si

EFFECTS = ("reciprocating", "rotating", "rod_inertia", "mass_torque", "balancers")
ROD_MODELS = ("rigid", "two_point", "two_point_couple")
PISTON_MODELS = ("exact", "series")
ROTATIONS = ("clockwise", "counterclockwise")

DEFAULT_ACCURACY = 1e-12
DEFAULT_MAX_ORDER = 12
#: Most speeds a sweep may ask for (one evaluation serves them all; 10⁶ keeps the Datasets ~1 GB at most).
MAX_SPEEDS = 1_000_000


# --------------------------------------------------------------------------
# Problems


@dataclass(frozen=True)
class Problem:
    """One thing wrong with a scene: where, what value, which rule."""

    source: str
    key: str
    value: Any
    rule: str

    def __str__(self) -> str:
        shown = "" if self.value is _MISSING else f" = {self.value!r}"
        return f"{self.source}: {self.key}{shown}: {self.rule}"


class SceneError(ValueError):
    """A scene that cannot be used; ``problems`` lists every reason."""

    def __init__(self, problems: list[Problem]):
        self.problems = list(problems)
        super().__init__("\n".join(str(p) for p in self.problems))


class _Missing:
    def __repr__(self) -> str:
        return "<missing>"


_MISSING = _Missing()


# --------------------------------------------------------------------------
# The validated scene (SI units throughout)


@dataclass(frozen=True)
class Piston:
    """Piston group: mass [kg] and CG offset from the piston-pin axis [m]
    (``cg_axial`` along the cylinder axis away from the crank, ``cg_lateral``
    perpendicular to it, positive in the direction of rotation)."""

    mass: float
    cg_axial: float = 0.0
    cg_lateral: float = 0.0


@dataclass(frozen=True)
class ConRod:
    """Connecting rod as a rigid body.

    ``cg_from_big_end`` [m] is measured along the rod axis from the crank-pin
    centre; ``cg_lateral`` [m] is the CG's distance from the rod axis (positive
    to the side the direction of rotation points to when the rod is at top dead
    centre); ``inertia`` [kg m^2] is about the CG, ``None`` when the rod was
    given only as a two-point split.
    """

    mass: float
    cg_from_big_end: float
    cg_lateral: float = 0.0
    inertia: float | None = None

    def split(self, length: float) -> tuple[float, float]:
        """Big-end and small-end masses [kg] keeping mass and CG."""
        small = self.mass * self.cg_from_big_end / length
        return self.mass - small, small


@dataclass(frozen=True)
class Unbalance:
    """A rotating static unbalance: mass x radius [kg m] at ``angle`` [rad]
    (in the direction of rotation) and axial position ``x`` [m]."""

    unbalance: float
    angle: float
    x: float


@dataclass(frozen=True)
class Cylinder:
    """One cylinder with its own throw, bank, position, geometry and masses."""

    label: str
    throw: float
    bank: float
    x: float
    crank_radius: float
    rod_length: float
    pin_offset: float
    cylinder_offset: float
    piston: Piston
    rod: ConRod
    #: Unbalances on this throw; angles relative to the throw, x absolute.
    throw_unbalances: tuple[Unbalance, ...] = ()

    @property
    def offset(self) -> float:
        """Total offset [m] of the piston-pin path from the crank axis."""
        return self.pin_offset + self.cylinder_offset


@dataclass(frozen=True)
class Model:
    """What to simulate and with which approximations."""

    effects: frozenset[str] = frozenset(EFFECTS)
    piston: str = "exact"
    series_harmonics: int = 2
    rod: str = "rigid"


@dataclass(frozen=True)
class Sampling:
    """Either a fixed number of samples per revolution or a target accuracy."""

    samples_per_rev: int | None = None
    accuracy: float | None = DEFAULT_ACCURACY
    max_order: int = DEFAULT_MAX_ORDER


@dataclass(frozen=True)
class Scene:
    """A validated engine description in SI units.

    Build one with :func:`load_scene`.
    """

    name: str
    cycle: int
    rotation: str
    speeds: tuple[float, ...]
    reference_point: tuple[float, float, float]
    cylinders: tuple[Cylinder, ...]
    crankshaft_unbalances: tuple[Unbalance, ...] = ()
    #: Balance shafts, Lanchester pairs (two shafts each) and the crankshaft's
    #: CAD mass data (a shaft at ratio 1 on the crank axis).
    shafts: tuple[Shaft, ...] = ()
    #: Lever (linkage) balancers: four-bars driven by a second crank pin.
    levers: tuple[LeverBalancer, ...] = ()
    model: Model = field(default_factory=Model)
    sampling: Sampling = field(default_factory=Sampling)
    description: str = ""
    #: Firing order as cylinder indices (0-based), if the scene gives one.
    firing_order: tuple[int, ...] | None = None
    #: What ``harmbal design`` should design ([design]) and what
    #: ``harmbal verify`` checks ([verify]), if the scene says.
    design: DesignRequest | LeverDesignRequest | None = None
    verify: VerifyRequest | None = None
    source: str = "<mapping>"
    source_text: str = ""

    def with_effects(self, effects: set[str] | frozenset[str]) -> "Scene":
        """The same scene simulating only those of its effects in ``effects``."""
        return replace(self, model=replace(self.model, effects=self.model.effects & effects))

    def with_speeds(self, speeds) -> "Scene":
        """The same scene at other crank speeds [rad/s] (any number, each > 0,
        distinct): one evaluation of the model serves them all (ω² scaling)."""
        values = np.atleast_1d(np.asarray(speeds, dtype=float))
        if values.ndim != 1 or values.size == 0 or not np.all(np.isfinite(values) & (values > 0)):
            raise ValueError("speeds must be a non-empty 1-D sequence of finite speeds > 0 [rad/s]")
        if np.unique(values).size != values.size:
            raise ValueError("speeds must be distinct")
        return replace(self, speeds=tuple(values.tolist()))

    @property
    def sense(self) -> int:
        """+1 if the crank turns about +x (counterclockwise seen from the
        front), -1 if clockwise seen from the front."""
        return 1 if self.rotation == "counterclockwise" else -1


# --------------------------------------------------------------------------
# Reading


def load_scene(path_or_mapping: str | os.PathLike | Mapping[str, Any]) -> Scene:
    """Read and validate a scene.

    Parameters
    ----------
    path_or_mapping : path-like or mapping
        A TOML scene file, or a mapping with the same structure (as returned
        by :func:`tomllib.load`).

    Returns
    -------
    Scene
        The validated scene, all quantities in SI units.

    Raises
    ------
    SceneError
        Listing every problem found (file, key path, value, rule).
    FileNotFoundError
        If a path is given and does not exist.
    """
    if isinstance(path_or_mapping, Mapping):
        import tomli_w

        data = dict(path_or_mapping)
        source = "<mapping>"
        try:
            text = tomli_w.dumps(data)
        except (TypeError, ValueError):
            text = repr(data)
    else:
        path = Path(path_or_mapping)
        return scene_from_text(path.read_text(encoding="utf-8"), str(path))
    return _read(data, text, source)


def scene_from_text(text: str, source: str = "<text>") -> Scene:
    """Read and validate a scene from TOML text, naming ``source`` in errors."""
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise SceneError([Problem(source, "(file)", _MISSING, f"TOML syntax error: {exc}")]) from None
    return _read(data, text, source)


def _read(data: Mapping, text: str, source: str) -> Scene:
    reader = _Reader(source)
    scene = reader.scene(data, text)
    if reader.problems:
        raise SceneError(reader.problems)
    import warnings

    for message in reader.warnings:
        warnings.warn(message, LinkageWarning, stacklevel=3)
    return scene


_TOP_KEYS = {
    "engine", "model", "sampling", "geometry", "piston", "rod",
    "throw_unbalance", "cylinder", "crankshaft_unbalance", "crankshaft", "counterweight", "balance_shaft",
    "lanchester_pair", "lever_balancer", "design", "verify",
}
_SWEEP_KEYS = {"from", "to", "points"}
_ENGINE_KEYS = {"name", "description", "cycle", "rotation", "speed", "reference_point", "firing_order"}
_MODEL_KEYS = {"effects", "piston", "series_harmonics", "rod"}
_SAMPLING_KEYS = {"samples_per_rev", "accuracy", "max_order"}
_GEOMETRY_KEYS = {"crank_radius", "rod_length", "pin_offset", "cylinder_offset"}
_PISTON_KEYS = {"mass", "cg_offset"}
_ROD_RIGID_KEYS = {"mass", "cg_from_big_end", "cg_offset", "inertia"}
_ROD_SPLIT_KEYS = {"mass_big_end", "mass_small_end"}
_CYLINDER_KEYS = {"label", "throw", "bank", "axial_position", "geometry", "piston", "rod", "throw_unbalance"}
_UNBALANCE_KEYS = {"unbalance", "mass", "radius", "angle"}
_PRODUCT_KEYS = {"xy", "xz", "convention"}
_SHAFT_KEYS = {"label", "ratio", "axis_position", "unbalance", "couple", "couple_angle", "products_of_inertia"}
_CRANKSHAFT_KEYS = {"mass", "cg_offset", "axial_position", "products_of_inertia"}
_LANCHESTER_KEYS = {"label", "order", "unbalance", "mass", "radius", "angle", "phase", "axial_position", "heights",
                    "lateral"}
_LEVER_KEYS = {"label", "axial_position", "pin_radius", "pin_angle", "pivot", "rocker_length", "coupler_length",
               "assembly", "rocker", "coupler"}
_LINK_KEYS = {"mass", "cg", "inertia"}
_COUNTERWEIGHT_KEYS = {"label", "unbalance", "mass", "radius", "angle", "axial_position"}
_DESIGN_KEYS = {"orders", "cancel", "objective", "peak", "counterweights", "balance_shaft", "moment_shaft",
                "lanchester_pair", "lever"}
_LEVER_DESIGN_KEYS = {"label", "signals", "weights", "mass", "cg_x", "cg_y"}
_CANDIDATE_KEYS = {
    "counterweights": {"label", "planes", "balance_factor", "max_unbalance"},
    "balance_shaft": {"label", "ratio", "axis_position", "planes", "max_unbalance"},
    "moment_shaft": {"label", "ratio", "axis_position", "planes", "max_unbalance"},
    "lanchester_pair": {"label", "order", "axial_position", "heights", "lateral", "max_unbalance"},
}
_VERIFY_KEYS = {"orders", "cancel", "speed", "tolerance", "predicted"}
_PREDICTED_KEYS = {"order"} | {name for name, _ in COMPONENTS}


class _Reader:
    """Walks the raw mapping, converts units, and collects problems."""

    def __init__(self, source: str):
        self.source = source
        self.problems: list[Problem] = []
        self.warnings: list[str] = []

    # -- primitives --------------------------------------------------------

    def fail(self, key: str, value: Any, rule: str) -> None:
        problem = Problem(self.source, key, value, rule)
        if problem not in self.problems:  # a shared key is checked once per cylinder
            self.problems.append(problem)

    def table(self, parent: Mapping, key: str, path: str, allowed: set[str], required: bool = False) -> dict:
        value = parent.get(key, _MISSING)
        if value is _MISSING:
            if required:
                self.fail(path, _MISSING, "missing required table")
            return {}
        if not isinstance(value, Mapping):
            self.fail(path, value, "must be a table")
            return {}
        self.unknown(value, path, allowed)
        return dict(value)

    def unknown(self, table: Mapping, path: str, allowed: set[str]) -> None:
        for key in table:
            if key not in allowed:
                hint = _closest(key, allowed)
                self.fail(_join(path, key), table[key],
                          "unknown key" + (f" (did you mean {hint!r}?)" if hint else "")
                          + f"; allowed: {', '.join(sorted(allowed))}")

    def quantity(self, table: Mapping, key: str, path: str, dimension: str, default: Any = _MISSING,
                 positive: bool = False, nonnegative: bool = False) -> float:
        value = table.get(key, default)
        where = _join(path, key)
        if value is _MISSING:
            self.fail(where, _MISSING, "missing required key")
            return math.nan
        try:
            si = to_si(value, dimension)
        except QuantityError as exc:
            self.fail(where, value, str(exc))
            return math.nan
        if dimension == "angle" and not isinstance(value, str) and abs(si) > 2 * math.pi:
            self.fail(where, value, "plain numbers are radians; this looks like degrees, write e.g. "
                      f"\"{value} deg\"")
            return math.nan
        if positive and not si > 0:
            self.fail(where, value, "must be positive")
        elif nonnegative and not si >= 0:
            self.fail(where, value, "must not be negative")
        return si

    def choice(self, table: Mapping, key: str, path: str, options: tuple, default: Any) -> Any:
        value = table.get(key, default)
        if value not in options:
            self.fail(_join(path, key), value, f"must be one of {', '.join(map(repr, options))}")
            return default
        return value

    def integer(self, table: Mapping, key: str, path: str, default: Any, minimum: int) -> int | None:
        value = table.get(key, default)
        if value is None:
            return None
        if isinstance(value, bool) or not isinstance(value, int):
            self.fail(_join(path, key), value, "must be an integer")
            return default
        if value < minimum:
            self.fail(_join(path, key), value, f"must be at least {minimum}")
            return default
        return value

    def string(self, table: Mapping, key: str, path: str, default: Any = _MISSING) -> str:
        value = table.get(key, default)
        if value is _MISSING:
            self.fail(_join(path, key), _MISSING, "missing required key")
            return ""
        if not isinstance(value, str):
            self.fail(_join(path, key), value, "must be a string")
            return ""
        return value

    def quantity_list(self, table: Mapping, key: str, path: str, dimension: str, length: int,
                      default: Any) -> tuple[float, ...]:
        value = table.get(key, default)
        if not isinstance(value, list) or len(value) != length:
            self.fail(_join(path, key), value, f"must be a list of {length} quantities")
            return (math.nan,) * length
        items = {f"{key}[{i + 1}]": v for i, v in enumerate(value)}
        return tuple(self.quantity(items, k, path, dimension) for k in items)

    # -- sections ----------------------------------------------------------

    def scene(self, data: Mapping, text: str) -> Scene:
        self.unknown(data, "", _TOP_KEYS)
        engine = self.table(data, "engine", "engine", _ENGINE_KEYS, required=True)
        name = self.string(engine, "name", "engine")
        description = self.string(engine, "description", "engine", "")
        cycle = engine.get("cycle", 4)
        if not isinstance(cycle, int) or isinstance(cycle, bool) or cycle not in (2, 4):
            self.fail("engine.cycle", cycle, "must be 2 or 4 (strokes)")
            cycle = 4
        rotation = self.choice(engine, "rotation", "engine", ROTATIONS, "clockwise")
        speeds = self.speeds(engine)
        reference = self.quantity_list(engine, "reference_point", "engine", "length", 3, [0, 0, 0])

        model = self.model(self.table(data, "model", "model", _MODEL_KEYS))
        sampling = self.sampling(self.table(data, "sampling", "sampling", _SAMPLING_KEYS))

        shared = {
            "geometry": self.table(data, "geometry", "geometry", _GEOMETRY_KEYS),
            "piston": self.table(data, "piston", "piston", _PISTON_KEYS),
            "rod": self.table(data, "rod", "rod", _ROD_RIGID_KEYS | _ROD_SPLIT_KEYS),
        }
        shared_unbalances = data.get("throw_unbalance", [])
        cylinders = self.cylinders(data.get("cylinder", _MISSING), shared, shared_unbalances, model)
        crankshaft = tuple(self.unbalances(data.get("crankshaft_unbalance", []), "crankshaft_unbalance",
                                           "axial_position"))
        firing_order = self.firing_order(engine, cylinders, cycle)
        sense = 1 if rotation == "counterclockwise" else -1
        shafts = (self.crankshaft(data, sense) + self.counterweights(data.get("counterweight", []))
                  + self.balance_shafts(data.get("balance_shaft", []), sense)
                  + self.lanchester_pairs(data.get("lanchester_pair", [])))
        levers = self.lever_balancers(data.get("lever_balancer", []), sense)
        fastest = max((abs(s.ratio) for s in shafts), default=0)
        if (sampling.samples_per_rev is not None and "balancers" in model.effects
                and sampling.samples_per_rev <= fastest + sampling.max_order):
            self.fail("sampling.samples_per_rev", sampling.samples_per_rev,
                      f"a balancer element turning at {fastest}× would alias into the orders kept: must be more "
                      f"than its |ratio| + max_order = {fastest + sampling.max_order}")
        labels = [s.label for s in shafts] + [lever.label for lever in levers]
        for label in sorted({x for x in labels if labels.count(x) > 1}):
            self.fail("balancer elements", label, "two balancer elements have this label; labels must be unique")
        requests = {}
        for key, allowed, read in (("design", _DESIGN_KEYS, self.design), ("verify", _VERIFY_KEYS, self.verify)):
            table = self.table(data, key, key, allowed)  # reports a non-table and unknown keys
            requests[key] = read(table, sampling.max_order) if isinstance(data.get(key), Mapping) else None
        design, verify = requests["design"], requests["verify"]
        return Scene(name=name, description=description, cycle=cycle, rotation=rotation, speeds=speeds,
                     reference_point=reference, cylinders=cylinders, crankshaft_unbalances=crankshaft, shafts=shafts,
                     levers=levers, model=model, sampling=sampling, firing_order=firing_order, design=design, verify=verify,
                     source=self.source, source_text=text)

    # -- design and verification requests -----------------------------------

    def orders(self, table: Mapping, path: str, max_order: int) -> tuple[int, ...]:
        raw = table.get("orders", _MISSING)
        where = _join(path, "orders")
        if raw is _MISSING:
            self.fail(where, raw, "missing: the orders to balance, e.g. [1, 2]")
            return ()
        if (not isinstance(raw, list) or not raw
                or any(isinstance(k, bool) or not isinstance(k, int) or not 1 <= k <= max_order for k in raw)):
            self.fail(where, raw, f"must be a non-empty list of orders from 1 to sampling.max_order = {max_order}")
            return ()
        if len(set(raw)) != len(raw):
            self.fail(where, raw, "an order is listed twice")
        return tuple(sorted(set(raw)))

    def names(self, table: Mapping, key: str, path: str, options: tuple[str, ...], default: tuple) -> tuple[str, ...]:
        raw = table.get(key, list(default))
        if not isinstance(raw, list) or not raw or any(v not in options for v in raw):
            self.fail(_join(path, key), raw, f"must be a non-empty list of {', '.join(map(repr, options))}")
            return default
        return tuple(v for v in options if v in raw)

    def lengths(self, table: Mapping, key: str, path: str, count: int | None = None) -> tuple[float, ...]:
        """A list of lengths (any number ≥ 1, or exactly ``count``), distinct."""
        raw = table.get(key, _MISSING)
        where = _join(path, key)
        if not isinstance(raw, list) or not raw or (count is not None and len(raw) != count):
            self.fail(where, raw, f"must be a list of {count or 'one or more'} axial positions (lengths)")
            return ()
        values = tuple(self.quantity({f"{key}[{i + 1}]": v}, f"{key}[{i + 1}]", path, "length")
                       for i, v in enumerate(raw))
        if len(set(values)) != len(values):
            self.fail(where, raw, "planes must be at distinct axial positions")
        return values

    def ratio(self, entry: Mapping, key: str, path: str) -> int:
        ratio = entry.get(key, _MISSING)
        if ratio is _MISSING:
            self.fail(_join(path, key), ratio, "missing: the speed ratio n (negative turns against the crank)")
        elif isinstance(ratio, bool) or not isinstance(ratio, int) or ratio == 0:
            self.fail(_join(path, key), ratio, "must be a non-zero integer (negative turns against the crank)")
        else:
            return ratio
        return 1

    def candidate(self, kind: str, path: str, entry: Mapping, max_order: int) -> Candidate:
        self.unknown(entry, path, _CANDIDATE_KEYS[kind])
        number = path.rsplit("[", 1)[-1].rstrip("]")
        label = self.string(entry, "label", path, "counterweights" if kind == "counterweights"
                            else f"{kind.replace('_', ' ')} {number}")
        bound = (self.quantity(entry, "max_unbalance", path, "unbalance", positive=True)
                 if "max_unbalance" in entry else None)
        if kind == "counterweights":
            factor = None
            if "balance_factor" in entry:
                factor = self.quantity(entry, "balance_factor", path, "dimensionless")
                if math.isfinite(factor) and not 0 <= factor <= 1:
                    self.fail(_join(path, "balance_factor"), entry["balance_factor"],
                              "must lie in [0, 1]: the share of the reciprocating masses the counterweights carry "
                              "besides the rotating masses")
            return Candidate(kind, label, 1, self.lengths(entry, "planes", path), balance_factor=factor,
                             max_unbalance=bound)
        if kind == "lanchester_pair":
            order = 1
            if "order" in entry:
                order = self.integer(entry, "order", path, 1, 1)
                if order > max_order:
                    self.fail(_join(path, "order"), order, f"must not exceed sampling.max_order = {max_order}")
            else:
                self.fail(_join(path, "order"), _MISSING, "missing: the order n the pair cancels (shafts at ±n×)")
            x = self.quantity(entry, "axial_position", path, "length", default=0.0)
            heights = self.quantity_list(entry, "heights", path, "length", 2, [0, 0])
            lateral = self.quantity_list(entry, "lateral", path, "length", 2, [0, 0])
            return Candidate(kind, label, order, (x,), heights=heights, lateral=lateral, max_unbalance=bound)
        y, z = self.position(entry, "axis_position", path)
        planes = self.lengths(entry, "planes", path, 2 if kind == "moment_shaft" else None)
        ratio = self.ratio(entry, "ratio", path)
        if abs(ratio) > max_order:
            self.fail(_join(path, "ratio"), ratio, f"|ratio| must not exceed sampling.max_order = {max_order}")
        return Candidate(kind, label, ratio, planes, y=y, z=z, max_unbalance=bound)

    def design(self, raw: dict, max_order: int) -> DesignRequest | LeverDesignRequest:
        if "lever" in raw:
            return self.lever_design(raw, max_order)
        orders = self.orders(raw, "design", max_order)
        cancel = self.names(raw, "cancel", "design", CANCEL, ("force", "moment"))
        objective = self.choice(raw, "objective", "design", OBJECTIVES, "least_squares")
        peak = self.names(raw, "peak", "design", PEAK_SIGNALS, ("moment_y", "moment_z"))
        if "peak" in raw and objective != "peak":
            self.fail("design.peak", raw["peak"], 'only used with objective = "peak"')
        candidates = [self.candidate(kind, path, entry, max_order) for kind in _CANDIDATE_KEYS
                      for path, entry in self.array(raw.get(kind, []), f"design.{kind}")]
        if not candidates:
            self.fail("design", sorted(raw), "give at least one candidate element: "
                      + ", ".join(f"[[design.{k}]]" for k in _CANDIDATE_KEYS))
        labels = [c.label for c in candidates]
        for label in sorted({x for x in labels if labels.count(x) > 1}):
            self.fail("design", label, "two candidate elements have this label; labels must be unique")
        return DesignRequest(orders, tuple(candidates), cancel, objective, peak)

    def lever_design(self, raw: dict, max_order: int) -> LeverDesignRequest:
        """[design] with a [design.lever] table: the optimal balance weight."""
        others = sorted(set(raw) & (set(_CANDIDATE_KEYS) | {"cancel", "peak"}))
        if others:
            self.fail("design", others, "a lever design optimises the balance weight alone; design other elements "
                      "in a separate [design] run")
        objective = self.choice(raw, "objective", "design", LEVER_OBJECTIVES, "peak_to_peak")
        orders = self.orders(raw, "design", max_order) if "orders" in raw else (1,)
        if "orders" in raw and objective != "orders":
            self.fail("design.orders", raw["orders"], 'only used with objective = "orders"')
        lever = self.table(raw, "lever", "design.lever", _LEVER_DESIGN_KEYS)
        label = self.string(lever, "label", "design.lever", None) if "label" in lever else None
        signals = self.names(lever, "signals", "design.lever", LEVER_SIGNALS, ("force_y", "force_z"))
        weights: tuple[float, ...] = ()
        if "weights" in lever:
            raw_weights = lever["weights"]
            if (objective != "orders" or not isinstance(raw_weights, list) or len(raw_weights) != len(orders)
                    or any(isinstance(w, bool) or not isinstance(w, (int, float)) or not w >= 0 for w in raw_weights)):
                self.fail("design.lever.weights", raw_weights, "one non-negative number per order of design.orders, "
                          'with objective = "orders"')
            else:
                weights = tuple(float(w) for w in raw_weights)
        bounds = {}
        for key, dimension in (("mass", "mass"), ("cg_x", "length"), ("cg_y", "length")):
            if key in lever:
                low, high = self.quantity_list(lever, key, "design.lever", dimension, 2, _MISSING)
                if math.isfinite(low) and math.isfinite(high) and not low <= high:
                    self.fail(f"design.lever.{key}", lever[key], "must be [low, high] with low <= high")
                if key == "mass" and math.isfinite(low) and low < 0:
                    self.fail("design.lever.mass", lever[key], "masses must not be negative")
                bounds[key] = (low, high)
        return LeverDesignRequest(label, objective, signals, orders, weights, bounds.get("mass"), bounds.get("cg_x"),
                                  bounds.get("cg_y"))

    def verify(self, raw: dict, max_order: int) -> VerifyRequest:
        orders = self.orders(raw, "verify", max_order)
        cancel = self.names(raw, "cancel", "verify", CANCEL, ("force", "moment"))
        speed = self.quantity(raw, "speed", "verify", "speed", positive=True) if "speed" in raw else None
        tolerance = self.quantity(raw, "tolerance", "verify", "dimensionless", default=0.0, nonnegative=True)
        if math.isfinite(tolerance) and tolerance >= 1:
            self.fail("verify.tolerance", raw["tolerance"], "must lie in [0, 1): the share of each value without "
                      "balancers that may remain")
        predicted = []
        if "predicted" in raw and speed is None:
            self.fail("verify.predicted", _MISSING, "needs verify.speed, the speed the predictions are given at")
        for path, entry in self.array(raw.get("predicted", []), "verify.predicted"):
            self.unknown(entry, path, _PREDICTED_KEYS)
            order = self.integer(entry, "order", path, 0, 1)
            if order not in orders:
                self.fail(_join(path, "order"), entry.get("order"), "must be one of verify.orders")
            for name, group in COMPONENTS:
                if name in entry:
                    dimension = "N" if group == "force" else "N m"
                    amplitude, phase = self.phasor(entry, name, path, dimension)
                    predicted.append((order, name, amplitude * complex(math.cos(phase), math.sin(phase))))
        return VerifyRequest(orders, cancel, speed, tuple(predicted), tolerance)

    def phasor(self, entry: Mapping, key: str, path: str, units: str) -> tuple[float, float]:
        """A phasor written as [amplitude, phase], e.g. ["12.5 N", "30 deg"]."""
        raw = entry[key]
        if not isinstance(raw, list) or len(raw) != 2:
            self.fail(_join(path, key), raw, f'must be [amplitude, phase], e.g. ["1.5 {units}", "30 deg"]')
            return math.nan, 0.0
        dimension = "force" if units == "N" else "moment"
        amplitude = self.quantity({key: raw[0]}, key, path, dimension, nonnegative=True)
        phase = self.quantity({key: raw[1]}, key, path, "angle")
        return amplitude, phase

    # -- balancer elements -------------------------------------------------

    def array(self, raw: Any, path: str) -> list[tuple[str, Mapping]]:
        """Entries of an array of tables with their key paths."""
        if not isinstance(raw, list) or not all(isinstance(e, Mapping) for e in raw):
            self.fail(path, raw, "must be an array of tables ([[...]])")
            return []
        return [(f"{path}[{i + 1}]", e) for i, e in enumerate(raw)]

    def position(self, table: Mapping, key: str, path: str) -> tuple[float, float]:
        """A transverse position [y, z]."""
        y, z = self.quantity_list(table, key, path, "length", 2, [0, 0])
        return y, z

    def couple(self, entry: Mapping, path: str, sense: int) -> complex:
        """A couple unbalance as a moment with its angle or as products of
        inertia with a named convention (not both)."""
        if "couple" in entry and "products_of_inertia" in entry:
            self.fail(path, sorted(entry), "give couple (with couple_angle) or products_of_inertia, not both")
            return 0j
        if "couple" in entry:
            size = self.quantity(entry, "couple", path, "inertia", nonnegative=True)
            return couple_from_moment(size, self.quantity(entry, "couple_angle", path, "angle", default=0.0))
        if "couple_angle" in entry:
            self.fail(_join(path, "couple_angle"), entry["couple_angle"], "only with couple")
        if "products_of_inertia" not in entry:
            return 0j
        where = _join(path, "products_of_inertia")
        products = self.table(entry, "products_of_inertia", where, _PRODUCT_KEYS)
        if "convention" not in products:
            self.fail(_join(where, "convention"), _MISSING,
                      "missing: name the sign convention, 'integral' (J_xy = +∫xy dm) or 'tensor' (−∫xy dm)")
            return 0j
        convention = self.choice(products, "convention", where, PRODUCT_CONVENTIONS, "integral")
        j_xy = self.quantity(products, "xy", where, "inertia", default=0.0)
        j_xz = self.quantity(products, "xz", where, "inertia", default=0.0)
        return couple_from_products(j_xy, j_xz, convention, sense)

    def balance_shafts(self, raw: Any, sense: int) -> tuple[Shaft, ...]:
        shafts = []
        for path, entry in self.array(raw, "balance_shaft"):
            self.unknown(entry, path, _SHAFT_KEYS)
            label = entry.get("label", f"shaft {len(shafts) + 1}")
            ratio = entry.get("ratio", _MISSING)
            if ratio is _MISSING:
                self.fail(_join(path, "ratio"), ratio, "missing: the speed ratio n (negative turns against the crank)")
                ratio = 1
            elif isinstance(ratio, bool) or not isinstance(ratio, int) or ratio == 0:
                self.fail(_join(path, "ratio"), ratio, "must be a non-zero integer (negative turns against the crank)")
                ratio = 1
            y, z = self.position(entry, "axis_position", path)
            unbalances = tuple(ShaftUnbalance(u.unbalance, u.angle, u.x) for u in
                               self.unbalances(entry.get("unbalance", []), _join(path, "unbalance"), "axial_position"))
            shafts.append(Shaft(str(label), ratio, y, z, unbalances, self.couple(entry, path, sense)))
        return tuple(shafts)

    def counterweights(self, raw: Any) -> tuple[Shaft, ...]:
        """Crank counterweights: static unbalances turning with the crank on
        its axis, angles relative to throw 1."""
        shafts = []
        for path, entry in self.array(raw, "counterweight"):
            self.unknown(entry, path, _COUNTERWEIGHT_KEYS)
            label = self.string(entry, "label", path, f"counterweight {len(shafts) + 1}")
            u = self.unbalance_size(entry, path)
            angle = self.quantity(entry, "angle", path, "angle", default=0.0)
            x = self.quantity(entry, "axial_position", path, "length", default=0.0)
            shafts.append(Shaft(label, 1, 0.0, 0.0, (ShaftUnbalance(u, angle, x),)))
        return tuple(shafts)

    def crankshaft(self, data: Mapping, sense: int) -> tuple[Shaft, ...]:
        """The crankshaft's CAD mass data as a shaft turning with the crank."""
        if "crankshaft" not in data:
            return ()
        entry = self.table(data, "crankshaft", "crankshaft", _CRANKSHAFT_KEYS)
        mass = self.quantity(entry, "mass", "crankshaft", "mass", positive=True)
        y, z = self.position(entry, "cg_offset", "crankshaft")
        x = self.quantity(entry, "axial_position", "crankshaft", "length", default=0.0)
        w = complex(z, -sense * y)  # w = z + i·t, t = −sense·y
        unbalances = (ShaftUnbalance(mass * abs(w), math.atan2(w.imag, w.real), x),) if w else ()
        return (Shaft("crankshaft", 1, 0.0, 0.0, unbalances, self.couple(entry, "crankshaft", sense)),)

    def lanchester_pairs(self, raw: Any) -> tuple[Shaft, ...]:
        """Each pair: two shafts at +n and −n with equal unbalances pointing
        the same way at θ = 0, at given heights (z) and lateral positions (y)."""
        shafts = []
        for path, entry in self.array(raw, "lanchester_pair"):
            self.unknown(entry, path, _LANCHESTER_KEYS)
            label = str(entry.get("label", f"Lanchester pair {len(shafts) // 2 + 1}"))
            if "order" in entry:
                order = self.integer(entry, "order", path, 1, 1)
            else:
                self.fail(_join(path, "order"), _MISSING, "missing: the order n the pair cancels (shafts at ±n×)")
                order = 1
            u = self.unbalance_size(entry, path)
            angle = self.quantity(entry, "angle", path, "angle", default=0.0)
            phase = self.quantity(entry, "phase", path, "angle", default=0.0)
            x = self.quantity(entry, "axial_position", path, "length", default=0.0)
            heights = self.quantity_list(entry, "heights", path, "length", 2, [0, 0])
            lateral = self.quantity_list(entry, "lateral", path, "length", 2, [0, 0])
            for ratio, y, z, side, sign in ((order, lateral[0], heights[0], "+", 1), (-order, lateral[1], heights[1],
                                                                                       "−", -1)):
                shafts.append(Shaft(f"{label} ({side}{order}×)", ratio, y, z,
                                    (ShaftUnbalance(u, angle + sign * phase, x),)))
        return tuple(shafts)

    def lever_balancers(self, raw: Any, sense: int) -> tuple[LeverBalancer, ...]:
        """Four-bar lever balancers, refused unless the loop closes at every
        crank angle (with the link lengths and the failing angle named)."""
        levers = []
        for path, entry in self.array(raw, "lever_balancer"):
            self.unknown(entry, path, _LEVER_KEYS)
            label = self.string(entry, "label", path, f"lever balancer {len(levers) + 1}")
            x = self.quantity(entry, "axial_position", path, "length", default=0.0)
            radius = self.quantity(entry, "pin_radius", path, "length", positive=True)
            angle = self.quantity(entry, "pin_angle", path, "angle")
            pivot = self.quantity_list(entry, "pivot", path, "length", 2, _MISSING)
            rocker_length = self.quantity(entry, "rocker_length", path, "length", positive=True)
            coupler_length = self.quantity(entry, "coupler_length", path, "length", positive=True)
            assembly = "ahead"
            if "assembly" in entry:
                assembly = self.choice(entry, "assembly", path, tuple(ASSEMBLY_MODES), "ahead")
            else:
                self.fail(_join(path, "assembly"), _MISSING, "missing: the assembly mode, \"ahead\" or \"behind\" "
                          "(B ahead of or behind the line from the pivot A to the pin C, in the direction of rotation)")
            bodies = {}
            for name in ("rocker", "coupler"):
                where = _join(path, name)
                table = self.table(entry, name, where, _LINK_KEYS, required=True)
                bodies[name] = LinkBody(self.quantity(table, "mass", where, "mass", nonnegative=True),
                                        self.quantity_list(table, "cg", where, "length", 2, [0, 0]),
                                        self.quantity(table, "inertia", where, "inertia", nonnegative=True))
            lever = LeverBalancer(label, x, radius, angle, pivot, rocker_length, coupler_length, assembly,
                                  bodies["rocker"], bodies["coupler"])
            values = (x, radius, angle, *pivot, rocker_length, coupler_length)
            if all(math.isfinite(v) for v in values) and radius > 0 and rocker_length > 0 and coupler_length > 0:
                check = closure(lever, sense)
                if check.failure is not None:
                    self.fail(path, {"pivot": entry.get("pivot"), "pin_radius": entry.get("pin_radius"),
                                     "rocker_length": entry.get("rocker_length"),
                                     "coupler_length": entry.get("coupler_length")}, closure_message(lever, check))
                elif check.min_transmission_angle < TRANSMISSION_WARNING and check.distance[1] > check.distance[0]:
                    # (a pivot on the crank axis turns the links rigidly: a constant γ is no toggle)
                    self.warnings.append(
                        f"{self.source}: {path} ({label}): minimum transmission angle "
                        f"{math.degrees(check.min_transmission_angle):.3g}° at θ = "
                        f"{math.degrees(check.min_transmission_theta):.6g}° (below "
                        f"{math.degrees(TRANSMISSION_WARNING):.0f}°): close to the toggle position, where the links' "
                        "accelerations and the joint forces grow without bound")
            levers.append(lever)
        return tuple(levers)

    def firing_order(self, engine: Mapping, cylinders: tuple[Cylinder, ...], cycle: int) -> tuple[int, ...] | None:
        """The firing order as cylinder indices, checked against the geometry."""
        from .firing import FiringOrderError, cylinder_firing

        raw = engine.get("firing_order", _MISSING)
        if raw is _MISSING:
            return None
        key = "engine.firing_order"
        labels = [c.label for c in cylinders]
        if not isinstance(raw, list) or any(isinstance(v, bool) or not isinstance(v, (str, int)) for v in raw):
            self.fail(key, raw, "must be a list of cylinder labels")
            return None
        given = [str(v) for v in raw]
        if sorted(given) != sorted(labels):
            self.fail(key, raw, f"must name every cylinder exactly once: {', '.join(labels)}")
            return None
        order = tuple(labels.index(v) for v in given)
        if self.problems:  # the geometry may be invalid; check the order once it is not
            return order
        try:
            cylinder_firing(cylinders, cycle, order)
        except FiringOrderError as exc:
            self.fail(key, raw, f"not possible with these throws and banks: {exc}")
            return None
        return order

    def speeds(self, engine: Mapping) -> tuple[float, ...]:
        raw = engine.get("speed", _MISSING)
        if isinstance(raw, Mapping):
            return self.speed_sweep(raw)
        if isinstance(raw, list):
            if not raw:
                self.fail("engine.speed", raw, "give at least one speed")
            items = {f"speed[{i + 1}]": v for i, v in enumerate(raw)}
            speeds = tuple(self.quantity(items, key, "engine", "speed", positive=True) for key in items)
        else:
            speeds = (self.quantity(engine, "speed", "engine", "speed", positive=True),)
        finite = [s for s in speeds if math.isfinite(s)]
        if len(set(finite)) != len(finite):
            self.fail("engine.speed", raw, "speeds must be distinct")
        return speeds

    def speed_sweep(self, table: Mapping) -> tuple[float, ...]:
        """``speed = {from = ..., to = ..., points = N}``: N speeds evenly spaced."""
        self.unknown(table, "engine.speed", _SWEEP_KEYS)
        low = self.quantity(table, "from", "engine.speed", "speed", positive=True)
        high = self.quantity(table, "to", "engine.speed", "speed", positive=True)
        if "points" not in table:
            self.fail("engine.speed.points", _MISSING, "missing required key")
            return (math.nan,)
        points = self.integer(table, "points", "engine.speed", None, minimum=2)
        if points is None:
            return (math.nan,)
        if points > MAX_SPEEDS:
            self.fail("engine.speed.points", points, f"must be at most {MAX_SPEEDS}")
            return (math.nan,)
        if not (math.isfinite(low) and math.isfinite(high)):
            return (math.nan,)
        if not low < high:
            self.fail("engine.speed.to", table.get("to"), "must be above engine.speed.from")
            return (math.nan,)
        return tuple(np.linspace(low, high, points).tolist())

    def model(self, table: Mapping) -> Model:
        effects_raw = table.get("effects", list(EFFECTS))
        effects: set[str] = set()
        if not isinstance(effects_raw, list) or not all(isinstance(e, str) for e in effects_raw):
            self.fail("model.effects", effects_raw, "must be a list of effect names")
        else:
            for effect in effects_raw:
                if effect not in EFFECTS:
                    hint = _closest(effect, set(EFFECTS))
                    self.fail("model.effects", effect, "unknown effect" + (f" (did you mean {hint!r}?)" if hint else "")
                              + f"; known: {', '.join(EFFECTS)}")
                effects.add(effect)
            if len(effects) != len(effects_raw):
                self.fail("model.effects", effects_raw, "an effect is listed twice")
        piston = self.choice(table, "piston", "model", PISTON_MODELS, "exact")
        harmonics = self.integer(table, "series_harmonics", "model", 2, minimum=1)
        if "series_harmonics" in table and piston != "series":
            self.fail("model.series_harmonics", table["series_harmonics"], 'only used with piston = "series"')
        rod = self.choice(table, "rod", "model", ROD_MODELS, "rigid")
        return Model(effects=frozenset(effects & set(EFFECTS)), piston=piston, series_harmonics=harmonics or 2, rod=rod)

    def sampling(self, table: Mapping) -> Sampling:
        max_order = self.integer(table, "max_order", "sampling", DEFAULT_MAX_ORDER, minimum=1)
        samples = self.integer(table, "samples_per_rev", "sampling", None, minimum=8)
        accuracy = None
        if "accuracy" in table:
            if samples is not None:
                self.fail("sampling.accuracy", table["accuracy"], "give samples_per_rev or accuracy, not both")
            accuracy = self.quantity(table, "accuracy", "sampling", "dimensionless", positive=True)
            if math.isfinite(accuracy) and not 1e-16 <= accuracy < 0.1:
                self.fail("sampling.accuracy", table["accuracy"], "must lie in [1e-16, 0.1) (relative error)")
        elif samples is None:
            accuracy = DEFAULT_ACCURACY
        if samples is not None and max_order is not None and samples < 2 * max_order + 2:
            self.fail("sampling.samples_per_rev", samples,
                      f"must be at least 2*max_order + 2 = {2 * max_order + 2} to resolve order {max_order}")
        return Sampling(samples_per_rev=samples, accuracy=accuracy, max_order=max_order or DEFAULT_MAX_ORDER)

    def cylinders(self, raw: Any, shared: dict, shared_unbalances: Any, model: Model) -> tuple[Cylinder, ...]:
        if raw is _MISSING:
            self.fail("cylinder", _MISSING, "missing: give at least one [[cylinder]]")
            return ()
        if not isinstance(raw, list) or not raw or not all(isinstance(c, Mapping) for c in raw):
            self.fail("cylinder", raw, "must be a non-empty array of tables ([[cylinder]])")
            return ()
        cylinders = []
        for i, entry in enumerate(raw):
            path = f"cylinder[{i + 1}]"
            self.unknown(entry, path, _CYLINDER_KEYS)
            cylinders.append(self.cylinder(entry, path, i, shared, shared_unbalances, model))
        self.check_distinct(cylinders)
        return tuple(cylinders)

    def cylinder(self, entry: Mapping, path: str, index: int, shared: dict, shared_unbalances: Any,
                 model: Model) -> Cylinder:
        label = entry.get("label", str(index + 1))
        if not isinstance(label, (str, int)) or isinstance(label, bool):
            self.fail(_join(path, "label"), label, "must be a string")
        label = str(label)
        throw = self.quantity(entry, "throw", path, "angle", default=0.0)
        bank = self.quantity(entry, "bank", path, "angle", default=0.0)
        x = self.quantity(entry, "axial_position", path, "length", default=0.0)

        def merged(name: str, allowed: set[str]) -> tuple[dict, dict[str, str]]:
            """Shared table overlaid by the cylinder's own, with the section
            each key was written in (missing keys are reported at the shared
            section, once for all cylinders)."""
            own = self.table(entry, name, _join(path, name), allowed)
            where = {k: _join(path, name) if k in own else name for k in {**shared[name], **own}}
            return {**shared[name], **own}, where

        geometry, gwhere = merged("geometry", _GEOMETRY_KEYS)
        r = self.quantity(geometry, "crank_radius", gwhere.get("crank_radius", "geometry"), "length", positive=True)
        l = self.quantity(geometry, "rod_length", gwhere.get("rod_length", "geometry"), "length", positive=True)
        e = self.quantity(geometry, "pin_offset", gwhere.get("pin_offset", "geometry"), "length", default=0.0)
        h = self.quantity(geometry, "cylinder_offset", gwhere.get("cylinder_offset", "geometry"), "length", default=0.0)
        if all(math.isfinite(v) for v in (r, l, e, h)) and r > 0 and l > 0 and not l > r + abs(e + h):
            own = sorted(k for k, w in gwhere.items() if w != "geometry")
            if own and "rod_length" not in own:  # the cylinder's own radius or offsets break it: name them
                key, value = _join(path, "geometry"), {k: geometry[k] for k in own}
            else:
                key, value = _join(gwhere["rod_length"], "rod_length"), geometry["rod_length"]
            self.fail(key, value,
                      f"the crank train cannot assemble: rod length {l * 1e3:.6g} mm must exceed crank radius "
                      f"+ |pin offset + cylinder offset| = {(r + abs(e + h)) * 1e3:.6g} mm")

        piston_t, pwhere = merged("piston", _PISTON_KEYS)
        piston_mass = self.quantity(piston_t, "mass", pwhere.get("mass", "piston"), "mass", positive=True)
        pcg = self.pair_at(piston_t, "cg_offset", pwhere, "piston")
        piston = Piston(piston_mass, *pcg)

        rod_t, rwhere = merged("rod", _ROD_RIGID_KEYS | _ROD_SPLIT_KEYS)
        rod = self.rod(rod_t, rwhere, path, l, model)

        unbalances = entry.get("throw_unbalance", shared_unbalances)
        upath = _join(path, "throw_unbalance") if "throw_unbalance" in entry else "throw_unbalance"
        throw_unbalances = tuple(
            Unbalance(u.unbalance, u.angle, x + u.x) for u in self.unbalances(unbalances, upath, "axial_offset")
        )
        return Cylinder(label=label, throw=throw, bank=bank, x=x, crank_radius=r, rod_length=l, pin_offset=e,
                        cylinder_offset=h, piston=piston, rod=rod, throw_unbalances=throw_unbalances)

    def pair_at(self, table: dict, key: str, where: dict[str, str], section: str) -> tuple[float, float]:
        return self.quantity_list(table, key, where.get(key, section), "length", 2, [0, 0])  # type: ignore

    def rod(self, table: dict, where: dict[str, str], path: str, length: float, model: Model) -> ConRod:
        """A rigid rod, or a two-point split converted to mass and CG."""
        split_keys = _ROD_SPLIT_KEYS & table.keys()
        rigid_keys = _ROD_RIGID_KEYS & table.keys()
        # Problems of the rod as a whole go where the cylinder wrote its rod
        # table, or to the shared [rod] table.
        section = _join(path, "rod") if _join(path, "rod") in where.values() else "rod"
        if split_keys and rigid_keys:
            self.fail(section, sorted(table), "give the rod either as a rigid body (mass, cg_from_big_end, "
                      "inertia) or as a two-point split (mass_big_end, mass_small_end), not both")
            return ConRod(math.nan, math.nan)
        if split_keys:
            big = self.quantity(table, "mass_big_end", where.get("mass_big_end", "rod"), "mass", positive=True)
            small = self.quantity(table, "mass_small_end", where.get("mass_small_end", "rod"), "mass", positive=True)
            if model.rod != "two_point":
                self.fail("model.rod", model.rod, f"{section} is given as a two-point split, which has no moment "
                          "of inertia; use rod = \"two_point\" or give mass, cg_from_big_end and inertia")
            return ConRod(big + small, length * small / (big + small))
        mass = self.quantity(table, "mass", where.get("mass", "rod"), "mass", positive=True)
        cg = self.quantity(table, "cg_from_big_end", where.get("cg_from_big_end", "rod"), "length", nonnegative=True)
        if math.isfinite(cg) and math.isfinite(length) and cg > length:
            self.fail(_join(where["cg_from_big_end"], "cg_from_big_end"), table["cg_from_big_end"],
                      f"must not exceed the rod length of {path} ({length * 1e3:.6g} mm)")
        lateral = self.quantity(table, "cg_offset", where.get("cg_offset", "rod"), "length", default=0.0)
        inertia = None
        if "inertia" in table:
            inertia = self.quantity(table, "inertia", where.get("inertia", "rod"), "inertia", positive=True)
        elif model.rod != "two_point":
            self.fail(_join(section, "inertia"), _MISSING,
                      f"missing: model.rod = {model.rod!r} needs the rod's moment of inertia about its CG")
        return ConRod(mass, cg, lateral, inertia)

    def unbalance_size(self, entry: Mapping, where: str) -> float:
        """Mass × radius [kg m], given as ``unbalance`` or as ``mass`` and ``radius``."""
        if "unbalance" in entry and ("mass" in entry or "radius" in entry):
            self.fail(where, sorted(entry), "give unbalance (mass x radius) or mass and radius, not both")
            return math.nan
        if "unbalance" in entry or not ("mass" in entry or "radius" in entry):
            return self.quantity(entry, "unbalance", where, "unbalance", positive=True)
        return (self.quantity(entry, "mass", where, "mass", positive=True)
                * self.quantity(entry, "radius", where, "length", positive=True))

    def unbalances(self, raw: Any, path: str, position_key: str) -> list[Unbalance]:
        entries = [raw] if isinstance(raw, Mapping) else raw
        if not isinstance(entries, list) or not all(isinstance(u, Mapping) for u in entries):
            self.fail(path, raw, "must be a table or an array of tables")
            return []
        result = []
        for i, entry in enumerate(entries):
            where = path if isinstance(raw, Mapping) else f"{path}[{i + 1}]"
            self.unknown(entry, where, _UNBALANCE_KEYS | {position_key})
            u = self.unbalance_size(entry, where)
            angle = self.quantity(entry, "angle", where, "angle", default=0.0)
            x = self.quantity(entry, position_key, where, "length", default=0.0)
            result.append(Unbalance(u, angle, x))
        return result

    def check_distinct(self, cylinders: list[Cylinder]) -> None:
        seen_labels: dict[str, int] = {}
        seen_places: dict[tuple, int] = {}
        for i, c in enumerate(cylinders, start=1):
            if c.label in seen_labels:
                self.fail(f"cylinder[{i}].label", c.label, f"duplicate of cylinder[{seen_labels[c.label]}]")
            seen_labels.setdefault(c.label, i)
            place = (round(math.remainder(c.throw, 2 * math.pi), 12), round(math.remainder(c.bank, 2 * math.pi), 12),
                     round(c.x, 12))
            if place in seen_places:
                self.fail(f"cylinder[{i}]", {"throw": c.throw, "bank": c.bank, "axial_position": c.x},
                          f"duplicate cylinder: same throw, bank and axial position as cylinder[{seen_places[place]}]")
            seen_places.setdefault(place, i)


def _join(path: str, key: str) -> str:
    return f"{path}.{key}" if path else key


def _closest(word: str, options: set[str]) -> str | None:
    import difflib

    matches = difflib.get_close_matches(word, sorted(options), n=1, cutoff=0.6)
    return matches[0] if matches else None

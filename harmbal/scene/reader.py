"""Scene files: reading a TOML scene (or an equivalent mapping) into a
validated :class:`~.schema.Scene`, units converted to SI and defaults filled
in, per-cylinder overrides merged.

Every problem found is collected and reported together in a
:class:`~.schema.SceneError`, each naming the source, the key path, the
offending value and the rule it breaks. This module holds the entry points,
the reader's primitives (collecting problems, tables and unknown keys,
quantities, choices, integers, strings, lists) and the assembly of the scene;
each group of tables is read by a mixin of its own module:
:mod:`.read_engine` ([engine], [model], [sampling]), :mod:`.read_cylinders`
([geometry], [piston], [rod], [[cylinder]], unbalances),
:mod:`.read_balancers` (balancer elements) and :mod:`.read_requests`
([design], [verify]). The dataclasses are in :mod:`.schema`, the range of
every numeric key in :mod:`.ranges`, and how files are read in
:mod:`.source_files`.

The format is documented in ``docs/scenes.md``; keep the two in step.
"""

from __future__ import annotations

import math
import os
import re
import tomllib
from pathlib import Path
from typing import Any, Iterable, Mapping

from .elements import LinkageWarning
from .ranges import KEY_RANGES, key_problem, magnitude_problem
from .read_balancers import BalancerTables
from .read_cylinders import CylinderTables
from .read_engine import _MODEL_KEYS, _SAMPLING_KEYS, EngineTables
from .read_gas import GasTables
from .read_loads import LoadTables
from .read_requests import RequestTables
from .schema import (_MISSING, EFFECTS, MAX_SPEEDS, Cylinder, Gas, Model, Problem, Scene, SceneError, _closest,
                     _join)
from .source_files import FileRefused, read_regular, trace_roots
from .units import QuantityError, to_si

__all__ = ["EFFECTS", "MAX_SPEEDS", "Cylinder", "Model", "Scene", "SceneError", "load_scene", "quantity_dimensions",
           "scene_from_text"]


def load_scene(path_or_mapping: str | os.PathLike | Mapping[str, Any], *, files: Mapping[str, str] | None = None,
               trace_roots: Iterable[str | os.PathLike] | None = None) -> Scene:
    """Read and validate a scene.

    Parameters
    ----------
    path_or_mapping : path-like or mapping
        A TOML scene file, or a mapping with the same structure (as returned
        by :func:`tomllib.load`).
    files : mapping of str to str, optional
        The text of every trace file the scene names, by its name as written
        (e.g. ``Scene.files`` of the scene the mapping was made from): the
        reader then opens no trace file. By default trace files are read from
        the scene's folder (a mapping's: the working folder).
    trace_roots : iterable of path-like, optional
        Folders outside the scene's folder tree that trace files may lie in
        (besides those of the environment variable ``HARMBAL_TRACE_ROOTS``).

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
        return scene_from_text(read_scene_text(path), str(path), files=files, trace_roots=trace_roots)
    return _read(data, text, source, files, trace_roots)


#: Longest name or label [characters]: they head tables, figures and archive coordinates.
MAX_LABEL = 200
#: Control characters (C0, DEL, C1) a string may not hold; a description may hold tabs and line breaks.
_CONTROL = re.compile(r"[\x00-\x08\x0b\x0c\x0e-\x1f\x7f-\x9f]")


def text_problems(data: Any, source: str, path: str = "") -> list[Problem]:
    """Problems of the strings in the raw scene ``data``: control characters
    anywhere (a NUL cannot be written to an archive, others garble tables),
    and names and labels that are empty, longer than :data:`MAX_LABEL` or
    more than one line."""
    if isinstance(data, Mapping):
        return [p for key, value in data.items() for p in text_problems(value, source, _join(path, str(key)))]
    if isinstance(data, list):
        return [p for i, value in enumerate(data) for p in text_problems(value, source, f"{path}[{i + 1}]")]
    if not isinstance(data, str):
        return []
    shown = data if len(data) <= 40 else data[:40] + "…"
    found = _CONTROL.search(data)
    if found:
        return [Problem(source, path, shown, f"holds the control character U+{ord(found.group()):04X}: only "
                                             "printable text")]
    if path.rsplit(".", 1)[-1] in ("name", "label"):
        if not data.strip():
            return [Problem(source, path, data, "must not be empty")]
        if "\n" in data or "\r" in data or "\t" in data:
            return [Problem(source, path, shown, "must be one line of text")]
        if len(data) > MAX_LABEL:
            return [Problem(source, path, shown, f"must be at most {MAX_LABEL} characters ({len(data)} given)")]
    return []


#: Largest scene file read [bytes]: a scene is a few kB of TOML; anything this large is not one.
MAX_SCENE_BYTES = 1 << 20


def read_scene_text(path: Path) -> str:
    """The text of the scene file ``path``: a regular file (not a directory,
    FIFO or device, which could block or never end) of at most
    :data:`MAX_SCENE_BYTES`, in UTF-8 with or without a byte-order mark.

    Raises
    ------
    FileNotFoundError
        If ``path`` does not exist.
    SceneError
        One problem naming the file and saying what to do otherwise.
    """
    try:
        return read_regular(path, MAX_SCENE_BYTES, "a scene file (.toml)")
    except FileRefused as exc:
        raise SceneError([Problem(str(path), "(file)", _MISSING, str(exc))]) from None


def scene_from_text(text: str, source: str = "<text>", *, files: Mapping[str, str] | None = None,
                    trace_roots: Iterable[str | os.PathLike] | None = None) -> Scene:
    """Read and validate a scene from TOML text, naming ``source`` in errors.

    Parameters
    ----------
    text : str
        The scene's TOML text.
    source : str, default "<text>"
        Where the text came from: trace files (``[gas.trace] file``) are read
        relative to its folder (a name in angle brackets: the working folder).
    files : mapping of str to str, optional
        The text of every trace file the scene names, by its name as written
        (``Scene.files`` of a scene read before, or an archive's
        ``scene_files``). With it the reader opens no file: a name not in the
        mapping is a problem.
    trace_roots : iterable of path-like, optional
        Folders, besides the scene's own folder tree and those of
        ``$HARMBAL_TRACE_ROOTS``, that trace files may lie in.

    Raises
    ------
    SceneError
        Listing every problem found.
    """
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise SceneError([Problem(source, "(file)", _MISSING, f"TOML syntax error: {exc}")]) from None
    return _read(data, text, source, files, trace_roots)


def _read(data: Mapping, text: str, source: str, files: Mapping[str, str] | None = None,
          roots: Iterable[str | os.PathLike] | None = None) -> Scene:
    reader = _Reader(source, files, roots)
    reader.problems.extend(text_problems(data, source))
    scene = reader.scene(data, text)
    if reader.problems:
        raise SceneError(reader.problems)
    import warnings

    for message in reader.warnings:
        warnings.warn(message, LinkageWarning, stacklevel=3)
    return scene


def quantity_dimensions(data: Mapping[str, Any], *, files: Mapping[str, str] | None = None) -> dict[str, str]:
    """The dimension of every key the scene reader reads as a quantity in ``data``.

    The reader itself answers: ``data`` is read as :func:`load_scene` reads
    it, recording the dimension each quantity is converted in, so that the
    answer follows the reader wherever a key is read (shared tables and each
    cylinder's own, arrays of tables, lists of quantities) and whatever its
    value (problems are not raised: a key is recorded even if its value is
    refused).

    Parameters
    ----------
    data : mapping
        A raw scene, as :func:`tomllib.loads` returns it.
    files : mapping of str to str, optional
        The text of trace files the scene names (as in :func:`load_scene`);
        no file is ever opened (a name not given is a problem, not recorded).

    Returns
    -------
    dict of str to str
        Key path as the user writes it (``piston.mass``,
        ``cylinder[2].piston.mass``, ``engine.reference_point[3]``) ->
        dimension (a key of :data:`~harmbal.scene.units.SI_UNITS`). A key the
        reader does not reach (an unknown key, a table it refuses) or reads
        otherwise (an integer, a choice) is not there.
    """
    reader = _Reader("<dimensions>", {} if files is None else files)
    reader.dimensions = {}
    reader.scene(data, "")
    return reader.dimensions


_TOP_KEYS = {
    "engine", "model", "sampling", "geometry", "piston", "rod",
    "throw_unbalance", "cylinder", "crankshaft_unbalance", "crankshaft", "counterweight", "balance_shaft",
    "lanchester_pair", "lever_balancer", "design", "verify", "gas", "flywheel", "loads", "outline",
}


class _Reader(EngineTables, CylinderTables, GasTables, BalancerTables, RequestTables, LoadTables):
    """Walks the raw mapping, converts units, and collects problems."""

    def __init__(self, source: str, files: Mapping[str, str] | None = None,
                 roots: Iterable[str | os.PathLike] | None = None):
        self.source = source
        self.problems: list[Problem] = []
        self.warnings: list[str] = []
        # Files a scene names (pressure traces) are relative to the scene file; those of a mapping or a text
        # without a file, to the working directory. They must lie in that folder's tree or in ``roots``.
        self.base = Path(source).parent if not source.startswith("<") else Path.cwd()
        self.roots = trace_roots(roots) if files is None else ()
        # The texts of the files given (None: read them from the file system), and of those read so far.
        self.given = None if files is None else dict(files)
        self.files: dict[str, str] = {}
        self.gases: list[Gas] = []
        # Key path -> dimension of every quantity read, when asked for (quantity_dimensions); None: not kept.
        self.dimensions: dict[str, str] | None = None

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
        if self.dimensions is not None:
            self.dimensions[where] = dimension
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
        name = key.split("[", 1)[0]
        if dimension == "dimensionless" and name not in KEY_RANGES:
            raise KeyError(f"{where}: a dimensionless key needs its range in harmbal.scene.ranges.KEY_RANGES")
        if positive and not si > 0:
            rule = "must be positive"
        elif nonnegative and not si >= 0:
            rule = "must not be negative"
        else:
            rule = key_problem(name, si) or magnitude_problem(dimension, si, positive)  # the narrower first
        if rule:
            # nan, not the value: a value 300 decades off would overflow the reader's own arithmetic (r², a blank's
            # area); every check downstream skips a nan, whose problem is this one.
            self.fail(where, value, rule)
            return math.nan
        return si

    def choice(self, table: Mapping, key: str, path: str, options: tuple, default: Any) -> Any:
        value = table.get(key, default)
        if value not in options:
            self.fail(_join(path, key), value, f"must be one of {', '.join(map(repr, options))}")
            return default
        return value

    def integer(self, table: Mapping, key: str, path: str, default: Any, minimum: int,
                maximum: int | None = None) -> int | None:
        """An integer from ``minimum`` to ``maximum`` (default: the top of the
        key's range in :data:`~.ranges.KEY_RANGES`, which every integer key has)."""
        bounds = KEY_RANGES[key]
        value = table.get(key, default)
        if value is None:
            return None
        if isinstance(value, bool) or not isinstance(value, int):
            self.fail(_join(path, key), value, "must be an integer")
            return default
        if value < minimum:
            self.fail(_join(path, key), value, f"must be at least {minimum}")
            return default
        top = int(bounds.high) if maximum is None else maximum
        if value > top:
            self.fail(_join(path, key), value, f"must be at most {top}: {bounds.why}")
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

    # -- the scene ---------------------------------------------------------

    def scene(self, data: Mapping, text: str) -> Scene:
        self.unknown(data, "", _TOP_KEYS)
        engine, header = self.engine(data)
        raw_cylinders = data.get("cylinder", _MISSING)
        has_gas = "gas" in data or (isinstance(raw_cylinders, list)
                                    and any(isinstance(c, Mapping) and "gas" in c for c in raw_cylinders))
        model = self.model(self.table(data, "model", "model", _MODEL_KEYS), has_gas)
        sampling = self.sampling(self.table(data, "sampling", "sampling", _SAMPLING_KEYS))
        cylinders = self.cylinders(raw_cylinders, self.shared(data), data.get("throw_unbalance", []), model,
                                   header["cycle"])
        crankshaft = tuple(self.unbalances(data.get("crankshaft_unbalance", []), "crankshaft_unbalance",
                                           "axial_position"))
        firing_order = self.firing_order(engine, cylinders, header["cycle"])
        sense = 1 if header["rotation"] == "counterclockwise" else -1
        shafts, levers = self.balancer_elements(data, sense, model, sampling)
        design, verify = self.requests(data, sampling.max_order)
        flywheel = self.flywheel(data, has_gas)
        outlines = self.outlines(data.get("outline", []), cylinders, shafts)
        loads = self.loads(data, shafts)
        if "speed_fluctuation" in model.effects:
            if flywheel is None:
                self.fail("model.effects", "speed_fluctuation", "needs a [flywheel] table (its inertia J₀)")
            if levers and "balancers" in model.effects:
                self.fail("model.effects", "speed_fluctuation", "lever balancers have no loads at a fluctuating "
                          "speed yet: leave out the effect or the levers")
        return Scene(**header, cylinders=cylinders, crankshaft_unbalances=crankshaft, shafts=shafts, levers=levers,
                     model=model, sampling=sampling, firing_order=firing_order, design=design, verify=verify,
                     flywheel=flywheel, loads=loads, outlines=outlines, source=self.source, source_text=text,
                     files=tuple(sorted(self.files.items())))

"""Scene files: reading a TOML scene (or an equivalent mapping) into a
validated :class:`~.schema.Scene`, units converted to SI and defaults filled
in, per-cylinder overrides merged.

Every problem found is collected and reported together in a
:class:`~.schema.SceneError`, each naming the source, the key path, the
offending value and the rule it breaks. This module holds the entry points
and composes the scene from the parts that plain ``read_*`` functions read,
each taking the problem collector (:class:`~.collector.Collector`, with the
primitives: tables and unknown keys, quantities, choices, integers, strings,
lists) and returning its part: :mod:`.read_engine` ([engine], [model],
[sampling]), :mod:`.read_cylinders` ([geometry], [piston], [rod],
[[cylinder]], unbalances), :mod:`.read_gas` ([gas], [flywheel]),
:mod:`.read_balancers` (balancer elements), :mod:`.read_requests`
([design], [verify]), :mod:`.read_loads` ([loads]), :mod:`.read_shapes`
(blanks, [[outline]]) and :mod:`.read_mounts` ([powertrain], [[mount]],
[mount_design]). What tables read in different places share (trace
files, gas tables) is a :class:`~.collector.SceneContext` passed to those
that need it. The dataclasses are in :mod:`.schema`, the range of every
numeric key in :mod:`.ranges`, and how files are read in
:mod:`.source_files`.

The format is documented in ``docs/scenes.md``; keep the two in step.
"""

from __future__ import annotations

import os
import re
import tomllib
from pathlib import Path
from typing import Any, Iterable, Mapping

from .collector import Collector, SceneContext
from .elements import LinkageWarning
from .read_balancers import read_balancer_elements
from .read_cylinders import read_cylinders, read_shared_tables, read_unbalances
from .read_engine import read_engine, read_firing_order, read_model, read_sampling
from .read_gas import read_flywheel
from .read_loads import read_loads
from .read_mounts import read_mount_design, read_mounts, read_powertrain
from .read_requests import read_requests
from .read_shapes import read_outlines
from .schema import EFFECTS, MAX_SPEEDS, MISSING, Cylinder, Flywheel, Model, Problem, Scene, SceneError, key_path
from .source_files import FileRefused, read_regular

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
        return [p for key, value in data.items() for p in text_problems(value, source, key_path(path, str(key)))]
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
        raise SceneError([Problem(str(path), "(file)", MISSING, str(exc))]) from None


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
        raise SceneError([Problem(source, "(file)", MISSING, f"TOML syntax error: {exc}")]) from None
    return _read(data, text, source, files, trace_roots)


def _read(data: Mapping, text: str, source: str, files: Mapping[str, str] | None = None,
          roots: Iterable[str | os.PathLike] | None = None) -> Scene:
    reader = Collector(source)
    reader.problems.extend(text_problems(data, source))
    scene = _read_scene(reader, SceneContext.of(source, files, roots), data, text)
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
    reader = Collector("<dimensions>", dimensions=True)
    _read_scene(reader, SceneContext.of("<dimensions>", {} if files is None else files), data, "")
    assert reader.dimensions is not None
    return reader.dimensions


_TOP_KEYS = {
    "engine", "model", "sampling", "geometry", "piston", "rod",
    "throw_unbalance", "cylinder", "crankshaft_unbalance", "crankshaft", "counterweight", "balance_shaft",
    "lanchester_pair", "lever_balancer", "design", "verify", "gas", "flywheel", "loads", "outline",
    "powertrain", "mount", "mount_design",
}


def _read_scene(reader: Collector, context: SceneContext, data: Mapping, text: str) -> Scene:
    """The scene of the raw mapping ``data``: each group of tables read by its
    module's ``read_*`` functions, and the checks that span groups."""
    reader.unknown(data, "", _TOP_KEYS)
    engine, header = read_engine(reader, data)
    raw_cylinders = data.get("cylinder", MISSING)
    has_gas = "gas" in data or (isinstance(raw_cylinders, list)
                                and any(isinstance(c, Mapping) and "gas" in c for c in raw_cylinders))
    model = read_model(reader, data, has_gas)
    sampling = read_sampling(reader, data)
    cylinders = read_cylinders(reader, context, raw_cylinders, read_shared_tables(reader, data),
                               data.get("throw_unbalance", []), model, header["cycle"])
    crankshaft = tuple(read_unbalances(reader, data.get("crankshaft_unbalance", []), "crankshaft_unbalance",
                                       "axial_position"))
    firing_order = read_firing_order(reader, engine, cylinders, header["cycle"])
    sense = 1 if header["rotation"] == "counterclockwise" else -1
    shafts, levers = read_balancer_elements(reader, data, sense, model, sampling)
    design, verify = read_requests(reader, data, sampling.max_order)
    flywheel = read_flywheel(reader, data, has_gas)
    outlines = read_outlines(reader, data.get("outline", []), cylinders, shafts)
    loads = read_loads(reader, data, shafts)
    powertrain = read_powertrain(reader, data)
    mounts = read_mounts(reader, data, powertrain)
    mount_design = read_mount_design(reader, data, mounts)
    _check_fluctuation(reader, model, flywheel, levers)
    return Scene(**header, cylinders=cylinders, crankshaft_unbalances=crankshaft, shafts=shafts, levers=levers,
                 model=model, sampling=sampling, firing_order=firing_order, design=design, verify=verify,
                 flywheel=flywheel, loads=loads, outlines=outlines, powertrain=powertrain, mounts=mounts,
                 mount_design=mount_design, source=reader.source, source_text=text,
                 files=tuple(sorted(context.read.items())))


def _check_fluctuation(reader: Collector, model: Model, flywheel: Flywheel | None, levers: tuple) -> None:
    """What the effect "speed_fluctuation" needs of the rest of the scene."""
    if "speed_fluctuation" in model.effects:
        if flywheel is None:
            reader.fail("model.effects", "speed_fluctuation", "needs a [flywheel] table (its inertia J₀)")
        if levers and "balancers" in model.effects:
            reader.fail("model.effects", "speed_fluctuation", "lever balancers have no loads at a fluctuating "
                   "speed yet: leave out the effect or the levers")

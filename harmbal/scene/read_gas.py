"""Reading the cylinder pressure: the shared [gas] table and each cylinder's
``[cylinder.gas]`` override, a measured trace ([gas.trace], inline or from a
CSV file) or a parametric one ([gas.combustion]), and the checks a trace
must pass to be read periodically over one working cycle.

The format is documented in ``docs/scenes.md`` and ``docs/gas.md``.
"""

from __future__ import annotations

import math
import re
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from .collector import Collector, SceneContext
from .ranges import MAGNITUDES
from .schema import (
    DEFAULT_CRANKCASE_PRESSURE,
    INTERPOLATIONS,
    MISSING,
    SPEED_MEANS,
    Combustion,
    Flywheel,
    Gas,
    PressureTrace,
    key_path,
)
from .source_files import MAX_TRACE_BYTES, FileRefused, read_regular, resolve_trace
from .units import to_si

GAS_KEYS = {"bore", "crankcase_pressure", "trace", "combustion"}
_FLYWHEEL_KEYS = {"inertia", "load_torque", "target_coefficient", "mean"}
_TRACE_KEYS = {"angle", "pressure", "file", "units", "interpolation"}
_COMBUSTION_KEYS = {"compression_ratio", "intake_pressure", "exhaust_pressure", "compression_exponent",
                    "expansion_exponent", "start", "duration", "shape", "efficiency", "peak_pressure", "imep"}
#: The units a trace's columns may be given in (the fast unit parser reads all of them without pint). Every
#: column must declare one (docs/design.md §6): plain numbers in a table are never taken as SI.
TRACE_UNITS = {"angle": ("deg", "rad"), "pressure": ("Pa", "kPa", "MPa", "bar", "mbar")}
#: The columns of a trace, in order, and the unit the messages asking for one name as the example.
_COLUMNS = ("angle", "pressure")
_EXAMPLE_UNITS = {"angle": "deg", "pressure": "bar"}
#: Peak pressures [Pa, absolute] no engine's cylinder reaches: a trace peaking below 1 bar (a cylinder that
#: compresses its charge exceeds it even motored at closed throttle) or above 500 bar = 50 MPa (production
#: engines peak below about 300 bar) is refused, as is one lying wholly at or below the crankcase pressure.
MIN_PEAK_PRESSURE, MAX_PEAK_PRESSURE = 1e5, 5e7
#: Peak pressures [Pa] outside this range are possible but unusual (a motored engine reaches about 3 bar and
#: more; the most highly loaded diesels about 300 bar): the trace reads, with a TraceWarning to check its unit.
LOW_PEAK_PRESSURE, HIGH_PEAK_PRESSURE = 3e5, 3.5e7
#: A trace is one table of samples: fewer points cannot describe a pressure cycle; more than the most are
#: no measured trace of one cycle (and would only cost time and memory).
MIN_TRACE_POINTS, MAX_TRACE_POINTS = 8, 200_000
#: Lowest pressure [Pa, absolute] a trace may hold: 1 mbar; below it the numbers are not absolute pressures.
MIN_TRACE_PRESSURE = 100.0
#: Longest part of a file's cell a message shows: an error names the offending token, never a file's lines.
_TOKEN_CHARS = 20
#: Largest gap closing the cycle, in units of the largest spacing inside the table.
MAX_CLOSING_GAP = 1.5
#: Relative difference allowed between the pressures at the two ends of a table that includes its endpoint.
PERIODIC_RTOL = 1e-6
#: Angles within this share of a spacing of first + one cycle count as the endpoint.
_ENDPOINT_RTOL = 1e-9
#: Alternative sources of a measured table: a cylinder's override giving one drops the shared other.
_TABLE_SOURCES = ({"file"}, {"angle", "pressure"})
_HEADER_UNITS = re.compile(r"^\s*([A-Za-z_ ]*?)\s*[\[(]\s*([^\])]+?)\s*[\])]\s*$")


class TraceWarning(UserWarning):
    """A measured pressure trace that reads, but whose peak is unusual for an
    engine's cylinder: most often a column in another unit than declared."""


@dataclass(frozen=True)
class _Columns:
    """A trace table as read, before conversion: the numbers of each column,
    their units (dimension -> unit), where they came from (``source``: the
    file path or ``"inline"``; ``key``: the file's key path, None inline), how
    messages name each column and how to change its unit (a template with
    ``{unit}``); ``written``: the file's name as the scene wrote it."""

    angle: list
    pressure: list
    source: str
    key: str | None
    units: dict[str, str]
    names: dict[str, str]
    fixes: dict[str, str]
    written: str = "inline"


def read_flywheel(reader: Collector, data: Mapping, has_gas: bool) -> Flywheel | None:
    """[flywheel]: what the speed fluctuation needs beyond the gas torque."""
    if "flywheel" not in data:
        return None
    table = reader.table(data, "flywheel", "flywheel", _FLYWHEEL_KEYS)
    if not has_gas:
        reader.fail("flywheel", data["flywheel"], "the speed fluctuation is driven by the gas torque: "
                    "it needs a [gas] table")
    inertia = reader.quantity(table, "inertia", "flywheel", "inertia", positive=True)
    load = reader.quantity(table, "load_torque", "flywheel", "moment") if "load_torque" in table else None
    target = None
    if "target_coefficient" in table:
        target = reader.quantity(table, "target_coefficient", "flywheel", "dimensionless", positive=True)  # (0, 1)
    mean = reader.choice(table, "mean", "flywheel", SPEED_MEANS, "time")
    return Flywheel(inertia=inertia, load_torque=load, target_coefficient=target, mean=mean)


def merge_gas(reader: Collector, shared: Mapping | None, entry: Mapping,
              path: str) -> tuple[dict, dict[str, Any]] | None:
    """A cylinder's gas table: the shared [gas] overlaid key by key by its
    own ``gas`` table (sub-tables likewise; a cylinder giving ``trace``
    drops the shared ``combustion`` and vice versa, and a trace giving
    ``file`` drops the shared ``angle``/``pressure`` and vice versa), with
    the section each key was written in. None when neither has one."""
    own = reader.table(entry, "gas", key_path(path, "gas"), GAS_KEYS)
    if shared is None and "gas" not in entry:
        return None
    shared = shared or {}
    # where: the section of each key, and of each key of a sub-table (a dict)
    merged: dict[str, Any] = {}
    where: dict[str, Any] = {}
    for key in GAS_KEYS - {"trace", "combustion"}:
        if key in own:
            merged[key], where[key] = own[key], key_path(path, "gas")
        elif key in shared:
            merged[key], where[key] = shared[key], "gas"
    chosen = [k for k in ("trace", "combustion") if k in own] or [k for k in ("trace", "combustion") if k in shared]
    for key in chosen:
        mine, theirs = own.get(key, {}), shared.get(key, {})
        if not isinstance(mine, Mapping) or not isinstance(theirs, Mapping):
            bad = (key_path(path, "gas"), mine) if not isinstance(mine, Mapping) else ("gas", theirs)
            reader.fail(key_path(bad[0], key), bad[1], "must be a table")
            continue
        if key == "trace":
            for source in _TABLE_SOURCES:
                if source & mine.keys():
                    theirs = {k: v for k, v in theirs.items() if k not in set().union(*_TABLE_SOURCES) - source}
        merged[key] = {**theirs, **mine}
        # Each key of the sub-table is reported where it was written.
        where[key] = {k: key_path(key_path(path, "gas") if k in mine else "gas", key) for k in merged[key]}
    return merged, where


def read_gas(reader: Collector, context: SceneContext, merged: tuple[dict, dict[str, Any]] | None,
             cycle: int) -> Gas | None:
    """The validated :class:`Gas` of one cylinder (None without a gas table)."""
    if merged is None:
        return None
    table, where = merged
    bore = reader.quantity(table, "bore", where.get("bore", "gas"), "length", positive=True)
    crankcase = reader.quantity(table, "crankcase_pressure", where.get("crankcase_pressure", "gas"), "pressure",
                                default=DEFAULT_CRANKCASE_PRESSURE, positive=True)
    given = [k for k in ("trace", "combustion") if k in table]
    if len(given) != 1:
        reader.fail("gas", sorted(given) if given else MISSING,
                    "give exactly one of [gas.trace] (a measured trace) and [gas.combustion] (a parametric one)")
        return None
    key = given[0]
    allowed = _TRACE_KEYS if key == "trace" else _COMBUSTION_KEYS
    for name, value in table[key].items():
        reader.unknown({name: value}, where[key][name], allowed)
    # Problems of the sub-table as a whole go where the cylinder wrote it, or to the shared one.
    section = next((w for w in where[key].values() if not w.startswith("gas.")), f"gas.{key}")
    trace: PressureTrace | Combustion | None
    if key == "trace":
        crankcase_key = key_path(where.get("crankcase_pressure", "gas"), "crankcase_pressure")
        trace = _trace(reader, context, table["trace"], where["trace"], section, cycle, (crankcase, crankcase_key))
    else:
        trace = _combustion(reader, table["combustion"], where["combustion"], section, cycle)
    if trace is None or not (math.isfinite(bore) and math.isfinite(crankcase)):
        return None
    gas = Gas(bore=bore, crankcase_pressure=crankcase, trace=trace)
    # Cylinders of equal tables share one object: the model finds cylinders with the same trace by
    # identity, without comparing the tables again at every evaluation.
    same = next((g for g in context.gases if g == gas), None)
    if same is None:
        context.gases.append(gas)
    return gas if same is None else same

# -- measured traces ---------------------------------------------------


def _trace(reader: Collector, context: SceneContext, table: dict, where: dict[str, str], section: str, cycle: int,
           crankcase: tuple[float, str]) -> PressureTrace | None:
    """A measured trace; ``where`` gives the section each key was written in,
    ``crankcase`` the crankcase pressure [Pa] (nan if invalid) and its key path."""

    def at(key: str) -> str:
        return key_path(where.get(key, section), key)

    interpolation = table.get("interpolation", INTERPOLATIONS[0])
    if interpolation not in INTERPOLATIONS:
        reader.fail(at("interpolation"), interpolation, f"must be one of {', '.join(map(repr, INTERPOLATIONS))}")
        return None
    units = table.get("units", {})
    if not isinstance(units, Mapping):
        reader.fail(at("units"), units, "must be a table such as { angle = \"deg\", pressure = \"bar\" }")
        return None
    reader.unknown(units, at("units"), set(TRACE_UNITS))
    has_file, has_table = "file" in table, bool({"angle", "pressure"} & table.keys())
    if has_file == has_table:
        reader.fail(section, sorted(table) if table else MISSING,
                    "give the trace either as a file or as angle and pressure lists, exactly one of them")
        return None
    columns = (_trace_file(reader, context, table["file"], at, units) if has_file
               else _trace_inline(reader, table, at, units))
    if columns is None:
        return None
    if len(columns.angle) != len(columns.pressure):
        reader.fail(columns.key or at("pressure"), f"{len(columns.angle)} angles, {len(columns.pressure)} pressures",
                    "angle and pressure must have the same length")
        return None
    factors = [to_si(f"1 {columns.units[d]}", d) for d in _COLUMNS]
    checked = _check_table(reader, np.asarray(columns.angle, float) * factors[0],
                           np.asarray(columns.pressure, float) * factors[1], cycle, columns, at)
    if checked is None or not _check_level(reader, checked[1], crankcase, columns, at):
        return None
    if not (checked[1] >= MIN_TRACE_PRESSURE).all():  # (a peak in range with a point near 0: not absolute)
        i = int(np.argmax(~(checked[1] >= MIN_TRACE_PRESSURE)))
        reader.fail(columns.key or at("pressure"), f"{checked[1][i]:.6g} Pa at point {i + 1}",
                    f"{columns.source + ': ' if columns.key else ''}absolute pressures must be at least "
                    f"{MIN_TRACE_PRESSURE:g} Pa (1 mbar): are these gauge pressures? add the ambient pressure")
        return None
    return PressureTrace(angle=tuple(checked[0].tolist()), pressure=tuple(checked[1].tolist()),
                         interpolation=interpolation, source=columns.source)


def _trace_inline(reader: Collector, table: Mapping, at, units: Mapping) -> _Columns | None:
    """The inline ``angle`` and ``pressure`` lists with their units from
    ``units``, which must name both: a bare list of numbers is refused."""
    lists = {}
    for name in _COLUMNS:
        values = table.get(name, MISSING)
        if values is MISSING:
            reader.fail(at(name), MISSING, "missing: a trace needs both angle and pressure lists")
            return None
        if (not isinstance(values, list) or any(isinstance(v, bool) or not isinstance(v, (int, float))
                                                for v in values)):
            reader.fail(at(name), values, "must be a list of numbers (units in trace.units)")
            return None
        lists[name] = values
    found = {}
    for name in _COLUMNS:
        if name not in units:
            reader.fail(at(name), f"{len(lists[name])} numbers",
                        f"no unit: {_units_fix(at('units'), name)}{_which_units(name)}")
        elif problem := _unknown_unit(name, units[name]):
            reader.fail(key_path(at("units"), name), units[name], problem)
        else:
            found[name] = units[name]
    if len(found) < len(_COLUMNS):
        return None
    return _Columns(lists["angle"], lists["pressure"], "inline", None, found,
                    names={n: f"the {n} list" for n in _COLUMNS},
                    fixes={n: f"set {key_path(at('units'), n)} = \"{{unit}}\"" for n in _COLUMNS})


def _trace_file(reader: Collector, context: SceneContext, name: Any, at, units: Mapping) -> _Columns | None:
    """The two columns of a CSV trace with their units, each from the
    header (``angle [deg]``) or else from ``units``; a column with neither
    is refused."""
    key = at("file")
    if not isinstance(name, str):
        reader.fail(key, name, "must be a path (a string)")
        return None
    path = Path(name) if Path(name).is_absolute() else context.base / name
    text = _trace_text(reader, context, name, path, key)
    if text is None:
        return None
    angle: list[float] = []
    pressure: list[float] = []
    header = None
    for number, line in enumerate(text.splitlines(), start=1):
        stripped = line.strip()
        if not stripped or stripped.startswith("#"):
            continue
        cells = [c.strip() for c in re.split(r"[,;\t]", stripped)] if re.search(r"[,;\t]", stripped) \
            else stripped.split()
        if header is None and not angle and _numbers(cells) is None:
            header = cells
            continue
        values = _numbers(cells)
        if values is None or len(values) != 2:
            reader.fail(key, name, f"{path}, line {number}: {_bad_row(cells, values, bool(angle))}")
            return None
        if len(angle) == MAX_TRACE_POINTS:
            reader.fail(key, name, f"{path}: more than {MAX_TRACE_POINTS} points: not a measured trace of one "
                        "cycle (0.01° steps over 720° are 72 000): resample it")
            return None
        angle.append(values[0])
        pressure.append(values[1])
    return _file_units(reader, angle, pressure, header, (name, str(path)), at, units)


def _trace_text(reader: Collector, context: SceneContext, name: str, path: Path, key: str) -> str | None:
    """The text of the trace file written ``name`` (``path``, relative to
    the scene's folder): from the files given to the reader, else read
    once from the file system within the rules of
    :mod:`.source_files`; None after a problem."""
    if name in context.read:  # cylinders sharing the [gas] table share its file: read it once
        return context.read[name]
    if context.given is not None:
        if name not in context.given:
            reader.fail(key, name, "not among the trace files stored with the scene (the reader was given the "
                        f"files {', '.join(map(repr, sorted(context.given))) or 'none'} and reads no other)")
            return None
        text = context.given[name]
    else:
        try:
            text = read_regular(resolve_trace(name, context.base, context.roots), MAX_TRACE_BYTES,
                                "a trace file (CSV)")
        except FileNotFoundError:
            reader.fail(key, name, f"file not found: {path}")
            return None
        except FileRefused as exc:
            reader.fail(key, name, f"{path} {exc}")
            return None
    context.read[name] = text
    return text


def _file_units(reader: Collector, angle: list, pressure: list, header: list[str] | None, name: tuple[str, str], at,
                units: Mapping) -> _Columns | None:
    """The columns of a file (``name``: as written, resolved) with the unit
    of each: from its header cell or, where the cell names none, from
    ``units`` (the two must agree). None after a problem."""
    cells = list(header or []) + [""] * len(_COLUMNS)
    read = [_column_unit(reader, i, cells[i], header is not None, name, at, units) for i in range(len(_COLUMNS))]
    columns = [r for r in read if r is not None]
    if len(columns) < len(read):
        return None
    units, names, fixes = ({d: r[j] for d, r in zip(_COLUMNS, columns)} for j in range(3))  # (unit, name, fix)
    return _Columns(angle, pressure, name[1], at("file"), units, names, fixes, written=name[0])


def _column_unit(reader: Collector, index: int, cell: str, has_header: bool, name: tuple[str, str], at,
                 units: Mapping) -> tuple[str, str, str] | None:
    """The unit of a file's column ``index`` (header ``cell``), how
    messages name the column and how to change its unit; None after a
    problem (no unit, an unknown one, or header and ``units`` disagreeing)."""
    dimension, (written, path), key = _COLUMNS[index], name, at("file")
    label = f"{path}, column {index + 1} " + (f"{_token(cell)!r}" if cell else f"({dimension}, no header)")
    units_key = key_path(at("units"), dimension)
    match, given = _HEADER_UNITS.match(cell), units.get(dimension)
    if match:
        unit, bad = match.group(2), _unknown_unit(dimension, match.group(2))
        if given is not None and given != unit:
            bad = f"the header gives {dimension} in {unit!r} but {units_key} says {given!r}"
        fix = f"write its header as \"{match.group(1) or dimension} [{{unit}}]\""
    elif given is not None:
        unit, bad, fix = given, _unknown_unit(dimension, given), f"set {units_key} = \"{{unit}}\""
        if bad:
            reader.fail(units_key, given, bad)
            return None
    else:
        bad = (f"no unit: {_header_fix(cell or dimension, dimension, has_header)} or "
               f"{_units_fix(at('units'), dimension)}{_which_units(dimension)}")
    if bad:
        reader.fail(key, written, f"{label}: {bad}")
        return None
    return unit, label, fix


def _check_table(reader: Collector, angle: np.ndarray, pressure: np.ndarray, cycle: int, columns: _Columns,
                 at) -> tuple[np.ndarray, np.ndarray] | None:
    """The table in SI checked to describe one cycle, without the closing
    endpoint if it was given. The problems of a file go to its key, naming
    the file; else to the angle or pressure list."""
    period = math.pi * cycle
    cycle_text = f"{180 * cycle}°"
    akey, pkey = columns.key or at("angle"), columns.key or at("pressure")
    where = f"{columns.source}: " if columns.key else ""
    if not MIN_TRACE_POINTS <= angle.size <= MAX_TRACE_POINTS:
        reader.fail(akey, f"{angle.size} points", f"{where}a trace needs at least {MIN_TRACE_POINTS} points"
                    if angle.size < MIN_TRACE_POINTS else f"{where}a trace has at most {MAX_TRACE_POINTS} points")
        return None
    if not (np.isfinite(angle).all() and np.isfinite(pressure).all()):
        reader.fail(akey, "nan or inf", f"{where}must be finite")
        return None
    if not (np.abs(angle) <= MAGNITUDES["angle"].high).all():
        reader.fail(akey, f"{math.degrees(float(np.max(np.abs(angle)))):.6g}°", f"{where}angles must lie within "
                    "±3600° (the angle range); a trace's angles span one cycle from firing TDC")
        return None
    steps = np.diff(angle)
    if not (steps > 0).all():
        i = int(np.argmax(steps <= 0))
        reader.fail(akey, f"{math.degrees(angle[i]):.6g}°, {math.degrees(angle[i + 1]):.6g}° (points {i + 1}, "
                    f"{i + 2})", f"{where}angles must be strictly increasing")
        return None
    if not (pressure > 0).all():
        i = int(np.argmax(~(pressure > 0)))
        reader.fail(pkey, f"{pressure[i]:.6g} Pa at point {i + 1}", f"{where}absolute pressures must be positive")
        return None

    span = angle[-1] - angle[0]
    largest = float(steps.max())
    if abs(span - period) <= _ENDPOINT_RTOL * largest:
        # The table includes its endpoint: it must close on itself.
        if abs(pressure[-1] - pressure[0]) > PERIODIC_RTOL * max(abs(pressure[0]), abs(pressure[-1])):
            reader.fail(pkey, f"{pressure[0]:.9g} Pa at {math.degrees(angle[0]):.6g}°, {pressure[-1]:.9g} Pa at "
                        f"{math.degrees(angle[-1]):.6g}°",
                        f"{where}not periodic: the two ends of the {cycle_text} cycle differ by more than "
                        f"{PERIODIC_RTOL:g} relative")
            return None
        return angle[:-1], pressure[:-1]
    extent = f"{math.degrees(angle[0]):.6g}° to {math.degrees(angle[-1]):.6g}°"
    if span > period:
        reader.fail(akey, extent, f"{where}trace longer than a cycle: it spans {math.degrees(span):.6g}°, one "
                    f"cycle is {cycle_text} (angles read in {columns.units['angle']}){_cycle_hint(span, largest, 4)}")
        return None
    gap = period - span
    if gap > MAX_CLOSING_GAP * largest:
        reader.fail(akey, extent, f"{where}trace shorter than a cycle: the gap closing the {cycle_text} cycle is "
                    f"{math.degrees(gap):.6g}°, more than {MAX_CLOSING_GAP:g} x the largest spacing "
                    f"({math.degrees(largest):.6g}°){_cycle_hint(span, largest, 2)}")
        return None
    return angle, pressure


def _check_level(reader: Collector, pressure: np.ndarray, crankcase: tuple[float, str], columns: _Columns, at) -> bool:
    """Whether the level of a trace [Pa] can be a cylinder pressure: its
    peak above the crankcase pressure and within [MIN_PEAK_PRESSURE,
    MAX_PEAK_PRESSURE] (else a problem), and within [LOW_PEAK_PRESSURE,
    HIGH_PEAK_PRESSURE] (else a :class:`TraceWarning`). Most often a
    trace failing it is in another unit than the one declared."""
    peak, unit = float(pressure.max()), columns.units["pressure"]
    raw = peak / to_si(f"1 {unit}", "pressure")
    key, name = columns.key or at("pressure"), columns.names["pressure"]
    likely = _likely_unit(raw, unit, crankcase[0], columns.fixes["pressure"])
    shown = f"{_bar(peak)} bar" + (f" ({raw:.6g} {unit})" if unit != "bar" else "")
    rule = _level_problem(peak, crankcase, shown)
    if rule is None:
        if not LOW_PEAK_PRESSURE <= peak <= HIGH_PEAK_PRESSURE:
            reader.warn(TraceWarning(
                f"{reader.source}: {key}: {name} peaks at {shown}, unusual for an engine (most peak between "
                f"{_bar(LOW_PEAK_PRESSURE)} and {_bar(HIGH_PEAK_PRESSURE)} bar): check its unit{likely}"))
        return True
    value = columns.written if columns.key else f"maximum {raw:.6g} {unit}"
    reader.fail(key, value, f"{name}: {rule}; the pressure unit is likely wrong"
                f"{likely or ': check the unit its numbers are in, and that they are absolute pressures'}")
    return False

# -- parametric traces -------------------------------------------------


def _combustion(reader: Collector, table: dict, where: dict[str, str], section: str, cycle: int) -> Combustion | None:
    """A parametric trace; ``where`` gives the section each key was written in."""

    def q(key: str, dimension: str, default: Any = MISSING, **checks) -> float:
        return reader.quantity(table, key, where.get(key, section), dimension, default=default, **checks)

    before = len(reader.problems)
    if cycle != 4:
        reader.fail(section, MISSING, "the parametric trace models a four-stroke cycle (engine.cycle = 4); "
                    "give a two-stroke a measured [gas.trace]")
    ratio = q("compression_ratio", "dimensionless")  # in (1, 100], as every key in its range (.ranges)
    intake = q("intake_pressure", "pressure", positive=True)
    exhaust = q("exhaust_pressure", "pressure", positive=True) if "exhaust_pressure" in table else intake
    exponents = []
    for key, default in (("compression_exponent", 1.35), ("expansion_exponent", 1.30)):
        exponents.append(q(key, "dimensionless", default=default))
    start = q("start", "angle")
    duration = q("duration", "angle", positive=True)
    if math.isfinite(start) and math.isfinite(duration) and duration > 0 and not (
            -math.pi < start and start + duration < math.pi):
        reader.fail(key_path(where.get("duration", section), "duration"), table.get("duration"),
                    f"combustion from {math.degrees(start):.6g}° for {math.degrees(duration):.6g}° must lie between "
                    "inlet valve closing (-180°) and exhaust valve opening (+180°)")
    shape = q("shape", "dimensionless", default=2.0, nonnegative=True)
    efficiency = q("efficiency", "dimensionless", default=6.908, positive=True)
    targets = [k for k in ("peak_pressure", "imep") if k in table]
    peak = imep = None
    if len(targets) != 1:
        reader.fail(section, sorted(targets) if targets else MISSING,
                    "give exactly one target for the heat release: peak_pressure or imep")
    elif targets[0] == "peak_pressure":
        peak = q("peak_pressure", "pressure", positive=True)
    else:
        imep = q("imep", "pressure", positive=True)
    if len(reader.problems) > before:
        return None
    return Combustion(compression_ratio=ratio, intake_pressure=intake, exhaust_pressure=exhaust,
                      compression_exponent=exponents[0], expansion_exponent=exponents[1], start=start,
                      duration=duration, shape=shape, efficiency=efficiency, peak_pressure=peak, imep=imep)


def _unknown_unit(dimension: str, unit: Any) -> str | None:
    """Why ``unit`` cannot be the unit of a trace's ``dimension`` column, or None if it can."""
    if unit in TRACE_UNITS[dimension]:
        return None
    return f"unknown units {unit!r} for {dimension}; allowed: {', '.join(TRACE_UNITS[dimension])}"


def _units_fix(units_key: str, dimension: str) -> str:
    """How to give a column's unit in the trace's ``units`` table."""
    return f"set {key_path(units_key, dimension)} = \"{_EXAMPLE_UNITS[dimension]}\""


def _header_fix(label: str, dimension: str, has_header: bool) -> str:
    """How to give a column's unit in a CSV file's header."""
    if has_header:
        return f"write its header as \"{label} [{_EXAMPLE_UNITS[dimension]}]\""
    return "start the file with a header line such as \"angle [deg],pressure [bar]\""


def _which_units(dimension: str) -> str:
    """The end of a message asking for a column's unit: which units it may be."""
    return f", with the unit its numbers are in (one of {', '.join(TRACE_UNITS[dimension])})"


def _cycle_hint(span: float, largest: float, cycle: int) -> str:
    """A hint to set ``engine.cycle`` when a table refused for the scene's
    cycle describes exactly one cycle of the other (``cycle``) stroke count."""
    period = math.pi * cycle
    if abs(span - period) <= _ENDPOINT_RTOL * largest or 0 < period - span <= MAX_CLOSING_GAP * largest:
        kind = "one revolution (360°)" if cycle == 2 else "two revolutions (720°)"
        engine = "a two-stroke" if cycle == 2 else "a four-stroke (the default)"
        return f"; the table covers {kind}: if the engine is {engine}, set engine.cycle = {cycle}"
    return ""


def _level_problem(peak: float, crankcase: tuple[float, str], shown: str) -> str | None:
    """Why a trace peaking at ``peak`` [Pa] (``shown`` as text) cannot be a
    cylinder pressure over a crankcase at ``crankcase`` ([Pa], its key path),
    or None if it can."""
    if peak <= crankcase[0]:
        return (f"the whole trace lies at or below the crankcase pressure ({_bar(crankcase[0])} bar, {crankcase[1]}): "
                f"its maximum is {shown}, so the gas would never push the piston")
    if peak < MIN_PEAK_PRESSURE:
        return (f"it peaks at {shown}, below {_bar(MIN_PEAK_PRESSURE)} bar absolute, which every cylinder that "
                "compresses its charge exceeds")
    if peak > MAX_PEAK_PRESSURE:
        return (f"it peaks at {shown}, above {_bar(MAX_PEAK_PRESSURE)} bar, which no engine's cylinder reaches "
                "(production engines peak below about 300 bar)")
    return None


def _likely_unit(raw_peak: float, unit: str, crankcase: float, fix: str) -> str:
    """The units in which a trace's numbers (peaking at ``raw_peak`` in
    ``unit``) would peak at an ordinary cylinder pressure, above the crankcase
    pressure [Pa], and how to declare the likeliest of them (``fix``, a
    template with ``{unit}``); "" if there is none."""
    peaks = {u: raw_peak * to_si(f"1 {u}", "pressure") for u in TRACE_UNITS["pressure"] if u != unit}
    plausible = [u for u, p in peaks.items() if LOW_PEAK_PRESSURE <= p <= HIGH_PEAK_PRESSURE and not p <= crankcase]
    if not plausible:
        return ""
    # The likeliest: the peak nearest a typical 100 bar (on a log scale).
    plausible.sort(key=lambda u: abs(math.log(peaks[u] / 1e7)))
    read = "; ".join(f"in {u} it would peak at {_bar(peaks[u])} bar" for u in plausible)
    return f" ({read}): if its numbers are in {plausible[0]}, {fix.format(unit=plausible[0])}"


def _bar(pascal: float) -> str:
    """A pressure [Pa] in bar, to 6 significant digits."""
    return f"{pascal / 1e5:.6g}"


def _token(cell: str) -> str:
    """A file's cell as a message may show it: at most :data:`_TOKEN_CHARS` characters."""
    return cell if len(cell) <= _TOKEN_CHARS else cell[:_TOKEN_CHARS] + "…"


def _bad_row(cells: list[str], values: list[float] | None, has_rows: bool) -> str:
    """What is wrong with a line of a trace file that is not two numbers. Only
    in a file that has rows of numbers already, i.e. one meant as a trace, the
    offending token is shown (shortened): a message never echoes a file's lines."""
    if not has_rows:
        return ("neither the header nor a row of two numbers (angle, pressure): a trace file has at most one "
                "header line, such as \"angle [deg],pressure [bar]\", then two numbers per line (# starts a "
                "comment); is this a pressure trace?")
    if values is None:
        bad = next(c for c in cells if _numbers([c]) is None)
        return f"expected two numbers (angle, pressure), got {_token(bad)!r}"
    return f"expected two numbers (angle, pressure), got {len(values)}"


def _numbers(cells: list[str]) -> list[float] | None:
    """The cells as floats, or None if one is not a number."""
    try:
        return [float(c) for c in cells]
    except ValueError:
        return None

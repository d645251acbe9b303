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
from pathlib import Path
from typing import Any

import numpy as np

from .schema import (_MISSING, DEFAULT_CRANKCASE_PRESSURE, INTERPOLATIONS, SPEED_MEANS, Combustion, Flywheel, Gas,
                     PressureTrace, _join)
from .units import to_si

_GAS_KEYS = {"bore", "crankcase_pressure", "trace", "combustion"}
_FLYWHEEL_KEYS = {"inertia", "load_torque", "target_coefficient", "mean"}
_TRACE_KEYS = {"angle", "pressure", "file", "units", "interpolation"}
_COMBUSTION_KEYS = {"compression_ratio", "intake_pressure", "exhaust_pressure", "compression_exponent",
                    "expansion_exponent", "start", "duration", "shape", "efficiency", "peak_pressure", "imep"}
#: The units a trace's columns may be given in (the fast unit parser reads all of them without pint).
TRACE_UNITS = {"angle": ("deg", "rad"), "pressure": ("Pa", "kPa", "MPa", "bar", "mbar")}
#: A trace is one table of samples: fewer points cannot describe a pressure cycle.
MIN_TRACE_POINTS = 8
#: Largest gap closing the cycle, in units of the largest spacing inside the table.
MAX_CLOSING_GAP = 1.5
#: Relative difference allowed between the pressures at the two ends of a table that includes its endpoint.
PERIODIC_RTOL = 1e-6
#: Angles within this share of a spacing of first + one cycle count as the endpoint.
_ENDPOINT_RTOL = 1e-9
#: Alternative sources of a measured table: a cylinder's override giving one drops the shared other.
_TABLE_SOURCES = ({"file"}, {"angle", "pressure"})
_HEADER_UNITS = re.compile(r"^\s*([A-Za-z_ ]*?)\s*[\[(]\s*([^\])]+?)\s*[\])]\s*$")


class GasTables:
    """The [gas] tables and [flywheel]; mixed into the scene reader, whose
    primitives (``fail``, ``table``, ``quantity``, ...) it uses. ``base`` is
    the directory trace files are relative to, ``files`` the trace files read
    so far (path -> text), ``gases`` the distinct gas tables made so far."""

    def flywheel(self, data: Mapping, has_gas: bool) -> Flywheel | None:
        """[flywheel]: what the speed fluctuation needs beyond the gas torque."""
        if "flywheel" not in data:
            return None
        table = self.table(data, "flywheel", "flywheel", _FLYWHEEL_KEYS)
        if not has_gas:
            self.fail("flywheel", data["flywheel"], "the speed fluctuation is driven by the gas torque: "
                      "it needs a [gas] table")
        inertia = self.quantity(table, "inertia", "flywheel", "inertia", positive=True)
        load = self.quantity(table, "load_torque", "flywheel", "moment") if "load_torque" in table else None
        target = None
        if "target_coefficient" in table:
            target = self.quantity(table, "target_coefficient", "flywheel", "dimensionless", positive=True)
            if not target < 1:
                self.fail("flywheel.target_coefficient", table["target_coefficient"],
                          "must be below 1 (δ = (ω_max − ω_min)/ω_mean; engines need about 0.002–0.05)")
        mean = self.choice(table, "mean", "flywheel", SPEED_MEANS, "time")
        return Flywheel(inertia=inertia, load_torque=load, target_coefficient=target, mean=mean)

    def gas_merged(self, shared: Mapping | None, entry: Mapping, path: str) -> tuple[dict, dict[str, str]] | None:
        """A cylinder's gas table: the shared [gas] overlaid key by key by its
        own ``gas`` table (sub-tables likewise; a cylinder giving ``trace``
        drops the shared ``combustion`` and vice versa, and a trace giving
        ``file`` drops the shared ``angle``/``pressure`` and vice versa), with
        the section each key was written in. None when neither has one."""
        own = self.table(entry, "gas", _join(path, "gas"), _GAS_KEYS)
        if shared is None and "gas" not in entry:
            return None
        shared = shared or {}
        merged, where = {}, {}
        for key in _GAS_KEYS - {"trace", "combustion"}:
            if key in own:
                merged[key], where[key] = own[key], _join(path, "gas")
            elif key in shared:
                merged[key], where[key] = shared[key], "gas"
        chosen = [k for k in ("trace", "combustion") if k in own] or [k for k in ("trace", "combustion") if k in shared]
        for key in chosen:
            mine, theirs = own.get(key, {}), shared.get(key, {})
            if not isinstance(mine, Mapping) or not isinstance(theirs, Mapping):
                bad = (_join(path, "gas"), mine) if not isinstance(mine, Mapping) else ("gas", theirs)
                self.fail(_join(bad[0], key), bad[1], "must be a table")
                continue
            if key == "trace":
                for source in _TABLE_SOURCES:
                    if source & mine.keys():
                        theirs = {k: v for k, v in theirs.items() if k not in set().union(*_TABLE_SOURCES) - source}
            merged[key] = {**theirs, **mine}
            # Each key of the sub-table is reported where it was written.
            where[key] = {k: _join(_join(path, "gas") if k in mine else "gas", key) for k in merged[key]}
        return merged, where

    def gas(self, merged: tuple[dict, dict[str, str]] | None, cycle: int) -> Gas | None:
        """The validated :class:`Gas` of one cylinder (None without a gas table)."""
        if merged is None:
            return None
        table, where = merged
        bore = self.quantity(table, "bore", where.get("bore", "gas"), "length", positive=True)
        crankcase = self.quantity(table, "crankcase_pressure", where.get("crankcase_pressure", "gas"), "pressure",
                                  default=DEFAULT_CRANKCASE_PRESSURE, positive=True)
        given = [k for k in ("trace", "combustion") if k in table]
        if len(given) != 1:
            self.fail("gas", sorted(given) if given else _MISSING,
                      "give exactly one of [gas.trace] (a measured trace) and [gas.combustion] (a parametric one)")
            return None
        key = given[0]
        allowed = _TRACE_KEYS if key == "trace" else _COMBUSTION_KEYS
        for name, value in table[key].items():
            self.unknown({name: value}, where[key][name], allowed)
        # Problems of the sub-table as a whole go where the cylinder wrote it, or to the shared one.
        section = next((w for w in where[key].values() if not w.startswith("gas.")), f"gas.{key}")
        if key == "trace":
            trace = self.trace(table["trace"], where["trace"], section, cycle)
        else:
            trace = self.combustion(table["combustion"], where["combustion"], section, cycle)
        if trace is None or not (math.isfinite(bore) and math.isfinite(crankcase)):
            return None
        gas = Gas(bore=bore, crankcase_pressure=crankcase, trace=trace)
        # Cylinders of equal tables share one object: the model finds cylinders with the same trace by
        # identity, without comparing the tables again at every evaluation.
        same = next((g for g in self.gases if g == gas), None)
        if same is None:
            self.gases.append(gas)
        return gas if same is None else same

    # -- measured traces ---------------------------------------------------

    def trace(self, table: dict, where: dict[str, str], section: str, cycle: int) -> PressureTrace | None:
        """A measured trace; ``where`` gives the section each key was written in."""

        def at(key: str) -> str:
            return _join(where.get(key, section), key)

        interpolation = table.get("interpolation", INTERPOLATIONS[0])
        if interpolation not in INTERPOLATIONS:
            self.fail(at("interpolation"), interpolation, f"must be one of {', '.join(map(repr, INTERPOLATIONS))}")
            return None
        units = table.get("units", {})
        if not isinstance(units, Mapping):
            self.fail(at("units"), units, "must be a table such as { angle = \"deg\", pressure = \"bar\" }")
            return None
        self.unknown(units, at("units"), set(TRACE_UNITS))
        has_file, has_table = "file" in table, bool({"angle", "pressure"} & table.keys())
        if has_file == has_table:
            self.fail(section, sorted(table) if table else _MISSING,
                      "give the trace either as a file or as angle and pressure lists, exactly one of them")
            return None
        if has_file:
            key = at("file")
            read = self.trace_file(table["file"], key, units)
            if read is None:
                return None
            angle, pressure, source, found = read
            factors = self.unit_factors(found, at("units") if units else key)
        else:
            angle, pressure, source, key = table.get("angle", _MISSING), table.get("pressure", _MISSING), "inline", None
            for name, values in (("angle", angle), ("pressure", pressure)):
                if values is _MISSING:
                    self.fail(at(name), _MISSING, "missing: a trace needs both angle and pressure lists")
                    return None
                if (not isinstance(values, list) or any(isinstance(v, bool) or not isinstance(v, (int, float))
                                                        for v in values)):
                    self.fail(at(name), values, "must be a list of numbers (units in trace.units)")
                    return None
            factors = self.unit_factors(dict(units), at("units"))
        if factors is None:
            return None
        if len(angle) != len(pressure):
            self.fail(key or at("pressure"), f"{len(angle)} angles, {len(pressure)} pressures",
                      "angle and pressure must have the same length")
            return None
        checked = self.check_table(np.asarray(angle, float) * factors[0], np.asarray(pressure, float) * factors[1],
                                   cycle, key, at)
        if checked is None:
            return None
        return PressureTrace(angle=tuple(checked[0].tolist()), pressure=tuple(checked[1].tolist()),
                             interpolation=interpolation, source=source)

    def unit_factors(self, units: Mapping, key: str) -> tuple[float, float] | None:
        """SI factors of the angle and pressure units (plain numbers are SI: rad and Pa)."""
        factors = []
        for dimension, default in (("angle", "rad"), ("pressure", "Pa")):
            unit = units.get(dimension, default)
            if unit not in TRACE_UNITS[dimension]:
                self.fail(_join(key, dimension) if not key.endswith(".file") else key, unit,
                          f"unknown units for {dimension}; allowed: {', '.join(TRACE_UNITS[dimension])}")
                return None
            factors.append(to_si(f"1 {unit}", dimension))
        return factors[0], factors[1]

    def trace_file(self, name: Any, key: str, units: Mapping) -> tuple[list, list, str, dict] | None:
        """Angles, pressures (in the file's units), the resolved path and the
        units (the header's, or ``units`` where the header has none)."""
        if not isinstance(name, str):
            self.fail(key, name, "must be a path (a string)")
            return None
        path = Path(name) if Path(name).is_absolute() else self.base / name
        try:
            # Cylinders sharing the [gas] table share its file: read it once.
            text = self.files[path] if path in self.files else self.files.setdefault(path, path.read_text(
                encoding="utf-8"))
        except FileNotFoundError:
            self.fail(key, name, f"file not found: {path}")
            return None
        except (OSError, UnicodeDecodeError) as exc:
            self.fail(key, name, f"cannot read {path}: {exc}")
            return None
        angle, pressure, header = [], [], None
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
                self.fail(key, name, f"{path}, line {number}: expected two numbers (angle, pressure), got {line!r}")
                return None
            angle.append(values[0])
            pressure.append(values[1])
        found = dict(units)
        if header is not None:
            for dimension, cell in zip(("angle", "pressure"), header):
                match = _HEADER_UNITS.match(cell)
                if match:
                    if dimension in units and units[dimension] != match.group(2):
                        self.fail(key, name, f"the header of {path} gives {dimension} in {match.group(2)!r} but "
                                  f"trace.units says {units[dimension]!r}")
                        return None
                    found[dimension] = match.group(2)
        return angle, pressure, str(path), found

    def check_table(self, angle: np.ndarray, pressure: np.ndarray, cycle: int, key: str | None,
                    at) -> tuple[np.ndarray, np.ndarray] | None:
        """The table in SI checked to describe one cycle, without the closing
        endpoint if it was given. ``key`` names the file, if any; else the
        problems go to the angle or pressure list."""
        period = math.pi * cycle
        cycle_text = f"{180 * cycle}°"
        akey, pkey = key or at("angle"), key or at("pressure")
        if angle.size < MIN_TRACE_POINTS:
            self.fail(akey, f"{angle.size} points", f"a trace needs at least {MIN_TRACE_POINTS} points")
            return None
        if not (np.isfinite(angle).all() and np.isfinite(pressure).all()):
            self.fail(akey, "nan or inf", "must be finite")
            return None
        steps = np.diff(angle)
        if not (steps > 0).all():
            i = int(np.argmax(steps <= 0))
            self.fail(akey, f"{math.degrees(angle[i]):.6g}°, {math.degrees(angle[i + 1]):.6g}° (points {i + 1}, "
                      f"{i + 2})", "angles must be strictly increasing")
            return None
        if not (pressure > 0).all():
            i = int(np.argmax(~(pressure > 0)))
            self.fail(pkey, f"{pressure[i]:.6g} Pa at point {i + 1}", "absolute pressures must be positive")
            return None
        span = angle[-1] - angle[0]
        largest = float(steps.max())
        if abs(span - period) <= _ENDPOINT_RTOL * largest:
            # The table includes its endpoint: it must close on itself.
            if abs(pressure[-1] - pressure[0]) > PERIODIC_RTOL * max(abs(pressure[0]), abs(pressure[-1])):
                self.fail(pkey, f"{pressure[0]:.9g} Pa at {math.degrees(angle[0]):.6g}°, {pressure[-1]:.9g} Pa at "
                          f"{math.degrees(angle[-1]):.6g}°",
                          f"not periodic: the two ends of the {cycle_text} cycle differ by more than "
                          f"{PERIODIC_RTOL:g} relative")
                return None
            return angle[:-1], pressure[:-1]
        if span > period:
            self.fail(akey, f"{math.degrees(angle[0]):.6g}° to {math.degrees(angle[-1]):.6g}°",
                      f"trace longer than a cycle: it spans {math.degrees(span):.6g}°, one cycle is {cycle_text} "
                      "(angles without units are radians)")
            return None
        gap = period - span
        if gap > MAX_CLOSING_GAP * largest:
            self.fail(akey, f"{math.degrees(angle[0]):.6g}° to {math.degrees(angle[-1]):.6g}°",
                      f"trace shorter than a cycle: the gap closing the {cycle_text} cycle is "
                      f"{math.degrees(gap):.6g}°, more than {MAX_CLOSING_GAP:g} x the largest spacing "
                      f"({math.degrees(largest):.6g}°)")
            return None
        return angle, pressure

    # -- parametric traces -------------------------------------------------

    def combustion(self, table: dict, where: dict[str, str], section: str, cycle: int) -> Combustion | None:
        """A parametric trace; ``where`` gives the section each key was written in."""

        def q(key: str, dimension: str, default: Any = _MISSING, **checks) -> float:
            return self.quantity(table, key, where.get(key, section), dimension, default=default, **checks)

        before = len(self.problems)
        if cycle != 4:
            self.fail(section, _MISSING, "the parametric trace models a four-stroke cycle (engine.cycle = 4); "
                      "give a two-stroke a measured [gas.trace]")
        ratio = q("compression_ratio", "dimensionless")
        if math.isfinite(ratio) and not ratio > 1:
            self.fail(_join(where.get("compression_ratio", section), "compression_ratio"), table["compression_ratio"],
                      "must be greater than 1")
        intake = q("intake_pressure", "pressure", positive=True)
        exhaust = q("exhaust_pressure", "pressure", positive=True) if "exhaust_pressure" in table else intake
        exponents = []
        for key, default in (("compression_exponent", 1.35), ("expansion_exponent", 1.30)):
            n = q(key, "dimensionless", default=default)
            if math.isfinite(n) and not 1 < n < 2:
                self.fail(_join(where.get(key, section), key), table[key], "a polytropic exponent must lie in (1, 2)")
            exponents.append(n)
        start = q("start", "angle")
        duration = q("duration", "angle", positive=True)
        if math.isfinite(start) and math.isfinite(duration) and duration > 0 and not (
                -math.pi < start and start + duration < math.pi):
            self.fail(_join(where.get("duration", section), "duration"), table.get("duration"),
                      f"combustion from {math.degrees(start):.6g}° for {math.degrees(duration):.6g}° must lie between "
                      "inlet valve closing (-180°) and exhaust valve opening (+180°)")
        shape = q("shape", "dimensionless", default=2.0, nonnegative=True)
        efficiency = q("efficiency", "dimensionless", default=6.908, positive=True)
        targets = [k for k in ("peak_pressure", "imep") if k in table]
        peak = imep = None
        if len(targets) != 1:
            self.fail(section, sorted(targets) if targets else _MISSING,
                      "give exactly one target for the heat release: peak_pressure or imep")
        elif targets[0] == "peak_pressure":
            peak = q("peak_pressure", "pressure", positive=True)
        else:
            imep = q("imep", "pressure", positive=True)
        if len(self.problems) > before:
            return None
        return Combustion(compression_ratio=ratio, intake_pressure=intake, exhaust_pressure=exhaust,
                          compression_exponent=exponents[0], expansion_exponent=exponents[1], start=start,
                          duration=duration, shape=shape, efficiency=efficiency, peak_pressure=peak, imep=imep)


def _numbers(cells: list[str]) -> list[float] | None:
    """The cells as floats, or None if one is not a number."""
    try:
        return [float(c) for c in cells]
    except ValueError:
        return None

"""Every numeric scene key lies in a documented range (issue 32, item 3):
the issue's examples are refused naming the key, the range table is complete
(docs, reader and ranges.py agree), both ends of every range are accepted and
just beyond them refused, and an engine scaled to the ends of the ranges
analyses to finite orders, equal to the nominal engine's times the scale."""

import math
import re
import tomllib
import warnings
from pathlib import Path

import numpy as np
import pytest

import harmbal as hb
from harmbal.cli import main
from harmbal.scene import SceneError
from harmbal.scene.firing import FiringWarning
from harmbal.scene.ranges import KEY_RANGES, MAGNITUDES, MAX_RATIO, number
from tests.conftest import assert_close_to_scale

ROOT = Path(__file__).resolve().parent.parent
ENGINES = ROOT / "datasets" / "engines"


def scene(name: str, **edits) -> dict:
    """The bundled scene ``name`` as a mapping with keys set (``a.b[2].c`` paths)."""
    data = tomllib.loads((ENGINES / f"{name}.toml").read_text(encoding="utf-8"))
    for path, value in edits.items():
        set_key(data, path, value)
    return data


def set_key(data: dict, path: str, value) -> None:
    parts = path.split(".")
    node = data
    for part in parts[:-1]:
        name, _, index = part.partition("[")
        node = node.setdefault(name, {})
        if index:
            node = node[int(index.rstrip("]")) - 1]
    if value is None:
        node.pop(parts[-1], None)
    else:
        node[parts[-1]] = value


def problems(data: dict) -> list:
    with pytest.raises(SceneError) as info:
        hb.load_scene(data)
    return info.value.problems


def refused_at(data: dict, key: str) -> str:
    """The rules of the problems of ``data``, which must all be at ``key``."""
    found = problems(data)
    assert {p.key for p in found} == {key}, [str(p) for p in found]
    return "; ".join(p.rule for p in found)


# -- the issue's examples --------------------------------------------------------------------------

GAS = "single-gas"
EXAMPLES = [
    (scene("inline-4", **{"engine.speed": "1e300 rpm"}), "engine.speed", "rad/s"),
    (scene("inline-4", **{"engine.speed": ["3000 rpm", 1e300]}), "engine.speed[2]", "rad/s"),
    (scene("inline-4", **{"piston.mass": 1e300}), "piston.mass", "kg"),
    (scene("inline-4", crankshaft_unbalance=[{"unbalance": "1e300 kg m"}]), "crankshaft_unbalance[1].unbalance",
     "kg m"),
    (scene("inline-4", crankshaft_unbalance=[{"mass": "1e300 kg", "radius": "1 mm"}]),
     "crankshaft_unbalance[1].mass", "kg"),
    (scene("inline-4", **{"cylinder[1].axial_position": "1e300 mm"}), "cylinder[1].axial_position", "m"),
    (scene("inline-4", **{"rod.cg_offset": 5e-324}), "rod.cg_offset", "m"),
    (scene("inline-4", **{"engine.reference_point": ["1e-300 mm", "0 mm", "0 mm"]}), "engine.reference_point[1]",
     "m"),
    (scene(GAS, **{"gas.combustion.compression_ratio": 1e10}), "gas.combustion.compression_ratio", "(1, 100]"),
    (scene("inline-4", sampling={"samples_per_rev": 10_000_000}), "sampling.samples_per_rev", "65536"),
    (scene("inline-4", balance_shaft=[{"ratio": 1_000_000_000, "unbalance": [{"unbalance": "1 kg mm"}]}]),
     "balance_shaft[1].ratio", str(MAX_RATIO)),
    (scene("inline-4-lanchester", **{"lanchester_pair[1].order": 10**20}), "lanchester_pair[1].order",
     str(MAX_RATIO)),
    (scene(GAS, **{"gas.combustion.intake_pressure": "1e6 bar"}), "gas.combustion.intake_pressure", "bar"),
    (scene(GAS, **{"gas.combustion.peak_pressure": "1e4 bar"}), "gas.combustion.peak_pressure", "bar"),
    (scene(GAS, **{"gas.combustion.peak_pressure": None, "gas.combustion.imep": "1e-3 Pa"}),
     "gas.combustion.imep", "bar"),
    (scene(GAS, **{"gas.crankcase_pressure": "1e300 Pa"}), "gas.crankcase_pressure", "bar"),
    (scene(GAS, **{"gas.bore": "1e300 mm"}), "gas.bore", "m"),
    (scene(GAS, **{"gas.combustion.compression_exponent": 1e300}), "gas.combustion.compression_exponent",
     "(1, 2)"),
]


@pytest.mark.parametrize("data, key, unit", EXAMPLES, ids=[e[1] for e in EXAMPLES])
def test_the_issues_examples_are_refused_naming_key_value_and_range(data, key, unit):
    rule = refused_at(data, key)
    assert unit in rule and re.search(r"between|must lie in|at most", rule), rule


def test_a_refusal_on_the_command_line_is_one_line_naming_file_and_key(tmp_path, capsys):
    import tomli_w

    path = tmp_path / "engine.toml"
    path.write_text(tomli_w.dumps(scene("inline-4", **{"piston.mass": 1e300})), encoding="utf-8")
    assert main(["run", str(path), "-o", str(tmp_path / "out.nc")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and f"{path}: piston.mass = 1e+300: out of range" in err[0], err
    assert "between 1e-9 and 1e7 kg" in err[0]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["engine.toml"]


# -- the table is complete -------------------------------------------------------------------------

def _ranges_section() -> dict[str, str]:
    """{first cell: range cell} of the tables of docs/scenes.md's "Ranges" section."""
    text = (ROOT / "docs" / "scenes.md").read_text(encoding="utf-8")
    section = text.split("\n## Ranges\n", 1)[1].split("\n## ", 1)[0]
    rows = {}
    for line in section.splitlines():
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        if line.startswith("|") and len(cells) >= 2 and not set(cells[0]) <= set("-") and cells[0] not in (
                "dimension", "key"):
            for name in re.findall(r"`(\w+)`", cells[0]) or [cells[0]]:
                rows[name] = cells[1]
    return rows


def test_the_documented_range_table_is_the_readers():
    rows = _ranges_section()
    for dimension, bounds in MAGNITUDES.items():
        high = "3600°" if dimension == "angle" else f"{number(bounds.high)} {bounds.unit}"
        low = f"{number(bounds.low)} rad" if dimension == "angle" else number(bounds.low)
        assert rows.pop(dimension) == f"0 or {low} … {high}", dimension
    for key, bounds in KEY_RANGES.items():
        assert rows.pop(key) == bounds.interval(), key
    assert not rows, f"documented ranges the reader does not have: {rows}"


def _reader_source() -> str:
    return "\n".join(p.read_text(encoding="utf-8") for p in (ROOT / "harmbal" / "scene").glob("read*.py"))


def test_every_key_the_reader_reads_has_a_range():
    source = _reader_source()
    call = r'(?:quantity(?:_list)?\(\s*[^,()]+,\s*|\bq\()"(\w+)",\s*(?:[^,()]*\([^()]*\)|[^,()]+),\s*"(\w+)"'
    quantities = set(re.findall(call, source)) | set(re.findall(r'\bq\("(\w+)",\s*"(\w+)"', source))
    integers = set(re.findall(r'\breader\.integer\(\s*[^,()]+,\s*"(\w+)"', source))
    assert len(quantities) > 40 and {"samples_per_rev", "max_order", "order", "points"} <= integers
    for name, dimension in quantities:
        assert dimension in MAGNITUDES or name in KEY_RANGES, (name, dimension)
        if dimension == "dimensionless":
            assert name in KEY_RANGES, name
    assert integers <= KEY_RANGES.keys(), integers - KEY_RANGES.keys()
    # Key-specific ranges of quantities lie within their dimension's.
    for name, dimension in quantities:
        if name in KEY_RANGES and dimension in MAGNITUDES:
            outer, inner = MAGNITUDES[dimension], KEY_RANGES[name]
            assert outer.low <= inner.low and inner.high <= outer.high, name


def test_a_dimensionless_key_without_a_range_cannot_be_read():
    from harmbal.scene.collector import Collector

    with pytest.raises(KeyError, match="KEY_RANGES"):
        Collector("x.toml").quantity({"new_key": 1.0}, "new_key", "model", "dimensionless")
    with pytest.raises(KeyError):
        Collector("x.toml").integer({"new_count": 3}, "new_count", "model", None, 1)


# -- both ends of every range ----------------------------------------------------------------------

def _lanchester_loads(**loads):
    return scene("inline-4-lanchester", loads={"element": [{"label": "Lanchester pair", **loads}]})


def _mounted(first: dict | None = None, **tables) -> dict:
    """inline-4 on three mounts, the first mount's keys updated by ``first``, tables added."""
    mounts = [{"name": str(i), "position": [x, y, "0 mm"], "stiffness": ["300 N/mm", "300 N/mm", "900 N/mm"]}
              for i, (x, y) in enumerate((("300 mm", "250 mm"), ("300 mm", "-250 mm"), ("-400 mm", "0 mm")))]
    mounts[0].update(first or {})
    powertrain = {"mass": "480 kg", "cg": ["0 mm", "0 mm", "180 mm"],
                  "inertia": {"xx": "18 kg m^2", "yy": "42 kg m^2", "zz": "38 kg m^2"}}
    return scene("inline-4", powertrain={**powertrain, **tables.pop("powertrain", {})}, mount=mounts, **tables)


def _mount_design(**keys) -> dict:
    return _mounted(mount_design={"variable": [{"mount": "0", "stiffness": "w", "bounds": ["1 N/mm", "1 kN/mm"]}],
                                  **keys})


#: Per dimension: a scene with a key of that dimension set to the value (SI), and that key's path.
DIMENSION_KEYS = {
    "length": lambda v: scene("inline-4", **{"cylinder[1].axial_position": v}),
    "mass": lambda v: scene("inline-4", **{"piston.mass": v}),
    "angle": lambda v: scene("inline-4", crankshaft_unbalance=[{"unbalance": "1 kg mm", "angle": f"{v} rad"}]),
    "speed": lambda v: scene("inline-4", **{"engine.speed": v}),
    "inertia": lambda v: scene("inline-4", **{"rod.inertia": v}),
    "unbalance": lambda v: scene("inline-4", crankshaft_unbalance=[{"unbalance": v}]),
    "force": lambda v: scene("inline-4", loads={"main_bearings": ["-200 mm", "200 mm"],
                                                "static_load": [{"force": [v, 0.0], "axial_position": 0.0}]}),
    "moment": lambda v: scene(GAS, flywheel={"inertia": "0.2 kg m^2", "load_torque": v}),
    "time": lambda v: scene("inline-4-lanchester", loads={
        "element": [{"label": "Lanchester pair", "inertia": "0.01 kg m^2"}],
        "ramp": {"from": 0.0, "to": "6000 rpm", "time": v}}),
    "density": lambda v: scene("inline-4", counterweight=[{"angle": "180 deg", "density": v, "thickness": "20 mm",
                                                           "shape": [{"kind": "circle", "radius": "50 mm",
                                                                      "centre": ["60 mm", "0 mm"]}]}]),
    "stiffness": lambda v: _mounted({"stiffness": [v, "1 N/mm", "1 N/mm"]}),
    "damping": lambda v: _mounted({"damping": [v, 0.0, 0.0]}),
    "acceleration": lambda v: _mounted(powertrain={"gravity": [0.0, 0.0, v]}),
    "frequency": lambda v: _mount_design(frequency_band=[0.0, v]),
}
DIMENSION_PATHS = {"length": "cylinder[1].axial_position", "mass": "piston.mass",
                   "angle": "crankshaft_unbalance[1].angle", "speed": "engine.speed", "inertia": "rod.inertia",
                   "unbalance": "crankshaft_unbalance[1].unbalance", "force": "loads.static_load[1].force[1]",
                   "moment": "flywheel.load_torque", "time": "loads.ramp.time", "density": "counterweight[1].density",
                   "stiffness": "mount[1].stiffness[1]", "damping": "mount[1].damping[1]",
                   "acceleration": "powertrain.gravity[3]", "frequency": "mount_design.frequency_band[2]"}


@pytest.mark.parametrize("dimension", sorted(DIMENSION_KEYS))
def test_both_ends_of_each_dimension_are_accepted_and_beyond_refused(dimension):
    bounds, build = MAGNITUDES[dimension], DIMENSION_KEYS[dimension]
    for value in (bounds.low, bounds.high):
        hb.load_scene(build(value))
    for value in (bounds.low / 2, bounds.high * 1.01):
        assert "out of range" in refused_at(build(value), DIMENSION_PATHS[dimension])


def test_every_dimension_with_keys_is_tested_at_its_ends():
    # pressure has no key of its own range: every gas pressure's is narrower (tested below)
    assert set(DIMENSION_KEYS) == set(MAGNITUDES) - {"pressure"}


def _inside(bounds, end: str) -> float:
    value = bounds.low if end == "low" else bounds.high
    is_open = bounds.open_low if end == "low" else bounds.open_high
    if not is_open:
        return value
    return value + 1e-9 * (1 if end == "low" else -1) * max(abs(value), 1.0)


def _outside(bounds, end: str, integer: bool) -> float:
    value = bounds.low if end == "low" else bounds.high
    is_open = bounds.open_low if end == "low" else bounds.open_high
    step = 0 if is_open else 1 if integer else 1e-6 * max(abs(value), 1e-3)
    return value - step if end == "low" else value + step


def _bar(v):
    return f"{v / 1e5!r} bar"


def _flywheel(v):
    return scene(GAS, flywheel={"inertia": "0.2 kg m^2", "target_coefficient": v})


#: Per key of KEY_RANGES: (scene with the value set, the key path refused, how to write the value).
KEY_CASES = {
    "samples_per_rev": (lambda v: scene("inline-4", sampling={"samples_per_rev": v, "max_order": 3}),
                        "sampling.samples_per_rev", int),
    "max_order": (lambda v: scene("inline-4", sampling={"max_order": v}, design=None), "sampling.max_order", int),
    "accuracy": (lambda v: scene("inline-4", sampling={"accuracy": v}), "sampling.accuracy", float),
    "negligible": (lambda v: scene("inline-4", model={"negligible": v}), "model.negligible", float),
    "series_harmonics": (lambda v: scene("inline-4", model={"piston": "series", "series_harmonics": v}),
                         "model.series_harmonics", int),
    "points": (lambda v: scene("inline-4", **{"engine.speed": {"from": "1000 rpm", "to": "6000 rpm", "points": v}}),
               "engine.speed.points", int),
    "cycle": (lambda v: scene("inline-4", **{"engine.cycle": v, "engine.firing_order": None}), "engine.cycle", int),
    "ratio": (lambda v: scene("inline-4", balance_shaft=[{"ratio": v, "unbalance": [{"unbalance": "1 kg mm"}]}]),
              "balance_shaft[1].ratio", int),
    "order": (lambda v: scene("inline-4", sampling={"max_order": 16384},
                              verify={"orders": [min(max(v, 1), 16384)], "speed": "3000 rpm",
                                      "predicted": [{"order": v, "force_co": ["0 N", "0 deg"]}]}),
              "verify.predicted[1].order", int),
    "fasteners": (lambda v: _lanchester_loads(fasteners=v), "loads.element[1].fasteners", int),
    "balance_factor": (lambda v: scene("test-single", **{"design.counterweights[1].balance_factor": v}),
                       "design.counterweights[1].balance_factor", float),
    "tolerance": (lambda v: scene("inline-4", verify={"orders": [2], "tolerance": v}), "verify.tolerance", float),
    "weights": (lambda v: scene("lever-single", design={"objective": "orders", "orders": [1, 2],
                                                        "lever": {"weights": [v, 1.0], "mass": ["0.5 kg", "5 kg"],
                                                                  "cg_x": ["0 mm", "100 mm"],
                                                                  "cg_y": ["-60 mm", "60 mm"]}}),
                "design.lever.weights", float),
    "target_coefficient": (_flywheel, "flywheel.target_coefficient", float),
    "compression_ratio": (lambda v: scene(GAS, **{"gas.combustion.compression_ratio": v}),
                          "gas.combustion.compression_ratio", float),
    "compression_exponent": (lambda v: scene(GAS, **{"gas.combustion.compression_exponent": v}),
                             "gas.combustion.compression_exponent", float),
    "expansion_exponent": (lambda v: scene(GAS, **{"gas.combustion.expansion_exponent": v}),
                           "gas.combustion.expansion_exponent", float),
    "shape": (lambda v: scene(GAS, **{"gas.combustion.shape": v}), "gas.combustion.shape", float),
    "efficiency": (lambda v: scene(GAS, **{"gas.combustion.efficiency": v}), "gas.combustion.efficiency", float),
    "crankcase_pressure": (lambda v: scene(GAS, **{"gas.crankcase_pressure": v}), "gas.crankcase_pressure", _bar),
    "intake_pressure": (lambda v: scene(GAS, **{"gas.combustion.intake_pressure": v}),
                        "gas.combustion.intake_pressure", _bar),
    "exhaust_pressure": (lambda v: scene(GAS, **{"gas.combustion.exhaust_pressure": v}),
                         "gas.combustion.exhaust_pressure", _bar),
    "peak_pressure": (lambda v: scene(GAS, **{"gas.combustion.peak_pressure": v}), "gas.combustion.peak_pressure",
                      _bar),
    "imep": (lambda v: scene(GAS, **{"gas.combustion.peak_pressure": None, "gas.combustion.imep": v}),
             "gas.combustion.imep", _bar),
    "loss_factor": (lambda v: _mounted({"loss_factor": v}), "mount[1].loss_factor", float),
    "decoupling": (lambda v: _mount_design(decoupling=v), "mount_design.decoupling", float),
}


def test_every_key_range_is_tested_at_its_ends():
    assert set(KEY_CASES) == set(KEY_RANGES)


@pytest.mark.parametrize("key", sorted(KEY_CASES))
def test_both_ends_of_each_key_range_are_accepted_and_beyond_refused(key):
    bounds, (build, path, written) = KEY_RANGES[key], KEY_CASES[key]
    if key == "cycle":  # 2 or 4, nothing between
        for value in (2, 4):
            hb.load_scene(build(value))
        for value in (1, 3, 5):
            refused_at(build(value), path)
        return
    for end in ("low", "high"):
        hb.load_scene(build(written(_inside(bounds, end))))
        refused_at(build(written(_outside(bounds, end, written is int))), path)


def test_a_lanchester_pairs_order_is_a_ratio():
    hb.load_scene(scene("inline-4-lanchester", **{"lanchester_pair[1].order": MAX_RATIO}))
    refused_at(scene("inline-4-lanchester", **{"lanchester_pair[1].order": MAX_RATIO + 1}), "lanchester_pair[1].order")
    design = scene("test-single", **{"design.lanchester_pair[1].order": MAX_RATIO + 1}, sampling={"max_order": 200})
    refused_at(design, "design.lanchester_pair[1].order")


# -- an engine at the ends of the ranges -----------------------------------------------------------

#: (length, mass) scale factors and speeds [rad/s] that put inline-4's keys at the ends of their ranges:
#: its smallest length (43 mm) at 4.3e-15 m, piston 1e-9 kg, rod inertia 4.6e-38 kg m²; or its largest
#: length (145 mm, 144 mm) near 1000 m, rod mass 9.9e6 kg, inertia 1.5e12 kg m², speeds up to 1e5 rad/s.
SCALES = {"smallest": (1e-13, 2e-9, [1e-3, 2e-3]), "largest": (6e3, 1.8e7, [5e4, 1e5])}
_LENGTH_KEYS = ("crank_radius", "rod_length", "cg_from_big_end", "axial_position")


def _scaled(length: float, mass: float, speeds: list[float]) -> dict:
    from harmbal.scene.units import to_si

    data = scene("inline-4")
    data["engine"]["speed"] = speeds
    data["engine"]["reference_point"] = [0.0, 0.0, 0.0]
    for table in (data["geometry"], data["piston"], data["rod"], *data["cylinder"]):
        for key, value in table.items():
            if key in _LENGTH_KEYS:
                table[key] = to_si(value, "length") * length
            elif key == "mass":
                table[key] = to_si(value, "mass") * mass
            elif key == "inertia":
                table[key] = to_si(value, "inertia") * mass * length**2
    return data


@pytest.mark.parametrize("end", sorted(SCALES))
def test_an_engine_at_the_ends_of_the_ranges_analyses_to_finite_scaled_orders(end):
    length, mass, speeds = SCALES[end]
    nominal = scene("inline-4")
    nominal["engine"]["speed"] = [s / speeds[0] * 314.0 for s in speeds]  # the same speed ratio
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # no numpy overflow or underflow warning either
        base = hb.analyse(hb.load_scene(nominal))["orders"].ds
        orders = hb.analyse(hb.load_scene(_scaled(length, mass, speeds)))["orders"].ds
    omega2 = (speeds[0] / 314.0) ** 2
    for name, scale in (("force", mass * length * omega2), ("moment", mass * length**2 * omega2)):
        for variable in (name, f"{name}_rotating"):
            assert np.isfinite(orders[variable].values).all()
            assert_close_to_scale(orders[variable].values, base[variable].values * scale,
                                  (base[f"{name}_scale"].values * scale)[:, None, None], rtol=1e-10,
                                  err_msg=f"{end}: {variable}")
        assert (orders[f"{name}_class"].values == base[f"{name}_class"].values).all()


# -- accepted without a word before ----------------------------------------------------------------

def test_a_firing_order_firing_two_cylinders_at_once_warns_naming_the_key():
    with pytest.warns(FiringWarning, match=r"engine\.firing_order = \[1, 2, 3, 4\]: cylinders 4 and 1 fire at the "
                                           r"same instant.*1-2-4-3"):
        hb.load_scene(scene("inline-4", **{"engine.firing_order": [1, 2, 3, 4]}))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        hb.load_scene(scene("inline-4"))  # 1-3-4-2, even
        hb.load_scene(scene("inline-twin-360"))  # both at TDC together and no way to fire them apart evenly


def test_too_few_samples_on_a_scene_without_balancers_is_one_problem():
    rule = refused_at(scene("inline-4", sampling={"samples_per_rev": 8}), "sampling.samples_per_rev")
    assert "2*max_order + 2" in rule  # not also "a balancer element turning at 0×"


def test_too_few_samples_for_a_balancer_names_the_samples():
    data = scene("inline-4-lanchester", sampling={"samples_per_rev": 26})
    data["lanchester_pair"][0]["order"] = 20
    assert "turning at 20×" in refused_at(data, "sampling.samples_per_rev")


def test_a_sweep_grid_across_zero_holds_zero():
    from harmbal.cli import _sweep_values

    def grid(text: str) -> list:
        values = _sweep_values("geometry.pin_offset", text)
        return list(values if isinstance(values, list) else values.values())  # (made lazily, after the budget)

    assert grid("-0.1 mm:0.1 mm:23")[11] == "0.0 mm"  # linspace gives 1.4e-17 mm, which the range refuses
    assert grid("-1e-4:1e-4:23")[11] == 0.0
    assert math.isclose(grid("0.3:0.5:3")[1], 0.4)



def test_with_speeds_holds_the_speeds_range():
    scene = hb.load_scene(ENGINES / "inline-4.toml")
    assert scene.with_speeds([1e-3, 1e5]).speeds == (1e-3, 1e5)
    for bad in ([1e300], [1e-4, 100.0]):
        with pytest.raises(ValueError, match=r"speeds must lie in \[1e-3, 1e5\] rad/s"):
            scene.with_speeds(bad)

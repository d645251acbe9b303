"""Reading [gas]: the effect's default, per-cylinder overrides, CSV traces and
every validation rule (one problem each, naming the key)."""

import math

import numpy as np
import pytest

import harmbal as hb
from harmbal.cli import main
from harmbal.scene import EFFECTS, SceneError
from harmbal.scene.schema import Combustion, PressureTrace

ANGLES = list(np.arange(0.0, 720.0, 10.0))


def pressures(angles=ANGLES):
    return [2.0 + math.cos(math.radians(a) / 2) for a in angles]


def combustion(**changes):
    table = {"compression_ratio": 17.5, "intake_pressure": "1.8 bar", "exhaust_pressure": "1.9 bar",
             "compression_exponent": 1.36, "expansion_exponent": 1.30, "start": "-8 deg", "duration": "70 deg",
             "shape": 2.0, "efficiency": 6.908, "peak_pressure": "116 bar"}
    table.update(changes)
    return {k: v for k, v in table.items() if v is not None}


@pytest.fixture(autouse=True)
def traces_may_lie_in_tmp_path(monkeypatch, tmp_path):
    """The scenes here are mappings (read relative to the working folder) naming trace files written to
    ``tmp_path``: allowed by the documented override (tests/test_safe_files.py tests the confinement)."""
    monkeypatch.setenv("HARMBAL_TRACE_ROOTS", str(tmp_path))


@pytest.fixture
def gas_scene(base_scene):
    base_scene["gas"] = {"bore": "86 mm", "trace": {"angle": ANGLES, "pressure": pressures(),
                                                    "units": {"angle": "deg", "pressure": "bar"}}}
    return base_scene


def all_problems(mapping):
    with pytest.raises(SceneError) as info:
        hb.load_scene(mapping)
    return info.value.problems


def only_problem(mapping):
    found = all_problems(mapping)
    assert len(found) == 1, [str(p) for p in found]
    return found[0]


def write_csv(tmp_path, text, name="trace.csv"):
    (tmp_path / name).write_text(text)
    return name


def csv_text(angles=ANGLES, header="angle [deg],pressure [bar]"):
    return "# synthetic\n" + header + "\n" + "".join(f"{a},{p}\n" for a, p in zip(angles, pressures(angles)))


# -- what loads -------------------------------------------------------------------


def test_inline_trace_is_read_in_si(gas_scene):
    scene = hb.load_scene(gas_scene)
    gas = scene.cylinders[0].gas
    assert gas.bore == pytest.approx(0.086) and gas.crankcase_pressure == 101325.0
    assert gas.piston_area == pytest.approx(math.pi * 0.086**2 / 4)
    assert isinstance(gas.trace, PressureTrace) and gas.trace.interpolation == "spline"
    assert gas.trace.angle[1] == pytest.approx(math.radians(10)) and gas.trace.pressure[0] == pytest.approx(3e5)
    assert scene.cylinders[1].gas == gas and hash(scene.cylinders[1].gas) == hash(gas)


def test_default_effects_add_gas_only_with_a_gas_table(gas_scene):
    # speed_fluctuation is off unless listed (it needs a [flywheel] too).
    assert hb.load_scene(gas_scene).model.effects == frozenset(EFFECTS) - {"speed_fluctuation"}
    del gas_scene["gas"]
    assert "gas" not in hb.load_scene(gas_scene).model.effects
    assert EFFECTS[-2:] == ("gas", "speed_fluctuation")


def test_gas_table_with_effects_without_gas_is_validated_but_off(gas_scene):
    gas_scene["model"] = {"effects": ["reciprocating"]}
    scene = hb.load_scene(gas_scene)
    assert scene.model.effects == {"reciprocating"} and scene.cylinders[0].gas is not None
    gas_scene["gas"]["bore"] = "-1 mm"
    assert only_problem(gas_scene).key == "gas.bore"


def test_gas_effect_without_gas_table_is_refused(base_scene):
    base_scene["model"] = {"effects": ["reciprocating", "gas"]}
    problem = only_problem(base_scene)
    assert problem.key == "model.effects" and "[gas]" in problem.rule


def test_cylinder_overrides_the_shared_gas_table(gas_scene, tmp_path):
    name = write_csv(tmp_path, csv_text())
    gas_scene["cylinder"][1]["gas"] = {"bore": "90 mm", "trace": {"file": str(tmp_path / name)}}
    first, second = (c.gas for c in hb.load_scene(gas_scene).cylinders)
    assert second.bore == pytest.approx(0.09) and first.bore == pytest.approx(0.086)
    assert second.trace.source == str(tmp_path / name)
    assert second.trace.pressure == pytest.approx(first.trace.pressure, rel=1e-15)
    gas_scene["cylinder"][1]["gas"] = {"combustion": combustion()}  # a parametric trace replaces the measured one
    assert isinstance(hb.load_scene(gas_scene).cylinders[1].gas.trace, Combustion)


def test_csv_trace_relative_to_the_scene_file(tmp_path):
    import tomli_w

    (tmp_path / "traces").mkdir()
    write_csv(tmp_path / "traces", csv_text())
    scene = {"engine": {"name": "s", "speed": "3000 rpm"},
             "geometry": {"crank_radius": "40 mm", "rod_length": "140 mm"},
             "piston": {"mass": "0.4 kg"},
             "rod": {"mass": "0.4 kg", "cg_from_big_end": "40 mm", "inertia": "0.001 kg m^2"},
             "cylinder": [{"throw": "0 deg"}], "gas": {"bore": "86 mm", "trace": {"file": "traces/trace.csv"}}}
    path = tmp_path / "engine.toml"
    path.write_text(tomli_w.dumps(scene))
    gas = hb.load_scene(path).cylinders[0].gas
    assert gas.trace.source == str(tmp_path / "traces" / "trace.csv")
    assert gas.trace.angle[-1] == pytest.approx(math.radians(710))


def test_table_with_its_endpoint_drops_it(gas_scene):
    angles = ANGLES + [720.0]
    gas_scene["gas"]["trace"].update(angle=angles, pressure=pressures(angles))
    assert len(hb.load_scene(gas_scene).cylinders[0].gas.trace.angle) == len(ANGLES)


def test_any_range_of_one_cycle_is_accepted(gas_scene):
    angles = [a - 360.0 for a in ANGLES]
    gas_scene["gas"]["trace"].update(angle=angles, pressure=pressures(angles))
    assert hb.load_scene(gas_scene).cylinders[0].gas.trace.angle[0] == pytest.approx(-2 * math.pi)


def test_two_stroke_cycle_is_360_degrees(gas_scene):
    gas_scene["engine"]["cycle"] = 2
    rule = only_problem(gas_scene).rule
    assert "longer than a cycle" in rule and "set engine.cycle = 4" in rule  # a 720° table: a four-stroke's
    angles = list(np.arange(0.0, 360.0, 10.0))
    gas_scene["gas"]["trace"].update(angle=angles, pressure=pressures(angles))
    assert len(hb.load_scene(gas_scene).cylinders[0].gas.trace.angle) == 36


def test_bundled_gas_datasets_load():
    from pathlib import Path

    root = Path(__file__).resolve().parent.parent / "datasets" / "engines"
    for path in sorted(root.glob("*-gas.toml")):
        scene = hb.load_scene(path)
        assert "gas" in scene.model.effects and all(c.gas is not None for c in scene.cylinders), path


# -- every rule -------------------------------------------------------------------------


def test_missing_csv_file_names_the_key_and_the_resolved_path(gas_scene, tmp_path):
    gas_scene["gas"]["trace"] = {"file": str(tmp_path / "nope.csv")}
    problem = only_problem(gas_scene)
    assert problem.key == "gas.trace.file" and str(tmp_path / "nope.csv") in problem.rule


@pytest.mark.parametrize("text, needle", [
    ("angle [deg],pressure [bar]\n0,1.0\n5,abc\n", "line 3"),
    ("angle [deg],pressure [bar]\n0,1.0,7\n", "line 2"),
])
def test_unreadable_csv_names_the_line(gas_scene, tmp_path, text, needle):
    gas_scene["gas"]["trace"] = {"file": str(tmp_path / write_csv(tmp_path, text))}
    problem = only_problem(gas_scene)
    assert problem.key == "gas.trace.file" and needle in problem.rule


def test_csv_without_units_in_its_header_takes_trace_units(gas_scene, tmp_path):
    path = tmp_path / write_csv(tmp_path, csv_text(header="angle,pressure"))
    gas_scene["gas"]["trace"] = {"file": str(path)}
    problems = all_problems(gas_scene)  # plain numbers in a table are refused, not taken as radians and Pa
    assert [p.key for p in problems] == ["gas.trace.file"] * 2
    for problem, column, header in zip(problems, ("column 1 'angle'", "column 2 'pressure'"),
                                       ('"angle [deg]"', '"pressure [bar]"')):
        assert str(path) in problem.rule and column in problem.rule and "no unit" in problem.rule
        assert header in problem.rule and "gas.trace.units." in problem.rule
    gas_scene["gas"]["trace"]["units"] = {"angle": "deg", "pressure": "bar"}
    assert hb.load_scene(gas_scene).cylinders[0].gas.trace.pressure[0] == pytest.approx(3e5)


def test_csv_header_units_contradicting_trace_units_are_refused(gas_scene, tmp_path):
    gas_scene["gas"]["trace"] = {"file": str(tmp_path / write_csv(tmp_path, csv_text())),
                                 "units": {"angle": "rad"}}
    assert "header" in only_problem(gas_scene).rule


@pytest.mark.parametrize("angles, values, key, needle", [
    (ANGLES[:5] + [35.0] + ANGLES[6:], None, "gas.trace.angle", "strictly increasing"),
    (ANGLES + [715.0, 730.0], None, "gas.trace.angle", "longer than a cycle"),
    (ANGLES[:60], None, "gas.trace.angle", "trace shorter than a cycle"),
    (ANGLES + [720.0], pressures(ANGLES) + [9.0], "gas.trace.pressure", "not periodic"),
    (ANGLES, [-1.0] + pressures(ANGLES)[1:], "gas.trace.pressure", "positive"),
    (ANGLES, [0.0] + pressures(ANGLES)[1:], "gas.trace.pressure", "positive"),
    (ANGLES[:7], None, "gas.trace.angle", "at least 8 points"),
    (ANGLES, pressures(ANGLES)[:-1], "gas.trace.pressure", "same length"),
    (ANGLES[:3] + ["x"] + ANGLES[4:], None, "gas.trace.angle", "list of numbers"),
])
def test_bad_tables(gas_scene, angles, values, key, needle):
    values = values if values is not None else pressures([a if isinstance(a, float) else 0.0 for a in angles])
    gas_scene["gas"]["trace"].update(angle=angles, pressure=values)
    problem = only_problem(gas_scene)
    assert (problem.key, needle in problem.rule) == (key, True), str(problem)


@pytest.mark.parametrize("edit, key, needle", [
    ({"units": {"angle": "furlong", "pressure": "bar"}}, "gas.trace.units.angle", "unknown units"),
    ({"units": {"angle": "deg", "pressure": "psi"}}, "gas.trace.units.pressure", "unknown units"),
    ({"units": {"angle": "deg", "pressure": "bar", "time": "s"}}, "gas.trace.units.time", "unknown key"),
    ({"interpolation": "linear"}, "gas.trace.interpolation", "must be one of"),
    ({"file": "x.csv"}, "gas.trace", "exactly one"),
    ({"smoothing": 1}, "gas.trace.smoothing", "unknown key"),
])
def test_bad_trace_keys(gas_scene, edit, key, needle):
    gas_scene["gas"]["trace"].update(edit)
    problem = only_problem(gas_scene)
    assert (problem.key, needle in problem.rule) == (key, True), str(problem)


@pytest.mark.parametrize("gas, key, needle", [
    ({"bore": "86 mm"}, "gas", "exactly one"),
    ({"bore": "86 mm", "trace": {"angle": ANGLES, "pressure": pressures()}, "combustion": combustion()}, "gas",
     "exactly one"),
    ({"trace": {"angle": ANGLES, "pressure": pressures(), "units": {"angle": "deg", "pressure": "bar"}}},
     "gas.bore", "missing"),
    ({"bore": "86 mm", "crankcase_pressure": "1 m", "combustion": combustion()}, "gas.crankcase_pressure",
     "has units m"),
    ({"bore": "86 mm", "combustion": combustion(imep="18 bar")}, "gas.combustion", "exactly one target"),
    ({"bore": "86 mm", "combustion": combustion(peak_pressure=None)}, "gas.combustion", "exactly one target"),
    ({"bore": "86 mm", "combustion": combustion(compression_ratio=1.0)}, "gas.combustion.compression_ratio",
     "must lie in (1, 100]"),
    ({"bore": "86 mm", "combustion": combustion(duration="0 deg")}, "gas.combustion.duration", "positive"),
    ({"bore": "86 mm", "combustion": combustion(duration="200 deg")}, "gas.combustion.duration", "between"),
    ({"bore": "86 mm", "combustion": combustion(expansion_exponent=0.9)}, "gas.combustion.expansion_exponent",
     "(1, 2)"),
    ({"bore": "86 mm", "combustion": combustion(intake_pressure="-1 bar")}, "gas.combustion.intake_pressure",
     "positive"),
    ({"bore": "86 mm", "combustion": combustion(start=-8)}, "gas.combustion.start", "looks like degrees"),
    ({"bore": "86 mm", "combustion": combustion(speed=1)}, "gas.combustion.speed", "unknown key"),
    ({"bore": "86 mm", "combustion": combustion(), "pressure": 1}, "gas.pressure", "unknown key"),
])
def test_bad_gas_tables(base_scene, gas, key, needle):
    base_scene["gas"] = gas
    problem = only_problem(base_scene)
    assert (problem.key, needle in problem.rule) == (key, True), str(problem)


def test_parametric_trace_needs_a_four_stroke(base_scene):
    base_scene["engine"]["cycle"] = 2
    base_scene["gas"] = {"bore": "86 mm", "combustion": combustion()}
    problem = only_problem(base_scene)
    assert problem.key == "gas.combustion" and "four-stroke" in problem.rule


def test_cylinder_override_problems_name_the_cylinder(gas_scene):
    gas_scene["cylinder"][1]["gas"] = {"trace": {"interpolation": "cubic"}}
    assert only_problem(gas_scene).key == "cylinder[2].gas.trace.interpolation"


def test_infeasible_target_names_the_key(base_scene):
    from harmbal.model.pressure import check_gas

    base_scene["gas"] = {"bore": "86 mm", "combustion": combustion(peak_pressure="20 bar")}
    scene = hb.load_scene(base_scene)  # the trace is built, and found infeasible, by the model
    with pytest.raises(SceneError) as info:
        check_gas(scene)
    assert {p.key for p in info.value.problems} == {"gas.combustion.peak_pressure"}
    assert all(p.source == "<mapping>" and "motored" in p.rule for p in info.value.problems)


def test_cli_run_with_missing_trace_file_exits_2_naming_the_key(tmp_path, gas_scene, capsys):
    import tomli_w

    gas_scene["gas"]["trace"] = {"file": "missing.csv"}
    path = tmp_path / "engine.toml"
    path.write_text(tomli_w.dumps(gas_scene))
    archive = tmp_path / "out.nc"
    assert main(["run", str(path), "-o", str(archive)]) == 2
    err = capsys.readouterr().err
    assert "gas.trace.file" in err and str(tmp_path / "missing.csv") in err
    assert not archive.exists()


# -- every number of a table has a declared unit, and a level a cylinder can have -------------------------------


def firing_bar(angles=ANGLES):
    """A firing four-stroke trace [bar]: 1 bar plus a combustion bump after firing TDC."""
    wrapped = (np.asarray(angles, float) + 360.0) % 720.0 - 360.0
    return 1.0 + 60.0 * np.exp(-((wrapped - 10.0) / 25.0) ** 2) + 8.0 * np.exp(-(wrapped / 60.0) ** 2)


def trace_csv(tmp_path, pressure_header, scale=1.0, name="trace.csv"):
    """The firing trace as a CSV file: its pressures in bar times ``scale`` under ``pressure_header``."""
    rows = [f"{float(a)!r},{float(p * scale)!r}" for a, p in zip(ANGLES, firing_bar())]
    path = tmp_path / name
    path.write_text("\n".join([f"angle [deg],{pressure_header}"] + rows) + "\n")
    return path


def test_bar_trace_under_a_bare_pressure_header_is_refused(gas_scene, tmp_path):
    """The reported bug: "angle [deg],pressure" with values in bar was read as pascals."""
    path = trace_csv(tmp_path, "pressure")
    gas_scene["gas"]["trace"] = {"file": str(path)}
    problem = only_problem(gas_scene)
    assert (problem.key, problem.value) == ("gas.trace.file", str(path))
    assert f"{path}, column 2 'pressure': no unit" in problem.rule
    assert 'write its header as "pressure [bar]"' in problem.rule
    assert 'set gas.trace.units.pressure = "bar"' in problem.rule


def test_bar_trace_declared_in_pascals_is_refused_naming_bar(gas_scene, tmp_path):
    path = trace_csv(tmp_path, "pressure [Pa]")
    gas_scene["gas"]["trace"] = {"file": str(path)}
    problem = only_problem(gas_scene)
    assert problem.key == "gas.trace.file" and f"{path}, column 2 'pressure [Pa]'" in problem.rule
    assert "whole trace lies at or below the crankcase pressure" in problem.rule
    assert "gas.crankcase_pressure" in problem.rule and "unit is likely wrong" in problem.rule
    assert f"in bar it would peak at {firing_bar().max():.6g} bar" in problem.rule
    assert 'write its header as "pressure [bar]"' in problem.rule


def test_header_units_bar_mpa_and_pa_give_the_same_loads(gas_scene, tmp_path):
    results = []
    for unit, scale in (("bar", 1.0), ("MPa", 0.1), ("Pa", 1e5)):
        gas_scene["gas"]["trace"] = {"file": str(trace_csv(tmp_path, f"pressure [{unit}]", scale, f"{unit}.csv"))}
        scene = hb.load_scene(gas_scene)
        results.append((np.array(scene.cylinders[0].gas.trace.pressure), hb.analyse(scene)))
    reference, tree = results[0]
    np.testing.assert_allclose(reference, firing_bar() * 1e5, rtol=1e-15)
    for pressure, other in results[1:]:
        np.testing.assert_allclose(pressure, reference, rtol=1e-12)
        for group, name in (("time", "force"), ("time", "moment"), ("torque", "gas_force"), ("torque", "gas_torque")):
            expected = tree[group].ds[name].values
            got = other[group].ds[name].values
            np.testing.assert_allclose(got, expected, rtol=0, atol=1e-12 * np.abs(expected).max(), err_msg=name)


def test_bare_inline_lists_are_refused(gas_scene):
    del gas_scene["gas"]["trace"]["units"]
    problems = all_problems(gas_scene)
    assert [p.key for p in problems] == ["gas.trace.angle", "gas.trace.pressure"]
    assert all(p.rule.startswith("no unit: set gas.trace.units.") for p in problems)
    gas_scene["gas"]["trace"]["units"] = {"angle": "deg"}
    problem = only_problem(gas_scene)
    assert problem.key == "gas.trace.pressure" and 'set gas.trace.units.pressure = "bar"' in problem.rule


def test_csv_without_a_header_line_is_refused_unless_units_are_given(gas_scene, tmp_path):
    path = tmp_path / write_csv(tmp_path, csv_text(header=""))
    gas_scene["gas"]["trace"] = {"file": str(path)}
    problems = all_problems(gas_scene)
    assert [p.key for p in problems] == ["gas.trace.file"] * 2
    assert all(str(path) in p.rule and "no header" in p.rule and '"angle [deg],pressure [bar]"' in p.rule
               for p in problems)
    gas_scene["gas"]["trace"]["units"] = {"angle": "deg", "pressure": "bar"}
    assert hb.load_scene(gas_scene).cylinders[0].gas.trace.pressure == pytest.approx(
        [p * 1e5 for p in pressures()], rel=1e-15)


def test_unknown_header_unit_names_the_column(gas_scene, tmp_path):
    path = trace_csv(tmp_path, "pressure [psi]")
    gas_scene["gas"]["trace"] = {"file": str(path)}
    problem = only_problem(gas_scene)
    assert problem.key == "gas.trace.file" and "column 2 'pressure [psi]': unknown units 'psi'" in problem.rule


def test_trace_wholly_below_the_crankcase_pressure_is_refused(gas_scene):
    gas_scene["gas"]["crankcase_pressure"] = f"{max(pressures()) + 1} bar"
    problem = only_problem(gas_scene)
    assert problem.key == "gas.trace.pressure" and problem.value == f"maximum {max(pressures()):.6g} bar"
    assert "the pressure list: the whole trace lies at or below the crankcase pressure" in problem.rule
    assert f"({max(pressures()) + 1:.6g} bar, gas.crankcase_pressure)" in problem.rule
    del gas_scene["gas"]["crankcase_pressure"]  # a cylinder's own crankcase pressure is named as its key
    gas_scene["cylinder"][1]["gas"] = {"crankcase_pressure": f"{max(pressures()) + 1} bar"}
    assert "cylinder[2].gas.crankcase_pressure" in only_problem(gas_scene).rule


@pytest.mark.parametrize("header, scale, crankcase, needle", [
    ("pressure [MPa]", 1.0, None, "above 500 bar"),  # bar values declared in MPa
    ("pressure [kPa]", 1.0, None, "at or below the crankcase pressure"),  # ... in kPa
    ("pressure [mbar]", 1.0, "0.01 bar", "below 1 bar absolute"),  # ... in mbar, over a low crankcase pressure
])
def test_peaks_no_cylinder_reaches_are_refused(gas_scene, tmp_path, header, scale, crankcase, needle):
    gas_scene["gas"]["trace"] = {"file": str(trace_csv(tmp_path, header, scale))}
    if crankcase:
        gas_scene["gas"]["crankcase_pressure"] = crankcase
    problem = only_problem(gas_scene)
    assert problem.key == "gas.trace.file" and needle in problem.rule
    assert f"in bar it would peak at {firing_bar().max():.6g} bar" in problem.rule


@pytest.mark.parametrize("header, scale", [("pressure [kPa]", 3.0), ("pressure [bar]", 6.0)])
def test_unusual_peaks_read_with_a_warning(gas_scene, tmp_path, header, scale):
    from harmbal.scene.read_gas import TraceWarning

    path = trace_csv(tmp_path, header, scale)
    gas_scene["gas"]["trace"] = {"file": str(path)}
    with pytest.warns(TraceWarning) as record:
        scene = hb.load_scene(gas_scene)
    assert len(record) == 1  # once, though both cylinders read the trace
    text = str(record[0].message)
    assert "gas.trace.file" in text and str(path) in text and "check its unit" in text
    expected = firing_bar() * scale * hb.scene.units.to_si(f"1 {header[10:-1]}", "pressure")
    np.testing.assert_allclose(scene.cylinders[0].gas.trace.pressure, expected, rtol=1e-15)


@pytest.mark.parametrize("last", [355.0, 360.0])
def test_one_revolution_trace_in_a_four_stroke_hints_at_the_cycle(gas_scene, last):
    angles = list(np.arange(0.0, last + 1.0, 5.0))
    gas_scene["gas"]["trace"].update(angle=angles, pressure=[2.0 + math.cos(math.radians(a)) for a in angles])
    problem = only_problem(gas_scene)
    assert problem.key == "gas.trace.angle" and "trace shorter than a cycle" in problem.rule
    assert "covers one revolution (360°): if the engine is a two-stroke, set engine.cycle = 2" in problem.rule
    gas_scene["engine"]["cycle"] = 2
    assert hb.load_scene(gas_scene).cylinders[0].gas.trace.angle[-1] == pytest.approx(math.radians(355))


@pytest.mark.parametrize("header", ["pressure", "pressure [Pa]"])
def test_cli_run_refuses_a_bar_trace_read_as_pascals(tmp_path, gas_scene, capsys, monkeypatch, header):
    import tomli_w

    monkeypatch.chdir(tmp_path)
    trace_csv(tmp_path, header)
    gas_scene["gas"]["trace"] = {"file": "trace.csv"}
    (tmp_path / "engine.toml").write_text(tomli_w.dumps(gas_scene))
    before = sorted(tmp_path.iterdir())
    assert main(["run", "engine.toml", "-o", "out.nc"]) == 2
    captured = capsys.readouterr()
    lines = captured.err.splitlines()
    assert len(lines) == 1 and lines[0].startswith("harmbal: error: engine.toml: gas.trace.file"), captured.err
    assert "trace.csv, column 2" in lines[0] and 'write its header as "pressure [bar]"' in lines[0]
    assert sorted(tmp_path.iterdir()) == before and captured.out == ""

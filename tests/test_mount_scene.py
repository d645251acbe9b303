"""Scene input of the powertrain and its mounts (issue 30, item 1): [powertrain],
[[mount]] and [mount_design] read into SI, each refusal naming the key and the
fix, and designed mounts written back as a scene that reads to their values."""

import dataclasses
import math
import tomllib
from pathlib import Path

import numpy as np
import pytest

import harmbal as hb
from harmbal.scene import SceneError, scene_from_text
from harmbal.scene.mounts import RigidPart
from harmbal.scene.read_mounts import combine_parts
from harmbal.scene.writer import mounts_scene_text

ENGINES = Path(__file__).resolve().parent.parent / "datasets" / "engines"

POWERTRAIN = {
    "mass": "480 kg", "cg": ["-40 mm", "0 mm", "180 mm"],
    "inertia": {"xx": "18 kg m^2", "yy": "42 kg m^2", "zz": "38 kg m^2", "xy": "0 kg m^2", "xz": "-2.1 kg m^2",
                "yz": "0 kg m^2"},
    "products": "tensor", "drive_torque": "420 N m",
}


def mount(name: str, x: str, y: str, **keys) -> dict:
    return {"name": name, "position": [x, y, "0 mm"], "stiffness": ["300 N/mm", "300 N/mm", "900 N/mm"], **keys}


def data(**tables) -> dict:
    """inline-4 on three mounts, with tables replaced (None removes one)."""
    scene = tomllib.loads((ENGINES / "inline-4.toml").read_text(encoding="utf-8"))
    scene.update(powertrain=dict(POWERTRAIN), mount=[mount("front left", "300 mm", "250 mm"),
                                                       mount("front right", "300 mm", "-250 mm"),
                                                       mount("rear", "-400 mm", "0 mm")])
    for key, value in tables.items():
        if value is None:
            scene.pop(key, None)
        else:
            scene[key] = value
    return scene


def refused(scene: dict) -> dict[str, str]:
    """{key: rule} of the problems of ``scene``."""
    with pytest.raises(SceneError) as info:
        hb.load_scene(scene)
    return {p.key: p.rule for p in info.value.problems}


def with_mount(index: int, **keys) -> dict:
    scene = data()
    scene["mount"][index].update(keys)
    return scene


# -- read into SI ----------------------------------------------------------------------------------

def test_the_spec_example_reads_into_si():
    scene = hb.load_scene(data())
    p = scene.powertrain
    assert p.mass == 480.0 and p.cg == (-0.04, 0.0, 0.18) and p.drive_torque == 420.0
    assert p.inertia == ((18.0, 0.0, -2.1), (0.0, 42.0, 0.0), (-2.1, 0.0, 38.0))
    assert p.gravity == (0.0, 0.0, -9.80665) and p.idle_speed is None and p.idle(scene.speeds) == min(scene.speeds)
    assert [m.name for m in scene.mounts] == ["front left", "front right", "rear"]
    first = scene.mounts[0]
    assert first.stiffness == (3e5, 3e5, 9e5) and first.axes == ((1, 0, 0), (0, 1, 0), (0, 0, 1))
    assert first.loss_factor == first.damping == (0, 0, 0) and first.preload_axis == "w" and first.table is None
    assert scene.mount_design is None
    assert hb.load_scene(ENGINES / "inline-4.toml").mounts == ()  # nothing asked, nothing read


def test_integral_products_change_sign():
    inertia = dict(POWERTRAIN["inertia"], xy="1 kg m^2")
    tensor = hb.load_scene(data(powertrain={**POWERTRAIN, "inertia": inertia})).powertrain.inertia
    integral = hb.load_scene(data(powertrain={**POWERTRAIN, "inertia": inertia,
                                              "products": "integral"})).powertrain.inertia
    assert tensor[0][1] == 1.0 and integral[0][1] == -1.0 and integral[0][2] == 2.1


def test_axes_from_any_two_are_right_handed_and_orthonormal():
    for axes in ({"u": [1, 0, 0], "w": [0, 0, 2]}, {"v": [0, 1, 1], "w": [0, -1, 1]}, {"u": [1, 1, 0], "v": [-1, 1, 0]},
                 {"u": [0, 0, 1], "v": [1, 0, 0], "w": [0, 1, 0]}):
        matrix = np.array(hb.load_scene(with_mount(0, axes=axes)).mounts[0].axes)
        assert np.allclose(matrix @ matrix.T, np.eye(3), rtol=0, atol=1e-14), axes  # scale: unit vectors
        assert math.isclose(np.linalg.det(matrix), 1.0, rel_tol=1e-14), axes
        for name, row in zip("uvw", matrix):
            if name in axes:
                given = np.array(axes[name], float)
                assert np.allclose(row, given / np.linalg.norm(given), rtol=0, atol=1e-14)  # scale: unit vectors


def test_loss_damping_and_table():
    table = {"frequency": ["5 Hz", "50 Hz", "200 Hz"],
             "stiffness": [["300 N/mm", "300 N/mm", "900 N/mm"], ["0.33 kN/mm", "330 N/mm", "1000 N/mm"],
                           ["400 N/mm", "400 N/mm", "1200 N/mm"]],
             "loss_factor": [0.1, [0.1, 0.2, 0.3], 0.2]}
    m = hb.load_scene(with_mount(1, loss_factor=[0.1, 0.1, 0.2], damping="150 N s/m", table=table,
                                 preload_axis="-w")).mounts[1]
    assert m.loss_factor == (0.1, 0.1, 0.2) and m.damping == (150.0,) * 3 and m.preload_axis == "-w"
    assert m.table.frequency == (5.0, 50.0, 200.0) and m.table.stiffness[1] == (3.3e5, 3.3e5, 1e6)
    assert m.table.loss_factor == ((0.1,) * 3, (0.1, 0.2, 0.3), (0.2,) * 3)
    del table["loss_factor"]
    assert hb.load_scene(with_mount(1, loss_factor=0.12, table=table)).mounts[1].table.loss_factor == ((0.12,) * 3,) * 3


def test_parts_build_the_totals_by_the_parallel_axis_theorem():
    block = {"name": "block", "mass": "300 kg", "cg": ["0 mm", "0 mm", "200 mm"],
             "inertia": {"xx": "10 kg m^2", "yy": "20 kg m^2", "zz": "20 kg m^2"}}
    box = {"name": "gearbox", "mass": "100 kg", "cg": ["-800 mm", "0 mm", "0 mm"]}  # a point mass
    p = hb.load_scene(data(powertrain={"part": [block, box]})).powertrain
    # by hand: m = 400 kg, c = (-0.2, 0, 0.15); block d = (0.2, 0, 0.05), gearbox d = (-0.6, 0, -0.15)
    assert p.mass == 400.0 and np.allclose(p.cg, (-0.2, 0.0, 0.15), rtol=0, atol=1e-14 * 0.8)  # parts 0.8 m apart
    expected = np.diag([10.0, 20.0, 20.0])
    for m, d in ((300.0, np.array([0.2, 0, 0.05])), (100.0, np.array([-0.6, 0, -0.15]))):
        expected += m * (d @ d * np.eye(3) - np.outer(d, d))
    assert np.allclose(p.inertia, expected, rtol=0, atol=1e-13 * np.abs(expected).max())
    assert [part.name for part in p.parts] == ["block", "gearbox"]
    single = combine_parts((RigidPart("a", 2.0, (1.0, 2.0, 3.0), ((1.0, 0, 0), (0, 1.0, 0), (0, 0, 1.0))),))
    assert single == (2.0, (1.0, 2.0, 3.0), ((1.0, 0, 0), (0, 1.0, 0), (0, 0, 1.0)))


def test_points_idle_gravity_and_design():
    powertrain = {**POWERTRAIN, "idle_speed": "750 rpm", "gravity": [0, "-9.81 m/s^2", 0],
                  "point": [{"name": "radiator", "position": ["500 mm", "0 mm", "600 mm"]}]}
    design = {"frequency_band": ["5 Hz", "16 Hz"], "max_static_roll": "3 deg", "max_tra_angle": "10 deg",
              "decoupling": 0, "variable": [
                  {"mount": "front left", "stiffness": "w", "bounds": ["100 N/mm", "1 kN/mm"], "group": "front"},
                  {"mount": "front right", "stiffness": "w", "bounds": ["100 N/mm", "1 kN/mm"], "group": "front"},
                  {"mount": "rear", "position": "x", "bounds": ["-450 mm", "-350 mm"]},
                  {"mount": "rear", "angle": "y", "bounds": ["-10 deg", "10 deg"]}]}
    scene = hb.load_scene(data(powertrain=powertrain, mount_design=design))
    assert scene.powertrain.idle_speed == pytest.approx(750 * math.pi / 30, rel=1e-15)
    assert scene.powertrain.gravity == (0.0, -9.81, 0.0) and scene.powertrain.points == (("radiator", (0.5, 0.0, 0.6)),)
    request = scene.mount_design
    assert request.decoupling is None and request.frequency_band == (5.0, 16.0) and request.objective == \
        "transmitted_force"
    assert [(v.mount, v.kind, v.axis, v.group) for v in request.variables] == [
        ("front left", "stiffness", 2, "front"), ("front right", "stiffness", 2, "front"),
        ("rear", "position", 0, None), ("rear", "angle", 1, None)]
    assert request.variables[0].lower == 1e5 and request.variables[3].upper == pytest.approx(math.pi / 18, rel=1e-15)


def test_a_powertrain_without_mounts_is_read_and_asks_for_nothing():
    scene = hb.load_scene(data(mount=None))
    assert scene.powertrain is not None and scene.mounts == ()


def test_units_of_the_new_dimensions():
    from harmbal.scene.units import QuantityError, to_si

    assert to_si("300 N/mm", "stiffness") == 3e5 and to_si("1.5 kN/mm", "stiffness") == 1.5e6
    assert to_si("200 N s/m", "damping") == 200.0 and to_si("-9.81 m/s^2", "acceleration") == -9.81
    assert to_si("16 Hz", "frequency") == 16.0 and to_si("50 1/s", "frequency") == 50.0
    with pytest.raises(QuantityError, match="Hz"):  # pint would give 2π·800/60 = 83.8 Hz
        to_si("800 rpm", "frequency")


# -- refused, naming the key and the fix ----------------------------------------------------------

REFUSALS = [
    ("mounts-without-powertrain", data(powertrain=None), "powertrain", "missing required table"),
    ("two-mounts", data(mount=[mount("a", "1 mm", "0 mm"), mount("b", "2 mm", "0 mm")]), "mount", "at least 3"),
    ("unknown-key", with_mount(0, stifness=["1 N/mm"] * 3), "mount[1].stifness", "did you mean 'stiffness'"),
    ("duplicate-names", with_mount(1, name="front left"), "mount", "unique"),
    ("totals-and-parts", data(powertrain={**POWERTRAIN, "part": [{"name": "b", "mass": "1 kg",
                                                                   "cg": [0, 0, 0]}]}), "powertrain", "not both"),
    ("products-unnamed", data(powertrain={k: v for k, v in POWERTRAIN.items() if k != "products"}),
     "powertrain.products", 'products = "tensor"'),
    ("triangle", data(powertrain={**POWERTRAIN, "inertia": {"xx": "90 kg m^2", "yy": "42 kg m^2", "zz": "38 kg m^2"}}),
     "powertrain.inertia.xx", "I_xx ≤ I_yy + I_zz"),
    ("not-definite", data(powertrain={**POWERTRAIN, "inertia": {**POWERTRAIN["inertia"], "xz": "30 kg m^2"}}),
     "powertrain.inertia", "not positive definite"),
    ("axes-oblique", with_mount(0, axes={"u": [1, 0, 0], "w": [0.01, 0, 1]}), "mount[1].axes", "not perpendicular"),
    ("axes-parallel", with_mount(0, axes={"u": [1, 0, 0], "w": [2, 0, 0]}), "mount[1].axes", "parallel"),
    ("axes-zero", with_mount(0, axes={"u": [0, 0, 0], "w": [0, 0, 1]}), "mount[1].axes.u", "zero vector"),
    ("axes-one", with_mount(0, axes={"u": [1, 0, 0]}), "mount[1].axes", "two of u, v, w"),
    ("axes-left-handed", with_mount(0, axes={"u": [1, 0, 0], "v": [0, 1, 0], "w": [0, 0, -1]}), "mount[1].axes",
     "right-handed"),
    ("stiffness-zero", with_mount(0, stiffness=[0, 0, 0]), "mount[1].stiffness", "positive"),
    ("stiffness-negative", with_mount(0, stiffness=["-1 N/mm", "1 N/mm", "1 N/mm"]), "mount[1].stiffness[1]",
     "negative"),
    ("stiffness-unit", with_mount(0, stiffness=["300 N", "1 N/mm", "1 N/mm"]), "mount[1].stiffness[1]", "[stiffness]"),
    ("loss-range", with_mount(0, loss_factor=5), "mount[1].loss_factor", "[0, 2]"),
    ("preload", with_mount(0, preload_axis="z"), "mount[1].preload_axis", "'-w'"),
    ("table-order", with_mount(0, table={"frequency": ["50 Hz", "5 Hz"], "stiffness": [[1, 1, 1], [1, 1, 1]]}),
     "mount[1].table.frequency", "increasing"),
    ("table-shape", with_mount(0, table={"frequency": ["5 Hz", "50 Hz"], "stiffness": [[1, 1, 1]]}),
     "mount[1].table.stiffness", "2 rows"),
    ("table-row", with_mount(0, table={"frequency": ["5 Hz", "50 Hz"], "stiffness": [[1, 1], [1, 1, 1]]}),
     "mount[1].table.stiffness[1]", "list of 3"),
    ("frequency-rpm", with_mount(0, table={"frequency": ["5 Hz", "800 rpm"], "stiffness": [[1, 1, 1], [1, 1, 1]]}),
     "mount[1].table.frequency[2]", "Hz"),
    ("design-unknown-mount", data(mount_design={"variable": [{"mount": "front lef", "stiffness": "w",
                                                              "bounds": ["1 N/mm", "1000 N/mm"]}]}),
     "mount_design.variable[1].mount", "did you mean 'front left'"),
    ("design-bounds-order", data(mount_design={"variable": [{"mount": "rear", "stiffness": "w",
                                                             "bounds": ["1000 N/mm", "1 N/mm"]}]}),
     "mount_design.variable[1].bounds", "lower < upper"),
    ("design-nominal-outside", data(mount_design={"variable": [{"mount": "rear", "stiffness": "w",
                                                                "bounds": ["1 N/mm", "500 N/mm"]}]}),
     "mount_design.variable[1].bounds", "900 N/mm, lies outside the bounds"),
    ("design-angle-outside", data(mount_design={"variable": [{"mount": "rear", "angle": "z",
                                                              "bounds": ["5 deg", "10 deg"]}]}),
     "mount_design.variable[1].bounds", "relative to the axes"),
    ("design-group-kinds", data(mount_design={"variable": [
        {"mount": "rear", "stiffness": "w", "bounds": ["1 N/mm", "1000 N/mm"], "group": "g"},
        {"mount": "rear", "position": "x", "bounds": ["-1 m", "1 m"], "group": "g"}]}),
     "mount_design.variable", "one kind"),
    ("design-two-kinds", data(mount_design={"variable": [{"mount": "rear", "stiffness": "w", "position": "x",
                                                          "bounds": ["1 N/mm", "1000 N/mm"]}]}),
     "mount_design.variable[1]", "give one of"),
    ("design-no-variables", data(mount_design={"decoupling": 0.8}), "mount_design.variable", "at least one"),
    ("design-without-mounts", data(mount=None, mount_design={"variable": []}), "mount_design", "[[mount]]"),
    ("design-decoupling", data(mount_design={"decoupling": 1.5, "variable": []}), "mount_design.decoupling",
     "[0, 1]"),
    ("design-band", data(mount_design={"frequency_band": ["16 Hz", "5 Hz"], "variable": []}),
     "mount_design.frequency_band", "low < high"),
]


@pytest.mark.parametrize("scene, key, text", [r[1:] for r in REFUSALS], ids=[r[0] for r in REFUSALS])
def test_refusals_name_the_key_and_the_fix(scene, key, text):
    problems = refused(scene)
    assert key in problems, problems
    assert text in problems[key], problems[key]


def test_every_problem_is_reported_at_once():
    scene = with_mount(0, stiffness=[0, 0, 0], preload_axis="z")
    scene["mount"][2]["axes"] = {"u": [1, 0, 0]}
    assert {"mount[1].stiffness", "mount[1].preload_axis", "mount[3].axes"} <= set(refused(scene))


# -- written back ----------------------------------------------------------------------------------

@pytest.mark.parametrize("form", ["text", "mapping"])
def test_designed_mounts_are_written_back_and_read_to_their_values(form):
    from harmbal.scene.writer import toml_tables

    raw = data(mount_design={"variable": [{"mount": "rear", "stiffness": "w", "bounds": ["1 N/mm", "1000 N/mm"]}]})
    if form == "text":  # a scene file as people write it (values inline, comments): edited in place
        added = {k: raw.pop(k) for k in ("powertrain", "mount", "mount_design")}
        base = (ENGINES / "inline-4.toml").read_text(encoding="utf-8")
        scene = scene_from_text(base + "\n# the mounts\n" + toml_tables(added), "engine.toml")
    else:  # its text is a plain dump (arrays over several lines): written as a plain dump
        scene = hb.load_scene(raw)
    c, s = math.cos(0.3), math.sin(0.3)
    turn = np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])
    new = [dataclasses.replace(scene.mounts[0], stiffness=(123456.789, 3.3e5, 7.654321e5),
                               position=(0.3123456789, 0.25, -1e-3)),
           dataclasses.replace(scene.mounts[2], axes=tuple(map(tuple, np.array(scene.mounts[2].axes) @ turn.T)))]
    text = mounts_scene_text(scene, new, name="inline-4 on designed mounts")
    again = scene_from_text(text)
    assert again.name == "inline-4 on designed mounts" and again.mount_design is None
    for given, read in zip(new, (again.mounts[0], again.mounts[2])):
        for field in ("position", "axes", "stiffness"):
            a, b = np.array(getattr(given, field)), np.array(getattr(read, field))
            assert np.allclose(a, b, rtol=0, atol=1e-12 * np.abs(a).max()), field
    assert again.mounts[1] == scene.mounts[1] and again.powertrain == scene.powertrain
    assert "N/mm" in text and ("# was" in text) == (form == "text")  # readable units; edited in place
    if form == "text":
        assert text.startswith((ENGINES / "inline-4.toml").read_text(encoding="utf-8").split("name =")[0])
    with pytest.raises(ValueError, match="not in the scene"):
        mounts_scene_text(scene, [dataclasses.replace(scene.mounts[0], name="nowhere")])

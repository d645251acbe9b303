"""Clearance over a revolution: closed-form minimum distances of parts on
known paths, exact polygon distances, collisions, invariance under a shift
of the angle origin, and the [[outline]] validation."""

import math

import numpy as np
import pytest

import harmbal as hb
from harmbal.model.clearance import signed_distance
from harmbal.scene import SceneError, scene_from_text

R_CRANK, L_ROD, E_PIN = 0.06, 0.215, 0.0005


def _engine(rotation="clockwise", throw="0 deg", shafts=""):
    return f"""
[engine]
name = "clearance"
cycle = 4
rotation = "{rotation}"
speed = "2300 rpm"
[geometry]
crank_radius = "{R_CRANK * 1e3} mm"
rod_length = "{L_ROD * 1e3} mm"
pin_offset = "{E_PIN * 1e3} mm"
[piston]
mass = "2.229 kg"
[rod]
mass = "2.726 kg"
cg_from_big_end = "72.255 mm"
inertia = "26131 kg mm^2"
[[cylinder]]
label = "1"
throw = "{throw}"
axial_position = "86 mm"
{shafts}"""


def _outline(part, body, kind, **keys):
    lines = [f'[[outline]]\npart = "{part}"\nbody = "{body}"\nkind = "{kind}"']
    for key, value in keys.items():
        lines.append(f"{key} = {value!r}".replace("'", '"'))
    return "\n".join(lines) + "\n"


def _mm(*values):
    return [f"{v * 1e3!r} mm" for v in values]


def test_circle_on_the_crank_against_a_fixed_circle():
    # A circle at radius R on the crank (at angle a in the crank frame) and a fixed circle at distance d
    # (angle b in the cylinder frame): min distance |d − R| − r1 − r2 when the crank angle is b − a.
    radius, a, d, b, r1, r2 = 0.085, 0.4, 0.16, 2.2, 0.01, 0.03
    text = _engine() + _outline("weight", "crank", "circle", centre=_mm(radius * math.cos(a), radius * math.sin(a)),
                                radius=f"{r1 * 1e3} mm")
    text += _outline("stud", "block", "circle", centre=_mm(d * math.cos(b), d * math.sin(b)), radius=f"{r2 * 1e3} mm")
    ds = hb.clearance(scene_from_text(text))
    assert float(ds.min_distance[0]) == pytest.approx(abs(d - radius) - r1 - r2, rel=1e-12)
    assert float(ds.angle[0]) == pytest.approx(b - a, abs=1e-6)
    assert not bool(ds.collision[0])
    assert list(ds.part_a.values) == ["weight"] and list(ds.part_b.values) == ["stud"]


@pytest.mark.parametrize("rotation, sense", [("clockwise", -1), ("counterclockwise", 1)])
def test_balance_shaft_weight_against_a_fixed_circle(rotation, sense):
    # Shaft axis at y = 70 mm; in the cylinder frame its axis is at n = −sense·y (n is 90° ahead of
    # the cylinder axis in the direction of rotation). A fixed circle 100 mm further out along n.
    shafts = '[[balance_shaft]]\nlabel = "shaft"\nratio = -1\naxis_position = ["70 mm", "0 mm"]\n'
    n_fixed = -sense * 0.17
    text = _engine(rotation, shafts=shafts) + _outline("weight", "shaft", "sector", radius="30 mm",
                                                       half_angle="60 deg")
    text += _outline("boss", "block", "circle", centre=_mm(0.0, n_fixed), radius="20 mm")
    ds = hb.clearance(scene_from_text(text))
    # The sector's arc (radius 30 mm) comes within 100 − 30 − 20 mm of the boss; its circumscribed
    # polygon stands out by at most 10 µm.
    assert float(ds.min_distance[0]) == pytest.approx(0.05, abs=1.1e-5)
    assert float(ds.min_distance[0]) <= 0.05


def _head(height):
    return _outline("head", "block", "polygon", vertices=[_mm(height, -0.1), _mm(height, 0.1)])


def test_piston_rectangle_against_a_fixed_line():
    # The piston pin's highest point: crank and rod in line, c_B = √((l + r)² − e²), at sin ψ = e/(l + r).
    top, width = 0.03, 0.07  # crown 30 + 35 mm above the pin
    text = _engine() + _outline("piston", "piston", "rectangle", centre=_mm(top, 0.0), width=f"{width * 1e3} mm",
                                height="104 mm") + _head(0.36)
    ds = hb.clearance(scene_from_text(text))
    highest = math.sqrt((L_ROD + R_CRANK) ** 2 - E_PIN**2) + top + width / 2
    assert float(ds.min_distance[0]) == pytest.approx(0.36 - highest, rel=1e-12)
    assert float(ds.angle[0]) == pytest.approx(math.asin(E_PIN / (L_ROD + R_CRANK)), abs=1e-6)


def test_collision_is_reported_with_both_part_names():
    text = _engine() + _outline("piston", "piston", "rectangle", centre=_mm(0.03, 0.0), width="70 mm",
                                height="104 mm") + _head(0.33)
    text += _outline("big end", "rod", "circle", radius="45 mm")
    ds = hb.clearance(scene_from_text(text))
    hit = ds.sel(pair="piston / head")
    highest = math.sqrt((L_ROD + R_CRANK) ** 2 - E_PIN**2) + 0.065
    assert bool(hit.collision) and float(hit.min_distance) == pytest.approx(0.33 - highest, rel=1e-12)
    assert (str(hit.part_a.values), str(hit.part_b.values)) == ("piston", "head")
    assert set(ds.pair.values) == {"piston / head", "piston / big end", "head / big end"}


def test_invariance_under_a_shift_of_the_angle_origin():
    parts = (_outline("counterweight", "crank", "sector", radius="95 mm", half_angle="80 deg", direction="180 deg")
             + _outline("big end", "rod", "polygon", vertices=[_mm(-0.045, -0.04), _mm(0.03, -0.04), _mm(0.03, 0.04),
                                                               _mm(-0.045, 0.04)], radius="5 mm")
             + _outline("skirt", "piston", "rectangle", centre=_mm(-0.04, 0.0), width="70 mm", height="104 mm")
             + _outline("liner", "block", "polygon", vertices=[_mm(0.09, 0.056), _mm(0.3, 0.056)]))
    base = hb.clearance(scene_from_text(_engine() + parts))
    shift = math.radians(40)
    shifted = hb.clearance(scene_from_text(_engine(throw="40 deg") + parts))
    np.testing.assert_allclose(shifted.min_distance, base.min_distance, rtol=0, atol=1e-12)  # scale: 0.1 m
    diff = np.angle(np.exp(1j * (shifted.angle.values + shift - base.angle.values)))
    # The skirt slides along the liner at a constant distance: no angle is special, both report 0.
    constant = base.pair.values == "skirt / liner"
    assert float(base.angle[constant][0]) == float(shifted.angle[constant][0]) == 0
    np.testing.assert_array_less(np.abs(diff[~constant]), 1e-6)


def test_signed_distance_of_polygons():
    square = np.array([0, 1, 1 + 1j, 1j])
    # Separated corner to corner: √2 · 0.5.
    other = square + (1.5 + 1.5j)
    assert signed_distance(square, 0.0, other, 0.0) == pytest.approx(math.sqrt(0.5), rel=1e-15)
    # Overlapping by 0.25 along x: minus the penetration depth.
    assert signed_distance(square, 0.0, square + 0.75, 0.0) == pytest.approx(-0.25, rel=1e-15)
    # A point inside, 0.2 from the nearest side, grown to a circle of radius 0.1.
    assert signed_distance(square, 0.0, np.array([0.2 + 0.5j]), 0.1) == pytest.approx(-0.3, rel=1e-15)
    # Two crossing bars and two bars in line with a gap.
    cross = signed_distance(np.array([0, 2]), 0.0, np.array([1 - 1j, 1 + 1j]), 0.0)
    assert cross <= 0
    assert signed_distance(np.array([0, 1]), 0.0, np.array([3, 4]), 0.0) == pytest.approx(2, rel=1e-15)
    # Vectorised over leading (angle) axes.
    many = np.stack([square, square + 2])
    np.testing.assert_allclose(signed_distance(many, 0.0, other[None, :], 0.0), [math.sqrt(0.5), 0.5],
                               atol=1e-15)  # scale: 1 (unit squares)


@pytest.mark.parametrize("entry, key, rule", [
    (_outline("a", "flywheel", "circle", radius="5 mm"), "outline[1].body", "must be one of"),
    (_outline("a", "block", "polygon", vertices=[_mm(0, 0), _mm(1, 0), _mm(0.2, 0.2), _mm(0, 1)]),
     "outline[1].vertices", "convex"),
    (_outline("a", "crank", "sector", radius="5 mm", half_angle="120 deg"), "outline[1].half_angle", "90°"),
    (_outline("a", "crank", "circle", radius="5 mm", width="3 mm"), "outline[1].width", "not a key"),
    (_outline("a", "crank", "circle", radius="5 mm", cylinder=2), "outline[1].cylinder", "cylinder number"),
    (_outline("a", "crank", "circle", radius="5 mm") + _outline("a", "rod", "circle", radius="5 mm"), "outline",
     "unique"),
    (_outline("a", "crank", "hexagon", radius="5 mm"), "outline[1].kind", "must be one of"),
])
def test_outline_validation_names_file_and_key(entry, key, rule):
    with pytest.raises(SceneError) as info:
        scene_from_text(_engine() + entry, "engine.toml")
    assert any(p.source == "engine.toml" and p.key == key and rule in p.rule for p in info.value.problems), \
        str(info.value)


def test_parts_apart_along_the_crank_axis_are_not_paired():
    text = _engine() + _outline("weight", "crank", "circle", radius="10 mm", axial_range=_mm(0.04, 0.07))
    text += _outline("big end", "rod", "circle", radius="40 mm", axial_range=_mm(0.071, 0.101))
    text += _outline("skirt", "piston", "rectangle", width="60 mm", height="100 mm", axial_range=_mm(0.03, 0.14))
    ds = hb.clearance(scene_from_text(text))
    assert list(ds.pair.values) == ["weight / skirt", "big end / skirt"]
    with pytest.raises(SceneError, match=r"outline\[1\].axial_range.*x_min < x_max"):
        scene_from_text(_engine() + _outline("w", "crank", "circle", radius="1 mm", axial_range=_mm(0.07, 0.04)))


def test_the_bundled_example_designs_its_blanks_and_clears():
    from pathlib import Path

    path = Path(__file__).resolve().parent.parent / "datasets" / "examples" / "test-single-shapes.toml"
    scene = hb.load_scene(path)
    ds = hb.clearance(scene)
    assert ds.sizes["pair"] == 20 and not bool(ds.collision.any())
    # The counterweights' bottom dead centre check against the skirt (docs/shapes.md quotes it).
    assert float(ds.min_distance.sel(pair="counterweight 1 / skirt, right")) == pytest.approx(0.0252082, abs=1e-7)
    design = hb.design(scene)
    assert "counterweight 2: blank sized, strip (shape 1) far = 81.0296 mm" in design.dataset.attrs["blanks"]
    assert "first-order balance shafts: blank sized, sector (shape 1) outer_radius = 76.6727 mm" in \
        design.dataset.attrs["blanks"]
    assert design.feasible and bool(hb.verify(design.scene).passed.all())
    from harmbal.reporting.tables import design_table

    printed = design_table(design).split("Blanks sized to these unbalances")[1]
    assert all(line in printed for line in design.dataset.attrs["blanks"].splitlines())


def test_no_outlines_no_pairs_and_the_sampling_is_checked():
    scene = scene_from_text(_engine())
    ds = hb.clearance(scene)
    assert ds.sizes["pair"] == 0 and ds.part_a.dtype.kind == "U"
    with pytest.raises(ValueError, match="at least 8"):
        hb.clearance(scene, samples=4)


def _twin(bank2, throw2):
    return _engine().replace('''[[cylinder]]
label = "1"
throw = "0 deg"
axial_position = "86 mm"''', f'''[[cylinder]]
label = "front"
axial_position = "0 mm"
[[cylinder]]
label = "rear"
throw = "{throw2} deg"
bank = "{bank2} deg"
axial_position = "100 mm"''')


@pytest.mark.parametrize("bank2, throw2", [(0, 180), (90, 0), (60, 300)])
def test_parts_of_different_cylinders_meet_in_the_engine_frame(bank2, throw2):
    # A circle on the crank given in the rear cylinder's crank frame (angle a) against a stud given in the
    # front cylinder's block frame (angle b; that cylinder is upright): the closed form of the first test with
    # the rear throw's angle: they line up at θ = b − a − throw₂. A stud given in the rear cylinder's block
    # frame (angle b from its axis) is at b + bank₂ in the engine, met at θ = b + bank₂ − a − throw₂.
    radius, a, d, b, r1, r2 = 0.085, 0.4, 0.16, 2.2, 0.01, 0.03
    x = _mm(0.04, 0.06)
    text = _twin(bank2, throw2) + _outline("weight", "crank", "circle", cylinder=2, axial_range=x,
                                           centre=_mm(radius * math.cos(a), radius * math.sin(a)), radius="10 mm")
    text += _outline("stud front", "block", "circle", cylinder=1, axial_range=x,
                     centre=_mm(d * math.cos(b), d * math.sin(b)), radius="30 mm")
    text += _outline("stud rear", "block", "circle", cylinder="rear", axial_range=_mm(0.05, 0.2),
                     centre=_mm(d * math.cos(b), d * math.sin(b)), radius="30 mm")
    text += _outline("rod front", "rod", "circle", cylinder=1, radius="40 mm")  # no axial range: its own plane
    text += _outline("rod rear", "rod", "circle", cylinder=2, radius="40 mm")
    ds = hb.clearance(scene_from_text(text))
    # Without an axial range a part meets only the parts of its own cylinder's plane.
    assert set(ds.pair.values) == {"weight / stud front", "weight / stud rear", "weight / rod rear",
                                   "stud front / rod front", "stud rear / rod rear"}
    expected = abs(d - radius) - r1 - r2
    throw, bank = math.radians(throw2), math.radians(bank2)
    for pair, angle in (("weight / stud front", b - a - throw), ("weight / stud rear", b + bank - a - throw)):
        hit = ds.sel(pair=pair)
        assert float(hit.min_distance) == pytest.approx(expected, rel=1e-12)
        assert abs(np.angle(np.exp(1j * (float(hit.angle) - angle)))) < 1e-6
    rear = ds.sel(pair="weight / stud rear")
    assert (str(rear.cylinder_a.values), str(rear.cylinder_b.values)) == ("rear", "rear")


def test_rods_of_two_cylinders_are_two_bodies():
    # Fork-and-blade style: both rods' big ends on one pin at the same axial range overlap: a collision.
    text = _twin(90, 0) + _outline("big end front", "rod", "circle", cylinder=1, radius="40 mm",
                                   axial_range=_mm(0.0, 0.03))
    text += _outline("big end rear", "rod", "circle", cylinder=2, radius="40 mm", axial_range=_mm(0.02, 0.05))
    text += _outline("web", "crank", "circle", cylinder=1, radius="5 mm", axial_range=_mm(0.0, 0.05))
    text += _outline("web rear", "crank", "circle", cylinder=2, radius="5 mm", axial_range=_mm(0.0, 0.05))
    ds = hb.clearance(scene_from_text(text))
    hit = ds.sel(pair="big end front / big end rear")
    # Two throws at 0° on crank pins 100 mm apart axially share no pin here: the big ends sit on their own
    # pins, both at radius 60 mm and angle θ + 0: concentric, overlapping by 80 mm.
    assert bool(hit.collision) and float(hit.min_distance) == pytest.approx(-0.08, abs=1e-12)  # scale: 0.08 m
    assert "web / web rear" not in set(ds.pair.values)  # one crank


def _colliding_scene_file(tmp_path):
    text = _engine() + _outline("piston", "piston", "rectangle", centre=_mm(0.03, 0.0), width="70 mm",
                                height="104 mm") + _head(0.33) + _outline("big end", "rod", "circle", radius="45 mm")
    path = tmp_path / "collide.toml"
    path.write_text(text, encoding="utf-8")
    return path


def test_cli_loads_prints_the_clearance_collisions_first_and_archives_it(tmp_path, capsys):
    from harmbal.cli import main

    path = _colliding_scene_file(tmp_path)
    expected = hb.clearance(hb.load_scene(path))
    assert main(["loads", str(path), "-o", str(tmp_path / "out.nc")]) in (0, None)
    out = capsys.readouterr().out
    table = out.split("clearance between moving parts")[1].split("\n\n")[0]
    rows = [line.split() for line in table.splitlines()[2:]]
    assert rows[0][-1] == "COLLISION" and rows[0][:3] == ["piston", "/", "head"]
    assert all(row[-1] == "clear" for row in rows[1:]) and len(rows) == expected.sizes["pair"]
    assert float(rows[0][-3]) == pytest.approx(float(expected.sel(pair="piston / head").min_distance) * 1e3, abs=5e-5)
    archived = hb.open_archive(tmp_path / "out.nc")
    np.testing.assert_array_equal(archived["clearance"].ds.min_distance.values, expected.min_distance.values)


def test_analyse_and_the_report_carry_the_clearance(tmp_path):
    path = _colliding_scene_file(tmp_path)
    tree = hb.analyse(hb.load_scene(path))
    expected = hb.clearance(hb.load_scene(path))
    np.testing.assert_array_equal(tree["clearance"].ds.min_distance.values, expected.min_distance.values)
    html = hb.report(tree)
    section = html[html.index('<section id="clearance">'):]
    section = section[: section.index("</section>")]
    assert "1 of 3 pairs collide" in section
    assert section.index("piston / head") < section.index("piston / big end")
    assert f"{float(expected.sel(pair='piston / head').min_distance) * 1e3:.4f} mm" in section
    # Without outlines there is neither a group nor a section.
    plain = hb.analyse(scene_from_text(_engine()))
    assert "clearance" not in plain.children and '<section id="clearance">' not in hb.report(plain)

"""Counterweight blanks: closed-form mass properties against polygon
integration written here, composites, invariances, the sizing solver, the
thesis's fastener loads, and the scene / design integration."""

import cmath
import math
import subprocess
import sys

import numpy as np
import pytest

import harmbal as hb
from harmbal.balance.counterweights import size_blank, unbalance_range
from harmbal.balance.solvers import DesignError
from harmbal.scene import SceneError, scene_from_text
from harmbal.scene.shapes import Blank, Box, Disc, PointMass, Sector, Segment, Strip, area_moments

# ---------------------------------------------------------------------------
# The oracle: shoelace area and first moment of a polygon, with the arcs of
# each shape sampled uniformly; the error of such a polygon is a series in
# even powers of the arc step, so two Richardson steps over N, 2N, 4N leave
# O(N⁻⁶). Nothing here uses harmbal's formulas.


def _shoelace(points):
    """Area and first moment (S_u, S_v) of a simple polygon, counterclockwise."""
    p = np.asarray(points)
    x, y = p.real, p.imag
    xn, yn = np.roll(x, -1), np.roll(y, -1)
    cross = x * yn - xn * y
    return (math.fsum(cross) / 2, math.fsum((x + xn) * cross) / 6, math.fsum((y + yn) * cross) / 6)


def _arc(radius, start, end, n, centre=0j):
    return centre + radius * np.exp(1j * np.linspace(start, end, n + 1))


def _richardson(polygon, n=2000):
    """Polygon integrals of ``polygon(n)`` extrapolated to n → ∞."""
    a, b, c = (np.array(_shoelace(polygon(k))) for k in (n, 2 * n, 4 * n))
    first, second = (4 * b - a) / 3, (4 * c - b) / 3
    return (16 * second - first) / 15


def _sector_polygon(r_out, r_in, half):
    def polygon(n):
        outer = _arc(r_out, -half, half, n)
        inner = _arc(r_in, half, -half, n) if r_in > 0 else np.array([0j])
        return np.concatenate([outer, inner])
    return polygon


def _segment_polygon(radius, chord):
    beta = math.acos(chord / radius)
    return lambda n: _arc(radius, -beta, beta, n)  # the chord closes the polygon


def _strip_polygon(radius, near, far):
    b_near, b_far = math.acos(near / radius), math.acos(far / radius)
    return lambda n: np.concatenate([_arc(radius, b_far, b_near, n), _arc(radius, -b_near, -b_far, n)])


def _moved(polygon, direction, centre):
    return lambda n: centre + cmath.exp(1j * direction) * polygon(n)


CASES = [
    (Sector(0.09, 0.7), _sector_polygon(0.09, 0.0, 0.7)),
    (Sector(0.09, 1.2, inner_radius=0.03), _sector_polygon(0.09, 0.03, 1.2)),
    (Sector(0.08, math.pi / 2), _sector_polygon(0.08, 0.0, math.pi / 2)),  # half-disc
    (Sector(0.08, 2.6, inner_radius=0.02), _sector_polygon(0.08, 0.02, 2.6)),  # wider than a half-disc
    (Segment(0.095, 0.04), _segment_polygon(0.095, 0.04)),
    (Segment(0.095, -0.03), _segment_polygon(0.095, -0.03)),
    (Strip(0.095, 0.0, 0.06), _strip_polygon(0.095, 0.0, 0.06)),
    (Strip(0.095, -0.02, 0.07), _strip_polygon(0.095, -0.02, 0.07)),
    (Sector(0.07, 0.5, 0.01, direction=2.0, centre=(0.01, -0.02)),
     _moved(_sector_polygon(0.07, 0.01, 0.5), 2.0, complex(0.01, -0.02))),
    (Segment(0.05, 0.01, direction=-1.0, centre=(-0.03, 0.04)),
     _moved(_segment_polygon(0.05, 0.01), -1.0, complex(-0.03, 0.04))),
    (Disc(0.012, centre=(0.03, 0.01)), lambda n: _arc(0.012, 0, 2 * math.pi, n)[:-1] + complex(0.03, 0.01)),
]


@pytest.mark.parametrize("shape, polygon", CASES, ids=[f"{c[0].kind}{i}" for i, c in enumerate(CASES)])
def test_area_and_centroid_against_polygon_integration(shape, polygon):
    area, s_u, s_v = area_moments(shape)
    ref_area, ref_u, ref_v = _richardson(polygon)
    scale = math.sqrt(area) * area  # first moments are in m³
    assert area == pytest.approx(ref_area, rel=1e-12, abs=0)
    assert abs(s_u - ref_u) <= 1e-12 * scale and abs(s_v - ref_v) <= 1e-12 * scale


def test_box_is_its_corners():
    box = Box(0.04, 0.02, direction=0.3, centre=(0.05, -0.01))
    corners = complex(0.05, -0.01) + cmath.exp(0.3j) * np.array([0.02 - 0.01j, 0.02 + 0.01j, -0.02 + 0.01j,
                                                                  -0.02 - 0.01j])
    assert np.allclose(area_moments(box), _shoelace(corners), rtol=1e-14, atol=0)


# ---------------------------------------------------------------------------
# Composites


def _blank(parts, density=7850.0, thickness=0.025):
    return Blank(density, thickness, tuple(parts))


def test_composite_is_the_sum_of_its_parts_and_holes_subtract():
    parts = [Strip(0.095, 0.0, 0.07), Disc(0.009, centre=(0.03, 0.0), hole=True),
             Box(0.02, 0.01, centre=(0.0, 0.05), thickness=0.01), PointMass(0.04, 0.03, 0.2)]
    blank = _blank(parts)
    expected_mass = 0.0
    expected_moment = 0j
    for part in parts:
        if isinstance(part, PointMass):
            expected_mass += part.mass
            expected_moment += part.mass * part.radius * cmath.exp(1j * part.angle)
            continue
        area, s_u, s_v = area_moments(part)
        factor = 7850.0 * (part.thickness or 0.025) * (-1 if part.hole else 1)
        expected_mass += factor * area
        expected_moment += factor * complex(s_u, s_v)
    assert blank.mass == pytest.approx(expected_mass, rel=1e-14)
    assert abs(blank.moment - expected_moment) <= 1e-14 * abs(expected_moment)
    assert blank.unbalance == pytest.approx(blank.mass * math.hypot(*blank.centroid), rel=1e-14)
    assert blank.centroid_radius == pytest.approx(math.hypot(*blank.centroid), rel=1e-14)
    # A hole and the same shape as a part cancel exactly.
    disc = Disc(0.01, centre=(0.02, 0.03))
    with_hole = _blank([Sector(0.08, 1.0), disc, Disc(0.01, centre=(0.02, 0.03), hole=True)])
    assert with_hole.mass == pytest.approx(_blank([Sector(0.08, 1.0)]).mass, rel=1e-15)


def test_half_disc_split_into_two_quarters_and_a_strip_plus_segment():
    half = _blank([Sector(0.08, math.pi / 2)])
    quarters = _blank([Sector(0.08, math.pi / 4, direction=math.pi / 4), Sector(0.08, math.pi / 4,
                                                                                direction=-math.pi / 4)])
    pieces = _blank([Strip(0.08, 0.0, 0.05), Segment(0.08, 0.05)])
    for other in (quarters, pieces):
        assert other.mass == pytest.approx(half.mass, rel=1e-14)
        assert abs(other.moment - half.moment) <= 1e-14 * abs(half.moment)
    # Textbook: a half-disc's centroid is 4R/(3π) from its diameter.
    assert half.centroid_radius == pytest.approx(4 * 0.08 / (3 * math.pi), rel=1e-15)


def _turned(parts, angle, mirror=False):
    out = []
    for p in parts:
        if isinstance(p, PointMass):
            a = -p.angle if mirror else p.angle
            out.append(PointMass(p.mass, p.radius, a + angle))
            continue
        c = complex(*p.centre)
        c = (c.conjugate() if mirror else c) * cmath.exp(1j * angle)
        d = -p.direction if mirror else p.direction
        out.append(type(p)(**{**p.__dict__, "direction": d + angle, "centre": (c.real, c.imag)}))
    return out


def test_rotation_and_mirror_invariance():
    parts = [Sector(0.09, 0.8, 0.02, direction=0.3), Segment(0.06, 0.02, direction=-0.4, centre=(0.01, 0.0)),
             Disc(0.008, centre=(0.04, 0.01), hole=True), PointMass(0.05, 0.03, 0.5)]
    blank = _blank(parts)
    turned = _blank(_turned(parts, 1.1))
    mirrored = _blank(_turned(parts, 0.0, mirror=True))
    assert turned.mass == pytest.approx(blank.mass, rel=1e-14)
    assert abs(turned.moment - blank.moment * cmath.exp(1.1j)) <= 1e-14 * blank.unbalance
    assert mirrored.mass == pytest.approx(blank.mass, rel=1e-14)
    assert abs(mirrored.moment - blank.moment.conjugate()) <= 1e-14 * blank.unbalance


# ---------------------------------------------------------------------------
# Sizing


@pytest.mark.parametrize("parts, solve, bounds", [
    ([Strip(0.095, 0.0, 0.06), Disc(0.009, centre=(0.025, 0.0), hole=True)], (0, "far"), None),
    ([Segment(0.095, 0.02), PointMass(0.04, 0.03)], (0, "chord"), None),
    ([Sector(0.09, 1.0, 0.02)], (0, "outer_radius"), (0.03, 0.15)),
    ([Sector(0.09, 1.0, 0.02)], (0, "half_angle"), (0.05, math.pi / 2)),
])
def test_sizing_round_trip(parts, solve, bounds):
    blank = _blank(parts)
    truth = blank.dimension(solve)
    target = blank.unbalance
    start = blank.with_dimension({"far": 0.03, "chord": 0.05, "outer_radius": 0.05, "half_angle": 0.3}[solve[1]],
                                 solve)
    sized = size_blank(start, target, solve, bounds)
    assert sized.value == pytest.approx(truth, rel=1e-12)
    assert sized.unbalance == pytest.approx(target, rel=1e-12)
    assert sized.mass == pytest.approx(blank.mass, rel=1e-12)
    assert sized.radius == pytest.approx(target / blank.mass, rel=1e-12)


def test_sizing_picks_the_lightest_of_several_roots():
    # A sector's unbalance (2/3)·sin α·(R³ − ρ³) rises to α = 90° and falls after: two roots.
    blank = _blank([Sector(0.09, 0.5)])
    sized = size_blank(blank, blank.unbalance, (0, "half_angle"))
    assert sized.value == pytest.approx(0.5, rel=1e-12)


def test_infeasible_target_is_reported_in_words_with_the_range():
    blank = Blank(7850.0, 0.025, (Strip(0.095, 0.0, 0.06),), solve=(0, "far"))
    low, high = unbalance_range(blank)
    exact_high = 7850 * 0.025 * 2 / 3 * 0.095**3  # the half-disc: far = radius
    assert high == pytest.approx(exact_high, rel=1e-12) and low == pytest.approx(0, abs=1e-12 * exact_high)
    with pytest.raises(DesignError, match=r"gives the unbalance 200 kg mm: this blank gives 0 to "
                                          rf"{exact_high * 1e3:.6g} kg mm; make it thicker"):
        size_blank(blank, 0.2)
    with pytest.raises(ValueError, match="no natural upper bound"):
        size_blank(Blank(7850.0, 0.025, (Disc(0.01, centre=(0.02, 0)),)), 0.01, (0, "radius"))


def test_fastener_loads_of_the_single_cylinder_thesis():
    # Thesis B: F_h = ½·m·ω²·x at ω = 241 s⁻¹, two bolts per blank.
    assert hb.fastener_load(2.174 * 0.0507, 241.0, 2) == pytest.approx(3201, abs=0.5)
    assert hb.fastener_load(3.399 * 0.0325, 241.0, 2) == pytest.approx(3208, abs=0.5)
    blank = _blank([Strip(0.095, 0.0, 0.06)])
    assert hb.fastener_load(blank, 241.0, 2) == pytest.approx(blank.unbalance * 241.0**2 / 2, rel=1e-15)


# ---------------------------------------------------------------------------
# Scenes


ENGINE = """
[engine]
name = "cw"
cycle = 4
speed = "2300 rpm"
[geometry]
crank_radius = "60 mm"
rod_length = "215 mm"
[piston]
mass = "2.229 kg"
[rod]
mass = "2.726 kg"
cg_from_big_end = "72.255 mm"
inertia = "26131 kg mm^2"
[[cylinder]]
label = "1"
axial_position = "86 mm"
"""

BLANK = """
[[counterweight]]
label = "cw"
angle = "180 deg"
axial_position = "55 mm"
density = "7.85 g/cm^3"
thickness = "25 mm"
[[counterweight.shape]]
kind = "strip"
radius = "95 mm"
far = "60 mm"
[[counterweight.shape]]
kind = "circle"
radius = "9 mm"
centre = ["25 mm", "5 mm"]
hole = true
[[counterweight.shape]]
kind = "fastener"
mass = "0.04 kg"
radius = "25 mm"
angle = "-30 deg"
"""


def test_scene_counterweight_from_a_blank():
    shaft = scene_from_text(ENGINE + BLANK).shafts[0]
    # By hand: strip = half-disc minus the segment beyond 60 mm (closed forms written out here).
    rho_t = 7850 * 0.025
    r, c = 0.095, 0.06
    strip = complex(2 / 3 * r**3 - 2 / 3 * (r * r - c * c) ** 1.5, 0)
    hole = math.pi * 0.009**2 * complex(0.025, 0.005)
    moment = rho_t * (strip - hole) + 0.04 * 0.025 * cmath.exp(-1j * math.radians(30))
    (u,) = shaft.unbalances
    assert u.unbalance == pytest.approx(abs(moment), rel=1e-14)
    assert cmath.exp(1j * u.angle) == pytest.approx(cmath.exp(1j * (math.pi + cmath.phase(moment))),
                                                    abs=1e-14)  # scale: 1 (unit phasors)
    assert u.x == pytest.approx(0.055)


@pytest.mark.parametrize("edit, key, rule", [
    (lambda t: t.replace('density = "7.85 g/cm^3"\n', ""), "counterweight[1].density", "missing"),
    (lambda t: t.replace('label = "cw"', 'label = "cw"\nunbalance = "0.1 kg m"'), "counterweight[1]",
     "not both"),
    (lambda t: t.replace('kind = "strip"', 'kind = "triangle"'), "counterweight[1].shape[1].kind",
     "must be one of"),
    (lambda t: t.replace('far = "60 mm"', 'far = "120 mm"'), "counterweight[1].shape[1]", "near < far"),
    (lambda t: t.replace('far = "60 mm"', 'far = "60 mm"\nsolve = "far"'), "counterweight[1].shape[1].solve",
     "only in a [[design.counterweights]]"),
    (lambda t: t.replace('hole = true', 'hole = "yes"'), "counterweight[1].shape[2].hole", "true or false"),
    (lambda t: t.replace('radius = "9 mm"', 'radius = "90 mm"'), "counterweight[1]", "mass must be positive"),
    (lambda t: t.replace('density = "7.85 g/cm^3"', 'density = "7.85 g"'), "counterweight[1].density", ""),
    (lambda t: t[:t.index("[[counterweight.shape]]")] + "shape = []\n", "counterweight[1].shape", "at least one"),
])
def test_blank_validation_names_file_and_key(edit, key, rule):
    with pytest.raises(SceneError) as info:
        scene_from_text(edit(ENGINE + BLANK), "engine.toml")
    assert any(p.source == "engine.toml" and p.key == key and rule in p.rule for p in info.value.problems), \
        str(info.value)


def test_cli_refuses_a_bad_blank_with_exit_2(tmp_path):
    path = tmp_path / "bad.toml"
    path.write_text(ENGINE + BLANK.replace('kind = "strip"', 'kind = "triangle"'), encoding="utf-8")
    run = subprocess.run([sys.executable, "-m", "harmbal", "run", str(path)], capture_output=True, text=True)
    assert run.returncode == 2
    assert "counterweight[1].shape[1].kind" in run.stderr and str(path) in run.stderr


DESIGN = """
[design]
orders = [1]
cancel = ["force"]

[[design.counterweights]]
label = "counterweight"
planes = ["86 mm"]
balance_factor = 0.5
density = "7850 kg/m^3"
thickness = "50 mm"
[[design.counterweights.shape]]
kind = "segment"
radius = "95 mm"
solve = "chord"
[[design.counterweights.shape]]
kind = "circle"
radius = "8 mm"
centre = ["40 mm", "0 mm"]
hole = true
"""


def test_design_writes_the_sized_blank(tmp_path):
    scene = scene_from_text(ENGINE + DESIGN, str(tmp_path / "engine.toml"))
    design = hb.design(scene)
    (element,) = design.elements
    (u,) = element.unbalances
    wanted = design.dataset.unbalance.values[0]
    assert u.unbalance == pytest.approx(wanted, rel=1e-12)
    assert math.cos(u.angle - design.dataset.unbalance_angle.values[0]) == pytest.approx(
        1, abs=1e-13)  # scale: 1 (a cosine)
    assert '[[counterweight.shape]]\nkind = "segment"' in design.text and "chord = " in design.text
    assert "counterweight: blank sized, segment (shape 1) chord = " in design.dataset.attrs["blanks"]
    assert hb.verify(design.scene).passed.all()


def test_design_blank_needs_one_free_dimension():
    with pytest.raises(SceneError, match=r"design.counterweights\[1\].shape.*exactly one shape"):
        scene_from_text(ENGINE + DESIGN.replace('solve = "chord"', 'chord = "10 mm"'))


def test_design_infeasible_blank_names_the_counterweight():
    scene = scene_from_text(ENGINE + DESIGN.replace('"50 mm"', '"1 mm"'))
    with pytest.raises(DesignError, match=r"^counterweight: no segment chord in \[-95 mm, 95 mm\] gives"):
        hb.design(scene)


def test_cli_design_writes_the_sized_blank_or_nothing(tmp_path):
    good, bad = tmp_path / "good.toml", tmp_path / "bad.toml"
    good.write_text(ENGINE + DESIGN, encoding="utf-8")
    bad.write_text(ENGINE + DESIGN.replace('"50 mm"', '"1 mm"'), encoding="utf-8")
    out = tmp_path / "designed.toml"
    # (balance factor 0.5 leaves the counter-rotating force: --partial writes the design anyway)
    run = subprocess.run([sys.executable, "-m", "harmbal", "design", str(good), "-o", str(out), "--partial"],
                         capture_output=True, text=True)
    assert run.returncode == 0, run.stderr
    written = out.read_text(encoding="utf-8")
    assert "#   counterweight: blank sized, segment (shape 1) chord = " in written
    assert hb.load_scene(out).shafts[0].unbalances[0].unbalance == pytest.approx(
        hb.design(scene_from_text(ENGINE + DESIGN)).dataset.unbalance.values[0], rel=1e-12)
    out.unlink()
    run = subprocess.run([sys.executable, "-m", "harmbal", "design", str(bad), "-o", str(out)], capture_output=True,
                         text=True)
    assert run.returncode == 2 and "counterweight: no segment chord" in run.stderr and not out.exists()


def test_the_documented_blank():
    # docs/shapes.md: the blank of datasets/examples/test-single-shapes.toml with its cut at 70 mm.
    blank = hb.Blank(7850.0, 0.030, (hb.Strip(0.095, 0.0, 0.07), hb.Disc(0.009, centre=(0.025, 0.0), hole=True),
                                     hb.PointMass(0.04, 0.025, math.radians(30)),
                                     hb.PointMass(0.04, 0.025, math.radians(-30))), solve=(0, "far"))
    assert (round(blank.mass, 4), round(blank.centroid_radius * 1e3, 2), round(blank.unbalance, 6)) == \
        (2.8395, 32.84, 0.093247)
    assert hb.unbalance_range(blank) == pytest.approx((0.233865e-3, 134.842e-3), rel=1e-5)
    sized = hb.size_blank(blank, 0.11569506063699182)  # the 117 mm plane's unbalance
    assert round(hb.fastener_load(sized.blank, 241.0, 2)) == 3360


SHAFT = """
[[balance_shaft]]
label = "shaft"
ratio = -1
axis_position = ["70 mm", "0 mm"]
[[balance_shaft.unbalance]]
angle = "90 deg"
axial_position = "86 mm"
density = "7850 kg/m^3"
thickness = "40 mm"
[[balance_shaft.unbalance.shape]]
kind = "half_disc"
radius = "50 mm"
direction = "20 deg"
[[balance_shaft.unbalance]]
unbalance = "0.01 kg m"
axial_position = "10 mm"

[[lanchester_pair]]
label = "pair"
order = 2
angle = "10 deg"
phase = "5 deg"
density = "7850 kg/m^3"
thickness = "20 mm"
[[lanchester_pair.shape]]
kind = "sector"
start_angle = "-30 deg"
end_angle = "60 deg"
outer_radius = "40 mm"
"""


def test_balance_shaft_and_lanchester_weights_from_blanks():
    shafts = {s.label: s for s in scene_from_text(ENGINE + SHAFT).shafts}
    weight, plain = shafts["shaft"].unbalances
    half_disc = 7850 * 0.04 * 2 / 3 * 0.05**3  # ⅔R³ per unit thickness and density
    assert weight.unbalance == pytest.approx(half_disc, rel=1e-14)
    assert weight.angle == pytest.approx(math.radians(110), rel=1e-14) and weight.x == pytest.approx(0.086)
    assert plain.unbalance == 0.01
    sector = 7850 * 0.02 * 2 / 3 * math.sin(math.radians(45)) * 0.04**3  # half-angle 45°, axis at 15°
    plus, minus = shafts["pair (+2×)"], shafts["pair (−2×)"]
    assert plus.unbalances[0].unbalance == pytest.approx(sector, rel=1e-14)
    assert plus.unbalances[0].angle == pytest.approx(math.radians(10 + 15 + 5), rel=1e-14)
    assert minus.unbalances[0].angle == pytest.approx(math.radians(10 + 15 - 5), rel=1e-14)
    with pytest.raises(SceneError, match=r"balance_shaft\[1\].unbalance\[2\] = .*not both"):
        scene_from_text(ENGINE + SHAFT.replace('unbalance = "0.01 kg m"',
                                               'unbalance = "0.01 kg m"\nthickness = "1 mm"'))


SHAFT_DESIGN = """
[design]
orders = [1]
cancel = ["force", "moment"]

[[design.counterweights]]
label = "counterweight"
planes = ["55 mm", "117 mm"]
balance_factor = 0.5

[[design.balance_shaft]]
label = "left shaft"
ratio = -1
axis_position = ["70 mm", "0 mm"]
planes = ["86 mm"]
density = "7850 kg/m^3"
thickness = "40 mm"
[[design.balance_shaft.shape]]
kind = "half_disc"
solve = "radius"
solve_range = ["10 mm", "100 mm"]

[[design.lanchester_pair]]
label = "pair"
order = 2
axial_position = "86 mm"
lateral = ["70 mm", "-70 mm"]
density = "7850 kg/m^3"
thickness = "20 mm"
[[design.lanchester_pair.shape]]
kind = "sector"
outer_radius = "40 mm"
solve = "half_angle"
[[design.lanchester_pair.shape]]
kind = "fastener"
mass = "0.01 kg"
radius = "20 mm"
angle = "10 deg"
"""


def test_shafts_and_pairs_are_written_as_sized_blanks():
    # One −1× shaft cancels the counter-rotating first-order force (not its moment: a plane too few),
    # the pair the second order; every designed unbalance is written as a blank that loads back equal.
    design = hb.design(scene_from_text(ENGINE + SHAFT_DESIGN.replace('cancel = ["force", "moment"]',
                                                                     'cancel = ["force"]\norders = [1, 2]')
                                       .replace("orders = [1]\n", "")))
    names = list(design.dataset.element.values)
    wanted = dict(zip(names, design.dataset.unbalance.values))
    written = {s.label: s for s in design.elements}
    assert written["left shaft"].unbalances[0].unbalance == pytest.approx(wanted["left shaft (−1×) at x = 86 mm"],
                                                                        rel=1e-12)
    for side in ("+", "−"):
        assert written[f"pair ({side}2×)"].unbalances[0].unbalance == pytest.approx(wanted[f"pair ({side}2×)"],
                                                                                 rel=1e-12)
    blanks = design.dataset.attrs["blanks"]
    # docs/shapes.md quotes this shaft weight.
    assert ("left shaft at x = 86 mm: blank sized, sector (shape 1) outer_radius = 76.6726 mm; mass 2.89955 kg, "
            "centre of mass at 32.5409 mm") in blanks
    assert "pair: blank sized, sector (shape 1) half_angle = " in blanks
    assert "[[balance_shaft.unbalance.shape]]" in design.text and "[[lanchester_pair.shape]]" in design.text
    assert bool(hb.verify(design.scene).passed.all())


def test_a_sizing_that_does_not_converge_is_refused_not_raised(monkeypatch):
    """Brent's method on a bracketed root converges in ~60 steps; should it
    not within its limit, sizing refuses with a DesignError (issue 32)."""
    import scipy.optimize

    real = scipy.optimize.brentq
    monkeypatch.setattr(scipy.optimize, "brentq", lambda *a, **k: real(*a, **{**k, "maxiter": 2}))
    blank = _blank([Sector(0.09, 0.5)])
    with pytest.raises(DesignError, match="did not converge"):
        size_blank(blank, blank.unbalance, (0, "half_angle"))

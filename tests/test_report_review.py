"""The top of the report and its design-review figures.

Oracles: the analysis Datasets and their classes (which orders the headline
shows, the values before and after the balancers, the one-line summary of
the others), the exact model (the unbalances "to remove what remains" are
added to the scene as balance shafts and the component they size must
vanish: read back from the page at the digits shown, and at full precision
from harmbal.reporting.review), the lever's closure (the mechanism sketch's
links keep their lengths) and the figures' own artists (stars drawn once,
negligible loci not drawn).
"""

import math
import re
from html.parser import HTMLParser
from pathlib import Path

import numpy as np
import pytest

import harmbal as hb
from harmbal.orders.spectrum import FREE, ZERO
from harmbal.reporting import review
from harmbal.scene import scene_from_text

ENGINES = Path(__file__).resolve().parent.parent / "datasets" / "engines"


class _Headline(HTMLParser):
    """The headline table's rows (cell texts; the remedy cell's lines) and the summary's paragraphs."""

    def __init__(self):
        super().__init__()
        self.rows, self.paragraphs, self.engine = [], [], None
        self._in_table = self._in_summary = False
        self._cell = self._paragraph = None

    def handle_starttag(self, tag, attrs):
        attrs = dict(attrs)
        if tag == "section":
            self._in_summary = attrs.get("id") == "summary"
        elif tag == "table" and attrs.get("class") == "headline":
            self._in_table = True
        elif self._in_table and tag == "tr":
            self.rows.append([])
        elif self._in_table and tag in ("td", "th"):
            self._cell = {"text": "", "lines": [], "class": attrs.get("class", "")}
        elif self._in_table and tag == "div" and self._cell is not None:
            self._cell["lines"].append("")
        elif self._in_summary and tag == "p" and not self._in_table:
            self._paragraph = {"class": attrs.get("class", ""), "text": ""}

    def handle_endtag(self, tag):
        if tag == "table":
            self._in_table = False
        elif tag in ("td", "th") and self._cell is not None:
            self.rows[-1].append(self._cell)
            self._cell = None
        elif tag == "p" and self._paragraph is not None:
            self.paragraphs.append(self._paragraph)
            self._paragraph = None

    def handle_data(self, data):
        if self._cell is not None:
            self._cell["text"] += data
            if self._cell["lines"]:
                self._cell["lines"][-1] += data
        if self._paragraph is not None:
            self._paragraph["text"] += data


def headline(html_text: str) -> _Headline:
    parser = _Headline()
    parser.feed(html_text)
    return parser


def _scene(name: str, rotation: str | None = None, reference_x: str | None = None):
    text = (ENGINES / f"{name}.toml").read_text(encoding="utf-8")
    if rotation:
        text = text.replace('rotation = "clockwise"', f'rotation = "{rotation}"')
    if reference_x:
        text = re.sub(r'reference_point = \["0 mm"', f'reference_point = ["{reference_x}"', text)
    return scene_from_text(text, f"{name}.toml")


def _first(ds):
    return ds.isel(speed=0) if "speed" in ds.dims else ds


@pytest.fixture(scope="module")
def reports():
    """Scene, tree and page of the engines the tests read."""
    out = {}
    for key, scene in {"single": _scene("single"), "tractor": _scene("tractor-3cyl"),
                       "tractor-ccw": _scene("tractor-3cyl", "counterclockwise", "30 mm"),
                       "balanced": _scene("tractor-3cyl-balanced"), "v8": _scene("v8-cross-plane")}.items():
        tree = hb.analyse(scene)
        out[key] = (scene, tree, hb.report(tree))
    return out


def _order_rows(page: _Headline) -> dict[float, list]:
    """Headline rows per order: one (as built) or two (without, with)."""
    rows, current = {}, None
    for row in page.rows[1:]:
        if row[0].get("class", "") == "" and re.fullmatch(r"[\d.]+", row[0]["text"].strip()):
            current = float(row[0]["text"])
            rows[current] = [row[1:]]
        else:
            rows[current].append(row)
    return rows


def _row_values(orders, i: int) -> list[complex]:
    """The headline's five components of order index ``i``: F co, F counter, M co, M counter, roll."""
    return [*orders["force_rotating"].values[i], *orders["moment_rotating"].values[i], orders["moment"].values[i, 0]]


def _components(cells: list) -> list[str]:
    """The five component cells of a row (after the balancers cell, if any), before the remedy."""
    return [c["text"] for c in cells[-6:-1]]


@pytest.mark.parametrize("key", ["single", "tractor", "v8", "balanced"])
def test_headline_shows_exactly_the_orders_with_a_free_component(reports, key):
    scene, tree, text = reports[key]
    orders = _first(tree["orders"].ds)
    free = set()
    for i, k in enumerate(orders["order"].values):
        codes = list(orders["force_class"].values[i]) + list(orders["moment_class"].values[i])
        if k > 0 and (FREE in codes or int(np.atleast_1d(orders["roll_class"].values)[i]) == FREE):
            free.add(float(k))
    if key == "balanced":  # and what the balancers removed: free without them, judged by the same levels
        bare = _first(hb.analyse(scene.with_effects(scene.model.effects - {"balancers"}))["orders"].ds)
        for i, k in enumerate(bare["order"].values):
            values = _row_values(bare, i)
            levels = [orders[f"{q}_negligible_level"].values for q in ("force", "force", "moment", "moment", "roll")]
            if k > 0 and any(abs(v) > level for v, level in zip(values, levels)):
                free.add(float(k))
    assert set(_order_rows(headline(text))) == free


@pytest.mark.parametrize("key", ["single", "v8", "balanced"])
def test_headline_values_are_the_orders_dataset(reports, key):
    scene, tree, text = reports[key]
    orders = _first(tree["orders"].ds)
    level = {"force": float(orders["force_negligible_level"]), "moment": float(orders["moment_negligible_level"]),
             "roll": float(orders["roll_negligible_level"])}
    for k, rows in _order_rows(headline(text)).items():
        i = list(orders["order"].values).index(k)
        want = _row_values(orders, i)
        kinds = ["force", "force", "moment", "moment", "roll"]
        for cell, value, kind in zip(_components(rows[-1]), want, kinds):
            if cell in ("0", "~0"):
                assert abs(value) <= level[kind]
            else:
                assert float(cell) == pytest.approx(abs(value), rel=5e-4) and abs(value) > level[kind]


def test_without_the_balancers_is_the_engine_without_its_elements(reports):
    scene, tree, text = reports["balanced"]
    bare = _first(hb.analyse(scene.with_effects(scene.model.effects - {"balancers"}))["orders"].ds)
    rows = _order_rows(headline(text))
    assert all(len(r) == 2 and r[0][0]["text"] == "without" and r[1][0]["text"] == "with" for r in rows.values())
    for k, (without, _) in rows.items():
        i = list(bare["order"].values).index(k)
        want = _row_values(bare, i)
        for cell, value in zip(_components(without), want):
            if cell not in ("0", "~0"):
                assert float(cell) == pytest.approx(abs(value), rel=5e-4)
            else:
                assert abs(value) <= float(tree["orders"].ds["moment_negligible_level"]) or abs(value) <= float(
                    tree["orders"].ds["force_negligible_level"])


def test_the_other_orders_are_in_one_line(reports):
    scene, tree, text = reports["tractor"]
    orders = _first(tree["orders"].ds)
    shown = set(_order_rows(headline(text)))
    line = next(p["text"] for p in headline(text).paragraphs if "negligible (every component" in p["text"])
    listed = set()
    for part in re.findall(r"Orders? ([\d–, ]+):", line):
        for piece in part.split(","):
            a, _, b = piece.strip().partition("–")
            listed |= set(range(int(a), int(b or a) + 1))
    assert listed == {int(k) for k in orders["order"].values if k > 0} - {int(k) for k in shown}


def _elements(lines: list[str], order: int) -> str:
    """[[balance_shaft]] tables for the remedy lines of one order, read from the page."""
    out = []
    for n, line in enumerate(lines):
        m = re.match(r"– ([+−])(\d+)×: ([\d.e+-]+) kg mm at ([\d.]+)° \(x = ([−\d.e+-]+) mm\)"
                     r"(?: and at ([\d.]+)° \(x = ([−\d.e+-]+) mm\))?$", line)
        if not m:
            continue
        sign, k, u, a1, x1, a2, x2 = m.groups()
        assert int(k) == order
        planes = [(a1, x1)] + ([(a2, x2)] if a2 else [])
        out.append(f'[[balance_shaft]]\nlabel = "remedy {order}-{n}"\nratio = {"" if sign == "+" else "-"}{k}\n'
                   + "".join(f'[[balance_shaft.unbalance]]\nunbalance = "{u} kg mm"\nangle = "{a} deg"\n'
                             f'axial_position = "{x.replace("−", "-")} mm"\n' for a, x in planes))
    return "\n".join(out)


@pytest.mark.parametrize("key", ["single", "tractor", "tractor-ccw", "v8"])
def test_the_sizes_shown_remove_what_remains_in_the_exact_model(reports, key):
    scene, tree, text = reports[key]
    orders = _first(tree["orders"].ds)
    for k, rows in _order_rows(headline(text)).items():
        lines = rows[-1][-1]["lines"]
        added = _elements(lines, int(k))
        if not added:
            assert all(line == "roll: the mounts" for line in lines)
            continue
        fixed = _first(hb.analyse(scene_from_text(scene.source_text + "\n" + added, "fixed.toml"))["orders"].ds)
        i = list(orders["order"].values).index(k)
        for name in ("force", "moment"):
            for j in range(2):
                was = abs(orders[f"{name}_rotating"].values[i, j])
                if int(orders[f"{name}_class"].values[i, j]) == FREE:
                    # Four digits and 0.1° on the page: what is left is at most a few thousandths.
                    assert abs(fixed[f"{name}_rotating"].values[i, j]) <= 3e-3 * was, (k, name, j)


@pytest.mark.parametrize("key", ["single", "tractor-ccw", "v8"])
def test_the_sizes_at_full_precision_leave_round_off(reports, key):
    scene, tree, _ = reports[key]
    orders = _first(tree["orders"].ds)
    found = [r for loads in review.order_loads(orders)
             for r in review.removals(loads, scene.speeds[0], scene.sense, scene.reference_point[0],
                                      review.couple_spacing(scene))]
    assert found
    tables = []
    for n, r in enumerate(found):
        planes = ([(r.angle, r.x)] if r.spacing is None
                  else [(r.angle, r.x + r.spacing / 2), (r.angle + math.pi, r.x - r.spacing / 2)])
        tables.append(f'[[balance_shaft]]\nlabel = "r{n}"\nratio = {r.order if r.rotation == "co" else -r.order}\n'
                      + "".join(f'[[balance_shaft.unbalance]]\nunbalance = {r.unbalance!r}\nangle = {a!r}\n'
                                f"axial_position = {x!r}\n" for a, x in planes))
    fixed = _first(hb.analyse(scene_from_text(scene.source_text + "\n" + "\n".join(tables), "f.toml"))["orders"].ds)
    for r in found:
        i, j = list(fixed["order"].values).index(r.order), ("co", "counter").index(r.rotation)
        assert int(fixed[f"{r.quantity}_class"].values[i, j]) == ZERO, r


def test_engine_line_names_the_layout(reports):
    assert headline(reports["v8"][2]).paragraphs[0]["text"].startswith("8 cylinders in a 90° V, four-stroke, 3000 and "
                                                                         "6000 rpm")
    assert headline(reports["single"][2]).paragraphs[0]["text"].startswith("A single cylinder, four-stroke")
    assert headline(reports["tractor"][2]).paragraphs[0]["text"].startswith("3 cylinders inline")


def test_order_ranges():
    assert review.order_ranges([5, 6, 7, 8, 10, 12]) == "5–8, 10, 12"
    assert review.order_ranges([1, 2, 4]) == "1, 2, 4"
    assert review.order_ranges([0.5, 1.0, 1.5, 3.0]) == "0.5–1.5, 3"


# Figures.


def test_a_single_cylinder_star_is_drawn_once(reports):
    from harmbal.reporting.review_plots import review_stars_figure, star_groups

    scene, tree, _ = reports["single"]
    from harmbal.views.stars import with_free_vectors

    stars = with_free_vectors(tree["stars"].ds, tree["orders"].ds)
    free = [k for k in range(1, 13)
            if bool(stars["force_free"].sel(order=k).any() | stars["moment_free"].sel(order=k).any())]
    assert star_groups(stars, free) == [free]  # one arm at 0° for every order
    fig = review_stars_figure(stars)
    strip, diagrams = fig.axes[0], fig.axes[1:]
    arms = [a.get_gid() for a in strip.get_lines() if (a.get_gid() or "").startswith("order")]
    assert arms == [f"order{free[0]}-star-arm-1"]
    # One diagram per free quantity of each order: the single's moment about its own plane is zero.
    assert len(diagrams) == sum(bool(stars[f"{q}_free"].sel(order=k).any()) for k in free for q in ("force", "moment"))
    assert all(ax.get_title().startswith("Force") for ax in diagrams)


def test_distinct_stars_are_each_drawn(reports):
    from harmbal.reporting.review_plots import star_groups

    scene, tree, _ = reports["tractor"]
    stars = tree["stars"].ds
    groups = star_groups(stars, list(range(1, 13)))
    # An inline three: orders 1, 4, 7, 10 share a star, 2, 5, 8, 11 the mirror one, 3, 6, 9, 12 all arms at 0°.
    assert sorted(map(sorted, groups)) == [[1, 4, 7, 10], [2, 5, 8, 11], [3, 6, 9, 12]]


def test_a_negligible_locus_is_not_drawn(reports):
    from harmbal.reporting.plots import locus_figure, time_traces_figure

    scene, tree, _ = reports["tractor"]  # an inline three: its forces cancel but for λ-series orders (negligible)
    time = hb.simulate(scene, samples_per_rev=360)
    level = time.attrs["negligible"] * float(time["force_scale"]) / time.attrs["cylinders"]
    assert 0 < np.abs(time["force"].sel(axis=["y", "z"]).values).max() <= level
    force, moment = locus_figure(time).axes
    assert not force.get_lines() and "negligible" in force.texts[0].get_text()
    assert [line.get_gid() for line in moment.get_lines() if line.get_gid()] == ["moment-locus-before", "moment-origin"]
    traces = time_traces_figure(time).axes
    assert not [line for line in traces[0].get_lines() if line.get_gid()]
    assert len([line for line in traces[1].get_lines() if line.get_gid()]) == 3


def test_the_mechanism_sketch_keeps_the_lever_links_lengths():
    from harmbal.reporting.review_plots import MECHANISM_ANGLES, mechanism_figure

    scene = hb.load_scene(ENGINES / "lever-single.toml")
    lever = scene.levers[0]
    fig = mechanism_figure(scene)
    assert len(fig.axes) == len(MECHANISM_ANGLES)
    for i, ax in enumerate(fig.axes):
        lines = {line.get_gid(): line.get_xydata() for line in ax.get_lines() if line.get_gid()}
        for link, length in (("crank", lever.pin_radius), ("coupler", lever.coupler_length),
                             ("rocker", lever.rocker_length)):
            a, b = lines[f"lever-{lever.label}-{link}-{i}"]
            assert np.hypot(*(a - b)) == pytest.approx(length * 1e3, rel=1e-12)
        cyl = scene.cylinders[0]
        a, b = lines[f"crank-{cyl.label}-{i}"]
        assert np.hypot(*(a - b)) == pytest.approx(cyl.crank_radius * 1e3, rel=1e-12)
        big, small = lines[f"rod-{cyl.label}-{i}"]
        assert np.hypot(*(big - small)) == pytest.approx(cyl.rod_length * 1e3, rel=1e-12)
        # The piston pin runs on the cylinder axis (bank 0: up), offset by the pin offset.
        assert abs(small[0]) == pytest.approx(cyl.offset * 1e3, rel=1e-9)
        assert a[1] == pytest.approx(0.0, abs=1e-12 * cyl.crank_radius * 1e3)  # scale: mm of the crank


def test_the_lever_report_tables_the_frame_force_before_and_after_the_optimal_weight():
    from harmbal.balance.lever import design_lever

    scene = hb.load_scene(ENGINES / "lever-single.toml")
    text = hb.report(hb.analyse(scene))
    section = text[text.index('<section id="lever">'):text.index("</section>", text.index('<section id="lever">'))]
    result = design_lever(scene)
    cells = re.findall(r"<td[^>]*>([^<]*)</td>", section)
    assert f"{result.criterion_start:.5g} N" in cells and f"{result.criterion:.5g} N" in cells
    assert f"{result.weight[0]:.4g} kg" in cells
    # Without the lever: the peak-to-peak of F_y plus that of F_z of the engine without its balancer elements.
    bare = hb.simulate(scene.with_effects(scene.model.effects - {"balancers"}), samples_per_rev=4096)
    force = bare["force"].sel(axis=["y", "z"]).values
    assert f"{float(np.ptp(force, axis=-1).sum()):.5g} N" in cells
    assert 'data-figure="mechanism"' in text


def test_the_spectrum_bars_are_the_free_components(reports):
    from harmbal.reporting.review_plots import review_spectrum_figure

    for key in ("single", "v8"):
        _, tree, _ = reports[key]
        orders = tree["orders"].ds
        sel = _first(orders)
        force, moment = review_spectrum_figure(orders).axes
        for ax, quantity in ((force, "force"), (moment, "moment")):
            entries = ("co", "counter", "roll") if quantity == "moment" else ("co", "counter")
            for j, entry in enumerate(entries):
                bars = next(c for c in ax.collections if c.get_gid() == f"{quantity}-{entry}")
                heights = np.array([path.vertices[:, 1].max() for path in bars.get_paths()])
                k = sel["order"].values[1:]
                if entry == "roll":
                    value, level = sel["moment"].values[1:, 0], float(sel["roll_negligible_level"])
                else:
                    value, level = sel[f"{quantity}_rotating"].values[1:, j], float(sel[f"{quantity}_negligible_level"])
                want = np.where(np.abs(value) > level, np.abs(value), 0.0)
                assert len(heights) == len(k)
                np.testing.assert_allclose(heights, want, rtol=1e-12, atol=0)

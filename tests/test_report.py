"""The HTML report (harmbal.report, `harmbal report`).

Oracles: the datasets the report is made from (numbers parsed back out of the
page's tables and compared with hb.analyse's Datasets), the report of the
same scene made through an archive (byte-identical), and the HTML itself
parsed with the standard library (self-contained: no external resources;
every figure an inline SVG of non-zero size).
"""

from html.parser import HTMLParser
from pathlib import Path

import numpy as np
import pytest

import harmbal as hb
from harmbal.cli import main

ROOT = Path(__file__).resolve().parent.parent
ENGINES = ROOT / "datasets" / "engines"


class _Page(HTMLParser):
    """Tables (rows of cell texts, per section id), figures and every URL-like attribute."""

    def __init__(self):
        super().__init__()
        self.section = None
        self.tables: dict[str, list[list[list[str]]]] = {}
        self.figures: list[tuple[str, dict]] = []
        self.urls: list[str] = []
        self.tags: set[str] = set()
        self._cell = None
        self._figure = None

    def handle_starttag(self, tag, attrs):
        attrs = dict(attrs)
        self.tags.add(tag)
        for key in ("src", "href", "xlink:href"):
            if key in attrs:
                self.urls.append(attrs[key])
        if tag == "section":
            self.section = attrs.get("id")
        elif tag == "table":
            self.tables.setdefault(self.section, []).append([])
        elif tag == "tr":
            self.tables[self.section][-1].append([])
        elif tag in ("td", "th"):
            self._cell = ""
        elif tag == "figure":
            self._figure = attrs.get("data-figure")
        elif tag == "svg" and self._figure is not None:
            self.figures.append((self._figure, attrs))
            self._figure = None

    def handle_endtag(self, tag):
        if tag in ("td", "th") and self._cell is not None:
            self.tables[self.section][-1][-1].append(self._cell)
            self._cell = None

    def handle_data(self, data):
        if self._cell is not None:
            self._cell += data


def _parse(text: str) -> _Page:
    page = _Page()
    page.feed(text)
    return page


@pytest.fixture(scope="module")
def lever_tree():
    return hb.analyse(hb.load_scene(ENGINES / "lever-single.toml"))


@pytest.fixture(scope="module")
def balanced_tree():
    return hb.analyse(hb.load_scene(ENGINES / "inline-3-balanced.toml"))


@pytest.fixture(scope="module")
def lever_html(lever_tree):
    return hb.report(lever_tree)


@pytest.fixture(scope="module")
def balanced_html(balanced_tree):
    return hb.report(balanced_tree)


def _value(cell: str) -> float:
    return 0.0 if cell.strip() == "0" else float(cell.split()[0])


@pytest.mark.parametrize("which", ["lever", "balanced"])
def test_report_from_an_archive_equals_the_report_from_its_scene(tmp_path, which, lever_tree, balanced_tree,
                                                                 lever_html, balanced_html):
    tree, direct = (lever_tree, lever_html) if which == "lever" else (balanced_tree, balanced_html)
    hb.save(tree, tmp_path / "a.nc")
    assert hb.report(hb.open_archive(tmp_path / "a.nc")) == direct


def test_self_contained_and_every_figure_inline(balanced_html, lever_html):
    for text, expected in ((balanced_html, {"spectrum", "stars", "traces", "locus", "phasing"}),
                           (lever_html, {"spectrum", "stars", "traces", "locus", "lever"})):
        page = _parse(text)
        assert not ({"script", "link", "img", "iframe", "object"} & page.tags)
        assert all(not url.startswith(("http:", "https:", "//", "data:")) for url in page.urls), page.urls
        assert {name for name, _ in page.figures} == expected
        for name, attrs in page.figures:
            width, height = (float(attrs[k].rstrip("pt")) for k in ("width", "height"))
            assert width > 0 and height > 0, name
        assert "@media print" in text and "break-inside: avoid" in text


def test_summary_names_the_model_and_sampling(lever_tree, lever_html):
    rows = {r[0]: r[1] for r in _parse(lever_html).tables["summary"][0][1:]}
    time = lever_tree["time"].ds
    assert rows["engine"] == "lever-single"
    assert rows["effects simulated"] == time.attrs["effects"]
    assert rows["sampling"].startswith(f"{time.attrs['samples_per_rev']} samples per revolution")
    assert rows["harmbal version"] == hb.__version__


def test_order_tables_equal_the_orders_dataset(balanced_tree, balanced_html):
    orders = balanced_tree["orders"].ds
    tables = _parse(balanced_html).tables["spectrum"]
    for table, name in zip(tables, ("force", "moment")):
        values = np.abs(orders[name].values)
        rotating = np.abs(orders[f"{name}_rotating"].values)
        scale = float(orders[f"{name}_scale"])
        for row in table[1:]:
            k = int(row[0])
            expected = list(values[k]) + list(rotating[k])
            printed = [_value(c) for c in row[1::2]]
            for got, want in zip(printed, expected):
                if got == 0.0:
                    assert want <= orders.attrs["balanced_rtol"] * scale
                else:
                    assert got == pytest.approx(want, rel=1e-4)


def test_verification_and_joint_tables_equal_their_datasets(balanced_tree, lever_tree, balanced_html, lever_html):
    check = balanced_tree["verify"].ds
    table = _parse(balanced_html).tables["balancers"][-1]
    assert len(table) - 1 == int(check["targeted"].sum()) * check.sizes["order"]
    assert all(row[-1] == "pass" for row in table[1:])
    joints = lever_tree["joints"].ds
    rows = _parse(lever_html).tables["lever"][0][1:]
    assert [r[0] for r in rows] == list(joints["joint"].values)
    for row, peak in zip(rows, joints["joint_force_peak"].values):
        assert _value(row[2]) == pytest.approx(peak, rel=1e-4)


def test_balancer_table_lists_every_unbalance(balanced_html):
    scene = hb.load_scene(ENGINES / "inline-3-balanced.toml")
    rows = _parse(balanced_html).tables["balancers"][0][1:]
    expected = [(s.label, u.unbalance * 1e3) for s in scene.shafts for u in s.unbalances]
    assert [(r[0], _value(r[3])) for r in rows] == [(label, pytest.approx(u, rel=1e-4)) for label, u in expected]


def test_log_option_changes_only_the_spectrum(balanced_tree, balanced_html):
    linear, log = balanced_html, hb.report(balanced_tree, log=True)
    assert linear != log
    assert linear.split('id="stars"')[1] == log.split('id="stars"')[1]


def test_cli_report(tmp_path, capsys):
    out = tmp_path / "r.html"
    assert main(["report", str(ENGINES / "v-twin-90.toml"), "-o", str(out)]) == 0
    assert out.read_text(encoding="utf-8").startswith("<!DOCTYPE html>")
    archive = tmp_path / "a.nc"
    assert main(["run", str(ENGINES / "v-twin-90.toml"), "-o", str(archive)]) == 0
    again = tmp_path / "again.html"
    assert main(["report", str(archive), "-o", str(again)]) == 0
    assert again.read_text(encoding="utf-8") == out.read_text(encoding="utf-8")


@pytest.mark.parametrize("output", ["r.txt", "missing/r.html"])
def test_cli_report_bad_output_exits_2_and_writes_nothing(tmp_path, capsys, output):
    assert main(["report", str(ENGINES / "v-twin-90.toml"), "-o", str(tmp_path / output)]) == 2
    assert "harmbal: error:" in capsys.readouterr().err
    assert list(tmp_path.iterdir()) == []


def test_cli_report_css_is_added_after_the_built_in_style(tmp_path):
    css = tmp_path / "house.css"
    css.write_text("body { font-family: 'House Sans'; }\n", encoding="utf-8")
    out = tmp_path / "r.html"
    assert main(["report", str(ENGINES / "v-twin-90.toml"), "-o", str(out), "--css", str(css)]) == 0
    style = out.read_text(encoding="utf-8").split("<style>")[1].split("</style>")[0]
    assert style.endswith("body { font-family: 'House Sans'; }\n")
    assert style.index("system-ui") < style.index("House Sans")


@pytest.mark.parametrize("content", [None, "</style><script>alert(1)</script>"])
def test_cli_report_bad_css_exits_2_and_writes_nothing(tmp_path, capsys, content):
    css = tmp_path / "house.css"
    if content is not None:
        css.write_text(content, encoding="utf-8")
    out = tmp_path / "out"
    out.mkdir()
    assert main(["report", str(ENGINES / "v-twin-90.toml"), "-o", str(out / "r.html"), "--css", str(css)]) == 2
    assert "house.css" in capsys.readouterr().err
    assert list(out.iterdir()) == []


def test_a_speed_sweep_gets_campbell_maps_whose_colours_are_its_order_amplitudes():
    from harmbal.reporting.sweep_plots import campbell_figure
    from harmbal.studies.sweep import order_amplitude

    scene = hb.load_scene(ENGINES / "v-twin-90.toml")
    swept = hb.analyse(scene.with_speeds(np.linspace(200.0, 900.0, 8)))
    names = {name for name, _ in _parse(hb.report(swept)).figures}
    assert {"campbell-force", "campbell-moment"} <= names
    two = hb.analyse(scene.with_speeds([300.0, 600.0]))
    assert not {n for n, _ in _parse(hb.report(two)).figures} & {"campbell-force", "campbell-moment"}
    # The map's cells are the order amplitudes per (speed, order), floored at 1e-6 of the largest.
    orders = swept["orders"].ds
    mesh = campbell_figure(orders, name="moment").axes[0].collections[0]
    amplitude = order_amplitude(orders["moment"].transpose("speed", "order", "axis").values)
    expected = np.maximum(amplitude, amplitude.max() * 1e-6).T
    np.testing.assert_allclose(np.asarray(mesh.get_array()).reshape(expected.shape), expected, rtol=1e-15)
